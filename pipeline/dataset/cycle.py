"""A run's periodic cycle as the model is compared with it: one frozen type for calibration and comparison."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

import model

from .derived import bulk_over_nominal


@dataclass(frozen=True)
class Cycle:
    """One run's cycle-averaged periodic cycle on the nominal strain grid (the period's closing sample left
    out), with its protocol and the per-sample scale of each component of A and tau/p (1 unless a noise
    model sets it: ``with_scales``). ``bulk_over_nominal`` is the run's strain measure per nominal strain."""

    theta_deg: float
    rotate_at: float
    period: float
    bulk_over_nominal: float
    n_cycles: int
    strain: np.ndarray
    A: np.ndarray
    tau: np.ndarray
    A_scale: np.ndarray
    tau_scale: np.ndarray
    phi: np.ndarray

    @classmethod
    def from_run(cls, run) -> Cycle:
        """The cycle of a :class:`pipeline.dataset.dem_file.DemRun`, read with its definitions."""
        c = run.cycle
        # the last sample closes the period: the DEM has turned back to e1 there, the model's output
        # at the period's end has not, so it is left out
        keep = slice(0, -1)
        ones = np.ones((len(c["strain"][keep]), 3, 3))
        return cls(run.spec["theta_deg"], run.spec["rotate_at_strain"], run.spec["period_strain"],
                   bulk_over_nominal(run), run.spec["n_cycles"], c["strain"][keep], c["A"][keep],
                   c["tau_over_p"][keep], ones, ones, c["packing_fraction"][keep])

    def with_scales(self, A_scale: np.ndarray, tau_scale: np.ndarray) -> Cycle:
        return dataclasses.replace(self, A_scale=A_scale, tau_scale=tau_scale)

    def prediction(self, params: model.Params) -> model.Result:
        """The model's periodic cycle for this protocol, in the cycle's strain measure, at its samples."""
        r = self.bulk_over_nominal
        history = model.periodic_cycle(self.theta_deg, rotate_at=r * self.rotate_at, period=r * self.period)
        return model.periodic(history, params=params, times=r * self.strain)
