"""A full disk at a stage of the pipeline or at the model's command line: one line naming the folder, exit status 4
(2 at the model's), nothing half-written, no cascade of HDF5 errors or crash at exit (a real tmpfs, filled)."""

import subprocess
import sys

import pytest

from pipeline.paths import ROOT
from tests.helpers import synthetic_file


@pytest.fixture
def full_disk(tmp_path):
    """A 256 KiB tmpfs of its own (root, as the SLURM tests are), all but 56 KiB of it taken."""
    folder = tmp_path / "disk"
    folder.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(folder)], check=True)
    (folder / "filler").write_bytes(b"\0" * 200_000)
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


def command(*argv):
    return subprocess.run([sys.executable, *argv], capture_output=True, text=True, cwd=ROOT)


def test_a_fit_onto_a_full_disk_is_one_line_and_leaves_nothing(full_disk, tmp_path):
    run = synthetic_file(tmp_path, name="theta180", n_cycles=1, noise=0.002)
    proc = command("-m", "pipeline.calibration", "--runs", str(run), "--out", str(full_disk / "fit"))
    assert proc.returncode == 4, proc.stderr[-2000:]
    errors = [line for line in proc.stderr.splitlines() if line.strip()]
    assert errors == [errors[-1]] and errors[0].startswith(f"error: cannot write in {full_disk / 'fit'} (No space")
    assert not list((full_disk / "fit").iterdir())


def test_the_models_command_line_onto_a_full_disk_is_one_line(full_disk):
    proc = command("-m", "model", "predict", "--theta", "90", "--out", str(full_disk / "cycle.csv"))
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "No space left" in proc.stderr and not (full_disk / "cycle.csv").exists()
