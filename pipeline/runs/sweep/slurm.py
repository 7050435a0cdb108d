"""A sweep on SLURM: one job array whose tasks run the launcher of ``make dem``, requeued to resume from their
checkpoints; the scheduler's settings from ``config/cluster.toml``, checked before anything is submitted."""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

from ... import engines, io
from ...errors import PipelineError, SpecError
from ...paths import CONFIG_DIR, ROOT
from .plan import Sweep

CLUSTER_FILE = CONFIG_DIR / "cluster.toml"
JOB_TEMPLATE = CONFIG_DIR / "slurm_job.sh"
NAME = re.compile(r"[A-Za-z0-9_.-]*")
TIME_LIMIT = re.compile(r"(?:([0-9]+)-)?([0-9]{1,2}):([0-9]{2}):([0-9]{2})")
MEMORY = re.compile(r"[0-9]+[KMGT]?")


class QueueUnreadable(PipelineError):
    """A submitted sweep's SLURM queue cannot be read (no ``squeue``, or it failed)."""


def load_cluster_config(path: Path = CLUSTER_FILE) -> dict:
    with open(path, "rb") as fh:
        return tomllib.load(fh)


def apply_overrides(section: dict, items: list[str], what: str) -> dict:
    """``key=value`` items onto a config section, each value of the type the section declares."""
    out = dict(section)
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or key not in section:
            known = ", ".join(section)
            raise SpecError(f"{what} override {item!r} is not key=value with a known key ({known})")
        if isinstance(section[key], int):
            if not re.fullmatch(r"[0-9]+", value):
                raise SpecError(f"{what} {key}={value!r} must be a whole number")
            out[key] = int(value)
        else:
            out[key] = value
    return out


def time_limit_seconds(text: str) -> int:
    match = TIME_LIMIT.fullmatch(text)
    if not match:
        raise SpecError(f"slurm time_limit={text!r} is not [D-]HH:MM:SS")
    days, hours, minutes, seconds = (int(g) if g else 0 for g in match.groups())
    return ((days * 24 + hours) * 60 + minutes) * 60 + seconds


def check_slurm(config: dict, sweep: Sweep, throughput: dict) -> None:
    """Refuse settings SLURM would reject, or that would let a task hit its time limit without a checkpoint."""
    for key in ("partition", "account"):
        if not NAME.fullmatch(config[key]):
            raise SpecError(f"slurm {key}={config[key]!r} is not a valid name")
    if not MEMORY.fullmatch(config["memory"]):
        raise SpecError(f"slurm memory={config['memory']!r} is not a size such as 2G")
    spec = sweep.tasks[0].spec()
    engines.check_parallel(spec.engine, config["ranks_per_run"], config["threads_per_run"],
                           ("slurm ranks_per_run", "slurm threads_per_run"), ("ranks_per_run", "threads_per_run"))
    limit = time_limit_seconds(config["time_limit"])
    lead = config["signal_lead_seconds"]
    rates = throughput[spec.engine]
    interval = spec.checkpoint_steps / rates.get(sweep.preset, min(rates.values()))
    if lead < interval:
        raise SpecError(f"slurm signal_lead_seconds={lead} is shorter than a checkpoint interval of preset "
                        f"{sweep.preset} (about {interval:.0f} s): the run could not checkpoint before the limit")
    if limit < lead + interval:
        raise SpecError(f"slurm time_limit={config['time_limit']} is shorter than a checkpoint interval (about "
                        f"{interval:.0f} s) plus the signal lead ({lead} s)")
    if shutil.which("sbatch") is None:
        raise SpecError("sbatch not found on PATH: LAUNCH=slurm needs SLURM's client tools")


