"""Compiled kernels are cached per version of the model's sources, so an edited module never meets a stale
kernel that inlined its old code."""

import shutil

import numba

import model
from model import kernel_cache


def test_the_cache_folder_follows_every_source_of_the_package(tmp_path, monkeypatch):
    copy = tmp_path / "model"
    shutil.copytree(kernel_cache.PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    before = kernel_cache.folder(copy)
    assert before.startswith(str(copy / "__pycache__" / "numba-"))
    assert kernel_cache.folder(copy) == before
    equations = copy / "equations.py"
    equations.write_text(equations.read_text() + "\n# changed\n")  # a module the kernels of others inline
    assert kernel_cache.folder(copy) != before
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "user"))
    assert kernel_cache.folder(copy).startswith(str(tmp_path / "user" / "numba-"))


def test_numba_setting_is_restored_after_the_import():
    assert model.predict(90).cycle_residual < 1e-10
    assert numba.config.CACHE_DIR != kernel_cache.folder()
