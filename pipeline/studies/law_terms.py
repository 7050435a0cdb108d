"""Each fitted law's own terms after a change of direction, beside the DEM's contact budget (``make budget``): on
the law's periodic cycle of the protocol, the rates per unit nominal strain of its input, recovery, spin and own
state's part (``model.terms``) on the memory fraction (the shear fraction where the turn has no normal part), in
the budget's windows and frame (``pipeline.studies.budget``). The DEM's exchange (made + lost) is what its contacts
made and lost carry, against a law's input and recovery; its kept, what the contacts that stay carry, against the
spin and the own state's part. A law whose total follows the DEM's with other terms fits the sum with the wrong
terms. The laws are ``make models``' fits on every run (its ``models.json``), or parameter files.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

import model
from model.terms import fabric_terms

from .. import io

#: the terms of a law's rate (``model.terms.FabricTerms``) and their sum
TERMS = ("input", "recovery", "spin", "own", "total")
#: the sampling of a law's cycle after the change (nominal strain): the budget's first window is 0.0005 wide
SAMPLE = 0.00025


@dataclasses.dataclass(frozen=True)
class TermRates:
    """A law's rates per unit nominal strain of the followed fraction over one window, per term (``TERMS``)."""

    input: float
    recovery: float
    spin: float
    own: float
    total: float

    def text(self) -> str:
        return " / ".join(f"{getattr(self, t):+.2f}" for t in TERMS)


@dataclasses.dataclass(frozen=True)
class LawTerms:
    """One law's ``TermRates`` in each of the budget's windows after the turn to theta, on its own cycle; ``error``
    where its cycle cannot be computed."""

    variant: str
    source: str
    windows: list[TermRates]
    error: str = ""


def fitted_laws(paths: list[Path] | None, models_folder: Path) -> tuple[list[tuple[model.Params, str]], list[Path]]:
    """The laws to set beside the DEM (each with where it came from) and the files read: the parameter files
    ``paths``, or else every law of ``make models``' ``models.json`` in ``models_folder`` (its fit on every run), or
    none where it has not run. A bad file is a one-line ``PipelineError``."""
    if paths is not None:
        return [(io.read_params(path), str(path)) for path in paths], list(paths)
    source = models_folder / "models.json"
    if not source.is_file():
        return [], []
    from ..schema.models import read_models

    return [(law.params, f"{source} ({law.variant})") for law in read_models(source).variants], [source]


def law_terms(params: model.Params, source: str, theta: float, rotate_at: float, windows,
              has_memory: bool) -> LawTerms:
    """``LawTerms`` of ``params`` (from ``source``) after the turn from 0 to ``theta`` at ``rotate_at``."""
    from .budget import BEFORE as before
    from .budget import E2, components, event_frame

    strains = np.arange(rotate_at - before, rotate_at + windows[-1][1] + SAMPLE / 2, SAMPLE)
    try:
        cycle = model.predict(theta, rotate_at=rotate_at, params=params, times=strains)
    except model.SolverError as exc:
        return LawTerms(params.variant, source, [], str(exc))
    after = strains >= rotate_at - 1e-12
    L = np.array([model.shear_velocity_gradient(theta)] * int(after.sum()))
    terms = fabric_terms(cycle.A[after], cycle.law_state[after], L, params)
    s_new, t, t_old = event_frame(0.0, theta)
    a0 = float(-model.shear_direction(0.0) @ cycle.A[~after].mean(axis=0) @ E2)
    gamma = strains[after] - rotate_at
    step = np.diff(gamma)
    part = 1 if has_memory else 0
    fractions = {}
    for name in TERMS[:-1]:
        increments = getattr(terms, name)[:-1] * step[:, None, None] / math.sqrt(2.0)  # d(|D'| t) = d gamma / sqrt2
        fractions[name] = components(increments, s_new, t, a0, t_old)[part]
    rates = []
    for lo, hi in windows:
        pick = (gamma[1:] > lo + 1e-9) & (gamma[1:] <= hi + 1e-9)
        values = {name: float(fractions[name][pick].sum() / step[pick].sum()) for name in TERMS[:-1]}
        rates.append(TermRates(**values, total=sum(values.values())))
    return LawTerms(params.variant, source, rates)


def markdown_rows(g, laws: list[LawTerms], first: int) -> list[str]:
    """The table of one budget group (``BudgetGroup``): per window from ``first``, the DEM's exchange, kept and total
    and each law's terms."""
    comp = "memory" if g.windows[0].memory else "shear"
    lines = [f"The laws' own terms on their cycles, rates of the {comp} fraction (input / recovery / spin / own / "
             "total; `pipeline/studies/law_terms.py`):", "",
             "| strain after | DEM exchange | kept | total | " + " | ".join(law.variant for law in laws) + " |",
             "|---|---|---|---|" + "---|" * len(laws)]
    for k, w in enumerate(g.windows[first:], start=first):
        r = getattr(w, comp)
        cells = [r[n].text(2, g.events) for n in ("exchange", "kept", "total")]
        cells += [law.windows[k].text() if law.windows else "no cycle" for law in laws]
        lines.append(f"| {w.lo:g}–{w.hi:g} | " + " | ".join(cells) + " |")
    return lines + [""]
