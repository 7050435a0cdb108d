"""``make models``: every fabric law (``model.params.VARIANTS``) fitted as ``make fit`` fits, and judged by the runs
it was not fitted on.

``python -m pipeline.comparison.models [--preset P] [--engine E] [--set K=V] [--across P[:E]|none ...] [--out DIR]``.
For each variant, the global fit (``calibration.global_fit``: the same definitions, noise model and weights as
``make fit``; the dilatancy is not fitted, Phi is not scored) on

- every run of the default protocol: in-sample misfit, AIC and BIC, parameters with their 68 % intervals from the
  noise, and whether the variant's own reversal runs;
- ``angles``: the reversal and 30, 60, 90 only, predicting 120, 150 and Fig. 7's turns at 0.1 and 0.2;
- ``without <theta>``: every angle but one, predicting that one (over all six);
- ``across``: every run of another data set, predicting this one's (and this one's predicting the other's).

A held-out run is never in the fit nor in the noise model that weighs it: the noise is measured on the training
runs and scales the held-out residuals. Per held-out run and component: the RMS error over the cycle in units of the
run's noise and per the DEM's steady value. Writes ``models.json``, ``models.md``, ``models.h5`` (the curves
``figures.models`` draws) and ``params-<variant>.json`` in ``results/<data set>/models/``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import model

from .. import io, schema
from ..calibration import covariance, global_fit
from ..calibration.definitions import own_reversal
from ..calibration.fit_cycle import FitCycle
from ..calibration.noise import COMPONENTS
from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..dataset.derived import PAPER_DEFINITIONS
from ..dataset.lookup import every_seed
from ..errors import CalibrationError
from ..paths import preset_output
from . import metrics

#: the angles the ``angles`` split fits (the reversal among them); it predicts the others and Fig. 7's turns
TRAIN_ANGLES = (180.0, 30.0, 60.0, 90.0)
#: a held-out difference "beyond the noise": the drop in chi^2 over this many standard deviations of what the noise
#: alone makes of it
BEYOND_NOISE_Z = 2.0
#: strain after a reversal over which the figure follows the jump
JUMP_SPAN = 0.05


@dataclass(frozen=True)
class Split:
    """A fit on the runs ``train`` (indices) judged on the runs ``test``."""

    name: str
    train: tuple[int, ...]
    test: tuple[int, ...]


def protocol(run) -> str:
    """``theta`` or ``theta@rotate_at`` (Fig. 7's turns), for tables."""
    label = f"{run.theta_deg:g}"
    return label if run.default_rotation else f"{label}@{run.spec.rotate_at_strain:g}"


def splits(runs: list) -> list[Split]:
    """``angles`` and one ``without <theta>`` per angle of the default protocol, each where it has runs to fit and
    runs to predict (a data set of the training angles alone has no ``angles`` split, one angle no split at all);
    no split lets a test run train."""
    default = [i for i, r in enumerate(runs) if r.default_rotation]
    train = tuple(i for i in default if runs[i].theta_deg in TRAIN_ANGLES)
    out = [Split("angles", train, tuple(i for i in range(len(runs)) if i not in train))]
    for theta in sorted({runs[i].theta_deg for i in default}, reverse=True):
        left = tuple(i for i in default if runs[i].theta_deg == theta)
        out.append(Split(f"without {theta:g}", tuple(i for i in default if i not in left), left))
    for s in out:
        if set(s.train) & set(s.test):
            raise CalibrationError(f"split {s.name}: a held-out run is among the fitted ones")
    return [s for s in out if s.train and s.test]


def fit(runs: list, variant: str, stress: str, weight: str) -> tuple[global_fit.GlobalFit, object]:
    """The global fit of ``variant`` on ``runs`` from Table 2 (``global_fit.start_of``), and the noise model
    measured on those runs alone."""
    data, noise = global_fit.prepare(runs, 0.0, stress, weight)
    return fit_prepared(data, noise, variant), noise


def fit_prepared(data, noise, variant: str) -> global_fit.GlobalFit:
    """``fit`` on data ``global_fit.prepare`` has read already."""
    return global_fit.refine(data, global_fit.start_of(variant), global_fit.free_names(variant), noise=noise)


def steady_scale(cycle: FitCycle, quantity: np.ndarray) -> float:
    """The DEM's steady value of a quantity: the modulus of its shear part (the 12 and 32 components) over the
    cycle's last 0.2 strain."""
    late = cycle.strain >= cycle.strain[-1] - metrics.OVERSHOOT_LATE
    return float(np.mean(np.hypot(quantity[late, 0, 1], quantity[late, 2, 1])))


def held_out(run, params: model.Params, noise, stress: str, cache: dict | None = None) -> dict:
    """``run`` predicted by ``params``: per component of A and of the fitted tau/p, the RMS error in units of the
    run's noise (``noise``, measured on the fit's runs) and per the DEM's steady value, and the sum of squared
    noise-scaled residuals with their count (``chi2``, ``samples``). ``_blocks`` (not written) keeps, per component,
    the scaled (A, tau) residuals and the noise's correlation over them (``covariance.sample_covariance``; ``cache``
    shares the matrices) for ``compared``."""
    cycle = global_fit.scaled_cycle(run, noise, 0.0, stress)
    try:
        pred = cycle.prediction(params)
    except model.SolverError as exc:  # the fitted law cannot run this protocol's cycle: no prediction at all
        return not_predicted(run, str(exc).split(" (parameters off")[0])
    row = {"run": run.path.stem, "protocol": protocol(run), "seed": run.spec.seed, "components": {}, "error": None}
    r_A, r_tau = global_fit.scaled_residuals(cycle, pred)
    row["_blocks"] = [(np.concatenate([r_A[:, k], r_tau[:, k]]), covariance.sample_covariance(noise, k, cycle, cache))
                      for k in range(len(COMPONENTS))]
    chi2 = samples = 0.0
    for name, ours, dem, scale in (("A", pred.A, cycle.A, cycle.A_scale), ("tau", pred.tau, cycle.tau,
                                                                           cycle.tau_scale)):
        steady = steady_scale(cycle, dem)
        for i, j in COMPONENTS:
            if not np.all(np.isfinite(scale[:, i, j])):
                continue
            error = ours[:, i, j] - dem[:, i, j]
            in_noise = error / scale[:, i, j]
            row["components"][f"{name}{i + 1}{j + 1}"] = {
                "rms_noise": float(np.sqrt(np.mean(in_noise**2))),
                "rms_per_steady": float(np.sqrt(np.mean(error**2)) / steady)}
            chi2, samples = chi2 + float(np.sum(in_noise**2)), samples + len(error)
    row.update(chi2=chi2, samples=samples, rms_noise=float(np.sqrt(chi2 / samples)))
    return row


def not_predicted(run, reason: str) -> dict:
    """``held_out``'s row for a run the law gives no prediction of (its cycle cannot be run, or the law could not be
    fitted on the other runs): an infinite error, no residuals."""
    return {"run": run.path.stem, "protocol": protocol(run), "seed": run.spec.seed, "components": {},
            "error": reason, "chi2": np.inf, "samples": 1.0, "rms_noise": np.inf, "_blocks": None}


def information(fit: global_fit.GlobalFit, data_points: float) -> dict:
    """AIC and BIC of a fit from its chi^2 (the noise taken as Gaussian and, for the counts, white: with noise
    correlated along strain both overstate the evidence, alike for every variant)."""
    k = len(fit.names)
    return {"parameters": k, "chi2": fit.chi2, "aic": fit.chi2 + 2 * k, "bic": fit.chi2 + k * np.log(data_points)}


def judge(variant: str, runs: list, other_runs: dict[str, list], stress: str, weight: str, progress) -> dict:
    """Everything ``make models`` reports of one variant (see the module's text)."""
    default = [r for r in runs if r.default_rotation]
    data, noise = global_fit.prepare(default, 0.0, stress, weight)  # once: the fit and the residuals' count
    full = fit_prepared(data, noise, variant)
    params = global_fit.with_eq19_c1(full.params)
    out = {"variant": variant, "params": params.to_dict(), "free": list(full.names),
           "values": full.values.tolist(), "standard_errors": full.standard_errors.tolist(),
           "misfit": full.misfit, **information(full, global_fit.fitted_residuals(data)),
           "own_reversal": own_reversal(params), "splits": [], "across": []}
    progress()
    for split in splits(runs):
        try:
            trained, train_noise = fit([runs[i] for i in split.train], variant, stress, weight)
        except CalibrationError as exc:  # the law cannot be fitted on these runs alone: it predicts nothing
            rows = [not_predicted(runs[i], f"not fitted on the other runs: {exc}") for i in split.test]
            out["splits"].append({"name": split.name, "params": None, "misfit": None, "error": str(exc),
                                  "rows": rows, "rms_noise": np.inf})
        else:
            rows = [held_out(runs[i], trained.params, train_noise, stress, {}) for i in split.test]
            out["splits"].append({"name": split.name, "params": trained.params.to_dict(), "misfit": trained.misfit,
                                  "error": None, "rows": rows, "rms_noise": pooled(rows)})
        progress()
    for label, others in other_runs.items():
        there = [r for r in others if r.default_rotation]
        trained, there_noise = fit(there, variant, stress, weight)
        here = [held_out(r, trained.params, noise, stress) for r in runs]
        back = [held_out(r, full.params, there_noise, stress) for r in others]
        out["across"].append({"other": label, "params_there": trained.params.to_dict(),
                              "here_from_there": here, "rms_noise_here": pooled(here),
                              "there_from_here": back, "rms_noise_there": pooled(back)})
        progress()
    return out


def compared(rows: list[dict], base_rows: list[dict]) -> float:
    """How far the held-out chi^2 of ``base_rows`` (Eq. 13's) lies above that of ``rows`` (a variant's, the same
    runs and noise), in standard deviations of what the noise alone makes of that difference: with r1, r2 the two
    laws' scaled residuals and C the noise's correlation, chi2_2 - chi2_1 = (r2 - r1).(r2 + r1), whose part from
    the noise has the variance 4 (r2 - r1)^T C (r2 - r1) (runs and components independent). Infinite where only
    the base cannot run a held-out cycle; nan where neither can."""
    difference = variance = 0.0
    for mine, base in zip(rows, base_rows, strict=True):
        if mine["_blocks"] is None or base["_blocks"] is None:
            return np.nan if mine["_blocks"] is base["_blocks"] else (np.inf if mine["_blocks"] else -np.inf)
        for (r1, C), (r2, _) in zip(mine["_blocks"], base["_blocks"], strict=True):
            delta = r2 - r1
            difference += float(delta @ (r2 + r1))
            variance += 4.0 * float(delta @ C @ delta)
    return difference / np.sqrt(variance) if variance > 0 else 0.0


def pooled(rows: list[dict]) -> float:
    """The RMS held-out error over ``rows`` in noise units (every sample of every scored component alike)."""
    return float(np.sqrt(sum(r["chi2"] for r in rows) / sum(r["samples"] for r in rows)))


def runnable(run, sets: dict) -> dict:
    """``metrics.model_for`` of the parameter sets whose law can run the run's cycle (one that cannot draws no curve;
    its held-out score says so)."""
    out = {}
    for label, params in sets.items():
        try:
            out.update(metrics.model_for(run, {label: params}))
        except model.SolverError:
            continue
    return out


def curves(runs: list, results: list[dict]) -> dict:
    """What the figure draws: per variant, the memory of the old direction after the turns of 120 and 150 (the DEM's
    cycle mean; each variant fitted without 120 and 150, the ``angles`` split) and the first JUMP_SPAN strain after
    the reversal (A's component along the old direction per its steady value; each variant's fit on every run)."""
    out = {"memory": [], "jump": []}
    full = {r["variant"]: r["params"] for r in results}
    # each law's fit of the ``angles`` split (made wherever a run at 120 or 150 is held out), where it was fitted
    sets = {r["variant"]: s["params"] for r in results for s in r["splits"] if s["name"] == "angles" and s["params"]}
    for run in runs:
        if not run.default_rotation:
            continue
        if run.theta_deg in (120.0, 150.0):
            preds = runnable(run, {v: model.Params.from_dict(p) for v, p in sets.items()})
            for c in metrics.memory_curves(run, preds):
                if c["segment"] == "after the turn to theta":
                    out["memory"].append({"run": run.path.stem, "seed": run.spec.seed, "theta": run.theta_deg,
                                          "strain": c["strain_after"],
                                          "dem": c["dem"].mean(axis=0),
                                          "model": {v: m[1] for v, m in c["model"].items()}})
        if run.is_reversal:
            preds = runnable(run, {v: model.Params.from_dict(p) for v, p in full.items()})
            out["jump"].append(jump_curve(run, preds))
    return out


def jump_curve(run, preds: dict) -> dict:
    """A's component along the old direction (e1) over the first JUMP_SPAN strain after the reversal, per its steady
    value before it: the DEM's cycle mean and each variant's."""
    spec = run.spec
    grid, idx = metrics.cycle_grid(spec, run.series["strain_nominal"])
    change = next(metrics.changes(spec))
    _, start, _, _, old, old_start, old_end = change
    after = metrics.window(grid, start, start + JUMP_SPAN)
    dem = metrics.along(run.series["A"][idx], old).mean(axis=0)
    steady = dem[metrics.segment_windows(grid, old_start, old_end)[1]].mean()
    out = {"run": run.path.stem, "seed": spec.seed, "strain": grid[after] - start, "dem": dem[after] / steady,
           "model": {}}
    for variant, (data, pred) in preds.items():
        a = metrics.along(pred.A, old)
        late = metrics.segment_windows(data.strain, old_start, old_end)[1]
        out["model"][variant] = np.interp(grid[after], data.strain, a) / a[late].mean()
    return out


def write_curves(path: Path, drawn: dict, made_from: schema.MadeFrom) -> None:
    with io.h5_file(path) as f:
        f.attrs.update(schema=schema.MODELS_SCHEMA, schema_version=schema.MODELS_VERSION,
                       made_from=json.dumps(made_from.to_dict()))
        for kind, items in drawn.items():
            for k, item in enumerate(items):
                g = f.create_group(f"{kind}/{k:02d}")
                g.attrs["run"], g.attrs["seed"] = item["run"], item["seed"]
                g.attrs["theta"] = item.get("theta", 180.0)
                g["strain"], g["dem"] = item["strain"], item["dem"]
                for variant, values in item["model"].items():
                    g[f"model/{variant}"] = values


def tests_of(result: dict):
    """(test, the held-out rows, their pooled RMS in noise units) for every split and cross-cell prediction."""
    for split in result["splits"]:
        yield split["name"], split["rows"], split["rms_noise"]
    for across in result["across"]:
        yield f"predicting this cell from {across['other']}", across["here_from_there"], across["rms_noise_here"]
        yield f"predicting {across['other']} from this cell", across["there_from_here"], across["rms_noise_there"]


def judged(results: list[dict]) -> list[dict]:
    """Per law beyond the first (Eq. 13), per held-out test: both pooled RMS errors and ``compared``'s z (positive:
    the law predicts better), with the word for it (``BEYOND_NOISE_Z``)."""
    base = results[0]
    out = []
    for r in results[1:]:
        for (name, rows, ours), (_, base_rows, theirs) in zip(tests_of(r), tests_of(base), strict=True):
            z = compared(rows, base_rows)
            word = ("neither law so fitted runs every held-out cycle" if np.isnan(z) else
                    "better beyond the noise" if z > BEYOND_NOISE_Z else
                    "worse beyond the noise" if z < -BEYOND_NOISE_Z else "within the noise")
            out.append({"variant": r["variant"], "against": base["variant"], "test": name, "rms_noise": ours,
                        "rms_noise_against": theirs, "z": z, "verdict": word})
    return out


def verdict_lines(judgements: list[dict]) -> list[str]:
    return [f"{j['variant']} against {j['against']}, {j['test']}: {j['rms_noise']:.2f} against "
            f"{j['rms_noise_against']:.2f} noise units, z = {j['z']:+.1f}: {j['verdict']}" for j in judgements]


def without_blocks(results: list[dict]) -> list[dict]:
    """``results`` without the residual blocks ``held_out`` keeps for ``compared`` (not written)."""
    strip = lambda rows: [{k: v for k, v in row.items() if k != "_blocks"} for row in rows]  # noqa: E731
    return [{**r, "splits": [{**s, "rows": strip(s["rows"])} for s in r["splits"]],
             "across": [{**a, "here_from_there": strip(a["here_from_there"]),
                         "there_from_here": strip(a["there_from_here"])} for a in r["across"]]} for r in results]


def markdown(label: str, results: list[dict], judgements: list[dict],
             not_fitted: dict[str, str] | None = None) -> str:
    """``models.md``: the held-out table, the in-sample numbers, the parameters and the verdict; the laws that could
    not be fitted on every run (``not_fitted``: the reason) are named."""
    variants = [r["variant"] for r in results]
    lines = [f"# Fabric laws judged by the runs they were not fitted on: {label}", "",
             "Held-out error: RMS over the cycle in units of the run's noise (1 is a prediction within the noise), "
             "pooled over the held-out runs and their components (A: 12, 32, 11, 22, 13; tau/p: 12, 32).", "",
             "| held out | " + " | ".join(variants) + " |", "|---|" + "---|" * len(variants)]
    for k, (name, _, _) in enumerate(tests_of(results[0])):
        lines.append(f"| {name} | " + " | ".join(f"{list(tests_of(r))[k][2]:.2f}" for r in results) + " |")
    lines += ["", "In sample (every run of the default protocol):", "",
              "| variant | parameters | misfit | AIC | BIC | own reversal |", "|---|---|---|---|---|---|"]
    for r in results:
        rev = r["own_reversal"]
        runs_away = "no cycle" if rev["error"] else f"peak/steady {rev['peak_over_steady']:.2f}"
        own = "no steady state" if rev["start_rate"] is None else f"start rate {rev['start_rate']:+.3g}, {runs_away}"
        lines.append(f"| {r['variant']} | {r['parameters']} | {r['misfit']:.2f} | {r['aic']:.0f} | {r['bic']:.0f} | "
                     f"{own} |")
    lines += ["", "Parameters (fit on every run; ± one standard error from the noise):", ""]
    for r in results:
        lines.append(f"- {r['variant']}: " + ", ".join(f"{n} = {v:+.4g} ± {s:.2g}" for n, v, s in
                                                        zip(r["free"], r["values"], r["standard_errors"], strict=True)))
    lines += ["", "Per held-out run (RMS over its components in noise units; inf: no prediction, the law fitted cannot "
              "run its cycle or could not be fitted on the other runs, models.json says which; models.json has each "
              "component, also per the DEM's steady value):", ""]
    for k, split in enumerate(results[0]["splits"]):
        for j, row in enumerate(split["rows"]):
            cells = [f"{r['splits'][k]['rows'][j]['rms_noise']:.2f}" for r in results]
            lines.append(f"- {split['name']}: {row['protocol']} seed {row['seed']}: " + ", ".join(
                f"{v} {c}" for v, c in zip(variants, cells, strict=True)))
    lines += ["", f"Verdict: z is how far Eq. 13's held-out chi^2 lies above the law's, in standard deviations of what "
              f"the noise alone makes of that difference (its correlation along strain included); beyond the noise "
              f"past |z| = {BEYOND_NOISE_Z:g}.", ""]
    lines += [f"- {line}" for line in verdict_lines(judgements)]
    if not_fitted:  # a law whose fit on every run failed
        lines += ["", "Not fitted on every run (so not judged):", ""]
        lines += [f"- {variant}: {reason}" for variant, reason in not_fitted.items()]
    return "\n".join(lines) + "\n"


def read(chosen) -> list:
    """Every run of the data set ``chosen``, every seed, read with ``make fit``'s definitions (the paper's)."""
    return [r.with_definitions(PAPER_DEFINITIONS) for r in every_seed(chosen)]


def other_data_sets(chosen, across: list[str]) -> dict[str, list]:
    """The runs of each data set named ``P[:E]`` in ``across``; by default the most faithful other preset with a
    reversal run; none for ``none``."""
    if across == ["none"]:
        return {}
    if "none" in across:
        raise CalibrationError(f"--across {' '.join(across)}: none stands alone (no other data set)")
    if not across:
        across = [p for p in selection.PRESETS_BY_FIDELITY
                  if p != chosen.preset and selection.has_reversal(selection.data_set(p))][:1]
    out = {}
    for item in across:
        preset, _, engine = item.partition(":")
        other = selection.data_set(preset, engine or None)
        runs = read(other)
        if not any(r.is_reversal for r in runs):
            raise CalibrationError(f"--across {item}: the data set {other.label} has no reversal run")
        out[other.folder] = runs
    return out


def law_list(text: str) -> list[str]:
    """``--laws``: known law names, comma-separated, in the registry's order with Eq. 13's first."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    known = model.params.VARIANTS
    if not names or not set(names) <= set(known):
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of {', '.join(known)}")
    return [v for v in known if v in names or v == model.params.DEFAULT_VARIANT]


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.comparison.models", description=__doc__.splitlines()[0])
    selection.add_arguments(parser, "preset whose runs judge the variants")
    parser.add_argument("--across", action="append", default=[], metavar="PRESET[:ENGINE]",
                        help="another data set to predict from this one and back (repeatable; default: the most "
                             "faithful other preset with a reversal run; none: no other)")
    parser.add_argument("--laws", type=law_list, default=list(model.params.VARIANTS), metavar="LAW,LAW...",
                        help="the fabric laws judged (default every one; Eq. 13's, rk2025, is always judged, first)")
    parser.add_argument("--out", type=Path, help="output folder (default results/<data set>/models)")
    args = parser.parse_args(argv)
    chosen = selection.from_arguments(args)
    runs = read(chosen)
    if not any(r.is_reversal for r in runs):
        raise CalibrationError(f"no reversal run of {chosen.label}: make one with `make dem THETA=180 ...`")
    others = other_data_sets(chosen, args.across)
    out = io.check_writable_dir(args.out or preset_output(chosen.folder, "models"))
    variants = args.laws
    total, done, began = len(variants) * (1 + len(splits(runs)) + len(others)), [0], time.monotonic()

    def progress():
        done[0] += 1
        rate = done[0] / (time.monotonic() - began)
        print(f"models: {done[0]}/{total} fits ({100 * done[0] / total:.0f}%), {rate:.2f} fits/s, "
              f"ETA {(total - done[0]) / rate:.0f} s", flush=True)

    print(f"runs: {chosen.label}; across: {', '.join(others) or 'none'}", flush=True)
    stress, weight = global_fit.STRESS_DEFAULT, global_fit.WEIGHT_DEFAULT
    results, not_fitted = [], {}
    for v in variants:
        try:
            results.append(judge(v, runs, others, stress, weight, progress))
        except CalibrationError as exc:  # this law cannot be fitted on these runs: the others are still judged
            if v == variants[0]:
                raise CalibrationError(f"Eq. 13's law (the one the others are judged against): {exc}") from None
            not_fitted[v] = str(exc)
            done[0] += total // len(variants)  # its fits, none made
            print(f"models: {v} not fitted on every run ({exc}): left out", flush=True)
    judgements = judged(results)
    results = without_blocks(results)
    made_from = schema.MadeFrom.of([r.path for r in (*runs, *(r for rs in others.values() for r in rs))],
                                   {"laws": variants, "across": list(others), "stress": stress, "weight": weight})
    summary = {"schema_version": schema.MODELS_VERSION, "data_set": chosen.folder, "stress_fitted": stress,
               "weight": weight, "train_angles": list(TRAIN_ANGLES), "beyond_noise_z": BEYOND_NOISE_Z,
               "variants": results, "not_fitted": not_fitted, "verdict": judgements,
               "made_from": made_from.to_dict()}
    with io.atomic_paths(*(out / n for n in ("models.json", "models.md", "models.h5"))) as (js, md, h5):
        io.write_bytes(js, io.json_text(summary).encode())
        io.write_bytes(md, markdown(chosen.label, results, judgements, not_fitted).encode())
        write_curves(h5, curves(runs, results), made_from)
    for r in results:
        io.write_params(out / f"params-{r['variant']}.json", model.Params.from_dict(r["params"]),
                        {"fit": "global (pipeline.comparison.models: every run of the default protocol)",
                         "misfit": r["misfit"]})
    print("\n".join(verdict_lines(judgements)))
    print(f"wrote {out / 'models.md'}, models.json, models.h5 and params-<variant>.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
