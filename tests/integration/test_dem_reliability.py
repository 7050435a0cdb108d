"""The real Yade under stress: runs on a loaded machine lose no sample, no port is opened, a live run
cannot be removed by --fresh, a damaged run folder is a one-line error, a killed scene is reported."""

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from pipeline import spec as run_spec
from pipeline.dataset.dem_file import load
from pipeline.paths import ROOT
from tests.helpers.sockets import listening_inodes, socket_inodes

pytestmark = pytest.mark.yade

RACE_ARGS = ("--theta", "180", "--preset", "tiny", "--set", "seed=7")


def launcher(*args, results):
    return [sys.executable, "-m", "pipeline.runs", "run", *args, "--results", str(results)]


def start(*args, results):
    return subprocess.Popen(launcher(*args, results=results), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)


def output_of(results, *args):
    return run_spec.output_path(run_spec.resolve(*_theta_preset(args)), results)


def _theta_preset(args):
    a = dict(zip(args[::2], args[1::2], strict=True))
    overrides = run_spec.parse_overrides([a["--set"]]) if "--set" in a else None
    return a["--theta"], a["--preset"], None, overrides


def test_runs_on_a_loaded_machine_lose_no_sample_and_match_an_undisturbed_run(tmp_path):
    """Checkpoints land while other processes compete for the cores (where a PyRunner that paused Yade
    used to lose the sample at the checkpoint): every run complete and bit-identical to an undisturbed one."""
    reference = subprocess.run(launcher(*RACE_ARGS, results=tmp_path / "alone"), cwd=ROOT, capture_output=True,
                               text=True)
    assert reference.returncode == 0, reference.stdout + reference.stderr
    ref = load(output_of(tmp_path / "alone", *RACE_ARGS))
    spec = ref.spec
    expected = int(round((spec.pre_strain + spec.n_cycles * spec.period_strain) / spec.sample_strain)) + 1
    assert len(ref.raw["strain"]) == expected
    load_procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        runs = [start(*RACE_ARGS, results=tmp_path / f"busy{k}") for k in range(6)]
        outputs = [proc.communicate()[0] for proc in runs]
    finally:
        for proc in load_procs:
            proc.kill()
    for k, (proc, out) in enumerate(zip(runs, outputs, strict=True)):
        assert proc.returncode == 0, out
        again = load(output_of(tmp_path / f"busy{k}", *RACE_ARGS))
        assert len(again.raw["strain"]) == expected
        for key, value in ref.raw.items():
            np.testing.assert_array_equal(again.raw[key], value, err_msg=f"run {k}: {key}")


def stop(proc) -> None:
    """Interrupt a running launcher once what is tested of it is seen, and wait for it (it stops at its next
    checkpoint: exit 130, or 138 for ranks under mpirun)."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    proc.communicate()


def children(pid):
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(entry.name))
    return out


@pytest.mark.parametrize("engine", ["yade", "lammps"])
def test_a_running_scene_listens_on_no_port(tmp_path, engine):
    """Neither engine's scene (one thread, one rank) opens a listening socket: not Yade's remote consoles, not Open
    MPI's TCP transport of a one-rank LAMMPS run."""
    proc = start("--theta", "90", "--preset", "tiny", "--engine", engine, results=tmp_path)
    try:
        for line in proc.stdout:
            if "strain" in line:
                break
        scenes = children(proc.pid)
        assert scenes, "the scene process was not found"
        listening = listening_inodes()
        for pid in scenes:
            assert not socket_inodes(pid) & set(listening), "the scene listens on a port"
        assert not {9000, 21000} & set(listening.values()), "Yade's remote consoles are listening"
    finally:
        stop(proc)
    assert proc.returncode == 130  # stopped at its next checkpoint: resumable
    assert "auth cookie" not in (next(tmp_path.rglob("log.txt"))).read_text()


