"""Command-line options the calibration's entry points share (``make fit``, ``fit-definitions``, ``fit-from``,
``fit-profile``)."""

from pathlib import Path

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
