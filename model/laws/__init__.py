"""The fabric laws, each a module that owns its parameters and its compiled parts, chosen once by name.

A law is Eq. 13 (paper Table 1) with at most two parameters of its own that a fit determines (and any it reads off
the DEM, ``Parameter.measured``: at most four in all), or several such laws together
(``elastic_compaction``), and reduces to it where they vanish (``docs/model.md``, "Variants"). Its module declares
``NAME``, ``PARAMETERS`` (``Parameter`` records: name, the value where the law is Eq. 13, where a fit starts, the
closed range the law is bounded in, the meaning), the sets its checks run with, and any of its parts, each compiled
with numba over the model's parameter array ``p`` (``Params.as_array``: Eq. 13's parameters, the law's code, then
its own) and taking, after its own arguments, ``s`` and ``q``: where its state and its parameters start
(``model.laws.law``, which makes each module a ``Law`` record and places its parts):

- ``removal(y, a.., d.., p, s, q)``: what beta2 |D'| removes in place of A (Eq. 13's recovery term), packed (11, 22,
  12, 13, 23), ``y`` the kernels' state;
- ``extra_rate(a.., d.., p, s, q)``: a rate per unit |D'| t added beside the Jaumann spin (scaled by Lambda as it
  is), packed alike;
- ``offset(p, s, q)``: kappa, where the fabric of Eqs. 14 and 18 is the state A plus kappa D'/|D'|;
- a state of its own (``STATE``, its names; ``STATE_BOUNDS``, the range each lies in, which ``model.update`` checks;
  optionally ``STATE_TOLERANCE``, the update's tolerance on each in units of A's): ``state_rates(y, Dh, Wn, p, g,
  c2, out, scale, s, q)`` writes its rates per unit |D'| t times ``scale`` (given Eq. 18's g and c2),
  ``state_fabric(y, p, s, q)`` the part of the fabric it holds beyond A (packed), ``set_packing(y, u, s, q)`` sets
  what it holds of the packing fraction 1/u where a history or step starts, ``start(Dh, phi, values)`` that part
  (3x3) and the state where a history starts, and ``relaxing_part(v, Dh, p, s, q)``, K:Dh over its relaxation rate
  for a part K of the fabric that relaxes fast (``model.stepper``);

and for the independent reference (``model.reference``, plain numpy on 3x3 tensors) ``reference_removal(A, Dh,
values, X, phi)``, ``reference_extra``, ``reference_offset``, and for a state ``reference_start``,
``reference_state_rate`` and ``reference_fabric``. A part a law leaves out is Eq. 13's (A, zero, zero, no state).
The kernels call the dispatchers below, generated from the registry (``model.laws.dispatch``): nothing outside
``LAWS`` names a law. Adding a law is its module and its line in ``LAWS`` (``docs/extending.md``).
"""

from __future__ import annotations

import numpy as np

from ..jit import jit
from . import (
    compaction,
    dispatch,
    elastic,
    elastic_compaction,
    jump,
    lasting,
    lasting_turn,
    loading,
    memory,
    rk2025,
    turn_compaction,
)
from .law import BASE, DECLARED, OWN, Law, ReferenceParts, make_law
from .law import reference_parts as _reference_parts
from .parameter import Parameter


def _registry(*modules) -> dict[str, Law]:
    laws: dict[str, Law] = {}
    for code, module in enumerate(modules):
        laws[module.NAME] = make_law(module, code, laws)
    return laws


#: the registry: every fabric law, Eq. 13's first (its code is its place here)
LAWS = _registry(rk2025, loading, memory, jump, elastic, compaction, elastic_compaction, lasting, turn_compaction,
                 lasting_turn)
DEFAULT = rk2025.NAME
CODE = {name: float(law.code) for name, law in LAWS.items()}
LAW_INDEX = OWN - 1  # where the law's code sits in the parameter array

__all__ = ["BASE", "DECLARED", "DEFAULT", "LAWS", "OWN", "Law", "Parameter", "declared", "examples", "extra_rate",
           "law_parameters", "offset", "reference_parts", "relaxing_part", "removal", "set_packing", "start",
           "state_bounds", "state_fabric", "state_names", "state_rates", "state_tolerance"]


def law_parameters(name: str) -> tuple[Parameter, ...]:
    """The parameters law ``name`` owns (``KeyError`` for a law that is not registered)."""
    return LAWS[name].parameters


def name_of(p) -> str:
    """The law whose code a parameter array holds."""
    return list(LAWS)[int(p[LAW_INDEX])]


