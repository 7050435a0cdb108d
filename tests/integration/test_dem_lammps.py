"""Debian's LAMMPS (python3-lammps, in Debian's python3): the contact law matched to Yade's, and the Couette scene
behind the same driver, spec and files as Yade's."""

import hashlib
import json
import os
import re
import shutil
import signal
import struct
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from dem.core import driver
from dem.core.cell import WALL_RADIUS
from dem.core.schema import contact_fields
from pipeline import spec as run_spec
from pipeline.dataset.dem_file import load
from pipeline.paths import ROOT
from pipeline.runs import launch, scripts
from tests.helpers import assert_contact_law

pytestmark = pytest.mark.lammps


def test_lammps_collisions_match_the_contact_law_as_yade_does(tmp_path):
    """Same checks, same tolerances as Yade's (``test_collisions_restitution_stiffness_ratio_and_sliding``):
    restitution of the smallest, mean and largest pairs, k_t/k_n, k_n, and sliding at tan 24 degrees."""
    spec = run_spec.resolve(90, "paper")
    (tmp_path / "spec.json").write_text(json.dumps(spec.to_dict()))
    proc = subprocess.run(["/usr/bin/python3", "-m", "dem.tools.lammps_collision", tmp_path / "spec.json",
                           tmp_path / "out.json"], capture_output=True, text=True, cwd=tmp_path,
                          env=scripts.environment())
    assert proc.returncode == 0, "LAMMPS is missing? `make system-lammps` installs it\n" + proc.stderr
    assert_contact_law(json.loads((tmp_path / "out.json").read_text()), spec)


def launcher(*args, results):
    return [sys.executable, "-m", "pipeline.runs", "run", *args, "--results", str(results)]


