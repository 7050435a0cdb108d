"""``make fit``: calibrate the model on a preset's DEM runs and write ``results/<preset>/fit/``.

``python -m pipeline.calibration [--preset P] [--runs a.h5 ...] [--window 0.05] [--fit-from 0.005] [--out DIR]
[--bootstrap N] [--jackknife] [--hold NAME=VALUE]``. Without ``--preset``, the most faithful preset that has a
reversal run is used, and named. The work is ``calibrate.calibrate``; outputs ``calibrate.write``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..cli import Parser, one_line_errors
from ..dataset.dem_file import load
from ..dataset.lookup import engine_folder, other_angles, preset_runs, reversal_seeds
from ..dataset.options import add_definition_arguments, definitions_from
from ..errors import CalibrationError
from ..paths import check_folder_name, preset_output
from .calibrate import Settings, default_preset, fit, parse_hold
from .text import print_report


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration", description=__doc__.splitlines()[0])
    parser.add_argument("--preset", help="preset whose runs to fit (default: the most faithful one with runs)")
    parser.add_argument("--engine", default="yade", help="the DEM engine whose runs to fit: yade (default) or lammps "
                        "(results/<preset>-lammps/fit)")
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
    settings = Settings(args.window, definitions_from(args), parse_hold(args.hold), args.fit_from,
                        args.persistence_exponent, args.bootstrap or 0, args.jackknife)
    if args.runs:
        reversals, cross, left_out = [load(p) for p in args.runs], (), ()
        out = args.out or preset_output(check_folder_name(args.preset or "custom"), "fit")
    else:
        preset = args.preset or default_preset()
        if args.preset is None:
            print(f"preset: {preset} (the most faithful one with a reversal run; --preset / PRESET= to choose)")
        out = args.out or preset_output(engine_folder(preset, args.engine), "fit")
        every = preset_runs(preset, engine=args.engine)
        reversals, cross = reversal_seeds(preset, engine=args.engine), tuple(other_angles(every))
        if not reversals:
            raise CalibrationError(f"no reversal run found of preset {preset} in {args.engine}: run `make dem "
                                   f"THETA=180 PRESET={preset} ENGINE={args.engine}` first")
        left_out = tuple(r for r in every if not r.default_rotation)
    print(f"definitions: {settings.definitions.label()}")
    report = fit(reversals, out, cross, left_out, **vars(settings))
    print_report(report, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
