"""Kinematics and shear histories. The project's conventions, written once:

- velocity gradient ``L_ij = dv_i/dx_j``; ``D = sym(L)``, ``W = (L - L^T)/2``, ``D' = D - tr(D) I/3``;
- tensor modulus ``|M| = sqrt(sum_ij M_ij**2)``;
- planar Couette shear between walls normal to e2, top wall moving along
  ``s(phi) = cos(phi) e1 + sin(phi) e3``: ``L = gamma_dot s (x) e2``, so ``D'_12 = gamma_dot/2`` at phi = 0;
  a positive phi turns the shear direction from e1 towards e3;
- strain is ``t * gamma_dot``; time is measured from the start of a period.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

E2 = np.array([0.0, 1.0, 0.0])


class HistoryError(ValueError):
    """Invalid shear history; the message names the bad value."""


def _finite(name: str, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise HistoryError(f"{name}={value!r} is not a number") from None
    if not math.isfinite(value):
        raise HistoryError(f"{name}={value!r} is not finite")
    return value


def _positive(name: str, value) -> float:
    value = _finite(name, value)
    if value <= 0:
        raise HistoryError(f"{name}={value!r} must be > 0")
    return value


def shear_direction(phi_deg) -> np.ndarray:
    """Unit vector s(phi) = cos(phi) e1 + sin(phi) e3 along which the top wall moves; an array of
    angles (degrees) gives a stack (..., 3)."""
    phi = np.radians(np.asarray(phi_deg, dtype=float))
    if not np.all(np.isfinite(phi)):
        raise HistoryError(f"phi_deg={phi_deg!r} must be finite")
    return np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], axis=-1)


def shear_velocity_gradient(phi_deg: float, shear_rate: float = 1.0) -> np.ndarray:
    """L = gamma_dot s(phi) (x) e2 for planar Couette shear (walls normal to e2), in 1/time."""
    return _positive("shear_rate", shear_rate) * np.outer(shear_direction(phi_deg), E2)


def rotation_about_e2(phi_deg: float) -> np.ndarray:
    """Rotation R with R e1 = s(phi), R e2 = e2 (turns e1 towards e3 for phi > 0)."""
    phi = math.radians(_finite("phi_deg", phi_deg))
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def stretching(L: np.ndarray) -> np.ndarray:
    """D = (L + L^T)/2."""
    return 0.5 * (L + np.swapaxes(L, -1, -2))


def spin(L: np.ndarray) -> np.ndarray:
    """W = (L - L^T)/2."""
    return 0.5 * (L - np.swapaxes(L, -1, -2))


def deviator(M: np.ndarray) -> np.ndarray:
    """M' = M - tr(M) I/3 (works on stacks (..., 3, 3))."""
    trace = np.trace(M, axis1=-2, axis2=-1)
    return M - trace[..., None, None] * np.eye(3) / 3.0


def modulus(M: np.ndarray) -> np.ndarray:
    """|M| = sqrt(sum_ij M_ij**2) (works on stacks (..., 3, 3))."""
    return np.sqrt(np.sum(M * M, axis=(-2, -1)))


@dataclass(frozen=True)
class Segment:
    """A constant velocity gradient ``L`` (1/time) applied for ``duration`` (time).

    Derived on construction: ``D_dev`` = D' and ``W`` (1/time), ``D_dev_norm`` = |D'|.
    """

    duration: float
    L: np.ndarray = field(repr=False)
    label: str = ""
    D_dev: np.ndarray = field(init=False, repr=False, compare=False)
    W: np.ndarray = field(init=False, repr=False, compare=False)
    D_dev_norm: float = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "duration", _positive("duration", self.duration))
        L = np.array(self.L, dtype=float)
        if L.shape != (3, 3):
            raise HistoryError(f"velocity gradient must be 3x3, got shape {L.shape}")
        if not np.all(np.isfinite(L)):
            raise HistoryError("velocity gradient has non-finite entries")
        D_dev = deviator(stretching(L))
        if modulus(D_dev) == 0:
            raise HistoryError("velocity gradient has no deviatoric stretching (|D'| = 0)")
        W = spin(L)
        for array in (L, D_dev, W):
            array.setflags(write=False)
        object.__setattr__(self, "L", L)
        object.__setattr__(self, "D_dev", D_dev)
        object.__setattr__(self, "W", W)
        object.__setattr__(self, "D_dev_norm", float(modulus(D_dev)))

    def rotated(self, R: np.ndarray) -> Segment:
        return Segment(self.duration, R @ self.L @ R.T, self.label)


