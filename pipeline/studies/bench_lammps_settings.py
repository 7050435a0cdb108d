"""LAMMPS settings side by side (``make bench-lammps-settings``): steps/s of the production loop from one run's
checkpoint under two sets of engine commands, one process per setting and round, alternating.

``python -m pipeline.studies.bench_lammps_settings --run-dir results/<folder>/dem/<run>.run --a "atom_modify sort 0
0.0" --b "atom_modify sort 1000 0.0" [--steps 3000] [--rounds 4] [--out results/bench]`` (several commands in one
setting: separated by ``;``). Each process resumes a copy of the checkpoint, issues its setting's commands, shears 200
steps, then times ``--steps`` (``dem/tools/lammps_settings_bench.py``). A and B swap places every round, so a drift of
the machine's load falls on both; the ratio B / A is taken within each round. Writes ``lammps_settings.json`` and
``lammps_settings.md``. """

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

from dem.core.spec import LEGACY_ENGINE
from dem.lammps import settings

from .. import io
from ..cli import Parser, one_line_errors
from ..errors import PipelineError
from ..paths import RESULTS_DIR
from ..runs import scripts
from ..runs.state import read_json


def checked_run_dir(run_dir: Path) -> Path:
    """A LAMMPS run folder with a checkpoint, else a one-line error naming it."""
    stored = read_json(run_dir / "spec.json")
    if not (run_dir / "checkpoint.json").is_file() or stored is None:
        raise PipelineError(f"--run-dir {run_dir}: no checkpoint there (a run folder <run>.run of results/*/dem/)")
    engine = stored.get("engine", LEGACY_ENGINE)
    if engine != "lammps":
        raise PipelineError(f"--run-dir {run_dir}: a {engine} run, not a LAMMPS one")
    return run_dir


def timed(run_dir: Path, steps: int, setting: list[str]) -> float:
    """Steps/s of ``steps`` production steps from ``run_dir``'s checkpoint under ``setting``."""
    result = scripts.run_script("dem.tools.lammps_settings_bench", None, (steps, scripts.OUT, *setting),
                                run_dir=run_dir, what=f"LAMMPS from {run_dir} with {'; '.join(setting)}")
    return result["steps_per_second"]


def report(record: dict) -> str:
    a, b = "; ".join(record["a"]), "; ".join(record["b"])
    lines = ["# LAMMPS settings side by side (`make bench-lammps-settings`)", "",
             f"From `{record['run_dir']}` ({record['steps']} steps a process, one rank, A and B alternating).", "",
             f"A: `{a}`  ", f"B: `{b}`", "", "| round | A steps/s | B steps/s | B / A |", "|---|---|---|---|"]
    for i, (sa, sb) in enumerate(zip(record["a_steps_per_second"], record["b_steps_per_second"], strict=True), 1):
        lines.append(f"| {i} | {sa:.0f} | {sb:.0f} | {sb / sa:.3f} |")
    r = record["ratios"]
    lines += ["", f"B / A: median {statistics.median(r):.3f}, range {min(r):.3f}–{max(r):.3f} over {len(r)} rounds."]
    return "\n".join(lines) + "\n"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.bench_lammps_settings", description=__doc__.splitlines()[0])
    parser.add_argument("--run-dir", type=Path, required=True, help="a LAMMPS run folder with a checkpoint")
    parser.add_argument("--a", required=True, help="setting A: LAMMPS commands, ';'-separated")
    parser.add_argument("--b", required=True, help="setting B: LAMMPS commands, ';'-separated")
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "bench")
    args = parser.parse_args(argv)
    if args.steps < 100:
        raise PipelineError(f"--steps {args.steps} must be at least 100")
    if args.rounds < 1:
        raise PipelineError(f"--rounds {args.rounds} must be at least 1")
    try:
        chosen = {"a": settings.parse(args.a, "--a"), "b": settings.parse(args.b, "--b")}
    except ValueError as exc:
        raise PipelineError(str(exc)) from None
    run_dir = checked_run_dir(args.run_dir)
    try:
        scripts.require("lammps")
    except scripts.EngineMissing as exc:
        raise PipelineError(str(exc)) from None
    out = io.check_writable_dir(args.out)
    rates = {"a": [], "b": []}
    start = time.perf_counter()
    for i in range(args.rounds):
        for name in ("a", "b") if i % 2 == 0 else ("b", "a"):
            rates[name].append(timed(run_dir, args.steps, chosen[name]))
        eta = (time.perf_counter() - start) / (i + 1) * (args.rounds - i - 1)
        print(f"[{100 * (i + 1) // args.rounds:3d}%] round {i + 1}/{args.rounds}: A {rates['a'][-1]:.0f}, "
              f"B {rates['b'][-1]:.0f} steps/s, B / A {rates['b'][-1] / rates['a'][-1]:.3f}  ETA {eta:.0f} s",
              flush=True)
    record = {"run_dir": str(run_dir), "steps": args.steps, "rounds": args.rounds, **chosen,
              "a_steps_per_second": rates["a"], "b_steps_per_second": rates["b"],
              "ratios": [b / a for a, b in zip(rates["a"], rates["b"], strict=True)]}
    io.write_json(out / "lammps_settings.json", record)
    io.write_text(out / "lammps_settings.md", report(record))
    print(report(record))
    return 0


if __name__ == "__main__":
    sys.exit(main())
