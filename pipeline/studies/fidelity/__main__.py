"""``make fidelity``: run the ladder's missing DEM runs, summarise every run, write ``results/fidelity/``.

``python -m pipeline.studies.fidelity [--run] [--jobs 2] [--launch local|slurm] [--out DIR]``

Without ``--run`` nothing is simulated: the table is built from the committed summaries
(``data/fidelity/``) and any ladder run found in ``results/`` or the reference dataset, which is
summarised first (a few seconds each) and its summary written to ``data/fidelity/`` to be committed.
With ``--run`` the runs that have neither are made first, as a sweep (``--jobs`` side by side, one
Yade thread each; resumable). Outputs: ``table.json``, ``table.csv``, ``table.md``.
"""

from __future__ import annotations

import csv
import io as text_io
import json
import sys
import time
from pathlib import Path

from ... import io
from ...cli import Parser, one_line_errors
from ...dataset.dem_file import load
from ...paths import RESULTS_DIR
from ...runs.sweep.local import run_local
from ...runs.sweep.plan import write_plan
from ...runs.sweep.slurm import load_cluster_config, submit
from . import ladder, render, table
from .summary import VERSION, summarize

OUT_DIR = RESULTS_DIR / "fidelity"


def _current(path: Path) -> dict | None:
    """The summary at ``path`` if there is one of this version (an older one is redone where its run is)."""
    if not path.exists():
        return None
    found = json.loads(path.read_text())
    return found if found.get("schema_version") == VERSION else None


def summaries(rungs: list, summary_dir: Path = ladder.SUMMARY_DIR, roots: tuple = ladder.DATA_ROOTS) -> list[tuple]:
    """(axis, setting, summary) for every rung that has a summary or a DEM file; new summaries are written,
    and a summary of an older version is written anew where the run's DEM file is at hand (else kept)."""
    entries, tic = [], time.time()
    cache = {r.relative: found for r in rungs if (found := _current(ladder.summary_path(r, summary_dir)))}
    todo = {r.relative for r in rungs if r.relative not in cache and ladder.dem_file(r, roots)}
    done = 0
    for r in rungs:
        path = ladder.summary_path(r, summary_dir)
        if r.relative not in cache:
            if r.relative not in todo and path.exists():
                cache[r.relative] = json.loads(path.read_text())  # an older version, its run not at hand
            elif (dem := ladder.dem_file(r, roots)) is not None:
                cache[r.relative] = summarize(load(dem))
                io.write_json(path, cache[r.relative])
                done += 1
                rate = done / (time.time() - tic)
                print(f"summarised {r.relative} ({done}/{len(todo)}, {rate:.2f} runs/s)", flush=True)
            else:
                continue
        entries.append((r.axis, r.label, cache[r.relative]))
    return entries


def top_summaries(paths: list[Path], summary_dir: Path = ladder.SUMMARY_DIR) -> list[dict]:
    """The summaries of the top rung's runs (``data/fidelity/<folder>/<name>.json``), made where missing or
    of an older version."""
    out = []
    for path in paths:
        target = summary_dir / path.parts[-3] / f"{path.stem}.json"
        found = _current(target)
        if found is None:
            found = summarize(load(path))
            io.write_json(target, found)
            print(f"summarised {path.parts[-3]}/{path.stem} (the top rung)", flush=True)
        out.append(found)
    return out


def csv_text(rows: list[dict]) -> str:
    out = text_io.StringIO()
    keys = ["axis", "setting", "theta_deg", "cpu_hours", "steps_per_second", "grains", "mu", "mu_se", "mu_shift",
            "mu_shift_se", "error", "A_norm", "phi_central", "phi_gap", "bulk_over_nominal", *table.FITTED]
    writer = csv.writer(out)
    writer.writerow(keys)
    for r in rows:
        s, c, fit = r["steady"], r["cost"], r["fit"] or {}
        writer.writerow([r["axis"], r["setting"], r["theta_deg"], c["cpu_hours"], c["steps_per_second"], c["grains"],
                         s["mu"]["mean"], s["mu"]["standard_error"], s["mu"]["shift"], s["mu"]["shift_se"],
                         r["error"], s["A_norm"]["mean"], s["phi_central"]["mean"], s["phi_gap"]["mean"],
                         r["bulk_over_nominal"], *(fit.get(n, "") for n in table.FITTED)])
    return out.getvalue()


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.fidelity", description=__doc__.splitlines()[0])
    parser.add_argument("--run", action="store_true", help="make the ladder's missing DEM runs first")
    parser.add_argument("--jobs", type=int, default=2, help="runs side by side (default 2)")
    parser.add_argument("--launch", choices=("local", "slurm"), default="local")
    parser.add_argument("--engine", default="yade", help="the DEM engine of the ladder's runs: yade or lammps")
    parser.add_argument("--out", type=Path, help="default results/fidelity (results/fidelity-lammps for LAMMPS)")
    args = parser.parse_args(argv)
    if args.out is None:
        args.out = OUT_DIR if args.engine == "yade" else OUT_DIR.with_name(f"fidelity-{args.engine}")
    if args.jobs < 1:
        parser.error(f"--jobs {args.jobs} must be at least 1")
    spec = ladder.load()
    rungs = ladder.rungs(spec, args.engine)
    out = io.check_writable_dir(args.out)
    missing = ladder.missing(rungs)
    if args.run and missing:
        sweep = ladder.sweep_of(missing, spec["preset"])
        write_plan(sweep)
        print(f"running {len(missing)} ladder run(s) as sweep {sweep.ident} ({args.launch}; "
              f"make sweep-status SWEEP={sweep.ident})", flush=True)
        if args.launch == "slurm":
            submit(sweep, load_cluster_config())
            return 0
        run_local(sweep, args.jobs)
    entries = summaries(rungs)
    label, top_paths = ladder.top_runs(spec)
    top = (label, top_summaries(top_paths), list(spec["top"].get("checks", []))) if top_paths else None
    result = table.build(entries, extrapolations={axis: entry["extrapolate"] for axis, entry in spec["axes"].items()
                                                  if "extrapolate" in entry},
                         node_cores=int(spec.get("node_cores", 32)), top=top)
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
