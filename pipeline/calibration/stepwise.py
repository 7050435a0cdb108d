"""The paper's stepwise calibration (Secs. 3.2, 3.3, 4 and 5) of one reversal run's cycle, on arrays.

Per run, on the cycle (two reversals: 180 -> 0 deg at strain 0 and 0 -> 180 deg at ``rotate_at``),
with rates per unit *bulk* strain (the measured central shear rate); A and tau are first smoothed
segment by segment (Savitzky-Golay, ``window``):
1. C by Eq. 15, the slope d tau12 / d A12 over ``c_window`` after each reversal (averaged). On
   model data this returns C - 2m, not C (tests/unit/test_calibrate.py).
2. Y = (tau/p - C A) : D'/|D'| at every sample (Eq. 16), fitted as n + m S.
3. alpha_1, alpha_2 from Eq. 9 with the Jaumann rate of A, then beta_i = alpha_i S^k (k = 3/4)
   fitted as a_i + b_i S over the fabric's transients; k itself from the log-log slope of |alpha_i|
   at S < ``s_small``.
4. Dilatancy (Eq. 18) with c1 = -C (Eq. 19), c2 = c2_coef S^(1/3) and c3 held at ``Params().c3``:
   ``dilatancy_estimate``.
Sec. 3.3 cross-check on the other angles: C and Y at every instant from the 12 and 32 components
of Eq. 14 (``cross_check_run``). Across runs: the mean and its standard error (``combine``).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.stats

import model

from ..dataset.derived import bulk_over_nominal, cycle_D_dev, resampled_cycle
from ..dataset.smoothing import relaxation_strain, smooth_segments
from ..errors import CalibrationError
from ..schema import StepwiseBootstrap
from . import estimators as cal


def dilatancy_estimate(strain, phi, dphi, A, D, S, c1: float, bulk_over_nominal: float, rotate_at: float,
                       c3: float = model.Params().c3, ref_window: float = 0.1) -> tuple[float, float]:
    """c2_coef and Phi_c of Eq. 18 (c2 = c2_coef S^(1/3)) from Phi(t), with c1 and c3 given.

    Phi barely moves, so Phi_c + c3 and c2 are nearly collinear in a direct regression. Instead
    Phi_c + c3 is eliminated with Eq. 18 at a reference r, the last ``ref_window`` of strain before
    the reversal (r_dot = Phi_dot/Phi - c1 A:D' there, and Phi_c + c3 = Phi_r + r_dot / (c2_r |D'|_r)),
    which leaves one coefficient, regressed through 0:
    Phi_dot/Phi - c1 A:D' - r_dot (S/S_r)^(1/3) |D'|/|D'|_r = c2_coef S^(1/3) |D'| (Phi_r - Phi).
    ``dphi`` is dPhi/dstrain (nominal); rates are per unit bulk strain (D per unit rate).
    """
    rate = dphi / bulk_over_nominal / phi - c1 * np.einsum("nij,nij->n", A, D)
    norm_D = np.linalg.norm(D, axis=(1, 2))
    ref = (strain > rotate_at - ref_window) & (strain < rotate_at)
    phi_r, rate_r, S_r, norm_r = (float(np.mean(v[ref])) for v in (phi, rate, S, norm_D))
    x = S ** (1 / 3) * norm_D * (phi_r - phi)
    y = rate - rate_r * (S / S_r) ** (1 / 3) * norm_D / norm_r
    ok = np.isfinite(x) & np.isfinite(y) & (S > 0)
    c2_coef = float(np.dot(x[ok], y[ok]) / np.dot(x[ok], x[ok]))
    phi_c = phi_r + rate_r / (c2_coef * S_r ** (1 / 3) * norm_r) - c3
    return c2_coef, float(phi_c)


def calibrate_run(run, window: float = 0.05, c_window=(0.3, 0.69), s_small: float = 0.02,
                  transient_efolds: float = 2.0, cycle: dict | None = None) -> dict:
    """Every stepwise estimate of one reversal run (see the module docstring); ``cycle`` replaces the
    run's own cycle (a bootstrap resample)."""
    if not run.is_reversal:
        raise CalibrationError(f"{run.path} is not a reversal run (theta = {run.spec.theta_deg})")
    c = run.cycle if cycle is None else cycle
    strain, A, tau, phi = c["strain"], c["A"], c["tau_over_p"], c["packing_fraction"]
    rotate_at = run.spec.rotate_at_strain
    D = cycle_D_dev(run)  # per unit nominal gamma_dot
    ratio = bulk_over_nominal(run)
    if not (math.isfinite(ratio) and ratio > 0):
        raise CalibrationError(f"{run.path}: no measured bulk shear rate")
    S = model.hardening_variable_stack(A, D)

    # smoothed A and tau: a regression on noisy A12 would bias the slope of Eq. 15 towards zero
    A_s, rate = cal.jaumann_rate(strain, A, D, window_strain=window)
    tau_s, _ = smooth_segments(strain, tau, D, window_strain=window)
    fits_C = [cal.backstress_constant(strain, tau_s, A_s, reversal_at=r, window=c_window) for r in (0.0, rotate_at)]
    C = float(np.mean([f.slope for f in fits_C]))
    Y = cal.yield_values(tau_s, A_s, D, C)
    yield_fit = cal.linear_fit(S, Y)

    alpha1, alpha2 = cal.fabric_coefficients(A_s, rate / ratio, D)  # per unit bulk strain
    k = model.Params().persistence_exponent
    # near steady state the Jaumann rate is zero plus noise and Eq. 9 fixes no alpha_i: the beta_i
    # fits use the transients, ``transient_efolds`` times the strain over which A12 relaxes by 1/e
    # after the reversal, from each change of direction
    after = strain >= rotate_at - 1e-9
    transient = transient_efolds * relaxation_strain(strain[after], A_s[after, 0, 1], fraction=math.exp(-1))
    if not math.isfinite(transient):
        raise CalibrationError(f"{run.path}: A12 shows no resolvable relaxation after the reversal")
    moving = np.where(strain < rotate_at - 1e-9, strain, strain - rotate_at) < transient
    beta1 = cal.linear_fit(S[moving], (alpha1 * S**k)[moving])
    beta2 = cal.linear_fit(S[moving], (alpha2 * S**k)[moving])
    exponents = []
    for alpha in (alpha1, alpha2):
        try:
            exponents.append(-cal.power_law_exponent(S, alpha, s_small).slope)
        except CalibrationError:
            exponents.append(float("nan"))

    phi_s, dphi = smooth_segments(strain, phi, D, window_strain=window)
    c2_coef, phi_c = dilatancy_estimate(strain, phi_s, dphi, A_s, D, S, -C, ratio, rotate_at)
    return {
        "path": str(run.path), "seed": run.spec.seed, "bulk_over_nominal": float(ratio),
        "transient_strain": float(transient),
        "C_eq15": C, "C_eq15_by_reversal": [f.slope for f in fits_C],
        "C_eq15_se": float(np.hypot(*[f.slope_se for f in fits_C]) / 2),
        "n": yield_fit.intercept, "m": yield_fit.slope, "n_se": yield_fit.intercept_se, "m_se": yield_fit.slope_se,
        "a1": beta1.intercept, "b1": beta1.slope, "a1_se": beta1.intercept_se, "b1_se": beta1.slope_se,
        "a2": beta2.intercept, "b2": beta2.slope, "a2_se": beta2.intercept_se, "b2_se": beta2.slope_se,
        "persistence_exponent_alpha1": exponents[0], "persistence_exponent_alpha2": exponents[1],
        "c2_coef": c2_coef, "phi_c": phi_c,
        "steady_packing_fraction": float(np.mean(phi[(strain > rotate_at - 0.2) & (strain < rotate_at)])),
        "arrays": {"strain": strain, "S": S, "alpha1": alpha1, "alpha2": alpha2, "beta1": alpha1 * S**k,
                   "beta2": alpha2 * S**k, "Y": Y, "tau12": tau_s[:, 0, 1], "A12": A_s[:, 0, 1]},
    }


