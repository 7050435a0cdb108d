"""A sweep run here: a makefile of one rule per run, run by Make with ``-j`` (one Yade thread or one or more MPI
ranks each)."""

from __future__ import annotations

import shlex
import subprocess

from ... import engines, io
from ...errors import SpecError
from ...paths import ROOT
from ..state import run_state
from .plan import Sweep, launcher_command


def ranks_and_jobs(ranks: int | None, jobs: int | None, slurm_ranks: int, slurm_ranks_given: bool,
                   config_jobs: int) -> tuple[int, int]:
    """MPI ranks per run and runs side by side: the options given, else ``[slurm] ranks_per_run`` and ``[local]
    jobs`` divided by the ranks; a one-line error where they disagree or fall outside the engine's limits."""
    if ranks is not None and slurm_ranks_given and ranks != slurm_ranks:
        raise SpecError(f"ranks={ranks} and slurm ranks_per_run={slurm_ranks} disagree: give one")
    ranks = slurm_ranks if ranks is None else ranks
    if not 1 <= ranks <= engines.MAX_RANKS:
        raise SpecError(f"ranks={ranks} must be between 1 and {engines.MAX_RANKS}")
    jobs = max(1, config_jobs // ranks) if jobs is None else jobs
    if jobs < 1:
        raise SpecError(f"jobs={jobs} must be >= 1")
    return ranks, jobs


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
