"""Figs. 5-7: A12, A32, tau12/p, tau32/p over the cycle, DEM (mean and standard-error band) against
the model with Table 2 and with our fit, one row per run."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..validation import COMPONENTS, model_for  # noqa: E402
from .output import save  # noqa: E402

LABELS = {"A12": "$A_{12}$", "A32": "$A_{32}$", "tau12": r"$\tau_{12}/p$", "tau32": r"$\tau_{32}/p$"}


def plot(runs: list, params_sets: dict, out: Path, title: str) -> Path:
    """One row per run, one column per component; ``params_sets``: label -> model.Params."""
    fig, axes = plt.subplots(len(runs), 4, figsize=(13, 2.4 * len(runs) + 0.6), squeeze=False, sharex=True)
    styles = dict(zip(params_sets, ("k-", "C1--", "C2:"), strict=False))
    for row, run in zip(axes, runs, strict=True):
        c = run.cycle
        for label, params in params_sets.items():
            data, pred = model_for(run, params)
            strain = data.strain * data.bulk_over_nominal
            for ax, (field, i, j) in zip(row, COMPONENTS.values(), strict=True):
                ax.plot(strain, getattr(pred, field)[:, i, j], styles[label], lw=1.2, label=f"model, {label}")
        ratio = data.bulk_over_nominal
        for ax, (name, (field, i, j)) in zip(row, COMPONENTS.items(), strict=True):
            key = "A" if field == "A" else "tau_over_p"
            mean, sem = c[key][:, i, j], np.nan_to_num(c[key + "_sem"][:, i, j])
            x = c["strain"] * ratio
            ax.fill_between(x, mean - sem, mean + sem, color="C0", alpha=0.3, lw=0)
            ax.plot(x, mean, "C0.", ms=2, label="DEM")
            ax.set_ylabel(LABELS[name])
        rot = run.spec["rotate_at_strain"]
        row[0].set_title(f"θ = {run.spec['theta_deg']:g}°, rotation at {rot:g}", loc="left", fontsize=9)
    for ax in axes[-1]:
        ax.set_xlabel(r"bulk strain $t\dot\gamma$")
    axes[0, -1].legend(fontsize=7, loc="best")
    fig.suptitle(title, fontsize=10)
    return save(fig, out)
