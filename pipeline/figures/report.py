"""report.md: our parameters beside Table 2, the model-vs-DEM errors per run, backstress share, Phi."""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

import model

from ..calibrate import relaxation_strain
from ..validation import COMPONENTS, backstress_share, errors, model_for
from .reversal import after_reversal, reversal_parts

NAMES = ("C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")


def _strain_text(value: float) -> str:
    return f"{value:.2f}" if np.isfinite(value) else "not resolved"


def model_relaxation(params) -> tuple[float, float]:
    """Relaxation strains of the isotropic part and the backstress of tau12/p after the model's
    reversal (the periodic theta = 180 cycle), by the measure applied to the DEM."""
    cycle = model.predict(180, params=params)
    d = reversal_parts(cycle.strain, cycle.tau[:, 0, 1], cycle.A[:, 0, 1], params.C)
    return relaxation_strain(d["strain"], d["isotropic12"]), relaxation_strain(d["strain"], d["backstress12"])


def sensitivity_lines(sens: dict) -> list[str]:
    """The stepwise estimates against the smoothing window, and Eq. 15's C against its strain window."""
    keys = ("C_eq15", "n", "m", "a1", "b1", "a2", "b2", "persistence_exponent_alpha1", "persistence_exponent_alpha2")
    heads = ("C (Eq. 15)", "n", "m", "a1", "b1", "a2", "b2", "k from alpha1", "k from alpha2")
    lines = ["## Stepwise calibration (paper Sec. 4) against its choices", "",
             "Mean over the reversal runs, per Savitzky-Golay window (strain) used for the smoothing and the "
             "Jaumann rate:", "", "| window | " + " | ".join(heads) + " |", "|---|" + "---|" * len(heads)]
    for window, values in sens["smoothing_window"].items():
        lines.append(f"| {window} | " + " | ".join(f"{values[k]:+.3g}" for k in keys) + " |")
    if "transient_efolds" in sens:
        lines += ["", "The fabric law per strain after each change of direction used by the beta_i fits (in 1/e "
                  "relaxation strains of A12 after the reversal; default 2):", "",
                  "| e-folds | a1 | b1 | a2 | b2 |", "|---|---|---|---|---|"]
        for efolds, values in sens["transient_efolds"].items():
            lines.append(f"| {efolds} | " + " | ".join(f"{values[k]:+.3g}" for k in ("a1", "b1", "a2", "b2")) + " |")
    lines += ["", "C from Eq. 15 per strain window after the reversal: " + ", ".join(
        f"{w}: {c:+.2f}" for w, c in sens["eq15_window"].items()) + " (on model data Eq. 15 gives C - 2m)."]
    return lines


def second_law_line(runs: list, params) -> str:
    """Eq. 19 for our fit: c1 = -C, and Phi <= Phi_c + c3 over every DEM cycle; plus the smallest
    total work rate of the model's cycles (Eq. 17, per unit p gamma_dot) for the runs' protocols."""
    phi_max = max(float(np.nanmax(r.cycle["packing_fraction"])) for r in runs)
    bound = params.phi_c + params.c3
    w_min = min(float(model.predict(r.spec["theta_deg"], rotate_at=r.spec["rotate_at_strain"],
                                    params=params).w_total.min()) for r in runs)
    holds = params.c1 == -params.C and phi_max <= bound and w_min >= 0
    return (f"- second law (Eq. 19) with our fit: c1 = {params.c1:.3f} = -C; max Phi of the DEM cycles {phi_max:.3f} "
            f"against Phi_c + c3 = {bound:.3f}; smallest total work rate of the model's cycles "
            f"{w_min:+.3f} p gamma_dot ({'holds' if holds else 'VIOLATED'})")


def write(runs: list, sets: dict, fit_json: dict | None, out: Path, preset: str, fit_h5: Path | None = None) -> Path:
    paper, ours = model.Params(), sets["our fit"]
    se = {}
    for part in ("global", "dilatancy"):
        if fit_json and fit_json.get(part):
            se.update(zip(fit_json[part]["free"], fit_json[part]["standard_errors"], strict=True))
    lines = [f"# Model against our DEM: preset `{preset}`", "",
             f"{len(runs)} DEM run(s); the model runs in bulk strain for each run's protocol.", "",
             "## Parameters", "", "| parameter | our fit | ± | Table 2 |", "|---|---|---|---|"]
    for name in NAMES:
        lines.append(f"| {name} | {getattr(ours, name):+.4g} | {se.get(name, float('nan')):.2g} | "
                     f"{getattr(paper, name):+.4g} |")
    lines += ["", "## Model against DEM", "",
              "RMSE over the cycle divided by the steady |A12| or |tau12/p|.", "",
              "| run | parameters | " + " | ".join(COMPONENTS) + " |", "|---|---|" + "---|" * len(COMPONENTS)]
    for run in runs:
        name = Path(run.path).stem
        for label, params in sets.items():
            data, pred = model_for(run, params)
            e = errors(data, pred)
            lines.append(f"| {name} | {label} | " + " | ".join(f"{e[k]:.2f}" for k in COMPONENTS) + " |")
    reversals = [r for r in runs if abs(abs(r.spec["theta_deg"]) - 180) < 1e-9]
    if reversals:
        share = np.mean([backstress_share(r, ours.C) for r in reversals])
        phi = np.mean([r.cycle["packing_fraction"].mean() for r in reversals])
        paper_phi = model.predict(180, params=paper).packing_fraction
        lines += ["", "## Reversal", "",
                  f"- share of the backstress C A12 in the steady shear stress: {share:.0%} with our C "
                  f"(paper: 88 %)",
                  f"- mean packing fraction over the cycle: {phi:.3f} (the model with Table 2: "
                  f"{paper_phi.min():.3f} to {paper_phi.max():.3f}; Phi_c = {paper.phi_c} is not the steady value)"]
        lines.append(second_law_line(runs, ours))
    if fit_h5 is not None:
        with h5py.File(fit_h5, "r") as f:
            parts = [after_reversal(f["reversal"][k], ours.C) for k in f["reversal"]]
        # one fit to the mean over the reversal runs (seeds share the cycle's strain grid)
        strain = parts[0]["strain"]
        iso = relaxation_strain(strain, np.mean([d["isotropic12"] for d in parts], axis=0))
        back = relaxation_strain(strain, np.mean([d["backstress12"] for d in parts], axis=0))
        lines.append(f"- relaxation strain after the reversal (to within 5 % of the final value, from an exponential "
                     f"fit; 'not resolved' where the fit does not fix it to +-50 %): isotropic part "
                     f"{_strain_text(iso)}, backstress {_strain_text(back)} in our DEM, mean of {len(parts)} "
                     "reversal run(s) "
                     "(paper, read off Fig. 8: 0.25 and 0.6); "
                     "the model by the same measure: " + "; ".join(
                         "{}: {} and {}".format(label, *map(_strain_text, model_relaxation(params)))
                         for label, params in sets.items()))
    if fit_json and fit_json.get("sensitivity"):
        lines += ["", *sensitivity_lines(fit_json["sensitivity"])]
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, out)
    return out
