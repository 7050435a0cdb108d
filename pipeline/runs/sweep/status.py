"""The state of every run of a sweep: done, running, queued, failed, stopped or not started."""

from __future__ import annotations

from ..state import progress, reached, run_state
from .plan import Sweep
from .slurm import QueueUnreadable, queue


def status(sweep: Sweep) -> list[dict]:
    """One row per run: label, state (done, running, queued, failed, stopped, not started) and detail. When a
    submitted sweep's queue cannot be read, a run that is not done or running says so instead of "rerun"."""
    try:
        queued, unread = queue(sweep), ""
    except QueueUnreadable as exc:
        queued, unread = {}, f"SLURM's queue unread ({exc}): it may be queued, check before rerunning"
    rows = []
    for k, task in enumerate(sweep.tasks):
        state, detail = run_state(task.run_dir, task.output)
        slurm_state, reason = queued.get(k, ("", ""))
        if state in ("stopped", "not started") and slurm_state in ("RUNNING", "COMPLETING"):
            state, detail = "running", progress(task.run_dir)
        elif state in ("stopped", "not started") and slurm_state:
            state, detail = "queued", f"{slurm_state.lower()} ({reason}){reached(task.run_dir)}"
        elif unread and state in ("stopped", "not started"):
            detail = unread + reached(task.run_dir)
        elif state == "stopped":
            detail = f"resumable from its checkpoint{reached(task.run_dir)}: rerun the sweep"
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
