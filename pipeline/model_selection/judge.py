"""Everything ``make models`` reports of one fabric law: its global fit on every run of the default protocol (misfit,
AIC, BIC, parameters, its own reversal), its predictions of each split's held-out runs (``splits``) and, across
cells, of another data set's runs from this one's and back."""

from __future__ import annotations

import numpy as np

from ..calibration import global_fit
from ..calibration.definitions import own_reversal
from ..errors import CalibrationError
from ..schema import AcrossScore, LawScore, SplitScore
from .scores import held_out, information, not_predicted, pooled
from .splits import splits


def fit(runs: list, variant: str, stress: str, weight: str) -> tuple[global_fit.GlobalFit, object]:
    """The global fit of ``variant`` on ``runs`` from Table 2 (``global_fit.start_of``), and the noise model
    measured on those runs alone."""
    data, noise = global_fit.prepare(runs, 0.0, stress, weight)
    return fit_prepared(data, noise, variant), noise


def fit_prepared(data, noise, variant: str) -> global_fit.GlobalFit:
    """``fit`` on data ``global_fit.prepare`` has read already."""
    return global_fit.refine(data, global_fit.start_of(variant), global_fit.free_names(variant), noise=noise)


def judge(variant: str, runs: list, other_runs: dict[str, list], stress: str, weight: str, progress) -> LawScore:
    """Everything ``make models`` reports of one variant (see the package's text)."""
    default = [r for r in runs if r.default_rotation]
    data, noise = global_fit.prepare(default, 0.0, stress, weight)  # once: the fit and the residuals' count
    full = fit_prepared(data, noise, variant)
    params = global_fit.with_eq19_c1(full.params)
    progress()
    scores = []
    for split in splits(runs):
        try:
            trained, train_noise = fit([runs[i] for i in split.train], variant, stress, weight)
        except CalibrationError as exc:  # the law cannot be fitted on these runs alone: it predicts nothing
            rows = [not_predicted(runs[i], f"not fitted on the other runs: {exc}") for i in split.test]
            scores.append(SplitScore(split.name, None, None, str(exc), rows, np.inf))
        else:
            rows = [held_out(runs[i], trained.params, train_noise, stress, {}) for i in split.test]
            scores.append(SplitScore(split.name, trained.params, trained.misfit, None, rows, pooled(rows)))
        progress()
    across = []
    for label, others in other_runs.items():
        there = [r for r in others if r.default_rotation]
        trained, there_noise = fit(there, variant, stress, weight)
        here = [held_out(r, trained.params, noise, stress) for r in runs]
        back = [held_out(r, full.params, there_noise, stress) for r in others]
        across.append(AcrossScore(label, trained.params, here, pooled(here), back, pooled(back)))
        progress()
    return LawScore(variant, params, list(full.names), full.values.tolist(), full.standard_errors.tolist(),
                    full.misfit, **information(full, global_fit.fitted_residuals(data)),
                    own_reversal=own_reversal(params), splits=scores, across=across)
