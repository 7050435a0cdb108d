"""The DEM on stiff and extreme cases (``make stability``): each runs and passes its checks, or stops with
the scene's diagnostic and a non-zero exit; none may give NaN or silent nonsense.

``python -m pipeline.studies.stability [--cases a,b] [--out results/fidelity]`` runs every case of
``CASES`` (small cells, one after another, one thread) into ``results/stability/`` and writes
``stability.md`` and ``stability.json``. Cases past the run spec's bounds (a time step beyond
``dt_safety`` = 0.5) are run with the bound lifted, to find where the integration fails and show that
the scene then stops cleanly; the spec itself refuses them. Checks on a finished run: every sample
finite; the wall stress held (the largest error of a sample's mean, after the first 0.05 strain); the
steady tau12/p along the shear; at theta = 0 the fabric at its steady value throughout (A12 drift); and
an energy balance over 0.1 strain of the same scene (``dem/tools/yade_energy.py``: the walls' work against the
contacts' dissipation plus the change of kinetic and elastic energy) closing within ``ENERGY_TOLERANCE``
of the energy passing through.
The scene itself stops a run whose measurements or grains are not finite, a grain that escapes the
walls, a gap that runs away and a wall stress off target (``dem/core/checks.py``), with exit status 3.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import io
from .. import spec as run_spec
from ..cli import Parser, one_line_errors
from ..dataset.dem_file import load
from ..errors import PipelineError
from ..paths import RESULTS_DIR
from ..runs import launch, scripts
from ..runs.state import FAILED

RUNS_DIR = RESULTS_DIR / "stability"
ENERGY_STRAIN = 0.1
ENERGY_TOLERANCE = 0.02  # of the energy passing through: the accounting closes within 0.5 % on the tiny cell


@dataclass(frozen=True)
class Case:
    label: str
    what: str
    preset: str = "tiny"
    theta_deg: float = 180.0
    overrides: dict = field(default_factory=dict)
    unchecked: dict = field(default_factory=dict)  # values past the spec's bounds, set after validation
    allow_inertial: bool = False


PHYSICAL_SMALL = {"width_d": 4.0, "gap_d": 3.4, "region_margin_d": 1.0}  # the quick physics in a 4d cell

CASES = (
    Case("baseline", "the tiny preset as it is"),
    Case("theta0", "no rotation (theta = 0): the fabric must stay at its steady value", theta_deg=0.0),
    Case("stiff", "very stiff grains, delta/d = 1e-4", overrides={"overlap_ratio": 1e-4}),
    Case("inertial", "beyond quasi-static, I = 1e-2", overrides={"inertial_number": 1e-2}, allow_inertial=True),
    Case("frictionless", "frictionless grains (0 deg)", overrides={"friction_deg": 0.0}),
    Case("frictional", "very frictional grains (45 deg)", overrides={"friction_deg": 45.0}),
    Case("restitution0.1", "restitution 0.1 (past the damping bound at this step)", unchecked={"restitution": 0.1}),
    Case("restitution0.9", "restitution 0.9", overrides={"restitution": 0.9}),
    Case("dt0.5", "time step at the spec's bound, dt_safety = 0.5", overrides={"dt_safety": 0.5}),
    Case("dt0.8", "dt_safety = 0.8 (past the bound)", unchecked={"dt_safety": 0.8}),
    Case("dt1.2", "dt_safety = 1.2 (past the bound)", unchecked={"dt_safety": 1.2}),
    Case("dt2.0", "dt_safety = 2.0 (past the bound; a lone contact's limit)", unchecked={"dt_safety": 2.0}),
    Case("small-physical", "a 4d x 3.4d cell with the quick preset's physics", preset="quick",
         overrides=PHYSICAL_SMALL),
)


def spec_of(case: Case) -> run_spec.DemSpec:
    """The case's spec; its ``unchecked`` values put in past the bounds that ``resolve`` enforces."""
    spec = run_spec.resolve(case.theta_deg, case.preset, overrides=case.overrides, allow_inertial=case.allow_inertial)
    return dataclasses.replace(spec, folder=f"{case.preset}-{case.label}",
                               overrides={**spec.overrides, **case.unchecked}, **case.unchecked)


def checks(path: Path) -> dict:
    """What a finished run shows: finite samples, the wall stress held, steady tau12/p, the fabric drift."""
    run = load(path)
    raw, s = run.raw, run.series
    finite = all(np.all(np.isfinite(raw[k])) for k in ("stress_contact", "fabric", "packing_fraction", "gap"))
    strain = s["strain_nominal"]
    late = strain > strain[0] + 0.05
    wall = float(np.max(np.abs(raw["wall_stress_error_mean"][late])))
    tail = strain > strain[-1] - 0.3 * run.spec.period_strain / 2
    out = {"finite": bool(finite), "max_wall_stress_error": wall, "steady_tau12": float(np.mean(s["w_shear"][tail]))}
    if run.spec.theta_deg == 0.0:  # the last half of the run, past the transient from compaction
        A12 = s["A"][:, 0, 1][strain >= strain[-1] / 2]
        out["A12_drift"] = float(np.max(A12) - np.min(A12))
        out["A12_noise"] = float(np.std(np.diff(A12)) / np.sqrt(2))
    return out


