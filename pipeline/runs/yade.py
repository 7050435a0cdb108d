"""How the project starts a scene script: Debian's python3 running ``python3 -m dem.<module>``.

The scripts import Yade as a library (``dem/yade_lib.py``), so the ``yade`` launcher's remote
consoles never start. The interpreter is the one Debian's ``yade`` launcher names in its first line; LAMMPS's
scene runs under it too (Debian's ``python3-lammps``, and Yade's grain cloud).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from ..errors import PipelineError
from ..paths import ROOT
from .state import STATUS


class YadeMissing(RuntimeError):
    """Yade is not installed; the message says how to install it."""


def yade_python() -> str:
    """The python3 that Debian's Yade is built for (the ``yade`` launcher's interpreter)."""
    launcher = shutil.which("yade")
    if launcher is None:
        raise YadeMissing("yade not found on PATH: run `make system` (apt-get install yade)")
    with open(launcher, encoding="utf-8", errors="replace") as fh:
        first = fh.readline()
    interpreter = first[2:].strip().split()[0] if first.startswith("#!") else "/usr/bin/python3"
    return interpreter if os.path.exists(interpreter) else "/usr/bin/python3"


def require_lammps() -> None:
    """Raise ``YadeMissing`` with LAMMPS's one-line message where Debian's python3 cannot start LAMMPS."""
    proc = subprocess.run([yade_python(), "-c", "from dem.lammps_lib import new_lammps; new_lammps().close()"],
                          capture_output=True, text=True, env=environment())
    if proc.returncode != 0:
        raise YadeMissing((proc.stderr.strip().splitlines() or ["LAMMPS cannot start"])[-1].removeprefix(
            "ImportError: "))


def command(module: str, *args: str) -> list[str]:
    """The command line running ``dem.<module>`` with ``args`` under Yade's python."""
    return [yade_python(), "-m", f"dem.{module}", *map(str, args)]


def environment(threads: int = 1) -> dict[str, str]:
    """Environment of a Yade script: the project on the path, ``threads`` OpenMP threads, unbuffered output."""
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path, "OMP_NUM_THREADS": str(threads), "PYTHONUNBUFFERED": "1"}


#: stands for the output file's path in ``run_script``'s arguments
OUT = object()


def run_script(module: str, spec, args: tuple, threads: int = 1, what: str = "", run_dir: Path | None = None) -> dict:
    """Run ``dem.<module>`` on ``spec`` (a ``DemSpec``) in a scratch folder (its ``spec.json``) with ``args`` after
    the folder, ``OUT`` among them standing for the JSON file the script writes; that file's content, or a one-line
    error with the script's last line on stderr. With ``run_dir`` (and no spec) the scratch folder is a copy of that
    run folder's checkpoint (its files but the logs and status), which the script may change."""
    with tempfile.TemporaryDirectory() as tmp:
        if run_dir is None:
            Path(tmp, "spec.json").write_text(json.dumps(spec.to_dict()))
        else:
            for path in run_dir.iterdir():
                if path.is_file() and path.suffix != ".log" and path.name not in ("log.txt", STATUS):
                    shutil.copy2(path, tmp)
        out = Path(tmp, "out.json")
        argv = [out if a is OUT else a for a in args]
        proc = subprocess.run(command(module, tmp, *argv), capture_output=True, text=True, cwd=tmp,
                              env=environment(threads))
        if proc.returncode != 0 or not out.exists():
            last = (proc.stderr.strip().splitlines() or [f"exit status {proc.returncode}"])[-1]
            raise PipelineError(f"{what or module} failed: {last}")
        return json.loads(out.read_text())