#: resampled cycles behind the standard error of Sec. 3.3's median C per run
CROSS_CHECK_DRAWS = 40


def cross_check_run(run, window: float = 0.05, min_sine: float = 0.1, draws: int = CROSS_CHECK_DRAWS) -> dict:
    """Sec. 3.3: C and Y at every instant of the cycle from the 12 and 32 components of Eq. 14,
    where the fabric and the shear direction are at least ``asin(min_sine)`` apart in that plane. The median C's
    standard error ``C_se``: its spread over ``draws`` cycle means of the run's cycles drawn with replacement,
    times sqrt(n / (n - 1)) (NaN for one cycle)."""
    out = _cross_check(run, run.cycle, window, min_sine)
    n = run.spec.n_cycles
    if "C_median" in out and n > 1 and draws:
        rng = np.random.default_rng(0)
        medians = [_cross_check(run, {**run.cycle, **resampled_cycle(run, rng)}, window, min_sine).get(
            "C_median", np.nan) for _ in range(draws)]
        out["C_se"] = float(np.nanstd(medians) * math.sqrt(n / (n - 1)))
    return out


def _cross_check(run, c: dict, window: float, min_sine: float) -> dict:
    """``cross_check_run`` on the cycle ``c`` of ``run``."""
    strain = c["strain"]
    D = cycle_D_dev(run)  # from the protocol alone
    A_s, _ = smooth_segments(strain, c["A"], D, window_strain=window)
    tau_s, _ = smooth_segments(strain, c["tau_over_p"], D, window_strain=window)
    C, Y = cal.backstress_and_yield(tau_s, A_s, D, min_sine=min_sine)
    S = model.hardening_variable_stack(A_s, D)
    ok = np.isfinite(C) & np.isfinite(S)
    out = {"path": str(run.path), "theta_deg": run.spec.theta_deg, "samples": int(ok.sum()),
           "arrays": {"strain": strain, "S": S, "C": C, "Y": Y}}
    if ok.sum() >= 3:
        q25, q50, q75 = np.percentile(C[ok], [25, 50, 75])
        line = cal.linear_fit(S[ok], Y[ok])
        out.update(C_median=float(q50), C_quartiles=[float(q25), float(q75)], n=line.intercept, m=line.slope,
                   n_se=line.intercept_se, m_se=line.slope_se)
    return out


