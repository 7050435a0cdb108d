"""DEM benchmark (``make bench-dem``): steps/s of the bare and the production loop per preset, and the cost
of our control and measurement.

``python -m pipeline.studies.bench_dem [--presets quick,reduced,paper] [--repeats 3] [--out results/bench]`` runs
``dem/tools/yade_bench.py`` under Yade's python, one thread, for each preset from a compacted, briefly sheared state
cached in ``<out>/cache/<preset>.yade.gz`` (made on first use: the paper cell's compaction takes the better
part of an hour once). The timings interleave bare and full runs of the same steps from the same
state, best of the repeats. Writes ``dem_throughput.json`` (one record per preset: grains, wall spheres,
steps/s and particle-steps/s of the bare and the full loop, Yade's engine timers in each, the cost of our
Python in the production loop) and ``dem_throughput.md``.

With ``--engines yade,lammps`` (``make bench-dem ENGINES=yade,lammps``) each preset is also run by LAMMPS's scene
(``dem/tools/lammps_bench.py``: the same spec, the same driver, from its own compaction) right after Yade's, and
``dem_engines.md`` and ``dem_engines.json`` give both engines' steps/s and their ratio, measured in this one
invocation. With ``--engines lammps`` LAMMPS's scene alone is timed. Every LAMMPS benchmark times the production loop
with and without the contact budget's tracking side by side (``dem_budget.md``: its cost). ``--set key=value``
overrides the preset for both engines (``make bench-dem PRESETS=paper ENGINES=lammps SET="inertial_number=0.001"``).
"""

from __future__ import annotations

import sys
from pathlib import Path

from .. import io
from .. import spec as run_spec
from ..cli import Parser, one_line_errors
from ..config import check_presets
from ..errors import PipelineError
from ..paths import RESULTS_DIR
from ..runs import scripts

#: steps per timed run: a few seconds of each preset here, several sampling intervals of the small ones
STEPS = {"tiny": 3000, "quick": 31000, "reduced": 45000, "paper": 4500}
REPEATS = 3


def bench(preset: str, repeats: int, cache: Path, overrides: dict) -> dict:
    spec = run_spec.resolve(180, preset, overrides=overrides)
    cache = cache.resolve()  # the scene runs in a scratch folder
    cache.parent.mkdir(parents=True, exist_ok=True)
    return scripts.run_script("dem.tools.yade_bench", spec, (STEPS.get(preset, 30000), repeats, scripts.OUT, cache),
                           what=f"benchmark of preset {preset}")


def bench_lammps(preset: str, repeats: int, overrides: dict) -> dict:
    spec = run_spec.resolve(180, preset, overrides=overrides, engine="lammps")
    return scripts.run_script("dem.tools.lammps_bench", spec, (STEPS.get(preset, 30000), repeats, scripts.OUT),
                           what=f"LAMMPS benchmark of preset {preset}")


def engines_report(pairs: list[tuple[dict, dict]]) -> str:
    lines = ["# DEM engines side by side (`make bench-dem ENGINES=yade,lammps`)", "",
             "One core each, one after the other in one invocation, best of the repeats; full: the production loop "
             "(the same driver: wall controller every 10 steps, sampling); bare: the engine's loop alone.", "",
             "| preset | grains + wall spheres | Yade bare / full steps/s | LAMMPS bare / full steps/s "
             "| LAMMPS / Yade, full | LAMMPS full M particle-steps/s |", "|---|---|---|---|---|---|"]
    for y, lmp in pairs:
        ys, ls = y["steps_per_second"], lmp["steps_per_second"]
        lines.append(f"| {y['preset']} | {y['grains']} + {y['wall_spheres']} | {ys['bare']:.0f} / {ys['full']:.0f} "
                     f"| {ls['bare']:.0f} / {ls['full']:.0f} | {ls['full'] / ys['full']:.1f}× "
                     f"| {lmp['particle_steps_per_second']['full'] / 1e6:.2f} |")
    return "\n".join(lines) + "\n"


