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

from ...calibration.identifiability import combination
from . import combinations
from .recommend import MAX_RUNS, recommend, values_of

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
    mean, ± SD/sqrt(n), or one run's error taken as the seeds' scatter per run ``ref_sd``), intercept,
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
            sd = ref_sd.get(name)
            se = (np.std(vals, ddof=1) / np.sqrt(len(vals)) if len(vals) > 2
                  else max(own, sd or 0.0) / np.sqrt(len(vals)))
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


def build(entries: list[tuple], seed_axis: str = "seed", extrapolations: dict | None = None,
          node_cores: int = 32) -> dict:
    """``entries``: (axis, setting label, summary) for every rung with a summary. Rows per angle, the
    references, the cheapest setting for each target error (``recommend``; cluster nodes of
    ``node_cores``), the Pareto front of the settings at each angle, the small cells against the reference cell and the
    ``extrapolations`` ({axis: {keys, transform, paper}}) to the paper's values."""
    thetas = sorted({s["theta_deg"] for _, _, s in entries}, reverse=True)
    out = {"references": {}, "recommendation": {}, "rows": [], "pareto": {}, "ensembles": {}, "extrapolations": {},
           "combinations": {}, "paper_definitions": {}}
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
    return out


def markdown(table: dict) -> str:
    lines = ["# The fidelity ladder", "",
             "Each row: one setting (an axis of `config/fidelity.toml` moved from the `reduced` preset). μ is the "
             "steady τ:D'/(p|D'|) (τ12/p along the shear), over the last 0.3 strain before each change of direction; "
             "*shift* is the row minus the reference (the seeds' ensemble at that angle), ± both errors combined, a "
             "run's error being the larger of its windows' standard error and the seeds' scatter per run. "
             "The fit is the global fit on that run alone (± from its own noise). CPU-hours of the DEM loop, "
             "one thread.", ""]
    for theta, ref in table["references"].items():
        mu = ref["steady"]["mu"]
        lines += [f"## θ = {theta}°: reference {ref['runs']} run(s), μ = {mu['mean']:.4f} ± {mu['standard_error']:.4f}",
                  "", "| axis | setting | CPU-h | steps/s | grains | μ | shift of μ | |A| | Φ central | Φ gap | "
                  "band/nominal | C | n | m | b1 | b2 | RMSE τ12 own / Table 2 |", "|" + "---|" * 17]
        shown = set()
        for r in table["rows"]:
            if f"{r['theta_deg']:g}" != theta or (r["folder"], r["name"]) in shown:
                continue  # the preset's own run sits on every axis: shown once, on the first
            shown.add((r["folder"], r["name"]))
            s, c = r["steady"], r["cost"]
            fit = r["fit"] or {}
            params = " | ".join(f"{fit[n]:+.3g}" if n in fit else "" for n in ("C", "n", "m", "b1", "b2"))
            rmse = r["rmse_tau12"]
            lines.append(
                f"| {r['axis']} | {r['setting']} | {c['cpu_hours']:.2f} | {c['steps_per_second'] or 0:.0f} | "
                f"{c['grains']} | "
                f"{s['mu']['mean']:.4f} ± {s['mu']['standard_error']:.4f} | {s['mu']['shift']:+.4f} ± "
                f"{s['mu']['shift_se']:.4f} | {s['A_norm']['mean']:.4f} | {s['phi_central']['mean']:.3f} | "
                f"{s['phi_gap']['mean']:.3f} | {r['bulk_over_nominal']:.2f} | {params} | "
                + (f"{rmse.get('own fit', np.nan):.3f} / {rmse.get('Table 2', np.nan):.3f}" if rmse else "") + " |")
        if rec := table.get("recommendation", {}).get(theta):
            lines += recommendation_lines(rec, table.get("extrapolations", {}).get(theta, {}))
        for axis, line in table.get("extrapolations", {}).get(theta, {}).items():
            lines += [f"Extrapolation along `{axis}` to the paper's {line['keys'][0]} = {line['target']:g} "
                      f"(a weighted line in {'1/' if line['transform'] == 'inverse' else ''}{line['keys'][0]}; "
                      "runs at one value pooled):", "",
                      "| quantity | points (value: mean ± se, runs) | slope | at the paper's value | χ²/dof | "
                      "Table 2 |", "|---|---|---|---|---|---|"]
            for name, q in line["quantities"].items():
                if name not in ("mu", *FITTED):
                    continue  # the combinations have a table of their own
                pts = "; ".join(f"{p['x']:g}: {p['mean']:.3g} ± {p['standard_error']:.2g} ({p['runs']})"
                                for p in q["points"])
                chi = f"{q['chi2_per_dof']:.2f}" if q["chi2_per_dof"] is not None else "— (two values: untested)"
                paper = f"{getattr(model.PAPER, name):.3g}" if hasattr(model.PAPER, name) else ""
                lines.append(f"| {name} | {pts} | {q['slope']:+.3g} | {q['at_target']:.3g} ± {q['at_target_se']:.2g} "
                             f"| {chi} | {paper} |")
            lines.append("")
        if found := table.get("combinations", {}).get(theta):
            lines += combination_lines(found, table.get("extrapolations", {}).get(theta, {}))
        if paper := table.get("paper_definitions", {}).get(theta):
            lines += paper_definition_lines(paper)
        ens = table.get("ensembles", {}).get(theta)
        if ens:
            lines += [f"Small cells against the reference cell at equal CPU time: {ens['small_runs']} seeds of "
                      f"the small cell ({ens['cpu_hours_small']:.2f} CPU-h each) against {ens['reference_runs']} of "
                      f"the reference ({ens['cpu_hours_reference']:.2f} CPU-h each); one reference run's time buys "
                      f"{ens['small_runs_per_reference_run']:.1f} small runs. Expected error = sqrt(bias² + sd²/k).",
                      "", "| quantity | small-cell bias | sd per run, small / reference | error: small ensemble / "
                      "one reference run | better |", "|---|---|---|---|---|"]
            for name, q in ens["quantities"].items():
                lines.append(f"| {name} | {q['bias']:+.3g} ± {q['bias_se']:.2g} | {q['sd_small']:.3g} / "
                             f"{q['sd_reference']:.3g} | {q['error_small_ensemble']:.3g} / "
                             f"{q['error_reference_run']:.3g} | {q['better']} |")
            lines.append("")
    return "\n".join(lines) + "\n"


