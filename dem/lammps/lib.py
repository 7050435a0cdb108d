"""LAMMPS as a library of Debian's python3 (``python3-lammps``; ``liblammps-dev`` provides ``liblammps.so``)."""

import atexit
import os
import shutil
import stat
import tempfile

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


def singleton_session_base() -> str:
    """A folder of this process's own for Open MPI's session directory, removed when the process ends (kept across
    the ``exec`` at a checkpoint, which keeps the process id). Open MPI's default, ``/tmp/ompi.<host>.<uid>``, is
    shared by every Open MPI job of the user on the machine: one ending there removes it while another starts
    (``orte_session_dir failed``), as when two runs of a sweep checkpoint at once."""
    base = os.path.join(tempfile.gettempdir(), f"dem-mpi-{os.getuid()}-{os.getpid()}")
    try:
        os.mkdir(base, 0o700)
    except FileExistsError:  # made before this process's exec, or by someone else: ours, a folder, private
        found = os.lstat(base)
        if not stat.S_ISDIR(found.st_mode) or found.st_uid != os.getuid() or found.st_mode & 0o077:
            raise OSError(f"{base} exists and is not a private folder of this user: remove it") from None
    atexit.register(shutil.rmtree, base, True)
    return base


def new_lammps(ranks_comm=None, log=None):
    """A LAMMPS instance that writes nothing to the screen and appends its log to ``log`` (none by default); a
    one-line ImportError naming the packages when LAMMPS is missing.

    Outside ``mpirun`` this LAMMPS starts MPI as a singleton, which would spawn an ``orted`` daemon that lives as
    long as the pipe to it stays open, and a scene that ``exec``s itself at each checkpoint keeps it open: one more
    daemon (about 20 MB) and about five more descriptors per checkpoint. An isolated singleton spawns none.
    Its session directory goes under a folder of this process alone (``singleton_session_base``)."""
    if ranks_comm is None and "OMPI_COMM_WORLD_SIZE" not in os.environ:
        os.environ["OMPI_MCA_ess_singleton_isolated"] = "1"
        os.environ.setdefault("OMPI_MCA_orte_tmpdir_base", singleton_session_base())
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

