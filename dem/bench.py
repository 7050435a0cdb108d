"""Yade benchmark: steps/s of the bare loop and of the production loop, and the cost of our Python in it.

``python3 -m dem.bench RUN_DIR STEPS REPEATS OUT.json [CACHE.yade.gz]`` (Debian's python3) builds the scene of
RUN_DIR/spec.json, compacts it and shears it briefly (or loads that state from CACHE, written the first
time, as ``dem/profile.py`` does), keeps it in memory, then times STEPS steps from that same state in
three modes, REPEATS times each, interleaved (best time kept): ``bare`` (no Python in the loop, walls at
constant velocity), ``dispatch`` (the PyRunner calls an empty command every ``control_every_steps``: the
same trajectory as bare, so the difference is the dispatch cost) and ``full`` (the wall controller and the
in-situ sampling, as in production). The controller changes the trajectory, so the cost of our Python is
timed inside the callbacks (``callback_seconds``), and the dispatch cost per call is measured with a
PyRunner every step (empty command against bare): cost = (dispatch per call x calls + callbacks) / bare.

One more pass of bare and of full runs with Yade's timers on, so that a difference between the two loops
shows up where it is: each engine's microseconds per step, the collider's sorts, and the interactions
(real contacts and all, the collider's potential pairs included) at the end of each mode.
"""

import json
import sys
import time

from dem import couette
from dem.profile import prepare
from dem.yade_lib import O, Vector3

MODES = ("bare", "dispatch", "full")


def control():
    couette.control()


def configure(mode, every=None):
    """Reload the kept state and configure ``mode``."""
    O.loadTmp("bench")
    couette.RUN = couette.Run()
    couette.RUN.state["next_checkpoint"] = 1 << 62
    controller = next(e for e in O.engines if e.label == "controller")
    controller.dead = mode == "bare"
    if mode == "dispatch":
        controller.command = "pass"
        controller.iterPeriod = every or controller.iterPeriod
    if mode in ("bare", "dispatch"):  # walls at constant velocity: keep the shear, stop the vertical motion
        for clump in (couette.RUN.top_clump, couette.RUN.bottom_clump):
            clump.state.vel = clump.state.vel - clump.state.vel[1] * Vector3(0, 1, 0)


def timed(mode, steps, every=None):
    """Seconds of ``steps`` steps in ``mode`` from the kept state, and the seconds inside our callbacks."""
    configure(mode, every)
    state = couette.RUN.state
    tic = time.perf_counter()
    O.run(steps, True)
    seconds = time.perf_counter() - tic
    if state["phase"] != "shear":
        raise RuntimeError(f"the benchmark left the shear phase: {state['phase']} {couette.RUN.failure}")
    return seconds, state["callback_seconds"]


def engine_split(mode, steps):
    """Yade's timers over ``steps`` steps of ``mode``: microseconds per step per engine, collider sorts,
    and the interactions (real, all) at the end."""
    configure(mode)
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
    couette.configure(sys.argv[1])
    prepare(cache, shear_steps=steps)
    state = couette.RUN.state
    state["callback_seconds"] = 0.0
    O.tags["state"] = json.dumps(state)
    O.saveTmp("bench")
    runs = {mode: [] for mode in MODES}
    for _ in range(repeats):  # interleaved, so that a busy spell of the machine hits every mode
        for mode in MODES:
            runs[mode].append(timed(mode, steps))
    callbacks = min(runs["full"])[1]
    best = {mode: min(t[0] for t in r) for mode, r in runs.items()}
    spread = max(t[0] for t in runs["bare"]) / best["bare"] - 1
    # the dispatch cost per call, from a PyRunner every step: well above the timing noise
    per_call = min(timed("dispatch", steps, every=1)[0] - timed("bare", steps)[0] for _ in range(repeats)) / steps
    calls = steps / couette.SPEC["control_every_steps"]
    sample_steps = couette.SPEC["sample_strain"] / (couette.RUN.gamma_dot * O.dt)
    wall_spheres = len(state["top"][1]) * 2
    result = {
        "preset": couette.SPEC["preset"], "grains": state["n_grains"], "wall_spheres": wall_spheres,
        "steps": steps, "repeats": repeats, "samples_per_run": steps / sample_steps,
        "control_every_steps": couette.SPEC["control_every_steps"], "dt": O.dt,
        "seconds": best, "steps_per_second": {mode: steps / t for mode, t in best.items()},
        "particle_steps_per_second": {mode: steps * (state["n_grains"] + wall_spheres) / t for mode, t in best.items()},
        "bare_spread_percent": 100 * spread, "callback_seconds": callbacks,
        "dispatch_percent": 100 * (best["dispatch"] / best["bare"] - 1),
        "dispatch_microseconds_per_call": 1e6 * per_call,
        "callback_percent": 100 * callbacks / best["bare"],
        "overhead_percent": 100 * (per_call * calls + callbacks) / best["bare"],
        "engines": {mode: engine_split(mode, steps) for mode in ("bare", "full")},
    }
    with open(out, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
