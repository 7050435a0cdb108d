"""The fabric laws, each a module that owns its parameters and its compiled parts, chosen once by name.

A law is Eq. 13 (paper Table 1) with at most two parameters of its own, or two such laws together
(``elastic_compaction``), and reduces to it where they vanish (``docs/model.md``, "Variants"). Its module declares
``NAME``, ``PARAMETERS`` (``Parameter`` records: name, the value where the law is Eq. 13, where a fit starts, the
closed range the law is bounded in, the meaning) and any of three parts, each compiled with numba over the model's
parameter array ``p`` (``Params.as_array``: Eq. 13's parameters, the law's code, then its own, read at ``OWN + k``):

- ``removal``: what beta2 |D'| removes in place of A (Eq. 13's recovery term), packed (11, 22, 12, 13, 23); the
  dispatcher hands it the kernels' state ``y`` too, which a law with a state of its own may read;
- ``extra_rate``: a rate per unit |D'| t added beside the Jaumann spin (scaled by Lambda as it is), packed alike;
- ``offset``: kappa, where the fabric of Eqs. 14 and 18 is the state A plus kappa D'/|D'|;
- a state of its own (``STATE``, its names; after the kernels' ``BASE`` components): ``state_rates`` writes its
  rates per unit |D'| t times ``scale`` (given Eq. 18's g and c2), ``state_fabric(y)`` the part of the fabric it
  holds beyond A (packed), ``set_packing(y, u)`` sets what it holds of the packing fraction 1/u where a history or
  step starts, ``start(Dh, phi, values)`` that part (3x3) and the state where a history starts, and optionally
  ``STATE_TOLERANCE``, the material-point update's tolerance on each, in units of A's, ``STATE_BOUNDS``, the range
  each lies in (required: ``model.update`` refuses a state outside it), and ``relaxing_part(v, Dh)``,
  K:Dh over its relaxation rate for a part K of the fabric that relaxes fast (``model.stepper``);

and for the independent reference (``model.reference``, plain numpy on 3x3 tensors) the same as
``reference_removal`` (given the law's own state and Phi where it reads them), ``reference_extra``,
``reference_offset``, and for a state ``reference_start``, ``reference_state_rate`` and ``reference_fabric``. A part
a law leaves out is Eq. 13's (A, zero, zero, no state). The kernels call ``removal``, ``extra_rate``, ``offset``,
``state_rates``, ``set_packing``, ``state_fabric`` and ``relaxing_part`` below, which branch on the law's code:
nothing outside this module asks which law it is. Adding a law is its module, its entry in ``LAWS`` and a branch in
each part it defines (``docs/extending.md``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..jit import jit
from . import compaction, elastic, elastic_compaction, jump, loading, memory, rk2025
from .parameter import OWN, Parameter

#: the registry: every fabric law, Eq. 13's first (its code is its place here)
LAWS = {law.NAME: law for law in (rk2025, loading, memory, jump, elastic, compaction, elastic_compaction)}
DEFAULT = rk2025.NAME
CODE = {name: float(k) for k, name in enumerate(LAWS)}
_LOADING, _MEMORY, _JUMP = CODE[loading.NAME], CODE[memory.NAME], CODE[jump.NAME]
_ELASTIC, _COMPACTION, _BOTH = CODE[elastic.NAME], CODE[compaction.NAME], CODE[elastic_compaction.NAME]
LAW_INDEX = OWN - 1  # where the law's code sits in the parameter array
#: the kernels' state before a law's own (``model.integrator``: A packed, t, G, v)
BASE = 8

__all__ = ["BASE", "DECLARED", "DEFAULT", "LAWS", "OWN", "Parameter", "declared", "examples", "extra_rate",
           "law_parameters", "offset",
           "reference_parts", "relaxing_part", "removal", "set_packing", "start", "state_bounds", "state_fabric",
           "state_names", "state_rates", "state_tolerance"]


def law_parameters(name: str) -> tuple[Parameter, ...]:
    """The parameters law ``name`` owns (``KeyError`` for a law that is not registered)."""
    return LAWS[name].PARAMETERS


@jit
def removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p):
    """What beta2 |D'| removes (Eq. 13: A itself); ``y`` the kernels' state."""
    code = p[LAW_INDEX]
    if code == _COMPACTION:
        return compaction.removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, compaction.FIRST, OWN)
    if code == _BOTH:
        return compaction.removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p,
                                  elastic_compaction.COMPACTION_FIRST, elastic_compaction.COMPACTION_OWN)
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


def name_of(p) -> str:
    """The law whose code a parameter array holds."""
    return list(LAWS)[int(p[LAW_INDEX])]


def state_names(name: str) -> tuple[str, ...]:
    """The law's own state variables (none for a law without)."""
    return getattr(LAWS[name], "STATE", ())


