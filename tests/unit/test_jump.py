"""The reversal-jump study on runs made by a model whose fabric jumps by a known fraction."""

import numpy as np
import pytest

import model
from pipeline.studies import jump
from tests.helpers import synthetic_run
from tests.helpers.synthetic import jump_cycle


def test_the_fabric_fraction_after_a_change_is_the_known_jump_and_the_model_after_it(tmp_path):
    run = synthetic_run(tmp_path, jump=0.3)
    truth = jump_cycle(180.0, model.Params(), 0.3).A[:, 0, 1]  # every 0.005 over a period; the change at 140
    profiles = jump.run_profiles(run)
    assert [p["change"] for p in profiles] == pytest.approx([0.0, 0.7, 1.4, 2.1])
    for p in profiles:
        at = dict(zip(jump.GAMMAS, p["fabric"], strict=True))
        assert np.isnan(at[0.0005]) and np.isnan(at[0.002])  # no dense samples in this run
        first, before = (140, 139) if p["change"] % 1.4 else (0, 279)
        for g in (0.005, 0.01, 0.05):
            assert at[g] == pytest.approx(truth[first + round(g / 0.005)] / truth[before], rel=1e-9)
        assert at[0.005] < 0.7  # the known jump, then the model's own decay
    row = jump.summarise([run])["settings"][0]
    assert row["changes"] == 4 and row["fabric"][3]["n"] == 4 and row["fabric"][0]["n"] == 0
    assert jump.model_fabric()[3] == pytest.approx(0.963, abs=2e-3)  # Table 2's model barely moves by 0.005
