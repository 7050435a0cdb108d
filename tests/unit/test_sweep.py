"""A sweep's plan as data, its local makefile and its SLURM batch script, without running anything."""

import json

import pytest

from pipeline.errors import PipelineError, SpecError
from pipeline.runs.sweep import local, slurm
from pipeline.runs.sweep.plan import plan, read_plan, write_plan
from pipeline.runs.sweep.status import status
from pipeline.spec import output_path
from tests.helpers import module_main


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


def test_a_lammps_sweep_plans_lammps_runs_and_reads_back_as_written(tmp_path):
    sweep = plan("reduced", "90 180", seeds="1 2", results=tmp_path, engine="lammps")
    assert all(t.engine == "lammps" and t.spec().engine == "lammps" for t in sweep.tasks)
    assert all(t.output.parts[-3].startswith("reduced-lammps") for t in sweep.tasks)
    assert sweep.tasks[0].args[:6] == ("--theta", "90", "--preset", "reduced", "--engine", "lammps")
    assert sweep.ident != plan("reduced", "90 180", seeds="1 2", results=tmp_path).ident
    write_plan(sweep)
    assert read_plan(tmp_path) == sweep
    with pytest.raises(SpecError, match="engine='foo' is not a DEM engine"):
        plan("reduced", "90", results=tmp_path, engine="foo")


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


def test_a_lammps_sweep_on_slurm_asks_one_task_per_rank_and_bounds_checkpoints_at_lammps_rates(tmp_path,
                                                                                                monkeypatch):
    monkeypatch.setattr(slurm.shutil, "which", lambda tool: f"/usr/bin/{tool}")  # as if SLURM's tools were here
    cluster = slurm.load_cluster_config()
    config = slurm.apply_overrides(cluster["slurm"], ["ranks_per_run=4"], "slurm")
    sweep = plan("paper", "180", results=tmp_path, engine="lammps")
    script = slurm.job_script(sweep, config, [0])
    assert "--ntasks=4 --cpus-per-task=1" in script.replace("\n#SBATCH ", " ") and "--ranks 4" in script
    slurm.check_slurm(config, sweep, cluster["throughput"])
    # a checkpoint interval of the paper cell: 30000 steps at LAMMPS's 250 steps/s (Yade's 20 would be 1500 s)
    short = slurm.apply_overrides(config, ["signal_lead_seconds=150", "time_limit=00:10:00"], "slurm")
    with pytest.raises(SpecError, match="shorter than a checkpoint interval of preset paper \\(about 120 s\\)"):
        slurm.check_slurm(slurm.apply_overrides(short, ["signal_lead_seconds=100"], "slurm"), sweep,
                          cluster["throughput"])
    slurm.check_slurm(short, sweep, cluster["throughput"])
    with pytest.raises(SpecError, match="signal_lead_seconds=150 is shorter than a checkpoint interval"):
        slurm.check_slurm(slurm.apply_overrides(short, ["ranks_per_run=1"], "slurm"),
                          plan("paper", "180", results=tmp_path), cluster["throughput"])
    with pytest.raises(SpecError, match="ranks_per_run=4: MPI ranks are for ENGINE=lammps"):
        slurm.check_slurm(config, plan("paper", "180", results=tmp_path), cluster["throughput"])
    with pytest.raises(SpecError, match="ranks_per_run=0 must be between 1 and 256"):
        slurm.check_slurm(slurm.apply_overrides(config, ["ranks_per_run=0"], "slurm"), sweep, cluster["throughput"])
    with pytest.raises(SpecError, match="threads_per_run=2: threads are for ENGINE=yade \\(lammps runs on MPI ranks"):
        slurm.check_slurm(slurm.apply_overrides(config, ["threads_per_run=2"], "slurm"), sweep, cluster["throughput"])


def test_a_plan_with_runs_outside_results_or_too_many_runs_is_refused(tmp_path):
    from pipeline.runs.sweep.plan import MAX_TASKS

    sweep = plan("reduced", "90", results=tmp_path)
    write_plan(sweep)
    data = json.loads((sweep.folder / "plan.json").read_text())
    data["tasks"][0]["output"] = "/etc/passwd.h5"
    (sweep.folder / "plan.json").write_text(json.dumps(data))
    with pytest.raises(PipelineError, match="names a run outside"):
        read_plan(tmp_path)
    many = " ".join(f"{1 + t / 10:g}" for t in range(MAX_TASKS + 1))
    with pytest.raises(SpecError, match=f"has {MAX_TASKS + 1} runs, more than {MAX_TASKS}: MANY=1"):
        plan("reduced", many, results=tmp_path)
    assert len(plan("reduced", many, results=tmp_path, allow_many=True).tasks) == MAX_TASKS + 1


def test_jobs_zero_is_refused_not_taken_as_the_default(tmp_path):
    main = module_main("pipeline.runs.sweep")
    from tests.helpers import run_main

    proc = run_main(main, ["run", "--preset", "tiny", "--thetas", "90", "--jobs", "0", "--results", str(tmp_path)])
    assert proc.returncode == 2 and "jobs=0 must be >= 1" in proc.stderr
    assert not (tmp_path / "sweeps").exists()


def test_sweep_status_shows_damaged_runs_on_one_line_each(tmp_path):
    sweep = plan("reduced", "30 60 90", results=tmp_path)
    a, b, c = sweep.tasks
    a.run_dir.mkdir(parents=True)
    (a.run_dir / "failed.json").write_text("{not json")
    b.run_dir.mkdir(parents=True)
    (b.run_dir / "failed.json").write_text(json.dumps({"exit_status": 1}))
    c.run_dir.with_suffix(".lock").mkdir(parents=True)  # a lock that is a folder
    rows = status(sweep)
    assert [r["state"] for r in rows] == ["failed", "failed", "not started"]
    assert "is damaged" in rows[0]["detail"] and "failed.json is damaged" in rows[1]["detail"]


