"""A copy of the project to run `make` in (results of this checkout are never touched), and a lane of `make`
commands that runs in such a copy beside the rest of the session."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from model import kernel_cache
from pipeline.paths import ROOT

#: the lane's process, run as a script (the package's helpers, which import the model, are not its)
LANE_SCRIPT = Path(__file__).with_name("lane.py")
#: the lane's test: the lane is started only when it is among the session's tests
LANE_TEST = "test_the_long_targets_run_in_a_lane_beside_the_session"
#: the demo's runs in the tests: the `quick` cell at five times its inertial number, its contacts tracked every 0.005
#: (a run in about two minutes of CPU, against six and a half: the same code, the flow less quasi-static than in a
#: user's demo, where the fit still runs)
DEMO_SET = "SET=inertial_number=0.005 contact_track_strain=0.005"
#: run in this order in one copy: the demo (its two DEM runs, fit, compare, figures), then on its data set a sweep of
#: the same runs (done: nothing runs) and its collection, the fit past the jump, a three-point profile of C and b2,
#: Eq. 13's law and `jump` judged within the data set (fits of seconds: `elastic`'s fast state takes minutes on these
#: runs), every benchmark at the smallest size and the studies of the committed data no other target reads
LANE = [("demo", DEMO_SET), ("sweep", "PRESET=quick", DEMO_SET, "THETAS=180 90"), ("sweep-collect",),
        ("fit-from", "PRESET=quick", DEMO_SET), ("fit-profile", "PRESET=quick", DEMO_SET, "POINTS=3", "NAMES=C,b2"),
        ("models", "PRESET=quick", DEMO_SET, "ACROSS=none", "LAWS=jump"),
        ("bench", "PRESETS=tiny", "POINTS=2000"),
        ("versus", "A=paper/lammps/n_cycles=1", "B=paper/lammps/inertial_number=0.001"), ("cells",), ("jump",),
        ("budget", "PRESET=reduced"), ("model-cycles",)]


def project_copy(folder: Path) -> Path:
    """The checkout's files (tracked and new, not ignored) copied into ``folder``; run files hard-linked (never written
    in place: every writer renames a new file onto its name), a virtualenv of links to the checkout's, and the
    checkout's folder of compiled kernels for these sources linked (``model.kernel_cache``: the copy's kernels compile
    once for the session, not once per copy)."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                            capture_output=True, check=True).stdout.decode().split("\0")
    for name in filter(None, listed):
        source, target = ROOT / name, folder / name
        if not source.is_file():
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        if source.suffix in (".h5", ".npz", ".lmp"):
            os.link(source, target)
        else:
            shutil.copy2(source, target)
    venv = folder / ".venv"
    venv.mkdir()
    for entry in (ROOT / ".venv").iterdir():
        if entry.name != ".installed":
            (venv / entry.name).symlink_to(entry.resolve())
    (venv / ".installed").touch()  # newer than the copied pyproject.toml: Make builds no virtualenv here
    kernels = Path(kernel_cache.folder())
    kernels.mkdir(parents=True, exist_ok=True)
    (folder / "model/__pycache__").mkdir()
    (folder / "model/__pycache__" / kernels.name).symlink_to(kernels)
    return folder


def make(project: Path, *args: str, timeout: float = 900) -> str:
    """``make ARGS`` in the copy; its output, after checking it succeeded."""
    proc = subprocess.run(["make", "--no-print-directory", *args], cwd=project, capture_output=True, text=True,
                          timeout=timeout)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"make {' '.join(args)}: exit {proc.returncode}\n{text[-3000:]}"
    assert "Traceback" not in text, text[-3000:]
    return text


@dataclass
class Done:
    """One command of a lane: its arguments, exit status, output and wall time (s)."""

    args: tuple[str, ...]
    status: int
    output: str
    seconds: float


class Lane:
    """``make`` commands run one after the other in a copy of the project by a process of their own
    (``tests/helpers/lane.py``), from the moment it is started: work too long to wait for in turn (a target's DEM
    runs) overlaps the rest of the session, at the priority of the session's workers (at nice 19 the two workers
    starved it, and its last minutes ran alone on one core: ``docs/results/test-suite.md``). The first failing
    command ends the lane. Its folder holds the copy (``project``), a record per command done and a mark when it
    ends; the process ends its command and itself when the session's process (``owner``) is gone. ``start`` makes it
    once for every worker of a session (``tests/conftest.py``): the first caller starts it, the others find it."""

    def __init__(self, folder: Path):
        self.folder, self.project = folder, folder / "project"

    @classmethod
    def start(cls, folder: Path, commands: list[tuple[str, ...]], owner: int) -> Lane:
        folder.mkdir(parents=True, exist_ok=True)
        try:
            os.close(os.open(folder / "started", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return cls(folder)
        project_copy(folder / "project")
        (folder / "commands.json").write_text(json.dumps(commands))
        subprocess.Popen([sys.executable, str(LANE_SCRIPT), str(folder), str(owner)], cwd=ROOT,
                         stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
        return cls(folder)

    def wait(self, timeout: float) -> list[Done]:
        """Every command's record once the lane has ended (an AssertionError after ``timeout`` s)."""
        end = time.monotonic() + timeout
        while not (self.folder / "ended").exists():
            assert time.monotonic() < end, f"the lane has not ended in {timeout:.0f} s: done {self.done()}"
            time.sleep(1)
        return self.done()

    def done(self) -> list[Done]:
        records = self.folder / "done.jsonl"
        lines = records.read_text().splitlines() if records.exists() else []
        return [Done(tuple(r["args"]), r["status"], r["output"], r["seconds"]) for r in map(json.loads, lines)]
