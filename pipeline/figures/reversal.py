"""Figs. 8 and 9 from ``compare.h5``. Fig. 8: the backstress C A12 and the isotropic part
tau12/p - C A12 after the reversal, and tau12/p against A12. Fig. 9: the work rates tau:D',
p dPhi/dt / Phi and their sum per unit p gamma_dot, and Phi from DEM and from Eq. 18."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from .output import save, strain_label


def backstress_figure(parts: list, C: float, out: Path) -> Path:
    """``parts``: compare.h5's reversal groups."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for n, d in enumerate(parts):  # every reversal seed, named once in the legend
        x = d["strain"][()] - d["strain"][0]
        axes[0].plot(x, d["backstress12"][()], "C0-", label=None if n else "backstress $C A_{12}$")
        axes[0].plot(x, d["isotropic12"][()], "C1-", label=None if n else r"isotropic part $\tau_{12}/p - C A_{12}$")
        axes[0].plot(x, d["tau12"][()], "k:", label=None if n else r"$\tau_{12}/p$")
        axes[1].plot(d["A12"][()], d["tau12"][()], "C0.-", ms=2)
    axes[0].set_xlabel("strain after the reversal")
    axes[0].legend(fontsize=7)
    axes[1].set_xlabel("$A_{12}$")
    axes[1].set_ylabel(r"$\tau_{12}/p$")
    fig.suptitle(f"Fig. 8: backstress and isotropic part after the reversal (smoothed DEM, our C = {C:.2f})",
                 fontsize=10)
    return save(fig, out)


def work_figure(groups: list, label: str, out: Path) -> Path:
    """``groups``: compare.h5's reversal run groups; the model's Phi with parameter set ``label``."""
    fig, axes = plt.subplots(len(groups), 2, figsize=(10, 2.6 * len(groups) + 0.6), squeeze=False)
    for row, g in zip(axes, groups, strict=True):
        dem, m = g["dem"], g["model"][label]
        x = dem["strain_bulk"][()]
        w_shear, w_vol = dem["w_shear"][()], dem["w_vol"][()]
        row[0].plot(x, w_shear, "C0.", ms=2, label=r"$\tau:D'$")
        row[0].plot(x, w_vol, "C1.", ms=2, label=r"$p\dot\Phi/\Phi$")
        row[0].plot(x, w_shear + w_vol, "k.", ms=2, label="sum")
        row[0].axhline(0, color="grey", lw=0.5)
        row[1].plot(x, dem["packing_fraction"][()], "C0.", ms=2, label="DEM")
        row[1].plot(m["strain_bulk"][()], m["packing_fraction"][()], "C1-", label=f"Eq. 18, {label}")
        row[0].set_title(f"θ = {g.attrs['theta_deg']:g}°", loc="left", fontsize=9)
        row[0].set_ylabel(r"per unit $p\dot\gamma$")
        row[1].set_ylabel(r"$\Phi$")
    axes[0, 0].legend(fontsize=7)
    axes[0, 1].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel(strain_label(groups[0]))
    fig.suptitle("Fig. 9: work rates (Sec. 5) and the packing fraction", fontsize=10)
    return save(fig, out)