ESTIMATES = ("C_eq15", "n", "m", "a1", "b1", "a2", "b2", "persistence_exponent_alpha1",
             "persistence_exponent_alpha2", "c2_coef", "phi_c", "steady_packing_fraction")


def small_sample_factor(cycles: int) -> float:
    """The widening that makes half a bootstrap's 68 % interval over ``cycles`` resampled cycles a 68 % error:
    sqrt(n / (n - 1)) (the bootstrap's plug-in variance) times Student's t at 84.1 % with n - 1 degrees of
    freedom; 1.27 for the paper's five cycles."""
    return math.sqrt(cycles / (cycles - 1)) * float(scipy.stats.t.ppf(0.8413, cycles - 1))


def combine(per_run: list[dict], resampled: StepwiseBootstrap | None = None) -> dict:
    """Mean over runs with its standard error; for a single run, half the 68 % interval over ``resampled``
    (``stepwise_bootstrap`` of its cycles; robust to the heavy tail of Phi_c, which goes as 1/c2_coef) widened
    by ``small_sample_factor``, else NaN: a regression's own error treats the smoothed, correlated samples as
    independent and comes out too small (it stays in the run's ``*_se``)."""
    out = {}
    for key in ESTIMATES:
        values = np.array([r[key] for r in per_run], dtype=float)
        mean = float(np.nanmean(values))
        if len(values) > 1:
            se, source = float(np.nanstd(values, ddof=1) / np.sqrt(np.isfinite(values).sum())), "runs"
        elif resampled is not None and key in resampled.free:
            half_width = resampled.half_width_68[resampled.free.index(key)]
            se, source = half_width * small_sample_factor(resampled.cycles), "cycle resamples"
        else:
            se, source = float("nan"), None
        out[key] = {"value": mean, "standard_error": se, "error_from": source, "per_run": values.tolist()}
    return out


