"""A fabric law as one record, made from its module's declarations (``model.laws``, the registry).

A law's module declares ``NAME``, ``PARAMETERS`` (``Parameter`` records), the sets its checks run with
(``EXAMPLES``, ``FIT_EXAMPLE``, ``SPEED_EXAMPLE``, ``LEAVES_A_REVERSAL``), optionally a state of its own (``STATE``,
``STATE_BOUNDS``, ``STATE_TOLERANCE``), and any of its compiled parts (``KINDS``), each taking after its own
arguments ``s``, where its state starts in the kernels' state ``y``, and ``q``, where its parameters start in the
parameter array ``p``; a law joining others declares ``JOINS`` (their names) instead of parameters, state and parts.
The registry places every part (``Part``): nothing is placed by hand.
"""

from __future__ import annotations

import dataclasses
from types import ModuleType

import numpy as np

from .parameter import Parameter

#: where a law's own parameters start in the parameter array (after Eq. 13's thirteen and the law's code)
OWN = 14
#: where a law's own state starts in the kernels' state (``model.integrator``: A packed, t, G, v)
BASE = 8
#: the compiled parts a law may define; of the first five at most one of a joined law's parts defines each, the
#: last two run for every part that defines them
ONE = ("removal", "extra_rate", "offset", "state_fabric", "relaxing_part")
EACH = ("state_rates", "set_packing")
KINDS = ONE + EACH
#: the plain-numpy parts for ``model.reference``
REFERENCE = ("reference_removal", "reference_extra", "reference_offset", "reference_start", "reference_state_rate",
             "reference_fabric")
#: what every law declares beside its parts (``Law.declared``)
DECLARED = ("EXAMPLES", "FIT_EXAMPLE", "SPEED_EXAMPLE", "LEAVES_A_REVERSAL")


@dataclasses.dataclass(frozen=True)
class Part:
    """One module's compiled parts in a law: its state at ``y[state_at:]``, its parameters at ``p[params_at:]``."""

    module: ModuleType
    state_at: int
    params_at: int

    def values(self, values: dict) -> dict:
        """The part's own parameters of a law's ``values``."""
        return {q.name: values[q.name] for q in self.module.PARAMETERS}


@dataclasses.dataclass(frozen=True)
class Law:
    """A registered fabric law: its name and code (its place in the registry), its parameters and state, the sets it
    is checked with, and its parts, placed."""

    name: str
    code: int
    parameters: tuple[Parameter, ...]
    state: tuple[str, ...]
    state_tolerance: tuple[float, ...]
    state_bounds: tuple[tuple[float, float], ...]
    examples: dict
    fit_example: dict
    speed_example: dict
    leaves_a_reversal: bool
    parts: tuple[Part, ...]
    joins: tuple[str, ...] = ()

    def defining(self, kind: str) -> tuple[Part, ...]:
        """The parts that define compiled part ``kind`` (one of ``KINDS``) or reference part (``REFERENCE``)."""
        return tuple(part for part in self.parts if hasattr(part.module, kind))

    def declared(self, key: str):
        """One of ``DECLARED``, as the module spells it."""
        if key not in DECLARED:
            raise KeyError(f"{key} is not a law's declaration ({', '.join(DECLARED)})")
        return getattr(self, key.lower())

    def start(self, Dh, phi, values: dict) -> tuple[np.ndarray, np.ndarray]:
        """Where a history starts under the unit stretching ``Dh`` (3x3 or a stack) at the packing fraction ``phi``:
        the part of the fabric beyond A (kappa Dh of "jump", K of "elastic") and the law's own state (packed)."""
        Dh = np.asarray(Dh, dtype=float)
        part = sum((p.module.reference_offset(p.values(values)) for p in self.defining("reference_offset")), 0.0) * Dh
        if not self.state:
            return part, np.zeros(Dh.shape[:-2] + (0,))
        starts = [p.module.start(Dh, phi, p.values(values)) for p in self.parts if getattr(p.module, "STATE", ())]
        shape = np.broadcast_shapes(part.shape[:-2], *(s.shape[:-1] for _, s in starts))
        held = sum((np.broadcast_to(h, shape + (3, 3)) for h, _ in starts), np.zeros(shape + (3, 3)))
        own = np.concatenate([np.broadcast_to(s, shape + s.shape[-1:]) for _, s in starts], axis=-1)
        return np.broadcast_to(part, shape + (3, 3)) + held, own


