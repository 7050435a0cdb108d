"""How the project starts a script of ``dem/``: Debian's python3 running ``python3 -m dem.<package>.<module>``.

The scenes import their engine as a library (``dem/yade/lib.py``, ``dem/lammps/lib.py``), so Yade's launcher and its
remote consoles never start. The interpreter is the engine's (``pipeline.engines``): the one its launcher names in its
first line (Debian's ``yade``: the python3 Yade is built for), else ``/usr/bin/python3`` (``python3-lammps``'s).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from ..engines import DEFAULT_ENGINE, engine, engine_of_module
from ..errors import PipelineError
from ..paths import ROOT
from .state import STATUS


class EngineMissing(RuntimeError):
    """An engine is not installed; the message says how to install it."""


def engine_python(name: str | None = None) -> str:
    """Debian's python3 of the engine ``name`` (the reference engine's by default): its launcher's interpreter where
    it has one and it is installed, else ``/usr/bin/python3``."""
    chosen = engine(name or DEFAULT_ENGINE)
    launcher = shutil.which(chosen.launcher) if chosen.launcher else None
    if launcher is None:
        return "/usr/bin/python3"
    with open(launcher, encoding="utf-8", errors="replace") as fh:
        first = fh.readline()
    interpreter = first[2:].strip().split()[0] if first.startswith("#!") else "/usr/bin/python3"
    return interpreter if os.path.exists(interpreter) else "/usr/bin/python3"


def require(name: str) -> None:
    """Raise ``EngineMissing`` with one line, naming the make target that installs it, where Debian's python3
    cannot start the engine ``name``."""
    chosen = engine(name)
    python = engine_python(name)
    proc = subprocess.run([python, "-c", chosen.start_check], capture_output=True, text=True, env=environment())
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or [f"{name} cannot start"])[-1]
        raise EngineMissing(f"{name} cannot start in {python} ({last.split(': ', 1)[-1]}): run "
                            f"`make {chosen.install}`")


def command(module: str, *args) -> list[str]:
    """The command line running the module ``module`` (``dem.<package>.<module>``) with ``args``, in its engine's
    interpreter."""
    return [engine_python(engine_of_module(module).name), "-m", module, *map(str, args)]


def on_this_machine(ranks: int) -> bool:
    """Whether every rank runs here: one rank, ``mpirun`` outside a SLURM job, or a SLURM job of one node."""
    return ranks == 1 or "SLURM_JOB_ID" not in os.environ or os.environ.get("SLURM_JOB_NUM_NODES") == "1"


def environment(threads: int = 1, ranks: int = 1) -> dict[str, str]:
    """Environment of a script: the project on the path, ``threads`` OpenMP threads, unbuffered output. Where every
    rank runs on this machine (one rank, ``mpirun`` outside a SLURM job, or a SLURM job of one node), Open MPI's
    byte transfer is limited to the process itself and shared memory (``OMPI_MCA_btl``, unless the user sets it):
    its TCP transport would otherwise listen on every interface. A SLURM job over several nodes needs it."""
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    one_node = {"OMPI_MCA_btl": os.environ.get("OMPI_MCA_btl", "self,vader")} if on_this_machine(ranks) else {}
    return {**os.environ, "PYTHONPATH": path, "OMP_NUM_THREADS": str(threads), "PYTHONUNBUFFERED": "1", **one_node}


#: stands for the output file's path in ``run_script``'s arguments
OUT = object()


def run_script(module: str, spec, args: tuple, threads: int = 1, what: str = "", run_dir: Path | None = None) -> dict:
    """Run ``module`` on ``spec`` (a ``DemSpec``) in a scratch folder (its ``spec.json``) with ``args`` after
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
