"""``make sweep``, ``make sweep-status``, ``make sweep-collect``: the command line of sweeps."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from ... import choices, engines
from ...cli import Parser, one_line_errors
from ...paths import RESULTS_DIR, ROOT
from .local import ranks_and_jobs, run_local
from .plan import MAX_TASKS, plan, read_plan, write_plan
from .slurm import apply_overrides, check_slurm, load_cluster_config, submit
from .status import format_status, status


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.runs.sweep", description="a set of DEM runs launched with one command")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    run = sub.add_parser("run", help="plan a sweep, check it, and launch the runs that are not done")
    run.add_argument("--preset", required=True)
    run.add_argument("--thetas", required=True, help='angles in degrees, e.g. "30 60 90"')
    run.add_argument("--rotate-ats", help='strains at which the direction turns (default: half the period)')
    run.add_argument("--seeds", help='seeds, e.g. "1 2 3" (default: the preset\'s)')
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override for every run")
    run.add_argument("--launch", choices=choices.LAUNCHES, default="local")
    run.add_argument("--slurm", action="append", default=[], metavar="KEY=VALUE", help="override of [slurm]")
    run.add_argument("--jobs", type=int, help="runs side by side with LAUNCH=local (default: [local] jobs, "
                     "divided by the ranks)")
    run.add_argument("--ranks", type=int, help="MPI ranks of each LAMMPS run, here or per SLURM task (default: "
                     "[slurm] ranks_per_run, 1)")
    run.add_argument("--allow-many", action="store_true", help=f"allow more than {MAX_TASKS} runs in one sweep")
    run.add_argument("--engine", default=engines.DEFAULT_ENGINE, help=f"DEM engine: {', '.join(engines.ENGINES)}")
    run.add_argument("--results", type=Path, default=RESULTS_DIR)
    st = sub.add_parser("status", help="the state of every run of a sweep (default: the latest)")
    st.add_argument("--sweep", help="the sweep's id (results/sweeps/<id>)")
    st.add_argument("--results", type=Path, default=RESULTS_DIR)
    pr = sub.add_parser("collect", help="make figures on the data set of a sweep (default: the latest): its preset, "
                        "engine and the overrides its runs share but the seed")
    pr.add_argument("--sweep")
    pr.add_argument("--results", type=Path, default=RESULTS_DIR)
    args = parser.parse_args(argv)
    if args.command == "status":
        sweep = read_plan(args.results, args.sweep)
        print(format_status(sweep, status(sweep)))
        return 0
    if args.command == "collect":
        settings = read_plan(args.results, args.sweep).data_set_settings()
        print("make figures " + " ".join(settings), flush=True)
        return subprocess.call(["make", "--no-print-directory", "-C", str(ROOT), "figures", *settings])
    config = load_cluster_config()
    slurm = apply_overrides(config["slurm"], args.slurm, "slurm")
    ranks, jobs = ranks_and_jobs(args.ranks, args.jobs, slurm["ranks_per_run"],
                                 any(o.startswith("ranks_per_run=") for o in args.slurm), config["local"]["jobs"])
    sweep = plan(args.preset, args.thetas, args.rotate_ats, args.seeds, args.set, args.results, args.allow_many,
                 args.engine)
    slurm["ranks_per_run"] = ranks
    if args.launch == "slurm":
        check_slurm(slurm, sweep, config["throughput"])
    else:
        engines.check_parallel(sweep.tasks[0].engine, ranks)
    write_plan(sweep)
    print(f"sweep {sweep.ident}: {len(sweep.tasks)} run(s) of preset {sweep.preset} "
          f"({sum(t.output.exists() for t in sweep.tasks)} done)")
    if args.launch == "local":
        return run_local(sweep, jobs, ranks)
    job = submit(sweep, slurm)
    print("every run is done or queued: nothing submitted" if job is None else
          f"submitted job array {job} ({sweep.folder / 'job.sh'}); follow it with `make sweep-status`")
    return 0


if __name__ == "__main__":
    sys.exit(main())
