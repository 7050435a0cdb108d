"""The real Yade past the time-step limit: the scene stops with its diagnostic and exit status 3, and the
run spec refuses such a step before anything runs."""

import pytest

from pipeline import spec as run_spec
from pipeline.errors import SpecError
from pipeline.studies import stability

pytestmark = pytest.mark.yade

#: shear over which the tests close the energy balance (the study's 0.1 costs 2.5 times as long): 3200 steps of the
#: tiny cell, where the residual is 4e-4 of the energy passing through and a blow-up's is above 50 (2026-11-25)
ENERGY_STRAIN = 0.04


def test_a_time_step_past_the_limit_stops_with_the_diagnostic_and_exit_status_3(tmp_path):
    case = next(c for c in stability.CASES if c.label == "dt2.0")
    row = stability.run_case(case, tmp_path)
    assert row["outcome"] == "stopped" and row["exit_status"] == 3
    assert "escaped the walls" in row["diagnostic"] or "not finite" in row["diagnostic"]
    with pytest.raises(SpecError, match="dt_safety"):
        run_spec.resolve(180, "tiny", overrides={"dt_safety": 2.0})


def test_a_coarse_time_step_at_the_bound_runs_to_its_verdict(tmp_path):
    """``dt0.5`` (the time step at the spec's bound) lands its samples up to a controller interval past their
    targets, more than half the dense spacing: its file is still written and the case judged (``make stability``
    stopped on it with a traceback when samples were told grid or dense by their strain)."""
    row = stability.run_case(next(c for c in stability.CASES if c.label == "dt0.5"), tmp_path,
                             energy_strain=ENERGY_STRAIN)
    assert row["outcome"] == "passed", row


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    """The tiny preset as it is, run and checked once (its energy balance is the scale the blow-up is judged by)."""
    return stability.run_case(next(c for c in stability.CASES if c.label == "baseline"),
                              tmp_path_factory.mktemp("baseline"), energy_strain=ENERGY_STRAIN)


def test_a_case_within_the_bounds_runs_and_passes_its_checks_the_energy_balance_included(baseline):
    assert baseline["outcome"] == "passed" and baseline["finite"] and baseline["max_wall_stress_error"] < 0.5
    energy = baseline["energy"]
    assert energy["steps"] > 1000 and energy["wall_work"] > 0 and energy["dissipated"]["friction"] > 0
    assert abs(energy["relative_residual"]) < stability.ENERGY_TOLERANCE


def test_the_energy_balance_catches_a_run_that_blows_up_without_tripping_the_wall_alarm(baseline):
    case = next(c for c in stability.CASES if c.label == "restitution0.1")  # tangential dashpot of the lightest
    energy = stability.energy_balance(stability.spec_of(case), ENERGY_STRAIN)  # pairs past its explicit limit
    assert abs(energy["relative_residual"]) > 10 * stability.ENERGY_TOLERANCE
    assert energy["elastic"][0] > 10 * baseline["energy"]["elastic"][0]  # overlaps far beyond the preset's


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
    assert again["interactions_potential_per_grain"] > again["interactions_real_per_grain"]  # the collider's pairs


def test_bench_dem_writes_one_throughput_record_per_preset(tmp_path, capsys):
    import json

    from pipeline.studies import bench_dem

    assert bench_dem.main(["--presets", "tiny", "--repeats", "1", "--out", str(tmp_path)]) == 0
    records = json.loads((tmp_path / "dem_throughput.json").read_text())
    assert [r["preset"] for r in records] == ["tiny"] and (tmp_path / "cache" / "tiny.yade.gz").exists()
    r = records[0]
    assert r["grains"] > 0 and r["wall_spheres"] > 0
    for mode in ("bare", "full"):
        assert r["steps_per_second"][mode] > 0
        assert r["particle_steps_per_second"][mode] == pytest.approx(
            r["steps_per_second"][mode] * (r["grains"] + r["wall_spheres"]))
        assert r["engines"][mode]["interactions_all"] >= r["engines"][mode]["interactions_real"] > 0
    assert r["ns_per_interaction_visit"] > 0 and "| tiny |" in capsys.readouterr().out


def test_bench_dem_refuses_an_unknown_preset_before_running_anything(tmp_path, capsys):
    from pipeline.studies import bench_dem

    assert bench_dem.main(["--presets", "tiny,huge", "--out", str(tmp_path)]) == 2
    assert "huge" in capsys.readouterr().err and not (tmp_path / "dem_throughput.json").exists()


def test_collisional_contacts_close_the_energy_balance_as_tightly_as_enduring_ones():
    # frictionless grains: most contacts are brief, clipped to zero force and re-engaging; the springs' energy
    # must be counted from the overlap and net of what a re-engaging spring already holds (else 2.3 % off)
    case = next(c for c in stability.CASES if c.label == "frictionless")
    energy = stability.energy_balance(stability.spec_of(case), ENERGY_STRAIN)
    assert energy["dissipated"]["friction"] == 0 and energy["dissipated"]["normal_dashpot"] > 0
    assert abs(energy["relative_residual"]) < 0.005