def budget_report(runs: list[dict], overrides: dict) -> str:
    """The contact budget's cost: LAMMPS's production loop with its tracking points (with and without the near pairs'
    search) against the same loop without."""
    setting = " ".join(f"{k}={v:g}" for k, v in overrides.items()) or "the presets' own values"
    lines = ["# The contact budget's cost (`make bench-dem ENGINES=lammps`)", "",
             f"LAMMPS, one core, {setting}; CPU time, interleaved repeats, best of each: the production loop with the "
             "contacts and near pairs tracked every `contact_track_strain` (full), the same without the near pairs' "
             "search (budget), and without tracking points (untracked).", "",
             "| preset | grains | contact_track_strain | untracked steps/s | budget steps/s | full steps/s "
             "| full / budget | full / untracked |", "|---|---|---|---|---|---|---|---|"]
    for r in runs:
        sps = r["steps_per_second"]
        lines.append(f"| {r['preset']} | {r['grains']} | {r['contact_track_strain']:g} | {sps['untracked']:.0f} "
                     f"| {sps['budget']:.0f} | {sps['full']:.0f} | {sps['full'] / sps['budget']:.3f} "
                     f"| {sps['full'] / sps['untracked']:.3f} |")
    return "\n".join(lines) + "\n"


def throughput_record(r: dict) -> dict:
    """The compact record of one preset in ``dem_throughput.json``; the cost of one interaction visited by
    the interaction loop (real contacts and the collider's other pairs) and of one body in the integrator,
    in ns, from the timers of the production loop."""
    full = r["engines"]["full"]
    us = full["microseconds_per_step"]
    bodies = r["grains"] + r["wall_spheres"]
    return {"preset": r["preset"], "grains": r["grains"], "wall_spheres": r["wall_spheres"], "steps": r["steps"],
            "repeats": r["repeats"], "threads": 1,
            "steps_per_second": {m: r["steps_per_second"][m] for m in ("bare", "full")},
            "particle_steps_per_second": {m: r["particle_steps_per_second"][m] for m in ("bare", "full")},
            "full_below_bare_percent": 100 * (1 - r["steps_per_second"]["full"] / r["steps_per_second"]["bare"]),
            "python_percent": r["python_percent"], "spread_percent": r["spread_percent"],
            "ns_per_interaction_visit": 1e3 * us["InteractionLoop"] / full["interactions_all"],
            "ns_per_body_integrated": 1e3 * us["NewtonIntegrator"] / bodies, "engines": r["engines"]}


