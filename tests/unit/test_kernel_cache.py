"""Compiled kernels are cached per version of the model's sources, so an edited module never meets a stale
kernel that inlined its old code."""

import shutil

import numba
import pytest

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


def test_a_kernel_is_placed_by_its_module_within_the_package_not_by_the_disk(monkeypatch):
    """Two copies of the package with the same sources find their kernels at the same place in the cache folder."""
    from model import equations
    from model.laws import compaction

    monkeypatch.setattr(numba.config, "CACHE_DIR", "/cache/numba-0123")
    placed = {name: kernel_cache.InPackageLocator.from_function(f.py_func, f.py_func.__code__.co_filename)
              for name, f in (("equations", equations.fabric_rates), ("compaction", compaction.gate))}
    assert placed["equations"].get_cache_path() == "/cache/numba-0123/model"
    assert placed["compaction"].get_cache_path() == "/cache/numba-0123/model/laws"
    assert kernel_cache.InPackageLocator.from_function(pytest.approx, pytest.__file__) is None  # not the package's
    assert kernel_cache.LOCATORS.startswith("model.kernel_cache.InPackageLocator,")


def test_numba_setting_is_restored_after_the_import():
    assert model.predict(90).cycle_residual < 1e-10
    assert numba.config.CACHE_DIR != kernel_cache.folder()


#: a kernel module of its own, cached where the test says, its entry wrapped as the model's are
KERNEL = '''
import importlib.util
import sys
import numba
found = importlib.util.spec_from_file_location("kernel_cache", sys.argv[2])  # the module alone, not the model
kernel_cache = importlib.util.module_from_spec(found)
found.loader.exec_module(kernel_cache)
kernel_cache.folder = lambda: sys.argv[1]
numba.config.CACHE_DIR = sys.argv[1]
@numba.njit(cache=True)
def twice(x):
    return 2.0 * x
print(kernel_cache.rebuilding_when_damaged(twice)(21.0))
'''


@pytest.mark.slow  # three interpreters, each importing numba
def test_a_damaged_kernel_cache_is_rebuilt_with_a_warning(tmp_path):
    """Every file of the cache overwritten (as a full disk or a stray copy may leave it): one warning, the folder
    removed, the kernel compiled again, the right answer; the next run reads the new cache quietly."""
    import subprocess
    import sys

    (tmp_path / "kernels.py").write_text(KERNEL)
    cache = tmp_path / "cache"

    def run():
        return subprocess.run([sys.executable, str(tmp_path / "kernels.py"), str(cache), kernel_cache.__file__],
                              capture_output=True, text=True, cwd=tmp_path)

    first = run()
    assert first.stdout.strip() == "42.0" and first.stderr == "", first.stderr
    damaged = [p for p in cache.rglob("*") if p.is_file()]
    assert damaged
    for path in damaged:
        path.write_bytes(b"{not a kernel")
    again = run()
    assert again.returncode == 0 and again.stdout.strip() == "42.0", again.stderr
    assert "compiled-kernel cache" in again.stderr and "is damaged (UnpicklingError)" in again.stderr
    quiet = run()
    assert quiet.stdout.strip() == "42.0" and quiet.stderr == ""
