"""What every pipeline command line shares: argparse with one-line errors."""

import argparse
import time
from pathlib import Path

from model.cli import printable


def given_path(text: str) -> Path:
    """A path option's value; an empty one would be the current folder, which no option means."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"{text!r} is empty: give a path")
    return Path(text)


class Progress:
    """A long loop's report, timed from the making: ``progress(done, total)`` prints ``label done/total (percent),
    rate, ETA``; ``step()`` counts one more of ``total``."""

    def __init__(self, label: str, total: int = 0, unit: str = "fits"):
        self.label, self.total, self.unit, self.done, self._began = label, total, unit, 0, time.monotonic()

    def __call__(self, done: int, total: int) -> None:
        self.done, self.total = done, total
        rate = done / max(time.monotonic() - self._began, 1e-9)
        print(f"{self.label} {done}/{total} ({done / total:.0%}), {rate:.2f} {self.unit}/s, "
              f"ETA {(total - done) / rate:.0f} s", flush=True)

    def step(self) -> None:
        self(self.done + 1, self.total)


class Parser(argparse.ArgumentParser):
    """argparse whose errors are one line (no usage dump) with exit status 2; every ``type=Path`` option refuses an
    empty value (``given_path``)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {printable(message)} (see --help)\n")

    def add_argument(self, *args, **kwargs):
        if kwargs.get("type") is Path:
            kwargs["type"] = given_path
        return super().add_argument(*args, **kwargs)


def one_line_errors(main):
    """Decorate a command line's ``main``: a pipeline or model error becomes its one-line message on
    stderr (``printable``: what a file or a user gave cannot act on the terminal) and exit status 2."""
    import functools
    import sys

    import model
    from dem.core.rawfile import DISK_FULL

    from .errors import PipelineError

    @functools.wraps(main)
    def wrapped(argv=None) -> int:
        try:
            return main(argv)
        except (PipelineError, model.ParameterError, model.SolverError) as exc:
            print(f"error: {printable(exc)}", file=sys.stderr)
            return 2
        except OSError as exc:
            if not disk_full(exc):
                raise
            print(f"error: {printable(full_disk_message(exc))}", file=sys.stderr)
            return DISK_FULL

    return wrapped


def disk_full(exc: OSError) -> bool:
    """A full, over-quota or read-only disk (h5py reports it in its message, without an errno)."""
    from dem.core.rawfile import DISK_ERRORS

    return exc.errno in DISK_ERRORS or any(text in str(exc) for text in ("No space left", "Disk quota", "Read-only"))


def full_disk_message(exc: OSError) -> str:
    """One line naming the folder whose disk is full and its free space: free some and run the same command again
    (every output is written atomically, so nothing half-written was left)."""
    import shutil
    from pathlib import Path

    from .paths import RESULTS_DIR

    path = Path(exc.filename) if getattr(exc, "filename", None) else RESULTS_DIR
    folder = next((p for p in (path, *path.parents) if p.is_dir()), RESULTS_DIR)
    free = shutil.disk_usage(folder).free
    return (f"cannot write in {folder} ({exc.strerror or exc}; {free / 2**20:.1f} MiB free there): free some space "
            "(a fit's folder takes a few MB) and run the same command again")
