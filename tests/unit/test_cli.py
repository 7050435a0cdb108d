import numpy as np
import pandas as pd
import pytest

from model import Params, predict
from model.cli import CSV_COLUMNS, main
from tests.helpers import run_main


def run_cli(*args):
    return run_main(main, args)


def test_predict_writes_the_cycle_as_csv(tmp_path):
    out = tmp_path / "sub" / "cycle.csv"
    assert main(["predict", "--theta", "90", "--rotate-at", "0.2", "--times", "0,0.2,0.5,1.4",
                 "--out", str(out)]) == 0
    table = pd.read_csv(out)
    assert list(table.columns) == list(CSV_COLUMNS)
    expected = predict(90, rotate_at=0.2, times=[0, 0.2, 0.5, 1.4])
    np.testing.assert_allclose(table["tau23"], expected.tau[:, 1, 2], rtol=1e-10)
    np.testing.assert_allclose(table["phi"], expected.packing_fraction, rtol=1e-10)
    np.testing.assert_allclose(table["w_shear"] + table["w_vol"], expected.w_total, rtol=1e-9)
    assert not list(tmp_path.rglob("*.tmp"))


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_files_written_get_the_umasks_permissions(tmp_path, umask, mode):
    """As a plain open() would: a group that may read the folder may read the cycle and the parameters."""
    import os

    before = os.umask(umask)
    try:
        assert main(["predict", "--theta", "90", "--times", "0,1.4", "--out", str(tmp_path / "c.csv")]) == 0
        assert main(["params", "--out", str(tmp_path / "p.json")]) == 0
    finally:
        os.umask(before)
    for name in ("c.csv", "p.json"):
        assert (tmp_path / name).stat().st_mode & 0o777 == mode, name


def test_params_file_round_trip(tmp_path):
    path = tmp_path / "p.json"
    assert main(["params", "--out", str(path)]) == 0
    path.write_text(path.read_text().replace('"C": -5.6', '"C": -4.0').replace('"c1": 5.6', '"c1": 4.0'))
    out = tmp_path / "c.csv"
    assert main(["predict", "--theta", "180", "--params", str(path), "--times", "1.4", "--out", str(out)]) == 0
    expected = predict(180, params=Params().replace(C=-4.0, c1=4.0), times=[1.4])  # Eq. 19: c1 = -C
    assert pd.read_csv(out)["tau12"].iloc[0] == pytest.approx(expected.tau[0, 0, 1], rel=1e-10)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--theta", "abc"], "--theta: 'abc' is not a number"),
        (["--theta", "nan"], "--theta: 'nan' is not a finite number"),
        (["--theta", "90", "--rotate-at", "-0.1"], "--rotate-at: '-0.1' must be > 0"),
        (["--theta", "90", "--times", "0,x"], "'x' is not a number"),
        (["--theta", "90", "--times", "0,2"], "time 2 lies outside"),
    ],
)
def test_bad_input_is_one_line_and_nonzero(tmp_path, args, message):
    proc = run_cli("predict", *args, "--out", str(tmp_path / "x.csv"))
    assert proc.returncode == 2
    assert message in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "x.csv").exists()


def test_params_file_with_unknown_or_missing_keys(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"C": -5.6, "mu": 0.3}')
    proc = run_cli("predict", "--theta", "90", "--params", str(bad), "--out", str(tmp_path / "x.csv"))
    assert proc.returncode == 2
    assert "unknown keys mu; missing keys n, m" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_help_explains_every_option():
    text = run_cli("predict", "--help").stdout
    for option in ("--theta", "--rotate-at", "--params", "--times", "--out", "t_gd", "tau/p"):
        assert option in text


@pytest.mark.slow
def test_python_m_model_runs_as_a_process_with_one_line_errors(tmp_path):
    import subprocess
    import sys

    command = [sys.executable, "-m", "model", "predict", "--theta", "abc", "--out", str(tmp_path / "x.csv")]
    proc = subprocess.run(command, capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0 and "'abc' is not a number" in proc.stderr


def test_an_output_that_is_a_link_is_refused_and_left_as_it_was(tmp_path):
    """Renaming onto a link replaces the link (``--out /dev/stdout`` would replace the system's): refused, in the
    model's command line and in the pipeline's writer alike, and the link and its target stay."""
    from pipeline import io
    from pipeline.errors import PipelineError

    target = tmp_path / "target.json"
    target.write_text("kept")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    said = run_main(main, ["params", "--out", str(link)])
    assert said.returncode == 2 and "is a link" in said.stderr
    with pytest.raises(PipelineError, match="is a link or not a regular file"):
        io.write_text(link, "new")
    assert link.is_symlink() and target.read_text() == "kept"


def test_results_as_a_link_is_refused_before_anything_is_written_there(tmp_path, monkeypatch):
    from pipeline import io
    from pipeline.errors import PipelineError

    data = tmp_path / "data"
    data.mkdir()
    results = tmp_path / "results"
    results.symlink_to(data)
    monkeypatch.setattr(io, "RESULTS_DIR", results)
    with pytest.raises(PipelineError, match="results is a link"):
        io.write_text(results / "fit" / "params.json", "{}")
    assert not any(data.iterdir())


def test_text_from_a_file_or_the_command_line_reaches_the_terminal_escaped(tmp_path):
    """A key of a params file (or any value echoed in an error) holding an escape sequence or a line break is shown
    as its Python escape, in the model's command line and the pipeline's alike: one line of plain text."""
    from pipeline.calibration.__main__ import main as fit_main

    bad = tmp_path / "bad.json"
    bad.write_text('{"C": -5, "\\u001b[31mred\\nline": 1}')
    said = run_main(main, ["predict", "--theta", "90", "--params", str(bad), "--out", str(tmp_path / "o.csv")])
    assert said.returncode == 2 and "unknown keys \\x1b[31mred\\nline" in said.stderr
    assert "\x1b" not in said.stderr and said.stderr.count("\n") == 1
    said = run_main(fit_main, ["--preset", "paper\x1b[2J"])
    assert said.returncode == 2 and "\x1b" not in said.stderr and "\\x1b[2J" in said.stderr
