"""``make fit``: calibrate the model on a preset's DEM runs and write ``results/<preset>/fit/``.

``python -m pipeline.calibration [--preset P] [--engine E] [--set K=V] [--runs a.h5 ...] [--window 0.05]
[--fit-from 0.005] [--out DIR] [--angles 180 90 ...] [--bootstrap N] [--jackknife [seeds|angles]]
[--hold NAME=VALUE] [--weight runs|angles]``. Without
``--preset``, the most faithful preset that has a reversal run is used, and named; the runs are the preset's data set
(``pipeline.dataset.selection``), the outputs go to ``results/<its folder>/fit``. The work is
``calibrate.calibrate``; outputs ``calibrate.write``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import model

from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..dataset.dem_file import load
from ..dataset.options import add_definition_arguments, definitions_from
from ..errors import CalibrationError
from ..paths import check_folder_name, preset_output
from . import global_fit
from .calibrate import JACKKNIFE_OVER, Settings, fit, parse_hold
from .inputs import runs_of
from .naming import fit_folder
from .options import add_weight_argument
from .text import print_report


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration", description=__doc__.splitlines()[0])
    selection.add_arguments(parser, "preset whose runs to fit")
    parser.add_argument("--runs", nargs="*", type=Path, help="reversal DEM files to fit instead of the preset's")
    parser.add_argument("--window", type=float, default=0.05, help="Savitzky-Golay window in strain (default 0.05)")
    parser.add_argument("--out", type=Path, help="output folder (default results/<preset>/fit)")
    add_definition_arguments(parser)
    parser.add_argument("--hold", action="append", default=[], metavar="NAME=VALUE",
                        help="hold a flow-rule or fabric parameter at VALUE instead of fitting it (repeatable)")
    parser.add_argument("--jackknife", nargs="?", const="seeds", default="", choices=JACKKNIFE_OVER,
                        help="also refit leaving out one reversal seed (seeds, the default; needs 3 or more) or one "
                             "angle with all its runs (angles; needs 3 or more) at a time; the outputs go to "
                             "results/<data set>/fit-jackknife-<over>[-from<STRAIN>][-<stress>]/")
    parser.add_argument("--fit-from", type=float, default=0.0, metavar="STRAIN",
                        help="restart the model from the DEM's state this far past each change of direction and "
                             "fit what follows (nominal strain, a multiple of the sampling step; default 0: all)")
    parser.add_argument("--persistence-exponent", type=float, default=0.75, metavar="K",
                        help="k of Lambda = S^k (Eq. 12), held (default 3/4, the paper's)")
    parser.add_argument("--stress", default=global_fit.STRESS_DEFAULT, choices=sorted(global_fit.STRESS_FITS),
                        help="the components of tau/p fitted: shear (12, 32: tau:D'; the paper's, default) or all "
                             "(the diagonal too, which carries normal-stress differences the model does not give)")
    add_weight_argument(parser)
    parser.add_argument("--variant", default=model.params.DEFAULT_VARIANT, choices=list(model.params.VARIANTS),
                        help="the fabric law fitted: rk2025 (Eq. 13, default) or a variant beyond it (docs/model.md); "
                             "its added parameters are fitted with the others")
    parser.add_argument("--angles", nargs="+", type=float, metavar="THETA",
                        help="fit only the data set's runs at these angles (degrees, 180 among them); the outputs "
                             "go to results/<data set>/fit-angles-<thetas>[-from<STRAIN>][-<stress>]/")
    parser.add_argument("--bootstrap", type=int, metavar="N",
                        help="also refit N >= 2 resamplings of the cycles (bootstrap standard deviations)")
    args = parser.parse_args(argv)
    if args.bootstrap is not None and args.bootstrap < 2:
        raise CalibrationError(f"bootstrap={args.bootstrap}: a bootstrap needs at least 2 resamples")
    settings = Settings(args.window, definitions_from(args), parse_hold(args.hold), args.fit_from,
                        args.persistence_exponent, args.bootstrap or 0, args.jackknife, args.stress, args.weight,
                        args.variant)
    if args.runs and args.angles:
        raise CalibrationError("--angles chooses among a data set's runs: give it without --runs")
    if args.runs:
        reversals, cross, left_out = [load(p) for p in args.runs], (), ()
        out = args.out or preset_output(check_folder_name(args.preset or "custom"), "fit")
        data_set = {"data_set": "runs given", "skip_cycles": 0}
    else:
        chosen = selection.from_arguments(args)
        print(f"runs: {chosen.label}")
        reversals, cross, left_out = runs_of(chosen, args.angles)
        out = args.out or preset_output(chosen.folder, fit_folder(
            args.angles, args.jackknife, fit_from=args.fit_from, stress=args.stress, weight=args.weight,
            variant=args.variant, skip_cycles=chosen.skip_cycles))
        data_set = {"data_set": chosen.folder, "skip_cycles": chosen.skip_cycles}
    print(f"definitions: {settings.definitions.label()}")
    report = fit(reversals, out, cross, left_out, data_set=data_set, **vars(settings))
    print_report(report, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
