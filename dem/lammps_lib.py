"""LAMMPS as a library of Debian's python3 (``python3-lammps``; ``liblammps-dev`` provides ``liblammps.so``)."""


def new_lammps(ranks_comm=None):
    """A LAMMPS instance that writes no log file and nothing to the screen; a one-line ImportError naming
    the packages when LAMMPS is missing."""
    try:
        import lammps
    except ImportError:
        raise ImportError("LAMMPS's python module not found: run `make system-lammps` "
                          "(apt-get install lammps python3-lammps liblammps-dev)") from None
    try:
        return lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"], comm=ranks_comm)
    except OSError as exc:
        raise ImportError(f"LAMMPS's library cannot be loaded ({exc}): apt-get install liblammps-dev") from None
