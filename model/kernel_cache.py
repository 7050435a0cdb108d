"""Where numba keeps this package's compiled kernels: one folder per version of the package's sources.

numba checks a cached kernel against its own module's file only, so a kernel that inlines a function of another
module (``integrator.dop853`` calls ``equations.fabric_rates``) would be loaded stale after that module changed.
Keyed by a digest of every source of the package, a changed source gets fresh kernels.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from pathlib import Path

import numba

PACKAGE = Path(__file__).resolve().parent


def source_digest(folder: Path = PACKAGE) -> str:
    """SHA-256 (16 hex) of the names and contents of the ``*.py`` files in ``folder`` and its subfolders (the fabric
    laws, ``model/laws``)."""
    digest = hashlib.sha256()
    for path in sorted(folder.rglob("*.py")):
        name = path.relative_to(folder).as_posix()
        digest.update(name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def folder(folder: Path = PACKAGE) -> str:
    """The cache folder: under ``NUMBA_CACHE_DIR`` where the user set one, else under the package's
    ``__pycache__``."""
    base = os.environ.get("NUMBA_CACHE_DIR") or str(folder / "__pycache__")
    return os.path.join(base, f"numba-{source_digest(folder)}")


@contextlib.contextmanager
def keyed_by_sources():
    """Kernels compiled (decorated) inside this block cache in ``folder()``; numba's setting is restored after."""
    before = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = folder()
    try:
        yield
    finally:
        numba.config.CACHE_DIR = before
