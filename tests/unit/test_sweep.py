"""A sweep's plan as data, its local makefile and its SLURM batch script, without running anything."""

import json

import pytest

from pipeline.errors import PipelineError, SpecError
from pipeline.runs.spec import output_path
from pipeline.runs.sweep import local, slurm
from pipeline.runs.sweep.plan import plan, read_plan, write_plan
from pipeline.runs.sweep.status import status


def test_a_plan_is_every_combination_once_and_reads_back_as_written(tmp_path):
    sweep = plan("reduced", "90 180", "0.1", "1 2", ["n_cycles=1"], tmp_path)
    assert len(sweep.tasks) == 4 and len({t.output for t in sweep.tasks}) == 4
    for task in sweep.tasks:
        assert output_path(task.spec(), tmp_path) == task.output  # the launcher makes exactly that run
    assert sweep.tasks[0].args[:4] == ("--theta", "90", "--preset", "reduced")
    assert "seed=2" in sweep.tasks[-1].overrides and "seed=1" not in sweep.tasks[0].overrides  # 1 is the default
    write_plan(sweep)
    assert read_plan(tmp_path) == sweep
    assert [r["state"] for r in status(sweep)] == ["not started"] * 4
    plan_json = json.loads((sweep.folder / "plan.json").read_text())
    (sweep.folder / "plan.json").write_text(json.dumps({**plan_json, "preset": "$(shell touch INJECTED)"}))
    with pytest.raises(PipelineError, match="preset '\\$\\(shell touch INJECTED\\)' is not a valid name"):
        read_plan(tmp_path)
    with pytest.raises(PipelineError, match="sweep '../../x' is not a valid name"):
        read_plan(tmp_path, "../../x")
    (sweep.folder / "plan.json").write_text(json.dumps({"id": "x", "tasks": [{"args": []}]}))
    with pytest.raises(PipelineError, match="is not a plan of this version"):
        read_plan(tmp_path)
    with pytest.raises(SpecError, match="THETAS is empty"):
        plan("reduced", " ", results=tmp_path)


def test_the_local_makefile_and_the_batch_script_run_the_launcher_of_make_dem(tmp_path):
    sweep = plan("reduced", "180", results=tmp_path)
    makefile = local.local_makefile(sweep)
    assert f"{sweep.tasks[0].output}:" in makefile and "-m pipeline.runs run --theta 180 --preset reduced" in makefile
    config = slurm.apply_overrides(slurm.load_cluster_config()["slurm"], ["time_limit=24:00:00", "max_requeues=5"],
                                   "slurm")
    script = slurm.job_script(sweep, config, [0])
    assert "@" not in script.replace("USR1@", "").replace('"${ARGS[@]}"', "")  # every field filled
    assert f"#SBATCH --job-name={sweep.job_name}" in script and "#SBATCH --array=0" in script
    assert '-lt 5 ]' in script and "scontrol requeue" in script and f"--results {tmp_path}" in script
    with pytest.raises(SpecError, match="max_requeues='x' must be a whole number"):
        slurm.apply_overrides(config, ["max_requeues=x"], "slurm")
