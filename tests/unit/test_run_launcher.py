
"""The DEM launcher's run folder: spec bookkeeping before Yade starts (no Yade needed)."""

import dataclasses
import json
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import pytest

from dem.core.rawfile import write_raw
from dem.lammps import lib as lammps_lib
from pipeline import spec as run_spec
from pipeline.dataset.dem_file import SCHEMA, SCHEMA_VERSION
from pipeline.errors import SpecError
from pipeline.paths import ROOT
from pipeline.runs import launch as dem
from tests.helpers.synthetic import synthetic_raw


def test_prepare_writes_the_spec_and_refuses_a_checkpoint_of_another_spec(tmp_path):
    spec = run_spec.resolve(90, "tiny")
    run_dir = dem.prepare(spec, tmp_path, fresh=False)
    assert json.loads((run_dir / "spec.json").read_text()) == spec.to_dict()
    (run_dir / "checkpoint.yade.gz").write_bytes(b"x")
    other = run_spec.resolve(90, "tiny", overrides={"seed": 5.0})
    other = dataclasses.replace(other, folder=spec.folder)  # same folder, other physics
    with pytest.raises(SpecError, match="holds a checkpoint.yade.gz of another spec"):
        dem.prepare(other, tmp_path, fresh=False)
    assert dem.prepare(other, tmp_path, fresh=True) == run_dir  # --fresh starts again
    assert not (run_dir / "checkpoint.yade.gz").exists()


def write_run_file(out, spec: dict):
    out.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(out, "w") as f:
        f.attrs.update(schema=SCHEMA, schema_version=SCHEMA_VERSION)
        f.create_group("parameters")
        f.create_group("provenance").attrs["spec_json"] = json.dumps(spec, sort_keys=True)


def test_an_existing_result_is_not_run_again_and_one_of_another_spec_is_refused(tmp_path, capsys):
    spec = run_spec.resolve(90, "tiny")
    out = run_spec.output_path(spec, tmp_path)
    write_run_file(out, spec.to_dict())
    assert dem.run(spec, tmp_path) == out
    assert "is up to date" in capsys.readouterr().out
    write_run_file(out, {**spec.to_dict(), "theta_deg": 90.04})  # a name that used to hold both
    with pytest.raises(SpecError, match="holds a run of another spec .its values differ.: rerun with --fresh"):
        dem.run(spec, tmp_path)
    out.write_bytes(b"not a run")
    with pytest.raises(SpecError, match="its file is unreadable"):
        dem.run(spec, tmp_path)


def test_names_carry_every_digit_and_minus_180_is_the_reversal():
    names = {run_spec.resolve(t, "tiny", rotate_at=r).name for t, r in
             [(0.01, None), (0.04, None), (90, 0.101), (90, 0.104), (90, 0.1)]}
    assert names == {"theta000.01", "theta000.04", "theta090_rot0.101", "theta090_rot0.104", "theta090_rot0.10"}
    assert run_spec.resolve(-180, "tiny") == run_spec.resolve(180, "tiny")


def test_a_leftover_raw_file_of_another_spec_is_refused(tmp_path):
    spec = run_spec.resolve(180, "tiny")
    run_dir = dem.prepare(spec, tmp_path, fresh=False)
    (run_dir / "raw.npz").write_bytes(b"x")
    other = dataclasses.replace(run_spec.resolve(135, "tiny"), name=spec.name)  # the same folder, another angle
    with pytest.raises(SpecError, match="holds a raw.npz of another spec"):
        dem.prepare(other, tmp_path, fresh=False)


def test_writing_the_file_holds_off_a_warning_and_then_gives_the_handler_back(tmp_path):
    """A scheduler's warning while the HDF5 file is written (seconds) is ignored, and only then: the launcher's
    SIGUSR1 handler is back afterwards (a caller in-process, or a child it starts, keeps what it had)."""
    spec = run_spec.resolve(90, "tiny")
    run_dir = run_spec.work_dir(spec, tmp_path)
    run_dir.mkdir(parents=True)
    write_raw(run_dir / "raw.npz", *synthetic_raw(90.0))  # the scene has finished: only the file is left to write
    before = signal.getsignal(signal.SIGUSR1)
    assert dem.run(spec, tmp_path).exists()
    assert signal.getsignal(signal.SIGUSR1) is before


