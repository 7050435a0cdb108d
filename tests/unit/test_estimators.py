"""Stepwise estimators of the calibration on noise-free model data: each recovers what it can."""

import numpy as np
import pytest

import model
from model.reference import fabric_rate
from pipeline.calibration import estimators as cal
from pipeline.errors import CalibrationError

PARAMS = model.Params()


@pytest.fixture(scope="module")
def reversal():
    """The model through a reversal at strain 0.5 from steady state, sampled every 0.005."""
    A_ss, _ = model.steady_state(model.shear_velocity_gradient(0.0))
    times = np.round(np.arange(0, 1.9 + 1e-9, 0.005), 10)
    return model.integrate(model.reversal(pre_strain=0.5, post_strain=1.4), A0=A_ss, packing_fraction0=0.6,
                           times=times)


def exact_jaumann(r):
    L = cal.simple_shear_gradient(r.D_dev)
    W = 0.5 * (L - np.swapaxes(L, 1, 2))
    return np.array([fabric_rate(A, g, PARAMS) + A @ w - w @ A for A, g, w in zip(r.A, L, W, strict=True)])


def test_fabric_coefficients_recover_beta_over_lambda_with_the_exact_rate(reversal):
    r = reversal
    alpha1, alpha2 = cal.fabric_coefficients(r.A, exact_jaumann(r), r.D_dev)
    ok = r.S > 1e-6
    np.testing.assert_allclose(alpha1[ok] * r.S[ok] ** 0.75, PARAMS.a1 + PARAMS.b1 * r.S[ok], rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(alpha2[ok] * r.S[ok] ** 0.75, PARAMS.a2 + PARAMS.b2 * r.S[ok], rtol=1e-8, atol=1e-12)


def test_smoothed_jaumann_rate_gives_the_betas_and_does_not_hinge_on_the_window(reversal):
    r = reversal
    fits = {}
    for window in (0.03, 0.05, 0.08):
        A_s, rate = cal.jaumann_rate(r.strain, r.A, r.D_dev, window_strain=window)
        alpha1, alpha2 = cal.fabric_coefficients(A_s, rate, r.D_dev)
        after = r.strain > 0.55  # the singular start of the transient is left to the power law
        S = r.S[after]
        fits[window] = (cal.linear_fit(S, alpha1[after] * S**0.75), cal.linear_fit(S, alpha2[after] * S**0.75))
    # the slopes b_i do not hinge on the window; the intercepts come from the fast start of the
    # transient, where smoothing lags: a2 = 0.26 / 0.28 / 0.34 for windows 0.03 / 0.05 / 0.08
    for f1, f2 in fits.values():
        assert f1.slope == pytest.approx(PARAMS.b1, rel=0.01) and f2.slope == pytest.approx(PARAMS.b2, rel=0.02)
        assert f1.intercept == pytest.approx(PARAMS.a1, rel=0.1) and f2.intercept == pytest.approx(PARAMS.a2, rel=0.4)
    assert np.ptp([f[1].slope for f in fits.values()]) < 0.02 * abs(PARAMS.b2)
    assert fits[0.03][1].intercept == pytest.approx(PARAMS.a2, rel=0.1)


def test_yield_values_are_exact_given_C(reversal):
    r = reversal
    fit = cal.linear_fit(r.S, cal.yield_values(r.tau, r.A, r.D_dev, PARAMS.C))
    assert fit.intercept == pytest.approx(PARAMS.n, abs=1e-10) and fit.slope == pytest.approx(PARAMS.m, abs=1e-10)


def test_eq15_measures_C_plus_the_drift_of_the_yield_function(reversal):
    # near steady state S = 2|A| = 2 sqrt(2) |A12| and D'/|D'| has 12-component -1/sqrt(2) after the
    # reversal, so d tau12 = (C - 2m) dA12 there: Eq. 15 returns C - 2m (-4.4 for Table 2), not C.
    for window in ((0.3, 0.7), (0.6, 1.4)):
        fit = cal.backstress_constant(reversal.strain, reversal.tau, reversal.A, reversal_at=0.5, window=window)
        assert fit.slope == pytest.approx(PARAMS.C - 2 * PARAMS.m, abs=0.02)


def test_power_law_exponent_of_the_divergence_at_small_S():
    # S starts at 1.8e-4 after a reversal from the model's steady state (A is not exactly coaxial
    # with D'); over S < 1e-3 the linear parts of beta_i bias the log-log slope: 0.71 and 0.79
    A_ss, _ = model.steady_state(model.shear_velocity_gradient(0.0))
    times = 0.5 + np.logspace(-9, -2, 80)
    r = model.integrate(model.reversal(pre_strain=0.5, post_strain=0.02), A0=A_ss, packing_fraction0=0.6,
                        times=np.concatenate([[0.0], times]))
    alpha1, alpha2 = cal.fabric_coefficients(r.A, exact_jaumann(r), r.D_dev)
    slopes = [-cal.power_law_exponent(r.S, alpha, S_max=1e-3).slope for alpha in (alpha1, alpha2)]
    assert slopes == pytest.approx([PARAMS.persistence_exponent] * 2, abs=0.05)
    assert np.mean(slopes) == pytest.approx(PARAMS.persistence_exponent, abs=0.01)


def test_bad_inputs():
    with pytest.raises(CalibrationError, match="too few samples"):
        cal.linear_fit(np.array([1.0, 2.0]), np.array([1.0, 2.0]))
    strain = np.array([0, 0.1, 0.3, 0.35])
    with pytest.raises(CalibrationError, match="not evenly spaced"):
        cal.jaumann_rate(strain, np.zeros((4, 3, 3)), np.zeros((4, 3, 3)))


@pytest.mark.parametrize("theta", [30.0, 90.0, 150.0])
def test_sec33_cross_check_recovers_constant_C_and_the_yield_line(theta):
    r = model.predict(theta)
    C, Y = cal.backstress_and_yield(r.tau, r.A, r.D_dev)
    ok = np.isfinite(C)
    assert ok.mean() > 0.9  # solvable wherever A is not parallel to the shear direction
    np.testing.assert_allclose(C[ok], PARAMS.C, rtol=1e-6)
    np.testing.assert_allclose(Y[ok], PARAMS.n + PARAMS.m * r.S[ok], atol=1e-6)


def test_sec33_cross_check_is_undetermined_in_a_reversal(reversal):
    C, Y = cal.backstress_and_yield(reversal.tau, reversal.A, reversal.D_dev)
    assert np.isnan(C).all() and np.isnan(Y).all()
