"""The DEM post-processing and HDF5 round trip, on synthetic runs made by the model (known truth)."""

import dataclasses
import json

import h5py
import numpy as np
import pytest

import model
from dem.core.rawfile import write_raw
from pipeline.dataset.dem_file import load, write_h5
from pipeline.errors import DemFileError
from tests.helpers.synthetic import synthetic_raw


def make_file(tmp_path, theta, **kw):
    raw, meta = synthetic_raw(theta, **kw)
    write_raw(tmp_path / "raw.npz", raw, meta)
    out = tmp_path / "run.h5"
    write_h5(tmp_path / "raw.npz", out, {"git_commit": "test", "sessions": []})
    return load(out)


@pytest.mark.parametrize("theta", [90.0, 180.0])
def test_noise_free_cycle_and_series_reproduce_the_model(tmp_path, theta):
    run = make_file(tmp_path, theta, n_cycles=2)
    cycle = model.predict(theta)
    c = run.cycle
    np.testing.assert_allclose(c["strain"], cycle.strain, atol=1e-12)
    np.testing.assert_allclose(c["A"], cycle.A, atol=1e-12)
    # the last grid point (strain 1.4) is a boundary sample: the DEM records the new direction there,
    # the model's output the old one
    inner = slice(0, -1)
    np.testing.assert_allclose(c["tau_over_p"][inner], cycle.tau[inner], atol=1e-12)
    # the post-processing's D', S and work rate follow the model's conventions
    np.testing.assert_allclose(c["S"][inner], cycle.S[inner], atol=1e-9)
    np.testing.assert_allclose(c["w_shear"][inner], cycle.w_shear[inner], atol=1e-9)
    np.testing.assert_allclose(c["mean_stress_over_p"], 1.0)
    np.testing.assert_allclose(c["A_sem"], 0.0, atol=1e-12)
    first = (run.series["strain_nominal"] >= 0) & (run.series["strain_nominal"] < 0.7)
    np.testing.assert_allclose(run.series["D_dev_nominal"][first][0], cycle.D_dev[0], atol=1e-15)


def test_noisy_cycles_report_standard_errors_that_cover_the_truth(tmp_path):
    run = make_file(tmp_path, 120.0, n_cycles=5, noise=0.02, seed=3)
    truth = model.predict(120.0)
    z = (run.cycle["tau_over_p"][:, 0, 1] - truth.tau[:, 0, 1]) / run.cycle["tau_over_p_sem"][:, 0, 1]
    assert 0.5 < np.std(z) < 2.0  # t-distributed with 4 degrees of freedom: sd 1.41
    assert np.sqrt(np.mean(run.cycle["tau_over_p_sem"][:, 0, 1] ** 2)) == pytest.approx(0.02 / np.sqrt(5), rel=0.2)


def test_bulk_strain_uses_the_measured_rate_and_each_interval_s_own_direction(tmp_path):
    """At a reversal the sample carries the new direction while the band still moves the old way (its
    rate along the new direction is negative): the interval ending there is integrated along the old one."""
    run = make_file(tmp_path, 180.0, n_cycles=1, bulk_ratio=1.3)
    s = run.series
    changes = np.flatnonzero(np.diff(run.raw["direction_deg"])) + 1
    assert np.all(s["shear_rate_bulk"][changes] < 0)
    # the band reverses within the interval after each change, linearly in the synthetic run: that
    # interval adds no strain, every other one 1.3 x its nominal strain
    start = np.argmin(np.abs(s["strain_nominal"]))
    lost = np.array([np.sum((changes >= start) & (changes < j)) for j in range(s["strain_nominal"].size)])
    np.testing.assert_allclose(s["strain_bulk"], 1.3 * (s["strain_nominal"] - 0.005 * lost), atol=1e-12)


def test_definitions_of_strain_packing_fraction_and_pressure(tmp_path):
    from pipeline.dataset.derived import Definitions, bulk_over_nominal, gap_packing_fraction

    run = make_file(tmp_path, 180.0, n_cycles=1, bulk_ratio=1.3)
    assert bulk_over_nominal(run) == pytest.approx(1.3 * (1 - 2 * 0.005 / 1.4))  # two reversals in the period
    assert bulk_over_nominal(run.with_definitions(Definitions(strain="nominal"))) == 1.0
    gap = run.with_definitions(Definitions(phi="gap"))
    expected = np.pi / 6 * np.sum(run.grain_diameter**3) / (run.parameters["width_d"] ** 2 * (run.raw["gap"] - 1.0))
    np.testing.assert_allclose(gap.series["packing_fraction"], expected)
    # the synthetic cell's gap follows its Phi: the whole gap's Phi is the model's, as the central one is
    np.testing.assert_allclose(gap.series["packing_fraction"], run.raw["packing_fraction"], rtol=1e-12)
    assert gap_packing_fraction(5.0, 4.0, [1.0]) == pytest.approx(np.pi / 6 / 64)
    raw = dict(run.raw, wall_stress_error_mean=np.full(len(run.raw["strain"]), -0.2))
    wall = dataclasses.replace(run, raw=raw).with_definitions(Definitions(pressure="wall"))
    np.testing.assert_allclose(wall.series["tau_over_p"], run.series["tau_over_p"] / 0.8)
    with pytest.raises(ValueError, match="strain='true' is not one of bulk, nominal"):
        Definitions(strain="true")


