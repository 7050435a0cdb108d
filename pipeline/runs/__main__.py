"""``python -m pipeline.runs``: the launcher of one DEM run (``pipeline/runs/launch.py``)."""

import signal
import sys


def stopped_before_the_scene(signum, _frame):
    """SIGUSR1 (a scheduler's warning) outside the scene's run, which passes it on: nothing to checkpoint here, so
    stop as a warned run does (exit 138, resumable), not by the signal's default action."""
    raise SystemExit(128 + signum)


signal.signal(signal.SIGUSR1, stopped_before_the_scene)  # before the imports below, which take a second

from .launch import main  # noqa: E402

sys.exit(main())
