"""Model parameters: one frozen, validated dataclass (defaults: the paper's Table 2 and Sec. 5).

Every parameter is dimensionless. Names follow the paper:

- flow rule (Eqs. 14/20, 22):        tau/p = C A + Y(S) D'/|D'|,  Y = n + m S
- fabric equation (Eqs. 13/23-25):   Lambda(S) A_jaumann = beta1 D' + beta2 |D'| A,
                                     beta_i = a_i + b_i S,  Lambda = S**persistence_exponent
- dilatancy (Eq. 18):                dPhi/dt / Phi = c1 A:D' + c2(S) (phi_c - Phi + c3) |D'|,
                                     c2(S) = c2_coef * S**c2_exponent
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, fields

import numpy as np


class ParameterError(ValueError):
    """Invalid model parameters; the message names every bad value."""


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

    def __post_init__(self):
        problems = []
        for f in fields(self):
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
        if problems:
            raise ParameterError("invalid model parameters: " + "; ".join(problems))
        array = np.array([getattr(self, name) for name in self.names()], dtype=float)
        array.setflags(write=False)
        object.__setattr__(self, "_array", array)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def as_array(self) -> np.ndarray:
        """Parameters in declaration order, as the compiled kernels expect them (read-only)."""
        return self._array

    def replace(self, **changes) -> Params:
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, float]:
        return {name: getattr(self, name) for name in self.names()}

    @classmethod
    def from_dict(cls, values: dict, source: str = "parameters") -> Params:
        """Build from a complete mapping; unknown or missing keys are an error."""
        if not isinstance(values, dict):
            raise ParameterError(f"{source}: expected a JSON object of parameters, got {type(values).__name__}")
        unknown = sorted(set(values) - set(cls.names()))
        missing = [name for name in cls.names() if name not in values]
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
