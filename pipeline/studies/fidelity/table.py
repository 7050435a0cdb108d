"""The fidelity table: every rung's steady values, fit and cost against the reference and against Table 2.

The reference at each angle is the ensemble of the ``seed`` axis (mean over seeds, standard error =
standard deviation / sqrt(seeds)); with one seed, that run (its windows' standard error). A rung's
*shift* is its value minus the reference's, with both errors combined (a run's error is the larger of its
windows' standard error and the seeds' scatter per run); ``error`` is the relative shift
of the steady shear stress ratio, the quantity every preset must get right. For the seed axis each
seed's shift is its scatter about the ensemble: the statistical error of one run. ``recommend`` prices a
target error on each quantity, setting by setting, and names the cheapest.
"""

from __future__ import annotations

import numpy as np

import model

from .. import welch
from . import combinations
from .recommend import recommend, values_of

STEADY = ("mu", "A_norm", "A_aligned", "phi_central", "phi_gap")
FITTED = ("C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")


def reference(summaries: list[dict]) -> dict:
    """Ensemble mean and standard error of the steady values and fitted parameters over ``summaries``."""
    out = {"runs": len(summaries), "steady": {}, "fit": {}, "fit_sd": {}}
    for name in STEADY:
        values = np.array([s["steady"][name]["mean"] for s in summaries])
        sd = float(np.std(values, ddof=1)) if len(values) > 1 else None
        se = sd / np.sqrt(len(values)) if sd is not None else summaries[0]["steady"][name]["standard_error"]
        out["steady"][name] = {"mean": float(values.mean()), "standard_error": float(se), "sd_per_run": sd}
    fits = [s["fit"]["values"] for s in summaries if s.get("fit") and "values" in s["fit"]]
    for name in FITTED if fits else ():
        values = np.array([f[name] for f in fits if name in f])
        if len(values) == 0:
            continue
        sd = float(np.std(values, ddof=1)) if len(values) > 1 else float("nan")
        out["fit"][name] = {"mean": float(values.mean()), "standard_error": sd / np.sqrt(len(values))}
        out["fit_sd"][name] = sd
    return out


def row(summary: dict, rung_axis: str, rung_label: str, ref: dict) -> dict:
    steady, out = summary["steady"], {}
    for name in STEADY:
        shift = steady[name]["mean"] - ref["steady"][name]["mean"]
        # one run's error: its windows' standard error, or the seeds' scatter per run where that is larger
        # (seeds differ by more than the noise within a run shows)
        own = max(steady[name]["standard_error"], ref["steady"][name].get("sd_per_run") or 0.0)
        se = float(np.hypot(own, ref["steady"][name]["standard_error"]))
        out[name] = {**steady[name], "shift": shift, "shift_se": se}
    mu = ref["steady"]["mu"]["mean"]
    fit = summary.get("fit") or {}
    paper = model.PAPER
    return {"axis": rung_axis, "setting": rung_label, "theta_deg": summary["theta_deg"], "folder": summary["folder"],
            "name": summary["name"], "cost": summary["cost"], "steady": out,
            "bulk_over_nominal": summary["bulk_over_nominal"],
            "error": abs(out["mu"]["shift"]) / mu, "error_se": out["mu"]["shift_se"] / mu,
            "fit": fit.get("values"), "fit_se": fit.get("standard_errors"), "fit_misfit": fit.get("misfit"),
            "fit_vs_table2": {n: v / getattr(paper, n) - 1 for n, v in (fit.get("values") or {}).items()},
            "fit_vs_reference": {n: v - ref["fit"][n]["mean"] for n, v in (fit.get("values") or {}).items()
                                 if n in ref["fit"]},
            "rmse_tau12": {k: v["tau12"] for k, v in (fit.get("rmse") or {}).items()}}