def state_names(name: str) -> tuple[str, ...]:
    """The law's own state variables (none for a law without)."""
    return LAWS[name].state


def state_tolerance(name: str) -> tuple[float, ...]:
    """Per own state variable, the material-point update's tolerance in units of A's (``model.stepper``): 1 unless
    the law declares ``STATE_TOLERANCE`` (a state whose local errors decay and do not add up step after step)."""
    return LAWS[name].state_tolerance


def state_bounds(name: str) -> tuple[tuple[float, float], ...]:
    """Per own state variable, the closed range it lies in (``STATE_BOUNDS``)."""
    return LAWS[name].state_bounds


def examples() -> list[tuple[str, str, dict]]:
    """(example name, law, its own parameters) of every registered law's ``EXAMPLES``, in the registry's order, Eq.
    13's neutral set first (a law declaring none is refused where the registry is made: ``model.laws.law``)."""
    return [(example, name, dict(values)) for name, law in LAWS.items() for example, values in law.examples.items()]


def declared(name: str, key: str):
    """Law ``name``'s declaration ``key`` (one of ``DECLARED``)."""
    return LAWS[name].declared(key)


def start(name: str, Dh, values: dict, phi) -> tuple[np.ndarray, np.ndarray]:
    """Where a history starts under the unit stretching ``Dh`` (3x3, or a stack) at the packing fraction ``phi``: the
    part of the fabric beyond the state A (kappa Dh of "jump", K of "elastic") and the law's own state (packed,
    empty for none)."""
    return LAWS[name].start(Dh, phi, values)


def reference_parts(name: str, values: dict) -> ReferenceParts:
    """Law ``name``'s reference parts with its own parameters ``values`` (Eq. 13's where it leaves one out)."""
    return _reference_parts(LAWS[name], values)


@jit
def _keep_a(args):
    return args[1], args[2], args[3], args[4], args[5]


@jit
def _no_fabric(args):
    return 0.0, 0.0, 0.0, 0.0, 0.0


@jit
def _no_number(args):
    return 0.0


@jit
def _nothing(args):
    return None


_ORDER = tuple(LAWS.values())
_REMOVAL = dispatch.generated("removal", _ORDER, _keep_a)
_EXTRA = dispatch.generated("extra_rate", _ORDER, _no_fabric)
_OFFSET = dispatch.generated("offset", _ORDER, _no_number)
_STATE_RATES = dispatch.generated("state_rates", _ORDER, _nothing)
_RELAXING = dispatch.generated("relaxing_part", _ORDER, _no_number)
_SET_PACKING = dispatch.generated("set_packing", _ORDER, _nothing)
_STATE_FABRIC = dispatch.generated("state_fabric", _ORDER, _no_fabric)


@jit
def removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p):
    """What beta2 |D'| removes (Eq. 13: A itself); ``y`` the kernels' state."""
    return _REMOVAL(int(p[LAW_INDEX]), (y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p))


@jit
def extra_rate(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p):
    """The law's rate beside the spin, per unit |D'| t (Eq. 13: none)."""
    return _EXTRA(int(p[LAW_INDEX]), (a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p))


@jit
def offset(p):
    """kappa: the fabric of Eqs. 14 and 18 is the state plus kappa D'/|D'| (Eq. 13: 0)."""
    return _OFFSET(int(p[LAW_INDEX]), (p,))


@jit
def state_rates(y, Dh, Wn, p, g, c2, out, scale):
    """The law's own state's rates per unit |D'| t, times ``scale``, into ``out[BASE:]`` (none for most laws); ``g``
    and ``c2`` are Eq. 18's (``model.equations.fabric_rates``)."""
    _STATE_RATES(int(p[LAW_INDEX]), (y, Dh, Wn, p, g, c2, out, scale))


@jit
def relaxing_part(v, Dh, p):
    """For a law whose own state holds a part K of the fabric that relaxes fast (rate c per unit |D'| t), K:Dh / c of
    the state ``v`` (or of its rate, the map being linear); 0 for the others (``model.stepper``)."""
    return _RELAXING(int(p[LAW_INDEX]), (v, Dh, p))


@jit
def set_packing(y, u, p):
    """What the law's own state holds of the packing fraction, set to 1/u where a history or a step starts."""
    _SET_PACKING(int(p[LAW_INDEX]), (y, u))


@jit
def state_fabric(y, p):
    """The part of the fabric the law's state holds beyond A, packed (zero for most laws)."""
    return _STATE_FABRIC(int(p[LAW_INDEX]), (y, p))
