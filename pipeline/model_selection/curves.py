"""What ``models.png`` draws (``figures.models``), written to ``models.h5`` (``schema.write_models_h5``): each law's
memory of the old direction after the large turns and its first strain after the reversal, beside the DEM's."""

from __future__ import annotations

import numpy as np

import model

from ..comparison import metrics
from ..schema import LawScore

#: strain after a reversal over which the figure follows the jump
JUMP_SPAN = 0.05


def runnable(run, sets: dict) -> dict:
    """``metrics.model_for`` of the parameter sets whose law can run the run's cycle (one that cannot draws no curve;
    its held-out score says so)."""
    out = {}
    for label, params in sets.items():
        try:
            out.update(metrics.model_for(run, {label: params}))
        except model.SolverError:
            continue
    return out


def curves(runs: list, results: list[LawScore]) -> dict:
    """What the figure draws: per variant, the memory of the old direction after the turns of 120 and 150 (the DEM's
    cycle mean; each variant fitted without 120 and 150, the ``angles`` split) and the first JUMP_SPAN strain after
    the reversal (A's component along the old direction per its steady value; each variant's fit on every run)."""
    out = {"memory": [], "jump": []}
    full = {r.variant: r.params for r in results}
    # each law's fit of the ``angles`` split (made wherever a run at 120 or 150 is held out), where it was fitted
    sets = {r.variant: s.params for r in results for s in r.splits if s.name == "angles" and s.params}
    for run in runs:
        if not run.default_rotation:
            continue
        if run.theta_deg in (120.0, 150.0):
            preds = runnable(run, sets)
            for c in metrics.memory_curves(run, preds):
                if c["segment"] == "after the turn to theta":
                    out["memory"].append({"run": run.path.stem, "seed": run.spec.seed, "theta": run.theta_deg,
                                          "strain": c["strain_after"],
                                          "dem": c["dem"].mean(axis=0),
                                          "model": {v: m[1] for v, m in c["model"].items()}})
        if run.is_reversal:
            preds = runnable(run, full)
            out["jump"].append(jump_curve(run, preds))
    return out


def jump_curve(run, preds: dict) -> dict:
    """A's component along the old direction (e1) over the first JUMP_SPAN strain after the reversal, per its steady
    value before it: the DEM's cycle mean and each variant's."""
    spec = run.spec
    grid, idx = metrics.cycle_grid(spec, run.series["strain_nominal"])
    change = next(metrics.changes(spec))
    _, start, _, _, old, old_start, old_end = change
    after = metrics.window(grid, start, start + JUMP_SPAN)
    dem = metrics.along(run.series["A"][idx], old).mean(axis=0)
    steady = dem[metrics.segment_windows(grid, old_start, old_end)[1]].mean()
    out = {"run": run.path.stem, "seed": spec.seed, "strain": grid[after] - start, "dem": dem[after] / steady,
           "model": {}}
    for variant, (data, pred) in preds.items():
        a = metrics.along(pred.A, old)
        late = metrics.segment_windows(data.strain, old_start, old_end)[1]
        out["model"][variant] = np.interp(grid[after], data.strain, a) / a[late].mean()
    return out