def kill_naming(text: str) -> None:
    """SIGKILL every process whose command line names ``text`` (a run's folder: its launcher, mpirun and ranks, which
    the launcher starts in a session of their own)."""
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and text in (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode():
                os.kill(int(entry.name), signal.SIGKILL)
        except (OSError, ProcessLookupError):
            pass


def run_launcher(*args, results):
    return subprocess.run(launcher(*args, results=results), cwd=ROOT, capture_output=True, text=True)


TINY = ("--theta", "180", "--preset", "tiny", "--set", "seed=3")


def tiny_spec(engine):
    return run_spec.resolve(180, "tiny", overrides={"seed": 3.0}, engine=engine)


def interrupt_at_first_sample(results):
    """The tiny LAMMPS run, sent SIGINT at its first progress line: (exit status, what it printed after)."""
    proc = subprocess.Popen(launcher(*TINY, "--engine", "lammps", results=results), cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for line in proc.stdout:
        if "strain" in line:
            proc.send_signal(signal.SIGINT)
            break
    rest = proc.communicate()[0]
    return proc.returncode, rest


@pytest.fixture(scope="module")
def both_engines(tmp_path_factory):
    """The same tiny spec run by each engine, uninterrupted."""
    results = tmp_path_factory.mktemp("engines")
    for engine in run_spec.ENGINES:
        proc = run_launcher(*TINY, "--engine", engine, results=results)
        assert proc.returncode == 0, proc.stdout + proc.stderr
    return results, {engine: load(run_spec.output_path(tiny_spec(engine), results)) for engine in run_spec.ENGINES}


def assert_holds_the_wall_stress(run):
    """The wall stress held at p: within 20 % rms over the samples (the tiny cell's LAMMPS runs: 9–12 %; a wall
    that lost its controller is off by order 1) and no sample beyond twice the alarm. A single sample may pass the
    alarm itself, which stops a run only over ``stress_alarm_strain`` in a row: the tiny cell is chaotic, and
    another order of the force sums (MPI ranks, the atoms' sorting) gives another trajectory."""
    error = run.raw["wall_stress_error_mean"]
    assert np.sqrt(np.mean(error ** 2)) < 0.2 and np.all(np.abs(error) < 2 * run.spec.stress_alarm), error


def test_both_engines_run_one_spec_into_files_the_pipeline_reads_alike(both_engines):
    """Same samples, same fields and units, each file naming its engine; the same grains (one cloud generator), and
    both hold the wall stress at p through the run."""
    _, runs = both_engines
    yade, lammps = runs["yade"], runs["lammps"]
    assert (yade.engine, lammps.engine) == ("yade", "lammps")
    assert lammps.provenance["engine"] == "lammps" and str(lammps.provenance["engine_version"]).isdigit()
    assert yade.units == lammps.units and set(yade.raw_all) == set(lammps.raw_all)
    for key in yade.raw_all:  # profiles: bins of about profile_bin_d across each run's own gap
        same = 1 if key.startswith("profile") else None
        assert yade.raw_all[key].shape[:same] == lammps.raw_all[key].shape[:same], key
    np.testing.assert_allclose(yade.raw_all["strain"], lammps.raw_all["strain"], atol=1e-3)
    np.testing.assert_array_equal(yade.grain_diameter, lammps.grain_diameter)
    for run in (yade, lammps):
        assert np.all(np.isfinite(run.raw["stress_contact"])) and np.all(np.isfinite(run.raw["fabric"]))
        assert_holds_the_wall_stress(run)
        assert 0.5 < np.mean(run.raw["packing_fraction"]) < 0.7
        # the Love-Weber pressure of the central region against the wall's p = 1 (a 4d cell: loose agreement)
        p = -np.trace(run.raw["stress_contact"], axis1=1, axis2=2) / 3
        assert 0.5 < np.median(p) < 1.5


def test_both_engines_track_their_contacts_into_a_budget_that_sums_to_the_change_of_the_fabric(both_engines):
    """The contact budget (dem/core/budget.py) of each engine: made + lost + kept + crossed is the change of the
    measured fabric from sample to sample, to rounding; contacts are made and lost; the persistence of each change's
    set starts at 1 and falls; the strong network is a minority; the near pairs (dem/core/neighbours.py) nest by
    gap and feed the contacts made."""
    _, runs = both_engines
    for run in runs.values():
        c = run.contacts
        assert c is not None and set(c) == set(contact_fields())
        total = sum(c[f"budget_{t}"] for t in ("made", "lost", "kept", "crossed"))
        assert np.all(np.isnan(total[0]))
        np.testing.assert_allclose(total[1:], np.diff(run.raw_all["fabric"], axis=0), atol=1e-13)
        assert c["made_count"][1:].sum() > 0 and c["lost_count"][1:].sum() > 0
        assert np.all(c["track_points"][1:] >= 1)
        assert 0 <= np.nanmin(c["persistence_touching"]) and np.nanmax(c["persistence_touching"]) == 1.0
        assert np.all(c["persistence_continuous"] <= c["persistence_touching"] + 1e-15)
        assert 0.2 < np.median(c["strong_fraction"]) < 0.5
        # the near pairs: the shells nest, and the contacts made come out of them
        assert np.all(np.diff(c["near_count"], axis=1) >= 0) and np.all(c["near_count"][:, 0] > 0)
        np.testing.assert_array_equal(c["near_by_load"].sum(axis=2), c["near_count"])
        np.testing.assert_array_equal(c["made_by_load"].sum(axis=1), c["made_count"])
        assert np.all(c["made_near"][:, -1] <= c["made_count"]) and c["made_near"][1:, -1].sum() > 0


def test_a_lammps_run_needs_no_yade(both_engines, tmp_path):
    """With Yade's Python modules hidden (a ``yade`` package that fails to import, first on the path) and no
    ``yade`` launcher on PATH, the tiny LAMMPS run builds the same grains (the numpy cloud) and gives the same file
    as with Yade present, bit for bit."""
    _, runs = both_engines
    hidden = tmp_path / "hidden"
    (hidden / "yade").mkdir(parents=True)
    (hidden / "yade" / "__init__.py").write_text("raise ImportError('Yade is hidden')\n")
    path = ":".join(p for p in os.environ["PATH"].split(":") if not (Path(p) / "yade").exists())
    env = {**os.environ, "PYTHONPATH": str(hidden), "PATH": path}
    proc = subprocess.run(launcher(*TINY, "--engine", "lammps", results=tmp_path / "results"), cwd=ROOT, env=env,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    alone = load(run_spec.output_path(tiny_spec("lammps"), tmp_path / "results"))
    np.testing.assert_array_equal(alone.grain_diameter, runs["lammps"].grain_diameter)
    for key, value in runs["lammps"].raw_all.items():
        np.testing.assert_array_equal(alone.raw_all[key], value, err_msg=key)


def test_an_interrupted_lammps_run_resumes_bit_identical_to_an_uninterrupted_one(both_engines, tmp_path):
    """SIGINT stops the scene at its next checkpoint (exit 130); the same command resumes it; every sample equals
    the uninterrupted run's, bit for bit (each run reads each of its checkpoints back in a new process). The
    results folder's name holds a space and a non-ASCII character, which LAMMPS's input parser would split or
    mangle."""
    _, runs = both_engines
    results = tmp_path / "a folder ü"
    status, rest = interrupt_at_first_sample(results)
    assert status == 130, rest
    assert "rerun the same command to resume" in rest
    run_dir = run_spec.work_dir(tiny_spec("lammps"), results)
    assert (run_dir / "checkpoint.json").exists() and list(run_dir.glob("restart_*.lmp"))
    assert (run_dir / "lammps.log").stat().st_size > 0
    again = run_launcher(*TINY, "--engine", "lammps", results=results)
    assert again.returncode == 0, again.stdout + again.stderr
    assert "resumed from checkpoint" in again.stdout
    resumed = load(run_spec.output_path(tiny_spec("lammps"), results))
    for key, value in runs["lammps"].raw_all.items():
        np.testing.assert_array_equal(resumed.raw_all[key], value, err_msg=key)
    for key, value in runs["lammps"].contacts.items():  # the contact tracker goes on from its checkpoint
        np.testing.assert_array_equal(resumed.contacts[key], value, err_msg=key)
    assert not list(run_dir.glob("restart_*")) and not (run_dir / "checkpoint.json").exists()


@pytest.fixture(scope="module")
def interrupted_lammps(tmp_path_factory):
    """A results folder holding the tiny LAMMPS run stopped at its first sample, made once: each case damages a
    copy."""
    results = tmp_path_factory.mktemp("interrupted")
    interrupt_at_first_sample(results)
    return results


@pytest.mark.parametrize("damage, fragment", [
    ("restart-truncated", "is missing or damaged"),
    ("record-junk", "checkpoint.json cannot be read"),
    ("state-null", "checkpoint.json cannot be read (ValueError: no state)"),
    ("restart-elsewhere", "is not a restart file of the run folder"),
    ("header-rehashed", "the scene failed loading its checkpoint (lammps: ERROR"),
    ("wall-sphere-rehashed", "does not hold the atoms it was written with"),
])
def test_a_damaged_lammps_checkpoint_is_a_one_line_error_that_suggests_fresh(interrupted_lammps, tmp_path, damage,
                                                                             fragment):
    """A checkpoint the scene did not write is refused in one line: a truncated restart file, a record that is no
    JSON, one without a state, one naming a file outside the run folder (which the next checkpoint would delete:
    that file is left as it was), and restart files damaged before their size and hash were taken (the record
    matches them): a header LAMMPS refuses, and a wall sphere 1 % larger, which LAMMPS reads without a word."""
    shutil.copytree(interrupted_lammps, tmp_path, dirs_exist_ok=True)
    run_dir = run_spec.work_dir(tiny_spec("lammps"), tmp_path)
    record = json.loads((run_dir / "checkpoint.json").read_text())
    victim = tmp_path / "victim.lmp"
    if damage == "restart-truncated":
        restart = next(run_dir.glob("restart_*.lmp"))
        restart.write_bytes(restart.read_bytes()[:1000])
    elif damage == "record-junk":
        (run_dir / "checkpoint.json").write_text("{junk")
    elif damage == "state-null":
        (run_dir / "checkpoint.json").write_text(json.dumps({**record, "state": None}))
    elif damage == "restart-elsewhere":
        victim.write_bytes((run_dir / record["restart"]).read_bytes())
        (run_dir / "checkpoint.json").write_text(json.dumps({**record, "restart": "../../victim.lmp"}))
    else:
        restart = run_dir / record["restart"]
        data = bytearray(restart.read_bytes())
        if damage == "header-rehashed":
            data[100:104] = b"\x7f" * 4
        else:
            at = data.index(struct.pack("<d", WALL_RADIUS))
            data[at:at + 8] = struct.pack("<d", 1.01 * WALL_RADIUS)
        restart.write_bytes(data)
        (run_dir / "checkpoint.json").write_text(json.dumps(
            {**record, "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}))
    again = run_launcher(*TINY, "--engine", "lammps", results=tmp_path)
    text = again.stdout + again.stderr
    errors = [line for line in text.splitlines() if "error:" in line]
    assert again.returncode == 2 and "Traceback" not in text
    assert len(errors) == 1 and fragment in errors[0] and "FRESH=1" in errors[0], text
    assert damage != "restart-elsewhere" or victim.exists()


def test_the_engines_benchmark_times_both_engines_on_one_preset(tmp_path):
    from pipeline.studies.bench_dem import main as bench_main

    assert bench_main(["--presets", "tiny", "--engines", "yade,lammps", "--repeats", "1", "--out", str(tmp_path)]) == 0
    (record,) = json.loads((tmp_path / "dem_engines.json").read_text())
    for engine in ("yade", "lammps"):
        sps = record[engine]["steps_per_second"]
        assert sps["bare"] > 0 and sps["full"] > 0, engine
    assert record["lammps"]["grains"] == record["yade"]["grains"]
    assert record["lammps"]["wall_spheres"] == record["yade"]["wall_spheres"]
    assert "| tiny | 54 + 48 |" in (tmp_path / "dem_engines.md").read_text()


def test_the_settings_benchmark_times_two_settings_from_a_runs_checkpoint_and_leaves_it_as_it_was(tmp_path):
    """Each round resumes a copy of the checkpoint once per setting (A then B, then B then A); the run folder
    stays as it was, and a command LAMMPS refuses is one line naming it."""
    from pipeline.studies.bench_lammps_settings import main as bench_main

    interrupt_at_first_sample(tmp_path)
    run_dir = run_spec.work_dir(tiny_spec("lammps"), tmp_path)
    before = {p.name: p.read_bytes() for p in run_dir.iterdir() if p.is_file()}
    out = tmp_path / "bench"
    a, b = "atom_modify sort 0 0.0", "atom_modify sort 1000 0.0; neighbor 0.2 bin"
    assert bench_main(["--run-dir", str(run_dir), "--a", a, "--b", b, "--steps", "100", "--rounds", "2",
                       "--out", str(out)]) == 0
    record = json.loads((out / "lammps_settings.json").read_text())
    assert record["a"] == [a] and record["b"] == ["atom_modify sort 1000 0.0", "neighbor 0.2 bin"]
    rates = np.array([record["a_steps_per_second"], record["b_steps_per_second"]])
    assert rates.shape == (2, 2) and np.all(rates > 0)
    np.testing.assert_allclose(record["ratios"], rates[1] / rates[0])
    assert "B / A: median" in (out / "lammps_settings.md").read_text()
    assert {p.name: p.read_bytes() for p in run_dir.iterdir() if p.is_file()} == before
    proc = subprocess.run([sys.executable, "-m", "pipeline.studies.bench_lammps_settings", "--run-dir", str(run_dir),
                           "--a", a, "--b", "atom_modify sort never", "--steps", "100", "--rounds", "1",
                           "--out", str(tmp_path / "refused")], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "atom_modify sort never" in proc.stderr and "Traceback" not in proc.stderr


def test_two_mpi_ranks_run_stop_at_a_checkpoint_and_resume(both_engines, tmp_path):
    """RANKS=2 under Debian's OpenMPI: SIGINT reaches the ranks as SIGUSR1 through mpirun (which would kill them on
    SIGINT), they stop together at the next checkpoint (exit 138) and the same command resumes the run to the end;
    its file has every sample (not bit-identical to one rank's: the sums run in another order)."""
    _, runs = both_engines
    args = (*TINY, "--engine", "lammps", "--ranks", "2")
    proc = subprocess.Popen(launcher(*args, results=tmp_path), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    for line in proc.stdout:
        if "strain" in line:
            listening = subprocess.run(["ss", "-ltnup"], capture_output=True, text=True).stdout
            proc.send_signal(signal.SIGINT)
            break
    # mpirun ran in a network namespace with only the loopback: none of its listeners is on this machine's
    assert launch.loopback_only() is not None and "mpirun" not in listening and "orted" not in listening, listening
    try:
        rest = proc.communicate(timeout=300)[0]
    except subprocess.TimeoutExpired:  # the ranks wait for each other: end them all, fail in minutes, not at CI's limit
        kill_naming(str(tmp_path))
        pytest.fail(f"the two ranks did not stop within 300 s of the signal: {proc.communicate()[0][-2000:]}")
    assert proc.returncode == 138, rest
    assert (run_spec.work_dir(tiny_spec("lammps"), tmp_path) / "checkpoint.json").exists()
    again = run_launcher(*args, results=tmp_path)
    assert again.returncode == 0, again.stdout + again.stderr
    two = load(run_spec.output_path(tiny_spec("lammps"), tmp_path))
    one = runs["lammps"]
    assert json.loads(two.provenance["sessions"])[-1]["ranks"] == 2
    assert all(s["git_commit"] for s in two.sessions)  # each session records the code that ran it
    assert two.cpu_seconds == pytest.approx(2 * two.parameters["loop_seconds"])  # both sessions on two cores
    assert one.cpu_seconds == pytest.approx(one.parameters["loop_seconds"])
    np.testing.assert_allclose(two.raw_all["strain"], one.raw_all["strain"], atol=1e-3)
    assert_holds_the_wall_stress(two)
    refused = run_launcher("--theta", "90", "--preset", "tiny", "--ranks", "2", results=tmp_path)
    assert refused.returncode == 2 and "MPI ranks are for ENGINE=lammps" in refused.stderr


#: the scene under mpirun with a fault at rank 0 alone, just after (warning) or in (quota) its first checkpoint,
#: the moment rank 1, which neither syncs nor hashes the restart file, may have decided already to run on, or in its
#: controller at the first sample (an exception the other rank does not share)
RANK_0_ALONE = """
import errno, os, signal, sys
from dem.core import driver
from dem.core.cell import WALL_RADIUS
from dem.lammps import scene as lammps_scene

mark = os.path.join(sys.argv[1], "faulted")
save, save_npz = lammps_scene.Scene.save, driver.save_npz


def first_time_at_rank_0():
    if lammps_scene.RANK == 0 and not os.path.exists(mark):
        open(mark, "w").close()
        return True
    return False


def save_then_warn(self, run):
    save(self, run)
    if first_time_at_rank_0():
        os.kill(os.getpid(), signal.SIGUSR1)


def over_quota(path, columns):
    if first_time_at_rank_0():
        raise OSError(errno.EDQUOT, os.strerror(errno.EDQUOT), path)
    save_npz(path, columns)


def sample_then_fault(self, *args):
    if first_time_at_rank_0():
        raise RuntimeError("a fault at rank 0 alone")
    sample(self, *args)


if sys.argv[2] == "warning":
    lammps_scene.Scene.save = save_then_warn
elif sys.argv[2] == "controller":
    sample = lammps_scene.Run.sample
    lammps_scene.Run.sample = sample_then_fault
else:
    driver.save_npz = over_quota
lammps_scene.main(sys.argv[1])
"""


def two_ranks(run_dir, *args):
    """The tiny run's scene in ``run_dir`` on two ranks (``mpirun``), as the launcher starts it; a hang fails."""
    command = ["mpirun", "-np", "2", "--allow-run-as-root", "--oversubscribe", scripts.engine_python(), *args]
    try:
        return subprocess.run(command, capture_output=True, text=True, cwd=run_dir, env=scripts.environment(),
                              timeout=180)
    except subprocess.TimeoutExpired as exc:
        raise AssertionError(f"the ranks never stopped:\n{exc.stdout}") from None


@pytest.mark.parametrize(("fault", "status", "message"), [
    ("warning", 138, "interrupted: checkpoint at iteration"),
    ("quota", 4, "Disk quota exceeded"),
    ("controller", 3, "error: RuntimeError: a fault at rank 0 alone (in the controller)"),
])
def test_a_fault_at_one_rank_during_a_checkpoint_ends_every_rank(tmp_path, fault, status, message):
    """A warning that reached rank 0 alone while it synced its restart file stops both ranks there (the ranks
    decide together), and a quota that rank 0 alone meets (it alone writes) or an error in its controller ends both
    with its exit status and its one error line, instead of one rank running on while the other waits for it for
    ever (the deadlock a SLURM warning met under load). The same folder then resumes to the end."""
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "spec.json").write_text(json.dumps(tiny_spec("lammps").to_dict()))
    stopped = two_ranks(run_dir, "-c", RANK_0_ALONE, run_dir, fault)
    text = stopped.stdout + stopped.stderr
    assert (run_dir / "faulted").exists() and stopped.returncode == status, text
    assert message in text and "Traceback" not in text
    resumed = two_ranks(run_dir, "-m", "dem.lammps.scene", run_dir)
    assert resumed.returncode == 0 and "done:" in resumed.stdout, resumed.stdout + resumed.stderr


#: the scene under mpirun with rank 1's clock running 20 times fast: the ranks' wall-clock decisions (when to print
#: the compaction's and the shear's progress) disagree, as between the nodes of a cluster or under load
CLOCKS_APART = """
import sys, time
from dem.lammps import scene as lammps_scene

if lammps_scene.RANK == 1:
    real, start = time.time, time.time()
    time.time = lambda: start + 20 * (real() - start)
lammps_scene.main(sys.argv[1])
"""


def test_ranks_whose_clocks_disagree_run_to_the_end(tmp_path):
    """Each rank decides from its own clock when to print; only the printing may follow that decision, never a call
    that every rank makes together (a wall's height is a reduction over the ranks), or the rank that prints waits in
    it for the other, which waits for it in the next step, for ever. With rank 1's clock 20 times fast both ranks
    run the tiny run to its end."""
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "spec.json").write_text(json.dumps(tiny_spec("lammps").to_dict()))
    done = two_ranks(run_dir, "-c", CLOCKS_APART, run_dir)
    assert done.returncode == 0 and "done:" in done.stdout, done.stdout + done.stderr


def descriptors_and_children(pid: int) -> tuple[Counter, list[str]]:
    """What process ``pid`` holds open (how many of each file, pipe or socket; not the checkpoint's own files,
    open for a moment, nor a descriptor closed between the listing and its reading), and the commands of its
    child processes."""
    held = Counter()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            held[os.readlink(fd).split("[")[0]] += 1
        except FileNotFoundError:
            continue
    held = Counter({k: n for k, n in held.items() if not Path(k).name.startswith(("restart_", "samples_"))})
    children = subprocess.run(["pgrep", "-a", "-P", str(pid)], capture_output=True, text=True).stdout.splitlines()
    return held, children


def while_lammps_runs(under: Path, signals: int, timeout: float = 20.0) -> tuple[Counter, list[str], dict]:
    """``descriptors_and_children`` of the scene running under ``under``, and whether each of its threads but the
    main one blocks every signal of the mask ``signals``, taken while LAMMPS is open (its log among the files) and
    MPI has started its threads: right after an ``exec`` at a checkpoint the new process has not yet started MPI, and
    it would hold fewer."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for pid in scene_pids(under):
            try:
                held, children = descriptors_and_children(pid)
                threads = [int(t.name) for t in Path(f"/proc/{pid}/task").iterdir() if int(t.name) != pid]
                blocking = {t: signal_mask(pid, t, "SigBlk") & signals == signals for t in threads}
            except FileNotFoundError:  # it ``exec``ed itself, or a thread ended, meanwhile
                continue
            if blocking and any(Path(name).name == "lammps.log" for name in held):
                return held, children, blocking
        time.sleep(0.01)
    raise AssertionError(f"no scene with LAMMPS open under {under} within {timeout} s")


def scene_pids(under: Path) -> list[int]:
    """The LAMMPS scene processes running in a folder under ``under``."""
    out = subprocess.run(["pgrep", "-f", "dem.lammps.scene"], capture_output=True, text=True).stdout
    pids = []
    for pid in map(int, out.split()):
        try:
            if Path(f"/proc/{pid}/cwd").resolve().is_relative_to(under):
                pids.append(pid)
        except FileNotFoundError:
            continue
    return pids


def signal_mask(pid: int, thread: int, field: str) -> int:
    """Thread ``thread``'s ``SigBlk`` mask (or another ``field``: bit k - 1 for signal k) of process ``pid``."""
    for line in Path(f"/proc/{pid}/task/{thread}/status").read_text().splitlines():
        if line.startswith(f"{field}:"):
            return int(line.split()[1], 16)
    raise AssertionError(f"no {field} line for thread {thread} of {pid}")


def test_a_one_rank_scene_holds_as_many_files_and_processes_at_its_end_as_at_its_start(tmp_path):
    """A one-rank scene ``exec``s itself at each of its checkpoints (the tiny run has about 37): it starts MPI as an
    isolated singleton, so no ``orted`` daemon is spawned (one more per checkpoint, about 20 MB each, before), and
    closes LAMMPS first, so its log file is not left open (one more descriptor per checkpoint).

    MPI's threads block the stop signals, in the first process and in those it ``exec``s. A warning (SIGUSR1) that
    came while the main thread blocks them before its ``exec`` went to such a thread: the process about to be
    replaced took it, said it would stop, and the new one ran on to the end."""
    stops = sum(1 << (int(s) - 1) for s in driver.STOP_SIGNALS)
    proc = subprocess.Popen(launcher(*TINY, "--engine", "lammps", results=tmp_path), cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    seen, lines = [], []
    for line in proc.stdout:
        lines.append(line)
        if "strain" in line and ("[  0%]" in line or "[ 80%]" in line):
            seen.append(while_lammps_runs(tmp_path, stops))
    assert proc.wait() == 0, "".join(lines)
    (first, none, first_threads), (last, still_none, last_threads) = seen
    assert none == [] and still_none == [], seen
    # a shared-memory file may come and go; the leak was about five per checkpoint
    assert sum(last.values()) <= sum(first.values()) + 2, seen
    assert all(first_threads.values()) and all(last_threads.values()), (first_threads, last_threads)


def catches(pid: int, signum: int) -> bool:
    """Whether process ``pid`` has a handler for ``signum``."""
    return bool(signal_mask(pid, pid, "SigCgt") >> (signum - 1) & 1)


def test_a_warning_at_any_moment_of_a_run_is_a_resumable_stop(tmp_path):
    """SIGUSR1 (a scheduler's warning) at times spread over the tiny run, from the moment the launcher's Python
    has its handler (before that, the interpreter is still starting) through its imports, the build, the
    compaction, the shear and the moments it ``exec``s itself at a checkpoint: every run stops resumably (exit
    138) or finishes, never fails; one that said where it would stop finishes only if it ended before there."""
    for k, delay in enumerate(np.arange(0.0, 7.5, 0.8)):  # the run takes about 10 s; a checkpoint each 0.3 s
        results = tmp_path / f"r{k}"
        proc = subprocess.Popen(launcher(*TINY, "--engine", "lammps", results=results), cwd=ROOT,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        end = time.time() + 60
        while not catches(proc.pid, signal.SIGUSR1) and proc.poll() is None and time.time() < end:
            time.sleep(0.005)
        try:
            proc.communicate(timeout=delay)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGUSR1)
        out = proc.communicate(timeout=120)[0] or ""
        assert proc.returncode in (0, 138) and "Traceback" not in out, f"warned {delay:.2f} s in:\n{out}"
        said = re.search(r"stopping at the next checkpoint \(iteration (\d+)\)", out)
        if said and proc.returncode == 0:
            steps = int(re.search(r"done: \d+ samples, (\d+) steps", out)[1])
            assert steps <= int(said[1]), f"warned {delay:.2f} s in, it ran on past iteration {said[1]}:\n{out}"
