"""Behaviour of the model and its integrator: invariants, symmetries, limits, accuracy, cost."""

import math

import numpy as np
import pytest

from model import (
    PAPER,
    History,
    Segment,
    SolverError,
    integrate,
    periodic,
    periodic_cycle,
    predict,
    reference,
    reversal,
    reversal_start_rate,
    rotation_about_e2,
    steady_shear,
    steady_state,
)
from model.kinematics import deviator, modulus, shear_velocity_gradient, spin, stretching
from tests.helpers import RUNS_AWAY

ANGLES = (30, 60, 90, 120, 150, 180)


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def test_fabric_rate_is_symmetric_and_traceless():
    rng = np.random.default_rng(1)
    for _ in range(20):
        A = rng.normal(scale=0.05, size=(3, 3))
        A = deviator(0.5 * (A + A.T))
        rate = reference.fabric_rate(A, rng.normal(size=(3, 3)), PAPER)
        assert abs(np.trace(rate)) < 1e-12
        np.testing.assert_allclose(rate, rate.T, atol=1e-12)


@pytest.mark.parametrize("theta", [180, 90])
def test_agrees_with_independent_reference(theta):
    cycle = predict(theta)
    A, phi, _ = reference.solve(periodic_cycle(theta), cycle.A[0], cycle.packing_fraction[0], PAPER, cycle.strain)
    assert np.max(np.abs(A - cycle.A)) < 1e-10
    assert np.max(np.abs(phi - cycle.packing_fraction)) < 1e-10
    # the reference keeps A symmetric and traceless on its own (9 free components)
    assert np.max(np.abs(np.trace(A, axis1=1, axis2=2))) < 1e-12
    assert np.max(np.abs(A - np.swapaxes(A, 1, 2))) < 1e-12


@pytest.mark.parametrize("rtol, budget", [(1e-6, 1e-4), (1e-8, 1e-6), (1e-10, 1e-8)])
def test_error_follows_requested_tolerance(rtol, budget):
    exact = predict(180, rtol=1e-13, atol=1e-15)
    approx = integrate(periodic_cycle(180), A0=exact.A[0], packing_fraction0=exact.packing_fraction[0],
                       rtol=rtol, atol=rtol * 1e-2)
    assert np.max(np.abs(approx.tau - exact.tau)) < budget


@pytest.mark.parametrize("b2_factor", [1, 10])
def test_outputs_between_steps_are_as_accurate_as_the_steps(b2_factor):
    # outputs come from the dense output; with a stiff relaxation (b2 x 10) the steady part of the
    # cycle takes long steps whose interpolant is only trusted after the defect check
    params = PAPER.replace(b2=b2_factor * PAPER.b2, phi_c=LOOSE)
    exact = predict(180, params=params, rtol=1e-13, atol=1e-16)
    A_ref, _, _ = reference.solve(periodic_cycle(180), exact.A[0], exact.packing_fraction[0], params, exact.strain)
    approx = integrate(periodic_cycle(180), A0=exact.A[0], packing_fraction0=exact.packing_fraction[0],
                       params=params, rtol=1e-11, atol=1e-13)
    assert approx.nsteps < approx.strain.size  # steps are not tied to the outputs
    assert np.max(np.abs(approx.A - A_ref)) < 1e-10


def test_cost_budget_of_a_reversal_cycle():
    cycle = predict(180)
    assert cycle.periods <= 3
    assert cycle.nfev < 3 * 3000  # about 1400 right-hand sides per period at the default tolerance


def test_S_nonnegative_and_fabric_bounded_on_random_histories():
    rng = np.random.default_rng(7)
    for _ in range(10):
        segments = tuple(Segment(rng.uniform(0.05, 0.5), rng.normal(size=(3, 3))) for _ in range(4))
        result = integrate(History(segments), times=np.linspace(0, sum(s.duration for s in segments), 200))
        assert np.all(result.S >= 0)
        eig = np.linalg.eigvalsh(result.A)
        assert eig.min() >= -1 / 3 and eig.max() <= 2 / 3


@pytest.mark.parametrize("theta", ANGLES)
def test_periodic_cycle_is_periodic(theta):
    cycle = predict(theta)
    assert cycle.cycle_residual < 1e-10
    np.testing.assert_allclose(cycle.A[-1], cycle.A[0], atol=1e-9)
    assert cycle.packing_fraction[-1] == pytest.approx(cycle.packing_fraction[0], abs=1e-9)


