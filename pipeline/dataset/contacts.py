"""The contact budget's values checked where a run file is read, by the kind each field declares
(``config/raw_schema.toml`` [contacts], ``kind``):

- **term** (``budget_*``): finite from the second sample on (the first has no budget: NaN), and the four together the
  change of the measured fabric from the previous sample, to rounding (``dem/core/budget.py``'s identity);
- **count**: whole and >= 0; the contacts made and lost by load sum to their counts, and no more contacts are made out
  of a near shell than are made;
- **share**: in [0, 1] or NaN (a class or network with no member);
- **fabric** (an ``<n n> - I/3`` or a part of one): each diagonal component within [-1/3, 2/3], each other within
  [-1/2, 1/2], or NaN;
- **force**: >= 0 or NaN.

A file that breaks one is refused in one line naming the file, the field and the first sample at fault.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dem.core.schema import contact_fields

from ..errors import DemFileError

#: the largest |made + lost + kept + crossed - (A1 - A0)| taken for rounding (the engines' sums agree within 1e-13)
IDENTITY_TOLERANCE = 1e-9
#: the rounding allowed on a fabric's and a share's bounds
BOUND_TOLERANCE = 1e-9
TERMS = ("made", "lost", "kept", "crossed")


def _first_bad(bad: np.ndarray) -> int:
    """The first sample (axis 0) where ``bad`` holds anywhere."""
    return int(np.flatnonzero(bad.reshape(len(bad), -1).any(axis=1))[0])


def _refuse(path: Path, name: str, bad: np.ndarray, why: str, first: int = 0) -> None:
    """One line naming the field and its first bad sample, where ``bad`` (over the samples from ``first`` on) holds."""
    if bad.any():
        raise DemFileError(f"{path}: /contacts/{name} {why} (first at sample {first + _first_bad(bad)})")


def check_contacts(path: Path, contacts: dict, fabric: np.ndarray) -> None:
    """Refuse ``contacts`` (a run's ``/contacts``, read) where a value breaks its kind's bounds or the budget's
    identity with ``fabric`` (``/raw/fabric``, every sample)."""
    kinds = {name: info["kind"] for name, info in contact_fields().items()}
    for name, values in contacts.items():
        v = np.asarray(values, dtype=float)
        finite = np.isfinite(v)
        kind = kinds[name]
        if kind == "term":
            _refuse(path, name, ~finite[1:], "is not finite after the first sample", first=1)
        elif kind == "count":
            _refuse(path, name, ~finite, "is not finite")
            _refuse(path, name, (v < 0) | (v != np.round(v)), "is not a whole number >= 0")
        elif kind == "share":
            _refuse(path, name, finite & ((v < -BOUND_TOLERANCE) | (v > 1 + BOUND_TOLERANCE)), "is outside [0, 1]")
        elif kind == "fabric":
            diagonal = np.eye(3, dtype=bool)
            low, high = np.where(diagonal, -1 / 3, -1 / 2), np.where(diagonal, 2 / 3, 1 / 2)
            _refuse(path, name, finite & ((v < low - BOUND_TOLERANCE) | (v > high + BOUND_TOLERANCE)),
                    "has a component outside a fabric's bounds (of unit normals: [-1/3, 2/3] on the diagonal, "
                    "[-1/2, 1/2] off it)")
        elif kind == "force":
            _refuse(path, name, finite & (v < 0), "is negative")
        else:
            raise DemFileError(f"{path}: /contacts/{name} has no known kind ({kind!r})")
    total = sum(np.asarray(contacts[f"budget_{t}"], dtype=float) for t in TERMS)[1:]
    off = np.abs(total - np.diff(fabric, axis=0)) > IDENTITY_TOLERANCE
    _refuse(path, "budget_*", off, "do not sum to the change of /raw/fabric (made + lost + kept + crossed)", first=1)
    for by_load, count in (("made_by_load", "made_count"), ("lost_by_load", "lost_count")):
        if by_load in contacts:
            _refuse(path, by_load, contacts[by_load].sum(axis=1) != contacts[count], f"does not sum to {count}")
    for near in ("made_near", "made_near_change"):
        if near in contacts:
            _refuse(path, near, contacts[near] > contacts["made_count"][:, None], "exceeds made_count")
