"""The DEM launcher's run folder: spec bookkeeping before Yade starts (no Yade needed)."""

import json

import pytest

from pipeline.errors import SpecError
from pipeline.runs import launch as dem
from pipeline.runs import spec as run_spec


def test_prepare_writes_the_spec_and_refuses_a_checkpoint_of_another_spec(tmp_path):
    spec = run_spec.resolve(90, "tiny")
    run_dir = dem.prepare(spec, tmp_path, fresh=False)
    assert json.loads((run_dir / "spec.json").read_text()) == spec
    (run_dir / "checkpoint.yade.gz").write_bytes(b"x")
    other = run_spec.resolve(90, "tiny", overrides={"seed": 5.0})
    other["folder"] = spec["folder"]  # same folder, other physics
    with pytest.raises(SpecError, match="holds a checkpoint of another spec"):
        dem.prepare(other, tmp_path, fresh=False)
    assert dem.prepare(other, tmp_path, fresh=True) == run_dir  # --fresh starts again
    assert not (run_dir / "checkpoint.yade.gz").exists()


def test_an_existing_result_is_not_run_again(tmp_path, capsys):
    spec = run_spec.resolve(90, "tiny")
    out = run_spec.output_path(spec, tmp_path)
    out.parent.mkdir(parents=True)
    out.write_bytes(b"done")
    assert dem.run(spec, tmp_path) == out
    assert "is up to date" in capsys.readouterr().out