def state_tolerance(name: str) -> tuple[float, ...]:
    """Per own state variable, the material-point update's tolerance in units of A's (``model.stepper``): 1 unless
    the law declares ``STATE_TOLERANCE`` (a state whose local errors decay and do not add up step after step)."""
    return getattr(LAWS[name], "STATE_TOLERANCE", (1.0,) * len(state_names(name)))


#: what every law declares beside its parts: the sets its checks run with, the fit's and the benchmark's set, and
#: whether it leaves a reversal to Eq. 13 (``examples``)
DECLARED = ("EXAMPLES", "FIT_EXAMPLE", "SPEED_EXAMPLE", "LEAVES_A_REVERSAL")


def examples() -> list[tuple[str, str, dict]]:
    """(example name, law, its own parameters) of every registered law's ``EXAMPLES``, in the registry's order, Eq.
    13's neutral set first; a law that declares none (or not ``DECLARED``) is a ``TypeError``: the checks would skip
    it."""
    out = []
    for name, law in LAWS.items():
        missing = [key for key in DECLARED if not hasattr(law, key)]
        if missing or not law.EXAMPLES:
            raise TypeError(f"the {name} law declares no {', '.join(missing) or 'EXAMPLES'}: every law is checked "
                            "with its own parameter sets")
        out += [(example, name, dict(values)) for example, values in law.EXAMPLES.items()]
    return out


def declared(name: str, key: str):
    """Law ``name``'s declaration ``key`` (one of ``DECLARED``)."""
    if key not in DECLARED:
        raise KeyError(f"{key} is not a law's declaration ({', '.join(DECLARED)})")
    return getattr(LAWS[name], key)


def state_bounds(name: str) -> tuple[tuple[float, float], ...]:
    """Per own state variable, the closed range it lies in (``STATE_BOUNDS``; a law with a state declares them)."""
    law = LAWS[name]
    if state_names(name) and not hasattr(law, "STATE_BOUNDS"):
        raise TypeError(f"the {name} law has a state but declares no STATE_BOUNDS")
    return getattr(law, "STATE_BOUNDS", ())


def start(name: str, Dh, values: dict, phi) -> tuple[np.ndarray, np.ndarray]:
    """Where a history starts under the unit stretching ``Dh`` (3x3, or a stack) at the packing fraction ``phi``: the
    part of the fabric beyond the state A (kappa Dh of "jump", K of "elastic") and the law's own state (packed,
    empty for none)."""
    law, Dh = LAWS[name], np.asarray(Dh, dtype=float)
    part = law.reference_offset(values) * Dh if hasattr(law, "reference_offset") else np.zeros(Dh.shape)
    if not state_names(name):
        return part, np.zeros(Dh.shape[:-2] + (0,))
    held, own = law.start(Dh, phi, values)
    return part + held, own


