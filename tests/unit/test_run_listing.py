"""A run's state from its files, and ``make runs``' listing of every run with its overrides."""

import json

from dem.core.rawfile import write_status
from pipeline.runs import listing
from pipeline.runs.state import progress, run_state
from tests.helpers import synthetic_file


def test_each_state_is_read_from_the_files_a_run_leaves(tmp_path):
    dem = tmp_path / "reduced-abc" / "dem"
    dem.mkdir(parents=True)
    run_dir = dem / "theta090_rot0.10.run"
    run_dir.mkdir()
    out = dem / "theta090_rot0.10.h5"
    assert run_state(run_dir, out) == ("not started", "")
    (run_dir / "checkpoint.json").write_text("{}")  # LAMMPS's checkpoint
    assert run_state(run_dir, out)[0] == "stopped"
    (run_dir / "checkpoint.json").unlink()
    (run_dir / "checkpoint.yade.gz").write_bytes(b"x")
    assert run_state(run_dir, out)[0] == "stopped"
    write_status(run_dir / "status.json", {"percent": 41.6, "steps_per_second": 1800.4, "eta_seconds": 725.0})
    assert progress(run_dir) == "42 %, 1800 steps/s, ETA 12m05s"
    assert run_state(run_dir, out) == ("stopped", "resumable from its checkpoint, reached 42 %: rerun the same command")
    (run_dir / "failed.json").write_text('{"reason": "wall normal stress off target"}')
    assert run_state(run_dir, out) == ("failed", "wall normal stress off target")
    (run_dir / "failed.json").write_text("not json")
    assert run_state(run_dir, out)[1].endswith("failed.json is damaged")
    (run_dir / "spec.json").write_text(json.dumps({"overrides": {"seed": 2.0}}))
    synthetic_file(dem, theta=180.0, name="theta180", n_cycles=1, overrides={"inertial_number": 0.003})
    summaries = tmp_path / "summaries"
    (summaries / "reduced-abc").mkdir(parents=True)
    (summaries / "reduced-abc" / "theta180.json").write_text("{}")
    (summaries / "reduced-xyz").mkdir()
    (summaries / "reduced-xyz" / "theta180.json").write_text('{"overrides": {"dt_safety": 0.3}}')
    rows = {f"{r['folder']}/{r['name']}": r for r in listing.runs((tmp_path,), summaries)}
    assert rows["reduced-abc/theta090_rot0.10"]["overrides"] == {"seed": 2.0}
    assert rows["reduced-abc/theta090_rot0.10"]["state"] == "failed"
    assert rows["reduced-abc/theta180"]["state"] == "done"
    assert rows["reduced-abc/theta180"]["overrides"] == {"inertial_number": 0.003}
    assert rows["reduced-abc/theta180"]["summary"].endswith("reduced-abc/theta180.json")
    assert rows["reduced-xyz/theta180"]["state"] == "summary only"
    assert "dt_safety=0.3" in listing.text(list(rows.values()))