def test_closed_form_packing_fraction_equals_brute_force_iteration():
    cycle = predict(180)
    history = periodic_cycle(180)
    phi0 = 0.60
    for _ in range(60):  # plain period iteration; Phi errors shrink by cycle.phi_contraction per period
        run = integrate(history, A0=cycle.A[0], packing_fraction0=phi0, times=[1.4])
        phi0 = run.packing_fraction[-1]
    assert cycle.phi_contraction ** 60 < 1e-12
    assert phi0 == pytest.approx(cycle.packing_fraction[0], abs=1e-11)


def test_objectivity_under_rotation_about_e2_and_arbitrary_rotations():
    base = predict(120)
    history = periodic_cycle(120)
    rng = np.random.default_rng(3)
    for R in (rotation_about_e2(37.0), random_rotation(rng)):
        rotated = integrate(history.rotated(R), A0=R @ base.A[0] @ R.T,
                            packing_fraction0=base.packing_fraction[0], times=base.strain)
        np.testing.assert_allclose(rotated.A, R @ base.A @ R.T, atol=1e-9)
        np.testing.assert_allclose(rotated.tau, R @ base.tau @ R.T, atol=1e-8)
        np.testing.assert_allclose(rotated.S, base.S, atol=1e-9)
        np.testing.assert_allclose(rotated.packing_fraction, base.packing_fraction, atol=1e-10)


def test_rate_independence():
    strains = np.linspace(0, 1.4, 57)
    slow = predict(150, times=strains)
    fast = periodic(periodic_cycle(150, shear_rate=250.0), times=strains)
    very_slow = periodic(periodic_cycle(150, shear_rate=1e-4), times=strains)
    for other in (fast, very_slow):
        np.testing.assert_allclose(other.A, slow.A, atol=1e-10)
        np.testing.assert_allclose(other.tau, slow.tau, atol=1e-9)
        np.testing.assert_allclose(other.w_total, slow.w_total, atol=1e-8)
    assert fast.t[-1] == pytest.approx(1.4 / 250.0)


@pytest.mark.parametrize("phi_deg", [0.0, 90.0])
def test_steady_state_solves_the_algebraic_equations(phi_deg):
    L = shear_velocity_gradient(phi_deg)
    A, phi = steady_state(L)
    D = deviator(stretching(L))
    W = spin(L)
    nD = modulus(D)
    S = np.linalg.norm(A) - np.sum(A * D) / nD
    # steady: A_dot = 0, so Lambda(S) (A W - W A) = beta1 D' + beta2 |D'| A (Eq. 13)
    lhs = S**0.75 * (A @ W - W @ A)
    rhs = (PAPER.a1 + PAPER.b1 * S) * D + (PAPER.a2 + PAPER.b2 * S) * nD * A
    np.testing.assert_allclose(lhs, rhs, atol=1e-12)
    # Eq. 18 with Phi_dot = 0
    c2 = PAPER.c2_coef * S ** PAPER.c2_exponent
    assert PAPER.c1 * np.sum(A * D) + c2 * (PAPER.phi_c - phi + PAPER.c3) * nD == pytest.approx(0, abs=1e-12)
    # the steady fabric is roughly antiparallel to D' (paper Sec. 3.2: S close to 2|A|)
    assert S == pytest.approx(2 * np.linalg.norm(A), rel=0.01)


def test_steady_shear_matches_paper_magnitudes():
    A, phi = steady_state(shear_velocity_gradient(0.0))
    cycle = integrate(steady_shear(0.01), A0=A, packing_fraction0=phi, times=[0.0])
    tau12 = cycle.tau[0, 0, 1]
    backstress = PAPER.C * A[0, 1]
    assert A[0, 1] < 0 < tau12  # contacts along compression; shear stress resists the top wall
    assert 0.35 < tau12 < 0.45
    assert backstress / tau12 == pytest.approx(0.88, abs=0.03)  # paper Sec. 4: 88 %


def test_isotropic_start_follows_the_small_strain_asymptote():
    # near A = 0 the fabric is antiparallel to D', S = 2x with x = |A|, and
    # x^k dx = |a1| 2^-k d(|D'|t)  =>  x = ((1 + k) |a1| 2^-k |D'| t)^(1/(1+k))
    k, a1 = PAPER.persistence_exponent, abs(PAPER.a1)
    strains = np.array([1e-8, 1e-7, 1e-6])
    result = integrate(steady_shear(1e-3), times=strains, rtol=1e-12, atol=1e-15)
    x = np.linalg.norm(result.A, axis=(1, 2))
    expected = ((1 + k) * a1 * 2**-k * strains / math.sqrt(2)) ** (1 / (1 + k))
    np.testing.assert_allclose(x, expected, rtol=0.02)
    assert np.all(result.S >= 0)


