"""Does the order of the grains in memory matter? Steps/s with the grains as created against sorted in space.

``python3 -m dem.tools.yade_order RUN_DIR STEPS REPEATS OUT.json CACHE.yade.gz`` (Debian's python3) loads the compacted
state that ``dem/tools/yade_profile.py`` cached, then times STEPS production steps REPEATS times in two layouts,
interleaved, each from that same state: ``created`` (the grains as makeCloud placed them: random in
space) and ``morton`` (the grains' states permuted among their bodies so that body ids follow a Z-order
curve through the cell on a 1 d grid: neighbours in space are neighbours in memory). Both layouts
drop the contacts and let the collider find them again (the permutation would scramble them), so both
lose the same tangential-spring history; the physics of either is the same up to that.
"""

import json
import sys
import time

from dem.tools.yade_profile import control  # noqa: F401 - the PyRunner's command runs in this namespace
from dem.yade import scene as yade_scene
from dem.yade.lib import O, Vector3


def morton_key(x, y, z, bits=10):
    key = 0
    for b in range(bits):
        key |= ((x >> b) & 1) << (3 * b) | ((y >> b) & 1) << (3 * b + 1) | ((z >> b) & 1) << (3 * b + 2)
    return key


def layout(scene, order, steps, cache):
    """Load the cached state; with ``morton``, move the grains' states so that ids follow space."""
    run = scene.load(cache)
    run.state.next_checkpoint = 1 << 62
    grains = run.grains
    if order == "morton":
        keys = [morton_key(*(int(max(c, 0.0)) for c in b.state.pos)) for b in grains]
        states = [(b.state.pos, b.state.vel, b.state.angVel, b.state.ori, b.shape.radius, b.state.mass,
                   b.state.inertia) for b in grains]
        for body, k in zip(grains, sorted(range(len(grains)), key=keys.__getitem__), strict=True):
            pos, vel, ang, ori, radius, mass, inertia = states[k]
            body.state.pos, body.state.vel, body.state.angVel, body.state.ori = Vector3(pos), Vector3(vel), \
                Vector3(ang), ori
            body.shape.radius, body.state.mass, body.state.inertia = radius, mass, Vector3(inertia)
        scene.attach().state.next_checkpoint = 1 << 62  # radii and masses in the new order
    O.interactions.clear()
    O.run(200, True)  # the collider finds the contacts again
    tic = time.perf_counter()
    O.run(steps, True)
    return time.perf_counter() - tic


def main():
    run_dir, steps, repeats, out, cache = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
    scene = yade_scene.Scene(run_dir)
    times = {"created": [], "morton": []}
    for _ in range(repeats):
        for order in times:
            times[order].append(layout(scene, order, steps, cache))
    best = {k: min(v) for k, v in times.items()}
    result = {"preset": scene.spec.preset, "grains": scene.run.state.n_grains, "steps": steps,
              "repeats": repeats, "seconds": times, "steps_per_second": {k: steps / v for k, v in best.items()},
              "speedup": best["created"] / best["morton"]}
    with open(out, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
