"""The targets `make help` names, run through `make` end to end at the smallest scale that exercises them, in a copy
of the project (results of this checkout are never touched). Which test runs which target is ``RUN_HERE``: the long
ones (the demo and what follows it on its data set) run in a lane started with the session (``tests/conftest.py``),
whose test runs last; ``RUN_BY_CI`` are the ones CI's `make test` is made of. A new target fails the first test until
it is placed."""

import os
import re
import signal
import subprocess

import pytest

from pipeline.paths import ROOT
from tests.helpers.project import LANE, LANE_TEST, make, project_copy

pytestmark = [pytest.mark.yade, pytest.mark.lammps]

RUN_HERE = {
    "help": "test_every_target_is_run_here_or_by_ci",
    **dict.fromkeys(("dem", "engines", "bench-lammps-settings", "bench-dem", "sweep", "runs", "sweep-status",
                     "fidelity"),
                    "test_the_dem_and_engine_targets_run_at_the_tiny_size"),
    **dict.fromkeys(("fit", "compare", "figures", "compare-seed", "fit-bootstrap", "fit-jackknife", "fit-angles",
                     "fit-definitions", "fidelity-table", "data-card", "clean"),
                    "test_the_data_targets_run_on_the_committed_data"),
    # the demo (its DEM runs, demo-dem, first), what follows it on its data set, and the studies of committed data
    **dict.fromkeys(("demo", "demo-dem", "sweep-collect", "fit-from", "fit-profile", "models", "bench", "versus",
                     "cells", "jump", "budget", "profile-dem", "stability", "model-cycles"), LANE_TEST),
}
assert {args[0] for args in LANE} <= set(RUN_HERE)
RUN_BY_CI = ("test", "test-unit", "test-yade", "test-cluster", "lint", "venv", "system", "system-venv",
             "system-lammps", "system-slurm")
#: a ladder of two tiny runs (seconds each), for `make fidelity LADDER=...`
TINY_LADDER = """preset = "tiny"
thetas = [180.0]

[axes.dt_safety]
what = "time step as a fraction of the critical one"
values = [{ dt_safety = 0.2 }, { dt_safety = 0.3 }]
"""


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    return project_copy(tmp_path_factory.mktemp("project"))


def test_every_target_is_run_here_or_by_ci(project):
    listed = re.findall(r"^  make (\S+)", make(project, "help"), flags=re.MULTILINE)
    assert len(listed) == len(set(listed)) > 40
    assert sorted(listed) == sorted([*RUN_HERE, *RUN_BY_CI])


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
    make(project, "bench-dem", "PRESETS=tiny", "ENGINES=yade,lammps")
    make(project, "sweep", "PRESET=tiny", "THETAS=30 60", "JOBS=2")
    assert (project / "results/tiny/dem/theta030.h5").exists() and (project / "results/tiny/dem/theta060.h5").exists()
    assert "tiny/theta060" in make(project, "runs")
    assert "done" in make(project, "sweep-status")
    (project / "ladder.toml").write_text(TINY_LADDER)
    said = make(project, "fidelity", "LADDER=ladder.toml", "JOBS=2")
    # dt_safety 0.2 is the preset's own: its run, made above, is found; the other is made
    assert "running 1 ladder run(s)" in said and "2 run(s) of the ladder; 0 not made yet" in said
    assert "moved from the `tiny` preset" in (project / "results/fidelity-ladder/table.md").read_text()


def test_the_data_targets_run_on_the_committed_data(project):
    paper = ("PRESET=paper",)
    assert "runs: paper (lammps, inertial_number=0.001, cycles from 2 on)" in make(project, "fit", *paper,
                                                                                   "SKIP_CYCLES=1")
    make(project, "figures", *paper, "SKIP_CYCLES=1")  # compare first, by the file rules
    folder = project / "results/paper-lammps-e29c082a"
    # a fit with other options than the defaults: its fit, comparison and report in folders of their own
    assert "## Drift over the cycles" in (folder / "compare-skip1/report.md").read_text()
    assert (folder / "fit-skip1/params.json").exists() and not (folder / "fit").exists()
    make(project, "compare-seed", *paper, "SEED=2")
    assert (folder / "compare-seed2/metrics.json").exists()
    for target, extra in (("fit-bootstrap", "BOOT=2"), ("fit-jackknife", "OVER=angles"),
                          ("fit-angles", "ANGLES=180 90"), ("fit-definitions", None)):
        make(project, target, *paper, *([extra] if extra else []))
    assert (folder / "fit/definitions.md").exists() and (folder / "fit-angles-180-90/params.json").exists()
    make(project, "fit-angles", *paper, "ANGLES=180 90", "VARIANT=jump")  # another law beside Eq. 13's
    assert '"variant": "jump"' in (folder / "fit-angles-180-90-jump/params.json").read_text()
    assert '"variant"' not in (folder / "fit-angles-180-90/params.json").read_text()
    assert "run(s) of the ladder" in make(project, "fidelity-table")
    make(project, "data-card")
    assert (project / "data/reference/README.md").read_text() == (ROOT / "data/reference/README.md").read_text()
    make(project, "clean")
    assert not (folder / "fit").exists() and not (folder / "compare-seed2").exists()


@pytest.mark.last
def test_the_long_targets_run_in_a_lane_beside_the_session(long_lane):
    """The lane's commands (``LANE``) each succeed without a traceback, and leave what they promise."""
    done = long_lane.wait(timeout=1800)
    for d in done:
        assert d.status == 0 and "Traceback" not in d.output, f"make {' '.join(d.args)}: exit {d.status}\n" \
                                                               f"{d.output[-3000:]}"
    assert [d.args for d in done] == LANE
    said = {d.args[0]: d.output for d in done}
    folder = long_lane.project / "results/quick"
    assert "demo done" in said["demo"] and (folder / "report.md").exists() and (folder / "fit/params.json").exists()
    assert len(list((long_lane.project / "results/model").glob("theta*.csv"))) == 6
    assert "(2 done)" in said["sweep"] and "make figures PRESET=quick" in said["sweep-collect"]
    assert (folder / "fit/fit_from.md").exists() and (folder / "fit/profiles.json").exists()
    assert "| held out |" in (folder / "models/models.md").read_text() and (folder / "models/models.png").exists()
    bench = long_lane.project / "results/bench"
    assert all((bench / name).exists() for name in ("update.md", "dem_throughput.md"))
    results = long_lane.project / "results"
    assert (bench / "dem_profile.md").exists() and "baseline" in (results / "fidelity/stability.md").read_text()
    assert "### θ = 180, cycle 1" in (results / "versus/versus.md").read_text()
    assert (results / "cells/cells.md").exists() and (results / "jump/jump.md").exists()
    budget = (results / "reduced-lammps/budget/budget.md").read_text()  # the reduced cell's runs with the budget
    assert "run(s) of reduced (lammps) with a contact budget" in said["budget"] and "## 150°" in budget
    assert "## 180°" in budget and (results / "reduced-lammps/budget/budget.png").stat().st_size > 10_000
    print("lane: " + ", ".join(f"{' '.join(d.args)} {d.seconds:.0f} s" for d in done))
