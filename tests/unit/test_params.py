import json

import pytest

from model import PAPER, ParameterError, Params
from model.cli import load_params, save_params


def test_defaults_are_table_2_and_section_5():
    assert (PAPER.C, PAPER.n, PAPER.m) == (-5.6, 0.18, -0.60)
    assert (PAPER.a1, PAPER.b1, PAPER.a2, PAPER.b2) == (-0.021, -2.7, 0.25, -35.0)
    assert PAPER.persistence_exponent == 0.75
    assert PAPER.c1 == -PAPER.C  # Eq. 19
    assert (PAPER.c2_coef, PAPER.c2_exponent, PAPER.c3, PAPER.phi_c) == (5.6, 1 / 3, 0.14, 0.652)


def test_json_round_trip(tmp_path):
    p = PAPER.replace(C=-4.0, c1=4.0, b2=-350.0)  # Eq. 19: c1 = -C
    path = tmp_path / "p.json"
    save_params(p, path)
    assert load_params(path) == p
    assert json.loads(path.read_text())["b2"] == -350.0


def test_unknown_and_missing_keys_are_named():
    values = PAPER.to_dict()
    values.pop("c3")
    values["C_typo"] = 1.0
    with pytest.raises(ParameterError, match="unknown keys C_typo; missing keys c3"):
        Params.from_dict(values, "file.json")


def test_every_bad_value_is_reported_at_once():
    with pytest.raises(ParameterError) as info:
        Params(C=float("nan"), n="x", phi_c=1.5)
    message = str(info.value)
    assert "C=nan is not finite" in message and "n='x' is not a number" in message
    with pytest.raises(ParameterError, match="phi_c=1.5"):
        Params(phi_c=1.5)


@pytest.mark.parametrize("values, message", [
    ({"c2_coef": 0.0}, "c2_coef=0.0 must be > 0"),
    ({"c2_coef": -1.0}, "c2_coef=-1.0 must be > 0"),
    ({"c2_exponent": 1e6}, r"c2_exponent=1000000.0 must lie in \[0, 10\]"),
    ({"c2_exponent": -0.5}, r"c2_exponent=-0.5 must lie in \[0, 10\]"),
])
def test_eq18s_relaxation_must_exist_where_the_model_divides_by_it(values, message):
    """c2 = 0 leaves the packing fraction without a steady value (its steady state divides by c2): refused, with
    what the bound means, instead of a ZeroDivisionError deep in the solver."""
    with pytest.raises(ParameterError, match=message):
        Params(**values)


def test_invalid_json_is_a_one_line_error():
    with pytest.raises(ParameterError, match="not valid JSON"):
        Params.from_json("{C: 1}", "p.json")


def test_params_are_frozen():
    with pytest.raises(AttributeError):
        PAPER.C = 0.0