def test_reading_a_file_of_another_kind_fails_in_one_line(tmp_path):
    import h5py

    with h5py.File(tmp_path / "other.h5", "w") as f:
        f.attrs["schema"] = "something-else"
    with pytest.raises(DemFileError, match="is not a DEM run file"):
        load(tmp_path / "other.h5")
    with pytest.raises(DemFileError, match="cannot open"):
        load(tmp_path / "missing.h5")


def test_committed_version_1_files_read_the_same_as_when_they_were_written():
    """A v1 file also stored /series and /cycle; reading it recomputes both from /raw, identically."""
    import h5py

    from pipeline.paths import REFERENCE_DIR

    path = REFERENCE_DIR / "reduced" / "dem" / "theta180.h5"
    run = load(path)
    with h5py.File(path) as f:
        assert f.attrs["schema_version"] == 1
        stored = {k: f["cycle"][k][()] for k in ("strain", "A", "tau_over_p", "packing_fraction", "A_sem")}
        series = {k: f["series"][k][()] for k in ("S", "w_vol")}
        stored_bulk = f["series"]["strain_bulk"][()]
    for key, value in stored.items():
        np.testing.assert_array_equal(run.cycle[key], value, err_msg=key)
    for key, value in series.items():  # S is evaluated by today's model code: equal to rounding
        np.testing.assert_allclose(run.series[key], value, rtol=1e-12, atol=1e-15, err_msg=key)
    # the bulk strain is now integrated along each interval's own direction: it differs only from the
    # first change of direction on, by a small step at each change (the band lags the walls)
    first_change = np.flatnonzero(np.diff(run.raw["direction_deg"]))[0] + 1
    np.testing.assert_allclose(np.diff(run.series["strain_bulk"][:first_change]), np.diff(stored_bulk[:first_change]),
                               atol=1e-12)
    steps = np.diff(run.series["strain_bulk"] - stored_bulk)
    changes = np.flatnonzero(np.diff(run.raw["direction_deg"])) + 1
    moved = np.flatnonzero(np.abs(steps) > 1e-9) + 1
    assert all(np.min(np.abs(changes - k)) <= 1 for k in moved) and 0.001 < steps.max() < 0.02


def test_a_checkpoint_is_whole_only_if_its_gzip_stream_is(tmp_path):
    """What the scene checks before a new checkpoint replaces the old one (Yade's O.save onto a full disk
    returns quietly with a truncated file)."""
    import gzip

    from dem.core.rawfile import complete_gzip

    whole = tmp_path / "c.yade.gz"
    with gzip.open(whole, "wb") as fh:
        fh.write(np.random.default_rng(0).bytes(300_000))
    truncated = tmp_path / "t.yade.gz"
    truncated.write_bytes(whole.read_bytes()[:-5000])
    junk = tmp_path / "j.yade.gz"
    junk.write_bytes(b"not gzip")
    assert complete_gzip(whole) and not complete_gzip(truncated) and not complete_gzip(junk)
    assert not complete_gzip(tmp_path / "missing.gz")


def test_cpu_seconds_count_each_session_s_cores_and_bound_an_older_file_from_above(tmp_path, monkeypatch):
    """A run's cost: its loop's wall seconds times its cores (MPI ranks times threads) session by session; a file
    from before that count gives its loop times the most cores a session used (an upper bound)."""
    from dem.core import driver
    from dem.core.state import RunState

    built = {"next_checkpoint": 0, "first_grain": 0, "n_grains": 1, "bottom_inner_offset": 0.0,
             "top_inner_offset": 0.0, "kn": 1.0, "kt": 0.5, "cn": 0.0, "ct": 0.0}
    state = RunState.from_dict({**built, "loop_seconds": 100.0})  # a checkpoint from before the count: one core
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "2")
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    driver.count_seconds(state, 50.0)
    assert (state.loop_seconds, state.cpu_seconds) == (150.0, 200.0)
    monkeypatch.delenv("OMPI_COMM_WORLD_SIZE")
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    driver.count_seconds(state, 10.0)
    assert (state.loop_seconds, state.cpu_seconds) == (160.0, 230.0)
    with pytest.raises(ValueError, match="unknown entries"):
        RunState.from_dict({**built, "colour": 1})

    raw, meta = synthetic_raw(180.0)
    write_raw(tmp_path / "raw.npz", raw, {**meta, "loop_seconds": 160.0, "cpu_seconds": 230.0})
    sessions = [{"ranks": 1, "threads": 1}, {"ranks": 2, "threads": 1}]
    write_h5(tmp_path / "raw.npz", tmp_path / "run.h5", {"git_commit": "test", "sessions": sessions})
    run = load(tmp_path / "run.h5")
    assert run.cpu_seconds == 230.0 and run.sessions == sessions
    older = dataclasses.replace(run, parameters={k: v for k, v in run.parameters.items() if k != "cpu_seconds"})
    assert older.cpu_seconds == 320.0


