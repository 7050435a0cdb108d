"""The LAMMPS commands a user may set for a run's speed (``make bench-lammps-settings``): how LAMMPS sorts atoms,
communicates and builds neighbour lists, never a command that runs a program or reads a file. Standard library only:
the front door (``pipeline.targets``) checks a setting with it before anything is installed, and the benchmark again
before it runs."""

import re

#: the commands a setting may hold
COMMANDS = ("atom_modify", "comm_modify", "neighbor", "neigh_modify", "balance", "newton")
_WORD = re.compile(r"[A-Za-z0-9_.+-]+")


def parse(text: str, name: str) -> list[str]:
    """The commands of a setting (``;``-separated), each one of ``COMMANDS`` in plain words; else a ``ValueError``
    of one line naming ``name``."""
    commands = [c.strip() for c in text.split(";") if c.strip()]
    if not commands or not all(c.split()[0] in COMMANDS and all(_WORD.fullmatch(w) for w in c.split())
                               for c in commands):
        raise ValueError(f"{name}={text!r} is not LAMMPS settings (commands separated by ';', each one of "
                         f"{', '.join(COMMANDS)})")
    return commands
