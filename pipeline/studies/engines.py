"""Yade against LAMMPS on one spec: the cross-validation of the two DEM engines.

``python -m pipeline.studies.engines [--preset reduced] [--out results/engines]`` (``make engines``) reads each
engine's runs of the preset (``<preset>/`` for Yade, ``<preset>-lammps/`` for LAMMPS, seed variants included): the
reversals (theta = 180) and the theta = 90 runs, at the default rotation. Per run, with the fidelity study's
measures (``pipeline.studies.fidelity.summary``): the steady values before each change of direction (tau12/p as
``mu``, |A|, A12 as ``A_aligned``, Phi of the central band and of the gap), the central band's strain per nominal
strain, the fabric's shear component after each change as a fraction of its value before it (``make jump``'s
measure) at gamma = 0.0005 ... 0.5 (below 0.005 from the runs with dense samples), and, for the reversals, the
global fit on the run alone in the paper's definitions.

Each quantity's mean over an engine's runs, its standard error from their scatter (seeds are independent), and
the difference in combined standard errors, ``z = (LAMMPS - Yade) / sqrt(se_Y^2 + se_L^2)``. With a few seeds per
engine z is a Welch t statistic, not a normal one: the engines agree on a quantity when |z| is below Welch's
two-sided 95 % critical value at the Welch-Satterthwaite degrees of freedom (about 2.2 with six seeds each, 4.3
with two and two). Of twenty quantities that truly agree, about one falls outside by chance. Writes
``engines.md`` and ``engines.json``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from scipy import stats

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset.derived import Definitions, bulk_over_nominal
from ..dataset.lookup import engine_folder, load_of_preset
from ..errors import PipelineError
from ..paths import DATA_ROOTS, RESULTS_DIR, preset_files
from ..runs.spec import ENGINES
from .fidelity.summary import PAPER_DEFINITIONS, own_fit, steady_values
from .jump import mean_and_error, run_profiles

TRANSIENT_GAMMAS = (0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5)
STEADY = {"mu": "τ12/p", "A_norm": "|A|", "A_aligned": "A12", "phi_central": "Φ band", "phi_gap": "Φ gap"}
FIT_NAMES = ("C", "n", "a1", "a2", "b1", "b2")
#: two-sided level of the agreement test
LEVEL = 0.95


def run_measures(run, fit: bool) -> dict:
    """One run's measures (see the module's doc), each a number (NaN where the run cannot give it)."""
    steady = steady_values(run)
    out = {label: steady[key]["mean"] for key, label in STEADY.items()}
    out["band strain / nominal"] = bulk_over_nominal(run.with_definitions(Definitions(strain="bulk")))
    profiles = run_profiles(run, TRANSIENT_GAMMAS)
    for k, g in enumerate(TRANSIENT_GAMMAS):
        values = [p["fabric"][k] for p in profiles if np.isfinite(p["fabric"][k])]
        out[f"A fraction at γ = {g:g}"] = float(np.mean(values)) if values else math.nan
    if fit:
        result = own_fit(run.with_definitions(PAPER_DEFINITIONS))
        for name in FIT_NAMES:
            out[f"fit {name}"] = result.get("values", {}).get(name, math.nan)
    return out


def engine_runs(preset: str, engine: str, theta: float, roots=DATA_ROOTS) -> list:
    """An engine's runs of ``preset`` at ``theta``, default rotation, no override but the seed."""
    runs = [load_of_preset(p, preset) for p in preset_files(engine_folder(preset, engine), roots)
            if p.stem == f"theta{int(theta):03d}"]
    return [r for r in runs if r.engine == engine and r.default_rotation and set(r.overrides) <= {"seed"}]


def welch_critical(a: dict, b: dict) -> float:
    """Welch's two-sided ``LEVEL`` critical value of t for two means with standard errors ``se`` from ``n`` runs."""
    va, vb = a["se"] ** 2, b["se"] ** 2
    if not (a["n"] > 1 and b["n"] > 1 and va + vb > 0):
        return math.nan
    dof = (va + vb) ** 2 / (va**2 / (a["n"] - 1) + vb**2 / (b["n"] - 1))
    return float(stats.t.ppf(0.5 + LEVEL / 2, dof))


