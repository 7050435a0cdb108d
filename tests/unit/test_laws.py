"""The registry of fabric laws (``model.laws``): each law owns its parameters, is chosen once by name, and is Eq. 13
where its parameters take their neutral values; nothing outside the registry asks which law it is."""

import re
import types
from pathlib import Path

import numpy as np
import pytest

import model
from model import Params, laws, periodic_cycle, predict
from model.laws.law import make_law
from model.solver import _fabric, _initial_state
from pipeline.calibration.global_fit import FREE, free_names, start_of

MODEL = Path(model.__file__).parent


@pytest.mark.parametrize("name", list(laws.LAWS))
def test_every_law_declares_parameters_in_range_whose_neutral_values_are_eq13(name):
    """Bit for bit for a law without a state of its own; to the integrator's tolerance for one with (its state,
    which holds no part of the fabric, joins the step size control)."""
    own = laws.law_parameters(name)
    joined = laws.LAWS[name].joins  # a law joining two owns both laws' parameters, no other
    fitted = [q for q in own if not q.measured]  # those read off the DEM are held at their measured value
    assert (len(fitted) <= 2 and len(own) <= 4 if not joined
            else own == sum((laws.law_parameters(j) for j in joined), ()) and len(own) <= 4)
    shared = [(q, other) for law in laws.LAWS.values() for other in law.parameters for q in own if q.name == other.name]
    assert all((q.low, q.high) == (other.low, other.high) for q, other in shared)  # one range per name
    assert len({q.name for q in own}) == len(own)
    tolerance = laws.state_tolerance(name)  # the update's tolerance on each state variable, never tighter than A's
    assert len(tolerance) == len(laws.state_names(name)) and all(t >= 1.0 for t in tolerance)
    for q in own:
        assert q.low <= q.neutral <= q.high and q.low <= q.start <= q.high and q.meaning
        assert q.name not in Params.names()
    neutral = Params(variant=name, **{q.name: q.neutral for q in own})
    D = periodic_cycle(150).packed.D_unit[0]
    for theta in (180, 150):
        paper, law = predict(theta), predict(theta, params=neutral)
        if laws.state_names(name):
            assert np.max(np.abs(law.A - paper.A)) < 1e-10 and np.max(np.abs(law.tau - paper.tau)) < 1e-9
            held = [_fabric(_initial_state(np.zeros((3, 3)), x), neutral, D) for x in law.law_state]
            assert np.all(np.array(held) == 0.0)
        else:
            assert np.array_equal(law.A, paper.A) and np.array_equal(law.tau, paper.tau)


def test_a_parameter_set_holds_eq13s_parameters_and_its_laws_own_alone():
    p = Params(variant="memory", memory_share=0.4, C=-6.0)
    assert p.law_values == (0.4, 0.0) and p.memory_share == 0.4 and p.C == -6.0
    assert p.own_names() == (*Params.names(), "memory_share", "memory_rate")
    assert len(p.as_array()) == len(Params.names()) + 1 + 2
    with pytest.raises(model.ParameterError, match="jump_fabric=0.01 belongs to another variant than memory"):
        Params(variant="memory", jump_fabric=0.01)
    with pytest.raises(AttributeError, match="not a parameter of the memory law"):
        p.chi  # noqa: B018
    moved = p.replace(variant="jump", jump_fabric=-0.01)
    assert (moved.variant, moved.jump_fabric, moved.C) == ("jump", -0.01, -6.0)
    assert Params.from_dict(p.to_dict()) == p and Params(variant="memory", law_values=(0.4, 0.0), C=-6.0) == p
    with pytest.raises(model.ParameterError, match="memory_rate=2000.0 must lie in"):
        p.replace(memory_rate=2000.0)


def test_no_module_of_the_model_but_the_registry_asks_which_law_it_is():
    """A law is chosen once by name: outside ``model/laws`` no code compares a law's name or code."""
    names = "|".join(map(re.escape, laws.LAWS))
    asking = re.compile(rf"""(==|!=|\bin)\s*\(?["']({names})["']|["']({names})["']\s*(==|!=)|p\[VARIANT\]""")
    for path in sorted(MODEL.glob("*.py")):
        code = "\n".join(line.split("#")[0] for line in path.read_text().splitlines())
        assert not asking.search(code), f"{path.name} asks which law it is"


