"""Sweeps: a set of DEM runs (angles x rotations x seeds of one preset) launched with one command.

``python -m pipeline.runs.sweep run --preset P --thetas "30 60 90" [--rotate-ats ...] [--seeds "1 2"]
[--set key=value ...] [--launch local|slurm] [--slurm key=value ...]`` (``make sweep``) plans the runs,
checks every one of them (and the scheduler's settings) before anything starts, writes the plan to
``results/sweeps/<id>/`` and launches the runs that are not done:

- ``local``: a makefile of one rule per run, run by Make with ``-j`` (``[local] jobs``, one Yade
  thread each); a finished run is never rerun, an interrupted one resumes from its checkpoint.
- ``slurm``: one job array (``sbatch --array``), each task running exactly the launcher of
  ``make dem`` (``python -m pipeline.runs run``) into the same ``results/`` tree. Tasks are submitted
  with ``--requeue`` and ``--signal=B:USR1@<lead>``: on the signal the run stops at its next
  checkpoint and the task requeues itself, so it resumes bit-identically (one thread). A task whose
  process is killed is requeued the same way, at most ``max_requeues`` times; a run that stops with
  the DEM's diagnostic (exit 3) or cannot be resumed (exit 2) is not requeued: it is failed, with its
  reason in ``<run>.run/failed.json``.

``status`` (``make sweep-status``) tabulates every run of a sweep: done, running (progress and ETA from
the run's own progress line), queued (with the scheduler's reason), failed (with the reason), stopped
(resumable) or not started, from the run folders and one ``squeue`` call.
"""

from __future__ import annotations

import hashlib
import json
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

from .. import io
from ..cli import Parser, one_line_errors
from ..config import load_presets
from ..errors import PipelineError, SpecError
from ..paths import CONFIG_DIR, RESULTS_DIR, ROOT
from . import spec as run_spec
from .state import progress, run_state

CLUSTER_FILE = CONFIG_DIR / "cluster.toml"
NAME = re.compile(r"[A-Za-z0-9_.-]*")
TIME_LIMIT = re.compile(r"(?:(\d+)-)?(\d{1,2}):(\d{2}):(\d{2})")
MEMORY = re.compile(r"\d+[KMGT]?")


@dataclass(frozen=True)
class Task:
    """One run of a sweep: the launcher's arguments and the HDF5 file it writes."""

    args: tuple[str, ...]
    output: Path
    label: str

    @property
    def run_dir(self) -> Path:
        return self.output.with_suffix(".run")


@dataclass(frozen=True)
class Sweep:
    ident: str
    folder: Path
    preset: str
    tasks: tuple[Task, ...]
    results: Path

    @property
    def job_name(self) -> str:
        return f"gb-{self.ident}"


# ---------------------------------------------------------------- configuration
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
            if not re.fullmatch(r"\d+", value):
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
    if not 1 <= config["threads_per_run"] <= 256:
        raise SpecError(f"slurm threads_per_run={config['threads_per_run']} must be between 1 and 256")
    limit = time_limit_seconds(config["time_limit"])
    lead = config["signal_lead_seconds"]
    spec = task_spec(sweep.tasks[0].args)
    interval = spec["checkpoint_steps"] / throughput.get(sweep.preset, min(throughput.values()))
    if lead < interval:
        raise SpecError(f"slurm signal_lead_seconds={lead} is shorter than a checkpoint interval of preset "
                        f"{sweep.preset} (about {interval:.0f} s): the run could not checkpoint before the limit")
    if limit < lead + interval:
        raise SpecError(f"slurm time_limit={config['time_limit']} is shorter than a checkpoint interval (about "
                        f"{interval:.0f} s) plus the signal lead ({lead} s)")
    if shutil.which("sbatch") is None:
        raise SpecError("sbatch not found on PATH: LAUNCH=slurm needs SLURM's client tools")


# ---------------------------------------------------------------- the plan
def _words(text: str | None) -> list[str]:
    return [] if not text else text.replace(",", " ").split()


