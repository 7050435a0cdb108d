"""DEM benchmark: steps/s of the bare Yade loop and the cost of our control and measurement.

``python -m pipeline.studies.bench_dem [--presets quick,reduced] [--out results/bench]`` runs
``dem/bench.py`` under Yade's python for each preset (after compaction and a little shear: the timings
interleave bare, dispatch and full runs of the same steps from the same state, best of five) and writes
``dem_overhead.md`` and ``dem_overhead.json``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ..paths import RESULTS_DIR
from ..runs import spec as run_spec
from ..runs import yade

#: steps per timed run: about ten sampling intervals of each preset
STEPS = {"tiny": 3000, "quick": 31000, "reduced": 45000, "paper": 15000}
REPEATS = 5


def bench(preset: str, repeats: int = REPEATS) -> dict:
    spec = run_spec.resolve(180, preset)
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "spec.json").write_text(json.dumps(spec))
        out = Path(tmp, "out.json")
        command = yade.command("bench", tmp, STEPS.get(preset, 30000), repeats, out)
        proc = subprocess.run(command, capture_output=True, text=True, cwd=tmp, env=yade.environment(1))
        if proc.returncode != 0 or not out.exists():
            raise RuntimeError(f"benchmark of preset {preset} failed: {proc.stderr.strip().splitlines()[-1:]}")
        return json.loads(out.read_text())


def report(rows: list[dict]) -> str:
    lines = ["# DEM: steps/s and the cost of control and measurement", "",
             "One thread; each mode runs the same steps from the same sheared state (kept in memory), "
             "best of five, interleaved. "
             "bare: no Python in the loop, walls at constant velocity. dispatch: an empty PyRunner every "
             "`control_every_steps` (same trajectory as bare). full: the wall controller and the in-situ sampling "
             "every 0.005 strain, as in production; the time spent in our callbacks is measured inside them. "
             "The dispatch of a PyRunner call is timed with an empty PyRunner every step against bare (well above "
             "the noise). cost = (dispatch per call x calls + callbacks) / bare; 'noise' is the spread of the bare "
             "repeats.", "",
             "| preset | grains + wall spheres | control every | bare steps/s | full steps/s | dispatch per call "
             "| callbacks | cost | noise |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['preset']} | {r['grains']} + {r['wall_spheres']} | {r['control_every_steps']} steps | "
                     f"{r['steps_per_second']['bare']:.0f} | {r['steps_per_second']['full']:.0f} | "
                     f"{r['dispatch_microseconds_per_call']:.0f} µs | {r['callback_percent']:.1f} % | "
                     f"{r['overhead_percent']:.1f} % | {r['bare_spread_percent']:.1f} % |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pipeline.studies.bench_dem", description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default="quick,reduced")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "bench")
    args = parser.parse_args(argv)
    if shutil.which("yade") is None:
        print("error: yade not found on PATH: run `make system`", file=sys.stderr)
        return 2
    rows = []
    for preset in args.presets.split(","):
        print(f"benchmarking preset {preset} ...", flush=True)
        rows.append(bench(preset.strip()))
    text = report(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "dem_overhead.md").write_text(text)
    (args.out / "dem_overhead.json").write_text(json.dumps(rows, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
