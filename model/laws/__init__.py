"""The fabric laws, each a module that owns its parameters and its compiled parts, chosen once by name.

A law is Eq. 13 (paper Table 1) with at most two parameters of its own, and reduces to it where they vanish
(``docs/model.md``, "Variants"). Its module declares ``NAME``, ``PARAMETERS`` (``Parameter`` records: name, the value
where the law is Eq. 13, where a fit starts, the closed range the law is bounded in, the meaning) and any of three
parts, each compiled with numba over the model's parameter array ``p`` (``Params.as_array``: Eq. 13's parameters,
the law's code, then its own, read at ``OWN + k``):

- ``removal``: what beta2 |D'| removes in place of A (Eq. 13's recovery term), packed (11, 22, 12, 13, 23);
- ``extra_rate``: a rate per unit |D'| t added beside the Jaumann spin (scaled by Lambda as it is), packed alike;
- ``offset``: kappa, where the fabric of Eqs. 14 and 18 is the state A plus kappa D'/|D'|;

and for the independent reference (``model.reference``, plain numpy on 3x3 tensors) the same three as
``reference_removal``, ``reference_extra`` and ``reference_offset``. A part a law leaves out is Eq. 13's (A, zero,
zero). The kernels call ``removal``, ``extra_rate`` and ``offset`` below, which branch on the law's code: nothing
outside this module asks which law it is. Adding a law is its module, its entry in ``LAWS`` and a branch in each of
the three parts it defines (``docs/extending.md``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..jit import jit
from . import jump, loading, memory, rk2025
from .parameter import OWN, Parameter

#: the registry: every fabric law, Eq. 13's first (its code is its place here)
LAWS = {law.NAME: law for law in (rk2025, loading, memory, jump)}
DEFAULT = rk2025.NAME
CODE = {name: float(k) for k, name in enumerate(LAWS)}
_LOADING, _MEMORY, _JUMP = CODE[loading.NAME], CODE[memory.NAME], CODE[jump.NAME]
LAW_INDEX = OWN - 1  # where the law's code sits in the parameter array

__all__ = ["DEFAULT", "LAWS", "OWN", "Parameter", "extra_rate", "law_parameters", "offset", "reference_parts",
           "removal"]


def law_parameters(name: str) -> tuple[Parameter, ...]:
    """The parameters law ``name`` owns (``KeyError`` for a law that is not registered)."""
    return LAWS[name].PARAMETERS


@jit
def removal(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p):
    """What beta2 |D'| removes (Eq. 13: A itself)."""
    code = p[LAW_INDEX]
    if code == _LOADING:
        return loading.removal(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p)
    if code == _MEMORY:
        return memory.removal(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p)
    return a11, a22, a12, a13, a23


@jit
def extra_rate(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p):
    """The law's rate beside the spin, per unit |D'| t (Eq. 13: none)."""
    if p[LAW_INDEX] == _MEMORY:
        return memory.extra_rate(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p)
    return 0.0, 0.0, 0.0, 0.0, 0.0


@jit
def offset(p):
    """kappa: the fabric of Eqs. 14 and 18 is the state plus kappa D'/|D'| (Eq. 13: 0)."""
    if p[LAW_INDEX] == _JUMP:
        return jump.offset(p)
    return 0.0


@dataclasses.dataclass(frozen=True)
class ReferenceParts:
    """A law's parts on 3x3 tensors for ``model.reference``: ``removal(A, Dh)``, ``extra(A, Dh)`` (per unit
    |D'| t) and ``offset`` (kappa)."""

    removal: object
    extra: object
    offset: float


def reference_parts(name: str, values: dict) -> ReferenceParts:
    """Law ``name``'s reference parts with its own parameters ``values`` (Eq. 13's where it leaves one out)."""
    law = LAWS[name]
    removal_of = getattr(law, "reference_removal", None)
    extra_of = getattr(law, "reference_extra", None)
    return ReferenceParts(
        (lambda A, Dh: removal_of(A, Dh, values)) if removal_of else (lambda A, Dh: A),
        (lambda A, Dh: extra_of(A, Dh, values)) if extra_of else (lambda A, Dh: np.zeros((3, 3))),
        float(law.reference_offset(values)) if hasattr(law, "reference_offset") else 0.0)
