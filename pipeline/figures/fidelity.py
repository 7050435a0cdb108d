"""The fidelity ladder's plots, from ``results/fidelity/table.json`` (``make fidelity``): read and draw.

``python -m pipeline.figures.fidelity [--table results/fidelity/table.json]`` writes beside the table
``error_vs_cpu.png`` (per angle, the relative shift of the steady shear stress ratio against CPU-hours,
log-log, one point per setting, error bars from the combined standard errors, the Pareto front joined)
and ``params_vs_fidelity.png`` (each fitted parameter of the reversal against the inertial number and
the cell size, with the seeds' ensemble as a band and Table 2 as a line).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import model  # noqa: E402

from ..cli import Parser, one_line_errors  # noqa: E402
from ..errors import PipelineError  # noqa: E402
from .output import save  # noqa: E402

PARAMETERS = ("C", "n", "m", "a1", "b1", "a2", "b2")
AXES = {"inertial_number": ("inertial_number", "inertial number I", True),
        "cell": ("width_d", "cell width W / d", False)}


def error_vs_cpu(table: dict, out: Path) -> Path:
    thetas = list(table["references"])
    fig, axes = plt.subplots(1, len(thetas), figsize=(5 * len(thetas), 4), squeeze=False)
    for ax, theta in zip(axes[0], thetas, strict=True):
        rows, seen = [], set()
        for r in table["rows"]:  # each run once: the preset's own run sits on every axis
            if f"{r['theta_deg']:g}" == theta and (r["folder"], r["name"]) not in seen:
                seen.add((r["folder"], r["name"]))
                rows.append(r)
        for k, axis in enumerate(dict.fromkeys(r["axis"] for r in rows)):
            mine = [r for r in rows if r["axis"] == axis]
            x = [r["cost"]["cpu_hours"] for r in mine]
            y = [max(r["error"], 1e-4) for r in mine]
            ax.errorbar(x, y, yerr=[r["error_se"] for r in mine], fmt="o", ms=4, color=f"C{k}", label=axis,
                        capsize=2, lw=0.8)
        front = [table["rows"][i] for i in table["pareto"][theta]]
        ax.plot([r["cost"]["cpu_hours"] for r in front], [max(r["error"], 1e-4) for r in front], "k--", lw=0.8,
                label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU-hours (one thread)")
        ax.set_ylabel("|shift of steady τ12/p| / reference")
        ax.set_title(f"θ = {theta}°", fontsize=9)
        ax.legend(fontsize=6)
    return save(fig, out)


def params_vs_fidelity(table: dict, out: Path) -> Path:
    rows = [r for r in table["rows"] if r["theta_deg"] == 180.0 and r["fit"]]
    ref = table["references"].get("180", {}).get("fit", {})
    fig, axes = plt.subplots(len(AXES), len(PARAMETERS), figsize=(2.3 * len(PARAMETERS), 2.4 * len(AXES)),
                             squeeze=False)
    for row_axes, (axis, (key, label, log)) in zip(axes, AXES.items(), strict=True):
        mine = [r for r in rows if r["axis"] == axis]
        for ax, name in zip(row_axes, PARAMETERS, strict=True):
            x = [float(r["setting"].split(f"{key}=")[1].split()[0]) for r in mine]
            y = [r["fit"][name] for r in mine]
            err = [(r["fit_se"] or {}).get(name) or 0.0 for r in mine]
            ax.errorbar(x, y, yerr=err, fmt="o", ms=4, capsize=2, lw=0.8)
            if name in ref:
                mean, se = ref[name]["mean"], ref[name]["standard_error"]
                ax.axhspan(mean - se, mean + se, color="C1", alpha=0.3, lw=0, label="seeds ± s.e.")
            ax.axhline(getattr(model.PAPER, name), color="k", ls="--", lw=0.8, label="Table 2")
            if log:
                ax.set_xscale("log")
            ax.set_xlabel(label, fontsize=7)
            ax.set_title(name, fontsize=8)
            ax.tick_params(labelsize=6)
    axes[0, 0].legend(fontsize=6)
    fig.suptitle("Reversal: each run's own global fit against the DEM setting", fontsize=9)
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
    made = [error_vs_cpu(table, args.table.with_name("error_vs_cpu.png")),
            params_vs_fidelity(table, args.table.with_name("params_vs_fidelity.png"))]
    print("wrote " + ", ".join(str(p) for p in made))
    return 0


if __name__ == "__main__":
    sys.exit(main())