SMOOTHING_WINDOWS = (0.03, 0.05, 0.08)  # Savitzky-Golay windows in strain
TRANSIENT_EFOLDS = (1.0, 2.0, 4.0)  # strain after each change used by the beta_i fits, in 1/e strains of A12
EQ15_WINDOWS = ((0.2, 0.69), (0.3, 0.69), (0.4, 0.69))  # strain after the reversal for Eq. 15's slope
SENSITIVE = ("C_eq15", "n", "m", "a1", "b1", "a2", "b2", "persistence_exponent_alpha1", "persistence_exponent_alpha2")
BOOTSTRAPPED = (*SENSITIVE, "c2_coef", "phi_c", "steady_packing_fraction")


def sensitivity(runs: list) -> dict:
    """The stepwise estimates (mean over runs) for each smoothing window, and Eq. 15's C for each
    strain window after the reversal: how much the calibration hinges on these choices. A setting the runs cannot
    be calibrated at (too few samples in its window) gives NaN: the spread is then over the others."""
    def means(**kwargs):
        try:
            per_run = [calibrate_run(run, **kwargs) for run in runs]
        except CalibrationError:
            return dict.fromkeys(SENSITIVE, math.nan)
        return {key: float(np.nanmean([r[key] for r in per_run])) for key in SENSITIVE}

    return {"smoothing_window": {f"{w:g}": means(window=w) for w in SMOOTHING_WINDOWS},
            "transient_efolds": {f"{f:g}": means(transient_efolds=f) for f in TRANSIENT_EFOLDS},
            "eq15_window": {f"{a:g}-{b:g}": means(c_window=(a, b))["C_eq15"] for a, b in EQ15_WINDOWS}}


def stepwise_bootstrap(runs: list, replicates: int, window: float, seed: int = 0) -> StepwiseBootstrap:
    """The stepwise calibration (mean over runs) on ``replicates`` resamplings of every run's cycles."""
    rng = np.random.default_rng(seed)
    values = []
    for _ in range(replicates):
        per_run = []
        for run in runs:
            cycle = {**run.cycle, **resampled_cycle(run, rng)} if run.spec.n_cycles > 1 else run.cycle
            per_run.append(calibrate_run(run, window=window, cycle=cycle))
        values.append([np.nanmean([r[key] for r in per_run]) for key in BOOTSTRAPPED])
    v = np.array(values)
    lo, hi = np.nanpercentile(v, [15.87, 84.13], axis=0)
    return StepwiseBootstrap(list(BOOTSTRAPPED), replicates, min(run.spec.n_cycles for run in runs),
                             np.nanstd(v, axis=0, ddof=1).tolist(), ((hi - lo) / 2).tolist(),
                             np.nanpercentile(v, 2.5, axis=0).tolist(), np.nanpercentile(v, 97.5, axis=0).tolist(),
                             seed)


def fitted_params(estimates: dict) -> model.Params:
    """Model parameters from the stepwise estimates (c1 = -C, Eq. 19; k and the c2 exponent kept)."""
    C = estimates["C_eq15"]["value"]
    values = {key: estimates[key]["value"] for key in ("n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")}
    return model.Params().replace(C=C, c1=-C, **values)