def ensemble_against_larger(entries: list[tuple], theta: float, small_axis: str = "small_cell_seed",
                            ref_axis: str = "seed") -> dict:
    """Several seeds of the small cell against the reference cell at equal CPU time (θ = ``theta``).

    For μ and each fitted parameter: the small cell's bias (its seeds' mean minus the reference seeds' mean,
    ± combined standard error) and each setting's scatter per run (standard deviation over its seeds). At a
    budget of one reference run's CPU time, the small cell's ensemble has the expected error
    sqrt(bias^2 + sd_small^2 / k), k = small runs in that budget, against the reference's sd_ref: the smaller
    one wins. The bias is measured, so it carries its own error (reported); an unresolved bias counts as its
    measured value. Empty when either setting has fewer than two seeds."""
    small = [s for a, _, s in entries if a == small_axis and s["theta_deg"] == theta]
    ref = [s for a, _, s in entries if a == ref_axis and s["theta_deg"] == theta]
    if len(small) < 2 or len(ref) < 2:
        return {}
    cpu_small = float(np.mean([s["cost"]["cpu_hours"] for s in small]))
    cpu_ref = float(np.mean([s["cost"]["cpu_hours"] for s in ref]))
    k = cpu_ref / cpu_small

    out = {"small_runs": len(small), "reference_runs": len(ref), "cpu_hours_small": cpu_small,
           "cpu_hours_reference": cpu_ref, "small_runs_per_reference_run": k, "quantities": {}}
    for name in ("mu", *FITTED):
        a, b = values_of(small, name), values_of(ref, name)
        if len(a) < 2 or len(b) < 2:
            continue
        sd_a, sd_b = float(np.std(a, ddof=1)), float(np.std(b, ddof=1))
        bias = float(a.mean() - b.mean())
        bias_se = float(np.hypot(sd_a / np.sqrt(len(a)), sd_b / np.sqrt(len(b))))
        ensemble = float(np.sqrt(bias**2 + sd_a**2 / k))
        out["quantities"][name] = {"bias": bias, "bias_se": bias_se, "sd_small": sd_a, "sd_reference": sd_b,
                                   "error_small_ensemble": ensemble, "error_reference_run": sd_b,
                                   "better": "small-cell ensemble" if ensemble < sd_b else "reference cell"}
    return out


TRANSFORMS = {"linear": lambda x: x, "inverse": lambda x: 1.0 / x}


def extrapolate(entries: list[tuple], theta: float, keys: list[str], transform: str, target: float,
                ref_sd: dict, names: tuple[str, ...] = ("mu", *FITTED)) -> dict:
    """A weighted straight line through the runs that differ from the preset only in ``keys`` (and the seed),
    in f(x) of the first key (``transform``: linear or inverse, e.g. a bias linear in 1/H), evaluated at
    the paper's value ``target``: for μ and each fitted parameter, the points (runs at one x pooled: their
    mean ± s/sqrt(n), s the largest of their SD, one run's own error and the seeds' scatter per run ``ref_sd``),
    intercept,
    slope, the value at the target with its standard error from the line's covariance, and χ²/dof when
    three or more x values leave the line testable. Empty when fewer than two x values exist."""
    f = TRANSFORMS[transform]
    allowed = set(keys) | {"seed"}
    runs = [s for _, _, s in entries if s["theta_deg"] == theta and set(s.get("overrides", {})) <= allowed]
    by_x = {}
    for s in {(s["folder"], s["name"]): s for s in runs}.values():
        by_x.setdefault(float(s["spec"][keys[0]]), []).append(s)
    if len(by_x) < 2:
        return {}
    out = {"keys": keys, "transform": transform, "target": target, "quantities": {}}
    for name in names:
        xs, ys, ses, ns = [], [], [], []
        for x, group in sorted(by_x.items()):
            if name == "mu":
                vals = [g["steady"]["mu"]["mean"] for g in group]
                own = max(g["steady"]["mu"]["standard_error"] for g in group)
            else:
                vals = [g["fit"]["values"][name] for g in group if g.get("fit") and name in g["fit"].get("values", {})]
                own = 0.0
            if not vals:
                continue
            # one run's scatter: the larger of the group's own (three runs or more), one run's windows and the
            # reference seeds' (a scatter estimated from a few runs is often far too small: the line's error
            # would then undercover)
            scatter = np.std(vals, ddof=1) if len(vals) > 2 else 0.0
            se = max(scatter, own, ref_sd.get(name) or 0.0) / np.sqrt(len(vals))
            if not np.isfinite(se) or se <= 0:
                continue
            xs.append(x), ys.append(float(np.mean(vals))), ses.append(float(se)), ns.append(len(vals))
        if len(xs) < 2:
            continue
        design = np.column_stack([np.ones(len(xs)), [f(x) for x in xs]])
        w = 1 / np.asarray(ses) ** 2
        cov = np.linalg.inv(design.T @ (design * w[:, None]))
        coef = cov @ design.T @ (w * np.asarray(ys))
        at = np.array([1.0, f(target)])
        chi2 = float(np.sum(w * (np.asarray(ys) - design @ coef) ** 2))
        dof = len(xs) - 2
        out["quantities"][name] = {
            "points": [{"x": x, "mean": y, "standard_error": e, "runs": n} for x, y, e, n in zip(xs, ys, ses, ns,
                                                                                                  strict=True)],
            "intercept": float(coef[0]), "slope": float(coef[1]), "at_target": float(at @ coef),
            "at_target_se": float(np.sqrt(at @ cov @ at)), "chi2_per_dof": chi2 / dof if dof else None}
    return out


