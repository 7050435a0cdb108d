"""``make fit``: calibrate the model on a preset's DEM runs and write ``results/<preset>/fit/``.

``python -m pipeline.calibration [--preset P] [--runs a.h5 ...] [--window 0.05] [--out DIR] [--bootstrap N]``

Without ``--preset``, the most faithful preset that has a reversal run (paper, then reduced, then
quick; in ``results/`` or the committed data) is used, and named. The preset's reversals (every
seed) are calibrated by the paper's stepwise route (``stepwise``), its other angles cross-check
the flow rule (Sec. 3.3), and all of them are fitted at once (``global_fit``). Outputs, each
written atomically: ``params.json`` (the global fit, loadable by ``python -m model predict
--params``), ``params_stepwise.json``, ``fit.json`` (every estimate, its standard error, the
per-run values, the settings and their sensitivity) and ``fit.h5`` (the per-sample alpha_i,
beta_i, Y and C against S behind them).
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from pathlib import Path

import h5py

import model

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset.dem_file import load
from ..dataset.derived import DEFAULT, Definitions
from ..dataset.lookup import other_angles, preset_runs, reversal_seeds
from ..dataset.options import add_definition_arguments, definitions_from
from ..errors import CalibrationError
from ..paths import check_folder_name, most_faithful_preset, preset_output
from . import design, global_fit, identifiability
from .stepwise import calibrate_run, combine, cross_check_run, fitted_params, sensitivity, stepwise_bootstrap


def write_arrays(path: Path, arrays: dict, per_run: list[dict], cross: list[dict]) -> None:
    """fit.h5: the per-sample values behind the fit (alpha_i, beta_i, Y, C against S), atomically."""
    with io.atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs.update(schema="granular-backstress/fit", schema_version=1)
        for group, items, meta in (("reversal", arrays["reversal"], per_run),
                                   ("cross_check", arrays["cross_check"], cross)):
            for k, (values, info) in enumerate(zip(items, meta, strict=True)):
                g = f.create_group(f"{group}/{k}")
                g.attrs["path"] = info["path"]
                if "theta_deg" in info:
                    g.attrs["theta_deg"] = info["theta_deg"]
                for name, data in values.items():
                    g.create_dataset(name, data=data).attrs["unit"] = "1"


def check_distinct(runs: list) -> None:
    """Refuse a run given twice (the same spec, seed included, is the same run): it would count as two seeds."""
    seen = {}
    for run in runs:
        key = json.dumps(run.spec, sort_keys=True)
        if key in seen:
            raise CalibrationError(f"{run.path} is the same run as {seen[key]} (same spec and seed): give it once")
        seen[key] = run.path


def check_window(window: float, runs: list) -> None:
    shortest = min(min(r.spec["rotate_at_strain"], r.spec["period_strain"] - r.spec["rotate_at_strain"])
                   for r in runs)
    if not (math.isfinite(window) and 0 < window < shortest):
        raise CalibrationError(f"window={window} must be a positive strain shorter than the shortest segment "
                               f"of a cycle ({shortest:g})")


def fit(reversals: list, out_dir: Path, window: float = 0.05, cross_runs: tuple = (), refine: bool = True,
        bootstrap: int = 0, definitions: Definitions = DEFAULT, hold: dict | None = None,
        left_out: tuple = (), jackknife: bool = False, fit_from: float = 0.0,
        persistence_exponent: float = 0.75) -> dict:
    """Calibrate from ``reversals``, cross-check on ``cross_runs`` (other angles, Sec. 3.3), refine
    globally on all of them (from Table 2) and write into ``out_dir``; every run read with ``definitions``;
    the parameters in ``hold`` are held at the values given instead of fitted. ``left_out``: runs the fit
    does not use (the Fig. 7 rotations, kept for the comparison), named among the candidates of
    ``next_runs``. ``fit_from``: the global fit restarts the model from the DEM's state this far (nominal
    strain) past each change of direction and fits what follows (``Cycle.restarted``); ``persistence_exponent``:
    k of Eq. 12, held."""
    hold = dict(hold or {})
    unknown = sorted(set(hold) - set(global_fit.FREE))
    if unknown:
        raise CalibrationError(f"cannot hold {', '.join(unknown)}: only {', '.join(global_fit.FREE)} can be held")
    start = model.Params().replace(persistence_exponent=persistence_exponent, **hold)
    free = tuple(n for n in global_fit.FREE if n not in hold)
    reversals = [r.with_definitions(definitions) for r in reversals]
    cross_runs = tuple(r.with_definitions(definitions) for r in cross_runs)
    if not reversals:
        raise CalibrationError("no reversal run found (theta = 180): run `make dem THETA=180 PRESET=...` first")
    not_reversals = [f"{r.path} (theta = {r.spec['theta_deg']})" for r in reversals if not r.is_reversal]
    if not_reversals:
        raise CalibrationError(f"not a reversal run: {', '.join(not_reversals)}")
    check_distinct([*reversals, *cross_runs])
    check_window(window, [*reversals, *cross_runs])
    if bootstrap and bootstrap < 2:
        raise CalibrationError(f"bootstrap={bootstrap}: a bootstrap needs at least 2 resamples")
    if jackknife and len(reversals) < 3:
        raise CalibrationError(f"a jackknife over seeds needs at least 3 reversal seeds, not {len(reversals)}")
    if fit_from and bootstrap:
        raise CalibrationError("a bootstrap of a restarted fit (fit_from > 0) is not implemented: leave one out")
    if bootstrap and not any(r.spec["n_cycles"] > 1 for r in (*reversals, *cross_runs)):
        raise CalibrationError("a bootstrap needs runs with more than one cycle (the noise is measured from them)")
    io.check_writable_dir(out_dir)
    per_run = [calibrate_run(run, window=window) for run in reversals]
    cross = [cross_check_run(run, window=window) for run in cross_runs]
    arrays = {"reversal": [r.pop("arrays") for r in per_run], "cross_check": [c.pop("arrays") for c in cross]}
    refined = dilatancy = boot = noise = identifiable = jack = None
    next_runs = []
    if refine:
        data, noise = global_fit.prepare([*reversals, *cross_runs], fit_from)
        refined = global_fit.refine(data, start, free, noise=noise)
        dilatancy = global_fit.refine_dilatancy(data, refined.params)
        identifiable = identifiability.summary(refined, data, hold, measured=noise.measured)
        if not hold and noise.measured:
            rotations = [(r.spec["theta_deg"], r.spec["rotate_at_strain"]) for r in left_out]
            next_runs = design.rank(refined, noise, [*reversals, *cross_runs], rotations)
        if bootstrap:
            tic = time.time()

            def progress(done, total):
                rate = done / (time.time() - tic)
                print(f"bootstrap {done}/{total} ({done / total:.0%}), {rate:.2f} fits/s, "
                      f"ETA {(total - done) / rate:.0f} s", flush=True)

            boot = global_fit.bootstrap(data, noise, refined, bootstrap, progress=progress)
            boot["stepwise"] = stepwise_bootstrap(reversals, bootstrap, window)
        if jackknife:
            jack = global_fit.jackknife(data, list(range(len(reversals))), refined,
                                        progress=lambda d, t: print(f"jackknife {d}/{t} ({d / t:.0%})", flush=True))
    estimates = combine(per_run)
    bad = [k for k in ("C_eq15", "n", "m", "a1", "b1", "a2", "b2") if not math.isfinite(estimates[k]["value"])]
    if bad:
        raise CalibrationError(f"the fit gave no finite value for {', '.join(bad)}")
    notes = ["C is Eq. 15's slope: on model data it returns C - 2m (Y still drifts near steady state)",
             "c3 is held at the paper's 0.14; c2_exponent and the persistence exponent at 1/3 and "
             f"{persistence_exponent:g}"]
    try:
        stepwise = fitted_params(estimates)
    except model.ParameterError as exc:  # the paper's route can land outside the model's domain on noisy cells
        if refined is None:
            raise CalibrationError(f"the stepwise calibration gives no valid parameters ({exc})") from None
        stepwise = None
        notes.append(f"the stepwise estimates are no valid parameter set ({exc}): no params_stepwise.json")
    params = stepwise if refined is None else dilatancy.params
    report = {"method": "stepwise (paper Sec. 4: Eqs. 9, 12, 15, 16, 18), then a global least-squares refinement",
              "definitions": dataclasses.asdict(definitions), "held": hold, "fit_from": fit_from,
              "persistence_exponent": persistence_exponent,
              "jaumann_window_strain": window, "runs": per_run, "estimates": estimates,
              "sensitivity": sensitivity(reversals),
              "params_stepwise": stepwise and stepwise.to_dict(), "params": params.to_dict(), "cross_check": cross,
              "global": None if refined is None else refined.to_dict(),
              "noise": None if noise is None else noise.to_dict(), "identifiability": identifiable,
              "next_runs": next_runs,
              "dilatancy": None if refined is None else dilatancy.to_dict(),
              "bootstrap": boot, "jackknife": jack,
              "global_runs": [str(r.path) for r in (*reversals, *cross_runs)] if refine else [],
              "notes": notes}
    write_arrays(out_dir / "fit.h5", arrays, per_run, cross)
    (out_dir / "params_stepwise.json").unlink(missing_ok=True)
    if stepwise is not None:
        io.write_params(out_dir / "params_stepwise.json", stepwise)
    io.write_params(out_dir / "params.json", params, None if identifiable is None else {
        "fit": "global (pipeline.calibration.global_fit)", "definitions": dataclasses.asdict(definitions),
        "held": hold, "intervals_68": identifiable["intervals_68"],
        "not_determined": identifiable["not_determined"], "misfit": refined.misfit})
    io.write_json(out_dir / "fit.json", report)
    return report


def default_preset() -> str:
    """The most faithful preset with a reversal run, in results/ or the committed data."""
    preset = most_faithful_preset()
    if not reversal_seeds(preset):
        raise CalibrationError("no reversal run of any preset: run `make dem THETA=180` first")
    return preset


def print_global(report: dict) -> None:
    """The global fit first: values with their 68 % intervals from the measured noise, what is determined."""
    g, ident, nm = report["global"], report["identifiability"], report["noise"]
    unit = ("the DEM's noise: 1 is a fit within the noise" if ident["noise_measured"] else
            "the scatter about a smoothed cycle, which is less than the noise")
    print(f"global fit on {len(report['global_runs'])} run(s); misfit {g['misfit']:.2f} (chi^2 per degree of "
          f"freedom in units of {unit})")
    if not ident["noise_measured"]:
        print(f"intervals: none ({nm['source']}): run two cycles or more, or three seeds")
    else:
        print(f"intervals: 68 % from the DEM's noise ({nm['source']}; correlated over "
              f"{min(min(v) for v in nm['correlation_strain'].values()):.2f}-"
              f"{max(max(v) for v in nm['correlation_strain'].values()):.2f} strain), not scaled by the misfit")
    for name, p in ident["parameters"].items():
        band = p["intervals"]["68"]
        text = "[none]" if band is None else f"[{band[0]:+.4g}, {band[1]:+.4g}]"
        print(f"{name:>8s} = {p['value']:+.4g}  68 % {text:>24s}  {p['status']}")
    d = report["dilatancy"]
    for name, value, se in zip(d["free"], d["values"], d["standard_errors"], strict=True):
        print(f"{name:>8s} = {value:+.4g} ± {se:.2g} (Eq. 18 on Phi; its scatter taken as white)")
    for label, items in (("fixed best", ident["strongest"]), ("fixed least", ident["weakest"])):
        if ident["noise_measured"]:
            print(f"the data {label}: " + "; ".join(f"{c['combination']} (±{c['relative_step']:.2g})"
                                                   for c in items))
    if ident["not_determined"]:
        print(f"not determined by these runs: {', '.join(ident['not_determined'])} (hold with --hold NAME=VALUE)")
    t = ident["table2"]
    if t:
        where = ("inside" if t["inside"]["95"] else "outside") if t["quantiles"] else "undecided"
        lenient = ("inside" if t["inside_misfit_widened"]["95"] else "outside") if t["quantiles"] else "undecided"
        bound = f" against {t['quantiles']['95']:.0f}" if t["quantiles"] else ""
        print(f"Table 2 on these data: chi^2 {t['relative_rise']:+.1%} above the best fit (a rise of "
              f"{t['chi2_rise']:.0f}{bound}): {where} the 95 % region from the noise, {lenient} it when widened "
              "by the misfit (make fit-definitions: under each definition)")


def print_next_runs(report: dict, count: int = 5) -> None:
    if not report["next_runs"]:
        return
    first = report["next_runs"][0]
    print(f"runs that would fix the weakest combination best per CPU-hour (now ±{first['weakest_before']:.2g}; "
          "fit.json: next_runs):")
    for r in report["next_runs"][:count]:
        print(f"  {r['run']}: ±{r['weakest_after']:.2g}, {r['cpu_hours']:.2f} CPU-hours")


def print_report(report: dict, out: Path) -> None:
    if report["global"]:
        print_global(report)
        print_next_runs(report)
    if report.get("bootstrap"):
        b = report["bootstrap"]
        print(f"noise bootstrap ({len(b['replicates'])} refits, blocks of {b['block_strain']:g} strain), 68 %: "
              + ", ".join(f"{n} [{lo:+.4g}, {hi:+.4g}]" for n, (lo, hi) in zip(b["free"], b["interval_68"],
                                                                               strict=True)))
    if report.get("jackknife"):
        j = report["jackknife"]
        print(f"jackknife over the {len(j['left_out'])} reversal seeds: standard errors "
              + ", ".join(f"{n} {se:.2g} ({r:.1f}x the noise model's)" for n, se, r in
                          zip(j["free"], j["standard_error"], j["over_sandwich"], strict=True)))
    print("the paper's stepwise route (Sec. 4), mean ± standard error over the reversal runs, and its range over "
          "smoothing windows 0.03-0.08 and 1-4 relaxation strains of transient (fit.json: sensitivity):")
    settings = [v for part in ("smoothing_window", "transient_efolds") for v in report["sensitivity"][part].values()]
    for key, e in report["estimates"].items():
        values = [v[key] for v in settings if key in v]
        spread = f"   ({min(values):+.4g} to {max(values):+.4g} over its settings)" if values else ""
        print(f"{key:>30s} = {e['value']:+.4g} ± {e['standard_error']:.2g}{spread}")
    for c in report["cross_check"]:
        if "C_median" in c:
            q = c["C_quartiles"]
            print(f"  Sec. 3.3, theta = {c['theta_deg']:g}: C = {c['C_median']:+.2f} (quartiles {q[0]:+.2f} "
                  f"{q[1]:+.2f}), Y = {c['n']:+.3f} {c['m']:+.3f} S")
    for note in report["notes"][2:]:
        print(f"note: {note}")
    print(f"wrote {out / 'params.json'} (global fit), fit.json and fit.h5"
          + (", params_stepwise.json" if report["params_stepwise"] else ""))


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration", description=__doc__.splitlines()[0])
    parser.add_argument("--preset", help="preset whose runs to fit (default: the most faithful one with runs)")
    parser.add_argument("--runs", nargs="*", type=Path, help="reversal DEM files to fit instead of the preset's")
    parser.add_argument("--window", type=float, default=0.05, help="Savitzky-Golay window in strain (default 0.05)")
    parser.add_argument("--out", type=Path, help="output folder (default results/<preset>/fit)")
    add_definition_arguments(parser)
    parser.add_argument("--hold", action="append", default=[], metavar="NAME=VALUE",
                        help="hold a flow-rule or fabric parameter at VALUE instead of fitting it (repeatable)")
    parser.add_argument("--jackknife", action="store_true",
                        help="also refit leaving out one reversal seed at a time (needs 3 or more seeds)")
    parser.add_argument("--fit-from", type=float, default=0.0, metavar="STRAIN",
                        help="restart the model from the DEM's state this far past each change of direction and "
                             "fit what follows (nominal strain, a multiple of the sampling step; default 0: all)")
    parser.add_argument("--persistence-exponent", type=float, default=0.75, metavar="K",
                        help="k of Lambda = S^k (Eq. 12), held (default 3/4, the paper's)")
    parser.add_argument("--bootstrap", type=int, metavar="N",
                        help="also refit N >= 2 resamplings of the cycles (bootstrap standard deviations)")
    args = parser.parse_args(argv)
    if args.bootstrap is not None and args.bootstrap < 2:
        raise CalibrationError(f"bootstrap={args.bootstrap}: a bootstrap needs at least 2 resamples")
    if not math.isfinite(args.window) or args.window <= 0:
        raise CalibrationError(f"window={args.window} must be a positive strain")
    if not math.isfinite(args.fit_from) or not 0 <= args.fit_from < 0.5:
        raise CalibrationError(f"fit_from={args.fit_from} must be a strain in [0, 0.5)")
    if not math.isfinite(args.persistence_exponent) or not 0 < args.persistence_exponent <= 2:
        raise CalibrationError(f"persistence_exponent={args.persistence_exponent} must lie in (0, 2]")
    if args.runs:
        reversals, cross, left_out = [load(p) for p in args.runs], (), ()
        out = args.out or preset_output(check_folder_name(args.preset or "custom"), "fit")
    else:
        preset = args.preset or default_preset()
        if args.preset is None:
            print(f"preset: {preset} (the most faithful one with a reversal run; --preset / PRESET= to choose)")
        out = args.out or preset_output(preset, "fit")
        every = preset_runs(preset)
        reversals, cross = reversal_seeds(preset), tuple(other_angles(every))
        left_out = tuple(r for r in every if not r.default_rotation)
    definitions = definitions_from(args)
    hold = {}
    for item in args.hold:
        name, _, value = item.partition("=")
        try:
            hold[name] = float(value)
        except ValueError:
            raise CalibrationError(f"--hold {item!r} is not NAME=VALUE with a number") from None
    print(f"definitions: {definitions.label()}")
    report = fit(reversals, out, args.window, cross, bootstrap=args.bootstrap or 0, definitions=definitions,
                 hold=hold, left_out=left_out, jackknife=args.jackknife, fit_from=args.fit_from,
                 persistence_exponent=args.persistence_exponent)
    print_report(report, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
