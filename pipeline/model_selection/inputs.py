"""What ``make models`` judges on: a data set's runs read with ``make fit``'s definitions, the other data sets it
predicts across, and the laws asked for."""

from __future__ import annotations

import argparse

import model

from ..dataset import selection
from ..dataset.derived import PAPER_DEFINITIONS
from ..dataset.lookup import every_seed
from ..errors import CalibrationError


def read(chosen) -> list:
    """Every run of the data set ``chosen``, every seed, read with ``make fit``'s definitions (the paper's)."""
    return [r.with_definitions(PAPER_DEFINITIONS) for r in every_seed(chosen)]


def other_data_sets(chosen, across: list[str]) -> dict[str, list]:
    """The runs of each data set named ``P[:E]`` in ``across``; by default the most faithful other preset with a
    reversal run; none for ``none``."""
    if across == ["none"]:
        return {}
    if "none" in across:
        raise CalibrationError(f"--across {' '.join(across)}: none stands alone (no other data set)")
    if not across:
        across = [p for p in selection.PRESETS_BY_FIDELITY
                  if p != chosen.preset and selection.has_reversal(selection.data_set(p))][:1]
    out = {}
    for item in across:
        preset, _, engine = item.partition(":")
        other = selection.data_set(preset, engine or None)
        runs = read(other)
        if not any(r.is_reversal for r in runs):
            raise CalibrationError(f"--across {item}: the data set {other.label} has no reversal run")
        out[other.folder] = runs
    return out


def law_list(text: str) -> list[str]:
    """``--laws``: known law names, comma-separated, in the registry's order with Eq. 13's first."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    known = model.params.VARIANTS
    if not names or not set(names) <= set(known):
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of {', '.join(known)}")
    return [v for v in known if v in names or v == model.params.DEFAULT_VARIANT]
