"""The scene's files: ``status.json`` (its progress), ``raw.npz`` (every sample and the run's meta data, read by
``pipeline.dataset.dem_file``) and the samples saved beside each checkpoint. Plain python and numpy, so
Yade's python3 and the project venv (the tests' synthetic runs) write the same format.

Written atomically: a temporary file named after the process, flushed to disk, then renamed. This is the scene's
own writer, not ``pipeline.io``'s: the scene runs under Debian's python3 with numpy and Yade only, without the
project's virtualenv and its packages.
"""

import json
import os

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
    """``status.json`` beside the run: its progress for ``make sweep-status`` and ``make runs`` (temp, then rename)."""
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as fh:
        json.dump(status, fh)
    os.replace(tmp, path)


def write_raw(path, columns, meta):
    """``raw.npz``: the sample columns plus ``meta_json`` (spec, contact constants, time step, ...)."""
    save_npz(path, {**columns, "meta_json": np.array(json.dumps(meta))})
