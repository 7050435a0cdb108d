"""The real Yade past the time-step limit: the scene stops with its diagnostic and exit status 3, and the
run spec refuses such a step before anything runs."""

import pytest

from pipeline.errors import SpecError
from pipeline.runs import spec as run_spec
from pipeline.studies import stability

pytestmark = pytest.mark.yade


def test_a_time_step_past_the_limit_stops_with_the_diagnostic_and_exit_status_3(tmp_path):
    case = next(c for c in stability.CASES if c.label == "dt2.0")
    row = stability.run_case(case, tmp_path)
    assert row["outcome"] == "stopped" and row["exit_status"] == 3
    assert "escaped the walls" in row["diagnostic"] or "not finite" in row["diagnostic"]
    with pytest.raises(SpecError, match="dt_safety"):
        run_spec.resolve(180, "tiny", overrides={"dt_safety": 2.0})


def test_a_case_within_the_bounds_runs_and_passes_its_checks(tmp_path):
    row = stability.run_case(next(c for c in stability.CASES if c.label == "baseline"), tmp_path)
    assert row["outcome"] == "passed" and row["finite"] and row["max_wall_stress_error"] < 0.5


def test_the_profile_splits_the_loop_time_by_engine_and_caches_the_compaction(tmp_path):
    from pipeline.studies.profile_dem import profile

    cache = tmp_path / "cache" / "tiny.yade.gz"
    first = profile("tiny", 1, 500, cache)
    assert cache.exists() and first["origin"] == "built"
    again = profile("tiny", 1, 500, cache)
    assert again["origin"] == "loaded" and again["grains"] == first["grains"]
    shares = {e["engine"]: e["percent"] for e in again["engines"]}
    assert sum(shares.values()) == pytest.approx(100.0) and shares["InteractionLoop"] > 10
    assert again["steps_per_second"] > 0 and again["interactions_real_per_grain"] > 0
    assert again["checkpoint_save_seconds"] > 0
