"""Model parameters: one frozen, validated dataclass (defaults: the paper's Table 2 and Sec. 5).

Every parameter is dimensionless. Names follow the paper:

- flow rule (Eqs. 14/20, 22):        tau/p = C A + Y(S) D'/|D'|,  Y = n + m S
- fabric equation (Eqs. 13/23-25):   Lambda(S) A_jaumann = beta1 D' + beta2 |D'| A,
                                     beta_i = a_i + b_i S,  Lambda = S**persistence_exponent
- dilatancy (Eq. 18):                dPhi/dt / Phi = c1 A:D' + c2(S) (phi_c - Phi + c3) |D'|,
                                     c2(S) = c2_coef * S**c2_exponent

A parameter set names its fabric law, ``variant`` (``model.laws``, the registry): ``rk2025`` is Eq. 13 as written;
every other owns at most two parameters a fit determines (with those read off the DEM, held at their measured
value: at most four in all, also where it joins two laws), declared in its module, and reduces to
Eq. 13 where they vanish (``docs/model.md``, "Variants").
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, fields

import numpy as np

from . import json_text
from .equations import PHI_MAX
from .laws import CODE, LAWS, law_parameters
from .laws import DEFAULT as DEFAULT_LAW


class ParameterError(ValueError):
    """Invalid model parameters; the message names every bad value."""


#: the largest c2_exponent: S**10 at the smallest S of a flow (about 0.01) is still far above underflow
C2_EXPONENT_MAX = 10.0
#: the fabric laws by name -> the parameters each owns beyond Eq. 13 (``model.laws``, the registry)
VARIANTS = {name: tuple(q.name for q in law.parameters) for name, law in LAWS.items()}
DEFAULT_VARIANT = DEFAULT_LAW
#: the closed range of every law's own parameters (each law's declaration)
EXTRA_RANGES = {q.name: (q.low, q.high) for law in LAWS.values() for q in law.parameters}


@dataclass(frozen=True, init=False)
class Params:
    """Parameters of the kinematic-hardening fabric model (paper Table 2 and Sec. 5): Eq. 13's, shared by every law,
    then the fabric law (``variant``, a name in ``model.laws.LAWS``) and the values of the parameters it owns, in its
    declaration's order (``law_values``; each also read as an attribute, ``params.jump_fabric``). Built by name:
    ``Params(variant="jump", jump_fabric=-0.013, C=-6.1)``; a parameter of another law is an error."""

    C: float = -5.6  # backstress constant (Eq. 14)
    n: float = 0.18  # yield function Y = n + m S (Eq. 22)
    m: float = -0.60
    a1: float = -0.021  # beta_1 = a1 + b1 S (Eq. 25)
    b1: float = -2.7
    a2: float = 0.25  # beta_2 = a2 + b2 S (Eq. 25)
    b2: float = -35.0
    persistence_exponent: float = 0.75  # Lambda(S) = S**k (Eq. 24)
    c1: float = 5.6  # dilatancy (Eq. 18); the second law (Eq. 19) needs c1 = -C
    c2_coef: float = 5.6  # c2(S) = c2_coef * S**c2_exponent (Sec. 5)
    c2_exponent: float = 1.0 / 3.0
    c3: float = 0.14
    phi_c: float = 0.652  # critical packing fraction
    variant: str = DEFAULT_VARIANT  # the fabric law (model.laws)
    law_values: tuple = ()  # the law's own parameters, in its declaration's order

    def __init__(self, variant: str = DEFAULT_VARIANT, law_values: tuple | None = None, **values):
        if not isinstance(variant, str) or variant not in LAWS:
            raise ParameterError(f"invalid model parameters: variant={variant!r:.40} is not one of "
                                 f"{', '.join(LAWS)}")
        own = law_parameters(variant)
        if law_values is not None:
            if len(law_values) != len(own):
                raise ParameterError(f"invalid model parameters: {variant} owns {len(own)} parameter(s), "
                                     f"{len(law_values)} given")
            values = {**{q.name: v for q, v in zip(own, law_values, strict=True)}, **values}
        problems = []
        unknown = sorted(set(values) - set(self.names()) - {q.name for q in own})
        for name in unknown:
            owner = next((law for law, names in VARIANTS.items() if name in names), None)
            problems.append(f"{name}={values[name]} belongs to another variant than {variant}" if owner
                            else f"{name} is not a parameter")
        if problems:
            raise ParameterError("invalid model parameters: " + "; ".join(problems))
        shared = {f.name: values.get(f.name, f.default) for f in fields(self) if f.name in self.names()}
        mine = {q.name: values.get(q.name, q.neutral) for q in own}
        for name, value in {**shared, **mine}.items():
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                problems.append(f"{name}={value!r:.40} is not a number")
                continue
            try:
                value = float(value)
            except OverflowError:
                problems.append(f"{name}={str(value)[:20]}... is too large")
                continue
            if not math.isfinite(value):
                problems.append(f"{name}={value!r} is not finite")
            elif name in shared:
                shared[name] = value
            else:
                mine[name] = value
        if not problems:
            if shared["persistence_exponent"] <= 0:
                problems.append(f"persistence_exponent={shared['persistence_exponent']} must be > 0")
            if not shared["c2_coef"] > 0:  # Eq. 18 relaxes Phi at c2 |D'|: without it Phi has no steady value
                problems.append(f"c2_coef={shared['c2_coef']} must be > 0 (Eq. 18's relaxation to the critical "
                                "state; with none the packing fraction has no steady value)")
            if not 0 <= shared["c2_exponent"] <= C2_EXPONENT_MAX:  # S**c2_exponent stays a number, S ~ 0.01-1
                problems.append(f"c2_exponent={shared['c2_exponent']} must lie in [0, {C2_EXPONENT_MAX:g}] (c2(S) = "
                                "c2_coef S**c2_exponent vanishes at larger exponents)")
            if not 0 < shared["phi_c"] < PHI_MAX:
                problems.append(f"phi_c={shared['phi_c']} must lie in (0, {PHI_MAX:.4f}) (pi/(3 sqrt 2), the "
                                "densest packing of spheres)")
            for q in own:
                if not q.low <= mine[q.name] <= q.high:
                    problems.append(f"{q.name}={mine[q.name]} must lie in [{q.low}, {q.high}]")
        if problems:
            raise ParameterError("invalid model parameters: " + "; ".join(problems))
        for name, value in shared.items():
            object.__setattr__(self, name, value)
        object.__setattr__(self, "variant", variant)
        object.__setattr__(self, "law_values", tuple(mine[q.name] for q in own))
        array = np.array([shared[name] for name in self.names()] + [CODE[variant]] + list(self.law_values),
                         dtype=float)
        array.setflags(write=False)
        object.__setattr__(self, "_array", array)

    def __getattr__(self, name: str):
        """A law's own parameter by name (only called where no field has the name)."""
        if name.startswith("_"):
            raise AttributeError(name)
        own = [q.name for q in law_parameters(object.__getattribute__(self, "variant"))]
        if name in own:
            return object.__getattribute__(self, "law_values")[own.index(name)]
        raise AttributeError(f"{name!r} is not a parameter of the {self.variant} law")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The parameters of Eq. 13's model (Tables 1-2, Sec. 5), every law's."""
        return tuple(f.name for f in fields(cls) if f.name not in ("variant", "law_values"))

    def own_names(self) -> tuple[str, ...]:
        """The parameters of this set's law: Eq. 13's, then its own."""
        return self.names() + VARIANTS[self.variant]

    def law_dict(self) -> dict:
        """The law's own parameters by name."""
        return dict(zip(VARIANTS[self.variant], self.law_values, strict=True))

    def as_array(self) -> np.ndarray:
        """As the compiled kernels expect them (read-only): ``names()`` in order, the law's code in the registry, then
        its own parameters (``model.laws``)."""
        return self._array

    def replace(self, **changes) -> Params:
        """The same parameters with ``changes`` (names of Eq. 13's or of the law's own; ``variant`` another law, whose
        own parameters then start where it is Eq. 13 unless given)."""
        variant = changes.pop("variant", self.variant)
        kept = self.to_dict()
        kept.pop("variant", None)
        if variant != self.variant:
            kept = {name: value for name, value in kept.items() if name in self.names()}
        return Params(variant=variant, **{**kept, **changes})

    def to_dict(self) -> dict:
        """The values by name; a law other than Eq. 13 adds its name and its parameters."""
        values = {name: getattr(self, name) for name in self.names()}
        if self.variant != DEFAULT_VARIANT:
            values.update(variant=self.variant, **self.law_dict())
        return values

    @classmethod
    def from_dict(cls, values: dict, source: str = "parameters") -> Params:
        """Build from a complete mapping (``variant`` may be left out: the default); unknown or missing keys are an
        error."""
        if not isinstance(values, dict):
            raise ParameterError(f"{source}: expected a JSON object of parameters, got {type(values).__name__}")
        variant = values.get("variant", DEFAULT_VARIANT)
        if not isinstance(variant, str) or variant not in VARIANTS:
            raise ParameterError(f"{source}: variant={variant!r:.40} is not one of {', '.join(VARIANTS)}")
        expected = (*cls.names(), *VARIANTS[variant])
        unknown = sorted(set(values) - set(expected) - {"variant"})
        missing = [name for name in expected if name not in values]
        problems = []
        if unknown:
            problems.append("unknown keys " + ", ".join(unknown))
        if missing:
            problems.append("missing keys " + ", ".join(missing))
        if problems:
            raise ParameterError(f"{source}: " + "; ".join(problems))
        try:
            return cls(**values)
        except ParameterError as exc:
            raise ParameterError(f"{source}: {exc}") from None

    def to_json(self, metadata: dict | None = None) -> str:
        """The parameters as a JSON object; ``metadata`` (what fitted them, how well each is determined)
        goes under the key ``"metadata"``, which reading ignores."""
        values = self.to_dict() if metadata is None else {**self.to_dict(), "metadata": metadata}
        return json.dumps(values, indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str, source: str = "parameters") -> Params:
        def unique_keys(pairs):
            keys = [key for key, _ in pairs]
            repeated = sorted({key for key in keys if keys.count(key) > 1})
            if repeated:
                raise ParameterError(f"{source}: key(s) given more than once: {', '.join(repeated)}")
            return dict(pairs)

        try:
            values = json_text.loads(text, source, object_pairs_hook=unique_keys)
        except ParameterError:
            raise
        except ValueError as exc:  # not JSON, nested too deep, an integer of more than 4300 digits
            raise ParameterError(f"{str(exc).splitlines()[0][:200]}: not a parameter file") from None
        if isinstance(values, dict):
            values.pop("metadata", None)
        params = cls.from_dict(values, source)
        worst = params.least_work_rate()
        if worst is not None and worst.work_rate < -SECOND_LAW_SLACK:
            raise ParameterError(f"{source}: breaks the second law (Eq. 19): sigma:D / (p |D'|) = "
                                 f"{worst.work_rate:.3g} < 0 at S = {worst.S:.3g}, A:D'/|D'| = {worst.x:.3g} "
                                 f"(Y(S) = {worst.Y:.3g}, C + c1 = {params.C + params.c1:.3g}; Eq. 19 asks c1 = -C "
                                 "and Y >= 0)")
        return params

    def least_work_rate(self) -> WorkRate | None:
        """The least work rate sigma:D / (p |D'|) = Y(S) + (C + c1)(A:D'/|D'| + kappa) + c2(S)(Phi_c - Phi + c3)
        (Sec. 5) over the states the model reaches: S up to the largest S and |A| up to the largest |A| of the
        reversal's periodic cycle (the largest turn: S peaks right after it), at a given S A:D'/|D'| = |A| - S in
        [-S/2, |A|max - S]; kappa the law's constant part of the fabric (``model.laws`` offset); Phi <= Phi_c + c3
        (Eq. 19's condition on the state: c2's term is then >= 0 and left out). None where the reversal cannot be
        predicted (its own error says why). It does not cover a law's own state's transient part of the fabric
        (the "elastic" K), nor states beyond what the reversal's cycle reaches."""
        from .laws import offset
        from .solver import SolverError, predict

        try:
            cycle = predict(180.0, params=self)
        except SolverError:
            return None
        reach = float(np.max(np.sqrt(np.einsum("nij,nij->n", cycle.A, cycle.A))))
        S = np.linspace(0.0, min(float(np.max(cycle.S)), 2.0 * reach), 401)
        Y = self.n + self.m * S
        ends = np.stack([-S / 2, reach - S])
        rate = Y + (self.C + self.c1) * (ends + float(offset(self.as_array())))
        k, i = np.unravel_index(int(np.argmin(rate)), rate.shape)
        return WorkRate(float(rate[k, i]), float(S[i]), float(ends[k, i]), float(Y[i]))


@dataclass(frozen=True)
class WorkRate:
    """The least work rate of a parameter set (``Params.least_work_rate``) and where it lies: per unit p |D'|, at
    S, A:D'/|D'| = x, with the yield function Y(S)."""

    work_rate: float
    S: float
    x: float
    Y: float


#: the rounding allowed below zero in the second law's check
SECOND_LAW_SLACK = 1e-12

PAPER = Params()


def table2_value(name: str) -> float:
    """Table 2's value of one of Eq. 13's parameters; for a law's own parameter, its neutral value (where the law is
    Eq. 13): what "Table 2" means for any law's parameter set."""
    if name in Params.names():
        return getattr(PAPER, name)
    return next(q.neutral for law in LAWS.values() for q in law.parameters if q.name == name)
