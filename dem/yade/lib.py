"""Yade as a library of Debian's python3, imported without the ``yade`` launcher.

The launcher (``/usr/bin/yade``) starts two remote servers before it runs a script: a Python
console on port 9000 and an XML-RPC provider on port 21000, both on every interface, guarded by a
six-letter cookie that it prints to the run's log. A scene needs neither, so the scene scripts
run as ``python3 -m dem.<script>`` and import Yade's modules directly: no port is opened.

The library folder is the one the launcher itself puts on ``sys.path`` (read from its text), so
this follows whatever build ``yade`` on the PATH is (``yade-double`` on Debian).
"""

import glob
import os
import re
import shutil
import sys


def library_dir() -> str:
    """Folder of Yade's python modules, as named by the ``yade`` launcher on the PATH."""
    launcher = shutil.which("yade")
    if launcher:
        with open(launcher, encoding="utf-8", errors="replace") as fh:
            match = re.search(r"sys\.path\.insert\(\s*1\s*,\s*'([^']+/py)'\s*\)", fh.read())
        if match and os.path.isdir(match.group(1)):
            return match.group(1)
    found = sorted(glob.glob("/usr/lib/*/yade*/py/yade/__init__.py"))
    if not found:
        raise ImportError("Yade's python modules not found: run `make system` (apt-get install yade)")
    return os.path.dirname(os.path.dirname(found[0]))


os.environ.setdefault("OMP_NUM_THREADS", "1")  # before Yade's OpenMP runtime starts
sys.path.insert(1, library_dir())

import yade  # noqa: E402
import yade.config  # noqa: E402
import yade.wrapper as wrapper  # noqa: E402
from yade import O, pack, utils  # noqa: E402
from yade._minieigenHP import Vector3  # noqa: E402
from yade.wrapper import PyRunner  # noqa: E402

VERSION = yade.config.version
__all__ = ["O", "PyRunner", "VERSION", "Vector3", "pack", "utils", "wrapper"]
