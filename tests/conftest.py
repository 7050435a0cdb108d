"""Every test's path to the project; the tests marked ``last`` run after every other; the lane of long targets
(``tests/helpers/project.py``, its test ``tests/integration/test_lane.py``): `make demo` and what a user runs on its
data set next, started in a copy of the project when the session starts, so that its DEM runs and fits overlap the
other tests, and its test, marked ``last``, finds it done."""

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from tests.helpers.project import LANE, LANE_TEST, Lane  # noqa: E402  (the project on the path first)


@pytest.fixture(scope="session", autouse=True)
def long_lane(request, tmp_path_factory):
    """The lane, running from the session's start (None when its test is not selected). Under pytest-xdist every
    worker finds the one lane of the session in the folder the workers share, owned by the session's main process
    (the workers' parent); run alone, the session's process owns it."""
    if not any(item.name == LANE_TEST for item in request.session.items):
        return None
    worker = hasattr(request.config, "workerinput")
    base = tmp_path_factory.getbasetemp()
    return Lane.start((base.parent if worker else base) / "lane", LANE, os.getppid() if worker else os.getpid())


def pytest_collection_modifyitems(items):
    """The tests marked ``last`` (they wait for work started with the session) after every other, in their order."""
    items.sort(key=lambda item: item.get_closest_marker("last") is not None)
