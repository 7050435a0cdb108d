"""Figs. 5-7 from ``compare.h5``: A12, A32, tau12/p, tau32/p over the cycle, DEM (mean and
standard-error band, and the cycle means of the protocol's other seeds) against the model with each parameter set,
one row per run."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .output import legend_of_all, save, strain_label

COMPONENTS = {"A12": ("A", 0, 1), "A32": ("A", 2, 1), "tau12": ("tau_over_p", 0, 1), "tau32": ("tau_over_p", 2, 1)}
LABELS = {"A12": "$A_{12}$", "A32": "$A_{32}$", "tau12": r"$\tau_{12}/p$", "tau32": r"$\tau_{32}/p$"}


def plot(groups: list, out: Path, title: str) -> Path:
    """One row per run group of compare.h5, one column per component."""
    fig, axes = plt.subplots(len(groups), 4, figsize=(13, 2.4 * len(groups) + 0.6), squeeze=False, sharex=True)
    for row, g in zip(axes, groups, strict=True):
        labels = list(g["model"])
        styles = dict(zip(labels, ("k-", "C1--", "C2:"), strict=False))
        for label in labels:
            m = g["model"][label]
            for ax, (field, i, j) in zip(row, COMPONENTS.values(), strict=True):
                ax.plot(m["strain_bulk"][()], m[field][:, i, j], styles[label], lw=1.2, label=f"model, {label}",
                        zorder=3)
        dem = g["dem"]
        x = dem["strain_bulk"][()]
        others = [g["other_seeds"][seed] for seed in g.get("other_seeds", {})]
        for ax, (name, (field, i, j)) in zip(row, COMPONENTS.items(), strict=True):
            for n, other in enumerate(others):  # beneath the rest, fainter the more there are
                ax.plot(other["strain_bulk"][()], other[field][:, i, j], "-", color="C9", lw=0.7, zorder=1,
                        alpha=min(0.8, 1.6 / len(others)), label=None if n else "DEM, other seeds")
            mean, sem = dem[field][:, i, j], np.nan_to_num(dem[field + "_sem"][:, i, j])
            ax.fill_between(x, mean - sem, mean + sem, color="C0", alpha=0.3, lw=0)
            ax.plot(x, mean, "C0.", ms=2, label="DEM")
            ax.set_ylabel(LABELS[name])
        seeds = f", {1 + len(others)} seeds" if others else ""
        row[0].set_title(f"θ = {g.attrs['theta_deg']:g}°, rotation at {g.attrs['rotate_at_strain']:g}{seeds}",
                         loc="left", fontsize=9)
    for ax in axes[-1]:
        ax.set_xlabel(strain_label(groups[0]))
    legend_of_all(axes[0, -1], axes[:, -1], fontsize=7, loc="best")  # a row with other seeds need not be the first
    fig.suptitle(title, fontsize=10)
    return save(fig, out)
