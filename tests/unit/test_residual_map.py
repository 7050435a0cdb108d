"""Where the global fit's residuals are largest: a feature the model lacks shows in its run, quantity and window."""

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

import model
from pipeline.calibration import global_fit
from pipeline.calibration.fit_cycle import FitCycle
from pipeline.calibration.residual_map import residual_map, strain_since_change
from tests.helpers import synthetic_run

TRUE = model.Params()


def test_a_feature_the_model_lacks_tops_the_map_in_its_run_quantity_and_window(tmp_path):
    runs = [FitCycle.from_run(synthetic_run(tmp_path, theta=t, name=f"r{int(t)}", noise=0.002, seed=int(t)))
            for t in (180.0, 90.0)]
    steady = strain_since_change(runs[1], runs[1].strain) >= 0.3
    tau = runs[1].tau.copy()
    tau[steady, 0, 0] += 0.03  # a normal-stress difference the model's tau = C A + Y D'/|D'| does not give
    tau[steady, 1, 1] -= 0.03
    data = [runs[0], dataclasses.replace(runs[1], tau=tau)]
    fit = SimpleNamespace(values=np.array([getattr(TRUE, n) for n in global_fit.FREE]), params=TRUE,
                          names=global_fit.FREE)
    rows = residual_map(fit, data)
    assert sum(r.share for r in rows) == pytest.approx(1.0)
    assert sum(r.samples for r in rows) == sum(2 * 5 * len(d.strain) for d in data)
    top = {(r.theta_deg, r.quantity, tuple(r.window)) for r in rows[:2]}
    assert top == {(90.0, "tau11/p", (0.3, np.inf)), (90.0, "tau22/p", (0.3, np.inf))}
    assert rows[0].per_sample_over_mean > 5


def test_strain_since_change_restarts_at_each_turn(tmp_path):
    d = FitCycle.from_run(synthetic_run(tmp_path, n_cycles=1))
    since = strain_since_change(d, np.array([0.0, 0.3, 0.69, 0.7, 1.0]))
    np.testing.assert_allclose(since, [0.0, 0.3, 0.69, 0.0, 0.3], atol=1e-12)


def test_components_the_fit_leaves_out_have_no_rows_and_no_samples(tmp_path):
    from pipeline.calibration.global_fit import noise_scales

    d = FitCycle.from_run(synthetic_run(tmp_path, noise=0.002))
    d = d.with_scales(*noise_scales(len(d.strain), None, d.n_cycles, "shear"))
    fit = SimpleNamespace(values=np.array([getattr(TRUE, n) for n in global_fit.FREE]), params=TRUE,
                          names=global_fit.FREE)
    rows = residual_map(fit, [d])
    assert {r.quantity for r in rows} == {"A12", "A32", "A11", "A22", "A13", "tau12/p", "tau32/p"}
    assert sum(r.samples for r in rows) == 7 * len(d.strain)
