"""Model against DEM: the model's cycle for a run's protocol, and the normalised errors (no plotting).

The model runs in bulk strain (the DEM's measured central shear rate; ``global_fit.predict_cycle``),
so its cycle is compared sample by sample with the DEM's cycle average. The error of a component is
the RMSE over the cycle divided by the steady value of that component's family (the largest |A12|
or |tau12/p| of the cycle), as the issue asks.
"""

from __future__ import annotations

import numpy as np

import model

from .global_fit import CycleData, predict_cycle

COMPONENTS = {"A12": ("A", 0, 1), "A32": ("A", 2, 1), "tau12": ("tau", 0, 1), "tau32": ("tau", 2, 1)}


def model_for(run, params: model.Params) -> tuple[CycleData, model.Result]:
    data = CycleData.from_run(run)
    return data, predict_cycle(data, params)


def errors(data: CycleData, pred: model.Result) -> dict[str, float]:
    """RMSE over the cycle of A12, A32, tau12/p, tau32/p, normalised by the steady |A12| or |tau12/p|."""
    steady = {"A": np.max(np.abs(data.A[:, 0, 1])), "tau": np.max(np.abs(data.tau[:, 0, 1]))}
    out = {}
    for name, (field, i, j) in COMPONENTS.items():
        dem = getattr(data, field)[:, i, j]
        mod = getattr(pred, field)[:, i, j]
        out[name] = float(np.sqrt(np.mean((mod - dem) ** 2)) / steady[field])
    return out


def backstress_share(run, C: float) -> float:
    """Share of the backstress C A12 in the steady shear stress tau12/p (paper: 88 %)."""
    c = run.cycle
    rotate_at = run.spec["rotate_at_strain"]
    steady = (c["strain"] > rotate_at - 0.2) & (c["strain"] < rotate_at)
    return float(np.mean(C * c["A"][steady, 0, 1]) / np.mean(c["tau_over_p"][steady, 0, 1]))