def test_a_niced_launchers_scene_runs_at_its_niceness_in_its_own_scheduler_group_too(tmp_path):
    """``nice make dem`` nices the scene: the niceness passes to it, and so to the scheduler group (Linux's autogroup)
    of the session it starts, which would else compete at full weight with every other session's work."""
    proc = subprocess.Popen(["nice", "-n", "7", *launcher(*RACE_ARGS, results=tmp_path)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        for line in proc.stdout:
            if "strain" in line:
                break
        (scene,) = children(proc.pid)
        assert os.getpriority(os.PRIO_PROCESS, scene) == 7
        group = Path(f"/proc/{scene}/autogroup")
        if group.exists():
            assert group.read_text().split()[-1] == "7", group.read_text()
    finally:
        stop(proc)
    assert proc.returncode == 130  # stopped at its next checkpoint: resumable


def test_two_local_lammps_ranks_listen_on_no_port(tmp_path):
    """At two ranks on this machine the ranks talk through shared memory: neither opens a listening socket (Open
    MPI's TCP transport would listen on every interface). ``mpirun`` itself keeps its runtime's listener
    (Open MPI 4.1 binds it to every interface whatever ``oob_tcp_if_include`` says; docs/sweeps.md)."""
    proc = start("--theta", "90", "--preset", "tiny", "--engine", "lammps", "--ranks", "2", results=tmp_path)
    try:
        for line in proc.stdout:
            if "strain" in line:
                break
        launchers = children(proc.pid)
        ranks = [pid for mpirun in launchers for pid in children(mpirun)]
        assert len(ranks) == 2, (launchers, ranks)
        listening = set(listening_inodes())
        for pid in ranks:
            assert not socket_inodes(pid) & listening, "a rank listens on a port"
    finally:
        stop(proc)
    assert proc.returncode == 138  # the ranks stopped together at their next checkpoint (SIGUSR1 through mpirun)


def test_fresh_on_a_live_run_is_refused_and_the_live_run_completes(tmp_path):
    proc = start("--theta", "90", "--preset", "tiny", results=tmp_path)
    for line in proc.stdout:
        if "strain" in line:
            break
    fresh = subprocess.run(launcher("--theta", "90", "--preset", "tiny", "--fresh", results=tmp_path), cwd=ROOT,
                           capture_output=True, text=True)
    assert fresh.returncode == 2 and "is in use by another run of the same spec" in fresh.stderr
    proc.communicate()
    assert proc.returncode == 0 and output_of(tmp_path, "--theta", "90", "--preset", "tiny").exists()


def interrupted_at_first_checkpoint(*args, results) -> str:
    """Run the tiny theta = 90 run (with ``args``), interrupt it at its first progress line and return what it
    printed; it stops at its first checkpoint (exit 130)."""
    proc = start("--theta", "90", "--preset", "tiny", *args, results=results)
    said = []
    for line in proc.stdout:
        said.append(line)
        if "strain" in line:
            proc.send_signal(signal.SIGINT)
            break
    said.append(proc.communicate()[0])
    assert proc.returncode == 130, "".join(said)
    return "".join(said)


def interrupted_run_dir(results):
    """A tiny run stopped at its first checkpoint: the folder a later command resumes."""
    interrupted_at_first_checkpoint(results=results)
    return run_spec.work_dir(run_spec.resolve(90, "tiny"), results)


@pytest.fixture(scope="module")
def interrupted_results(tmp_path_factory):
    """A results folder holding ``interrupted_run_dir``, made once: each case damages a copy."""
    results = tmp_path_factory.mktemp("interrupted")
    interrupted_run_dir(results)
    return results


@pytest.mark.parametrize("damage, fragment", [
    ("checkpoint-random", "checkpoint"),
    ("checkpoint-truncated", "checkpoint"),
    ("samples-junk", "samples of the checkpoint cannot be read"),
    ("spec-not-json", "spec.json is damaged (not JSON)"),
])
def test_a_damaged_run_folder_is_a_one_line_error_that_suggests_fresh(interrupted_results, tmp_path, damage,
                                                                        fragment):
    shutil.copytree(interrupted_results, tmp_path, dirs_exist_ok=True)
    run_dir = run_spec.work_dir(run_spec.resolve(90, "tiny"), tmp_path)
    if damage == "checkpoint-random":
        (run_dir / "checkpoint.yade.gz").write_bytes(os.urandom(4096))
    elif damage == "checkpoint-truncated":
        data = (run_dir / "checkpoint.yade.gz").read_bytes()
        (run_dir / "checkpoint.yade.gz").write_bytes(data[: len(data) // 2])
    elif damage == "samples-junk":
        next(run_dir.glob("samples_*.npz")).write_bytes(b"junk" * 100)
    else:
        (run_dir / "spec.json").write_text("{not json")
    proc = subprocess.run(launcher("--theta", "90", "--preset", "tiny", results=tmp_path), cwd=ROOT,
                          capture_output=True, text=True)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 2 and "Traceback" not in text
    errors = [line for line in text.splitlines() if "error:" in line]
    assert len(errors) == 1 and fragment in errors[0] and "FRESH=1" in errors[0], text
    said = interrupted_at_first_checkpoint("--fresh", results=tmp_path)  # starts over: its first checkpoint shows it
    assert "resumed" not in said, said


def test_a_scene_killed_by_a_signal_is_reported_and_resumes(tmp_path):
    proc = start("--theta", "90", "--preset", "tiny", results=tmp_path)
    for line in proc.stdout:
        if "strain" in line:
            for pid in children(proc.pid):
                os.kill(pid, signal.SIGKILL)
            break
    rest = proc.communicate()[0]
    assert proc.returncode == 137
    assert "error: the scene was killed by signal 9 (SIGKILL); rerun the same command to resume" in rest
    log = (run_spec.work_dir(run_spec.resolve(90, "tiny"), tmp_path) / "log.txt").read_text()
    assert "strain" in log  # line-buffered: what the scene printed before the kill is in the log
    again = subprocess.run(launcher("--theta", "90", "--preset", "tiny", results=tmp_path), cwd=ROOT,
                           capture_output=True, text=True)
    assert again.returncode == 0, again.stdout + again.stderr


def test_a_killed_launcher_leaves_no_second_scene_and_the_run_resumes(tmp_path):
    """kill -9 of the launcher (an OOM kill): its scene still holds the run's lock, so a rerun is refused
    instead of starting a second scene in the same folder; the scene stops at its next checkpoint (the
    parent-death signal), and the rerun then resumes the run to the end. The scene is held stopped
    (SIGSTOP) around the kill so that it cannot finish first."""
    from pipeline.runs.state import is_locked

    args = ("--theta", "180", "--preset", "tiny", "--set", "seed=4")
    run_dir = run_spec.work_dir(run_spec.resolve(*_theta_preset(args)), tmp_path)
    proc = start(*args, results=tmp_path)
    for line in proc.stdout:
        if "strain" in line:
            scenes = children(proc.pid)
            for pid in scenes:
                os.kill(pid, signal.SIGSTOP)
            proc.kill()
            break
    proc.communicate()
    assert scenes, "the scene had not started"
    assert is_locked(run_dir)
    rerun = subprocess.run(launcher(*args, results=tmp_path), cwd=ROOT, capture_output=True, text=True)
    assert rerun.returncode == 2 and "Traceback" not in rerun.stderr
    assert "is in use by another run of the same spec (or by its scene, still stopping" in rerun.stderr
    for pid in scenes:
        os.kill(pid, signal.SIGCONT)
    for pid in scenes:  # the orphaned scene stops by itself, at its next checkpoint
        for _ in range(600):
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.1)
        else:
            raise AssertionError(f"the orphaned scene {pid} did not stop")
    assert not is_locked(run_dir)
    again = subprocess.run(launcher(*args, results=tmp_path), cwd=ROOT, capture_output=True, text=True)
    assert again.returncode == 0, again.stdout + again.stderr
    assert load(output_of(tmp_path, *args)).spec.seed == 4


@pytest.mark.parametrize("odd", ["lock-link", "lock-folder", "run-link"])
def test_an_odd_lock_or_run_folder_is_one_line_and_no_link_is_followed(tmp_path, odd):
    args = ("--theta", "90", "--preset", "tiny")
    run_dir = run_spec.work_dir(run_spec.resolve(90, "tiny"), tmp_path)
    run_dir.parent.mkdir(parents=True)
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    if odd == "lock-link":
        run_dir.with_suffix(".lock").symlink_to(victim)
    elif odd == "lock-folder":
        run_dir.with_suffix(".lock").mkdir()
    else:
        run_dir.symlink_to(tmp_path)
    proc = subprocess.run(launcher(*args, results=tmp_path), cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "move it away, then rerun" in proc.stderr
    assert victim.read_text() == "keep me"


@pytest.fixture
def disk(tmp_path):
    """A 64 MiB tmpfs of its own (root, as the SLURM tests are), to fill."""
    folder = tmp_path / "disk"
    folder.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64m", "tmpfs", str(folder)], check=True)
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


def test_a_full_disk_stops_the_run_with_one_line_and_the_run_resumes_when_space_returns(disk):
    """The disk fills during the run (a file takes all but 64 KiB once shearing starts): the scene stops at
    the checkpoint it cannot hold, exit status 4 and one line; the last checkpoint is a whole gzip stream,
    no temporary is left, the run is not marked failed; with the space back the same command resumes it."""
    from dem.core.rawfile import complete_gzip, free_bytes

    args = ("--theta", "180", "--preset", "tiny", "--set", "seed=6")
    run_dir = run_spec.work_dir(run_spec.resolve(*_theta_preset(args)), disk)
    proc = start(*args, results=disk)
    lines = []
    for line in proc.stdout:
        lines.append(line)
        if "strain" in line:
            with open(disk / "filler", "wb") as fh:
                os.posix_fallocate(fh.fileno(), 0, free_bytes(disk) - 64 * 1024)
            break
    text = "".join(lines) + proc.communicate()[0]
    assert proc.returncode == 4, text
    assert "Traceback" not in text
    errors = [line for line in text.splitlines() if "error:" in line]
    assert len(errors) == 1 and "free space, then rerun the same command to resume" in errors[0], text
    checkpoint = run_dir / "checkpoint.yade.gz"
    assert checkpoint.exists() and complete_gzip(checkpoint)
    assert not list(run_dir.glob("*.tmp*")) and not (run_dir / "failed.json").exists()
    (disk / "filler").unlink()
    again = subprocess.run(launcher(*args, results=disk), cwd=ROOT, capture_output=True, text=True)
    assert again.returncode == 0, again.stdout + again.stderr
    assert "resumed from checkpoint" in again.stdout
    assert load(output_of(disk, *args)).spec.seed == 6
