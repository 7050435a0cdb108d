"""report.md from ``metrics.json`` and ``fit.json``: our parameters beside Table 2, the model-vs-DEM
errors per run, the backstress share, Phi, the second law, the relaxation strains, the stepwise route's
sensitivity. It formats numbers; it computes none."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io import write_text

NAMES = ("C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")


def _strain_text(value: float) -> str:
    return f"{value:.2f}" if value is not None and np.isfinite(value) else "not resolved"


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


def second_law_line(law: dict) -> str:
    return (f"- second law (Eq. 19) with our fit: c1 = {law['c1']:.3f} = -C; max Phi of the DEM cycles "
            f"{law['phi_max_dem']:.3f} against Phi_c + c3 = {law['phi_c_plus_c3']:.3f}; smallest total work rate of "
            f"the model's cycles {law['min_total_work_rate']:+.3f} p gamma_dot "
            f"({'holds' if law['holds'] else 'VIOLATED'})")


def write(metrics: dict, fit_json: dict | None, out: Path, n_runs: int) -> Path:
    """Write report.md from the comparison's ``metrics`` and the calibration's ``fit_json``."""
    sets = metrics["param_sets"]
    paper, ours = sets["Table 2"], sets["our fit"]
    se = {}
    for part in ("global", "dilatancy"):
        if fit_json and fit_json.get(part):
            se.update(zip(fit_json[part]["free"], fit_json[part]["standard_errors"], strict=True))
    components = metrics["components"]
    lines = [f"# Model against our DEM: preset `{metrics['preset']}`", "",
             f"{n_runs} DEM run(s); the model runs in bulk strain for each run's protocol.", "",
             "## Parameters", "", "| parameter | our fit | ± | Table 2 |", "|---|---|---|---|"]
    for name in NAMES:
        lines.append(f"| {name} | {ours[name]:+.4g} | {se.get(name, float('nan')):.2g} | {paper[name]:+.4g} |")
    directions = (fit_json or {}).get("global", {}) or {}
    if directions.get("fisher_directions"):
        lines += ["", "## What the data fix", "",
                  "Eigen-directions of the global fit's Fisher matrix in relative parameters, weakest first: the "
                  "relative step along each that raises chi^2 by one reduced chi^2. The ± above are not "
                  "confidence intervals: the reduced chi^2 is model misfit, not noise.", "",
                  "| relative step | combination (components >= 0.1) |", "|---|---|"]
        for d in directions["fisher_directions"]:
            combination = " ".join(f"{c:+.2f} {n}" for n, c in d["direction"].items() if abs(c) >= 0.1)
            lines.append(f"| {d['relative_step']:.2g} | {combination} |")
    lines += ["", "## Model against DEM", "",
              "RMSE over the cycle divided by the steady |A12| or |tau12/p|.", "",
              "| run | parameters | " + " | ".join(components) + " |", "|---|---|" + "---|" * len(components)]
    for e in metrics["errors"]:
        lines.append(f"| {e['run']} | {e['parameters']} | " + " | ".join(f"{e[k]:.2f}" for k in components) + " |")
    if "reversal" in metrics:
        r = metrics["reversal"]
        lo, hi = r["table2_packing_fraction_range"]
        lines += ["", "## Reversal", "",
                  f"- share of the backstress C A12 in the steady shear stress: {r['backstress_share']:.0%} with our C "
                  f"(paper: 88 %)",
                  f"- mean packing fraction over the cycle: {r['mean_packing_fraction']:.3f} (the model with Table 2: "
                  f"{lo:.3f} to {hi:.3f}; Phi_c = {paper['phi_c']} is not the steady value)",
                  second_law_line(metrics["second_law"])]
    if "relaxation" in metrics:
        rel = metrics["relaxation"]
        lines.append(f"- relaxation strain after the reversal (to within 5 % of the final value, from an exponential "
                     f"fit; 'not resolved' where the fit does not fix it to +-50 %): isotropic part "
                     f"{_strain_text(rel['dem']['isotropic'])}, backstress {_strain_text(rel['dem']['backstress'])} "
                     f"in our DEM, mean of {rel['reversal_runs']} reversal run(s) "
                     "(paper, read off Fig. 8: 0.25 and 0.6); "
                     "the model by the same measure: " + "; ".join(
                         f"{label}: {_strain_text(v['isotropic'])} and {_strain_text(v['backstress'])}"
                         for label, v in rel["model"].items()))
    if fit_json and fit_json.get("sensitivity"):
        lines += ["", *sensitivity_lines(fit_json["sensitivity"])]
    return write_text(out, "\n".join(lines) + "\n")
