"""``model.terms``: the fabric's rate split into input, recovery, spin and the law's own part, for every law."""

import numpy as np
import pytest

import model
from model.equations import eq13_terms
from model.terms import fabric_terms

#: after the turn of a 150 degree cycle, inside its segment (no change of direction within)
STRAINS = np.arange(0.75, 1.0, 0.0005)


def cycle_and_terms(params):
    result = model.predict(150, params=params, times=STRAINS)
    L = np.array([model.shear_velocity_gradient(150.0)] * len(STRAINS))
    return result, fabric_terms(result.A, result.law_state, L, params)


@pytest.mark.parametrize("law", list(model.laws.LAWS))
def test_the_terms_sum_to_the_rate_of_the_fabric(law):
    """For every law (its first example set), the four terms add up to the rate of the fabric it returns (central
    differences in |D'| t = strain / sqrt2), with the rate of the part its own state holds where it has one."""
    values = next(iter(model.laws.declared(law, "EXAMPLES").values()))
    params = model.Params(variant=law, **values)
    result, terms = cycle_and_terms(params)
    rate = np.gradient(result.A, STRAINS / np.sqrt(2.0), axis=0)[1:-1]
    total = terms.total()[1:-1]
    assert np.abs(total - rate).max() < 2e-3 * np.abs(rate).max()
    holds_fabric = any(hasattr(p.module, "state_fabric") for p in model.laws.LAWS[law].parts)
    assert (np.abs(terms.own).max() > 0) == holds_fabric


def test_eq13s_terms_are_eq13s():
    """Eq. 13's input, recovery and spin are ``model.equations.eq13_terms``' (its own part is none)."""
    result, terms = cycle_and_terms(model.PAPER)
    L = np.array([model.shear_velocity_gradient(150.0)] * len(STRAINS))
    expected = eq13_terms(result.A, L, model.PAPER)
    np.testing.assert_allclose(terms.input, expected["input"], atol=1e-12)
    np.testing.assert_allclose(terms.recovery, expected["recovery"], atol=1e-12)
    np.testing.assert_allclose(terms.spin, expected["spin"], atol=1e-12)
    assert not terms.own.any()