def _cost(c: dict, cores: int) -> str:
    if not c["runs"]:
        return f"not met: {c['why']}"
    return (f"{c['runs']} run(s), {c['cpu_hours']:.1f} CPU-h (wall {c['wall_hours_here']:.1f} h here, "
            f"{c['wall_hours_node']:.1f} h on {cores} cores)")


def recommendation_lines(rec: dict, extrapolations: dict) -> list[str]:
    """The recommendation as Markdown: per quantity and target, the cheapest setting and the preset's own
    cost, and how far the reference sits from the paper's setting along each extrapolated axis."""
    if not rec["quantities"]:
        return []
    levels, cores = [f"{x:g}" for x in rec["levels"]], rec["node_cores"]
    lines = ["", f"**The cheapest setting for a target error** against the reference (expected error "
             f"sqrt(bias² + its variance + SD²/k) of the mean of k runs, at most {MAX_RUNS}; wall time here "
             f"with {rec['jobs_here']} runs side by side and on a node of {cores} cores, one run per core at "
             "this machine's rate). The last column is the reference's distance from the paper's setting where "
             "the ladder extrapolates: it is not in the errors, and no setting here removes it.", "",
             "| quantity | reference (SD per run) | " + " | ".join(
                 f"±{float(x):.0%}: cheapest | ±{float(x):.0%}: the preset" for x in levels)
             + " | paper's setting − reference |", "|" + "---|" * (3 + 2 * len(levels))]
    for name, q in rec["quantities"].items():
        preset = next((c for c in q["candidates"] if c["setting"] == "preset"), None)
        cells = []
        for x in levels:
            best = q["cheapest"][x]
            cells += [f"`{best['setting']}`: {_cost(best, cores)}" if best else "none",
                      _cost(preset["levels"][x], cores) if preset else ""]
        away = "; ".join(
            f"{axis}: {e['quantities'][name]['at_target'] - q['reference']:+.3g} ± "
            f"{np.hypot(e['quantities'][name]['at_target_se'], q['reference_se']):.2g}"
            + (" (untested)" if e["quantities"][name]["chi2_per_dof"] is None else "")
            for axis, e in extrapolations.items() if name in e["quantities"])
        lines.append(f"| {name} | {q['reference']:.3g} ± {q['reference_se']:.2g} ({q['sd_per_run']:.2g}) | "
                     + " | ".join(cells) + f" | {away} |")
    return [*lines, ""]


