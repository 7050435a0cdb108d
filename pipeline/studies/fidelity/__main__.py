"""``make fidelity``: run the ladder's missing DEM runs, summarise every run, write ``results/fidelity/``.

``python -m pipeline.studies.fidelity [--run] [--jobs 2] [--launch local|slurm] [--ladder FILE] [--out DIR]``

Without ``--run`` nothing is simulated: the table is built from the committed summaries
(``data/fidelity/``) and any ladder run found in ``results/`` or the reference dataset, which is
summarised first (a few seconds each) and its summary written to ``data/fidelity/`` to be committed.
With ``--run`` the runs that have neither are made first, as a sweep (``--jobs`` side by side, one
Yade thread each; resumable). Outputs: ``table.json``, ``table.csv``, ``table.md``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ... import choices, engines, io
from ...cli import Parser, one_line_errors
from ...paths import FIDELITY_LADDER, fidelity_output, shown
from ...runs.sweep.plan import MAX_TASKS
from . import ladder, render, table
from .gather import csv_text, summaries, top_summaries


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.fidelity", description=__doc__.splitlines()[0])
    parser.add_argument("--run", action="store_true", help="make the ladder's missing DEM runs first")
    parser.add_argument("--jobs", type=int, default=2, help="runs side by side (default 2)")
    parser.add_argument("--allow-many", action="store_true", help=f"allow more than {MAX_TASKS} runs (MANY=1)")
    parser.add_argument("--launch", choices=choices.LAUNCHES, default="local")
    parser.add_argument("--engine", default=engines.DEFAULT_ENGINE,
                        help=f"the DEM engine of the ladder's runs: {', '.join(engines.ENGINES)}")
    parser.add_argument("--ladder", type=Path, default=FIDELITY_LADDER,
                        help="the ladder (default config/fidelity.toml)")
    parser.add_argument("--out", type=Path, help="default results/fidelity, with -<ladder> for another ladder and "
                                                 "-<engine> for an engine but Yade")
    args = parser.parse_args(argv)
    if args.out is None:
        args.out = fidelity_output(args.ladder, args.engine)
    if args.jobs < 1:
        parser.error(f"--jobs {args.jobs} must be at least 1")
    ladder_config = ladder.load(args.ladder)
    rungs = ladder.rungs(ladder_config, args.engine, args.ladder.name)
    out = io.check_writable_dir(args.out)
    missing = ladder.missing(rungs)
    if args.run and missing and ladder.make_runs(missing, ladder_config["preset"], args.launch, args.jobs,
                                                 args.allow_many, args.ladder) == "submitted":
        return 0
    entries = summaries(rungs)
    label, top_paths = ladder.top_runs(ladder_config)
    top = (label, top_summaries(top_paths), list(ladder_config["top"].get("checks", []))) if top_paths else None
    extrapolations = {axis: entry["extrapolate"] for axis, entry in ladder_config["axes"].items()
                      if "extrapolate" in entry}
    result = {**table.build(entries, extrapolations=extrapolations,
                            node_cores=int(ladder_config.get("node_cores", 32)), top=top),
              "ladder": shown(args.ladder), "preset": ladder_config["preset"]}
    io.write_json(out / "table.json", result)
    io.write_text(out / "table.csv", csv_text(result["rows"]))
    io.write_text(out / "table.md", render.markdown(result))
    left = len(ladder.missing(rungs))
    print(f"wrote {out / 'table.md'}, table.csv, table.json: {len({e[2]['folder'] + e[2]['name'] for e in entries})} "
          f"run(s) of the ladder; {left} not made yet" + (" (make fidelity runs them)" if left else "")
          + f"; the top rung ({label or 'none'}): {len(top_paths)} run(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
