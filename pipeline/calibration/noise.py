"""The DEM's noise, measured from the runs themselves: its size per component and its correlation along strain.

A run's cycle (the mean over its ``n`` cycles) differs from the infinitely averaged one by noise that
is neither white nor independent between A and tau: on the committed ``reduced`` runs the scatter of
A12 about its cycle mean is still 35-50 % correlated 0.05 strain later, and the A and tau noise of one
component are correlated at -0.5 to -0.65. The model here, per fitted component k (``COMPONENTS``):

- ``sigma_cycle``: the standard deviation of one cycle's A_k and tau_k/p about the run's cycle mean,
  pooled over runs, cycles and samples (``sqrt(n/(n-1))`` corrects the mean's own scatter);
- ``sigma_seed``: the standard deviation of a run's cycle mean about the mean over seeds of the same
  protocol that the cycle scatter does not explain (0 unless a protocol has three or more seeds);
- the joint autocovariance of (A_k, tau_k/p) in units of the sigmas, against lag in samples, from the
  seeds' deviations where a protocol has three or more seeds and from the cycles' otherwise; the
  biased estimator with a Bartlett taper out to Sokal's window (the smallest M >= 5 tau_int(M)), so
  every covariance matrix built from it is positive semi-definite.

A run with ``n`` cycles then carries noise of standard deviation ``sqrt(sigma_cycle^2 / n + sigma_seed^2)``
per sample, with that correlation. With one cycle per run and no seeds, the scatter about each run's
smoothed cycle stands in, white (``source`` says so): its intervals are then too narrow.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from ..dataset.derived import cycle_D_dev, cycle_indices
from ..dataset.smoothing import smooth_segments
from ..errors import CalibrationError
from ..schema import NoiseSummary

#: the tensor components the global fit compares (12, 32, 11, 22, 13)
COMPONENTS = ((0, 1), (2, 1), (0, 0), (1, 1), (0, 2))
QUANTITIES = ("A", "tau_over_p")
MAX_LAG = 100  # samples: 0.5 strain at the default sampling
MIN_SEEDS = 3  # seeds of one protocol needed to measure the seed-to-seed part
#: the least noise per sample assumed, so that model-made data without noise keep a defined fit: far below any DEM
#: cell's (the paper cell's five-cycle means scatter by 1.1-1.5e-3 in A and 6-8e-3 in tau/p, the reduced cell's
#: two-cycle means by 6-9e-3 and 0.03-0.05), so that it never stands in for a measured noise
SIGMA_FLOOR = {"A": 1e-4, "tau_over_p": 5e-4}


def per_cycle(run, key: str) -> np.ndarray:
    """The run's samples of ``key`` on its cycle grid, ``(n_cycles, n_grid - 1, 3, 3)`` (the sample that
    closes the period left out, as in the fit)."""
    spec = run.spec
    _, idx = cycle_indices(run.series["strain_nominal"], spec.period_strain, spec.sample_strain,
                           spec.n_cycles)
    return run.series[key][idx][:, :-1]


def _protocol(run) -> tuple:
    s = run.spec
    return (s.theta_deg, s.rotate_at_strain, s.period_strain, s.sample_strain, s.n_cycles)


def sokal_window(rho: np.ndarray, c: float = 5.0) -> int:
    """The smallest lag M with M >= c (1 + 2 sum_{1..M} rho); the last lag if none."""
    tau = 1.0 + 2.0 * np.cumsum(rho[1:])
    for m in range(1, len(rho)):
        if m >= c * tau[m - 1]:
            return m
    return len(rho) - 1


def joint_autocovariance(series: list[np.ndarray], max_lag: int) -> np.ndarray:
    """Gamma[lag, x, y] = sum_i s_x(i) s_y(i + lag) / N over every series ``(n, 2)`` (already in units of
    its sigmas), tapered (Bartlett) beyond Sokal's window of the two autocorrelations."""
    total = sum(len(s) for s in series)
    gamma = np.zeros((max_lag + 1, 2, 2))
    for s in series:
        for lag in range(min(max_lag, len(s) - 1) + 1):
            gamma[lag] += s[: len(s) - lag].T @ s[lag:]
    gamma /= total
    for x in range(2):
        if gamma[0, x, x] <= 0:  # a component without noise: white with unit variance
            gamma[0, x, x] = 1.0
    window = max(sokal_window(gamma[:, x, x] / gamma[0, x, x]) for x in range(2))
    taper = np.clip(1.0 - np.arange(max_lag + 1) / (window + 1), 0.0, None)
    return gamma * taper[:, None, None]


