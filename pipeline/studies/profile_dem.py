"""Profile of the DEM scene by engine (``make profile-dem``): where Yade's time goes, per preset and threads.

``python -m pipeline.studies.profile_dem [--presets reduced,paper] [--threads 1,2] [--steps N]`` runs
``dem/tools/yade_profile.py`` under Yade's python for each preset and thread count, from a compacted state cached
in ``results/bench/cache/<preset>.yade.gz`` (made on first use), and writes ``results/bench/dem_profile.json``
and ``dem_profile.md``: steps/s and particle-steps/s, each engine's share, collider sorts, potential and
real interactions per grain, and the cost of a checkpoint save and reload.
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

OUT_DIR = RESULTS_DIR / "bench"
STEPS = {"tiny": 2000, "quick": 20000, "reduced": 20000, "paper": 3000}


def profile(preset: str, threads: int, steps: int, cache: Path) -> dict:
    spec = run_spec.resolve(180, preset)
    cache = cache.resolve()  # the scene runs in a scratch folder
    cache.parent.mkdir(parents=True, exist_ok=True)
    return scripts.run_script("dem.tools.yade_profile", spec, (steps, scripts.OUT, cache), threads,
                              what=f"profile of {preset}")


def order_experiment(preset: str, steps: int, repeats: int, cache: Path) -> dict:
    """Steps/s with the grains in creation order against sorted along a Z-order curve (``dem/tools/yade_order.py``),
    from the cached compaction (made by ``profile`` first)."""
    cache = cache.resolve()  # the scene runs in a scratch folder
    if not cache.exists():
        raise PipelineError(f"no cached compaction {cache}: profile {preset} first")
    spec = run_spec.resolve(180, preset)
    return scripts.run_script("dem.tools.yade_order", spec, (steps, repeats, scripts.OUT, cache),
                              what=f"order experiment on {preset}")


def markdown(rows: list[dict], orders: list[dict] = ()) -> str:
    lines = ["# Where Yade's time goes (`make profile-dem`)", "",
             "| preset | threads | grains + wall spheres | steps/s | M particle-steps/s | interactions per grain "
             "(potential / real) | collider sorts per 1000 steps | checkpoint save / load (s) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['preset']} | {r['threads']} | {r['grains']} + {r['wall_spheres']} | "
                     f"{r['steps_per_second']:.0f} | {r['particle_steps_per_second'] / 1e6:.2f} | "
                     f"{r['interactions_potential_per_grain']:.1f} / {r['interactions_real_per_grain']:.1f} | "
                     f"{1000 * r['collider_sorts'] / r['steps']:.0f} | "
                     f"{r['checkpoint_save_seconds']:.1f} / {r['checkpoint_load_seconds']:.1f} |")
    lines += ["", "Share of the loop time per engine (Yade's timers):", "",
              "| preset | threads | " + " | ".join(e["engine"] for e in rows[0]["engines"]) + " |",
              "|---|---|" + "---|" * len(rows[0]["engines"])]
    for r in rows:
        lines.append(f"| {r['preset']} | {r['threads']} | " + " | ".join(f"{e['percent']:.1f} %" for e in r["engines"])
                     + " |")
    if orders:
        lines += ["", "Grains in creation order against sorted in space (Z-order), same state, best of the repeats:",
                  "",
                  "| preset | grains | steps/s created | steps/s sorted | speed-up |", "|---|---|---|---|---|"]
        lines += [f"| {o['preset']} | {o['grains']} | {o['steps_per_second']['created']:.0f} | "
                  f"{o['steps_per_second']['morton']:.0f} | {o['speedup']:.2f} |" for o in orders]
    return "\n".join(lines) + "\n"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.profile_dem", description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default="reduced,paper")
    parser.add_argument("--threads", default="1")
    parser.add_argument("--steps", type=int, help="steps per timing (default per preset)")
    parser.add_argument("--order", action="store_true", help="also time the grains sorted in space against as created")
    parser.add_argument("--out", type=Path, default=OUT_DIR)
    args = parser.parse_args(argv)
    presets = check_presets(args.presets.split(","))
    try:
        threads = [int(t) for t in args.threads.split(",")]
    except ValueError:
        raise PipelineError(f"--threads {args.threads!r} is not a comma-separated list of whole numbers") from None
    out = io.check_writable_dir(args.out)
    rows = []
    for preset in presets:
        for n in threads:
            print(f"profiling {preset} on {n} thread(s) (a paper cell's first compaction takes long)", flush=True)
            rows.append(profile(preset, n, args.steps or STEPS.get(preset, 10000), out / "cache" / f"{preset}.yade.gz"))
            print(f"  {rows[-1]['steps_per_second']:.0f} steps/s", flush=True)
    orders = []
    for preset in presets if args.order else ():
        print(f"grain order on {preset}", flush=True)
        orders.append(order_experiment(preset, args.steps or STEPS.get(preset, 10000), 3,
                                       out / "cache" / f"{preset}.yade.gz"))
        print(f"  speed-up {orders[-1]['speedup']:.2f}", flush=True)
    io.write_json(out / "dem_profile.json", {"profiles": rows, "order": orders})
    io.write_text(out / "dem_profile.md", markdown(rows, orders))
    print(f"wrote {out / 'dem_profile.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
