"""The scene's protocol and its run checks, without Yade (they are plain python and numpy)."""

import numpy as np
import pytest

from dem.core import checks, protocol
from pipeline.errors import SpecError
from pipeline.spec import resolve


def test_direction_follows_fig1_and_a_boundary_belongs_to_the_segment_it_starts():
    spec = resolve(90, "reduced")
    assert protocol.direction_deg(-0.3, spec) == 90.0  # the preceding half period at theta
    assert protocol.direction_deg(0.0, spec) == 0.0
    assert protocol.direction_deg(0.7 - 1e-9, spec) == 0.0
    assert protocol.direction_deg(0.7, spec) == 90.0
    assert protocol.direction_deg(1.4, spec) == 0.0  # the next period starts along e1
    assert protocol.direction_deg(0.15, resolve(90, "reduced", rotate_at=0.1)) == 90.0
    assert protocol.end_strain(spec) == pytest.approx(2.8)


def test_samples_are_the_regular_grid_plus_a_dense_window_after_each_change_of_direction():
    spec = resolve(180, "reduced", overrides={"dense_window_strain": 0.01, "dense_sample_strain": 0.001})
    strains = np.array(protocol.sample_strains(spec))
    assert np.all(np.diff(strains) > 1e-9) and strains[0] == pytest.approx(-0.7) and strains[-1] == pytest.approx(2.8)
    grid = [s for s in strains if protocol.on_grid(s, spec)]
    assert len(grid) == 701  # 0.7 + 2 x 1.4 strain every 0.005, both ends
    assert protocol.direction_changes(spec) == pytest.approx([0.0, 0.7, 1.4, 2.1])
    dense = strains[[not protocol.on_grid(s, spec) for s in strains]]
    # after each of the 4 changes: 0.001 ... 0.009 but 0.005 (on the grid); 0.01 is on the grid
    assert len(dense) == 4 * 8 and dense[:5] == pytest.approx([0.001, 0.002, 0.003, 0.004, 0.006])
    assert protocol.on_grid(0.005 + 1e-5, spec) and not protocol.on_grid(0.006 + 1e-5, spec)  # a late sample
    off = resolve(180, "reduced", overrides={"dense_window_strain": 0})
    assert len(protocol.sample_strains(off)) == 701
    assert protocol.direction_changes(resolve(0, "reduced")) == []
    with pytest.raises(SpecError, match="dense_sample_strain=0.002 must divide sample_strain"):
        resolve(180, "reduced", overrides={"dense_sample_strain": 0.002})


def row(gap=8.0, stress=0.0):
    return {"stress_contact": np.eye(3) * stress, "fabric": np.zeros((3, 3)), "packing_fraction": 0.6, "gap": gap,
            "strain": 0.1}


def test_each_check_fires_on_a_case_built_to_fail_it():
    ids, vel = np.arange(3), np.zeros((3, 3))
    pos = np.array([[0, 2.0, 0], [0, 4.0, 0], [0, 6.0, 0]])
    assert checks.sample_problem(row(), ids, pos, vel, (1.0, 9.0), 8.0) is None
    assert "stress_contact is not finite" in checks.sample_problem(row(stress=np.nan), ids, pos, vel, (1, 9), 8.0)
    assert "NaN grain" in checks.sample_problem(row(), ids, pos, vel * np.nan, (1, 9), 8.0)
    escaped = pos.copy()
    escaped[2, 1] = 12.0
    assert "1 grain(s) escaped the walls (first: id 2" in checks.sample_problem(row(), ids, escaped, vel, (1, 9), 8.0)
    assert "wall gap ran away: 13.00 d" in checks.sample_problem(row(gap=13.0), ids, pos, vel, (1, 9), 8.0)


def test_the_stress_alarm_needs_the_error_to_last_a_strain_not_a_number_of_samples():
    spec = resolve(180, "reduced")  # alarm at 25 % for 0.05 strain
    off, problem = 0.0, None
    for _ in range(9):
        off, problem = checks.stress_alarm(-0.3, off, 0.005, spec)
    assert off == pytest.approx(0.045) and problem is None
    off, problem = checks.stress_alarm(0.01, off, 0.005, spec)
    assert (off, problem) == (0.0, None)  # back on target: the count restarts
    for _ in range(80):  # dense samples: 80 x 0.0005 = 0.04 strain is still short of the alarm
        off, problem = checks.stress_alarm(-0.3, off, 0.0005, spec)
    assert problem is None
    off, problem = checks.stress_alarm(-0.3, 0.045, 0.005, spec)
    assert "wall normal stress off target by -30% for 0.05 strain" in problem
    off, problem = checks.stress_alarm(0.55, 0.0, 0.005, spec)  # more than twice the alarm: at once
    assert off == 0.005 and "off target by +55% over one sample (more than twice the alarm level, 25%)" in problem
