"""The state of a run from its files: done (its HDF5 file), failed (``failed.json``), running (its lock held),
stopped (a checkpoint to resume from) or not started; with the progress the scene writes to ``status.json``."""

from __future__ import annotations

import fcntl
import json
from pathlib import Path

FAILED = "failed.json"  # in the run folder: why the last attempt stopped for good (exit 2 or 3)
STATUS = "status.json"  # in the run folder: the scene's progress (dem/yade/scene.py)
CHECKPOINTS = ("checkpoint.yade.gz", "checkpoint.json")  # Yade's scene, LAMMPS's


def is_locked(run_dir: Path) -> bool:
    """Whether a launcher holds the run's lock (``<name>.lock`` beside its folder)."""
    lock = Path(run_dir).with_suffix(".lock")
    if not lock.is_file():
        return False
    with open(lock) as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        fcntl.flock(fh, fcntl.LOCK_UN)
    return False


def read_json(path: Path) -> dict | None:
    """A small JSON object, or None where it is missing or damaged."""
    try:
        value = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return value if isinstance(value, dict) else None


def last_report(run_dir: Path) -> dict | None:
    """The scene's last progress report (``status.json``), None before its first or where it is damaged."""
    s = read_json(Path(run_dir) / STATUS)
    return s if s and isinstance(s.get("percent"), (int, float)) else None


def progress(run_dir: Path) -> str:
    """``42 %, 1800 steps/s, ETA 12m`` from the scene's ``status.json`` ('' before its first report)."""
    s = last_report(run_dir)
    if s is None:
        return ""
    eta = s.get("eta_seconds")
    eta_text = "?" if not isinstance(eta, (int, float)) else f"{int(eta) // 60}m{int(eta) % 60:02d}s"
    return f"{s['percent']:.0f} %, {s.get('steps_per_second', 0):.0f} steps/s, ETA {eta_text}"


def reached(run_dir: Path) -> str:
    """``, reached 42 %``: how far a run that is not running got (its last report), '' before its first."""
    s = last_report(run_dir)
    return "" if s is None else f", reached {s['percent']:.0f} %"


def run_state(run_dir: Path, output: Path) -> tuple[str, str]:
    """(state, detail) of the run whose folder is ``run_dir`` and whose HDF5 file is ``output``."""
    run_dir = Path(run_dir)
    if Path(output).exists():
        return "done", ""
    if (run_dir / FAILED).exists():
        failure = read_json(run_dir / FAILED) or {}
        return "failed", str(failure.get("reason", f"{run_dir / FAILED} is damaged"))
    if is_locked(run_dir):
        return "running", progress(run_dir)
    if any((run_dir / name).exists() for name in CHECKPOINTS):
        return "stopped", f"resumable from its checkpoint{reached(run_dir)}: rerun the same command"
    return "not started", ""
