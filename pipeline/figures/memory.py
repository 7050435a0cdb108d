"""The memory of the old shear direction after each turn, from ``compare.h5``'s ``memory`` groups: the
fabric's part normal to the new shear direction, as a fraction of the old steady fabric's, against the strain
after the turn; the DEM (mean over cycles ± standard error, both turns of a run; other seeds' means as thin lines)
against each parameter set."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from .output import legend_of_all, save

TURN_STYLE = {"after the turn to theta": ("C0", "o"), "after the turn back": ("C3", "s")}


def plot(groups: list, labels: list[str], out: Path, title: str) -> Path:
    """``groups``: compare.h5's memory groups; one panel per run, the model's curve of each set in ``labels``."""
    runs = list(dict.fromkeys(g.attrs["run"] for g in groups))
    fig, axes = plt.subplots(1, len(runs), figsize=(3.2 * len(runs) + 0.6, 3.4), sharey=True, squeeze=False)
    for ax, run in zip(axes[0], runs, strict=True):
        mine = [g for g in groups if g.attrs["run"] == run]
        compared = mine[0].attrs.get("seed")  # the compared seed's groups come first; others' follow
        seeds = {g.attrs.get("seed") for g in mine}
        for g in mine:
            colour, marker = TURN_STYLE[g.attrs["segment"]]
            x, y, se = g["strain_after"][()], g["dem"][()], g["dem_sem"][()]
            if g.attrs.get("seed") != compared:
                ax.plot(x, y, "-", color=colour, lw=0.7, alpha=0.7, label="DEM, other seeds")
                continue
            ax.fill_between(x, y - se, y + se, color=colour, alpha=0.2, lw=0)
            ax.plot(x, y, marker, color=colour, ms=2, label=f"DEM, {g.attrs['segment']}")
        for k, label in enumerate(labels):  # the model's two turns by one angle are one curve
            m = mine[0]["model"][label]
            ax.plot(m["strain_after"][()], m["fraction"][()], ("k--", "k-")[k % 2], lw=1, label=f"model, {label}")
        ax.axhline(0.0, color="0.6", lw=0.5)
        turn = abs(mine[0].attrs["direction_deg"] - mine[0].attrs["from_deg"])
        ax.set_title(f"{run}: a turn of {turn:g}°" + (f", {len(seeds)} seeds" if len(seeds) > 1 else ""), fontsize=9)
        ax.set_xlabel("strain after the turn")
    axes[0][0].set_ylabel("old direction's part left")
    legend_of_all(axes[0][0], axes[0], fontsize=6)
    fig.suptitle(title, fontsize=10)
    return save(fig, out)
