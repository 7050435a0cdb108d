"""Every figure and the report of one comparison: reads ``compare.h5``, ``metrics.json``, ``fit.h5`` and
``fit.json``, draws and formats, computes nothing (``make figures``; the command line is ``__main__.py``)."""

from __future__ import annotations

from pathlib import Path

import h5py

from .. import io, schema
from ..errors import PipelineError
from . import cycles, laws, memory, profiles, report, reversal


def check_fit_belongs(fit, fit_dir: Path, compared: schema.MadeFrom) -> None:
    """Refuse, in one line, a ``fit.json`` or ``fit.h5`` that is not the fit the comparison read (``metrics.json``'s
    ``made_from`` records its digest): another data set's, or another fit's copied beside it."""
    recorded = compared.options.get("fit")
    if fit is None:
        return
    if fit.made_from.digest() != recorded:
        raise PipelineError(f"{fit_dir / 'fit.json'} is not the fit {fit_dir.parent.name}'s comparison read (another "
                            "fit's, or another data set's): `make fit compare` remakes them from the data set's "
                            "runs")
    fit_h5 = fit_dir / "fit.h5"
    if fit_h5.exists():
        with h5py.File(fit_h5, "r") as f:
            stamp = f.attrs.get("made_from")
        if stamp != recorded:
            raise PipelineError(f"{fit_h5} is not the fit.json beside it's (another fit's): `make fit` remakes both")


def draw(compare_dir: Path, fit_dir: Path, out: Path) -> list[Path]:
    """Every figure and the report from the comparison and calibration outputs."""
    metrics = schema.read_metrics(compare_dir / "metrics.json")
    schema.check_compared(metrics, compare_dir / "metrics.json")
    io.check_writable_dir(out)
    fit = schema.read_fit(fit_dir / "fit.json") if (fit_dir / "fit.json").exists() else None
    check_fit_belongs(fit, fit_dir, metrics.made_from)
    sets = metrics.param_sets.labelled()
    fitted, paper = metrics.param_sets.our_fit, metrics.param_sets.table2
    preset = metrics.preset
    figures = out / "figures"
    made = []
    try:
        f = h5py.File(compare_dir / "compare.h5", "r")
    except OSError as exc:
        raise PipelineError(f"cannot read {compare_dir / 'compare.h5'}: run `make compare` first ({exc})") from None
    with f:
        schema.check_compare(f, compare_dir / "compare.h5")
        if f.attrs.get("made_from") != metrics.made_from.digest():
            raise PipelineError(f"{compare_dir / 'compare.h5'} is not the metrics.json beside it's (another "
                                "comparison's): `make compare` remakes both")
        runs = [f["runs"][k] for k in f["runs"]]
        default = [g for g in runs if g.attrs["default_rotation"]]
        rotated = [g for g in runs if not g.attrs["default_rotation"]]
        made.append(cycles.plot(default, figures / "fig5_6_cycles.png", f"{preset}: Figs. 5-6"))
        if rotated:
            made.append(cycles.plot(rotated, figures / "fig7_rotations.png", f"{preset}: Fig. 7"))
        if "memory" in f:
            made.append(memory.plot([f["memory"][k] for k in f["memory"]], list(sets), figures / "memory.png",
                                    f"{preset}: the fabric's memory of the old shear direction after a turn"))
        if "reversal" in f:
            parts = [f["reversal"][k] for k in f["reversal"]]
            made.append(reversal.backstress_figure(parts, fitted.C, figures / "fig8_backstress.png"))
        reversal_runs = [g for g in runs if g.attrs["is_reversal"]]
        if reversal_runs:
            made.append(reversal.work_figure(reversal_runs, schema.OUR_FIT, figures / "fig9_work_rates.png"))
        n_runs = len(runs)
    if (fit_dir / "profiles.json").exists():
        result = schema.read_json_object(fit_dir / "profiles.json", "profile", "fit-profile")
        if profiles.belongs_to(result, fit):
            made.append(profiles.plot(result, paper, figures / "profiles.png"))
        else:
            print(f"{fit_dir / 'profiles.json'} profiles another fit than fit.json: not drawn (make fit-profile)")
    fit_h5 = fit_dir / "fit.h5"
    if fit_h5.exists():
        made.append(laws.fabric_law(fit_h5, fitted, paper, figures / "fig3_fabric_law.png"))
        made.append(laws.flow_rule(fit_h5, fitted, paper, figures / "fig4_flow_rule.png"))
    fit_from = (schema.read_fit_rows(fit_dir / "fit_from.json", "fit-from")
                if (fit_dir / "fit_from.json").exists() else None)
    if fit_from and not report.same_weighting(fit_from, fit):
        print(f"{fit_dir / 'fit_from.json'} weighs the runs otherwise than fit.json: left out of the report "
              "(make fit-from with the fit's WEIGHT)")
        fit_from = None
    made.append(report.write(metrics, fit, out / "report.md", n_runs, fit_from))
    return made