def energy_balance(spec: run_spec.DemSpec, strain: float = ENERGY_STRAIN) -> dict:
    """``dem/tools/yade_energy.py`` on ``spec`` in a scratch folder: every term of the balance, or the scene's
    diagnostic."""
    try:
        return scripts.run_script("dem.tools.yade_energy", spec, (strain, scripts.OUT))
    except PipelineError as exc:
        return {"error": str(exc)}


def run_case(case: Case, results: Path = RUNS_DIR, energy_strain: float = ENERGY_STRAIN) -> dict:
    """Run ``case`` fresh, check its samples and close its energy balance over ``energy_strain`` of shear."""
    spec = spec_of(case)
    row = {"case": case.label, "what": case.what, "preset": case.preset, "theta_deg": case.theta_deg,
           "settings": {**case.overrides, **case.unchecked}}
    try:
        path = launch.run(spec, results, fresh=True)
    except SystemExit as exc:
        failed = run_spec.work_dir(spec, results) / FAILED
        reason = json.loads(failed.read_text())["reason"] if failed.exists() else f"exit status {exc.code}"
        return {**row, "outcome": "stopped", "exit_status": exc.code, "diagnostic": reason}
    result = checks(path)
    result["energy"] = energy_balance(spec, energy_strain)
    residual = result["energy"].get("relative_residual")
    held = result["max_wall_stress_error"] < spec.stress_alarm
    failures = [] if result["finite"] else ["not finite"]
    if not held:
        failures.append(f"wall stress off by up to {result['max_wall_stress_error']:.0%} (alarm "
                        f"{spec.stress_alarm:.0%}, unnoticed: it never lasted {spec.stress_alarm_strain} strain)")
    if residual is not None and abs(residual) > ENERGY_TOLERANCE:
        failures.append(f"energy balance off by {residual:+.0%}")
    verdict = "passed" if not failures else "ran, checks failed: " + "; ".join(failures)
    return {**row, "outcome": verdict, "exit_status": 0, **result}


def markdown(rows: list[dict]) -> str:
    lines = ["# The DEM on stiff and extreme cases", "",
             "`make stability`: each case ran (and passed the checks) or stopped with the scene's diagnostic and "
             "exit status 3. Wall stress: the largest |σ_wall/p − 1| of a sample's mean after the first 0.05 "
             "strain. Energy: (walls' work − dissipation − Δkinetic − Δelastic) / (energy passing through) over "
             f"{ENERGY_STRAIN} strain of the same scene, tolerance ±{ENERGY_TOLERANCE:.0%}. Cases past the spec's "
             "bounds were run with the bound lifted; `make dem` refuses them.", "",
             "| case | what | outcome | exit | wall stress error | steady τ12/p | energy balance | notes |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        notes = r.get("diagnostic", "")
        if "A12_drift" in r:
            notes = f"A12 range {r['A12_drift']:.4f} (sample noise {r['A12_noise']:.4f})"
        wall = f"{r['max_wall_stress_error']:.1%}" if "max_wall_stress_error" in r else ""
        tau = f"{r['steady_tau12']:.3f}" if "steady_tau12" in r else ""
        energy = r.get("energy") or {}
        balance = (f"{energy['relative_residual']:+.2%}" if energy.get("relative_residual") is not None else
                   energy.get("error", "no shear left" if energy else ""))
        lines.append(f"| {r['case']} | {r['what']} | {r['outcome']} | {r['exit_status']} | {wall} | {tau} | {balance} "
                     f"| {notes} |")
    return "\n".join(lines) + "\n"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.stability", description=__doc__.splitlines()[0])
    parser.add_argument("--cases", help="comma-separated case labels (default: all)")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "fidelity")
    args = parser.parse_args(argv)
    known = {c.label: c for c in CASES}
    chosen = args.cases.split(",") if args.cases else list(known)
    unknown = [c for c in chosen if c not in known]
    if unknown:
        raise PipelineError(f"unknown case(s) {', '.join(unknown)} (known: {', '.join(known)})")
    for label in chosen:  # every case's spec is checked before anything runs
        spec_of(known[label])
    out = io.check_writable_dir(args.out)
    rows = []
    for k, label in enumerate(chosen):
        print(f"[{k + 1}/{len(chosen)}] {label}: {known[label].what}", flush=True)
        rows.append(run_case(known[label]))
        print(f"  -> {rows[-1]['outcome']} {rows[-1].get('diagnostic', '')}", flush=True)
    print(f"wrote {io.write_table(out, 'stability', rows, markdown(rows))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