def job_script(sweep: Sweep, config: dict, indices: list[int]) -> str:
    """The batch script of the sweep's job array (tasks ``indices`` of the plan): ``config/slurm_job.sh`` with
    its ``@NAME@`` fields filled, every path quoted for the shell (and for ``#SBATCH``, in double quotes: a
    path holding one, or a newline, is refused)."""
    if any(c in str(sweep.folder) for c in '"\n'):
        raise SpecError(f"{sweep.folder}: a path with a double quote or a newline cannot go into #SBATCH --output")
    threads = config["threads_per_run"]
    directives = [
        f"--job-name={sweep.job_name}", f"--array={','.join(map(str, indices))}", "--requeue",
        "--open-mode=append", f"--signal=B:USR1@{config['signal_lead_seconds']}", f"--time={config['time_limit']}",
        f"--ntasks={config['ranks_per_run']}", f"--cpus-per-task={threads}", f"--mem={config['memory']}",
        f"--output=\"{sweep.folder / 'logs' / 'task-%a.out'}\"",
    ]
    directives += [f"--{key}={config[key]}" for key in ("partition", "account") if config[key]]
    fields = {"DIRECTIVES": "\n".join(f"#SBATCH {d}" for d in directives), "SWEEP": sweep.ident,
              "LEAD": str(config["signal_lead_seconds"]), "ROOT": shlex.quote(str(ROOT)),
              "TASKS": shlex.quote(str(sweep.folder / "tasks")), "PYTHON": shlex.quote(sys.executable),
              "RESULTS": shlex.quote(str(sweep.results)), "THREADS": str(threads),
              "RANKS": str(config["ranks_per_run"]),
              "MAX_REQUEUES": str(config["max_requeues"])}
    text = JOB_TEMPLATE.read_text()
    for key, value in fields.items():
        text = text.replace(f"@{key}@", value)
    return text


def submit(sweep: Sweep, config: dict) -> str | None:
    """Submit the runs that are neither done nor in SLURM's queue already (a rerun submits no run twice) as one job
    array; returns the job id (None when there is none to submit)."""
    try:
        queued = queue(sweep)
    except QueueUnreadable as exc:
        raise QueueUnreadable(f"{exc}: cannot tell which runs of sweep {sweep.ident} are queued already, so nothing "
                              "was submitted") from None
    todo = [k for k, t in enumerate(sweep.tasks) if not t.output.exists() and k not in queued]
    if not todo:
        return None
    (sweep.folder / "tasks").mkdir(parents=True, exist_ok=True)
    (sweep.folder / "logs").mkdir(parents=True, exist_ok=True)
    for k, task in enumerate(sweep.tasks):
        io.write_text(sweep.folder / "tasks" / f"{k}.args", "\n".join(task.args) + "\n")
    script = io.write_text(sweep.folder / "job.sh", job_script(sweep, config, todo))
    proc = subprocess.run(["sbatch", "--parsable", str(script)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise PipelineError(f"sbatch refused the sweep: {proc.stderr.strip().splitlines()[-1:]}")
    job_id = proc.stdout.strip().split(";")[0]
    with open(sweep.folder / "jobs.txt", "a") as fh:
        fh.write(job_id + "\n")
    return job_id


def queue(sweep: Sweep) -> dict[int, tuple[str, str]]:
    """``{task index: (state, reason)}`` of the sweep's tasks in SLURM's queue: one ``squeue`` call (empty for a
    sweep never submitted). Raises ``QueueUnreadable`` for a submitted sweep whose queue cannot be read: its
    tasks may still be queued, so a rerun could submit them twice."""
    if not (sweep.folder / "jobs.txt").exists():
        return {}
    if shutil.which("squeue") is None:
        raise QueueUnreadable("squeue is not on PATH")
    proc = subprocess.run(["squeue", "-h", "-r", f"--name={sweep.job_name}", "-o", "%K|%T|%r"],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
        raise QueueUnreadable(last if last.startswith("squeue:") else f"squeue: {last}")
    out = {}
    for line in proc.stdout.splitlines():
        index, state, reason = (line.split("|") + ["", ""])[:3]
        if index.isdigit():
            out[int(index)] = (state, reason)
    return out
