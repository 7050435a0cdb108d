"""A run's cycles one by one: the drift test holds its level on stationary windows and finds a compaction put into a
run; ``SKIP_CYCLES`` leaves out a run's first cycles as if they had been its preparation."""

import numpy as np
import pytest

from dem.core.rawfile import write_raw
from pipeline.dataset import drift
from pipeline.dataset.dem_file import load, write_h5
from pipeline.dataset.lookup import skipped
from pipeline.dataset.selection import DataSet
from pipeline.errors import PipelineError
from tests.helpers.synthetic import synthetic_raw


def test_the_drift_test_rejects_stationary_windows_at_its_level_and_finds_a_trend():
    rng = np.random.default_rng(1)
    cycle = np.repeat(np.arange(5), 2)
    p = np.array([drift.trend(cycle, rng.normal(size=10), 5).p for _ in range(4000)])
    assert abs(np.mean(p < drift.LEVEL) - drift.LEVEL) < 0.012  # 3.5 standard errors of the rate
    trends = [drift.trend(cycle, -0.04 * cycle + rng.normal(scale=0.01, size=10), 5) for _ in range(400)]
    slopes = np.array([t.slope for t in trends])
    errors = np.array([t.standard_error for t in trends])
    assert abs(np.mean(slopes) + 0.04) < 0.001 and 0.8 < np.std(slopes) / np.mean(errors) < 1.25
    assert np.mean([t.drifts for t in trends]) > 0.99


def test_one_cycle_has_no_test():
    t = drift.trend(np.array([0, 0]), np.array([1.0, 2.0]), 1)
    assert t.per_cycle == (1.5,) and np.isnan(t.p) and not t.drifts
    assert drift.describe({"gap": t}) == "no test (one cycle)"


def run_file(tmp_path, compaction=0.0, n_cycles=5, seed=0):
    """A synthetic reversal whose packing fraction (and so its gap) grows by ``compaction`` per cycle."""
    raw, meta = synthetic_raw(180.0, n_cycles=n_cycles, noise=0.002, seed=seed)
    grown = np.clip(np.floor(raw["strain"] / meta["spec"]["period_strain"]), 0, None) * compaction
    volume = (raw["gap"] - 1.0) * raw["packing_fraction"]
    raw["packing_fraction"] = raw["packing_fraction"] + grown
    raw["profile_packing_fraction"] = raw["packing_fraction"][:, None]
    raw["gap"] = 1.0 + volume / raw["packing_fraction"]
    meta["spec"]["name"] = "theta180"
    write_raw(tmp_path / "run.npz", raw, meta)
    write_h5(tmp_path / "run.npz", tmp_path / "theta180.h5", {"git_commit": "test", "sessions": []})
    return load(tmp_path / "theta180.h5")


def test_a_compaction_put_into_a_run_is_found_and_a_stationary_run_is_not(tmp_path):
    compacting = drift.drift(run_file(tmp_path, compaction=0.002))
    band = compacting["Φ band"]
    assert band.drifts and abs(band.slope - 0.002) < 3 * band.standard_error
    assert compacting["gap"].drifts and compacting["gap"].slope < 0
    (tmp_path / "steady").mkdir()
    steady = drift.drift(run_file(tmp_path / "steady", compaction=0.0))
    assert not steady["Φ band"].drifts and not steady["gap"].drifts
    assert "Φ band" in drift.describe(compacting) and drift.describe(steady) == "stationary"


def test_skipping_cycles_averages_the_later_cycles_only_and_keeps_the_preceding_half_period(tmp_path):
    run = run_file(tmp_path, compaction=0.002, n_cycles=3)
    later = run.without_first_cycles(1)
    assert later.spec.n_cycles == 2 and later.raw["strain"][0] == pytest.approx(-run.spec.pre_strain)
    period = run.spec.period_strain
    every = run.series["packing_fraction"]
    mean_of_later = np.mean([every[np.isclose(run.raw["strain"], c * period + 0.35)] for c in (1, 2)])
    at = np.isclose(later.cycle["strain"], 0.35)
    assert later.cycle["packing_fraction"][at][0] == pytest.approx(mean_of_later)
    assert run.without_first_cycles(0) is run
    with pytest.raises(PipelineError, match="skip_cycles=3: .* has 3 cycle"):
        skipped(run, DataSet("synthetic", skip_cycles=3))
    assert "cycles from 2 on" in DataSet("paper", "lammps", skip_cycles=1).label