def test_a_run_in_progress_travels_through_data_and_is_taken_up_where_none_is(tmp_path):
    """``--commit`` copies a stopped run's folder, its logs left behind, under the reference data; the same run on
    another machine (another results folder, no folder of its own) starts from it; another spec's is refused."""
    spec = run_spec.resolve(180, "tiny", engine="lammps")
    here, there, reference = tmp_path / "here", tmp_path / "there", tmp_path / "data"
    run_dir = dem.prepare(spec, here, fresh=False, reference=reference)
    for name, text in (("checkpoint.json", "{}"), ("restart_000000004000.lmp", "state"), ("lammps.log", "log"),
                       ("log.txt", "log"), ("status.json", '{"percent": 12.5, "strain": 0.1}')):
        (run_dir / name).write_text(text)
    committed = dem.commit_in_progress(spec, here, reference)
    assert sorted(p.name for p in committed.iterdir()) == ["checkpoint.json", "restart_000000004000.lmp", "spec.json",
                                                            "status.json"]
    taken = dem.prepare(spec, there, fresh=False, reference=reference)
    assert (taken / "restart_000000004000.lmp").read_text() == "state"
    assert dem.prepare(spec, there, fresh=False, reference=reference) == taken  # a folder here: left as it is
    other = dataclasses.replace(spec, seed=5)
    (committed / "spec.json").write_text(json.dumps(other.to_dict()))
    with pytest.raises(SpecError, match="holds a run of another spec"):
        dem.prepare(spec, tmp_path / "third", fresh=False, reference=reference)
    with pytest.raises(SpecError, match="no run in progress here"):
        dem.commit_in_progress(spec, tmp_path / "nowhere", reference)


def test_a_damaged_provenance_is_one_line_before_the_scene_starts(tmp_path):
    spec = run_spec.resolve(90, "tiny")
    for k, text in enumerate(("{bad", "null", '{"sessions": 3}')):
        run_dir = dem.prepare(spec, tmp_path / str(k), fresh=False)
        (run_dir / "provenance.json").write_text(text)
        with pytest.raises(SpecError, match=r"provenance.json is damaged .*: rerun with FRESH=1"):
            dem.run(spec, tmp_path / str(k))


@pytest.mark.parametrize("engine, options, message", [
    ("lammps", {"threads": 2}, "threads=2: threads are for ENGINE=yade (lammps runs on MPI ranks: RANKS=)"),
    ("yade", {"ranks": 2}, "ranks=2: MPI ranks are for ENGINE=lammps (yade runs on threads: THREADS=)"),
])
def test_an_option_the_engine_would_ignore_is_refused_before_anything_runs(tmp_path, engine, options, message):
    spec = run_spec.resolve(180.0, "tiny", None, {}, engine=engine)
    with pytest.raises(SpecError) as refused:
        dem.run(spec, tmp_path, **options)
    assert str(refused.value) == message and not any(tmp_path.iterdir())


@pytest.mark.parametrize("job, local", [({}, True), ({"SLURM_JOB_ID": "7", "SLURM_JOB_NUM_NODES": "1"}, True),
                                        ({"SLURM_JOB_ID": "7", "SLURM_JOB_NUM_NODES": "2"}, False)],
                         ids=["here", "slurm-one-node", "slurm-two-nodes"])
def test_ranks_on_one_machine_talk_through_shared_memory_and_open_no_port(monkeypatch, job, local):
    """Open MPI's TCP transport (a port on every interface) stays off wherever every rank runs on this machine; a job
    over several nodes keeps Open MPI's defaults; a user's own setting wins."""
    from pipeline.runs import scripts

    monkeypatch.delenv("OMPI_MCA_btl", raising=False)
    for name in ("SLURM_JOB_ID", "SLURM_JOB_NUM_NODES"):
        monkeypatch.delenv(name, raising=False)
    for name, value in job.items():
        monkeypatch.setenv(name, value)
    assert scripts.environment(ranks=2).get("OMPI_MCA_btl") == ("self,vader" if local else None)
    assert scripts.environment(ranks=1)["OMPI_MCA_btl"] == "self,vader"
    monkeypatch.setenv("OMPI_MCA_btl", "self,tcp")
    assert scripts.environment(ranks=2)["OMPI_MCA_btl"] == "self,tcp"



SESSION_BASE = """
import os
from dem.lammps import lib
base = lib.singleton_session_base()
assert lib.singleton_session_base() == base  # again, as after the exec at a checkpoint
print(base, oct(os.stat(base).st_mode & 0o777))
"""


def test_a_lammps_singleton_keeps_open_mpis_session_in_a_private_folder_of_its_own_removed_at_its_end(
        tmp_path, monkeypatch):
    """Two runs of a sweep never share (and remove) one session directory; a folder in its place that is not this
    user's private one is refused."""
    env = {**os.environ, "TMPDIR": str(tmp_path), "PYTHONPATH": str(ROOT)}
    said = subprocess.run([sys.executable, "-c", SESSION_BASE], capture_output=True, text=True, env=env, check=True)
    base, mode = said.stdout.split()
    assert Path(base).parent == tmp_path and mode == "0o700" and not Path(base).exists()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    squatted = tmp_path / f"dem-mpi-{os.getuid()}-{os.getpid()}"
    squatted.mkdir()
    squatted.chmod(0o777)
    with pytest.raises(OSError, match="is not a private folder of this user"):
        lammps_lib.singleton_session_base()
