"""Where numba keeps this package's compiled kernels: one folder per version of the package's sources.

numba checks a cached kernel against its own module's file only, so a kernel that inlines a function of another
module (``integrator.dop853`` calls ``equations.fabric_rates``) would be loaded stale after that module changed.
Keyed by a digest of every source of the package, a changed source gets fresh kernels. Inside that folder a kernel's
place is its module's path within the package (``InPackageLocator``), not the module's path on the disk, so a copy
of the package with the same sources (another checkout, a test's copy of the project) reads the same kernels. A
damaged cache (a truncated or overwritten file) is removed with a warning and the kernels compile again
(``rebuilding_when_damaged``).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import shutil
import traceback
import warnings
from pathlib import Path

import numba
from numba.core import caching

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


class InPackageLocator(caching.UserProvidedCacheLocator):
    """numba's locator under its cache folder, at the module's folder within this package (``model``, ``model/laws``)
    where numba's own takes a digest of the module's absolute folder. numba still checks each kernel against a digest
    of its module's contents."""

    def __init__(self, py_func, py_file):
        super().__init__(py_func, py_file)
        within = Path(py_file).resolve().parent.relative_to(PACKAGE.parent)
        self._cache_path = os.path.join(os.path.abspath(numba.config.CACHE_DIR), *within.parts)

    @classmethod
    def from_function(cls, py_func, py_file):
        if not Path(py_file).resolve().is_relative_to(PACKAGE):
            return None
        return super().from_function(py_func, py_file)


#: numba's locators, ours first (``NUMBA_CACHE_LOCATOR_CLASSES``'s form: a class by its module path, or numba's own
#: by name)
LOCATORS = ",".join([f"{__name__}.{InPackageLocator.__name__}",
                     *(c.__name__ for c in caching.CacheImpl._locator_classes)])


@contextlib.contextmanager
def keyed_by_sources():
    """Kernels compiled (decorated) inside this block cache in ``folder()``, placed by ``InPackageLocator``; numba's
    settings are restored after."""
    before = numba.config.CACHE_DIR, numba.config.CACHE_LOCATOR_CLASSES
    numba.config.CACHE_DIR, numba.config.CACHE_LOCATOR_CLASSES = folder(), LOCATORS
    try:
        yield
    finally:
        numba.config.CACHE_DIR, numba.config.CACHE_LOCATOR_CLASSES = before


def _raised_by_the_cache(exc: BaseException) -> bool:
    """Whether ``exc`` came out of numba's reading of a cached kernel (a damaged or truncated file)."""
    frames = traceback.extract_tb(exc.__traceback__)
    return any(f.filename.replace(os.sep, "/").endswith("numba/core/caching.py") for f in frames)


def rebuilding_when_damaged(function):
    """``function`` (a public entry of the model), which on finding its compiled kernels' cache damaged warns once,
    removes the cache folder (``folder()``) and runs again: the kernels compile afresh and are cached anew."""
    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except Exception as exc:
            if not _raised_by_the_cache(exc):
                raise
            warnings.warn(f"the model's compiled-kernel cache {folder()} is damaged ({type(exc).__name__}): "
                          "removed; the kernels compile again", RuntimeWarning, stacklevel=2)
            shutil.rmtree(folder(), ignore_errors=True)
            return function(*args, **kwargs)
    return wrapper
