"""The model against a data set's DEM runs: every run's cycle predicted with each parameter set, written to
``compare.h5`` and ``metrics.json`` (``make compare``; the command line is ``pipeline/comparison/__main__.py``)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np

import model

from .. import io, schema
from ..dataset import drift
from ..dataset.derived import PAPER_DEFINITIONS, Definitions
from ..dataset.lookup import protocol_and_seed
from ..errors import PipelineError
from ..paths import preset_output
from . import metrics


def write_dem_cycle(g: h5py.Group, run, ratio: float, keys: tuple[str, ...]) -> None:
    """A run's cycle mean (``keys`` of it) into ``g``, against strain in the fit's measure (``ratio`` times the
    nominal strain)."""
    g.create_dataset("strain_bulk", data=run.cycle["strain"] * ratio)
    for key in keys:
        g.create_dataset(key, data=run.cycle[key])


def write_compare_h5(path: Path, runs: list, predictions: list, sets: dict, preset: str,
                     reversal_parts: list, memory_curves: list, other_seeds: tuple = (), others: list = (),
                     made_from: str = "") -> None:
    """compare.h5: per run, the DEM cycle and every parameter set's model cycle, against strain in the fit's
    measure (``strain_measure``: the datasets keep the name ``strain_bulk``), and the DEM cycle of each of
    ``other_seeds`` of its protocol (``others``: their predictions, for their strain measure); per reversal run of
    the fit, the smoothed tau12/p split into backstress C A12 and isotropic part; per change of direction with a
    memory (``metrics.memory_curves``, the compared runs' first, then other seeds'), the memory of the old direction
    against the strain after the change (the DEM's mean over cycles and its standard error, each parameter set's)."""
    with io.h5_file(path) as f:
        schema.stamp_compare(f)
        f.attrs.update(made_from=made_from, preset=preset, strain_measure=runs[0].definitions.strain,
                       param_sets=json.dumps({label: p.to_dict() for label, p in sets.items()}))
        for k, run in enumerate(runs):
            g = f.create_group(f"runs/{k:02d}")
            g.attrs.update(path=str(run.path), name=Path(run.path).stem, theta_deg=run.spec.theta_deg,
                           rotate_at_strain=run.spec.rotate_at_strain, is_reversal=run.is_reversal,
                           default_rotation=run.default_rotation)
            c = run.cycle
            ratio = metrics.bulk_over_nominal(predictions[k])
            g.attrs["bulk_over_nominal"] = ratio
            dem = g.create_group("dem")
            write_dem_cycle(dem, run, ratio, ("A", "A_sem", "tau_over_p", "tau_over_p_sem", "packing_fraction"))
            for key in ("w_shear", "w_vol"):  # per unit strain of the fit's measure
                dem.create_dataset(key, data=c[key] / ratio)
            for other, preds in zip(other_seeds, others, strict=True):
                if protocol_and_seed(other)[:2] == protocol_and_seed(run)[:2]:
                    write_dem_cycle(g.create_group(f"other_seeds/{other.spec.seed}"), other,
                                    metrics.bulk_over_nominal(preds), ("A", "tau_over_p"))
            for label, (data, pred) in predictions[k].items():
                m = g.create_group(f"model/{label}")
                for key, value in (("strain_bulk", data.strain * ratio), ("A", pred.A), ("tau_over_p", pred.tau),
                                   ("packing_fraction", pred.packing_fraction)):
                    m.create_dataset(key, data=value)
        for k, part in enumerate(reversal_parts):
            g = f.create_group(f"reversal/{k:02d}")
            for key, value in part.items():
                g.create_dataset(key, data=value)
        for k, c in enumerate(memory_curves):
            g = f.create_group(f"memory/{k:02d}")
            g.attrs.update(run=c["run"], seed=c["seed"], segment=c["segment"], from_deg=c["from_deg"],
                           direction_deg=c["direction_deg"], cycles=len(c["dem"]))
            mean, se = metrics.cycle_mean_and_error(c["dem"])
            g.create_dataset("strain_after", data=c["strain_after"])
            g.create_dataset("dem", data=mean)
            g.create_dataset("dem_sem", data=np.full(mean.shape, np.nan) if se is None else se)
            for label, (strain, fraction) in c["model"].items():
                g.create_dataset(f"model/{label}/strain_after", data=strain)
                g.create_dataset(f"model/{label}/fraction", data=fraction)


def compare(runs: list, sets: dict, fit_h5: Path | None, out_dir: Path, preset: str, label: str = "",
            other_seeds: tuple = (), made_from: schema.MadeFrom = None) -> dict:
    """Predict, measure and write ``compare.h5`` and ``metrics.json`` into ``out_dir``; ``other_seeds`` (the same
    protocols at other seeds) enter the errors' spread over seeds, the overshoot and memory tables (a row per
    seed) and, as DEM cycles, the figures; ``made_from`` (the files read, the options) goes into ``metrics.json``."""
    io.check_writable_dir(out_dir)
    predictions = [metrics.model_for(run, sets) for run in runs]
    ours = sets[schema.OUR_FIT]
    others = [metrics.model_for(run, sets) for run in other_seeds]
    rows = metrics.error_rows(runs, predictions)
    errors = schema.Errors(list(metrics.COMPONENTS), rows,
                           metrics.seed_spread(rows + metrics.error_rows(other_seeds, others)))
    result = {"preset": preset, "data_set": label or preset, "definitions": runs[0].definitions,
              "param_sets": schema.ParamSets(sets[schema.TABLE2], ours), "errors": errors}
    per_run = metrics.per_run
    curves = per_run(metrics.memory_curves, runs, predictions)
    more = [c for c in per_run(metrics.memory_curves, other_seeds, others)
            if any((c["run"], c["segment"]) == (d["run"], d["segment"]) for d in curves)]
    result["after_changes"] = schema.AfterChanges(
        metrics.beside_first(per_run(metrics.overshoots, runs, predictions),
                             per_run(metrics.overshoots, other_seeds, others)),
        metrics.beside_first(metrics.memories(curves), metrics.memories(more)))
    result["drift"] = [drift_row(r) for r in [*runs, *other_seeds]]
    reversals = [r for r in runs if r.is_reversal]
    if reversals:
        paper_phi = model.predict(180, params=model.Params()).packing_fraction
        result["reversal"] = schema.Reversal(
            backstress_share=float(np.mean([metrics.backstress_share(r, ours.C) for r in reversals])),
            mean_packing_fraction=float(np.mean([r.cycle["packing_fraction"].mean() for r in reversals])),
            table2_packing_fraction_range=[float(paper_phi.min()), float(paper_phi.max())],
            backstress_share_by_C={label: float(np.mean([metrics.backstress_share(r, p.C) for r in reversals]))
                                   for label, p in sets.items()},
            model_backstress_share={label: metrics.model_backstress_share(p, reversals[0].spec.rotate_at_strain)
                                    for label, p in sets.items()})
        result["second_law"] = metrics.second_law(runs, ours)
    parts = []
    if fit_h5 is not None:
        with h5py.File(fit_h5, "r") as f:
            groups = [f["reversal"][k] for k in f["reversal"]]
            rotate_at = reversals[0].spec.rotate_at_strain if reversals else model.ROTATE_AT_STRAIN
            parts = [metrics.reversal_parts(g["strain"][()], g["tau12"][()], g["A12"][()], ours.C, rotate_at)
                     for g in groups]
        cycles = {label: [metrics.model_cycle_parts(p, rotate_at)] for label, p in sets.items()}
        by_cut = {f"{cut:g}": schema.CutRelaxation(
            dem={label: schema.Strains(*metrics.relaxation_strains(
                [metrics.reversal_parts(d["strain"], d["tau12"], d["A12"], p.C, rotate_at) for d in parts], cut))
                for label, p in sets.items()},
            model={label: schema.Strains(*metrics.relaxation_strains(cycle, cut)) for label, cycle in cycles.items()})
            for cut in metrics.RELAXATION_CUTS}
        result["relaxation"] = schema.Relaxation(len(parts), schema.Strains(*metrics.relaxation_strains(parts)),
                                                 by_cut[f"{metrics.RELAXATION_CUTS[0]:g}"].model, by_cut)
    with io.atomic_paths(out_dir / "compare.h5", out_dir / "metrics.json") as (h5, js):  # renamed together
        write_compare_h5(h5, runs, predictions, sets, preset, parts, curves + more, other_seeds, others,
                         made_from.digest() if made_from is not None else "")
        found = schema.Metrics(**result, made_from=made_from)
        io.write_bytes(js, io.json_text(found.to_dict()).encode())
    return found


def drift_row(run) -> schema.DriftRow:
    """The run's protocol, seed and cycles compared, and each quantity's trend over them (``drift.drift``; NaN,
    where there is no degree of freedom, as None)."""
    def trend(t: drift.Trend) -> schema.Trend:
        return schema.Trend(list(t.per_cycle), *(None if math.isnan(v) else v
                                                 for v in (t.slope, t.standard_error, t.t, t.p)))

    return schema.DriftRow(run.theta_deg, run.spec.rotate_at_strain, run.spec.seed, run.spec.n_cycles,
                           {name: trend(t) for name, t in drift.drift(run).items()})


def fitted_in(params_file: Path) -> Definitions:
    """The definitions of strain, Phi and p that the parameters in ``params_file`` were fitted in: its metadata's
    (``make fit`` and ``make fit-from`` write them), else the paper's (Table 2's; a file of one's own)."""
    given = schema.read_params(params_file).definitions
    if given is None:
        return PAPER_DEFINITIONS
    try:
        return Definitions(**given)
    except (TypeError, ValueError) as exc:  # not a mapping, an unknown name, an unknown choice
        raise PipelineError(f"{params_file}: metadata.definitions {given} are not definitions ({exc})") from None


def smoothed_reversals(params_file: Path, folder: str, definitions: Definitions) -> Path | None:
    """The ``fit.h5`` holding the DEM's smoothed reversals read in ``definitions`` (the relaxation strains' data):
    the one beside the parameters, else the data set's own fit's (for a row of ``make fit-from``); none if
    neither was fitted in those definitions."""
    for fit_h5 in dict.fromkeys((params_file.with_name("fit.h5"), preset_output(folder, "fit", "fit.h5"))):
        its_params = fit_h5.with_name("params.json")
        if fit_h5.exists() and its_params.exists() and fitted_in(its_params) == definitions:
            return fit_h5
    return None
