"""A run's cycle as a fit sees it: the data (``pipeline.dataset.cycle.Cycle``) with the scale of each sample's noise,
its weight in the fit, the restarts of a fit past the reversal jump, and the model at its samples."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

import model

from ..dataset.cycle import Cycle


@dataclass(frozen=True)
class FitCycle(Cycle):
    """A :class:`Cycle` with, per sample, the scale of each component of A and tau/p (ones unless a noise model
    sets them: ``with_scales``), the samples kept (``grid_index``: indices into the full cycle grid, None for
    all), the restarts of a fit past the jump (``restarted``) and the weight of its squared residuals."""

    A_scale: np.ndarray | None = None
    tau_scale: np.ndarray | None = None
    grid_index: np.ndarray | None = None
    #: with ``fit_from`` > 0: per segment of constant direction, (start strain, end strain, phi in degrees,
    #: the DEM's A and Phi at the start) from which the model restarts
    restarts: tuple = ()
    fit_from: float = 0.0
    #: the weight of this run's squared residuals in a fit (``global_fit.weighed``): 1, or 1 / the number of runs
    #: of its protocol when each protocol counts once
    weight: float = 1.0

    def __post_init__(self):
        ones = np.ones((len(self.strain), 3, 3))
        for name in ("A_scale", "tau_scale"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, ones)

    @property
    def sample_step(self) -> float:
        """The strain between samples of the full cycle grid (a restarted cycle's gaps left aside)."""
        index = np.arange(len(self.strain)) if self.grid_index is None else self.grid_index
        return float((self.strain[-1] - self.strain[0]) / (index[-1] - index[0])) if len(index) > 1 else 0.0

    def with_scales(self, A_scale: np.ndarray, tau_scale: np.ndarray) -> FitCycle:
        return dataclasses.replace(self, A_scale=A_scale, tau_scale=tau_scale)

    def restarted(self, fit_from: float, states=None) -> FitCycle:
        """The cycle fitted past the first ``fit_from`` strain after each change of direction (nominal strain):
        the samples before it are dropped, and the model restarts each segment from the DEM's cycle-mean A and
        Phi at the segment's start plus ``fit_from``. Those come from the cycle's own samples when ``fit_from``
        is a multiple of the sampling step, else from ``states`` = (A (2, 3, 3), Phi (2,)) at that strain
        past each of the two changes (``derived.states_after_changes``: the dense samples)."""
        if fit_from == 0:
            return self
        step = self.strain[1] - self.strain[0]
        k = fit_from / step
        shortest = min(self.rotate_at, self.period - self.rotate_at)
        on_grid = abs(k - round(k)) <= 1e-6
        if not 0 < fit_from < shortest or not (on_grid or states is not None):
            raise ValueError(f"fit_from={fit_from!r} must be a multiple of the sampling step {step:g}, or have dense "
                             "samples in every cycle, inside each segment of constant direction")
        keep, restarts = [], []
        segments = ((0.0, self.rotate_at, 0.0), (self.rotate_at, self.period, self.theta_deg))
        for j, (start, end, phi) in enumerate(segments):
            restart = start + fit_from
            inside = np.flatnonzero((self.strain >= restart - 1e-9) & (self.strain < end - 1e-9))
            keep.append(inside)
            if on_grid:
                first = inside[0]
                restarts.append((float(self.strain[first]), float(end), float(phi), self.A[first],
                                 float(self.phi[first])))
            else:
                restarts.append((float(restart), float(end), float(phi), states[0][j], float(states[1][j])))
        idx = np.concatenate(keep)
        return dataclasses.replace(self, strain=self.strain[idx], A=self.A[idx], tau=self.tau[idx],
                                   A_scale=self.A_scale[idx], tau_scale=self.tau_scale[idx], phi=self.phi[idx],
                                   grid_index=idx, restarts=tuple(restarts), fit_from=float(fit_from))

    def prediction(self, params: model.Params):
        """The model at the cycle's samples, in the cycle's strain measure: its converged periodic cycle, or,
        for a restarted cycle, each segment integrated from the DEM's state at its restart (``.A``, ``.tau``,
        ``.packing_fraction`` on the kept samples)."""
        if not self.restarts:
            r = self.bulk_over_nominal
            history = model.periodic_cycle(self.theta_deg, rotate_at=r * self.rotate_at, period=r * self.period)
            return model.periodic(history, params=params, times=r * self.strain)
        parts = [self.segment_prediction(params, k) for k in range(len(self.restarts))]
        return SegmentPrediction(*(np.concatenate([getattr(p, k) for p in parts])
                                   for k in ("A", "tau", "packing_fraction")))

    def segment_mask(self, k: int) -> np.ndarray:
        """The kept samples of restart segment ``k``."""
        start, end = self.restarts[k][:2]
        return (self.strain >= start - 1e-9) & (self.strain < end - 1e-9)

    def segment_prediction(self, params: model.Params, k: int, A0_offset=0.0) -> model.Result:
        """The model over restart segment ``k``'s samples from the DEM's A (plus ``A0_offset``) and Phi at its start."""
        start, end, phi, A0, phi0 = self.restarts[k]
        r = self.bulk_over_nominal
        history = model.History((model.shear_segment(r * (end - start), phi),))
        return model.integrate(history, A0=A0 + A0_offset, packing_fraction0=phi0, params=params,
                               times=r * (self.strain[self.segment_mask(k)] - start))


@dataclass(frozen=True)
class SegmentPrediction:
    """The model on a restarted cycle's kept samples."""

    A: np.ndarray
    tau: np.ndarray
    packing_fraction: np.ndarray