def pareto(candidates: list[dict]) -> list[str]:
    """The settings no other beats in both CPU time per run and |bias| of the steady τ12/p (the Pareto
    front), cheapest first; ``candidates`` are ``recommend``'s for μ, the preset (no bias by definition)
    left out."""
    order = sorted((c for c in candidates if c["setting"] != "preset"),
                   key=lambda c: (c["cpu_hours_per_run"], abs(c["bias"])))
    front, best = [], np.inf
    for c in order:
        if abs(c["bias"]) < best:
            front.append(c["setting"])
            best = abs(c["bias"])
    return front


def combo_name(k: int) -> str:
    return f"K{k + 1}"


def with_combinations(entries: list[tuple], found: dict) -> list[tuple]:
    """``entries`` with each run's fit extended by the ln of each combination (``K1``, ``K2``, ...)."""
    if not found:
        return entries
    out = []
    for axis, label, s in entries:
        fit = s.get("fit") or {}
        if fit.get("values"):
            extra = {combo_name(k): combinations.value(s, c) for k, c in enumerate(found["combinations"])}
            fit = {**fit, "values": {**fit["values"], **{k: v for k, v in extra.items() if v is not None}}}
        out.append((axis, label, {**s, "fit": fit}))
    return out


def own_errors(top: list[dict], name: str) -> list:
    """The top rung's seeds' own errors of ``name``: μ's from their windows, a parameter's from their own fits."""
    return [s["steady"]["mu"]["standard_error"] if name == "mu"
            else ((s.get("fit") or {}).get("standard_errors") or {}).get(name) for s in top]


def top_check(top: list[dict], extrapolated: dict, checks: list[str], label: str) -> dict:
    """The top rung (the paper's cell) at one angle against each ``checks`` axis's extrapolation there: for μ and
    each fitted parameter, the top rung's value (its seeds' mean ± SD/sqrt(n), never below their own errors'
    ``welch.own_floor``; one run: its windows' standard error for μ, its own fit's for a parameter, which leave a
    seed's scatter out), the extrapolated value, the difference in combined standard errors (z) and whether it
    lies within the two-sided 95 % quantile of Student's t, its degrees of freedom Welch's (the top rung's from
    its n - 1 seeds, or its windows for one run's μ; the line's taken as many)."""
    ref = reference(top)
    out = {"data_set": label, "runs": len(top), "checks": {}}
    for axis in checks:
        line = extrapolated.get(axis)
        if not line:
            continue
        rows = {}
        for name, q in line["quantities"].items():
            several = len(top) > 1
            if name == "mu":
                value, se = ref["steady"]["mu"]["mean"], ref["steady"]["mu"]["standard_error"]
                dof = len(top) - 1 if several else len(top[0]["steady"]["mu"].get("windows", ())) - 1
            elif name in ref["fit"]:
                value, se = ref["fit"][name]["mean"], ref["fit"][name]["standard_error"]  # NaN from one run
                dof = len(top) - 1 if several else np.inf  # one run: its fit's error, from thousands of samples
            else:
                continue
            floor = welch.own_floor(own_errors(top, name))  # one run: its own error
            se = max(se, floor) if np.isfinite(se) else floor
            if not np.isfinite(se):
                continue
            combined = float(np.hypot(se, q["at_target_se"]))
            critical = welch.critical(se, dof, q["at_target_se"], np.inf)
            z = (value - q["at_target"]) / combined
            rows[name] = {"paper_cell": value, "paper_cell_se": se, "extrapolated": q["at_target"],
                          "extrapolated_se": q["at_target_se"], "z": float(z), "critical": critical,
                          "within_95": bool(abs(z) <= critical)}
        out["checks"][axis] = rows
    return out


