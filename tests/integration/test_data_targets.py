"""The data targets `make help` names, run through `make` on the committed paper cell in a copy of the project
(results of this checkout are never touched), in order: a comparison and figures read the fit before them; clean
last. A file of its own, so that a worker of the suite runs them beside the DEM targets."""

import numpy as np
import pytest

from pipeline.paths import ROOT
from pipeline.schema import read_metrics
from tests.helpers.project import make, project_copy
from tests.helpers.targets import RUN_HERE

pytestmark = [pytest.mark.yade, pytest.mark.lammps]


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    return project_copy(tmp_path_factory.mktemp("project"))


def compared(path, seeds: set[int]) -> bool:
    """Whether ``path`` is a comparison the pipeline reads, with an error row for every run of ``seeds`` (and no
    other) and finite errors."""
    metrics = read_metrics(path)
    rows = metrics.errors.rows
    return bool(rows) and {r.seed for r in rows} == seeds \
        and all(np.isfinite(v) for r in rows for v in r.errors.values())


PAPER = "results/paper-lammps-e29c082a"
#: the targets of the committed data, in order (a comparison and figures read the fit before them; clean last)
DATA_TARGETS = [
    # a fit with other options than the defaults: its fit, comparison and report in folders of their own
    ("fit", ("SKIP_CYCLES=1",),
     lambda p, said: "runs: paper (lammps, inertial_number=0.001, cycles from 2 on)" in said
     and (p / PAPER / "fit-skip1/params.json").exists() and not (p / PAPER / "fit").exists()),
    ("compare", ("SKIP_CYCLES=1",), lambda p, said: compared(p / PAPER / "compare-skip1/metrics.json", {1})
     and not (p / PAPER / "compare-skip1/report.md").exists()),
    ("figures", ("SKIP_CYCLES=1",),
     lambda p, said: "## Drift over the cycles" in (p / PAPER / "compare-skip1/report.md").read_text()),
    ("compare-seed", ("SEED=2",), lambda p, said: compared(p / PAPER / "compare-seed2/metrics.json", {2})),
    ("fit-bootstrap", ("BOOT=2",),
     lambda p, said: '"interval_68"' in (p / PAPER / "fit-bootstrap/fit.json").read_text()),
    ("fit-jackknife", ("OVER=angles",),
     lambda p, said: '"over": "angles"' in (p / PAPER / "fit-jackknife-angles/fit.json").read_text()),
    ("fit-angles", ("ANGLES=180 90",),
     lambda p, said: '"variant"' not in (p / PAPER / "fit-angles-180-90/params.json").read_text()),
    ("fit-angles", ("ANGLES=180 90", "VARIANT=jump"),  # another law beside Eq. 13's, in a folder of its own
     lambda p, said: '"variant": "jump"' in (p / PAPER / "fit-angles-180-90-jump/params.json").read_text()),
    ("fit-definitions", ("SKIP_CYCLES=1",),  # beside the fit of the same cycles, not over the default's table
     lambda p, said: "cycles from 2 on" in (p / PAPER / "fit-skip1/definitions.md").read_text()
     and not (p / PAPER / "fit/definitions.md").exists()),
    ("fidelity-table", (), lambda p, said: "run(s) of the ladder" in said),
    ("data-card", (), lambda p, said: (p / "data/reference/README.md").read_text()
     == (ROOT / "data/reference/README.md").read_text()),
    ("clean", (), lambda p, said: not (p / PAPER / "fit").exists() and not (p / PAPER / "compare-seed2").exists()),
]


assert {t for t, *_ in DATA_TARGETS} == {t for t, n in RUN_HERE.items()
                                        if n == "test_a_data_target_runs_on_the_committed_data"}


@pytest.mark.parametrize("target, variables, holds", DATA_TARGETS,
                         ids=[f"{k}-{t[0]}" for k, t in enumerate(DATA_TARGETS)])
def test_a_data_target_runs_on_the_committed_data(project, target, variables, holds):
    said = make(project, target, "PRESET=paper", *variables)
    assert holds(project, said), said[-2000:]
