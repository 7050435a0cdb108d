"""The model's front door refuses in one line what it cannot honour: complex numbers, a step too long to mean
anything, tolerances that are no tolerance, and inputs taken from a result of other parameters."""

import re

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


@pytest.mark.parametrize("changes, where", [
    ({"C": 50.0}, "C + c1 = 55.6"),
    ({"C": -9.0}, "C + c1 = -3.4"),
    ({"n": 0.05, "m": -1.0}, "Y(S) = -0.118"),
])
def test_a_parameter_file_that_breaks_the_second_law_is_refused_naming_where(tmp_path, changes, where):
    """Eq. 19: sigma:D >= 0 over the states the model reaches; a set that dissipates negatively somewhere is refused
    at the file's reading, naming S, A:D'/|D'| and the culprit."""
    text = model.PAPER.replace(**changes).to_json()
    said = r"p.json: breaks the second law \(Eq. 19\).*" + re.escape(where)
    with pytest.raises(model.params.ParameterError, match=said):
        model.Params.from_json(text, "p.json")


def test_the_second_laws_check_passes_table_2_and_every_laws_neutral_set_and_finds_the_known_minimum():
    for law in model.laws.LAWS:
        assert model.PAPER.replace(variant=law).least_work_rate().work_rate > 0
    worst = model.PAPER.replace(C=50.0).least_work_rate()  # Y(S) + 55.6 x at S = 2 A_s, x = -A_s
    steady = abs(model.PAPER.a1) / model.PAPER.a2  # the reversal's cycle reaches Eq. 13's steady fabric
    assert worst.S == pytest.approx(2 * steady, rel=1e-2) and worst.x == pytest.approx(-steady, rel=1e-2)
    assert worst.work_rate == pytest.approx(model.PAPER.n + model.PAPER.m * worst.S + 55.6 * worst.x)
    result = model.predict(180, params=model.PAPER.replace(C=50.0))
    assert np.min(result.w_total) < 0  # what the check is there for: the cycle dissipates negatively


@pytest.mark.parametrize("law", [law for law in model.laws.LAWS if model.laws.state_names(law)])
def test_every_law_with_a_state_declares_its_bounds_and_update_refuses_a_state_outside_them(law):
    params = model.PAPER.replace(variant=law)
    bounds = model.laws.state_bounds(law)
    names = model.laws.state_names(law)
    assert len(bounds) == len(names)
    good = model.Update.empty(2, params).law_state
    good[:] = [np.clip(0.0, low, high) if np.isfinite(high) else low + 0.3 for low, high in bounds]
    model.update(A, PHI, L, 0.01, params=params, law_state=good)
    for k, (low, high) in enumerate(bounds):
        for value in (low - 1.0, high + 1.0 if np.isfinite(high) else -5.0, 0.0 if low > 0 else None):
            if value is None:
                continue
            bad = good.copy()
            bad[1, k] = value
            with pytest.raises(SolverError, match=rf"law_state\[1\] has {names[k]}=.* outside"):
                model.update(A, PHI, L, 0.01, params=params, law_state=bad)
