"""The lane of long targets (``tests/helpers/project.py``: ``LANE``), started with the session in a copy of the project
(``tests/conftest.py``): `make demo` and what a user runs on its data set next, every benchmark at the smallest size
and the studies of committed data no other target reads. Its test, in a file of its own, runs last."""

import json

import pytest

from tests.helpers.project import LANE

pytestmark = [pytest.mark.yade, pytest.mark.lammps]


@pytest.mark.last
def test_the_long_targets_run_in_a_lane_beside_the_session(long_lane):
    """The lane's commands (``LANE``) each succeed without a traceback, and leave what they promise."""
    done = long_lane.wait(timeout=1800)
    for d in done:
        assert d.status == 0 and "Traceback" not in d.output, f"make {' '.join(d.args)}: exit {d.status}\n" \
                                                               f"{d.output[-3000:]}"
    assert [d.args for d in done] == LANE
    said = {d.args[0]: d.output for d in done}
    folder, = (long_lane.project / "results").glob("quick-*")  # the demo's data set: quick with DEMO_SET
    assert "demo done" in said["demo"] and (folder / "report.md").exists() and (folder / "fit/params.json").exists()
    assert len(list((long_lane.project / "results/model").glob("theta*.csv"))) == 6
    assert "(2 done)" in said["sweep"] and "make figures PRESET=quick" in said["sweep-collect"]
    assert (folder / "fit/fit_from.md").exists()
    assert set(json.loads((folder / "fit/profiles-C-b2.json").read_text())["parameters"]) == {"C", "b2"}
    assert "| held out |" in (folder / "models/models.md").read_text() and (folder / "models/models.png").exists()
    bench = long_lane.project / "results/bench"
    assert all((bench / name).exists() for name in ("update.md", "dem_throughput.md"))
    results = long_lane.project / "results"
    assert "### θ = 180, cycle 1" in (results / "versus/versus.md").read_text()
    assert (results / "cells/cells.md").exists() and (results / "jump/jump.md").exists()
    budget = (results / "reduced-lammps/budget/budget.md").read_text()  # the reduced cell's runs with the budget
    assert "run(s) of reduced (lammps) with a contact budget" in said["budget"] and "## 150°" in budget
    assert "## 180°" in budget and (results / "reduced-lammps/budget/budget.png").stat().st_size > 10_000
    print("lane: " + ", ".join(f"{' '.join(d.args)} {d.seconds:.0f} s" for d in done))
