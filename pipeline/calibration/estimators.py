"""Stepwise calibration of the model from shear histories (paper Secs. 3.2-3.3 and 5), on arrays.

Every estimator takes samples along a simple-shear history between walls normal to e2: strain
(t*gamma_dot), the fabric A (n, 3, 3), tau/p (n, 3, 3) and D'/gamma_dot (n, 3, 3) (README
conventions). Nothing here reads files; ``pipeline.calibration.stepwise`` feeds it DEM cycles.

- :func:`jaumann_rate`: the Jaumann rate of A, smoothed (``pipeline.dataset.smoothing``).
- :func:`fabric_coefficients`: alpha_1, alpha_2 at every instant from Eq. 9 by least squares.
- :func:`backstress_constant`: C from Eq. 15, the slope d tau12 / d A12 near steady state after a reversal.
- :func:`yield_values`: Y at every instant from Eq. 16 (tau/p - C A projected on D'/|D'|).
- :func:`backstress_and_yield`: C and Y at every instant from the 12 and 32 components (Sec. 3.3).
- :func:`linear_fit`, :func:`power_law_exponent`: beta_i = a_i + b_i S and the exponent of Lambda = S^k.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dataset.smoothing import smooth_segments
from ..errors import CalibrationError


@dataclass(frozen=True)
class LinearFit:
    """y = intercept + slope x, with standard errors and the correlation of the two estimates."""

    intercept: float
    slope: float
    intercept_se: float
    slope_se: float
    correlation: float
    n: int


def simple_shear_gradient(D_dev: np.ndarray) -> np.ndarray:
    """L = g e2 of simple shear between walls normal to e2, from D' (g_i = 2 D'_i2, i = 1, 3)."""
    L = np.zeros_like(D_dev)
    L[..., 0, 1] = 2 * D_dev[..., 0, 1]
    L[..., 2, 1] = 2 * D_dev[..., 2, 1]
    return L


def jaumann_rate(strain: np.ndarray, A: np.ndarray, D_dev: np.ndarray, window_strain: float = 0.05,
                 polyorder: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Smoothed A and its Jaumann rate dA/dstrain + A W - W A (Eq. 9), per unit gamma_dot
    (:func:`smooth_segments` for the smoothing)."""
    smooth, rate = smooth_segments(strain, A, D_dev, window_strain, polyorder)
    L = simple_shear_gradient(D_dev)
    W = 0.5 * (L - np.swapaxes(L, -1, -2))
    return smooth, rate + smooth @ W - W @ smooth


def fabric_coefficients(A: np.ndarray, A_jaumann: np.ndarray, D_dev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """alpha_1, alpha_2 at every instant: least squares of A_jaumann = alpha_1 D' + alpha_2 |D'| A (Eq. 9).

    The fit runs over the six independent components of the symmetric tensors (off-diagonal
    components counted twice, i.e. the Frobenius norm).
    """
    norm_D = np.linalg.norm(D_dev, axis=(1, 2))
    X1 = D_dev.reshape(len(A), 9)
    X2 = (norm_D[:, None, None] * A).reshape(len(A), 9)
    y = A_jaumann.reshape(len(A), 9)
    g11, g12, g22 = (X1 * X1).sum(1), (X1 * X2).sum(1), (X2 * X2).sum(1)
    r1, r2 = (X1 * y).sum(1), (X2 * y).sum(1)
    det = g11 * g22 - g12 * g12
    with np.errstate(invalid="ignore", divide="ignore"):
        return (g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det


def yield_values(tau: np.ndarray, A: np.ndarray, D_dev: np.ndarray, C: float) -> np.ndarray:
    """Y = (tau/p - C A) : D'/|D'| at every instant (Eqs. 14/16)."""
    unit = D_dev / np.linalg.norm(D_dev, axis=(1, 2))[:, None, None]
    return np.einsum("nij,nij->n", tau - C * A, unit)


def backstress_and_yield(tau: np.ndarray, A: np.ndarray, D_dev: np.ndarray,
                         min_sine: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """C and Y at every instant from the 12 and 32 components of Eq. 14 (Sec. 3.3).

    tau_i2 = C A_i2 + Y D'_i2/|D'| for i = 1, 3: two equations in two unknowns, solvable when the
    fabric is not parallel to the shear direction in the (12, 32) plane: NaN where the sine of the
    angle between (A12, A32) and (D'12, D'32) is below ``min_sine`` (steady shear, a reversal).
    """
    unit = D_dev / np.linalg.norm(D_dev, axis=(1, 2))[:, None, None]
    a1, a3 = A[:, 0, 1], A[:, 2, 1]
    u1, u3 = unit[:, 0, 1], unit[:, 2, 1]
    t1, t3 = tau[:, 0, 1], tau[:, 2, 1]
    det = a1 * u3 - a3 * u1
    scale = np.hypot(a1, a3) * np.hypot(u1, u3)
    with np.errstate(invalid="ignore", divide="ignore"):
        ok = np.abs(det) > min_sine * scale
        C = np.where(ok, (t1 * u3 - t3 * u1) / det, np.nan)
        Y = np.where(ok, (a1 * t3 - a3 * t1) / det, np.nan)
    return C, Y


def linear_fit(x: np.ndarray, y: np.ndarray, weights: np.ndarray | None = None) -> LinearFit:
    """Least-squares line with standard errors from the residual scatter (finite samples only)."""
    ok = np.isfinite(x) & np.isfinite(y)
    w = np.ones(ok.sum()) if weights is None else weights[ok]
    x, y = x[ok], y[ok]
    if len(x) < 3:
        raise CalibrationError(f"too few samples for a line ({len(x)})")
    X = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(X * np.sqrt(w)[:, None], y * np.sqrt(w), rcond=None)
    resid = y - X @ coef
    dof = len(x) - 2
    sigma2 = (w * resid**2).sum() / dof if dof > 0 else np.nan
    cov = sigma2 * np.linalg.inv(X.T @ (X * w[:, None]))
    se = np.sqrt(np.diag(cov))
    return LinearFit(float(coef[0]), float(coef[1]), float(se[0]), float(se[1]),
                     float(cov[0, 1] / (se[0] * se[1])) if se.all() else np.nan, len(x))


def backstress_constant(strain: np.ndarray, tau: np.ndarray, A: np.ndarray, reversal_at: float,
                        window: tuple[float, float] = (0.3, 0.7), component=(0, 1)) -> LinearFit:
    """C of Eq. 15: the slope of tau_12 against A_12 over ``window`` strain after a reversal.

    Near steady state after a reversal the isotropic part Y(S) D'/|D'| has settled while the
    backstress still evolves, so d tau12 = C d A12. Only approximate: Y still drifts with S.
    """
    after = strain - reversal_at
    pick = (after >= window[0]) & (after <= window[1])
    if pick.sum() < 5:
        raise CalibrationError(f"too few samples ({pick.sum()}) in the window {window} after the reversal")
    i, j = component
    return linear_fit(A[pick, i, j], tau[pick, i, j])


def power_law_exponent(S: np.ndarray, alpha: np.ndarray, S_max: float) -> LinearFit:
    """Slope of log|alpha| against log S for 0 < S < S_max: alpha ~ S^-k means slope -k (Eq. 12)."""
    pick = (S > 0) & (S < S_max) & np.isfinite(alpha) & (alpha != 0)
    return linear_fit(np.log(S[pick]), np.log(np.abs(alpha[pick])))
