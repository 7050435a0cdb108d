"""The model's front door refuses in one line what it cannot honour: complex numbers, a step too long to mean
anything, tolerances that are no tolerance, and inputs taken from a result of other parameters."""

import numpy as np
import pytest

import model
from model.material_point import MAX_STEP_STRAIN
from model.solver import SolverError

A = np.zeros((2, 3, 3))
PHI = np.array([0.6, 0.6])
L = model.shear_velocity_gradient(0.0)


@pytest.mark.parametrize("name", ["A", "phi", "L", "dt"])
def test_a_complex_input_is_refused_not_cut_to_its_real_part(name):
    given = {"A": A, "phi": PHI, "L": L, "dt": 0.01}
    given[name] = np.asarray(given[name]) + 0j
    with pytest.raises(SolverError, match=f"^{name} is complex"):
        model.update(given["A"], given["phi"], given["L"], given["dt"])


@pytest.mark.parametrize("dt", [1e300, 2 * MAX_STEP_STRAIN * np.sqrt(2), [0.01, 1e20]])
def test_a_step_of_absurd_strain_names_dt(dt):
    with pytest.raises(SolverError, match=r"dt\[\d\] makes a step of strain .* split the step"):
        model.update(A, PHI, L, dt)


def test_the_longest_step_allowed_still_integrates():
    out = model.update(A, PHI, L, 0.99 * MAX_STEP_STRAIN * np.sqrt(2))
    assert np.all(np.isfinite(out.A)) and np.all(out.phi > 0)


@pytest.mark.parametrize("name", ["rtol", "atol", "s_ref", "fabric_tol"])
@pytest.mark.parametrize("value", [0.0, -1e-6, 1.0, 1e300, float("nan"), True])
def test_a_tolerance_that_is_no_tolerance_is_named(name, value):
    with pytest.raises(SolverError, match=f"^{name}=.* must be a number in \\(0, 1\\)$"):
        model.update(A, PHI, L, 0.01, **{name: value})


def test_update_inputs_refuses_what_is_not_a_result_and_a_result_of_other_parameters():
    with pytest.raises(SolverError, match="takes a model.Result .* got NoneType"):
        model.update_inputs(None)
    jump = model.Params(variant="jump", jump_fabric=-0.013)
    result = model.predict(90, params=jump)
    with pytest.raises(SolverError, match=r"made with other parameters \(jump\) than those given \(rk2025\)"):
        model.update_inputs(result)
    A0, phi0, _ = model.update_inputs(result, params=jump)
    assert A0.shape == result.A.shape and np.allclose(phi0, result.packing_fraction)
