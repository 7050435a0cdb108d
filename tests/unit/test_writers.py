"""One write check for every writer (``pipeline.io.check_destination``): through a link below ``results/``, no
output lands in the committed ``data/`` or outside ``results/``; and a committed run read through such a link is
still held to its manifest."""

import os
from pathlib import Path

import pytest

import model
from pipeline import io, targets
from pipeline.dataset import manifest
from pipeline.errors import DemFileError, PipelineError
from pipeline.paths import REFERENCE_DIR, RESULTS_DIR

#: every writer of the stages, each writing ``name`` below the folder it is given
WRITERS = {
    "write_text": lambda d: io.write_text(d / "x.md", "x"),
    "write_json": lambda d: io.write_json(d / "x.json", {"x": 1}),
    "write_table": lambda d: io.write_table(d, "x", {"x": 1}, "x"),
    "write_params": lambda d: io.write_params(d / "params.json", model.PAPER),
    "h5_file": lambda d: io.h5_file(d / "x.h5").__enter__(),
    "check_writable_dir": lambda d: io.check_writable_dir(d / "fit"),
    "write_if_changed (Make's stamps)": lambda d: targets.write_if_changed(d / "fit" / "options.txt", "x"),
}


@pytest.fixture
def link(request, tmp_path):
    """``results/zz-link-<case>`` -> the committed data set's folder, or a folder outside the project."""
    where = REFERENCE_DIR / "reduced" if request.param == "data" else tmp_path
    path = RESULTS_DIR / f"zz-link-{request.param}-{os.getpid()}"
    RESULTS_DIR.mkdir(exist_ok=True)
    path.symlink_to(where, target_is_directory=True)
    yield path, where
    path.unlink()


@pytest.mark.parametrize("link", ["data", "outside"], indirect=True)
@pytest.mark.parametrize("writer", WRITERS)
def test_no_writer_writes_through_a_link_below_results(link, writer):
    path, where = link
    before = sorted(p.name for p in where.iterdir())
    with pytest.raises(PipelineError) as caught:
        WRITERS[writer](path)
    said = str(caught.value)
    assert "\n" not in said and ("the committed data is never written" in said or "lands outside results/" in said)
    assert sorted(p.name for p in where.iterdir()) == before


def test_a_committed_run_read_through_a_link_is_held_to_its_manifest(tmp_path):
    """A data folder with a manifest, reached through ``results/<link>``: a changed file is refused as if read in
    place."""
    root = tmp_path / "committed"
    run = root / "reduced" / "dem" / "theta090.h5"
    run.parent.mkdir(parents=True)
    run.write_bytes(b"the committed bytes")
    manifest.write(root)
    run.write_bytes(b"tampered bytes")
    path = RESULTS_DIR / f"zz-link-manifest-{os.getpid()}"
    RESULTS_DIR.mkdir(exist_ok=True)
    path.symlink_to(root / "reduced", target_is_directory=True)
    try:
        with pytest.raises(DemFileError, match="does not match its SHA-256"):
            manifest.check_committed(Path(path) / "dem" / "theta090.h5")
    finally:
        path.unlink()


@pytest.mark.parametrize("shape", ["folder is a file", "file is a folder"])
def test_an_output_folder_of_the_wrong_type_is_one_line_naming_it(tmp_path, shape):
    folder = RESULTS_DIR / f"zz-wrong-{os.getpid()}"
    RESULTS_DIR.mkdir(exist_ok=True)
    try:
        if shape == "folder is a file":
            folder.write_text("")
            expected = "is a file, not a folder"
        else:
            (folder / "options.txt").mkdir(parents=True)
            expected = "is a link or not a regular file"
        with pytest.raises(PipelineError, match=expected):
            targets.write_if_changed(folder / "options.txt", "x")
    finally:
        if folder.is_dir():
            (folder / "options.txt").rmdir()
            folder.rmdir()
        else:
            folder.unlink()


def test_an_unshare_that_hangs_is_waited_for_a_bounded_time_then_named_in_one_line(tmp_path, monkeypatch, capsys):
    """An ``unshare`` that never returns (a stuck namespace setup): the launcher waits ``UNSHARE_WAIT``, says so in one
    line and runs without a namespace of its own."""
    from pipeline.runs import launch

    fake = tmp_path / "unshare"
    fake.write_text("#!/bin/sh\nexec sleep 600\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{tmp_path}:{os.environ['PATH']}")
    monkeypatch.setattr(launch, "UNSHARE_WAIT", 0.5)
    launch.loopback_only.cache_clear()
    try:
        assert launch.loopback_only() is None
    finally:
        launch.loopback_only.cache_clear()
    said = capsys.readouterr().err.strip()
    assert said.count("\n") == 0 and "did not return within 0.5 s" in said


def test_a_read_only_output_folder_is_one_line_naming_it(tmp_path):
    """A folder on a read-only mount (a user and mount namespace of the test's own: ``unshare -rm``, as the launcher's
    network namespace), where root too cannot write: the fit's stamp is refused in one line naming the folder."""
    import subprocess
    import sys

    folder = tmp_path / "ro"
    (folder / "fit").mkdir(parents=True)
    stamp = folder / "fit" / "options.txt"
    script = (f"mount --bind {folder} {folder} && mount -o remount,bind,ro {folder} && "
              f"exec {sys.executable} -m pipeline.targets fit-options {stamp}")
    proc = subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, timeout=60,
                          cwd=Path(__file__).resolve().parents[2], env={**os.environ, "PRESET": "reduced"})
    said = proc.stderr.strip()
    assert proc.returncode == 2 and said.count("\n") == 0 and f"{folder / 'fit'} is not writable" in said, said
    assert not stamp.exists()


def _write_goals_many_times(folder: str) -> None:
    for i in range(40):
        targets.write_goal_values(Path(folder) / "goals.stamp", targets.GoalValues(DATA_SET=f"d{i % 2}"))


def test_two_makes_at_once_write_the_goals_without_tripping_on_each_other():
    """Two ``make`` in one checkout (two runs, one per core) write ``results/.make/goals/`` at once: each writer's
    temporary is its own, so neither finds its temporary taken by the other."""
    import multiprocessing

    folder = RESULTS_DIR / f"zz-goals-{os.getpid()}"
    folder.mkdir(parents=True, exist_ok=True)
    try:
        with multiprocessing.get_context("fork").Pool(3) as pool:
            pool.map(_write_goals_many_times, [str(folder)] * 6)
        assert (folder / "goals" / "DATA_SET").read_text() in {"d0", "d1"}
        assert not [p for p in folder.rglob("*") if ".tmp" in p.name]
    finally:
        import shutil

        shutil.rmtree(folder)
