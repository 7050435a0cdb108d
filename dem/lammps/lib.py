"""LAMMPS as a library of Debian's python3 (``python3-lammps``; ``liblammps-dev`` provides ``liblammps.so``)."""

import os

# lammps.constants' values, here so that this module imports without LAMMPS
LMP_STYLE_GLOBAL, LMP_STYLE_LOCAL = 0, 2
LMP_TYPE_VECTOR, LMP_TYPE_ARRAY = 1, 2


def quoted(path) -> str:
    """``path`` as one argument of a LAMMPS command, whatever spaces or characters it holds (LAMMPS splits its
    commands at white space; triple quotes keep an argument whole)."""
    text = str(path)
    if '"""' in text:
        raise ValueError(f"{text!r}: a path with three double quotes in a row cannot be given to LAMMPS")
    return f'"""{text}"""'


def new_lammps(ranks_comm=None, log=None):
    """A LAMMPS instance that writes nothing to the screen and appends its log to ``log`` (none by default); a
    one-line ImportError naming the packages when LAMMPS is missing.

    Outside ``mpirun`` this LAMMPS starts MPI as a singleton, which would spawn an ``orted`` daemon that lives as
    long as the pipe to it stays open, and a scene that ``exec``s itself at each checkpoint keeps it open: one more
    daemon (about 20 MB) and about five more descriptors per checkpoint. An isolated singleton spawns none."""
    if ranks_comm is None and "OMPI_COMM_WORLD_SIZE" not in os.environ:
        os.environ["OMPI_MCA_ess_singleton_isolated"] = "1"
    try:
        import lammps
    except ImportError:
        raise ImportError("LAMMPS's python module not found: run `make system-lammps` "
                          "(apt-get install lammps python3-lammps liblammps-dev)") from None
    try:
        lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"], comm=ranks_comm)
    except OSError as exc:
        raise ImportError(f"LAMMPS's library cannot be loaded ({exc}): apt-get install liblammps-dev") from None
    if log:
        lmp.command(f"log {quoted(log)} append")
    return lmp

