"""The targets `make help` names, run through `make` end to end at the smallest scale that exercises them, in a copy
of the project (results of this checkout are never touched). Which test runs which target is ``RUN_HERE``;
``RUN_BY_CI`` are the ones CI's `make test` is made of; ``NOT_RUN`` the ones still too long for CI, each with the
reason. A new target fails the first test until it is placed in one of them."""

import os
import re
import shutil
import signal
import subprocess
from pathlib import Path

import pytest

from pipeline.paths import ROOT

pytestmark = [pytest.mark.yade, pytest.mark.lammps]

RUN_HERE = {
    "help": "test_every_target_is_run_here_or_by_ci",
    **dict.fromkeys(("dem", "engines", "bench-lammps-settings", "profile-dem", "bench-dem", "stability",
                     "model-cycles", "sweep", "runs", "sweep-status"),
                    "test_the_dem_and_engine_targets_run_at_the_tiny_size"),
    **dict.fromkeys(("fit", "compare", "figures", "compare-seed", "fit-bootstrap", "fit-jackknife", "fit-angles",
                     "fit-definitions", "versus", "cells", "jump", "fidelity-table", "data-card", "clean"),
                    "test_the_data_targets_run_on_the_committed_data"),
}
RUN_BY_CI = ("test", "test-unit", "test-yade", "test-cluster", "lint", "venv", "system", "system-venv",
             "system-lammps", "system-slurm")
#: each with why CI does not run it through `make` (the tiny cell is too noisy for the stepwise route, so a data
#: set of its runs cannot be fitted, and the committed ones take minutes in these)
NOT_RUN = {
    "demo": "two quick-preset DEM runs (about 5 min on two cores), then fit, compare and figures, run here",
    "demo-dem": "two quick-preset DEM runs (about 5 min); its launcher is run here by `dem`",
    "bench": "minutes of timing by design; bench-dem is run here at the tiny size",
    "sweep-collect": "fit, compare and figures of a sweep's data set: a tiny sweep cannot be fitted",
    "fit-from": "2-5 min on the committed paper cell (its functions: tests/unit/test_calibration.py)",
    "fit-profile": "3-4 min on the committed paper cell (tests/unit/test_calibration.py)",
    "models": "about 3 min on the committed paper cell (tests/unit/test_models.py)",
    "fidelity": "makes the ladder's missing DEM runs first (on a fresh clone `reduced` θ = 90 seeds 4 and 5, about "
                "35 min each); fidelity-table, its table without them, is run here",
}


def project_copy(folder: Path) -> Path:
    """The checkout's files (tracked and new, not ignored) copied into ``folder``; run files hard-linked (never written
    in place: every writer renames a new file onto its name), and a virtualenv of links to the checkout's."""
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
    return folder


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    return project_copy(tmp_path_factory.mktemp("project"))


def make(project: Path, *args: str, timeout: float = 900) -> str:
    """``make ARGS`` in the copy; its output, after checking it succeeded."""
    proc = subprocess.run(["make", "--no-print-directory", *args], cwd=project, capture_output=True, text=True,
                          timeout=timeout)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"make {' '.join(args)}: exit {proc.returncode}\n{text[-3000:]}"
    assert "Traceback" not in text, text[-3000:]
    return text


def test_every_target_is_run_here_or_by_ci(project):
    listed = re.findall(r"^  make (\S+)", make(project, "help"), flags=re.MULTILINE)
    assert len(listed) == len(set(listed)) > 40
    assert sorted(listed) == sorted([*RUN_HERE, *RUN_BY_CI, *NOT_RUN])


def test_the_dem_and_engine_targets_run_at_the_tiny_size(project):
    make(project, "dem", "THETA=180", "PRESET=tiny")
    make(project, "dem", "THETA=180", "PRESET=tiny", "ENGINE=lammps")
    assert (project / "results/tiny/dem/theta180.h5").exists()
    assert (project / "results/tiny-lammps/dem/theta180.h5").exists()
    make(project, "engines", "PRESET=tiny")
    assert "tiny (lammps)" in (project / "results/engines/engines.md").read_text()
    # a LAMMPS run stopped at its first checkpoint: the folder the settings benchmark resumes from
    proc = subprocess.Popen(["make", "--no-print-directory", "dem", "THETA=90", "PRESET=tiny", "ENGINE=lammps",
                             "SET=seed=9"], cwd=project, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    for line in proc.stdout:
        if "strain" in line:
            os.killpg(proc.pid, signal.SIGINT)
            break
    proc.communicate(timeout=120)
    run_dir = next((project / "results").glob("tiny-lammps-*/dem/theta090.run"))
    make(project, "bench-lammps-settings", f"RUN_DIR={run_dir.relative_to(project)}")
    assert (project / "results/bench").is_dir() and any((project / "results/bench").iterdir())
    make(project, "profile-dem", "PRESETS=tiny")
    assert (project / "results/bench/dem_profile.md").exists()
    make(project, "bench-dem", "PRESETS=tiny", "ENGINES=yade,lammps")
    make(project, "stability", "CASES=baseline")
    assert "baseline" in (project / "results/fidelity/stability.md").read_text()
    make(project, "model-cycles")
    assert len(list((project / "results/model").glob("theta*.csv"))) == 6
    make(project, "sweep", "PRESET=tiny", "THETAS=30 60", "JOBS=2")
    assert (project / "results/tiny/dem/theta030.h5").exists() and (project / "results/tiny/dem/theta060.h5").exists()
    assert "tiny/theta060" in make(project, "runs")
    assert "done" in make(project, "sweep-status")


def test_the_data_targets_run_on_the_committed_data(project):
    paper = ("PRESET=paper",)
    assert "runs: paper (lammps, inertial_number=0.001, cycles from 2 on)" in make(project, "fit", *paper,
                                                                                   "SKIP_CYCLES=1")
    make(project, "figures", *paper, "SKIP_CYCLES=1")  # compare first, by the file rules
    folder = project / "results/paper-lammps-e29c082a"
    assert "## Drift over the cycles" in (folder / "report.md").read_text()
    make(project, "compare-seed", *paper, "SEED=2")
    assert (folder / "compare-seed2/metrics.json").exists()
    for target, extra in (("fit-bootstrap", "BOOT=2"), ("fit-jackknife", "OVER=angles"),
                          ("fit-angles", "ANGLES=180 90"), ("fit-definitions", None)):
        make(project, target, *paper, *([extra] if extra else []))
    assert (folder / "fit/definitions.md").exists() and (folder / "fit-angles-180-90/params.json").exists()
    make(project, "versus", "A=paper/lammps/n_cycles=1", "B=paper/lammps/inertial_number=0.001")
    assert "### θ = 180, cycle 1" in (project / "results/versus/versus.md").read_text()
    make(project, "cells")
    make(project, "jump")
    assert (project / "results/cells/cells.md").exists() and (project / "results/jump/jump.md").exists()
    assert "run(s) of the ladder" in make(project, "fidelity-table")
    make(project, "data-card")
    assert (project / "data/reference/README.md").read_text() == (ROOT / "data/reference/README.md").read_text()
    make(project, "clean")
    assert not (folder / "fit").exists() and not (project / "results/cells").exists()
