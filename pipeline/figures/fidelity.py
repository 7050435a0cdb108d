"""The fidelity ladder's plots, from ``results/fidelity/table.json`` (``make fidelity``): read and draw.

``python -m pipeline.figures.fidelity [--table results/fidelity/table.json]`` writes beside the table
``error_vs_cpu.png`` (per angle, the relative shift of the steady shear stress ratio against CPU-hours,
log-log, one point per setting, error bars from the seeds' scatter, the Pareto front joined) and
``params_vs_fidelity.png`` (the steady stress ratio and each fitted parameter of the reversal against the
inertial number and the cell size, the table's line carried to the paper's value, and Table 2).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from ..cli import Parser, one_line_errors
from ..errors import PipelineError
from .output import save

PARAMETERS = ("mu", "C", "n", "m", "a1", "b1", "a2", "b2")
AXES = {"inertial_number": ("inertial number I", True), "cell": ("gap H / d", False)}
TITLES = {"mu": "steady τ12/p"}


class NothingToDraw(Exception):
    """A figure the table has no data for (yet): said, and the other figures drawn."""


def error_vs_cpu(table: dict, out: Path) -> Path:
    """Per angle: each setting's |shift| of the steady τ12/p from the reference (its runs' mean; error bars
    the shift's standard error from the seeds' scatter) against its CPU-hours per run, the Pareto front
    joined, and one run's scatter at the preset as a line."""
    thetas = [t for t in table["references"] if "mu" in table["recommendation"][t]["quantities"]]
    if not thetas:
        raise NothingToDraw("no angle has the seeds' scatter of the steady τ12/p (a seed axis) yet")
    fig, axes = plt.subplots(1, len(thetas), figsize=(6 * len(thetas), 4.5), squeeze=False)
    for ax, theta in zip(axes[0], thetas, strict=True):
        mu = table["recommendation"][theta]["quantities"]["mu"]
        ref = abs(mu["reference"])
        settings = [c for c in mu["candidates"] if c["setting"] != "preset"]
        front = table["pareto"][theta]
        for c in settings:
            y = max(abs(c["bias"]) / ref, 1e-3)
            low = min(c["bias_se"] / ref, y - 1e-3)
            on = c["setting"] in front
            ax.errorbar(c["cpu_hours_per_run"], y, yerr=[[low], [c["bias_se"] / ref]], fmt="o", ms=4, capsize=2,
                        lw=0.8, color="C3" if on else "C0")
            ax.annotate(f"{c['setting']} ({c['runs_measured']})", (c["cpu_hours_per_run"], y), fontsize=5,
                        xytext=(3, 2), textcoords="offset points")
        line = sorted((c["cpu_hours_per_run"], max(abs(c["bias"]) / ref, 1e-3)) for c in settings
                      if c["setting"] in front)
        if line:
            ax.plot([x for x, _ in line], [y for _, y in line], "--", color="C3", lw=0.8, label="Pareto front")
        preset = next(c for c in mu["candidates"] if c["setting"] == "preset")
        ax.axhline(preset["sd_per_run"] / ref, color="k", ls=":", lw=0.8,
                   label=f"one preset run's scatter ({preset['cpu_hours_per_run']:.2f} CPU-h)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.xaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.set_xlabel("CPU-hours per run (one thread)")
        ax.set_ylabel("|shift of steady τ12/p| / reference")
        ax.set_title(f"θ = {theta}°: settings (runs), against the preset's seeds", fontsize=9)
        ax.legend(fontsize=6, loc="lower right")
    return save(fig, out)


def params_vs_fidelity(table: dict, out: Path) -> Path:
    """Per extrapolated axis at θ = 180°: each quantity's values (runs at one setting pooled, errors from the
    seeds' scatter), the fitted line carried to the paper's value with its extrapolation, and Table 2."""
    lines = table.get("extrapolations", {}).get("180", {})
    axes_shown = [a for a in AXES if a in lines]
    if not axes_shown:
        raise NothingToDraw("no inertial-number or cell axis with two or more values at θ = 180° yet")
    fig, axes = plt.subplots(len(axes_shown), len(PARAMETERS), figsize=(2.3 * len(PARAMETERS), 2.5 * len(axes_shown)),
                             squeeze=False)
    for row_axes, axis in zip(axes, axes_shown, strict=True):
        label, log = AXES[axis]
        line = lines[axis]
        f = (lambda x: 1.0 / x) if line["transform"] == "inverse" else (lambda x: x)
        for ax, name in zip(row_axes, PARAMETERS, strict=True):
            q = line["quantities"].get(name)
            if q:
                x = [p["x"] for p in q["points"]]
                ax.errorbar(x, [p["mean"] for p in q["points"]], yerr=[p["standard_error"] for p in q["points"]],
                            fmt="o", ms=4, capsize=2, lw=0.8, label="runs (pooled per value)")
                grid = np.geomspace(min(*x, line["target"]), max(*x, line["target"]), 50)
                ax.plot(grid, q["intercept"] + q["slope"] * f(grid), "-", color="C0", lw=0.6)
                untested = q["chi2_per_dof"] is None
                ax.errorbar([line["target"]], [q["at_target"]], yerr=[q["at_target_se"]], fmt="s", ms=4, capsize=2,
                            lw=0.8, color="C3", mfc="none" if untested else "C3",
                            label="at the paper's value" + (" (two values: untested)" if untested else ""))
            if name in table.get("table2", {}):
                ax.axhline(table["table2"][name], color="k", ls="--", lw=0.8, label="Table 2")
            if log:
                ax.set_xscale("log")
                ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
                ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
                ax.set_xticks(sorted({*(p["x"] for p in (q or {"points": []})["points"]), line["target"]}))
            ax.set_xlabel(label, fontsize=7)
            ax.set_title(TITLES.get(name, name), fontsize=8)
            ax.tick_params(labelsize=6)
        row_axes[0].legend(fontsize=5)
    fig.suptitle("Reversal: each quantity against the DEM setting, its line carried to the paper's value",
                 fontsize=9)
    return save(fig, out)


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.figures.fidelity", description=__doc__.splitlines()[0])
    parser.add_argument("--table", type=Path, default=Path("results/fidelity/table.json"))
    args = parser.parse_args(argv)
    try:
        table = json.loads(args.table.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise PipelineError(f"cannot read {args.table}: run `make fidelity` first ({exc})") from None
    for draw, name in ((error_vs_cpu, "error_vs_cpu.png"), (params_vs_fidelity, "params_vs_fidelity.png")):
        try:
            print(f"wrote {draw(table, args.table.with_name(name))}")
        except NothingToDraw as exc:
            print(f"{args.table.with_name(name)}: not drawn, {exc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