def task_spec(args: tuple[str, ...]) -> dict:
    """The run spec that the launcher's arguments ``args`` (``--theta``, ``--preset``, ``--rotate-at``, ``--set``)
    resolve to: what ``make dem`` with them would run."""
    a = dict(zip(args[::2], args[1::2], strict=True))
    overrides = run_spec.parse_overrides([v for k, v in zip(args[::2], args[1::2], strict=True) if k == "--set"])
    return run_spec.resolve(a["--theta"], a["--preset"], a.get("--rotate-at"), overrides)


def plan(preset: str, thetas: str, rotate_ats: str | None = None, seeds: str | None = None,
         overrides: list[str] = (), results: Path = RESULTS_DIR) -> Sweep:
    """Every run of the sweep, each validated as ``make dem`` would validate it."""
    theta_list = _words(thetas)
    if not theta_list:
        raise SpecError("THETAS is empty: give the angles to run, e.g. THETAS=\"30 60 90\"")
    defaults = load_presets().get(preset, {})
    tasks = {}
    for theta in theta_list:
        for rotate_at in _words(rotate_ats) or [None]:
            for seed in _words(seeds) or [None]:
                items = list(overrides)
                if seed is not None and run_spec.parse_number("seed", seed) != defaults.get("seed"):
                    items.append(f"seed={seed}")
                args = ("--theta", theta, "--preset", preset)
                args += ("--rotate-at", rotate_at) if rotate_at is not None else ()
                args += tuple(x for item in items for x in ("--set", item))
                spec = task_spec(args)
                output = run_spec.output_path(spec, results)
                tasks[output] = Task(args, output, f"{spec['folder']}/{spec['name']}")
    ordered = tuple(tasks.values())
    digest = hashlib.sha1(json.dumps([t.args for t in ordered]).encode()).hexdigest()[:8]
    ident = f"{preset}-{digest}"
    return Sweep(ident, results / "sweeps" / ident, preset, ordered, results)


def write_plan(sweep: Sweep) -> None:
    io.write_json(sweep.folder / "plan.json", {
        "id": sweep.ident, "preset": sweep.preset, "results": str(sweep.results),
        "tasks": [{"args": list(t.args), "output": str(t.output), "label": t.label} for t in sweep.tasks]})
    io.write_text(sweep.results / "sweeps" / "latest", sweep.ident + "\n")


def read_plan(results: Path = RESULTS_DIR, ident: str | None = None) -> Sweep:
    if ident is None:
        latest = results / "sweeps" / "latest"
        if not latest.exists():
            raise PipelineError(f"no sweep in {results / 'sweeps'}: run `make sweep` first")
        ident = latest.read_text().strip()
    path = results / "sweeps" / ident / "plan.json"
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        raise PipelineError(f"sweep {ident!r} has no readable plan ({path})") from None
    tasks = tuple(Task(tuple(t["args"]), Path(t["output"]), t["label"]) for t in data["tasks"])
    return Sweep(data["id"], path.parent, data["preset"], tasks, Path(data["results"]))


def launcher_command(task: Task, results: Path, threads: int = 1) -> list[str]:
    return [sys.executable, "-m", "pipeline.runs", "run", *task.args, "--results", str(results),
            "--threads", str(threads)]


# ---------------------------------------------------------------- local: Make's -j
def local_makefile(sweep: Sweep) -> str:
    lines = ["# one rule per run of the sweep; run by `make sweep LAUNCH=local` with -j", "",
             "all: " + " ".join(shlex.quote(str(t.output)) for t in sweep.tasks), ""]
    for task in sweep.tasks:
        lines += [f"{shlex.quote(str(task.output))}:",
                  "\tcd " + shlex.quote(str(ROOT)) + " && " + shlex.join(launcher_command(task, sweep.results)), ""]
    return "\n".join(lines)