@dataclass(frozen=True)
class NoiseModel:
    """Per component k of ``COMPONENTS``: ``sigma_cycle[q][k]``, ``sigma_seed[q][k]`` for q in ``QUANTITIES``,
    and ``autocovariance[k]`` ``(lags, 2, 2)`` of (A_k, tau_k/p) in units of their sigmas (see the module)."""

    sample_strain: float
    sigma_cycle: dict
    sigma_seed: dict
    autocovariance: np.ndarray
    source: str
    pool: tuple = ()  # the deviation series measured, {q: (samples, 3, 3)}: the bootstrap draws from them
    pool_sigma: dict | None = None  # their sigma per quantity and component
    measured: bool = True  # False: one cycle per run and no seeds, the scatter about a smoothed cycle stands in

    def sigma(self, quantity: str, n_cycles: int) -> np.ndarray:
        """Per-sample noise of an ``n_cycles`` cycle mean, per component."""
        return np.sqrt(self.sigma_cycle[quantity] ** 2 / n_cycles + self.sigma_seed[quantity] ** 2)

    def correlation_strain(self) -> dict:
        """The integrated correlation length, sample_strain * (1 + 2 sum rho), per quantity and component."""
        g = self.autocovariance
        return {q: [float(self.sample_strain * (2 * np.sum(g[k, :, x, x]) / g[k, 0, x, x] - 1))
                    for k in range(len(COMPONENTS))] for x, q in enumerate(QUANTITIES)}

    def covariance(self, k: int, length: int, lag_scale: float = 1.0) -> np.ndarray:
        """Correlation matrix of the stacked (A_k over ``length`` samples, tau_k over the same samples);
        ``lag_scale``: the sampling interval in units of the measured one (interpolated between lags)."""
        g = self.autocovariance[k]
        measured = np.arange(len(g))
        steps = np.arange(length) * lag_scale  # |j - i| in measured samples
        by_lag = np.arange(length)[None, :] - np.arange(length)[:, None] + length - 1  # j - i, from 0
        out = np.empty((2 * length, 2 * length))
        for x in range(2):
            for y in range(2):
                ahead = np.interp(steps, measured, g[:, x, y], right=0.0)  # j >= i
                behind = np.interp(steps, measured, g[:, y, x], right=0.0)  # j < i: the pair the other way
                out[x * length:(x + 1) * length, y * length:(y + 1) * length] = np.concatenate(
                    [behind[:0:-1], ahead])[by_lag]
        return out

    def summary(self) -> NoiseSummary:
        """The record ``fit.json`` keeps."""
        g = self.autocovariance
        lag = lambda k: min(round(0.05 / self.sample_strain), len(g[k]) - 1)  # noqa: E731
        return NoiseSummary(self.source, self.measured, [f"{i + 1}{j + 1}" for i, j in COMPONENTS],
                            {q: self.sigma_cycle[q].tolist() for q in QUANTITIES},
                            {q: self.sigma_seed[q].tolist() for q in QUANTITIES}, self.correlation_strain(),
                            [float(g[k, 0, 0, 1]) for k in range(len(COMPONENTS))],
                            {q: [float(g[k, lag(k), x, x]) for k in range(len(g))] for x, q in enumerate(QUANTITIES)})


def _deviation_series(blocks: list[dict], sigma: dict) -> list[list[np.ndarray]]:
    """Per component, the list of (A, tau) deviation series in units of ``sigma``."""
    out = [[] for _ in COMPONENTS]
    for b in blocks:
        for k, (i, j) in enumerate(COMPONENTS):
            for c in range(b["A"].shape[0]):
                out[k].append(np.stack([b[q][c, :, i, j] / sigma[q][k] for q in QUANTITIES], axis=1))
    return out


def _pooled_sigma(blocks: list[dict]) -> dict:
    """Root mean square of the deviations per quantity and component, at least ``SIGMA_FLOOR``."""
    def rms(q, i, j):
        return np.sqrt(np.mean(np.concatenate([b[q][:, :, i, j].ravel() for b in blocks]) ** 2))

    return {q: np.maximum(SIGMA_FLOOR[q], [rms(q, i, j) for i, j in COMPONENTS]) for q in QUANTITIES}