@dataclass(frozen=True)
class PackedSegments:
    """Segments as arrays: ``end`` (m,) end times; ``D_unit`` (m, 6) D'/|D'| packed as (11, 22, 33,
    12, 13, 23); ``W_unit`` (m, 3) W/|D'| packed as (12, 13, 23); ``rate`` (m,) |D'| (1/time);
    ``D_dev`` (m, 3, 3) D' (1/time)."""

    end: np.ndarray
    D_unit: np.ndarray
    W_unit: np.ndarray
    rate: np.ndarray
    D_dev: np.ndarray


@dataclass(frozen=True)
class History:
    """A sequence of constant-L segments; ``shear_rate`` converts time to strain t*gamma_dot."""

    segments: tuple[Segment, ...]
    shear_rate: float = 1.0

    def __post_init__(self):
        segments = tuple(self.segments)
        if not segments:
            raise HistoryError("a history needs at least one segment")
        object.__setattr__(self, "segments", segments)
        object.__setattr__(self, "shear_rate", _positive("shear_rate", self.shear_rate))

    @property
    def duration(self) -> float:
        return float(self.boundaries[-1])

    @cached_property
    def boundaries(self) -> np.ndarray:
        """Segment start times and the end time, shape (n_segments + 1,)."""
        bounds = np.concatenate([[0.0], np.cumsum([seg.duration for seg in self.segments])])
        bounds.setflags(write=False)
        return bounds

    @cached_property
    def packed(self) -> PackedSegments:
        """The segments in the compiled kernels' layout (see ``PackedSegments``)."""
        norms = np.array([seg.D_dev_norm for seg in self.segments])
        D_dev = np.array([seg.D_dev for seg in self.segments])
        D_unit = D_dev / norms[:, None, None]
        W = np.array([seg.W for seg in self.segments]) / norms[:, None, None]
        packed = PackedSegments(
            end=self.boundaries[1:].copy(),
            D_unit=np.ascontiguousarray(D_unit[:, [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]),
            W_unit=np.ascontiguousarray(W[:, [0, 0, 1], [1, 2, 2]]),
            rate=norms,
            D_dev=D_dev,
        )
        for member in dataclasses.fields(packed):
            getattr(packed, member.name).setflags(write=False)
        return packed

    def segment_index(self, t: np.ndarray) -> np.ndarray:
        """Index of the segment acting at each time; a segment owns [start, end), the last one its end too."""
        t = np.asarray(t, dtype=float)
        idx = np.searchsorted(self.boundaries, t, side="right") - 1
        return np.clip(idx, 0, len(self.segments) - 1)

    def rotated(self, R: np.ndarray) -> History:
        """The same history seen in a frame rotated by R (L -> R L R^T)."""
        return History(tuple(seg.rotated(R) for seg in self.segments), self.shear_rate)


def shear_segment(strain: float, phi_deg: float, shear_rate: float = 1.0) -> Segment:
    """Planar Couette shear along s(phi) for a strain ``strain`` = t*gamma_dot."""
    strain = _positive("strain", strain)
    return Segment(strain / shear_rate, shear_velocity_gradient(phi_deg, shear_rate), f"phi={phi_deg:g}")


def steady_shear(strain: float, phi_deg: float = 0.0, shear_rate: float = 1.0) -> History:
    """Monotonic shear along s(phi)."""
    return History((shear_segment(strain, phi_deg, shear_rate),), shear_rate)


def reversal(pre_strain: float, post_strain: float, shear_rate: float = 1.0) -> History:
    """Shear along e1 for ``pre_strain``, then reversed (theta = 180 deg) for ``post_strain``."""
    segments = (shear_segment(pre_strain, 0.0, shear_rate), shear_segment(post_strain, 180.0, shear_rate))
    return History(segments, shear_rate)


PERIOD_STRAIN = 1.4  # paper Fig. 1: T = 1.4 / gamma_dot
ROTATE_AT_STRAIN = 0.7  # half period


def periodic_cycle(
    theta_deg: float,
    rotate_at: float = ROTATE_AT_STRAIN,
    period: float = PERIOD_STRAIN,
    shear_rate: float = 1.0,
) -> History:
    """One period of the paper's Fig. 1 protocol, starting when the direction turns back to e1.

    phi = 0 for 0 <= t*gamma_dot < rotate_at, phi = theta for rotate_at <= t*gamma_dot < period.
    ``rotate_at`` = 0.7 is Fig. 1; 0.1 and 0.2 with theta = 90 deg are Fig. 7.
    """
    theta = _finite("theta_deg", theta_deg)
    rotate_at = _positive("rotate_at", rotate_at)
    period = _positive("period", period)
    if rotate_at >= period:
        raise HistoryError(f"rotate_at={rotate_at:g} must be smaller than the period {period:g}")
    return History(
        (shear_segment(rotate_at, 0.0, shear_rate), shear_segment(period - rotate_at, theta, shear_rate)),
        shear_rate,
    )
