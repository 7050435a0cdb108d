"""LAMMPS benchmark: steps/s of the bare and of the production loop of the LAMMPS scene.

``python3 -m dem.tools.lammps_bench RUN_DIR STEPS REPEATS OUT.json`` (Debian's python3 with LAMMPS) builds the scene of
RUN_DIR/spec.json, compacts it and shears it STEPS steps (no checkpoint), then times STEPS steps of shear in three
modes, REPEATS times each, interleaved (best time kept): ``bare`` (the controller's ``fix python/invoke`` and
``fix halt`` removed: LAMMPS alone, the walls at their shear velocity with the gap held), ``untracked`` (the
controller and the in-situ sampling without the contact budget's tracking points), ``budget`` (the contacts tracked
without the near pairs' search, ``dem/core/neighbours.py``) and ``full`` (as in production, the contacts and near pairs
tracked every ``contact_track_strain``). Unlike ``dem/tools/yade_bench.py`` the runs follow one another
rather than restart from one kept state (LAMMPS reads a restart file back in one process only once, see
``dem/lammps/scene.py``): each repeat shears on, in the same steady state. Times are the process's CPU time (one
rank, no threads: the steps/s of a core of its own, as untouched by other work on the machine as a time can be).
"""

import dataclasses
import json
import sys
import time

from dem.core import protocol
from dem.lammps import scene as lammps_scene


def main():
    steps, repeats, out = int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    scene = lammps_scene.Scene(sys.argv[1])
    run = scene.start()
    run.state.next_checkpoint = 1 << 62
    # the runs follow one another: a bare run's held gap leaves the wall stress off p for the next full run, whose
    # wall-stress alarm would stop the benchmark (it measures speed, not physics)
    run.spec = dataclasses.replace(run.spec, stress_alarm=float("inf"))
    # and its repeats shear on past the run's own end (four modes of a small cell's steps can outrun it)
    run.spec = dataclasses.replace(run.spec, n_cycles=100 * run.spec.n_cycles)
    run.sample_strains, run.track_strains = protocol.sample_strains(run.spec), protocol.track_strains(run.spec)
    lmp = scene.lmp
    while run.state.phase == "compaction":
        lmp.command(f"run {steps}")
    lmp.command(f"run {steps}")
    every = int(scene.spec.control_every_steps)
    times = {"bare": [], "untracked": [], "budget": [], "full": []}
    tracker, track_strains = run.tracker, run.track_strains
    for _ in range(repeats):
        for mode in times:
            tracked = mode in ("budget", "full")
            run.tracker, run.track_strains = (tracker, track_strains) if tracked else (None, [])
            run.neighbour_search = mode == "full"
            if mode == "bare":  # the walls go on at their shear velocity, the gap held (as dem/tools/yade_bench.py's)
                lmp.command("unfix halt")
                lmp.command("unfix control")
                lmp.set_variable("tvy", "0.0")
            tic = time.process_time()  # one rank: the CPU it spent, whatever else runs on the machine
            lmp.command(f"run {steps}")
            times[mode].append(time.process_time() - tic)
            if mode == "bare":
                lmp.command(f"fix control all python/invoke {every} end_of_step {lammps_scene.CONTROL}")
                lmp.command(f"fix halt all halt {every} v_halte != 0 error continue message no")
            if run.state.phase != "shear":
                raise RuntimeError(f"the benchmark left the shear phase: {run.state.phase} {run.failure}")
    best = {mode: min(t) for mode, t in times.items()}
    bodies = run.state.n_grains + run.state.n_wall_spheres
    result = {"engine": "lammps", "engine_version": lmp.version(), "preset": scene.spec.preset,
              "contact_track_strain": scene.spec.contact_track_strain,
              "grains": run.state.n_grains, "wall_spheres": run.state.n_wall_spheres, "steps": steps,
              "repeats": repeats, "dt": run.dt(), "seconds": best,
              "steps_per_second": {mode: steps / t for mode, t in best.items()},
              "particle_steps_per_second": {mode: steps * bodies / t for mode, t in best.items()},
              "spread_percent": {mode: 100 * (max(t) / best[mode] - 1) for mode, t in times.items()}}
    with open(out, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
