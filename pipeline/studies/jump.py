"""The reversal jump: how much fabric and wall stress a DEM run loses right after each change of direction.

``python -m pipeline.studies.jump [--runs a.h5 ...] [--out results/jump]`` (``make jump``) reads every run of
the committed data and ``results/`` (or the files given) and, for each change of direction of each run,
measures against the nominal strain gamma after the change:

- ``fabric``: the fabric's shear component in the frame of the direction before the change, as a fraction
  of its value at the last sample before the change (1 at the change; -1 once reversed to steady state),
  ``s_old . A . e2 / (s_old . A_before . e2)``;
- ``wall``: the wall normal stress over p, averaged over each sampling interval, at its lowest within the
  first 0.01 strain;
- ``band``: the central band's strain (the integral of s . dv/dy) over the first gamma, per unit nominal strain.

Dense samples (``dense_sample_strain``) resolve gamma = 0.0005 ... 0.005; runs without them give gamma >= 0.005.
Runs are grouped by setting (their overrides less the seed), each value the mean over the setting's runs
and changes with its standard error; the paper's model (Table 2) is given beside it. Writes ``jump.md``
and ``jump.json``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import model
from dem.core.protocol import direction_changes

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset.dem_file import load
from ..errors import PipelineError
from ..paths import DATA_ROOTS, RESULTS_DIR, globbed

GAMMAS = (0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05)
WALL_WINDOW = 0.01
#: a sample stands for gamma when it lies this close to it (a sample lands within one controller interval)
TOLERANCE = 1e-4


def change_profile(series: dict, change: float, gammas=GAMMAS) -> dict:
    """The fabric fraction, the band's strain ratio at each of ``gammas`` that a sample resolves (NaN where none
    does), and the lowest wall stress over p within ``WALL_WINDOW`` after ``change``."""
    strain = series["strain_nominal"]
    before = int(np.flatnonzero(strain < change - 1e-9)[-1])
    at = int(np.argmin(np.abs(strain - change)))
    s_old = model.shear_direction(series["direction_deg"][before])
    shear = np.einsum("i,nij,j->n", s_old, series["A"], np.array([0.0, 1.0, 0.0]))
    fabric, band = [], []
    for g in gammas:
        k = int(np.argmin(np.abs(strain - change - g)))
        near = abs(strain[k] - change - g) < TOLERANCE
        fabric.append(float(shear[k] / shear[before]) if near else np.nan)
        band.append(float((series["strain_bulk"][k] - series["strain_bulk"][at]) / (strain[k] - strain[at]))
                    if near else np.nan)
    window = (strain > change + 1e-9) & (strain <= change + WALL_WINDOW + 1e-9)
    wall = float(np.min(1.0 + series["wall_stress_error"][window])) if window.any() else np.nan
    return {"change": change, "fabric": fabric, "band": band, "wall_min": wall}


def run_profiles(run, gammas=GAMMAS) -> list[dict]:
    """``change_profile`` at every change of direction of a run (the one ending the preceding half period too)."""
    series = {**run.series_all, "direction_deg": run.raw_all["direction_deg"],
              "wall_stress_error": run.raw_all["wall_stress_error_mean"]}
    return [change_profile(series, c, gammas) for c in direction_changes(run.spec)]


def setting_label(run) -> str:
    """The run's preset, its engine where it is not Yade, its overrides but the seed (runs of one setting differ
    only by their seed), and whether it has dense samples (its band strain right after a change is resolved; on
    the 0.005 grid alone the trapezoid over the first interval averages the old and the new direction's flow)."""
    rest = {k: v for k, v in sorted(run.overrides.items()) if k != "seed"}
    dense = run.spec.dense_window_strain > 0
    engine = "" if run.engine == "yade" else f" {run.engine}"
    return (run.spec.preset + engine + "".join(f" {k}={v:g}" for k, v in rest.items())
            + (" (dense)" if dense else ""))


def mean_and_error(values) -> tuple[float, float, int]:
    v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
    if not len(v):
        return np.nan, np.nan, 0
    return float(v.mean()), float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else np.nan, len(v)


def summarise(runs: list) -> dict:
    """Per (setting, angle): runs, changes, and every measure's mean, standard error and count."""
    groups = {}
    for run in runs:
        key = (setting_label(run), f"{run.theta_deg:g}", f"{run.spec.rotate_at_strain:g}")
        groups.setdefault(key, []).append((run, run_profiles(run)))
    out = []
    for (label, theta, rotate_at), members in sorted(groups.items()):
        profiles = [p for _, ps in members for p in ps]
        row = {"setting": label, "theta_deg": float(theta), "rotate_at": float(rotate_at),
               "runs": [str(r.path) for r, _ in members], "changes": len(profiles),
               "seeds": sorted({int(r.spec.seed) for r, _ in members}),
               "dense": any(r.spec.dense_window_strain > 0 for r, _ in members)}
        for name in ("fabric", "band"):
            row[name] = [dict(zip(("mean", "se", "n"), mean_and_error([p[name][k] for p in profiles]), strict=True))
                         for k in range(len(GAMMAS))]
        row["wall_min"] = dict(zip(("mean", "se", "n"), mean_and_error([p["wall_min"] for p in profiles]),
                                   strict=True))
        out.append(row)
    return {"gammas": list(GAMMAS), "settings": out, "model": model_fabric()}


def model_fabric(theta_deg: float = 180.0) -> list[float]:
    """The paper's model (Table 2): the same fabric fraction after the change at half the period."""
    half = model.ROTATE_AT_STRAIN
    cycle = model.predict(theta_deg, times=[half - 1e-9, *(half + g for g in GAMMAS)])
    before = cycle.A[0, 0, 1]
    return [float(a / before) for a in cycle.A[1:, 0, 1]]


def cell(m: dict) -> str:
    """``mean ± se`` of a ``mean_and_error`` dict; empty without values."""
    if not m["n"]:
        return ""
    return f"{m['mean']:.3f}" + (f" ± {m['se']:.3f}" if np.isfinite(m["se"]) else "")


def markdown(summary: dict) -> str:
    gammas = summary["gammas"]
    lines = ["# The reversal jump", "",
             "Per setting (overrides but the seed) and angle: the fabric's shear component in the frame of the "
             "direction before each change, as a fraction of its value just before it (mean ± standard error "
             "over runs and changes), at each nominal strain γ after the change; the lowest wall normal stress "
             "over p within 0.01 strain; the central band's strain per unit nominal strain over the first γ. "
             "Empty: no sample at that γ (runs without dense sampling start at 0.005).", "",
             "## Fabric fraction", "",
             "| setting | θ | rotate at | runs | changes | " + " | ".join(f"γ = {g:g}" for g in gammas)
             + " | min σ_wall/p |", "|" + "---|" * (len(gammas) + 6)]
    for r in summary["settings"]:
        lines.append(f"| {r['setting']} | {r['theta_deg']:g} | {r['rotate_at']:g} | {len(r['runs'])} | "
                     f"{r['changes']} | " + " | ".join(cell(m) for m in r["fabric"]) + f" | {cell(r['wall_min'])} |")
    lines.append("| Table 2 model | 180 | 0.7 | | | " + " | ".join(f"{v:.3f}" for v in summary["model"]) + " | |")
    lines += ["", "## Band strain per nominal strain over the first γ", "",
              "| setting | θ | rotate at | " + " | ".join(f"γ = {g:g}" for g in gammas) + " |",
              "|" + "---|" * (len(gammas) + 3)]
    for r in summary["settings"]:
        lines.append(f"| {r['setting']} | {r['theta_deg']:g} | {r['rotate_at']:g} | "
                     + " | ".join(cell(m) for m in r["band"]) + " |")
    return "\n".join(lines) + "\n"


def every_run() -> list[Path]:
    """Every DEM file of the committed data and results/ (results/ first where both hold one path)."""
    seen, out = set(), []
    for root in DATA_ROOTS:
        for path in globbed(root, "*/dem/*.h5"):
            if path.relative_to(root) not in seen:
                seen.add(path.relative_to(root))
                out.append(path)
    return out


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.jump", description=__doc__.splitlines()[0])
    parser.add_argument("--runs", nargs="*", type=Path, help="DEM files (default: every run found)")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "jump")
    args = parser.parse_args(argv)
    out = io.check_writable_dir(args.out)
    paths = args.runs or every_run()
    if not paths:
        raise PipelineError("no DEM run found: make dem first")
    runs = [load(p) for p in paths]
    summary = summarise([r for r in runs if direction_changes(r.spec)])
    print(f"wrote {io.write_table(out, 'jump', summary, markdown(summary))} and jump.json ({len(runs)} runs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
