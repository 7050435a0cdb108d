"""What the data determine: each parameter's interval and status, the combinations fixed and left loose,
and Table 2 tested as a hypothesis against the global fit.

All of it rests on the global fit's sandwich covariance (the DEM's measured, correlated noise;
``global_fit.refine``), not on its misfit. A parameter is *determined* when its standard error is at
most 10 % of its value, *loosely determined* up to 50 %, and *not determined* beyond (or where the data
fix nothing along it). Combinations are the covariance's eigen-directions in relative parameters: a
direction v stands for the product prod |theta_k|^v_k, and its ``relative_step`` is one standard deviation
along it.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh

import model

from ..schema import Combination, Identifiability, Jackknife, ParameterInterval, SpreadOverAngles, Table2Test
from . import global_fit

DETERMINED, LOOSE = 0.1, 0.5  # relative standard error limits
#: a misfit from here on (the model missing the runs by sqrt(2) times their noise or more) is said beside the
#: intervals, with the intervals widened by sqrt(misfit)
MISFIT_NOTED = 2.0
LEVELS = {"68": 0.6827, "95": 0.95}
Z = {"68": 1.0, "95": 1.959964}


def status(value: float, se: float) -> str:
    relative = se / abs(value) if value != 0 else np.inf
    if not np.isfinite(relative) or relative > LOOSE:
        return "not determined"
    return "determined" if relative <= DETERMINED else "loosely determined"


def combination(direction: dict, cut: float = 0.1) -> str:
    """``|a1|^0.70 |a2|^0.69``-style text of a relative direction (components below ``cut`` left out)."""
    terms = [f"|{n}|^{c:+.2f}" for n, c in sorted(direction.items(), key=lambda t: -abs(t[1])) if abs(c) >= cut]
    return " ".join(terms)


def chi2_rise_quantiles(fit: global_fit.GlobalFit, draws: int = 200_000, seed: int = 0) -> dict | None:
    """Quantiles of chi^2(truth) - chi^2(best) over the noise: (theta_hat - theta)^T H (theta_hat - theta)
    with theta_hat - theta ~ N(0, sandwich), a weighted sum of chi^2_1 (linearised). None if a direction is
    not determined."""
    V, W = fit.covariance, fit.white_covariance
    if V is None or not (np.all(np.isfinite(V)) and np.all(np.isfinite(W))):
        return None
    weights = np.clip(eigh(V, W, eigvals_only=True), 0.0, None)
    z = np.random.default_rng(seed).standard_normal((draws, len(weights)))
    rise = (z**2) @ weights
    return {level: float(np.quantile(rise, q)) for level, q in LEVELS.items()}


def table2_test(fit: global_fit.GlobalFit, data: list, paper: model.Params = model.PAPER) -> Table2Test:
    """Table 2's flow rule and fabric law on our data (a law's own parameters at their neutral values: Eq. 13): its
    chi^2 rise above the best fit and whether it lies inside the joint 68 / 95 % confidence regions; both for the
    noise as measured and with the region widened by the misfit (as if the misfit were noise: the most lenient
    reading)."""
    values = np.array([getattr(paper, n) if n in paper.own_names() else model.params.table2_value(n)
                       for n in fit.names])
    chi2 = float(np.sum(global_fit.residuals(values, data, fit.params, fit.names) ** 2))
    rise = chi2 - fit.chi2
    quantiles = chi2_rise_quantiles(fit)
    relative = rise / fit.chi2 if fit.chi2 > 0 else (np.inf if rise > 0 else 0.0)  # exact data: chi2 = 0
    if quantiles is None:
        return Table2Test(rise, float(relative), fit.misfit, None)
    return Table2Test(rise, float(relative), fit.misfit, quantiles,
                      {level: bool(rise <= q) for level, q in quantiles.items()},
                      {level: bool(rise <= q * max(fit.misfit, 1.0)) for level, q in quantiles.items()})


UNMEASURED = "no interval: the noise is not measured (one cycle per run, no seeds)"


def summary(fit: global_fit.GlobalFit, data: list, hold: dict | None = None, measured: bool = True) -> Identifiability:
    """Per parameter its interval and status, the best and worst determined combinations, Table 2's test.
    Each parameter's ``intervals_misfit_widened`` take the misfit as if it were noise (standard errors times
    sqrt(misfit), the most lenient reading): where the model misses the runs, the noise's own intervals describe
    the noise, not what another set of runs would give, and even the widened ones assume that one parameter set
    fits every run (``make fit-jackknife OVER=angles`` tests that). ``misfit_noted``: the noise is measured and the
    misfit is at least ``MISFIT_NOTED``, so the printout and the report say so beside the intervals.
    Without a ``measured`` noise (one cycle per run and no seeds) there are no intervals and no test: the
    scatter about a smoothed cycle misses the correlated part of the noise, and an interval from it
    would look tight and mean nothing."""
    params, intervals, loose = {}, {}, []
    widening = float(np.sqrt(max(fit.misfit, 1.0)))
    for name, value, se in zip(fit.names, fit.values, fit.standard_errors, strict=True):
        se = se if measured else np.inf
        state = status(value, se) if measured else UNMEASURED
        ranges = {level: [value - z * se, value + z * se] if np.isfinite(se) else None for level, z in Z.items()}
        wide = {level: [value - z * se * widening, value + z * se * widening] if np.isfinite(se) else None
                for level, z in Z.items()}
        params[name] = ParameterInterval(float(value), float(se) if np.isfinite(se) else None, state, ranges, wide)
        intervals[name] = ranges["68"]
        if state == "not determined":
            loose.append(name)
    described = [Combination(d["relative_step"], d["direction"], combination(d["direction"])) for d in fit.directions]
    return Identifiability(params, intervals, loose, dict(hold or {}), float(fit.misfit), widening,
                           bool(measured and fit.misfit >= MISFIT_NOTED), described[:3], described[::-1][:3], measured,
                           None if hold or not measured else table2_test(fit, data))


def spread_over_angles(jack: Jackknife) -> SpreadOverAngles:
    """Each parameter's range over the refits without one angle (``resampling.jackknife`` over the angles). Where
    one parameter set does not fit every angle, this range, not an interval from the noise, is the scale of what
    the runs say about a parameter: which angles are in the data set moves it."""
    values = np.array(jack.values, dtype=float)
    return SpreadOverAngles(list(jack.left_out), {name: [float(values[:, k].min()), float(values[:, k].max())]
                                                  for k, name in enumerate(jack.free)})