@jit
def state_rates(y, Dh, Wn, p, g, c2, out, scale):
    """The law's own state's rates per unit |D'| t, times ``scale``, into ``out[BASE:]`` (none for most laws); ``g``
    and ``c2`` are Eq. 18's (``model.equations.fabric_rates``)."""
    code = p[LAW_INDEX]
    if code == _ELASTIC:
        elastic.state_rates(y, Dh, Wn, p, out, scale, elastic.FIRST, OWN)
    elif code == _COMPACTION:
        compaction.state_rates(y, p, g, c2, out, scale, compaction.FIRST, OWN)
    elif code == _BOTH:
        elastic.state_rates(y, Dh, Wn, p, out, scale, elastic_compaction.ELASTIC_FIRST,
                            elastic_compaction.ELASTIC_OWN)
        compaction.state_rates(y, p, g, c2, out, scale, elastic_compaction.COMPACTION_FIRST,
                               elastic_compaction.COMPACTION_OWN)


@jit
def relaxing_part(v, Dh, p):
    """For a law whose own state holds a part K of the fabric that relaxes fast (rate c per unit |D'| t), K:Dh / c of
    the state ``v`` (or of its rate, the map being linear); 0 for the others (``model.stepper``)."""
    code = p[LAW_INDEX]
    if code == _ELASTIC:
        return elastic.relaxing_part(v, Dh, p, elastic.FIRST, OWN)
    if code == _BOTH:
        return elastic.relaxing_part(v, Dh, p, elastic_compaction.ELASTIC_FIRST, elastic_compaction.ELASTIC_OWN)
    return 0.0


@jit
def set_packing(y, u, p):
    """What the law's own state holds of the packing fraction, set to 1/u where a history or a step starts."""
    code = p[LAW_INDEX]
    if code == _COMPACTION:
        compaction.set_packing(y, u, compaction.FIRST)
    elif code == _BOTH:
        compaction.set_packing(y, u, elastic_compaction.COMPACTION_FIRST)


@jit
def state_fabric(y, p):
    """The part of the fabric the law's state holds beyond A, packed (zero for most laws)."""
    code = p[LAW_INDEX]
    if code == _ELASTIC:
        return elastic.state_fabric(y, elastic.FIRST)
    if code == _BOTH:
        return elastic.state_fabric(y, elastic_compaction.ELASTIC_FIRST)
    return 0.0, 0.0, 0.0, 0.0, 0.0


@dataclasses.dataclass(frozen=True)
class ReferenceParts:
    """A law's parts on 3x3 tensors for ``model.reference``: ``removal(A, Dh, X, phi)``, ``extra(A, Dh)`` (per unit
    |D'| t), ``offset`` (kappa), and for a law with a state X of its own (a flat array; None for none)
    ``state_start(Dh, phi)``, ``state_rate(X, A, phi, L)`` (dX/dt) and ``state_fabric(X)`` (the part of the fabric
    it holds, 3x3)."""

    removal: object
    extra: object
    offset: float
    state_start: object = None
    state_rate: object = None
    state_fabric: object = None


def reference_parts(name: str, values: dict) -> ReferenceParts:
    """Law ``name``'s reference parts with its own parameters ``values`` (Eq. 13's where it leaves one out)."""
    law = LAWS[name]
    removal_of = getattr(law, "reference_removal", None)
    extra_of = getattr(law, "reference_extra", None)
    state_of = getattr(law, "reference_state_rate", None)
    fabric_of = getattr(law, "reference_fabric", lambda X: np.zeros((3, 3)))
    return ReferenceParts(
        (lambda A, Dh, X, phi: removal_of(A, Dh, values, *((X, phi) if state_of else ()))) if removal_of
        else (lambda A, Dh, X, phi: A),
        (lambda A, Dh: extra_of(A, Dh, values)) if extra_of else (lambda A, Dh: np.zeros((3, 3))),
        float(law.reference_offset(values)) if hasattr(law, "reference_offset") else 0.0,
        (lambda Dh, phi: law.reference_start(Dh, phi, values)) if state_of else None,
        (lambda X, A, phi, L: state_of(X, A, phi, L, values)) if state_of else None,
        fabric_of if state_of else None)
