"""Where the global fit's residuals are largest (``fit.json`` → ``global`` → ``residual_map``): its chi^2 split by
run, quantity and strain since the last change of direction. A feature the model does not resolve, such as the
jump right after a reversal, shows here before a parameter that absorbed it is trusted.
"""

from __future__ import annotations

import numpy as np

from ..schema import ResidualCell
from . import global_fit
from .fit_cycle import FitCycle
from .noise import COMPONENTS

#: strain since the last change of direction (the bulk or nominal measure of the fit), window edges
WINDOWS = (0.0, 0.005, 0.02, 0.1, 0.3, np.inf)
LABELS = [f"{''.join(str(i + 1) for i in c)}" for c in COMPONENTS]


def strain_since_change(d: FitCycle, strain: np.ndarray) -> np.ndarray:
    """Strain since the last change of direction of a cycle's samples (changes at 0 and ``rotate_at``)."""
    return np.where(strain >= d.rotate_at - 1e-9, strain - d.rotate_at, strain)


def sample_strains(d: FitCycle) -> np.ndarray:
    """The cycle strains of ``global_fit.residuals``' rows for ``d`` (restart segments in their order)."""
    if not d.restarts:
        return d.strain
    return np.concatenate([d.strain[d.segment_mask(k)] for k in range(len(d.restarts))])


def residual_map(fit: global_fit.GlobalFit, data: list[FitCycle], windows: tuple = WINDOWS) -> list[ResidualCell]:
    """Per run, fitted quantity (A_ij, tau_ij/p) and window of ``windows`` (edges in strain since a change):
    samples, chi^2, its share of the total and its chi^2 per sample over the fit's mean per sample; largest share
    first. A component the fit leaves out
    (an infinite scale: ``global_fit.STRESS_FITS``) has no row and no samples in the mean."""
    r = global_fit.residuals(fit.values, data, fit.params, fit.names)
    rows, at = [], 0
    for d in data:
        since = strain_since_change(d, sample_strains(d))
        window = np.digitize(since, windows[1:-1])
        for label, (i, j) in zip(LABELS, COMPONENTS, strict=True):
            for quantity, scale in ((f"A{label}", d.A_scale), (f"tau{label}/p", d.tau_scale)):
                block = r[at:at + len(since)] ** 2
                at += len(since)
                if not np.isfinite(scale[:, i, j]).all():
                    continue
                for w in range(len(windows) - 1):
                    pick = window == w
                    if pick.any():
                        rows.append({"theta_deg": d.theta_deg, "rotate_at": d.rotate_at, "quantity": quantity,
                                     "window": [windows[w], windows[w + 1]], "samples": int(pick.sum()),
                                     "chi2": float(block[pick].sum())})
    if at != len(r):
        raise ValueError(f"residual rows {len(r)} != mapped samples {at}")
    total, count = sum(x["chi2"] for x in rows), sum(x["samples"] for x in rows)
    if total == 0:  # exact data: nothing to map
        return []
    mean = total / count
    cells = [ResidualCell(**x, share=x["chi2"] / total, per_sample_over_mean=x["chi2"] / x["samples"] / mean)
             for x in rows]
    return sorted(cells, key=lambda c: -c.share)
