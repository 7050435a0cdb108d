"""Where Yade's time goes in the production scene: per engine, the collider's work, the interactions, checkpoints.

``python3 -m dem.tools.yade_profile RUN_DIR STEPS OUT.json [CACHE.yade.gz]`` (Debian's python3) builds the scene of
RUN_DIR/spec.json and compacts it (or loads the compacted, briefly sheared state from CACHE, which it
writes the first time: a paper-size compaction takes the better part of an hour), then runs STEPS
production steps with Yade's timers on (``O.timingEnabled``) and writes OUT.json: each engine's share
of the loop time and its calls; ``yade.timing.stats()`` as text (the interaction loop's functors
inside); how often the collider re-sorted (``numAction``); potential (bounding-box) and real
interactions per grain; steps per second with and without the timers; and the wall time of one
checkpoint save and reload at this size.
"""

import contextlib
import io
import json
import os
import sys
import time

from dem.yade import scene as yade_scene
from dem.yade.lib import O


def prepare(scene, cache, shear_steps=2000, chunk=20000):
    """The compacted scene, sheared ``shear_steps`` steps, in memory (from ``cache`` when it exists, which
    is written otherwise), attached to ``scene``, its checkpoints off."""
    if cache and os.path.exists(cache):
        scene.load(cache)
        return "loaded"
    state = scene.build().state
    state.next_checkpoint = 1 << 62
    while state.phase == "compaction":
        O.run(chunk, True)  # the shear starts within the last chunk
    O.run(shear_steps, True)  # into shear
    O.tags["state"] = json.dumps(state.to_dict())
    if cache:
        O.save(cache)
    return "built"


def timed_steps(steps):
    tic = time.perf_counter()
    O.run(steps, True)
    return time.perf_counter() - tic


def main():
    run_dir, steps, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    cache = sys.argv[4] if len(sys.argv) > 4 else None
    scene = yade_scene.Scene(run_dir)
    origin = prepare(scene, cache)
    scene.run.state.next_checkpoint = 1 << 62
    O.tags["state"] = json.dumps(scene.run.state.to_dict())
    plain = timed_steps(steps)  # timers off: the production speed
    collider = next(e for e in O.engines if type(e).__name__ == "InsertionSortCollider")
    sorts_before = collider.numAction
    O.timingEnabled = True
    for e in O.engines:
        e.execTime, e.execCount = 0, 0
    timed = timed_steps(steps)
    engines = [{"engine": e.label or type(e).__name__, "seconds": e.execTime * 1e-9, "calls": e.execCount}
               for e in O.engines]
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        import yade.timing

        yade.timing.stats()
    O.timingEnabled = False
    total = sum(e["seconds"] for e in engines)
    for e in engines:
        e["percent"] = 100 * e["seconds"] / total
    st = scene.run.state
    grains = st.n_grains
    potential, real = len(O.interactions), O.interactions.countReal()  # a saved scene keeps only real contacts
    tic = time.perf_counter()
    O.save(os.path.join(run_dir, "profile.yade.gz"))
    saved = time.perf_counter() - tic
    tic = time.perf_counter()
    O.load(os.path.join(run_dir, "profile.yade.gz"))
    loaded = time.perf_counter() - tic
    os.remove(os.path.join(run_dir, "profile.yade.gz"))
    result = {
        "preset": scene.spec.preset, "grains": grains, "wall_spheres": 2 * len(st.top[1]),
        "origin": origin, "steps": steps, "threads": int(os.environ.get("OMP_NUM_THREADS", "1")),
        "steps_per_second": steps / plain, "steps_per_second_timed": steps / timed,
        "particle_steps_per_second": steps * (grains + 2 * len(st.top[1])) / plain,
        "engines": engines, "collider_sorts": collider.numAction - sorts_before,
        "collider_verlet_dist": collider.verletDist,
        "interactions_potential_per_grain": potential / grains, "interactions_real_per_grain": real / grains,
        "checkpoint_save_seconds": saved, "checkpoint_load_seconds": loaded, "timing_stats": text.getvalue(),
    }
    with open(out, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