def compare(measures: dict) -> list[dict]:
    """Per quantity: each engine's mean, standard error and runs, and z (``measures[engine]`` is a list of the
    runs' measure dicts)."""
    rows = []
    names = list(next(iter(m for m in measures.values() if m))[0]) if any(measures.values()) else []
    for name in names:
        row = {"quantity": name}
        for engine in ENGINES:
            row[engine] = dict(zip(("mean", "se", "n"), mean_and_error([m[name] for m in measures[engine]]),
                                   strict=True))
        a, b = row[ENGINES[0]], row[ENGINES[1]]
        combined = math.hypot(a["se"], b["se"])
        row["z"] = (b["mean"] - a["mean"]) / combined if combined > 0 else math.nan
        row["critical"] = welch_critical(a, b)
        row["agree"] = bool(abs(row["z"]) < row["critical"]) if math.isfinite(row["z"]) else None
        rows.append(row)
    return rows


def summarise(runs: dict, fits: bool = True) -> dict:
    """The comparison of ``runs[theta][engine]`` (lists of runs), the reversals' own fits with ``fits``."""
    groups = {}
    for theta, by_engine in runs.items():
        measures = {engine: [run_measures(r, fit=fits and theta == "180") for r in by_engine[engine]]
                    for engine in ENGINES}
        groups[theta] = {"seeds": {e: len(m) for e, m in measures.items()}, "rows": compare(measures)}
    return {"engines": list(ENGINES), "gammas": list(TRANSIENT_GAMMAS), "level": LEVEL, "groups": groups}


def cell(m: dict) -> str:
    if not m["n"]:
        return ""
    return f"{m['mean']:.4g}" + (f" ± {m['se']:.2g}" if np.isfinite(m["se"]) else "") + f" ({m['n']})"


def markdown(summary: dict) -> str:
    yade, lammps = summary["engines"]
    lines = ["# Yade against LAMMPS", "",
             f"Preset `{summary['preset']}`. Per quantity: each engine's mean over its runs ± the standard error "
             "from their scatter (runs in brackets), and z = (LAMMPS − Yade) / combined standard error; the engines "
             f"agree at these seeds where |z| is below Welch's two-sided {summary['level']:.0%} critical value t* "
             "(about one quantity in twenty falls outside by chance). Steady values over the 0.3 strain before "
             "each change of direction; A fraction: the fabric's shear component after a change over its value "
             "before it; fit: the global fit on each reversal alone, in the paper's definitions (nominal strain, Φ "
             "of the gap)."]
    for theta, group in summary["groups"].items():
        lines += ["", f"## θ = {theta}° ({group['seeds'][yade]} Yade runs, {group['seeds'][lammps]} LAMMPS runs)", "",
                  f"| quantity | {yade} | {lammps} | z | t* | agree |", "|---|---|---|---|---|---|"]
        for r in group["rows"]:
            z = f"{r['z']:+.2f}" if math.isfinite(r["z"]) else ""
            agree = {True: "yes", False: "**no**", None: ""}[r["agree"]]
            critical = f"{r['critical']:.2f}" if math.isfinite(r["critical"]) else ""
            lines.append(f"| {r['quantity']} | {cell(r[yade])} | {cell(r[lammps])} | {z} | {critical} | {agree} |")
    return "\n".join(lines) + "\n"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.engines", description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="reduced")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "engines")
    parser.add_argument("--no-fit", action="store_true", help="leave out the reversals' own fits (minutes)")
    args = parser.parse_args(argv)
    out = io.check_writable_dir(args.out)
    runs = {f"{theta:g}": {engine: engine_runs(args.preset, engine, theta) for engine in ENGINES}
            for theta in (180.0, 90.0)}
    missing = [engine for engine in ENGINES if len(runs["180"][engine]) < 2]
    if missing:
        raise PipelineError(f"{' and '.join(missing)} need(s) two or more reversals of preset {args.preset}: make dem "
                            f"THETA=180 PRESET={args.preset} ENGINE={missing[0]} SET=seed=2 (and more seeds)")
    summary = {"preset": args.preset, **summarise(runs, fits=not args.no_fit)}
    print(f"wrote {io.write_table(out, 'engines', summary, markdown(summary))} and engines.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