def run_local(sweep: Sweep, jobs: int) -> int:
    makefile = io.write_text(sweep.folder / "runs.mk", local_makefile(sweep))
    return subprocess.call(["make", "--no-print-directory", "-k", f"-j{jobs}", "-f", str(makefile), "all"])


# ---------------------------------------------------------------- SLURM: one job array
def job_script(sweep: Sweep, config: dict, indices: list[int]) -> str:
    """The batch script of the sweep's job array (tasks ``indices`` of the plan)."""
    threads = config["threads_per_run"]
    directives = [
        f"--job-name={sweep.job_name}", f"--array={','.join(map(str, indices))}", "--requeue",
        "--open-mode=append", f"--signal=B:USR1@{config['signal_lead_seconds']}", f"--time={config['time_limit']}",
        "--ntasks=1", f"--cpus-per-task={threads}", f"--mem={config['memory']}",
        f"--output={sweep.folder / 'logs' / 'task-%a.out'}",
    ]
    directives += [f"--{key}={config[key]}" for key in ("partition", "account") if config[key]]
    python = shlex.quote(sys.executable)
    tasks_dir = shlex.quote(str(sweep.folder / "tasks"))
    return "\n".join(["#!/bin/bash", *(f"#SBATCH {d}" for d in directives), f"""
# Each task runs the launcher of `make dem` on one run of the sweep ({sweep.ident}).
# SIGUSR1 ({config['signal_lead_seconds']} s before the time limit): the run stops at its next checkpoint and
# the task requeues itself; it resumes from that checkpoint, bit-identically at one thread.
cd {shlex.quote(str(ROOT))}
mapfile -t ARGS < {tasks_dir}/"$SLURM_ARRAY_TASK_ID".args
echo "task $SLURM_ARRAY_TASK_ID, attempt $(( ${{SLURM_RESTART_COUNT:-0}} + 1 )) on $(hostname): ${{ARGS[*]}}"
{python} -m pipeline.runs run "${{ARGS[@]}}" --results {shlex.quote(str(sweep.results))} --threads {threads} &
child=$!
trap 'kill -USR1 "$child" 2>/dev/null' USR1
status=0
while kill -0 "$child" 2>/dev/null; do wait "$child"; status=$?; done
case $status in
  0) echo "task $SLURM_ARRAY_TASK_ID: done"; exit 0 ;;
  2|3) echo "task $SLURM_ARRAY_TASK_ID: failed (exit $status), not requeued"; exit "$status" ;;
esac
if [ "${{SLURM_RESTART_COUNT:-0}}" -lt {config['max_requeues']} ]; then
  echo "task $SLURM_ARRAY_TASK_ID: stopped (exit $status); requeued to resume from its checkpoint"
  scontrol requeue "${{SLURM_ARRAY_JOB_ID}}_${{SLURM_ARRAY_TASK_ID}}"
else
  echo "task $SLURM_ARRAY_TASK_ID: stopped (exit $status) after {config['max_requeues']} requeues; not requeued"
fi
exit "$status"
"""])


def submit(sweep: Sweep, config: dict) -> str | None:
    """Submit the runs that are not done as one job array; returns the job id (None when all are done)."""
    todo = [k for k, t in enumerate(sweep.tasks) if not t.output.exists()]
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


# ---------------------------------------------------------------- status
def queue(sweep: Sweep) -> dict[int, tuple[str, str]]:
    """``{task index: (state, reason)}`` of the sweep's tasks in SLURM's queue: one ``squeue`` call."""
    if shutil.which("squeue") is None or not (sweep.folder / "jobs.txt").exists():
        return {}
    proc = subprocess.run(["squeue", "-h", "-r", f"--name={sweep.job_name}", "-o", "%K|%T|%r"],
                          capture_output=True, text=True)
    out = {}
    for line in proc.stdout.splitlines():
        index, state, reason = (line.split("|") + ["", ""])[:3]
        if index.isdigit():
            out[int(index)] = (state, reason)
    return out


