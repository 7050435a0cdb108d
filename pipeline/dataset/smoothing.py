"""Smoothing of sampled series and the strain over which a transient relaxes (numpy and scipy; no I/O).

Series are sampled along a simple-shear history between walls normal to e2 (docs/conventions.md):
strain t*gamma_dot, values (n, ...) and D'/gamma_dot (n, 3, 3); a change of D' starts a new segment.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import OptimizeWarning, curve_fit
from scipy.signal import savgol_filter

from ..errors import CalibrationError


def segments(D_dev: np.ndarray, tol: float = 1e-9) -> list[slice]:
    """Index ranges of constant D' (the shear direction changes between them)."""
    change = np.flatnonzero(np.abs(np.diff(D_dev, axis=0)).max(axis=(1, 2)) > tol) + 1
    bounds = np.concatenate([[0], change, [len(D_dev)]])
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def smooth_segments(strain: np.ndarray, X: np.ndarray, D_dev: np.ndarray, window_strain: float = 0.05,
                    polyorder: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """X (n, ...) smoothed, and its derivative per unit strain, segment by segment of constant D'.

    A Savitzky-Golay filter (``window_strain`` wide, polynomial order ``polyorder``) within each
    segment of constant direction, so that the jump of the rates at a rotation is not smeared; a
    segment shorter than the window is fitted with its own length (NaN when it has fewer than
    ``polyorder + 2`` samples). Samples must be evenly spaced in strain.
    """
    step = np.median(np.diff(strain))
    if not np.allclose(np.diff(strain), step, rtol=0.05, atol=0):
        raise CalibrationError("samples are not evenly spaced in strain")
    smooth = np.full_like(X, np.nan)
    rate = np.full_like(X, np.nan)
    for seg in segments(D_dev):
        n = seg.stop - seg.start
        window = min(int(round(window_strain / step)) | 1, n if n % 2 else n - 1)
        if window < polyorder + 2:
            continue
        smooth[seg] = savgol_filter(X[seg], window, polyorder, axis=0, mode="interp")
        rate[seg] = savgol_filter(X[seg], window, polyorder, deriv=1, delta=step, axis=0, mode="interp")
    return smooth, rate


def relaxation_strain(strain: np.ndarray, x: np.ndarray, fraction: float = 0.05, skip: float = 0.02) -> float:
    """Strain after which x stays within ``fraction`` of its total change from its final value.

    From a least-squares fit x = x_end + (x_start - x_end) exp(-(strain - strain[0]) / lam) to the
    points after ``skip`` (where smoothing blurs a jump): lam ln(1/fraction). A fit rather than a
    threshold crossing, so that noise of the size of the change does not decide the answer; nan
    where the fit fails or does not fix lam to better than +-50 %.
    """
    s = np.asarray(strain, dtype=float) - strain[0]
    x = np.asarray(x, dtype=float)
    keep = (s >= skip) & np.isfinite(x)
    s, x = s[keep], x[keep]
    if len(s) < 5:
        return float("nan")
    tail = np.mean(x[-max(len(x) // 5, 2):])

    def curve(t, end, start, lam):
        return end + (start - end) * np.exp(-t / lam)

    try:
        with warnings.catch_warnings(), np.errstate(over="ignore"):  # a trial lam < 0 overflows exp on the way
            warnings.simplefilter("ignore", OptimizeWarning)  # an exact fit has no covariance
            coef, cov = curve_fit(curve, s, x, p0=(tail, x[0], 0.1 * s[-1]), maxfev=5000)
    except (RuntimeError, ValueError):
        return float("nan")
    lam = coef[2]
    exact = np.max(np.abs(curve(s, *coef) - x)) <= 1e-6 * np.ptp(x)
    determined = 0 < lam < 10 * s[-1] and (exact or np.sqrt(cov[2, 2]) < 0.5 * lam)
    return float(lam * np.log(1.0 / fraction)) if determined else float("nan")