def build(entries: list[tuple], seed_axis: str = "seed", extrapolations: dict | None = None,
          node_cores: int = 32, top: tuple[str, list[dict], list[str]] | None = None) -> dict:
    """``entries``: (axis, setting label, summary) for every rung with a summary. Rows per angle, the
    references, the cheapest setting for each target error (``recommend``; cluster nodes of
    ``node_cores``), the Pareto front of the settings at each angle, the small cells against the reference cell and the
    ``extrapolations`` ({axis: {keys, transform, paper}}) to the paper's values; ``top`` (its data set's label,
    its runs' summaries, the axes it checks): the paper's cell against those axes' extrapolations."""
    thetas = sorted({s["theta_deg"] for _, _, s in entries}, reverse=True)
    out = {"references": {}, "recommendation": {}, "rows": [], "pareto": {}, "ensembles": {}, "extrapolations": {},
           "combinations": {}, "paper_definitions": {}, "top": {}, "table2": model.PAPER.to_dict()}
    for theta in thetas:
        at = [(a, label, s) for a, label, s in entries if s["theta_deg"] == theta]
        seeds = {s["folder"]: s for a, _, s in at if a == seed_axis}
        base = list(seeds.values()) or [s for _, _, s in at if not s["overrides"]][:1] or [at[0][2]]
        ref = reference(base)
        out["references"][f"{theta:g}"] = ref
        out["recommendation"][f"{theta:g}"] = recommend(entries, theta, ref, node_cores=node_cores)
        out["rows"] += [row(s, a, label, ref) for a, label, s in at]
        mu = out["recommendation"][f"{theta:g}"]["quantities"].get("mu")
        out["pareto"][f"{theta:g}"] = pareto(mu["candidates"]) if mu else []
        if ensemble := ensemble_against_larger(entries, theta):
            out["ensembles"][f"{theta:g}"] = ensemble
        ref_sd = {"mu": ref["steady"]["mu"].get("sd_per_run"), **ref["fit_sd"]}
        in_paper_terms = [{**s, "fit": s["fit_paper_definitions"]} for s in base if s.get("fit_paper_definitions")]
        if found_paper := combinations.find(in_paper_terms, FITTED):
            out["paper_definitions"][f"{theta:g}"] = {"reference": reference(in_paper_terms), **found_paper}
        found = combinations.find(base, FITTED)
        tagged = with_combinations(entries, found)
        names = ("mu", *FITTED, *(combo_name(k) for k in range(len(found.get("combinations", [])))))
        if found:
            out["combinations"][f"{theta:g}"] = found
            ref_sd.update({combo_name(k): c["sd_per_run"] for k, c in enumerate(found["combinations"])})
        for axis, how in (extrapolations or {}).items():
            if line := extrapolate(tagged, theta, how["keys"], how["transform"], how["paper"], ref_sd, names):
                out["extrapolations"].setdefault(f"{theta:g}", {})[axis] = line
        if top and (at_top := [s for s in top[1] if s["theta_deg"] == theta]):
            out["top"][f"{theta:g}"] = top_check(at_top, out["extrapolations"].get(f"{theta:g}", {}), top[2], top[0])
    return out