@pytest.mark.parametrize("damage, message", [
    (lambda s: s.__setitem__(3, np.nan), "/raw/strain has non-finite values"),
    (lambda s: s.__setitem__(slice(None), s[::-1].copy()), "/raw/strain does not rise from sample to sample"),
    (lambda s: s.__setitem__(5, s[4]), "/raw/strain does not rise from sample to sample"),
])
def test_a_run_file_whose_strain_is_damaged_is_refused_in_one_line(tmp_path, damage, message):
    import h5py

    raw, meta = synthetic_raw(180.0, n_cycles=1)
    write_raw(tmp_path / "raw.npz", raw, meta)
    write_h5(tmp_path / "raw.npz", tmp_path / "run.h5", {"git_commit": "test", "sessions": []})
    with h5py.File(tmp_path / "run.h5", "r+") as f:
        strain = f["raw/strain"][()]
        damage(strain)
        f["raw/strain"][...] = strain
    with pytest.raises(DemFileError) as err:
        load(tmp_path / "run.h5")
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_run_filed_under_another_runs_name_or_folder_is_refused(tmp_path):
    """A file stands for the run its provenance names: one copied to another angle's name, or a LAMMPS run copied
    into the Yade folder of the same preset, is refused rather than read as that run (or silently left out)."""
    from pipeline.dataset import lookup
    from pipeline.dataset.selection import DataSet
    from pipeline.errors import PipelineError
    from tests.helpers import synthetic_file

    dem = tmp_path / "p" / "dem"
    dem.mkdir(parents=True)
    synthetic_file(dem, name="theta180", n_cycles=1, preset="p")
    assert len(lookup.preset_runs(DataSet("p"), (tmp_path,))) == 1
    moved = synthetic_file(dem, theta=75.0, name="theta075", n_cycles=1, preset="p")
    moved.rename(dem / "theta060.h5")
    with pytest.raises(PipelineError, match=r"is the run p/theta075 by its provenance, filed as p/theta060"):
        lookup.preset_runs(DataSet("p"), (tmp_path,))
    # its spec's name and folder edited to the place it is filed at: its angle still tells
    with h5py.File(dem / "theta060.h5", "r+") as f:
        stored = json.loads(f["provenance"].attrs["spec_json"])
        f["provenance"].attrs["spec_json"] = json.dumps({**stored, "name": "theta060"})
    with pytest.raises(PipelineError, match=r"its angle and rotation make it theta075, not theta060"):
        lookup.preset_runs(DataSet("p"), (tmp_path,))
    (dem / "theta060.h5").unlink()
    lammps = tmp_path / "p-lammps" / "dem"
    lammps.mkdir(parents=True)
    synthetic_file(lammps, theta=90.0, name="theta090", n_cycles=1, preset="p", engine="lammps").rename(
        dem / "theta090.h5")
    with pytest.raises(PipelineError, match=r"is the run p-lammps/theta090 by its provenance, filed as p/theta090"):
        lookup.every_seed(DataSet("p"), (tmp_path,))
    (dem / "theta090.h5").unlink()
    # a value that its override contradicts (the inertial number edited, the override and folder kept)
    with h5py.File(dem / "theta180.h5", "r+") as f:
        stored = json.loads(f["provenance"].attrs["spec_json"])
        f["provenance"].attrs["spec_json"] = json.dumps({**stored, "overrides": {"inertial_number": 0.002}})
    with pytest.raises(PipelineError, match=r"preset, engine and overrides file it in p-[0-9a-f]{8}, not p; "
                                            r"inertial_number=0.001 but its override says 0.002"):
        lookup.preset_runs(DataSet("p"), (tmp_path,))


def test_samples_that_land_late_in_a_coarse_step_are_still_told_grid_from_dense():
    """A coarse time step lands a sample up to one controller interval past its target, which can be more than half
    the dense spacing: each sample is its target's (one per target, in order), not whichever grid point is near."""
    from dem.core.protocol import on_grid, sample_strains
    from pipeline import spec as run_spec
    from pipeline.dataset.dem_file import grid_samples

    spec = run_spec.resolve(180.0, "tiny")
    targets = np.array(sample_strains(spec))
    truth = np.isclose(((targets + spec.pre_strain) / spec.sample_strain) % 1, 0, atol=1e-6) | np.isclose(
        ((targets + spec.pre_strain) / spec.sample_strain) % 1, 1, atol=1e-6)
    landed = targets + 0.0004  # later than half the dense spacing (0.00025) past every target
    assert not np.array_equal([on_grid(float(s), spec) for s in landed], truth)  # the strain alone misleads
    assert np.array_equal(grid_samples(landed, spec), truth)
    assert np.array_equal(grid_samples(landed[:50], spec), truth[:50])  # a run in progress
