"""A run's periodic cycle: its protocol and the cycle-averaged A, tau/p and Phi on the nominal strain grid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .derived import bulk_over_nominal


@dataclass(frozen=True)
class Cycle:
    """One run's cycle-averaged periodic cycle on the nominal strain grid (the period's closing sample left
    out), with its protocol. ``bulk_over_nominal`` is the run's strain measure per nominal strain."""

    theta_deg: float
    rotate_at: float
    period: float
    bulk_over_nominal: float
    n_cycles: int
    strain: np.ndarray
    A: np.ndarray
    tau: np.ndarray
    phi: np.ndarray

    @classmethod
    def from_run(cls, run, **extra):
        """The cycle of a :class:`pipeline.dataset.dem_file.DemRun`, read with its definitions (``extra``: the
        fields a subclass adds)."""
        c = run.cycle
        # the last sample closes the period: the DEM has turned back to e1 there, the model's output
        # at the period's end has not, so it is left out
        keep = slice(0, -1)
        return cls(run.spec.theta_deg, run.spec.rotate_at_strain, run.spec.period_strain, bulk_over_nominal(run),
                   run.spec.n_cycles, c["strain"][keep], c["A"][keep], c["tau_over_p"][keep],
                   c["packing_fraction"][keep], **extra)
