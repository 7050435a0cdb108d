"""A sweep run here: a makefile of one rule per run, run by Make with ``-j`` (one Yade thread or one or more MPI
ranks each)."""

from __future__ import annotations

import shlex
import subprocess

from ... import io
from ...paths import ROOT
from ..state import run_state
from .plan import Sweep, launcher_command


def local_makefile(sweep: Sweep, ranks: int = 1) -> str:
    lines = ["# one rule per run of the sweep; run by `make sweep LAUNCH=local` with -j", "",
             "all: " + " ".join(shlex.quote(str(t.output)) for t in sweep.tasks), ""]
    for task in sweep.tasks:
        command = shlex.join(launcher_command(task, sweep.results, ranks=ranks))
        lines += [f"{shlex.quote(str(task.output))}:", "\tcd " + shlex.quote(str(ROOT)) + " && " + command, ""]
    return "\n".join(lines)


def run_local(sweep: Sweep, jobs: int, ranks: int = 1) -> int:
    """Make's exit status, but 0 when every run is done in the end (some perhaps by another sweep of the same
    runs, whose launches this one's were refused): the status reports the runs, not the race. ``jobs`` runs side
    by side, each on ``ranks`` MPI ranks."""
    makefile = io.write_text(sweep.folder / "runs.mk", local_makefile(sweep, ranks))
    status = subprocess.call(["make", "--no-print-directory", "-k", f"-j{jobs}", "-f", str(makefile), "all"])
    if status == 0:
        return 0
    states = [run_state(t.run_dir, t.output)[0] for t in sweep.tasks]
    if all(s in ("done", "running") for s in states):
        elsewhere = states.count("running")
        print(f"sweep {sweep.ident}: {states.count('done')} run(s) done" + (
            f", {elsewhere} running in another process (follow with `make sweep-status`)" if elsewhere else
            " (some by another process running the same runs)"))
        return 0
    return status
