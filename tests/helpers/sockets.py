"""What listens: the TCP sockets in LISTEN state and the sockets a process holds, read from /proc."""

import os
from pathlib import Path


def listening_inodes():
    """Socket inodes of every TCP socket in LISTEN state, and their local ports."""
    found = {}
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(table) as fh:
            for line in fh.readlines()[1:]:
                fields = line.split()
                if fields[3] == "0A":
                    found[fields[9]] = int(fields[1].rsplit(":", 1)[1], 16)
    return found


def socket_inodes(pid):
    """The inodes of the sockets process ``pid`` holds (none once it has ended)."""
    inodes = set()
    try:
        fds = list(Path(f"/proc/{pid}/fd").iterdir())
    except OSError:
        return inodes
    for fd in fds:
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    return inodes


def scene_ranks(run_dir: Path, module: str = "dem.lammps.scene") -> list[int]:
    """The processes running ``python -m module run_dir`` (an MPI run's ranks; not ``mpirun`` itself)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            argv = (entry / "cmdline").read_bytes().decode(errors="replace").split("\0")
        except OSError:
            continue
        if argv[1:4] == ["-m", module, str(run_dir)]:
            found.append(int(entry.name))
    return found