def test_a_submitted_sweep_whose_queue_cannot_be_read_is_neither_told_to_rerun_nor_submitted_again(tmp_path,
                                                                                                     monkeypatch):
    sweep = plan("reduced", "30 60", results=tmp_path)
    a, _ = sweep.tasks
    a.run_dir.mkdir(parents=True)
    (a.run_dir / "checkpoint.json").write_text("{}")
    (a.run_dir / "status.json").write_text('{"percent": 49.2}')
    assert status(sweep)[0]["detail"] == "resumable from its checkpoint, reached 49 %: rerun the sweep"  # unsubmitted
    sweep.folder.mkdir(parents=True, exist_ok=True)
    (sweep.folder / "jobs.txt").write_text("41\n")
    monkeypatch.setenv("PATH", str(tmp_path / "no-slurm-here"))  # a login shell without the SLURM module
    rows = status(sweep)
    assert [r["state"] for r in rows] == ["stopped", "not started"]
    assert rows[0]["detail"].endswith("check before rerunning, reached 49 %")
    for row in rows:
        assert "SLURM's queue unread (squeue is not on PATH)" in row["detail"]
        assert "rerun the sweep" not in row["detail"]
    config = slurm.load_cluster_config()["slurm"]
    with pytest.raises(slurm.QueueUnreadable, match="cannot tell which runs of sweep .* are queued already"):
        slurm.submit(sweep, config)
    assert not (sweep.folder / "job.sh").exists()


def test_the_batch_script_quotes_its_log_path_and_requeues_only_what_can_resume(tmp_path):
    folder = tmp_path / "a clone with spaces"
    sweep = plan("reduced", "180", results=folder)
    config = slurm.load_cluster_config()["slurm"]
    script = slurm.job_script(sweep, config, [0])
    assert f'#SBATCH --output="{sweep.folder}/logs/task-%a.out"' in script
    assert "130|137|138|143) ;;" in script and "failed (exit $status), not requeued" in script
    bad = plan("reduced", "180", results=tmp_path / 'say "hi"')
    with pytest.raises(SpecError, match="double quote or a newline"):
        slurm.job_script(bad, config, [0])


def test_a_local_sweep_whose_runs_another_process_finished_reports_them_done(tmp_path, monkeypatch, capsys):
    sweep = plan("reduced", "90 180", results=tmp_path)
    for task in sweep.tasks:
        task.output.parent.mkdir(parents=True, exist_ok=True)
        task.output.write_bytes(b"")  # done by a concurrent sweep of the same plan
    monkeypatch.setattr(local.subprocess, "call", lambda *a, **k: 2)  # this sweep's launches were refused
    assert local.run_local(sweep, 2) == 0
    assert "2 run(s) done" in capsys.readouterr().out


def test_sweep_collect_reads_the_data_set_of_the_sweeps_runs(tmp_path):
    sweep = plan("paper", "90 180", seeds="1 2", overrides=["inertial_number=0.001"], results=tmp_path,
                 engine="lammps")
    assert sweep.data_set_settings() == ["PRESET=paper", "ENGINE=lammps", "SET=inertial_number=0.001"]
    assert plan("reduced", "180", seeds="2 3", results=tmp_path).data_set_settings() == [
        "PRESET=reduced", "ENGINE=yade", "SET="]
    write_plan(sweep)
    plan_json = json.loads((sweep.folder / "plan.json").read_text())
    plan_json["tasks"][0]["overrides"] = ["$(touch INJECTED)=1"]
    (sweep.folder / "plan.json").write_text(json.dumps(plan_json))
    with pytest.raises(SpecError, match="unknown override key"):
        read_plan(tmp_path).data_set_settings()


def test_a_local_lammps_sweep_runs_each_run_on_its_ranks_and_refuses_ranks_it_cannot_use(tmp_path, capsys):
    """``make sweep ENGINE=lammps RANKS=2``: every rule of the sweep's makefile launches its run on two MPI ranks
    (one run at a time on two cores by default); ranks for Yade, ranks that contradict SLURM=ranks_per_run, and
    no ranks are one-line errors before anything runs."""
    main = module_main("pipeline.runs.sweep")

    sweep = plan("tiny", "90 180", results=tmp_path, engine="lammps")
    for task in sweep.tasks:  # as if done: Make has nothing to run
        task.output.parent.mkdir(parents=True, exist_ok=True)
        task.output.touch()
    args = ["run", "--preset", "tiny", "--thetas", "90 180", "--engine", "lammps", "--results", str(tmp_path)]
    assert main([*args, "--ranks", "2"]) == 0
    rules = (read_plan(tmp_path).folder / "runs.mk").read_text()
    assert rules.count("--ranks 2") == 2
    assert main(args) == 0 and "--ranks" not in (read_plan(tmp_path).folder / "runs.mk").read_text()
    cases = [([*args[:-4], "--results", str(tmp_path), "--ranks", "2"], "ranks=2: MPI ranks are for ENGINE=lammps"),
             ([*args, "--ranks", "2", "--slurm", "ranks_per_run=4"], "ranks=2 and slurm ranks_per_run=4 disagree"),
             ([*args, "--ranks", "0"], "ranks=0 must be between 1 and 256")]
    for argv, message in cases:
        capsys.readouterr()
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, err
