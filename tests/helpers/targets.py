"""Which test runs which target `make help` names (``RUN_HERE``), and the ones CI's `make test` is made of
(``RUN_BY_CI``): a new target fails ``test_every_target_is_run_here_or_by_ci`` until it is placed."""

from tests.helpers.project import LANE, LANE_TEST

RUN_HERE = {
    "help": "test_every_target_is_run_here_or_by_ci",
    **dict.fromkeys(("dem", "engines", "bench-lammps-settings", "bench-dem", "sweep", "runs", "sweep-status",
                     "fidelity", "profile-dem", "stability"),
                    "test_a_dem_or_engine_target_runs_at_the_tiny_size"),
    **dict.fromkeys(("fit", "compare", "figures", "compare-seed", "fit-bootstrap", "fit-jackknife", "fit-angles",
                     "fit-definitions", "fidelity-table", "data-card", "clean"),
                    "test_a_data_target_runs_on_the_committed_data"),
    # the demo (its DEM runs, demo-dem, first), what follows it on its data set, and the studies of committed data
    **dict.fromkeys(("demo", "demo-dem", "sweep-collect", "fit-from", "fit-profile", "models", "bench", "versus",
                     "cells", "jump", "budget", "model-cycles"), LANE_TEST),
}
assert {args[0] for args in LANE} <= set(RUN_HERE)
RUN_BY_CI = ("test", "test-unit", "test-yade", "test-cluster", "lint", "venv", "system", "system-venv",
             "system-lammps", "system-slurm")
