"""A run's cycles one by one: is the packing still changing while its cycles are averaged?

Each cycle has two steady windows, the ``STEADY_WINDOW`` (0.3) of nominal strain before each of its changes of
direction. Per window, the means of: the gap H between the walls' inner planes (d), Φ of the central band and of
the gap, τ12/p (τ:D' per unit nominal rate: the shear stress along the current direction) and |A|. A quantity's trend is
the least-squares slope of its window means on their cycle (per cycle), with the standard error from the windows'
scatter about the line, 2n − 2 degrees of freedom for n cycles. The drift test: Student's two-sided p of
slope / se; a run drifts in a quantity where p < ``LEVEL``. Windows of one cycle are taken as independent (0.7
strain apart, several relaxation strains). With one cycle there is no test; with two, two degrees of freedom.
``SKIP_CYCLES=k`` (``DemRun.without_first_cycles``) leaves out the cycles a drift shows to be compacting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.stats

from .derived import Definitions, change_strains, means_before

#: the drift test's level (two-sided)
LEVEL = 0.05
#: the quantities, in the order tables show them
QUANTITIES = ("gap", "Φ band", "Φ gap", "τ12/p", "|A|")


@dataclass(frozen=True)
class Trend:
    """One quantity of one run: its mean per cycle (both windows), and the slope per cycle with its error, t and p
    (NaN where there is no degree of freedom)."""

    per_cycle: tuple[float, ...]
    slope: float
    standard_error: float
    t: float
    p: float

    @property
    def drifts(self) -> bool:
        return bool(self.p < LEVEL)


def window_means(run) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The cycle (0, 1, ...) of each steady window and every quantity's mean over it."""
    s = run.series
    strain = s["strain_nominal"]
    values = {
        "gap": run.raw["gap"],
        "Φ band": run.raw["packing_fraction"],
        "Φ gap": run.with_definitions(Definitions(phi="gap")).series["packing_fraction"],
        "τ12/p": s["w_shear"],
        "|A|": np.sqrt(np.sum(s["A"] ** 2, axis=(1, 2))),
    }
    ends = change_strains(run.spec)
    ends = ends[ends > 1e-9]  # the window before 0 is the preceding half period
    cycle = np.floor((ends - 1e-9) / run.spec.period_strain).astype(int)
    return cycle, {name: means_before(strain, v, ends) for name, v in values.items()}


def trend(cycle: np.ndarray, values: np.ndarray, n_cycles: int) -> Trend:
    """The slope of ``values`` on ``cycle`` and its drift test (see the module's doc)."""
    per_cycle = tuple(float(np.mean(values[cycle == c])) for c in range(n_cycles))
    dof = len(values) - 2
    if n_cycles < 2 or dof < 1:
        return Trend(per_cycle, math.nan, math.nan, math.nan, math.nan)
    x = cycle - cycle.mean()
    slope = float(np.sum(x * (values - values.mean())) / np.sum(x**2))
    residual = values - values.mean() - slope * x
    se = float(math.sqrt(np.sum(residual**2) / dof / np.sum(x**2)))
    t = slope / se if se > 0 else math.copysign(math.inf, slope) if slope else 0.0
    return Trend(per_cycle, slope, se, t, float(2 * scipy.stats.t.sf(abs(t), dof)))


def drift(run) -> dict[str, Trend]:
    """Every quantity's trend over the run's cycles."""
    cycle, means = window_means(run)
    return {name: trend(cycle, means[name], run.spec.n_cycles) for name in QUANTITIES}


def describe(trends: dict[str, Trend]) -> str:
    """``gap −0.12 ± 0.02 /cycle (p 0.001), ...``: the quantities that drift, or ``stationary`` (``no test`` with
    one cycle)."""
    if all(math.isnan(t.p) for t in trends.values()):
        return "no test (one cycle)"
    drifting = [f"{name} {t.slope:+.3g} ± {t.standard_error:.2g}/cycle (p {t.p:.2g})" for name, t in trends.items()
                if t.drifts]
    return "; ".join(drifting) if drifting else "stationary"
