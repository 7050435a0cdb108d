"""``python -m pipeline.figures [--preset reduced] [--params FILE]``: Figs. 3-9 and report.md."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import model

from ..dem_h5 import DemFileError, load
from ..paths import REFERENCE_DIR, RESULTS_DIR, first_existing
from . import cycles, laws, report, reversal


def dem_runs(preset: str, roots=(RESULTS_DIR, REFERENCE_DIR)) -> list:
    names = sorted({p.name for root in roots for p in (root / preset / "dem").glob("theta*.h5")})
    return [load(first_existing(Path(preset) / "dem" / name, roots)) for name in names]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pipeline.figures", description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="reduced")
    parser.add_argument("--params", type=Path, help="fitted parameters (default results/<preset>/fit/params.json)")
    parser.add_argument("--runs", nargs="+", type=Path, help="DEM files to show instead of the preset's")
    parser.add_argument("--out", type=Path, help="output folder (default results/<preset>)")
    args = parser.parse_args(argv)
    out = args.out or RESULTS_DIR / args.preset
    params_file = args.params or RESULTS_DIR / args.preset / "fit" / "params.json"
    try:
        runs = [load(p) for p in args.runs] if args.runs else dem_runs(args.preset)
        if not runs:
            raise DemFileError(f"no DEM run of preset {args.preset!r}: run `make dem PRESET={args.preset}` first")
        fitted = model.Params.load(params_file)
    except (DemFileError, model.ParameterError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    sets = {"Table 2": model.Params(), "our fit": fitted}
    default = [r for r in runs if abs(r.spec["rotate_at_strain"] - r.spec["period_strain"] / 2) < 1e-9]
    rotated = [r for r in runs if r not in default]
    made = [cycles.plot(default, sets, out / "figures" / "fig5_6_cycles.png", f"{args.preset}: Figs. 5-6")]
    if rotated:
        made.append(cycles.plot(rotated, sets, out / "figures" / "fig7_rotations.png", f"{args.preset}: Fig. 7"))
    fit_h5 = params_file.with_name("fit.h5")
    if fit_h5.exists():
        made.append(laws.fabric_law(fit_h5, fitted, model.Params(), out / "figures" / "fig3_fabric_law.png"))
        made.append(laws.flow_rule(fit_h5, fitted, model.Params(), out / "figures" / "fig4_flow_rule.png"))
        made.append(reversal.backstress_figure(fit_h5, fitted.C, out / "figures" / "fig8_backstress.png"))
    reversals = [r for r in runs if abs(abs(r.spec["theta_deg"]) - 180) < 1e-9]
    if reversals:
        made.append(reversal.work_figure(reversals, fitted, out / "figures" / "fig9_work_rates.png"))
    fit_report = params_file.with_name("fit.json")
    fit_json = json.loads(fit_report.read_text()) if fit_report.exists() else None
    made.append(report.write(runs, sets, fit_json, out / "report.md", args.preset,
                             fit_h5 if fit_h5.exists() else None))
    for path in made:
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
