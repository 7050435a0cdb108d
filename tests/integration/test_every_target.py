"""The targets `make help` names, run through `make` end to end at the smallest scale that exercises them, in a copy
of the project (results of this checkout are never touched): the DEM and engine targets at the tiny size here, the
data targets on the committed data in ``test_data_targets.py``, the long ones (the demo and what follows it on its
data set) in the lane (``test_lane.py``). Which test runs which target is ``tests/helpers/targets.py``'s
``RUN_HERE``; a new target fails the first test until it is placed."""

import json
import os
import re
import signal
import subprocess

import numpy as np
import pytest

from pipeline.dataset.dem_file import load
from tests.helpers.project import make, project_copy
from tests.helpers.targets import RUN_BY_CI, RUN_HERE

pytestmark = [pytest.mark.yade, pytest.mark.lammps]

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


def tiny_ladder(project) -> tuple[str, ...]:
    """``make fidelity``'s variables for a ladder of two tiny runs, written into the project."""
    (project / "ladder.toml").write_text(TINY_LADDER)
    return ("LADDER=ladder.toml", "JOBS=2")


def stop_at_first_checkpoint(project):
    """A LAMMPS run stopped at its first checkpoint: the folder the settings benchmark resumes from."""
    proc = subprocess.Popen(["make", "--no-print-directory", "dem", "THETA=90", "PRESET=tiny", "ENGINE=lammps",
                             "SET=seed=9"], cwd=project, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    for line in proc.stdout:
        if "strain" in line:
            os.killpg(proc.pid, signal.SIGINT)
            break
    proc.communicate(timeout=120)
    return next((project / "results").glob("tiny-lammps-*/dem/theta090.run")).relative_to(project)


def a_run(path, engine: str) -> bool:
    """Whether ``path`` is a run the pipeline reads, of ``engine``, with samples over its cycle and a contact
    budget."""
    run = load(path)
    return run.engine == engine and len(run.raw["strain"]) > 10 and run.contacts is not None \
        and bool(np.isfinite(run.raw["strain"]).all())


def settings_timed(record: dict) -> bool:
    """Whether the settings benchmark timed both settings in every round, at positive rates."""
    rates = record["a_steps_per_second"], record["b_steps_per_second"]
    return all(len(r) == record["rounds"] and min(r) > 0 for r in rates) and len(record["ratios"]) == record["rounds"]


#: the DEM and engine targets at the tiny size, in order (each may read what one before it made): the target, its
#: variables (a function of the project where they name a file made before), and what its outputs must hold
DEM_TARGETS = [
    ("dem", ("THETA=180", "PRESET=tiny"), lambda p, said: a_run(p / "results/tiny/dem/theta180.h5", "yade")),
    ("dem", ("THETA=180", "PRESET=tiny", "ENGINE=lammps"),
     lambda p, said: a_run(p / "results/tiny-lammps/dem/theta180.h5", "lammps")),
    ("engines", ("PRESET=tiny",), lambda p, said: "tiny (lammps)" in (p / "results/engines/engines.md").read_text()),
    ("bench-lammps-settings", lambda p: (f"RUN_DIR={stop_at_first_checkpoint(p)}",),
     lambda p, said: settings_timed(json.loads((p / "results/bench/lammps_settings.json").read_text()))),
    ("bench-dem", ("PRESETS=tiny", "ENGINES=yade,lammps"),
     lambda p, said: re.search(r"^\| tiny \| \d+ \+ \d+ \| [1-9]\d* / [1-9]\d* \| [1-9]\d* / [1-9]\d* \| [\d.]+× \|",
                               (p / "results/bench/dem_engines.md").read_text(), re.MULTILINE) is not None),
    ("sweep", ("PRESET=tiny", "THETAS=30 60", "JOBS=2"),
     lambda p, said: a_run(p / "results/tiny/dem/theta030.h5", "yade") and a_run(p / "results/tiny/dem/theta060.h5",
                                                                               "yade")),
    ("runs", (), lambda p, said: "tiny/theta060" in said),
    ("sweep-status", (), lambda p, said: "done" in said),
    # dt_safety 0.2 is the preset's own: its run, made above, is found; the other is made
    ("fidelity", lambda p: tiny_ladder(p),
     lambda p, said: "running 1 ladder run(s)" in said and "2 run(s) of the ladder; 0 not made yet" in said
     and "moved from the `tiny` preset" in (p / "results/fidelity-ladder/table.md").read_text()),
    ("profile-dem", ("PRESETS=tiny",),
     lambda p, said: re.search(r"^\| tiny \| 1 \| \d+ \+ \d+ \| [1-9]\d* \| ",
                               (p / "results/bench/dem_profile.md").read_text(), re.MULTILINE) is not None),
    # a case past the time-step bound: its verdict in seconds (test_dem_stability runs the cases that pass)
    ("stability", ("CASES=dt2.0",),
     lambda p, said: "| dt2.0 |" in (text := (p / "results/fidelity/stability.md").read_text())
     and "| stopped | 3 |" in text),
]


@pytest.mark.parametrize("target, variables, holds", DEM_TARGETS,
                         ids=[f"{k}-{t[0]}" for k, t in enumerate(DEM_TARGETS)])
def test_a_dem_or_engine_target_runs_at_the_tiny_size(project, target, variables, holds):
    said = make(project, target, *(variables(project) if callable(variables) else variables))
    assert holds(project, said), said[-2000:]


assert {t for t, *_ in DEM_TARGETS} == {t for t, n in RUN_HERE.items()
                                       if n == "test_a_dem_or_engine_target_runs_at_the_tiny_size"}
