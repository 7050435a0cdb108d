"""How far the global fit's estimates move with the data: refits on copies with fresh draws of the DEM's own noise
(``bootstrap``) and refits leaving out one group of runs at a time (``jackknife``), each a typed record
(``pipeline.schema``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import CalibrationError
from ..schema import Bootstrap, Jackknife
from . import noise as noise_model
from .covariance import covariances, shift_covariance
from .fit_cycle import FitCycle
from .global_fit import GlobalFit, refine, weighed
from .naming import WEIGHT_DEFAULT
from .noise import COMPONENTS, QUANTITIES


def with_noise(data: FitCycle, noise: noise_model.NoiseModel, block: int, rng: np.random.Generator) -> FitCycle:
    """``data`` plus a draw of the measured noise: blocks of ``block`` samples of the DEM's own deviations
    (every component of A and tau at once, from a random series and start), scaled to the noise of
    ``data``'s cycle mean."""
    length = len(data.strain)
    picks = []
    while sum(len(p["A"]) for p in picks) < length:
        series = noise.pool[rng.integers(len(noise.pool))]
        start = rng.integers(len(series["A"]))
        idx = (start + np.arange(block)) % len(series["A"])
        picks.append({q: series[q][idx] for q in QUANTITIES})
    fields = {}
    for q, attr in zip(QUANTITIES, ("A", "tau"), strict=True):
        draw = np.concatenate([p[q] for p in picks])[:length]
        gain = np.ones((3, 3))
        for (i, j), target, pooled in zip(COMPONENTS, noise.sigma(q, data.n_cycles), noise.pool_sigma[q], strict=True):
            gain[i, j] = target / pooled
        fields[attr] = getattr(data, attr) + draw * gain
    return dataclasses.replace(data, **fields)


def bootstrap(data: list[FitCycle], noise: noise_model.NoiseModel, best: GlobalFit, replicates: int,
              block_strain: float = 0.2, seed: int = 0, progress=None) -> Bootstrap:
    """Refit ``best``'s parameters on ``replicates`` copies of the data, each with a fresh draw of the
    DEM's own noise added in blocks of ``block_strain`` (``with_noise``). The spread of the refits about
    ``best`` is the noise's; the basic-bootstrap 68 and 95 % intervals reflect it about ``best``."""
    block = max(1, round(block_strain / noise.sample_strain))
    rng = np.random.default_rng(seed)
    values = []
    for k in range(replicates):
        noisy = [with_noise(d, noise, block, rng) for d in data]
        values.append(refine(noisy, best.params, best.names).values)
        if progress:
            progress(k + 1, replicates)
    v = np.array(values)

    def interval(lo: float, hi: float) -> list:
        q_lo, q_hi = np.percentile(v, lo, axis=0), np.percentile(v, hi, axis=0)
        return np.stack([2 * best.values - q_hi, 2 * best.values - q_lo], axis=1).tolist()

    return Bootstrap(list(best.names), v.tolist(), v.std(axis=0, ddof=1).tolist(), block * noise.sample_strain, seed,
                     interval(16, 84), interval(2.5, 97.5))


def jackknife(data: list[FitCycle], groups: dict[str, list[int]], best: GlobalFit,
              noise: noise_model.NoiseModel | None = None, progress=None, weight: str = WEIGHT_DEFAULT,
              over: str = "") -> Jackknife:
    """Refit ``best``'s parameters leaving out one group of runs at a time (``groups``: a label for each, and
    the indices in ``data`` of its runs; at least three groups), the runs kept weighted anew by ``weight``
    (``weighed``: the same estimator on fewer runs); ``noise``: the noise model ``best`` was fitted with;
    ``over``: what the groups are ("seeds", "angles"), recorded.

    Over the seeds of one protocol, the jackknife standard error sqrt((N-1)/N sum (theta_i - mean)^2) carries
    everything that differs between seeds (the packing, the fit's nonlinearity), which a noise model measured
    within runs may miss; it redraws only the noise of the runs it leaves out, so it is told against that part
    of the sandwich (``over_their_noise``; ``covariances`` with ``runs``), not the whole (``over_sandwich``),
    which also holds every other run's noise. Over the angles, which are no exchangeable draws, it is no standard
    error; there each refit's shift from ``best`` is told in units of the standard deviation the noise alone
    would give it (``shift_covariance``): a |z| of many says the group pulls the parameter where the others do not
    follow, i.e. one parameter set does not fit every group."""
    if len(groups) < 3:
        raise CalibrationError(f"a jackknife needs at least 3 groups of runs to leave out, not {len(groups)} "
                               f"({', '.join(groups) or 'none'})")
    values, shift_z = [], []
    for k, left in enumerate(groups.values()):
        kept = [i for i in range(len(data)) if i not in left]
        reweighed = dict(zip(kept, weighed([data[i] for i in kept], weight), strict=True))
        refit = refine(list(reweighed.values()), best.params, best.names)
        values.append(refit.values)
        kept_weights = [reweighed[i].weight if i in reweighed else 0.0 for i in range(len(data))]
        with np.errstate(invalid="ignore", divide="ignore"):
            noise_only = np.sqrt(np.diag(shift_covariance(best.jacobian, data, noise, left, kept_weights)))
            shift_z.append(np.where(noise_only > 0, (refit.values - best.values) / noise_only, np.nan))
        if progress:
            progress(k + 1, len(groups))
    v = np.array(values)
    n = len(groups)
    se = np.sqrt((n - 1) / n * np.sum((v - v.mean(axis=0)) ** 2, axis=0))
    their_noise, _ = covariances(best.jacobian, data, noise, runs=[i for left in groups.values() for i in left])
    finite = lambda a: np.where(np.isfinite(a), a, None).tolist()  # noqa: E731
    return Jackknife(list(best.names), list(groups), v.tolist(), se.tolist(), (se / best.standard_errors).tolist(),
                     finite(se / np.sqrt(np.diag(their_noise))), finite(np.array(shift_z)), over)
