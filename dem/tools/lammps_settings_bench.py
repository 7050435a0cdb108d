"""LAMMPS settings benchmark: steps/s of the production loop from a run's checkpoint, with engine commands changed.

``python3 -m dem.tools.lammps_settings_bench RUN_DIR STEPS OUT.json [COMMAND ...]`` (Debian's python3 with LAMMPS)
resumes the run of RUN_DIR (a copy: it is sheared on and left changed), issues each COMMAND (``neighbor 0.15 bin``,
``atom_modify sort 1000 0.0``), shears ``WARMUP`` steps (the settings' set-up, the first neighbour lists), then times
STEPS steps of the production loop (controller and sampling; no checkpoint). One setting per process: LAMMPS reads a
restart file back in one process only once (``dem/lammps/scene.py``), so ``pipeline.studies.bench_lammps_settings``
starts one process per setting and round, from the same state.
"""

import json
import sys
import time

from dem.lammps import scene as lammps_scene

WARMUP = 200


def main():
    run_dir, steps, out, commands = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
    scene = lammps_scene.Scene(run_dir)
    run = scene.start()
    run.state.next_checkpoint = 1 << 62
    lmp = scene.lmp
    for command in commands:
        lmp.command(command)
    lmp.command(f"run {WARMUP}")
    tic = time.perf_counter()
    lmp.command(f"run {steps}")
    seconds = time.perf_counter() - tic
    if run.failure:
        raise RuntimeError(f"the run failed while timed: {run.failure}")
    result = {"engine_version": lmp.version(), "preset": scene.spec.preset, "grains": run.state.n_grains,
              "iteration": run.iteration(), "commands": commands, "steps": steps, "seconds": seconds,
              "steps_per_second": steps / seconds}
    with open(out, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
