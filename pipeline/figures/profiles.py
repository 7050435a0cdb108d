"""The profile likelihood of every fitted parameter, from ``profiles.json`` (``make fit-profile``)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import model

from .output import save


def belongs_to(result: dict, fit) -> bool:
    """Whether ``profiles.json`` profiles the fit in ``fit.json`` (a ``schema.FitSummary``, or None): the same
    parameters at the same best values."""
    g = fit.global_fit.estimates if fit and fit.global_fit else None
    best = dict(zip(g.free, g.values, strict=True)) if g else {}
    parameters = result.get("parameters", {})
    return bool(parameters) and set(parameters) == set(best) and all(
        "noise_factor" in p and np.isclose(p["best"], best[n], rtol=1e-6) for n, p in parameters.items())


def plot(result: dict, paper, out: Path) -> Path:
    """chi^2 rise over each parameter's noise factor against the held parameter (1 and 3.84 mark the 68 and
    95 % intervals); Table 2's value marked."""
    names = list(result["parameters"])
    fig, axes = plt.subplots(1, len(names), figsize=(2.4 * len(names), 2.8), squeeze=False)
    for ax, name in zip(axes[0], names, strict=True):
        p = result["parameters"][name]
        ax.plot(p["grid"], np.array(p["chi2_rise"]) / p["noise_factor"], "C0.-")
        for level, factor in result["levels"].items():
            ax.axhline(factor, color="grey", lw=0.6, ls=":")
            ax.text(p["grid"][0], factor, f" {level} %", fontsize=6, va="bottom")
        ax.axvline(p["best"], color="C0", lw=0.6)
        ax.axvline(getattr(paper, name) if name in paper.own_names() else model.params.table2_value(name), color="k",
                   ls="--", lw=0.8, label="Table 2")
        ax.set_xlabel(name)
        ax.set_ylim(0, 6)
    axes[0, 0].set_ylabel(r"$\Delta\chi^2$ / noise factor")
    axes[0, 0].legend(fontsize=6)
    fig.suptitle("Profile likelihood: each parameter held, the others refitted (the DEM's correlated noise)",
                 fontsize=9)
    return save(fig, out)