@dataclasses.dataclass(frozen=True)
class ReferenceParts:
    """A law's parts on 3x3 tensors for ``model.reference``: ``removal(A, Dh, X, phi)``, ``extra(A, Dh)`` (per unit
    |D'| t), ``offset`` (kappa), and for a law with a state X of its own (a flat array; None for none)
    ``state_start(Dh, phi)``, ``state_rate(X, A, phi, L)`` (dX/dt) and ``state_fabric(X)`` (the part of the fabric
    it holds, 3x3). A part the law leaves out is Eq. 13's: A, zero, zero, no state."""

    removal: object
    extra: object
    offset: float
    state_start: object = None
    state_rate: object = None
    state_fabric: object = None


def reference_parts(law: Law, values: dict) -> ReferenceParts:
    """``law``'s reference parts with its own parameters ``values``: each part reads its slice of the law's own state
    X (its ``reference_start``'s length)."""
    stateful = law.defining("reference_start")
    sizes = [len(p.module.reference_start(np.eye(3) / np.sqrt(3.0), 0.6, p.values(values))) for p in stateful]
    ends = np.cumsum([0] + sizes)
    own = {p: slice(ends[k], ends[k + 1]) for k, p in enumerate(stateful)}

    def mine(part, X):
        return X[own[part]] if part in own else np.zeros(0)

    def removal(A, Dh, X, phi):
        for p in law.defining("reference_removal"):
            return p.module.reference_removal(A, Dh, p.values(values), mine(p, X), phi)
        return A

    def extra(A, Dh):
        for p in law.defining("reference_extra"):
            return p.module.reference_extra(A, Dh, p.values(values))
        return np.zeros((3, 3))

    def state_start(Dh, phi):
        return np.concatenate([p.module.reference_start(Dh, phi, p.values(values)) for p in stateful])

    def state_rate(X, A, phi, L):
        return np.concatenate([p.module.reference_state_rate(X[own[p]], A, phi, L, p.values(values))
                               for p in stateful])

    def state_fabric(X):
        for p in law.defining("reference_fabric"):
            return p.module.reference_fabric(X[own[p]])
        return np.zeros((3, 3))

    offset = sum((float(p.module.reference_offset(p.values(values))) for p in law.defining("reference_offset")), 0.0)
    if not stateful:
        return ReferenceParts(removal, extra, offset)
    return ReferenceParts(removal, extra, offset, state_start, state_rate, state_fabric)


def _required(module: ModuleType, keys: tuple[str, ...]) -> None:
    """A ``TypeError`` naming what ``module`` lacks of ``keys`` (and ``EXAMPLES`` if it declares none): the
    registry's checks run every law with its own sets, and a state without bounds could not be checked."""
    missing = [key for key in keys if not hasattr(module, key)]
    if missing or not getattr(module, "EXAMPLES", None):
        name = getattr(module, "NAME", None) or getattr(module, "__name__", "?")
        raise TypeError(f"the {name} law declares no {', '.join(missing) or 'EXAMPLES'} (model.laws.law: what "
                        "every law declares)")


def make_law(module: ModuleType, code: int, registered: dict[str, Law]) -> Law:
    """The law ``module`` declares, with code ``code``; a law joining others takes their parts from ``registered``
    and places them one after the other. A missing declaration, or two parts defining one of ``ONE``, is a
    ``TypeError`` naming it."""
    _required(module, ("NAME",) + DECLARED + (() if hasattr(module, "JOINS") else ("PARAMETERS",)))
    members = [registered[name].parts for name in getattr(module, "JOINS", ())] or [(Part(module, BASE, OWN),)]
    parts, state_at, params_at = [], BASE, OWN
    for member in members:
        for part in member:
            parts.append(Part(part.module, state_at, params_at))
            _required(part.module, ("STATE_BOUNDS",) if getattr(part.module, "STATE", ()) else ())
            state_at += len(getattr(part.module, "STATE", ()))
            params_at += len(part.module.PARAMETERS)
    law = Law(
        name=module.NAME, code=code,
        parameters=sum((p.module.PARAMETERS for p in parts), ()),
        state=sum((tuple(getattr(p.module, "STATE", ())) for p in parts), ()),
        state_tolerance=sum((tuple(getattr(p.module, "STATE_TOLERANCE", (1.0,) * len(getattr(p.module, "STATE", ()))))
                             for p in parts), ()),
        state_bounds=sum((tuple(getattr(p.module, "STATE_BOUNDS", ())) for p in parts), ()),
        examples=dict(module.EXAMPLES), fit_example=dict(module.FIT_EXAMPLE),
        speed_example=dict(module.SPEED_EXAMPLE), leaves_a_reversal=bool(module.LEAVES_A_REVERSAL),
        parts=tuple(parts), joins=tuple(getattr(module, "JOINS", ())))
    for kind in ONE + ("reference_removal", "reference_extra", "reference_fabric"):
        if len(law.defining(kind)) > 1:
            raise TypeError(f"the {law.name} law joins two parts that each define {kind}: one part owns it")
    return law
