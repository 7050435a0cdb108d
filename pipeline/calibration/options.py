"""Command-line options the calibration's entry points share (``make fit``, ``fit-definitions``, ``fit-from``,
``fit-profile``)."""

from pathlib import Path

import model

from .. import choices
from ..dataset.options import add_definition_arguments
from ..paths import preset_output
from . import global_fit
from .naming import fit_folder


def add_weight_argument(parser) -> None:
    """--weight: how a protocol's runs share the fit (``global_fit.WEIGHTS``)."""
    parser.add_argument("--weight", default=global_fit.WEIGHT_DEFAULT, choices=global_fit.WEIGHTS,
                        help="runs: each run counts once (an angle with three seeds pulls three times as hard; "
                             "default); angles: each angle (protocol) counts once, its seeds' residuals averaged, "
                             "as in the paper's one run per angle")


def weighted_label(label: str, weight: str) -> str:
    """A data set's label, and how its runs were weighted where not the default."""
    return label if weight == global_fit.WEIGHT_DEFAULT else f"{label}, each angle counted once"


def table_folder(chosen, weight: str) -> Path:
    """Where a table of fits of the data set ``chosen`` (``make fit-definitions``, ``fit-from``, ``fit-profile``)
    goes by default: the folder of ``make fit`` with the same weighting and skipped cycles, so that no other
    option's table replaces it."""
    return preset_output(chosen.folder, fit_folder(weight=weight, skip_cycles=chosen.skip_cycles))


def add_fit_arguments(parser) -> None:
    """The options of ``make fit`` (``python -m pipeline.calibration``) beside the data set's."""
    parser.add_argument("--runs", nargs="*", type=Path, help="reversal DEM files to fit instead of the preset's")
    parser.add_argument("--window", type=float, default=0.05, help="Savitzky-Golay window in strain (default 0.05)")
    parser.add_argument("--out", type=Path, help="output folder (default results/<preset>/fit)")
    add_definition_arguments(parser)
    parser.add_argument("--hold", action="append", default=[], metavar="NAME=VALUE",
                        help="hold a flow-rule or fabric parameter at VALUE instead of fitting it (repeatable)")
    parser.add_argument("--jackknife", nargs="?", const="seeds", default="", choices=choices.JACKKNIFE_OVER,
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
