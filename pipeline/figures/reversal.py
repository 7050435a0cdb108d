"""Figs. 8 and 9. Fig. 8 (from ``fit.h5``): backstress C A12 and isotropic part tau12/p - C A12
after the reversal, and tau12/p against A12. Fig. 9 (from the DEM runs): the work rates tau:D',
p dPhi/dt / Phi and their sum per unit p gamma_dot, and Phi from DEM and from Eq. 18."""

from __future__ import annotations

from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from ..dem_analysis import bulk_over_nominal  # noqa: E402
from ..validation import model_for  # noqa: E402
from .output import save  # noqa: E402


def reversal_parts(strain, tau12, A12, C: float, rotate_at: float = 0.7) -> dict:
    """The second half of a theta = 180 cycle (the reversal at ``rotate_at``): strain, tau12/p, A12,
    the backstress C A12 and the isotropic part tau12/p - C A12."""
    pick = strain >= rotate_at - 1e-9
    d = {"strain": strain[pick], "tau12": tau12[pick], "A12": A12[pick]}
    d["backstress12"] = C * d["A12"]
    d["isotropic12"] = d["tau12"] - d["backstress12"]
    return d


def after_reversal(group, C: float, rotate_at: float = 0.7) -> dict:
    """``reversal_parts`` of a reversal run's smoothed A12 and tau12/p in fit.h5."""
    return reversal_parts(group["strain"][()], group["tau12"][()], group["A12"][()], C, rotate_at)


def backstress_figure(fit_h5: Path, C: float, out: Path) -> Path:
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    with h5py.File(fit_h5, "r") as f:
        for key in f["reversal"]:
            d = after_reversal(f["reversal"][key], C)
            x = d["strain"] - d["strain"][0]
            axes[0].plot(x, d["backstress12"], "C0-", label="backstress $C A_{12}$")
            axes[0].plot(x, d["isotropic12"], "C1-", label=r"isotropic part $\tau_{12}/p - C A_{12}$")
            axes[0].plot(x, d["tau12"], "k:", label=r"$\tau_{12}/p$")
            axes[1].plot(d["A12"], d["tau12"], "C0.-", ms=2)
    axes[0].set_xlabel("strain after the reversal")
    axes[0].legend(fontsize=7)
    axes[1].set_xlabel("$A_{12}$")
    axes[1].set_ylabel(r"$\tau_{12}/p$")
    fig.suptitle(f"Fig. 8: backstress and isotropic part after the reversal (smoothed DEM, our C = {C:.2f})",
                 fontsize=10)
    return save(fig, out)


def work_figure(runs: list, params, out: Path) -> Path:
    fig, axes = plt.subplots(len(runs), 2, figsize=(10, 2.6 * len(runs) + 0.6), squeeze=False)
    for row, run in zip(axes, runs, strict=True):
        c = run.cycle
        ratio = bulk_over_nominal(run)
        x = c["strain"] * ratio
        w_shear, w_vol = c["w_shear"] / ratio, c["w_vol"] / ratio  # per unit bulk strain
        row[0].plot(x, w_shear, "C0.", ms=2, label=r"$\tau:D'$")
        row[0].plot(x, w_vol, "C1.", ms=2, label=r"$p\dot\Phi/\Phi$")
        row[0].plot(x, w_shear + w_vol, "k.", ms=2, label="sum")
        row[0].axhline(0, color="grey", lw=0.5)
        data, pred = model_for(run, params)
        row[1].plot(x, c["packing_fraction"], "C0.", ms=2, label="DEM")
        row[1].plot(data.strain * ratio, pred.packing_fraction, "C1-", label="Eq. 18, our fit")
        row[0].set_title(f"θ = {run.spec['theta_deg']:g}°", loc="left", fontsize=9)
        row[0].set_ylabel(r"per unit $p\dot\gamma$")
        row[1].set_ylabel(r"$\Phi$")
    axes[0, 0].legend(fontsize=7)
    axes[0, 1].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel(r"bulk strain $t\dot\gamma$")
    fig.suptitle("Fig. 9: work rates (Sec. 5) and the packing fraction", fontsize=10)
    return save(fig, out)
