"""Sec. 3.3's C per angle: noise of the DEM's size in A and tau/p does not pull it from the truth at small turns, and
its error from the run's cycles covers the spread over noise draws."""

import numpy as np

import model
from dem.core.rawfile import write_raw
from pipeline.calibration.stepwise import cross_check_run
from pipeline.dataset.dem_file import load, write_h5
from tests.helpers.synthetic import dem_like_noise, synthetic_raw

#: the paper cell's noise per sample and cycle (fit.json -> noise, 2026-11-27): A 0.0027, tau/p 0.016, correlated
#: over 0.1 strain and between the two at -0.6
SIGMA_A, SIGMA_TAU = 0.0027, 0.016


def noisy_run(folder, theta, seed):
    raw, meta = synthetic_raw(float(theta), n_cycles=5, seed=seed)
    noise_A, noise_tau = dem_like_noise(np.random.default_rng(seed), len(raw["strain"]), 1.0, 0.1, -0.6)
    raw["fabric"] = raw["fabric"] + SIGMA_A * noise_A
    raw["stress_contact"] = raw["stress_contact"] + SIGMA_TAU * noise_tau
    raw["profile_fabric"], raw["profile_stress"] = raw["fabric"][:, None], raw["stress_contact"][:, None]
    meta["spec"]["name"] = f"theta{theta:03d}"
    write_raw(folder / f"s{seed}.npz", raw, meta)
    write_h5(folder / f"s{seed}.npz", folder / f"s{seed}.h5", {"git_commit": "test", "sessions": []})
    return load(folder / f"s{seed}.h5")


def test_noise_of_the_dems_size_does_not_attenuate_c_at_a_small_turn(tmp_path):
    checks = [cross_check_run(noisy_run(tmp_path, 30, seed), draws=20) for seed in range(4)]
    medians = np.array([c["C_median"] for c in checks])
    errors = np.array([c["C_se"] for c in checks])
    truth = model.Params().C
    assert abs(medians.mean() - truth) < 3 * errors.mean() / 2  # the mean of four draws
    assert np.all(np.abs(medians - truth) < 4 * errors)
    assert 0.03 < errors.mean() < 0.5
