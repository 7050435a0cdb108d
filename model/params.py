"""Model parameters: one frozen, validated dataclass (defaults: the paper's Table 2 and Sec. 5).

Every parameter is dimensionless. Names follow the paper:

- flow rule (Eqs. 14/20, 22):        tau/p = C A + Y(S) D'/|D'|,  Y = n + m S
- fabric equation (Eqs. 13/23-25):   Lambda(S) A_jaumann = beta1 D' + beta2 |D'| A,
                                     beta_i = a_i + b_i S,  Lambda = S**persistence_exponent
- dilatancy (Eq. 18):                dPhi/dt / Phi = c1 A:D' + c2(S) (phi_c - Phi + c3) |D'|,
                                     c2(S) = c2_coef * S**c2_exponent

A parameter set names its fabric law, ``variant`` (``VARIANTS``): ``rk2025`` is Eq. 13 as written; every other
adds at most two parameters, and reduces to Eq. 13 where they are zero (``docs/model.md``, "Variants").
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, fields

import numpy as np


class ParameterError(ValueError):
    """Invalid model parameters; the message names every bad value."""


#: the fabric laws: name -> the parameters it adds to Eq. 13 (each law is Eq. 13 where they are zero)
VARIANTS = {
    "rk2025": (),  # Eq. 13 (paper Table 1)
    "loading": ("chi",),  # removal weighted by how D' loads each part of A (docs/model.md)
    "memory": ("memory_share", "memory_rate"),  # the part of A that D' does not load, removed at its own rate
    "jump": ("jump_fabric",),  # a part of the fabric, kappa D'/|D'|, that follows D' at once
}
DEFAULT_VARIANT = "rk2025"
#: the closed range of each added parameter: where the law keeps A bounded (chi < 3/4, docs/model.md), and a
#: memory rate up to a removal within 0.001 strain
EXTRA_RANGES = {"chi": (-0.5, 0.7), "memory_share": (0.0, 1.0), "memory_rate": (0.0, 1e3), "jump_fabric": (-0.1, 0.1)}


@dataclass(frozen=True)
class Params:
    """Parameters of the kinematic-hardening fabric model (paper Table 2 and Sec. 5)."""

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
    variant: str = DEFAULT_VARIANT  # the fabric law (VARIANTS)
    chi: float = 0.0  # "loading": the removal of a part of A that D' does not load, less by this fraction
    memory_share: float = 0.0  # "memory": the share of that part taken from beta2's removal ...
    memory_rate: float = 0.0  # ... and removed instead at this rate per unit |D'| t
    jump_fabric: float = 0.0  # "jump": the fabric is the state A plus this times D'/|D'|

    def __post_init__(self):
        problems = []
        if self.variant not in VARIANTS:
            raise ParameterError(f"invalid model parameters: variant={self.variant!r:.40} is not one of "
                                 f"{', '.join(VARIANTS)}")
        for f in fields(self):
            if f.name == "variant":
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                problems.append(f"{f.name}={value!r:.40} is not a number")
                continue
            try:
                value = float(value)
            except OverflowError:
                problems.append(f"{f.name}={str(value)[:20]}... is too large")
                continue
            if not math.isfinite(value):
                problems.append(f"{f.name}={value!r} is not finite")
            else:
                object.__setattr__(self, f.name, value)
        if not problems:
            if self.persistence_exponent <= 0:
                problems.append(f"persistence_exponent={self.persistence_exponent} must be > 0")
            if self.c2_exponent < 0:
                problems.append(f"c2_exponent={self.c2_exponent} must be >= 0")
            if not 0 < self.phi_c < 1:
                problems.append(f"phi_c={self.phi_c} must lie in (0, 1)")
            for name in self.extra_names():
                low, high = EXTRA_RANGES[name]
                value = getattr(self, name)
                if name not in VARIANTS[self.variant] and value != 0:
                    problems.append(f"{name}={value} belongs to another variant than {self.variant}")
                elif not low <= value <= high:
                    problems.append(f"{name}={value} must lie in [{low}, {high}]")
        if problems:
            raise ParameterError("invalid model parameters: " + "; ".join(problems))
        values = [getattr(self, name) for name in self.names()]
        values += [list(VARIANTS).index(self.variant)] + [getattr(self, name) for name in self.extra_names()]
        array = np.array(values, dtype=float)
        array.setflags(write=False)
        object.__setattr__(self, "_array", array)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The parameters of Eq. 13's model (Tables 1-2, Sec. 5), every variant's."""
        return tuple(f.name for f in fields(cls) if f.name != "variant" and f.name not in cls.extra_names())

    @staticmethod
    def extra_names() -> tuple[str, ...]:
        """Every parameter a variant adds, in declaration order."""
        return tuple(name for names in VARIANTS.values() for name in names)

    def own_names(self) -> tuple[str, ...]:
        """The parameters of this set's variant: Eq. 13's, then its additions."""
        return self.names() + VARIANTS[self.variant]

    def as_array(self) -> np.ndarray:
        """As the compiled kernels expect them (read-only): ``names()`` in order, the variant's index in
        ``VARIANTS``, then ``extra_names()``."""
        return self._array

    def replace(self, **changes) -> Params:
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """The values by name; a variant other than the default adds its name and its parameters."""
        values = {name: getattr(self, name) for name in self.names()}
        if self.variant != DEFAULT_VARIANT:
            values.update(variant=self.variant, **{name: getattr(self, name) for name in VARIANTS[self.variant]})
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
            values = json.loads(text, object_pairs_hook=unique_keys)
        except json.JSONDecodeError as exc:
            raise ParameterError(f"{source}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
        except ParameterError:
            raise
        except (ValueError, RecursionError) as exc:  # e.g. an integer of more than 4300 digits, deep nesting
            raise ParameterError(f"{source}: not a parameter file ({str(exc).splitlines()[0][:80]})") from None
        if isinstance(values, dict):
            values.pop("metadata", None)
        return cls.from_dict(values, source)


PAPER = Params()
