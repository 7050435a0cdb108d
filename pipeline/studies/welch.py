"""Welch's test of two means with standard errors of their own: the critical value of t at the
Welch-Satterthwaite degrees of freedom, shared by the studies that set one measurement against another."""

from __future__ import annotations

import math

import numpy as np
from scipy import stats


def critical(se_a: float, dof_a: float, se_b: float, dof_b: float, level: float = 0.95) -> float:
    """Two-sided ``level`` critical value of t for a difference whose parts have standard errors ``se_a``, ``se_b``
    estimated with ``dof_a``, ``dof_b`` degrees of freedom (``math.inf``: a known error); NaN where a part has no
    degree of freedom or the difference no error."""
    va, vb = se_a**2, se_b**2
    if not (dof_a > 0 and dof_b > 0 and va + vb > 0):
        return math.nan
    spread = va**2 / dof_a + vb**2 / dof_b
    dof = (va + vb) ** 2 / spread if spread > 0 else math.inf  # both errors known: the normal quantile
    return float(stats.t.ppf(0.5 + level / 2, dof))


def own_floor(errors: list) -> float:
    """The standard error of a mean over runs from each run's own error, sqrt(mean of squares / n) (NaN where none
    has one): the least a few seeds' mean may claim, where they agree by chance more closely than each one's noise
    allows and their scatter alone would claim less."""
    known = [e for e in errors if e is not None and np.isfinite(e)]
    return float(np.sqrt(np.mean(np.square(known)) / len(errors))) if known else math.nan