def _white_scatter(runs: list) -> NoiseModel:
    """One cycle per run and no seeds: rms scatter about each run's smoothed cycle, taken as white."""
    devs = []
    for run in runs:
        c = run.cycle
        D = cycle_D_dev(run)
        dev = {}
        for q in QUANTITIES:
            smooth, _ = smooth_segments(c["strain"], c[q], D, window_strain=0.05)
            dev[q] = (c[q] - smooth)[None, :-1]
        devs.append(dev)
    sigma = _pooled_sigma(devs)
    gamma = np.zeros((len(COMPONENTS), 1, 2, 2))
    gamma[:, 0] = np.eye(2)
    zero = {q: np.zeros(len(COMPONENTS)) for q in QUANTITIES}
    pool = tuple({q: d[q][0] for q in QUANTITIES} for d in devs)
    return NoiseModel(runs[0].spec.sample_strain, sigma, zero, gamma,
                      "scatter about each run's smoothed cycle, taken as white (one cycle per run, no seeds: "
                      "the noise is not measurable)", pool, sigma, measured=False)


def _seed_deviations(runs: list) -> tuple[list[dict], list[int]]:
    """Each run's cycle mean about the mean of its protocol's seeds (protocols with >= MIN_SEEDS seeds),
    scaled by sqrt(R/(R-1)); and the cycle counts of those runs."""
    groups = defaultdict(list)
    for run in runs:
        groups[_protocol(run)].append({q: per_cycle(run, q).mean(axis=0) for q in QUANTITIES})
    deviations, n_cycles = [], []
    for key, means in groups.items():
        R = len(means)
        if R < MIN_SEEDS:
            continue
        stacked = {q: np.array([m[q] for m in means]) for q in QUANTITIES}
        deviations += [{q: ((stacked[q][r] - stacked[q].mean(axis=0)) * np.sqrt(R / (R - 1)))[None]
                        for q in QUANTITIES} for r in range(R)]
        n_cycles += [key[4]] * R
    return deviations, n_cycles


def estimate(runs: list) -> NoiseModel:
    """The noise model of ``runs`` (read with the definitions they carry); see the module docstring."""
    if not runs:
        raise CalibrationError("no run to measure the noise on")
    steps = {r.spec.sample_strain for r in runs}
    if len(steps) > 1:
        raise CalibrationError(f"runs sampled at different strains ({sorted(steps)}): fit them separately")
    cycles = []
    for run in runs:
        n = run.spec.n_cycles
        if n > 1:
            cycles.append({q: (x - x.mean(axis=0)) * np.sqrt(n / (n - 1))
                           for q in QUANTITIES for x in [per_cycle(run, q)]})
    seeds, seed_cycles = _seed_deviations(runs)
    zero = {q: np.zeros(len(COMPONENTS)) for q in QUANTITIES}
    if seeds:
        seed_sigma = _pooled_sigma(seeds)
        if cycles:
            sigma_cycle = _pooled_sigma(cycles)
            n = np.mean(seed_cycles)
            sigma_seed = {q: np.sqrt(np.clip(seed_sigma[q] ** 2 - sigma_cycle[q] ** 2 / n, 0.0, None))
                          for q in QUANTITIES}
        else:  # one cycle per seed: all of the seeds' scatter counts as one cycle's
            sigma_cycle, sigma_seed = seed_sigma, zero
        blocks, sigma, source = seeds, seed_sigma, "the seeds' cycle means about their protocol's mean"
    elif cycles:
        sigma_cycle = _pooled_sigma(cycles)
        sigma_seed, blocks, sigma, source = zero, cycles, sigma_cycle, "the cycles about their run's cycle mean"
    else:
        return _white_scatter(runs)
    series = _deviation_series(blocks, sigma)
    gamma = np.array([joint_autocovariance(s, MAX_LAG) for s in series])
    pool = tuple({q: b[q][c] for q in QUANTITIES} for b in blocks for c in range(b["A"].shape[0]))
    return NoiseModel(runs[0].spec.sample_strain, sigma_cycle, sigma_seed, gamma, f"correlation from {source}",
                      pool, sigma)
