"""The DEM engines, by name: what the launcher, the spec and the data sets need to know of each one.

An engine is a package under ``dem/`` that implements the adapter contract of ``dem/core/contract.py`` plus one
entry of ``ENGINES`` here: the module its scene runs as (``python3 -m <scene> RUN_DIR``, Debian's python3), the files
of its checkpoint, its own log (where it writes the errors it stops on), the make target that installs it and the
code that fails where it cannot start, whether it runs on MPI ranks or on threads, the starts of the lines it
prints that are not the scene's, the modules of ``dem/`` that run in its interpreter, and the launcher whose first
line names that interpreter (Debian's python3 the engine is built for; ``/usr/bin/python3`` without one). The first
entry is the reference, the default everywhere. Standard library only: the Makefile's checks read it before anything
is installed.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from .errors import SpecError


@dataclasses.dataclass(frozen=True)
class Engine:
    """One DEM engine (see the module's docstring)."""

    name: str
    scene: str
    checkpoint_files: tuple[str, ...]
    install: str
    start_check: str
    log: str | None = None
    mpi: bool = False
    threads: bool = False  # the scene uses OpenMP threads (THREADS=)
    noise: tuple[str, ...] = ()
    modules: tuple[str, ...] = ()  # the starts of the module names of dem/ that run in its interpreter
    launcher: str | None = None  # the command whose first line (#!) names its interpreter

    def last_error(self, run_dir: Path) -> str:
        """The engine's own last error in its log, where it stopped the scene without one of ours; else ''."""
        log = run_dir / self.log if self.log else None
        if log is None or not log.exists():
            return ""
        errors = [line.strip() for line in log.read_text(errors="replace").splitlines() if line.startswith("ERROR")]
        return f"error: {self.name}: {errors[-1]}" if errors else ""


ENGINES: dict[str, Engine] = {e.name: e for e in (
    Engine("yade", "dem.yade.scene", ("checkpoint.yade.gz",), "system", "import dem.yade.lib", threads=True,
           noise=("Using python version",), modules=("dem.yade.", "dem.tools.yade_"), launcher="yade"),
    Engine("lammps", "dem.lammps.scene", ("restart_*.lmp",), "system-lammps",
           "from dem.lammps.lib import new_lammps; new_lammps().close()", log="lammps.log", mpi=True,
           modules=("dem.lammps.", "dem.tools.lammps_")),
)}
#: the engines that run on MPI ranks, and those that run on threads, as a message names them
MPI_ENGINES = " or ".join(e.name for e in ENGINES.values() if e.mpi)
THREADED_ENGINES = " or ".join(e.name for e in ENGINES.values() if e.threads)
#: the most MPI ranks and OpenMP threads a run may ask for (one bound for a run, a sweep and a SLURM job)
MAX_RANKS = MAX_THREADS = 256


def check_parallel(name: str, ranks: int = 1, threads: int = 1, words: tuple[str, str] = ("ranks", "threads"),
                   hints: tuple[str, str] = ("RANKS=", "THREADS=")) -> None:
    """A one-line ``SpecError`` where ``ranks`` or ``threads`` lie outside 1..256 or ask engine ``name`` for what it
    does not run on (MPI ranks, OpenMP threads). ``words`` name the two values as the caller's user gave them,
    ``hints`` what to give instead."""
    for word, value, bound in ((words[0], ranks, MAX_RANKS), (words[1], threads, MAX_THREADS)):
        if not 1 <= value <= bound:
            raise SpecError(f"{word}={value} must be between 1 and {bound}")
    chosen = engine(name)
    if ranks != 1 and not chosen.mpi:
        raise SpecError(f"{words[0]}={ranks}: MPI ranks are for ENGINE={MPI_ENGINES} ({name} runs on threads: "
                        f"{hints[1]})")
    if threads != 1 and not chosen.threads:
        raise SpecError(f"{words[1]}={threads}: threads are for ENGINE={THREADED_ENGINES} ({name} runs on MPI ranks: "
                        f"{hints[0]})")


#: the reference engine: the default of every run and data set, and the one whose runs' folders carry no suffix
DEFAULT_ENGINE = next(iter(ENGINES))


def engine_of_module(module: str) -> Engine:
    """The engine a module of ``dem/`` runs in (the reference engine's for one of none: ``dem.core``'s)."""
    return next((e for e in ENGINES.values() if module.startswith(e.modules)), ENGINES[DEFAULT_ENGINE])


def engine(name: str) -> Engine:
    """The engine called ``name``; another name is a one-line error that lists the known ones."""
    if name not in ENGINES:
        raise SpecError(f"engine={name!r} is not a DEM engine here (known: {', '.join(ENGINES)})")
    return ENGINES[name]
