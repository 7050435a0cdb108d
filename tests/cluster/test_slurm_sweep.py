"""A sweep on a real SLURM: munged, slurmctld and slurmd started here on the loopback (a generated
slurm.conf in a temporary folder; nothing left running), a tiny sweep of three angles submitted as one
job array, one task warned with SIGUSR1 (it checkpoints, requeues itself and resumes), another's
process killed outright (requeued and resumed), a failing run not requeued; every HDF5 file identical
to a local run of the same specs. Then a LAMMPS sweep at two MPI ranks per task, with a warned task.
`make test-cluster` runs it (Debian's slurm-wlm and munge)."""

import getpass
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from pipeline import spec as run_spec
from pipeline.dataset.dem_file import load
from pipeline.paths import ROOT
from pipeline.runs.state import STATUS, read_json
from pipeline.runs.sweep import plan as sweep_plan
from pipeline.runs.sweep import slurm as sweep_slurm
from pipeline.runs.sweep import status as sweep_status
from tests.helpers.sockets import listening_inodes, scene_ranks, socket_inodes

pytestmark = [pytest.mark.yade, pytest.mark.slurm]

THETAS = "90 180"  # one warned, the other killed: both at once on the node's two CPUs
LONGER = ["--set", "n_cycles=3"]  # about 15 s a run here: time to warn one and kill another mid-run
SLURM = ["--slurm", "time_limit=00:10:00", "--slurm", "signal_lead_seconds=60", "--slurm", "memory=1G"]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(predicate, timeout, what, explain=lambda: ""):
    end = time.time() + timeout
    while time.time() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}\n{explain()}")


def cluster_state(base: Path, plan) -> str:
    """What a stuck sweep looks like: the queue with its reasons, the node, each task's state and log, and the
    daemons' last lines."""
    def run(*cmd):
        return subprocess.run(cmd, capture_output=True, text=True).stdout.strip()

    parts = [f"squeue: {run('squeue', '-h', '-o', '%i %T %r %C')}", f"sinfo: {run('sinfo', '-h', '-o', '%T %E %C')}",
             f"tasks: {sweep_status.status(plan)}"]
    for log in sorted((plan.folder / "logs").glob("*.out")):
        parts.append(f"--- {log.name}\n{log.read_text()[-3000:]}")
    for task in plan.tasks:
        for name in ("log.txt", "failed.json"):
            if (task.run_dir / name).exists():
                parts.append(f"--- {task.label} {name}\n{(task.run_dir / name).read_text()[-3000:]}")
    for name in ("slurmctld.log", "slurmd.log"):
        lines = (base / "log" / name).read_text().splitlines() if (base / "log" / name).exists() else []
        parts.append(f"--- {name}\n" + "\n".join(lines[-40:]))
    return "\n".join(parts)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A one-node SLURM cluster with its own munged, on the loopback; torn down afterwards."""
    for tool in ("munged", "mungekey", "slurmctld", "slurmd", "sbatch", "squeue", "scontrol", "scancel"):
        assert shutil.which(tool), f"{tool} is missing: `make system-slurm` installs slurm-wlm and munge"
    base = tmp_path_factory.mktemp("slurm")
    for sub in ("munge", "state", "spool", "log"):
        (base / sub).mkdir()
    key, sock = base / "munge" / "munge.key", base / "munge" / "socket"
    subprocess.run(["mungekey", "--create", f"--keyfile={key}"], check=True)
    key.chmod(0o600)
    subprocess.run(["munged", f"--socket={sock}", f"--key-file={key}", f"--pid-file={base / 'munge' / 'pid'}",
                    f"--log-file={base / 'munge' / 'log'}", f"--seed-file={base / 'munge' / 'seed'}", "--force"],
                   check=True)
    user = getpass.getuser()
    conf = base / "slurm.conf"
    conf.write_text(f"""ClusterName=gbtest
