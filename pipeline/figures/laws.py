"""Figs. 3 and 4 from ``fit.h5``: alpha_i and beta_i against S from the reversal (with the fitted
lines and log-log insets of |alpha_i|), and C and Y against S from the Sec. 3.3 cross-check; the
lines are the laws of each parameter set drawn over S."""

from __future__ import annotations

from pathlib import Path

import h5py
import matplotlib.pyplot as plt
import numpy as np

from .output import save


def fabric_law(fit_h5: Path, params, paper, out: Path) -> Path:
    """Fig. 3: alpha_i (top, log-log insets) and beta_i = alpha_i S^k (bottom) against S."""
    fig, axes = plt.subplots(2, 2, figsize=(10, 7))
    S_line = np.linspace(1e-3, 0.25, 200)
    k = params.persistence_exponent
    with h5py.File(fit_h5, "r") as f:
        groups = [f["reversal"][key] for key in f["reversal"]]
        for col, i in enumerate((1, 2)):
            a, b = getattr(params, f"a{i}"), getattr(params, f"b{i}")
            pa, pb = getattr(paper, f"a{i}"), getattr(paper, f"b{i}")
            inset = axes[0, col].inset_axes([0.55, 0.55, 0.4, 0.4])  # one per panel: every seed in it
            for g in groups:
                S, alpha, beta = g["S"][()], g[f"alpha{i}"][()], g[f"beta{i}"][()]
                axes[0, col].plot(S, alpha, ".", ms=3, color="C0", alpha=0.6)
                axes[1, col].plot(S, beta, ".", ms=3, color="C0", alpha=0.6)
                ok = (S > 0) & np.isfinite(alpha) & (alpha != 0)
                inset.loglog(S[ok], np.abs(alpha[ok]), ".", ms=2, color="C0")
            inset.loglog(S_line, np.abs((a + b * S_line) / S_line**k), "C1-", lw=1)
            inset.tick_params(labelsize=6)
            axes[0, col].plot(S_line, (a + b * S_line) / S_line**k, "C1-", label="our fit")
            axes[0, col].plot(S_line, (pa + pb * S_line) / S_line**k, "k--", label="Table 2")
            axes[1, col].plot(S_line, a + b * S_line, "C1-", label="our fit")
            axes[1, col].plot(S_line, pa + pb * S_line, "k--", label="Table 2")
            axes[0, col].set_ylabel(rf"$\alpha_{i}$")
            axes[1, col].set_ylabel(rf"$\beta_{i} = \alpha_{i} S^{{{k:g}}}$")
            axes[1, col].set_xlabel("S")
            lim = np.nanpercentile(np.abs(np.concatenate([g[f"alpha{i}"][()] for g in groups])), 95)
            axes[0, col].set_ylim(-3 * lim, 3 * lim)
    axes[1, 0].legend(fontsize=8)
    fig.suptitle("Fig. 3: fabric coefficients from the reversal (Eqs. 9, 12, 13)", fontsize=10)
    return save(fig, out)


#: the angles' colours in Fig. 4: matplotlib's cycle without C1, which is our fit's in every figure
ANGLE_COLORS = tuple(f"C{k}" for k in range(10) if k != 1)


def flow_rule(fit_h5: Path, params, paper, out: Path) -> Path:
    """Fig. 4: C (left) and Y (right) against S, from the 12 and 32 components at every angle."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    S_line = np.linspace(0, 0.25, 50)
    colors = {}  # one colour and one legend entry per angle, however many seeds it has
    with h5py.File(fit_h5, "r") as f:
        for key in f.get("cross_check", {}):
            g = f["cross_check"][key]
            theta = g.attrs["theta_deg"]
            label = None if theta in colors else f"θ = {theta:g}°"
            color = colors.setdefault(theta, ANGLE_COLORS[len(colors) % len(ANGLE_COLORS)])
            axes[0].plot(g["S"][()], g["C"][()], ".", ms=3, color=color, label=label)
            axes[1].plot(g["S"][()], g["Y"][()], ".", ms=3, color=color, label=label)
        for n, key in enumerate(f["reversal"]):
            g = f["reversal"][key]
            axes[1].plot(g["S"][()], g["Y"][()], "x", ms=3, color="grey", label=None if n else "reversal (Eq. 16)")
    axes[0].axhline(params.C, color="C1", label="our fit")
    axes[0].axhline(paper.C, color="k", ls="--", label="Table 2")
    axes[1].plot(S_line, params.n + params.m * S_line, "C1-", label="our fit")
    axes[1].plot(S_line, paper.n + paper.m * S_line, "k--", label="Table 2")
    axes[0].set_ylim(3 * paper.C, 0)
    axes[1].set_ylim(-0.2, 0.6)
    for ax, name in zip(axes, ("C", "Y"), strict=True):
        ax.set_xlabel("S")
        ax.set_ylabel(name)
        ax.legend(fontsize=7)
    fig.suptitle("Fig. 4: the flow rule (Eq. 14) from the 12 and 32 components", fontsize=10)
    return save(fig, out)
