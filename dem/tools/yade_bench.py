"""Yade benchmark: steps/s of the bare loop and of the production loop, and the cost of our Python in it.

``python3 -m dem.tools.yade_bench RUN_DIR STEPS REPEATS OUT.json [CACHE.yade.gz]`` (Debian's python3) builds the scene
of RUN_DIR/spec.json, compacts it and shears it briefly (or loads that state from CACHE, written the first time, as
``dem/tools/yade_profile.py`` does), keeps it in memory, then times STEPS steps from that same state in two modes,
REPEATS times each, interleaved (best time kept): ``bare`` (no Python in the loop, the walls go on at their velocity
without the vertical part: the gap is held, so the packing's contacts may change) and ``full`` (the wall controller
and the in-situ sampling, as in production).

One more pass of each with Yade's timers on says where a difference between the two loops comes from:
each engine's microseconds per step, the collider's sorts and the interactions (real contacts and all,
the collider's potential pairs included) at the end. The cost of our Python is the controller
PyRunner's share of the timed production loop (its dispatch and our callbacks, timed by Yade).
"""

import json
import sys
import time

from dem.tools.yade_profile import prepare
from dem.yade import scene as yade_scene
from dem.yade.lib import O, Vector3

MODES = ("bare", "full")


def configure(scene, mode):
    """Reload the kept state into ``scene`` and configure ``mode``."""
    O.loadTmp("bench")
    run = scene.attach()
    run.state.next_checkpoint = 1 << 62
    controller = next(e for e in O.engines if e.label == "controller")
    controller.dead = mode == "bare"
    if mode == "bare":  # walls at constant velocity: keep the shear, stop the vertical motion
        for clump in (run.top_clump, run.bottom_clump):
            clump.state.vel = clump.state.vel - clump.state.vel[1] * Vector3(0, 1, 0)


def timed(scene, mode, steps):
    """Seconds of ``steps`` steps in ``mode`` from the kept state."""
    configure(scene, mode)
    state = scene.run.state
    tic = time.perf_counter()
    O.run(steps, True)
    seconds = time.perf_counter() - tic
    if state.phase != "shear":
        raise RuntimeError(f"the benchmark left the shear phase: {state.phase} {scene.run.failure}")
    return seconds


def engine_split(scene, mode, steps):
    """Yade's timers over ``steps`` steps of ``mode``: microseconds per step per engine, collider sorts,
    and the interactions (real, all) at the end."""
    configure(scene, mode)
    collider = next(e for e in O.engines if type(e).__name__ == "InsertionSortCollider")
    sorts = collider.numAction
    O.timingEnabled = True
    for e in O.engines:
        e.execTime, e.execCount = 0, 0
    O.run(steps, True)
    O.timingEnabled = False
    return {"microseconds_per_step": {e.label or type(e).__name__: e.execTime * 1e-3 / steps for e in O.engines},
            "collider_sorts": collider.numAction - sorts,
            "interactions_real": O.interactions.countReal(), "interactions_all": len(O.interactions)}


def main():
    steps, repeats, out = int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    cache = sys.argv[5] if len(sys.argv) > 5 else None
    scene = yade_scene.Scene(sys.argv[1])
    prepare(scene, cache, shear_steps=steps)
    state = scene.run.state
    O.tags["state"] = json.dumps(state.to_dict())
    O.saveTmp("bench")
    runs = {mode: [] for mode in MODES}
    for _ in range(repeats):  # interleaved, so that a busy spell of the machine hits every mode
        for mode in MODES:
            runs[mode].append(timed(scene, mode, steps))
    best = {mode: min(r) for mode, r in runs.items()}
    engines = {mode: engine_split(scene, mode, steps) for mode in MODES}
    full = engines["full"]["microseconds_per_step"]
    wall_spheres = len(state.top[1]) * 2
    bodies = state.n_grains + wall_spheres
    result = {
        "preset": scene.spec.preset, "grains": state.n_grains, "wall_spheres": wall_spheres,
        "steps": steps, "repeats": repeats, "control_every_steps": scene.spec.control_every_steps, "dt": O.dt,
        "seconds": best, "steps_per_second": {mode: steps / t for mode, t in best.items()},
        "particle_steps_per_second": {mode: steps * bodies / t for mode, t in best.items()},
        "spread_percent": {mode: 100 * (max(r) / best[mode] - 1) for mode, r in runs.items()},
        "python_percent": 100 * full["controller"] / sum(full.values()), "engines": engines,
    }
    with open(out, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
