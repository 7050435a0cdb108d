"""How a law's prediction of a held-out run is scored (``held_out``: the RMS error per component in units of the
run's noise and per the DEM's steady value) and how two laws' scores on the same runs are told apart beyond the noise
(``compared``, ``judged``)."""

from __future__ import annotations

import numpy as np

import model

from ..calibration import covariance, global_fit
from ..calibration.fit_cycle import FitCycle
from ..calibration.noise import COMPONENTS
from ..comparison import metrics
from ..schema import HeldOut, Judgement, LawScore
from .splits import protocol

#: a held-out difference "beyond the noise": the drop in chi^2 over this many standard deviations of what the noise
#: alone makes of it
BEYOND_NOISE_Z = 2.0


def steady_scale(cycle: FitCycle, quantity: np.ndarray) -> float:
    """The DEM's steady value of a quantity: the modulus of its shear part (the 12 and 32 components) over the
    cycle's last 0.2 strain."""
    late = cycle.strain >= cycle.strain[-1] - metrics.OVERSHOOT_LATE
    return float(np.mean(np.hypot(quantity[late, 0, 1], quantity[late, 2, 1])))


def held_out(run, params: model.Params, noise, stress: str, cache: dict | None = None) -> HeldOut:
    """``run`` predicted by ``params``: per component of A and of the fitted tau/p, the RMS error in units of the
    run's noise (``noise``, measured on the fit's runs) and per the DEM's steady value, and the sum of squared
    noise-scaled residuals with their count (``chi2``, ``samples``). ``blocks`` (not written) keeps, per component,
    the scaled (A, tau) residuals and the noise's correlation over them (``covariance.sample_covariance``; ``cache``
    shares the matrices) for ``compared``."""
    cycle = global_fit.scaled_cycle(run, noise, 0.0, stress)
    try:
        pred = cycle.prediction(params)
    except model.SolverError as exc:  # the fitted law cannot run this protocol's cycle: no prediction at all
        return not_predicted(run, str(exc).split(" (parameters off")[0])
    r_A, r_tau = global_fit.scaled_residuals(cycle, pred)
    blocks = [(np.concatenate([r_A[:, k], r_tau[:, k]]), covariance.sample_covariance(noise, k, cycle, cache))
              for k in range(len(COMPONENTS))]
    components, chi2, samples = {}, 0.0, 0.0
    for name, ours, dem, scale in (("A", pred.A, cycle.A, cycle.A_scale), ("tau", pred.tau, cycle.tau,
                                                                           cycle.tau_scale)):
        steady = steady_scale(cycle, dem)
        for i, j in COMPONENTS:
            if not np.all(np.isfinite(scale[:, i, j])):
                continue
            error = ours[:, i, j] - dem[:, i, j]
            in_noise = error / scale[:, i, j]
            components[f"{name}{i + 1}{j + 1}"] = {
                "rms_noise": float(np.sqrt(np.mean(in_noise**2))),
                "rms_per_steady": float(np.sqrt(np.mean(error**2)) / steady)}
            chi2, samples = chi2 + float(np.sum(in_noise**2)), samples + len(error)
    return HeldOut(run.path.stem, protocol(run), run.spec.seed, components, None, chi2, samples,
                   float(np.sqrt(chi2 / samples)), blocks)


def not_predicted(run, reason: str) -> HeldOut:
    """``held_out``'s score of a run the law gives no prediction of (its cycle cannot be run, or the law could not be
    fitted on the other runs): an infinite error, no residuals."""
    return HeldOut(run.path.stem, protocol(run), run.spec.seed, {}, reason, np.inf, 1.0, np.inf)


def information(fit: global_fit.GlobalFit, data_points: float) -> dict:
    """AIC and BIC of a fit from its chi^2 (the noise taken as Gaussian and, for the counts, white: with noise
    correlated along strain both overstate the evidence, alike for every variant)."""
    k = len(fit.names)
    return {"parameters": k, "chi2": fit.chi2, "aic": fit.chi2 + 2 * k, "bic": fit.chi2 + k * np.log(data_points)}


def compared(rows: list[HeldOut], base_rows: list[HeldOut]) -> float:
    """How far the held-out chi^2 of ``base_rows`` (Eq. 13's) lies above that of ``rows`` (a variant's, the same
    runs and noise), in standard deviations of what the noise alone makes of that difference: with r1, r2 the two
    laws' scaled residuals and C the noise's correlation, chi2_2 - chi2_1 = (r2 - r1).(r2 + r1), whose part from
    the noise has the variance 4 (r2 - r1)^T C (r2 - r1) (runs and components independent). Infinite where only
    the base cannot run a held-out cycle; nan where neither can."""
    difference = variance = 0.0
    for mine, base in zip(rows, base_rows, strict=True):
        if mine.blocks is None or base.blocks is None:
            return np.nan if mine.blocks is base.blocks else (np.inf if mine.blocks else -np.inf)
        for (r1, C), (r2, _) in zip(mine.blocks, base.blocks, strict=True):
            delta = r2 - r1
            difference += float(delta @ (r2 + r1))
            variance += 4.0 * float(delta @ C @ delta)
    return difference / np.sqrt(variance) if variance > 0 else 0.0


def pooled(rows: list[HeldOut]) -> float:
    """The RMS held-out error over ``rows`` in noise units (every sample of every scored component alike)."""
    return float(np.sqrt(sum(r.chi2 for r in rows) / sum(r.samples for r in rows)))


def judged(results: list[LawScore]) -> list[Judgement]:
    """Per law beyond the first (Eq. 13), per held-out test: both pooled RMS errors and ``compared``'s z (positive:
    the law predicts better), with the word for it (``BEYOND_NOISE_Z``)."""
    base = results[0]
    out = []
    for r in results[1:]:
        for (name, rows, ours), (_, base_rows, theirs) in zip(r.tests(), base.tests(), strict=True):
            z = compared(rows, base_rows)
            word = ("neither law so fitted runs every held-out cycle" if np.isnan(z) else
                    "better beyond the noise" if z > BEYOND_NOISE_Z else
                    "worse beyond the noise" if z < -BEYOND_NOISE_Z else "within the noise")
            out.append(Judgement(r.variant, base.variant, name, ours, theirs, z, word))
    return out
