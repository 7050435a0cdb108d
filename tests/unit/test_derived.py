"""Model-ready series and cycle averages from synthetic raw samples."""

import numpy as np
import pytest

import model
from model.kinematics import shear_velocity_gradient
from pipeline.dataset import derived as dem_analysis


def synthetic_raw(n_cycles=3, noise=0.0, seed=0):
    """Samples of a fake run: tau12 and A12 follow a known periodic function plus noise."""
    step, period, pre = 0.005, 1.4, 0.7
    strain = np.arange(-pre, n_cycles * period + step / 2, step)
    phase = np.mod(strain, period)
    rng = np.random.default_rng(seed)
    n = len(strain)
    theta = 90.0
    direction = np.where((strain < 0) | (phase >= 0.7 - 1e-9), theta, 0.0)
    A = np.zeros((n, 3, 3))
    A[:, 0, 1] = A[:, 1, 0] = -0.05 * np.cos(2 * np.pi * phase / period) + noise * rng.normal(size=n)
    stress = np.zeros((n, 3, 3))
    stress[:, [0, 1, 2], [0, 1, 2]] = -1.0
    stress[:, 0, 1] = stress[:, 1, 0] = 0.3 * np.sin(2 * np.pi * phase / period) + noise * rng.normal(size=n)
    gamma_dot = 1e-3
    s = model.shear_direction(np.concatenate([direction[:1], direction[:-1]]))  # the band lags the walls a sample
    raw = {"strain": strain, "time": (strain + pre) / gamma_dot, "direction_deg": direction,
           "velocity_gradient": 1.2 * gamma_dot * s, "stress_contact": stress, "stress_kinetic": np.zeros_like(stress),
           "fabric": A, "packing_fraction": 0.6 + 0.001 * np.sin(2 * np.pi * phase / period)}
    return raw, {"gamma_dot_nominal": gamma_dot}


def test_series_conventions_match_the_model_kinematics():
    raw, meta = synthetic_raw()
    series = dem_analysis.model_series(raw, meta)
    first_half = (raw["strain"] >= 0) & (raw["strain"] < 0.7)
    L = shear_velocity_gradient(0.0)
    D = 0.5 * (L + L.T)
    np.testing.assert_allclose(series["D_dev_nominal"][first_half][0], D - np.trace(D) * np.eye(3) / 3)
    # tau = deviator of the stress, p = 1: the isotropic -1 drops out, the mean stress is +1
    np.testing.assert_allclose(series["mean_stress_over_p"], 1.0)
    np.testing.assert_allclose(series["tau_over_p"][:, 0, 1], raw["stress_contact"][:, 0, 1])
    # the bulk strain follows the measured rate (1.2 x nominal) and is 0 where the first period starts; in
    # the interval after each of the six 90-degree turns the band, still moving the old way, shears the new
    # direction only at the interval's end: half an interval's strain
    zero = np.argmin(np.abs(raw["strain"]))
    assert series["strain_bulk"][zero] == 0
    assert series["strain_bulk"][-1] == pytest.approx(1.2 * (raw["strain"][-1] - 6 * 0.005 / 2), rel=1e-9)
    # S (Eq. 10) with A12 < 0 under D'12 > 0 is 2|A|
    k = np.flatnonzero(first_half)[0]
    assert series["S"][k] == pytest.approx(2 * np.linalg.norm(raw["fabric"][k]))
    np.testing.assert_allclose(series["w_shear"][first_half],
                               np.einsum("nij,ij->n", series["tau_over_p"][first_half], D))


def test_cycle_average_excludes_the_preceding_half_and_gives_standard_errors():
    raw, meta = synthetic_raw(n_cycles=4, noise=0.01)
    series = dem_analysis.model_series(raw, meta)
    cycle = dem_analysis.cycle_average(raw["strain"], {"A": series["A"]}, 1.4, 0.005, 4)
    assert cycle["strain"].shape == (281,) and cycle["A"].shape == (281, 3, 3)
    truth = -0.05 * np.cos(2 * np.pi * cycle["strain"] / 1.4)
    # noise 0.01 per sample, 4 cycles: the mean is off by 0.005 rms, which the standard error reports
    assert np.sqrt(np.mean((cycle["A"][:, 0, 1] - truth) ** 2)) == pytest.approx(0.01 / 2, rel=0.15)
    assert np.sqrt(np.mean(cycle["A_sem"][:, 0, 1] ** 2)) == pytest.approx(0.01 / 2, rel=0.15)
    one = dem_analysis.cycle_average(raw["strain"], {"A": series["A"]}, 1.4, 0.005, 1)
    assert np.isnan(one["A_sem"]).all()


def test_cycle_average_refuses_missing_cycles():
    raw, _ = synthetic_raw(n_cycles=1)
    with pytest.raises(ValueError, match="do not cover"):
        dem_analysis.cycle_average(raw["strain"], {"x": raw["strain"]}, 1.4, 0.005, 2)