SlurmctldHost=localhost
SlurmctldPort={free_port()}
SlurmdPort={free_port()}
AuthType=auth/munge
AuthInfo=socket={sock}
CredType=cred/munge
SlurmUser={user}
SlurmdUser={user}
StateSaveLocation={base / 'state'}
SlurmdSpoolDir={base / 'spool'}
SlurmctldPidFile={base / 'slurmctld.pid'}
SlurmdPidFile={base / 'slurmd.pid'}
SlurmctldLogFile={base / 'log' / 'slurmctld.log'}
SlurmdLogFile={base / 'log' / 'slurmd.log'}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
JobRequeue=1
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
MinJobAge=600
NodeName=localhost NodeAddr=127.0.0.1 CPUs=2 RealMemory=4000 State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
""")
    previous = os.environ.get("SLURM_CONF")
    os.environ["SLURM_CONF"] = str(conf)
    subprocess.run(["slurmctld", "-f", str(conf)], check=True)
    subprocess.run(["slurmd", "-f", str(conf), "-N", "localhost"], check=True)
    try:
        wait_for(lambda: "idle" in subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True,
                                                  text=True).stdout, 60, "the node to come up")
        yield base
    finally:
        subprocess.run(["scancel", "--full", f"--user={user}"], capture_output=True)
        wait_for(lambda: not subprocess.run(["squeue", "-h"], capture_output=True, text=True).stdout.strip(), 60,
                 "the queue to empty")
        daemons = subprocess.run(["pgrep", "-f", str(base)], capture_output=True, text=True).stdout.split()
        for pid in map(int, daemons):
            os.kill(pid, signal.SIGTERM)
        wait_for(lambda: not subprocess.run(["pgrep", "-f", str(base)], capture_output=True).stdout, 60,
                 "slurmd, slurmctld and munged to stop")
        if previous is None:
            os.environ.pop("SLURM_CONF", None)
        else:
            os.environ["SLURM_CONF"] = previous


def sweep_cli(*args):
    return subprocess.run([sys.executable, "-m", "pipeline.runs.sweep", *args], cwd=ROOT, capture_output=True,
                          text=True)


def job_id(results: Path, ident: str) -> str:
    return (results / "sweeps" / ident / "jobs.txt").read_text().split()[-1]


#: how long a requeued task stays pending before it is released: its last attempt's batch step must be cleaned
#: up on the node first (released at once, the new attempt's launch fails there with exit 1)
SETTLE_SECONDS = 5.0


def release_requeued(plan, job: str, pending_since: dict):
    """A requeued task waits for its BeginTime (SLURM's requeue delay, 2 minutes): start it once it has been
    pending ``SETTLE_SECONDS``."""
    now = time.time()
    for k, (state, reason) in sweep_slurm.queue(plan).items():
        if state == "PENDING" and reason == "BeginTime":
            if now - pending_since.setdefault(k, now) >= SETTLE_SECONDS:
                subprocess.run(["scontrol", "update", f"JobId={job}_{k}", "StartTime=now"], capture_output=True)
                pending_since.pop(k)


def progressed(plan, task, percent):
    status = read_json(plan.tasks[task].run_dir / STATUS)
    return bool(status) and status.get("percent", 0) >= percent


def scene_pids(run_dir: Path) -> list[int]:
    out = subprocess.run(["pgrep", "-f", f"dem.yade.scene {run_dir}"], capture_output=True, text=True).stdout
    return [int(p) for p in out.split()]


def test_a_sweep_survives_a_warning_a_killed_process_and_matches_a_local_run(cluster, tmp_path):
    local, remote = tmp_path / "local", tmp_path / "slurm"
    tic = time.time()
    proc = sweep_cli("run", "--preset", "tiny", "--thetas", THETAS, *LONGER, "--results", str(local))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    local_seconds = time.time() - tic

    tic = time.time()
    proc = sweep_cli("run", "--preset", "tiny", "--thetas", THETAS, *LONGER, "--launch", "slurm", *SLURM,
                     "--results", str(remote))
    assert proc.returncode == 0 and "submitted job array" in proc.stdout, proc.stdout + proc.stderr
    plan = sweep_plan.read_plan(remote)
    job = job_id(remote, plan.ident)
    table_states = set()
    pending_since = {}

    def poll():
        release_requeued(plan, job, pending_since)  # the admin who will not wait for a requeue delay
        rows = sweep_status.status(plan)
        out = sweep_cli("status", "--results", str(remote)).stdout  # what `make sweep-status` prints
        table_states.update(s for s in ("done", "running", "queued", "failed", "stopped") if f"  {s}" in out)
        return rows

    # one task warned as before a time limit (checkpoint, requeue, resume); another's scene killed outright
    # (the task requeues itself); both resume from their last checkpoint
    acted = {}

    def act():
        rows = poll()
        for row in rows:
            k = row["task"]
            if row["state"] != "running" or k in acted.values():
                continue
            if "warned" not in acted and progressed(plan, k, 20):
                subprocess.run(["scancel", "--signal=USR1", "--batch", f"{job}_{k}"], check=True)
                acted["warned"] = k
            elif "killed" not in acted and progressed(plan, k, 10) and (pids := scene_pids(plan.tasks[k].run_dir)):
                for pid in pids:
                    os.kill(pid, signal.SIGKILL)
                acted["killed"] = k
        return all(r["state"] == "done" for r in rows)

    wait_for(act, 600, "every run of the sweep to finish", lambda: cluster_state(cluster, plan))
    slurm_seconds = time.time() - tic
    assert {"running", "queued", "done"} <= table_states, table_states
    assert set(acted) == {"warned", "killed"}, acted
    logs = remote / "sweeps" / plan.ident / "logs"
    warned, killed = (logs / f"task-{acted[k]}.out" for k in ("warned", "killed"))
    assert "stopped (exit 138); requeued to resume from its checkpoint" in warned.read_text()
    assert "killed by signal 9" in killed.read_text() and "stopped (exit 137); requeued" in killed.read_text()
    for log in (warned, killed):
        assert "attempt 2" in log.read_text() and "resumed from checkpoint" in log.read_text()
    for task in plan.tasks:
        mine, theirs = load(task.output), load(local / task.output.relative_to(remote))
        for key, value in theirs.raw.items():
            np.testing.assert_array_equal(mine.raw[key], value, err_msg=f"{task.label}: {key}")
    print(f"local sweep {local_seconds:.0f} s; SLURM sweep with a warning and a kill {slurm_seconds:.0f} s")


def test_a_run_that_fails_with_the_dem_diagnostic_is_not_requeued(cluster, tmp_path):
    proc = sweep_cli("run", "--preset", "tiny", "--thetas", "90", "--set", "compaction_max_time=5",
                     "--launch", "slurm", *SLURM, "--results", str(tmp_path))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    plan = sweep_plan.read_plan(tmp_path)
    row = wait_for(lambda: next((r for r in sweep_status.status(plan) if r["state"] == "failed"), None), 180,
                   "the run to fail")
    assert "compaction did not converge" in row["detail"]
    log = tmp_path / "sweeps" / plan.ident / "logs" / "task-0.out"
    wait_for(lambda: "not requeued" in log.read_text(), 60, "the task to end")
    time.sleep(2)
    assert not sweep_slurm.queue(plan), "a failed task is back in the queue"
    assert "attempt 2" not in log.read_text()
    status = sweep_cli("status", "--results", str(tmp_path)).stdout
    assert "failed" in status and "compaction did not converge" in status


def test_bad_sweeps_are_refused_before_anything_is_submitted(cluster, tmp_path):
    cases = [
        (["--thetas", "30 ninety"], "theta='ninety' is not a number"),
        (["--thetas", ""], "THETAS is empty"),
        (["--thetas", "30", "--set", "colour=1"], "unknown override key(s) colour"),
        (["--thetas", "30", "--slurm", "time_limit=00:00:30"], "is shorter than a checkpoint interval"),
        (["--thetas", "30", "--slurm", "time_limit=soon"], "time_limit='soon' is not [D-]HH:MM:SS"),
        (["--thetas", "30", "--slurm", "signal_lead_seconds=0"], "signal_lead_seconds=0 is shorter than"),
        (["--thetas", "30", "--slurm", "queue=fast"], "override 'queue=fast' is not key=value with a known key"),
        (["--thetas", "30", "--slurm", "partition=a;b"], "partition='a;b' is not a valid name"),
        (["--thetas", "30", "--slurm", "ranks_per_run=2"], "ranks_per_run=2: MPI ranks are for ENGINE=lammps"),
    ]
    for args, fragment in cases:
        proc = sweep_cli("run", "--preset", "tiny", *args, "--launch", "slurm", "--results", str(tmp_path))
        assert proc.returncode == 2 and fragment in proc.stderr, (args, proc.stderr)
        assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr
    env = {**os.environ, "PATH": "/nonexistent"}
    proc = subprocess.run([sys.executable, "-m", "pipeline.runs.sweep", "run", "--preset", "tiny", "--thetas", "30",
                           "--launch", "slurm", "--results", str(tmp_path)], cwd=ROOT, capture_output=True,
                          text=True, env=env)
    assert proc.returncode == 2 and "sbatch not found on PATH" in proc.stderr
    assert not (tmp_path / "sweeps").exists()
    out = subprocess.run(["squeue", "-h"], capture_output=True, text=True).stdout
    assert "gb-tiny" not in out


def test_a_rerun_submits_no_queued_run_twice_and_a_controller_out_of_reach_is_said(cluster, tmp_path):
    """The node drained, so that the tasks stay queued: a rerun of the sweep submits nothing; with the controller
    out of reach, status says the queue is unread (not "rerun") and a rerun refuses in one line."""
    subprocess.run(["scontrol", "update", "NodeName=localhost", "State=DRAIN", "Reason=queued-test"], check=True)
    args = ("run", "--preset", "tiny", "--thetas", "30 90", "--launch", "slurm", *SLURM, "--results", str(tmp_path))
    try:
        first, again = sweep_cli(*args), sweep_cli(*args)
        assert "submitted job array" in first.stdout, first.stdout + first.stderr
        assert again.returncode == 0 and "nothing submitted" in again.stdout, again.stdout + again.stderr
        plan = sweep_plan.read_plan(tmp_path)
        assert len((plan.folder / "jobs.txt").read_text().split()) == 1
        assert [r["state"] for r in sweep_status.status(plan)] == ["queued", "queued"]
        dead = tmp_path / "unreachable.conf"
        conf = (cluster / "slurm.conf").read_text()
        dead.write_text(re.sub(r"SlurmctldPort=\d+", f"SlurmctldPort={free_port()}", conf))
        env = {**os.environ, "SLURM_CONF": str(dead)}
        status = subprocess.run([sys.executable, "-m", "pipeline.runs.sweep", "status", "--results", str(tmp_path)],
                                cwd=ROOT, capture_output=True, text=True, env=env).stdout
        assert status.count("SLURM's queue unread (squeue: ") == 2 and "rerun the sweep" not in status, status
        third = subprocess.run([sys.executable, "-m", "pipeline.runs.sweep", *args], cwd=ROOT, capture_output=True,
                               text=True, env=env)
        assert third.returncode == 2 and "nothing was submitted" in third.stderr, third.stderr
        assert len(third.stderr.strip().splitlines()) == 1
        assert len((plan.folder / "jobs.txt").read_text().split()) == 1
    finally:
        subprocess.run(["scancel", f"--name={sweep_plan.read_plan(tmp_path).job_name}"], capture_output=True)
        subprocess.run(["scontrol", "update", "NodeName=localhost", "State=RESUME"], check=True)


def warn_once_running(base, plan, job, percent):
    """Release requeued tasks at once; warn (SIGUSR1, as before a time limit) the first task past ``percent``;
    true when every run is done, an error (with the cluster's state) as soon as one has failed. Returns a poller
    for ``wait_for`` and the set of warned tasks."""
    warned, pending_since = set(), {}

    def poll():
        release_requeued(plan, job, pending_since)
        rows = sweep_status.status(plan)
        assert not any(r["state"] == "failed" for r in rows), cluster_state(base, plan)
        for row in rows:
            if not warned and row["state"] == "running" and progressed(plan, row["task"], percent):
                subprocess.run(["scancel", "--signal=USR1", "--batch", f"{job}_{row['task']}"], check=True)
                warned.add(row["task"])
        return all(r["state"] == "done" for r in rows)

    return poll, warned


@pytest.mark.lammps
def test_a_lammps_sweep_runs_two_ranks_per_task_and_survives_a_warning(cluster, tmp_path):
    """``make sweep ENGINE=lammps LAUNCH=slurm SLURM=ranks_per_run=2``: the task asks SLURM for two tasks (cores)
    and runs the launcher, which runs the scene under mpirun inside the allocation; warned, it checkpoints,
    requeues and resumes with every sample. (A multi-rank resume is not bit-identical: the ranks' sums change
    order. The Yade sweep above tests the array and the identity with a local run; test_dem_lammps the one-rank
    resume's identity.)"""
    proc = sweep_cli("run", "--preset", "tiny", "--thetas", "180", "--engine", "lammps", *LONGER, "--launch", "slurm",
                     *SLURM, "--slurm", "ranks_per_run=2", "--results", str(tmp_path))
    assert proc.returncode == 0 and "submitted job array" in proc.stdout, proc.stdout + proc.stderr
    plan = sweep_plan.read_plan(tmp_path)
    job = job_id(tmp_path, plan.ident)
    assert "--ntasks=2" in (tmp_path / "sweeps" / plan.ident / "job.sh").read_text()
    poll, warned = warn_once_running(cluster, plan, job, 20)
    (task,) = plan.tasks
    looked = []  # per look at the two running ranks: the listening sockets they hold

    def poll_and_look():
        ranks = scene_ranks(task.run_dir)
        if len(ranks) == 2 and len(looked) < 3:
            listening = set(listening_inodes())
            looked.append([socket_inodes(pid) & listening for pid in ranks])
        return poll()

    wait_for(poll_and_look, 300, "the LAMMPS run of the sweep to finish", lambda: cluster_state(cluster, plan))
    # a job of one node: the ranks talk through shared memory, and no rank listens (mpirun's runtime still does)
    assert looked and all(not held for look in looked for held in look), looked
    assert len(warned) == 1, warned
    log = (tmp_path / "sweeps" / plan.ident / "logs" / f"task-{warned.pop()}.out").read_text()
    assert "stopped (exit 138); requeued to resume from its checkpoint" in log, log
    assert "attempt 2" in log and "resumed from checkpoint" in log
    mine = load(task.output)
    assert mine.engine == "lammps" and len(mine.raw_all["fabric"]) == run_spec.cost(task.spec())["samples"]
    assert "mpirun -np 2" in (task.run_dir / "log.txt").read_text()