def status(sweep: Sweep) -> list[dict]:
    """One row per run: label, state (done, running, queued, failed, stopped, not started) and detail."""
    queued = queue(sweep)
    rows = []
    for k, task in enumerate(sweep.tasks):
        state, detail = run_state(task.run_dir, task.output)
        slurm_state, reason = queued.get(k, ("", ""))
        if state in ("stopped", "not started") and slurm_state in ("RUNNING", "COMPLETING"):
            state, detail = "running", progress(task.run_dir)
        elif state in ("stopped", "not started") and slurm_state:
            state, detail = "queued", f"{slurm_state.lower()} ({reason})"
        elif state == "stopped":
            detail = "resumable from its checkpoint: rerun the sweep"
        rows.append({"task": k, "run": task.label, "state": state, "detail": detail})
    return rows


def format_status(sweep: Sweep, rows: list[dict]) -> str:
    counts = {}
    for r in rows:
        counts[r["state"]] = counts.get(r["state"], 0) + 1
    width = max(len(r["run"]) for r in rows)
    lines = [f"sweep {sweep.ident}: " + ", ".join(f"{n} {s}" for s, n in counts.items()),
             f"{'task':>4}  {'run':<{width}}  {'state':<11}  detail"]
    lines += [f"{r['task']:>4}  {r['run']:<{width}}  {r['state']:<11}  {r['detail']}" for r in rows]
    return "\n".join(lines)


# ---------------------------------------------------------------- command line
@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.runs.sweep", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    run = sub.add_parser("run", help="plan a sweep, check it, and launch the runs that are not done")
    run.add_argument("--preset", required=True)
    run.add_argument("--thetas", required=True, help='angles in degrees, e.g. "30 60 90"')
    run.add_argument("--rotate-ats", help='strains at which the direction turns (default: half the period)')
    run.add_argument("--seeds", help='seeds, e.g. "1 2 3" (default: the preset\'s)')
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override for every run")
    run.add_argument("--launch", choices=("local", "slurm"), default="local")
    run.add_argument("--slurm", action="append", default=[], metavar="KEY=VALUE", help="override of [slurm]")
    run.add_argument("--jobs", type=int, help="runs side by side with LAUNCH=local (default: [local] jobs)")
    run.add_argument("--results", type=Path, default=RESULTS_DIR)
    st = sub.add_parser("status", help="the state of every run of a sweep (default: the latest)")
    st.add_argument("--sweep", help="the sweep's id (results/sweeps/<id>)")
    st.add_argument("--results", type=Path, default=RESULTS_DIR)
    pr = sub.add_parser("preset", help="print the preset of a sweep (default: the latest)")
    pr.add_argument("--sweep")
    pr.add_argument("--results", type=Path, default=RESULTS_DIR)
    args = parser.parse_args(argv)
    if args.command == "status":
        sweep = read_plan(args.results, args.sweep)
        print(format_status(sweep, status(sweep)))
        return 0
    if args.command == "preset":
        print(read_plan(args.results, args.sweep).preset)
        return 0
    config = load_cluster_config()
    sweep = plan(args.preset, args.thetas, args.rotate_ats, args.seeds, args.set, args.results)
    if args.launch == "slurm":
        slurm = apply_overrides(config["slurm"], args.slurm, "slurm")
        check_slurm(slurm, sweep, config["throughput"])
    jobs = args.jobs or config["local"]["jobs"]
    if jobs < 1:
        raise SpecError(f"jobs={jobs} must be >= 1")
    write_plan(sweep)
    print(f"sweep {sweep.ident}: {len(sweep.tasks)} run(s) of preset {sweep.preset} "
          f"({sum(t.output.exists() for t in sweep.tasks)} done)")
    if args.launch == "local":
        return run_local(sweep, jobs)
    job = submit(sweep, slurm)
    print("every run is done: nothing submitted" if job is None else
          f"submitted job array {job} ({sweep.folder / 'job.sh'}); follow it with `make sweep-status`")
    return 0


if __name__ == "__main__":
    sys.exit(main())
