"""A DEM run's compact summary for the fidelity study: steady values, its own fit, its cost, its provenance.

Everything the ladder's table and plots need, a few kB per run (the raw file stays out of the repository):

- steady values over the last ``STEADY_WINDOW`` strain before each change of direction (the end of the
  preceding half period included): tau:D'/(p|D'|) scaled to tau12/p (``mu``: the shear stress ratio along
  the shear, sign-free), |A|, A:D' scaled likewise (``A_aligned``, A12 at phi = 0), Phi of the central
  band and of the gap; each as the mean over those windows and its standard error (windows 0.4 strain
  or more apart, beyond the noise's correlation);
- the central band's strain per nominal strain;
- the global fit on this run alone (C, n, m, a_i, b_i with the DEM's noise measured on its own cycles;
  c2_coef, Phi_c) and the model-vs-DEM RMSE of A12, A32, tau12/p, tau32/p over the cycle with that fit
  and with Table 2 (``comparison.metrics``), in our default definitions (bulk strain, central Phi), and
  the same fit in the definitions the paper's numbers match (``PAPER_DEFINITIONS``: nominal strain,
  Phi of the gap), to set against Table 2 in its own terms (version 2 on);
- cost: steps, loop and callback seconds, steps per second, grains and wall spheres, threads;
- provenance: preset, overrides, theta, seed, git commit, Yade version.
"""

from __future__ import annotations

import numpy as np

import model

from ...calibration import global_fit
from ...comparison.metrics import errors, model_for
from ...dataset.derived import STEADY_WINDOW, Definitions, bulk_over_nominal, change_strains, means_before
from ...errors import CalibrationError

SCHEMA = "granular-backstress/fidelity-summary"
VERSION = 2
PAPER_DEFINITIONS = Definitions(strain="nominal", phi="gap")  # README, Calibration: "Strain", "Packing fraction"


def steady_values(run, window: float = STEADY_WINDOW) -> dict:
    """Mean and standard error, over the windows before each change of direction, of the steady values."""
    s = run.series
    strain = s["strain_nominal"]
    D = s["D_dev_nominal"]  # |D'| = 1/sqrt(2) per unit nominal rate: A:D' and tau:D' are the 12 parts at phi = 0
    quantities = {"mu": s["w_shear"], "A_norm": np.sqrt(np.sum(s["A"] ** 2, axis=(1, 2))),
                  "A_aligned": np.einsum("nij,nij->n", s["A"], D), "phi_central": run.raw["packing_fraction"],
                  "phi_gap": run.with_definitions(Definitions(phi="gap")).series["packing_fraction"]}
    out = {}
    for name, values in quantities.items():
        means = means_before(strain, values, change_strains(run.spec), window).tolist()
        se = float(np.std(means, ddof=1) / np.sqrt(len(means)))
        out[name] = {"mean": float(np.mean(means)), "standard_error": se, "windows": means}
    return out


def own_fit(run) -> dict:
    """The global fit on this run alone, and the RMSE of its cycle with that fit and with Table 2; the
    dilatancy (Eq. 18) fitted after it where one run fixes it (its failure is recorded, not fatal)."""
    try:
        data, noise = global_fit.prepare([run], stress="all")  # every summary of the ladder was fitted so
        fit = global_fit.refine(data, model.Params(), noise=noise)
    except (CalibrationError, model.ParameterError, model.SolverError) as exc:
        return {"error": str(exc)}
    values = dict(zip(fit.names, fit.values.tolist(), strict=True))
    out = {"standard_errors": dict(zip(fit.names, [v if np.isfinite(v) else None for v in fit.standard_errors.tolist()],
                                       strict=True)), "misfit": fit.misfit}
    try:
        dilatancy = global_fit.refine_dilatancy(data, fit.params)
        values.update(zip(dilatancy.names, dilatancy.values.tolist(), strict=True))
    except CalibrationError as exc:
        out["dilatancy_error"] = str(exc)
    rmse = {label: errors(*pair) for label, pair in model_for(run, {"Table 2": model.PAPER,
                                                                   "own fit": fit.params}).items()}
    return {"values": values, **out, "rmse": rmse}


def cost(run) -> dict:
    p = run.parameters
    threads = max([s.get("threads", 1) for s in run.sessions] or [1])
    return {"steps": int(p["iterations"]), "loop_seconds": float(p["loop_seconds"]),
            "callback_seconds": float(p["callback_seconds"]),
            "steps_per_second": float(p["iterations"] / p["loop_seconds"]) if p["loop_seconds"] > 0 else None,
            "cpu_hours": run.cpu_seconds / 3600, "threads": int(threads),
            "grains": int(p["n_grains"]), "wall_spheres": int(p["n_wall_spheres"])}


def summarize(run) -> dict:
    """The compact summary of one DEM run (read with the default definitions)."""
    spec = run.spec
    return {"schema": SCHEMA, "schema_version": VERSION, "folder": spec.folder,
            "name": spec.name, "preset": spec.preset, "overrides": spec.overrides,
            "theta_deg": spec.theta_deg, "rotate_at_strain": spec.rotate_at_strain, "seed": spec.seed,
            "spec": spec.to_dict(),
            "git_commit": run.provenance.get("git_commit", ""), "yade_version": run.provenance.get("yade_version", ""),
            "steady_window_strain": STEADY_WINDOW, "steady": steady_values(run),
            "bulk_over_nominal": bulk_over_nominal(run), "fit": own_fit(run) if run.is_reversal else None,
            "fit_paper_definitions": own_fit(run.with_definitions(PAPER_DEFINITIONS)) if run.is_reversal else None,
            "cost": cost(run)}
