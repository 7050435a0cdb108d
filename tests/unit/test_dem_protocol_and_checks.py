"""The scene's protocol and its run checks, without Yade (they are plain python and numpy)."""

import numpy as np
import pytest

from dem import checks, protocol
from pipeline.runs.spec import resolve


def test_direction_follows_fig1_and_a_boundary_belongs_to_the_segment_it_starts():
    spec = resolve(90, "reduced")
    assert protocol.direction_deg(-0.3, spec) == 90.0  # the preceding half period at theta
    assert protocol.direction_deg(0.0, spec) == 0.0
    assert protocol.direction_deg(0.7 - 1e-9, spec) == 0.0
    assert protocol.direction_deg(0.7, spec) == 90.0
    assert protocol.direction_deg(1.4, spec) == 0.0  # the next period starts along e1
    assert protocol.direction_deg(0.15, resolve(90, "reduced", rotate_at=0.1)) == 90.0
    assert protocol.end_strain(spec) == pytest.approx(2.8)
    assert protocol.total_samples(spec) == 701 and protocol.sample_strain(140, spec) == pytest.approx(0.0)


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


def test_the_stress_alarm_needs_the_error_to_last():
    spec = resolve(180, "reduced")  # alarm at 25 % for 0.05 strain = 10 samples of 0.005
    off, problem = 0, None
    for _ in range(9):
        off, problem = checks.stress_alarm(-0.3, off, spec)
    assert off == 9 and problem is None
    assert checks.stress_alarm(0.01, off, spec) == (0, None)  # back on target: the count restarts
    off, problem = checks.stress_alarm(-0.3, 9, spec)
    assert "wall normal stress off target by -30% for 0.05 strain" in problem
    off, problem = checks.stress_alarm(0.55, 0, spec)  # more than twice the alarm: at once
    assert off == 1 and "off target by +55% over one sample (more than twice the alarm level, 25%)" in problem
