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

from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..dataset.dem_file import load
from ..dataset.options import definitions_from
from ..errors import CalibrationError
from ..paths import check_folder_name, preset_output
from .calibrate import Settings, fit, parse_hold
from .inputs import runs_of
from .naming import fit_folder
from .options import add_fit_arguments
from .text import print_report


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration", description=__doc__.splitlines()[0])
    selection.add_arguments(parser, "preset whose runs to fit")
    add_fit_arguments(parser)
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
