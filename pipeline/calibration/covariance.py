"""The covariance of the global fit's estimates (``global_fit.refine``): the sandwich ``H^-1 J^T Sigma J H^-1``
with ``H = J^T J`` and ``Sigma`` the noise's measured correlation along strain and between A and tau/p
(``noise.NoiseModel``), run by run; the part of it from some runs' noise; the covariance of a refit's shift when
runs are left out; and the eigen-directions of a covariance, weakest first."""

from __future__ import annotations

import numpy as np

from . import noise as noise_model
from .fit_cycle import FitCycle
from .noise import COMPONENTS


def directions(covariance: np.ndarray, values: np.ndarray, names) -> tuple[dict, ...]:
    """Eigen-directions of the covariance in relative parameters (d ln theta), weakest first.

    ``relative_step`` is one standard deviation along the direction, as a relative change: a large
    step is a combination the data do not fix; ``inf`` where they fix nothing at all.
    """
    scale = np.where(values != 0, np.abs(values), 1.0)
    finite = np.where(np.isfinite(covariance), covariance, 0.0)
    strength, vectors = np.linalg.eigh(finite / np.outer(scale, scale))
    undetermined = ~np.isfinite(np.diag(covariance))
    out = []
    for lam, v in zip(strength[::-1], vectors.T[::-1], strict=True):
        v = v * np.sign(v[np.argmax(np.abs(v))])
        step = np.inf if np.any(undetermined & (np.abs(v) > 0.01)) else float(np.sqrt(max(lam, 0.0)))
        out.append({"relative_step": step, "direction": {n: float(c) for n, c in zip(names, v, strict=True)}})
    return tuple(sorted(out, key=lambda d: -d["relative_step"]))


def sample_covariance(noise: noise_model.NoiseModel, k: int, d: FitCycle, cache: dict | None = None) -> np.ndarray:
    """The noise's correlation of component ``k`` over the cycle's (A, tau) samples, at the cycle's sampling step
    (the noise's lags scaled to it: ``NoiseModel.covariance``); for a restarted cycle, the rows and columns of its
    kept samples out of the full grid's (the gaps keep their true lags). ``cache`` keeps each full grid's matrix
    for the next cycle of the same grid."""
    index = np.arange(len(d.strain)) if d.grid_index is None else d.grid_index
    full = int(index[-1]) + 1
    key = (k, full, round((d.sample_step or noise.sample_strain) / noise.sample_strain, 9))
    cache = {} if cache is None else cache
    if key not in cache:
        cache[key] = noise.covariance(k, full, lag_scale=key[2])
    if d.grid_index is None:
        return cache[key]
    pick = np.concatenate([index, index + full])
    return cache[key][np.ix_(pick, pick)]


def run_parts(jac: np.ndarray, data: list[FitCycle], noise: noise_model.NoiseModel | None,
              cache: dict | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each run's parts of the least squares, ``(J^T J, J^T Sigma J)``, with ``J`` its unweighted rows of ``jac``
    (the Jacobian of the weighted residuals: per run, per component, the A block then the tau block) and
    ``Sigma`` the noise's correlation (``sample_covariance``; white without a noise model); the noise is
    independent between runs and components. ``cache``: as for ``sample_covariance``."""
    out, row, cache = [], 0, {} if cache is None else cache
    for d in data:
        length, JJ, JSJ = len(d.strain), 0.0, 0.0
        for k in range(len(COMPONENTS)):
            J = jac[row:row + 2 * length] / np.sqrt(d.weight)
            sigma = np.eye(2 * length) if noise is None else sample_covariance(noise, k, d, cache)
            JJ, JSJ, row = JJ + J.T @ J, JSJ + J.T @ sigma @ J, row + 2 * length
        out.append((JJ, JSJ))
    return out


def sandwich(parts: list[tuple], weights: list[float], runs=None) -> tuple[np.ndarray, np.ndarray]:
    """(sandwich, white) covariance of the least squares over runs with ``parts`` (``run_parts``) weighted by
    ``weights``: ``H^-1 M H^-1`` with ``H = sum w J^T J`` and ``M = sum w^2 J^T Sigma J``, and ``H^-1`` (the noise
    taken as white). With ``runs`` (indices) ``M`` sums those runs alone: the part of the sandwich from their noise
    (the parts add up to the whole). Parameters the data do not fix (a null direction of H) get infinite
    variance."""
    H = sum(w * JJ for w, (JJ, _) in zip(weights, parts, strict=True))
    strength, vectors = np.linalg.eigh(H)
    null = strength <= 1e-10 * max(strength.max(), 1e-300)
    inverse = np.linalg.pinv(H, hermitian=True, rcond=1e-10)
    runs = range(len(parts)) if runs is None else set(runs)
    meat = sum(w**2 * JSJ for i, (w, (_, JSJ)) in enumerate(zip(weights, parts, strict=True)) if i in runs)
    covariance, white = inverse @ meat @ inverse, inverse.copy()
    loose = np.any(np.abs(vectors[:, null]) > 0.01, axis=1)
    for m in (covariance, white):
        m[loose, :] = np.inf
        m[:, loose] = np.inf
    return covariance, white


def covariances(jac: np.ndarray, data: list[FitCycle], noise: noise_model.NoiseModel | None,
                runs=None) -> tuple:
    """``sandwich`` of the fit whose weighted residuals have the Jacobian ``jac`` over ``data``: (the sandwich
    ``H^-1 J^T W Sigma W J H^-1``, ``W`` the runs' weights, or with ``runs`` its part from those runs' noise;
    ``H^-1``, the noise taken as white)."""
    return sandwich(run_parts(jac, data, noise), [d.weight for d in data], runs)


def shift_covariance(jac: np.ndarray, data: list[FitCycle], noise: noise_model.NoiseModel | None,
                     left_out: list[int], kept_weights: list[float] | None = None) -> np.ndarray:
    """The covariance, from the noise alone, of (the fit without the runs ``left_out``) - (the fit with all),
    linearized about the fit with all (``jac``, the Jacobian of its weighted residuals): each is
    ``-H^-1 J^T W r`` over its own runs with its own weights ``W`` (the kept runs': ``kept_weights``, one per run
    of ``data``, by default their weights in the fit with all), and the noise is independent between runs, so
    the shift's covariance is the sum over runs of ``P J^T Sigma J P^T`` with
    ``P = w_kept H_kept^-1 - w H^-1`` (``J`` unweighted; ``w_kept`` = 0 for a run left out)."""
    weights = [0.0 if i in left_out else (d.weight if kept_weights is None else kept_weights[i])
               for i, d in enumerate(data)]
    parts = run_parts(jac, data, noise)
    inverse = np.linalg.pinv(jac.T @ jac, hermitian=True, rcond=1e-10)
    inverse_kept = np.linalg.pinv(sum(w * JJ for w, (JJ, _) in zip(weights, parts, strict=True)), hermitian=True,
                                  rcond=1e-10)
    out = np.zeros_like(inverse)
    for w_kept, d, (_, JSJ) in zip(weights, data, parts, strict=True):
        P = w_kept * inverse_kept - d.weight * inverse
        out += P @ JSJ @ P.T
    return out
