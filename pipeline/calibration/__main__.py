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

from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..dataset.dem_file import load
from ..dataset.lookup import every_seed, other_angles, reversals_of
from ..dataset.options import add_definition_arguments, definitions_from
from ..errors import CalibrationError
from ..paths import check_folder_name, preset_output
from . import global_fit
from .calibrate import JACKKNIFE_OVER, Settings, fit, parse_hold
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
    parser.add_argument("--angles", nargs="+", type=float, metavar="THETA",
                        help="fit only the data set's runs at these angles (degrees, 180 among them); the outputs "
                             "go to results/<data set>/fit-angles-<thetas>[-from<STRAIN>][-<stress>]/")
    parser.add_argument("--bootstrap", type=int, metavar="N",
                        help="also refit N >= 2 resamplings of the cycles (bootstrap standard deviations)")
    args = parser.parse_args(argv)
    if args.bootstrap is not None and args.bootstrap < 2:
        raise CalibrationError(f"bootstrap={args.bootstrap}: a bootstrap needs at least 2 resamples")
    settings = Settings(args.window, definitions_from(args), parse_hold(args.hold), args.fit_from,
                        args.persistence_exponent, args.bootstrap or 0, args.jackknife, args.stress, args.weight)
    if args.runs and args.angles:
        raise CalibrationError("--angles chooses among a data set's runs: give it without --runs")
    if args.runs:
        reversals, cross, left_out = [load(p) for p in args.runs], (), ()
        out = args.out or preset_output(check_folder_name(args.preset or "custom"), "fit")
    else:
        chosen = selection.from_arguments(args)
        print(f"runs: {chosen.label}")
        every = every_seed(chosen)
        reversals, cross = reversals_of(every), tuple(other_angles(every))
        if args.angles:
            cross = only_angles(args.angles, reversals, cross)
        out = args.out or preset_output(chosen.folder, folder_name(args.angles, args.jackknife, args.fit_from,
                                                                   args.stress, args.weight))
        if not reversals:
            given = f' SET="{" ".join(chosen.settings)}"' if chosen.settings else ""
            raise CalibrationError(f"no reversal run of {chosen.label}: run `make dem THETA=180 "
                                   f"PRESET={chosen.preset} ENGINE={chosen.engine}{given}` first")
        left_out = tuple(r for r in every if not r.default_rotation)
    print(f"definitions: {settings.definitions.label()}")
    report = fit(reversals, out, cross, left_out, **vars(settings))
    print_report(report, out)
    return 0


def folder_name(angles: list[float] | None, jackknife: str, fit_from: float, stress: str,
                weight: str = global_fit.WEIGHT_DEFAULT) -> str:
    """The fit's folder in the data set's results: ``fit`` (``make fit`` keeps its options in ``fit/options.txt``),
    or beside it ``fit-angles-<thetas>`` or ``fit-jackknife-<over>``, with ``-from<FIT_FROM>``, ``-<STRESS>`` and
    ``-per-angle`` (``WEIGHT=angles``) when not the defaults, so that no fit replaces another's files."""
    if angles:
        name = "fit-angles-" + "-".join(f"{theta:g}" for theta in angles)
    elif jackknife:
        name = f"fit-jackknife-{jackknife}"
    else:
        return "fit"
    return name + (f"-from{fit_from:g}" if fit_from else "") + (
        f"-{stress}" if stress != global_fit.STRESS_DEFAULT else "") + (
        f"-per-{weight.removesuffix('s')}" if weight != global_fit.WEIGHT_DEFAULT else "")


def only_angles(angles: list[float], reversals: list, cross: tuple) -> tuple:
    """The runs of ``cross`` at ``angles`` (degrees), after checking that each angle has a run and that the
    reversal (180) is among them: the global fit needs it."""
    present = {180.0} if reversals else set()
    present |= {r.theta_deg for r in cross}
    for theta in angles:
        if theta not in present:
            raise CalibrationError(f"angles: no run at theta = {theta:g} (the data set has "
                                   f"{', '.join(f'{t:g}' for t in sorted(present))})")
    if 180.0 not in angles:
        raise CalibrationError(f"angles={' '.join(f'{t:g}' for t in angles)}: the fit needs the reversal, 180")
    return tuple(r for r in cross if r.theta_deg in angles)


if __name__ == "__main__":
    sys.exit(main())