def test_every_law_declares_the_sets_it_is_checked_with_and_one_without_fails():
    """The registry's checks take each law's declared examples; a law module without them is refused where the
    registry is made, so the suite stops at its import."""
    for name in model.laws.LAWS:
        for key in model.laws.DECLARED:
            assert model.laws.declared(name, key) is not None
    for _, law, values in model.laws.examples():
        assert set(values) <= {q.name for q in model.laws.law_parameters(law)}
        model.Params(variant=law, **values)  # each a valid set
    bare = types.SimpleNamespace(NAME="bare", PARAMETERS=())
    with pytest.raises(TypeError, match="the bare law declares no EXAMPLES, FIT_EXAMPLE"):
        make_law(bare, 7, dict(model.laws.LAWS))
    stateful = types.SimpleNamespace(NAME="stateful", PARAMETERS=(), STATE=("x",), EXAMPLES={"s": {}},
                                     FIT_EXAMPLE={}, SPEED_EXAMPLE={}, LEAVES_A_REVERSAL=True)
    with pytest.raises(TypeError, match="the stateful law declares no STATE_BOUNDS"):
        make_law(stateful, 7, dict(model.laws.LAWS))


def test_a_joined_law_is_placed_from_its_parts_and_two_owners_of_one_part_are_refused():
    """``elastic_compaction``: the elastic part's state and parameters first, the compaction part's right after them;
    the parameter array's law code sits just before the first law parameter. Joining two laws that both remove is
    refused in one line."""
    law = model.laws.LAWS["elastic_compaction"]
    elastic, compaction = law.parts
    assert (elastic.state_at, elastic.params_at) == (model.laws.BASE, model.laws.OWN)
    assert compaction.state_at == model.laws.BASE + len(model.laws.state_names("elastic"))
    assert compaction.params_at == model.laws.OWN + len(model.laws.law_parameters("elastic"))
    p = Params(variant="elastic_compaction", compaction_gain=123.0).as_array()
    assert p[model.laws.OWN - 1] == law.code and p[compaction.params_at] == 123.0
    assert model.laws.OWN == len(Params.names()) + 1
    both = types.SimpleNamespace(NAME="both", JOINS=("loading", "memory"), EXAMPLES={"b": {}}, FIT_EXAMPLE={},
                                 SPEED_EXAMPLE={}, LEAVES_A_REVERSAL=True)
    with pytest.raises(TypeError, match="joins two parts that each define removal"):
        make_law(both, 7, dict(model.laws.LAWS))


def test_a_parameter_read_off_the_dem_is_held_by_the_fit():
    """The fit refines a law's parameters but those it reads off the DEM (``Parameter.measured``), which it holds at
    their measured value, its start."""
    for name, law in laws.LAWS.items():
        measured = [q for q in law.parameters if q.measured]
        assert free_names(name) == FREE + tuple(q.name for q in law.parameters if not q.measured)
        assert all(getattr(start_of(name), q.name) == q.start for q in measured)
    assert any(q.measured for q in laws.law_parameters("lasting"))


def test_the_lasting_laws_reduce_to_the_laws_they_extend():
    """``lasting`` with gamma_n = gamma_e is ``elastic``; ``lasting_turn`` with k = 0 is ``lasting``, with kappa = 0
    ``turn_compaction`` whose gamma_r is gamma_n (to the integrator's tolerance: their states differ in length)."""
    K = {"elastic_fabric": -0.012, "elastic_strain": 0.005}
    pairs = [(Params(variant="lasting", **K, lasting_strain=0.005), Params(variant="elastic", **K)),
             (Params(variant="lasting_turn", **K, lasting_strain=0.4, turn_gain=0.0),
              Params(variant="lasting", **K, lasting_strain=0.4)),
             (Params(variant="lasting_turn", elastic_fabric=0.0, elastic_strain=0.005, lasting_strain=0.4,
                     turn_gain=150.0), Params(variant="turn_compaction", turn_gain=150.0, turn_strain=0.4))]
    for law, reduced in pairs:
        a, b = predict(150, params=law), predict(150, params=reduced)
        assert np.max(np.abs(a.A - b.A)) < 1e-8 and np.max(np.abs(a.tau - b.tau)) < 1e-7
    far = predict(150, params=Params(variant="lasting", **K, lasting_strain=0.5))
    assert np.max(np.abs(far.A - predict(150, params=pairs[0][1]).A)) > 1e-4  # gamma_n acts