def combination_lines(found: dict, extrapolations: dict) -> list[str]:
    """What one reversal fixes, as Markdown: each combination's scatter per run, the reference's value and
    where each extrapolation carries it, as ratios to Table 2's value of the same product."""
    def ratio(log_value: float, log_se: float, paper: float) -> str:
        return f"×{np.exp(log_value - paper):.2f} ± {log_se:.0%}"

    lines = [f"**What one reversal fixes**: products ∏|θ|^v of the fitted parameters of one sign, the "
             f"eigen-directions of the {found['seeds']} seeds' scatter in ln|θ|, best fixed first (scatter per run "
             "measured out of sample, leaving each seed out; in-sample beside it). Each value is our product "
             "over Table 2's value of it (± the relative standard error).", "",
             "| combination | scatter per run (in sample) | reference / Table 2 |" + "".join(
                 f" along {axis}, at {e['keys'][0]} = {e['target']:g} |" for axis, e in extrapolations.items()),
             "|" + "---|" * (3 + len(extrapolations))]
    for k, c in enumerate(found["combinations"]):
        cells = []
        for e in extrapolations.values():
            q = e["quantities"].get(combo_name(k))
            cells.append("" if not q else ratio(q["at_target"], q["at_target_se"], c["table2"])
                         + (" (untested)" if q["chi2_per_dof"] is None else ""))
        lines.append(f"| {combination(c['direction'])} | {c['sd_per_run']:.1%} ({c['in_sample_sd']:.1%}) | "
                     f"{ratio(c['mean'], c['standard_error'], c['table2'])} |" + "".join(f" {x} |" for x in cells))
    return [*lines, ""]


def paper_definition_lines(paper: dict) -> list[str]:
    """The reference seeds' fits in the definitions the paper's numbers match, against Table 2: each
    parameter, then the combinations."""
    fit = paper["reference"]["fit"]
    lines = [f"**In the paper's definitions** (nominal strain, Φ of the gap; the same {paper['seeds']} seeds "
             "refitted): each parameter's ensemble mean against Table 2, in the seeds' standard errors, then "
             "the products the seeds' fits fix in these terms.", "",
             "| | " + " | ".join(fit) + " |", "|" + "---|" * (len(fit) + 1),
             "| seeds' mean ± se | " + " | ".join(f"{q['mean']:.3g} ± {q['standard_error']:.2g}"
                                                    for q in fit.values()) + " |",
             "| Table 2 | " + " | ".join(f"{getattr(model.PAPER, n):.3g}" for n in fit) + " |",
             "| (mean − Table 2) / se | " + " | ".join(
                 f"{(q['mean'] - getattr(model.PAPER, n)) / q['standard_error']:+.1f}" if q["standard_error"] > 0
                 else "" for n, q in fit.items()) + " |", ""]
    return lines + combination_lines(paper, {})[2:]