def test_exact_reversal_of_an_aligned_fabric_is_integrated():
    # a fabric exactly parallel to D' has S = 0 and an infinite fabric rate: the fabric jumps at
    # fixed strain, which the regularised variable resolves without NaN or S < 0
    D = deviator(stretching(shear_velocity_gradient(0.0)))
    antiparallel = -0.08 * D / modulus(D)  # a 2D steady-like state for shear along e1 (S = 2|A|)
    result = integrate(reversal(1e-9, 0.5), A0=antiparallel, times=np.linspace(0, 0.5, 101))
    assert np.all(np.isfinite(result.A)) and np.all(result.S >= 0)
    assert result.A[-1, 0, 1] > 0  # relaxed towards the reversed steady state
    reversed_steady, _ = steady_state(shear_velocity_gradient(180.0))
    np.testing.assert_allclose(result.A[-1], reversed_steady, atol=2e-3)


def test_the_reversal_start_rate_tells_a_reversal_that_turns_from_one_that_runs_away():
    """a1 + a2 |A| at S = 0 (Eq. 13 right after a reversal of steady shear): Table 2 sits on the edge and its cycle
    keeps |A| at its steady value; a fabric law with a positive rate grows along its old direction, and the cycle's
    error names the fabric, not phi_c and c3; one with a negative rate turns."""
    steady = modulus(steady_state(shear_velocity_gradient(0.0))[0])
    assert reversal_start_rate() == pytest.approx(PAPER.a1 + PAPER.a2 * steady, rel=1e-12)
    assert abs(reversal_start_rate()) < 1e-4
    assert np.max(modulus(predict(180).A)) < 1.01 * steady
    assert reversal_start_rate(RUNS_AWAY) > 0.01
    with pytest.raises(SolverError, match=r"the fabric grows to [0-9.]+ times its steady \|A\|.*check the fabric law"):
        predict(180, params=RUNS_AWAY)
    turns = PAPER.replace(a2=0.15)
    assert reversal_start_rate(turns) < -0.005
    assert np.max(modulus(predict(180, params=turns).A)) < 1.01 * modulus(steady_state(
        shear_velocity_gradient(0.0), turns)[0])


#: Phi_c lowered beside a stiffer fabric law or no dilatancy coupling, so that Eq. 18 stays a packing of spheres
LOOSE = 0.55


def test_extreme_parameters_b2_times_ten():
    params = PAPER.replace(b2=10 * PAPER.b2, phi_c=LOOSE)
    cycle = predict(180, params=params)
    A, _, _ = reference.solve(periodic_cycle(180), cycle.A[0], cycle.packing_fraction[0], params, cycle.strain)
    assert np.max(np.abs(A - cycle.A)) < 1e-9
    assert np.all(cycle.S >= 0)


def test_explicit_euler_converges_at_first_order():
    exact = predict(180)
    history = periodic_cycle(180)
    errors = []
    for step in (4e-4, 2e-4, 1e-4):
        euler = integrate(history, A0=exact.A[0], packing_fraction0=exact.packing_fraction[0],
                          times=exact.strain, method="euler", strain_step=step)
        errors.append(np.max(np.abs(euler.tau - exact.tau)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    np.testing.assert_allclose(orders, 1.0, atol=0.15)


def test_explicit_euler_cannot_start_at_S_zero():
    with pytest.raises(SolverError, match="S = 0"):
        integrate(steady_shear(0.1), method="euler", strain_step=1e-3)


@pytest.mark.parametrize("theta, rotate_at", [(t, 0.7) for t in ANGLES] + [(90, 0.1), (90, 0.2)])
def test_second_law_holds_when_c1_equals_minus_C(theta, rotate_at):
    cycle = predict(theta, rotate_at=rotate_at)
    assert cycle.w_total.min() >= 0  # Eq. 19
    assert np.all(cycle.packing_fraction <= PAPER.phi_c + PAPER.c3)


def test_second_law_check_can_fail():
    cycle = predict(180, params=PAPER.replace(c1=0.0, phi_c=LOOSE))
    assert cycle.w_shear.min() < 0 and cycle.w_total.min() < 0


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: predict(180, rtol=1e-16), "rtol=1e-16 cannot be honoured"),
        (lambda: predict(180, times=[0.0, float("nan")]), "non-finite value nan"),
        (lambda: predict(180, times=[0.5, 0.1]), "increasing order"),
        (lambda: integrate(steady_shear(1.0), A0=np.eye(3)), "traceless"),
        (lambda: integrate(steady_shear(1.0), packing_fraction0=1.2), "packing_fraction0=1.2"),
        (lambda: integrate(steady_shear(1.0), method="rk4"), "unknown method 'rk4'"),
        (lambda: predict(180, params={"C": 1}), "params must be a model.Params"),
    ],
)
def test_bad_inputs_raise_clear_errors(call, message):
    with pytest.raises(SolverError, match=message):
        call()
