"""The profile likelihood of every fitted parameter, from ``profiles.json`` (``make fit-profile``)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .output import save  # noqa: E402


def plot(result: dict, paper, out: Path) -> Path:
    """chi^2 rise over the best fit's reduced chi^2 against each held parameter; Table 2's value marked."""
    names = list(result["parameters"])
    fig, axes = plt.subplots(1, len(names), figsize=(2.4 * len(names), 2.8), squeeze=False)
    for ax, name in zip(axes[0], names, strict=True):
        p = result["parameters"][name]
        ax.plot(p["grid"], np.array(p["chi2_rise"]) / result["reduced_chi2"], "C0.-")
        for level, factor in result["levels"].items():
            ax.axhline(factor, color="grey", lw=0.6, ls=":")
            ax.text(p["grid"][0], factor, f" {level} %", fontsize=6, va="bottom")
        ax.axvline(p["best"], color="C0", lw=0.6)
        ax.axvline(getattr(paper, name), color="k", ls="--", lw=0.8, label="Table 2")
        ax.set_xlabel(name)
        ax.set_ylim(0, 6)
    axes[0, 0].set_ylabel(r"$\Delta\chi^2 / \chi^2_{red}$")
    axes[0, 0].legend(fontsize=6)
    fig.suptitle("Profile likelihood: each parameter held, the others refitted (misfit-scaled)", fontsize=9)
    return save(fig, out)