def throughput_report(records: list[dict]) -> str:
    lines = ["# DEM throughput (`make bench-dem`)", "",
             "One thread, best of the repeats (spread: the slowest repeat's excess), interleaved, from the same "
             "sheared state. bare: Yade's loop alone, the walls at constant velocity with the gap held (the packing "
             "may lose contacts: see the interactions below); full: the production loop (wall controller every "
             "10 steps, sampling every 0.005 strain). Our Python: the controller PyRunner's share of the timed "
             "production loop (dispatch and callbacks). Cost per interaction visited by the interaction loop (real "
             "contacts and the collider's other pairs) and per body integrated, from Yade's timers.", "",
             "| preset | grains + wall spheres | bare steps/s | full steps/s | bare / full M particle-steps/s "
             "| full below bare | spread bare / full | our Python | ns per interaction visit "
             "| ns per body integrated |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        sps, pps = r["steps_per_second"], r["particle_steps_per_second"]
        lines.append(f"| {r['preset']} | {r['grains']} + {r['wall_spheres']} | {sps['bare']:.0f} | {sps['full']:.0f} "
                     f"| {pps['bare'] / 1e6:.2f} / {pps['full'] / 1e6:.2f} | {r['full_below_bare_percent']:.0f} % "
                     f"| {r['spread_percent']['bare']:.0f} / {r['spread_percent']['full']:.0f} % "
                     f"| {r['python_percent']:.1f} % | {r['ns_per_interaction_visit']:.0f} "
                     f"| {r['ns_per_body_integrated']:.0f} |")
    lines += ["", "Yade's timers in one more pass of each loop (µs per step; interactions at the end):", "",
              "| preset | loop | InteractionLoop | NewtonIntegrator | collider | controller | other | collider sorts "
              "| real contacts | all interactions |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        for mode, e in r["engines"].items():
            us = dict(e["microseconds_per_step"])
            main = [us.pop("InteractionLoop", 0.0), us.pop("NewtonIntegrator", 0.0),
                    us.pop("InsertionSortCollider", 0.0), us.pop("controller", 0.0)]
            lines.append(f"| {r['preset']} | {mode} | " + " | ".join(f"{v:.0f}" for v in main)
                         + f" | {sum(us.values()):.0f} | {e['collider_sorts']} | {e['interactions_real']} "
                         f"| {e['interactions_all']} |")
    return "\n".join(lines) + "\n"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.bench_dem", description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default="quick,reduced,paper")
    parser.add_argument("--repeats", type=int, default=REPEATS)
    parser.add_argument("--engines", default="yade", help="yade, lammps, or yade,lammps for both side by side")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a preset value overridden for both engines (repeatable)")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "bench")
    args = parser.parse_args(argv)
    presets = check_presets([p.strip() for p in args.presets.split(",")])
    if args.repeats < 1:
        raise PipelineError(f"--repeats {args.repeats} must be at least 1")
    engines = [e.strip() for e in args.engines.split(",")]
    if engines not in (["yade"], ["lammps"], ["yade", "lammps"]):
        raise PipelineError(f"--engines {args.engines!r}: yade, lammps, or yade,lammps")
    overrides = run_spec.parse_overrides(args.set)
    for preset in presets:  # a one-line error now for a bad value
        run_spec.resolve(180, preset, overrides=overrides)
    try:
        for engine in engines:  # a one-line error now if an engine asked for is missing
            scripts.require(engine)
    except scripts.EngineMissing as exc:
        raise PipelineError(str(exc)) from None
    out = io.check_writable_dir(args.out)
    rows, lammps_runs = [], []
    for preset in presets:
        print(f"benchmarking {preset} (a paper cell's first compaction takes long) ...", flush=True)
        if "yade" in engines:
            rows.append(bench(preset, args.repeats, out / "cache" / f"{preset}.yade.gz", overrides))
            sps = rows[-1]["steps_per_second"]
            print(f"  bare {sps['bare']:.0f} steps/s, full {sps['full']:.0f} steps/s", flush=True)
        if "lammps" in engines:
            lammps_runs.append(bench_lammps(preset, args.repeats, overrides))
            sps = lammps_runs[-1]["steps_per_second"]
            print(f"  LAMMPS: bare {sps['bare']:.0f}, untracked {sps['untracked']:.0f}, budget {sps['budget']:.0f}, "
                  f"full {sps['full']:.0f} steps/s", flush=True)
    if lammps_runs:
        io.write_json(out / "dem_budget.json", lammps_runs)
        io.write_text(out / "dem_budget.md", budget_report(lammps_runs, overrides))
        print(budget_report(lammps_runs, overrides))
    if not rows:
        return 0
    pairs = list(zip(rows, lammps_runs, strict=False)) if lammps_runs else []
    if pairs:
        io.write_json(out / "dem_engines.json", [{"yade": throughput_record(y), "lammps": lmp} for y, lmp in pairs])
        io.write_text(out / "dem_engines.md", engines_report(pairs))
        print(engines_report(pairs))
    records = [throughput_record(r) for r in rows]
    io.write_json(out / "dem_throughput.json", records)
    io.write_text(out / "dem_throughput.md", throughput_report(records))
    print(throughput_report(records))
    return 0


if __name__ == "__main__":
    sys.exit(main())
