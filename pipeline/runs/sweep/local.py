"""A sweep run here: a makefile of one rule per run, run by Make with ``-j`` (one Yade thread each)."""

from __future__ import annotations

import shlex
import subprocess

from ... import io
from ...paths import ROOT
from .plan import Sweep, launcher_command


def local_makefile(sweep: Sweep) -> str:
    lines = ["# one rule per run of the sweep; run by `make sweep LAUNCH=local` with -j", "",
             "all: " + " ".join(shlex.quote(str(t.output)) for t in sweep.tasks), ""]
    for task in sweep.tasks:
        lines += [f"{shlex.quote(str(task.output))}:",
                  "\tcd " + shlex.quote(str(ROOT)) + " && " + shlex.join(launcher_command(task, sweep.results)), ""]
    return "\n".join(lines)


def run_local(sweep: Sweep, jobs: int) -> int:
    makefile = io.write_text(sweep.folder / "runs.mk", local_makefile(sweep))
    return subprocess.call(["make", "--no-print-directory", "-k", f"-j{jobs}", "-f", str(makefile), "all"])
