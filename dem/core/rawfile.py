"""The scene's files: ``status.json`` (its progress), ``raw.npz`` (every sample and the run's meta data, read by
``pipeline.dataset.dem_file``) and the samples saved beside each checkpoint. Plain python and numpy, so
Yade's python3 and the project venv (the tests' synthetic runs) write the same format.

Written atomically: a temporary file named after the process, flushed to disk, then renamed. This is the scene's
own writer, not ``pipeline.io``'s: the scene runs under Debian's python3 with numpy and Yade only, without the
project's virtualenv and its packages.
"""

import errno
import gzip
import json
import os
import zlib

import numpy as np


def stack(samples):
    """Sample rows (dicts of arrays) -> columns ``{name: (n, ...) array}``."""
    keys = samples[0].keys() if samples else []
    return {key: np.array([row[key] for row in samples]) for key in keys}


def save_npz(path, arrays):
    """``np.savez`` to a temporary file beside ``path``, fsync, then rename onto ``path``."""
    tmp = f"{path}.tmp{os.getpid()}.npz"
    try:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def write_status(path, status):
    """``status.json`` beside the run: its progress for ``make sweep-status`` and ``make runs`` (temp, then rename).
    Advisory: where it cannot be written (a full disk) it is left as it was; the checkpoints say so loudly."""
    tmp = f"{path}.tmp{os.getpid()}"
    try:
        with open(tmp, "w") as fh:
            json.dump(status, fh)
        os.replace(tmp, path)
    except OSError:
        if os.path.exists(tmp):
            os.remove(tmp)


def write_raw(path, columns, meta):
    """``raw.npz``: the sample columns plus ``meta_json`` (spec, contact constants, time step, ...)."""
    save_npz(path, {**columns, "meta_json": np.array(json.dumps(meta))})


#: errors of the disk rather than of the run: the run stops with one line and resumes once they are gone
DISK_ERRORS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EIO)
#: exit status of a run stopped by its disk (the scene's and the launcher's): resumable once space is back
DISK_FULL = 4


class DiskError(Exception):
    """The run's disk cannot take a file (full, over quota, read-only): stop, keep the last checkpoint."""


def free_bytes(folder):
    st = os.statvfs(folder)
    return st.f_bavail * st.f_frsize


def require_free(folder, needed, what):
    """A ``DiskError`` unless ``folder``'s disk has ``needed`` bytes free for ``what``."""
    free = free_bytes(folder)
    if free < needed:
        raise DiskError(f"{folder} has {free / 2**20:.1f} MiB free, {what} needs about {needed / 2**20:.1f} MiB")


def complete_gzip(path):
    """Whether ``path`` is a whole gzip stream (Yade's ``O.save`` onto a full disk returns quietly with a
    truncated file)."""
    try:
        with gzip.open(path, "rb") as fh:
            while fh.read(1 << 22):
                pass
        return True
    except (OSError, EOFError, zlib.error):
        return False


def sync(path):
    """fsync a file or a folder, so that a rename after it survives a crash."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
