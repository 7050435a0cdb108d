"""Global refinement: every flow-rule and fabric parameter fitted at once to the cycles of every angle.

Beyond the paper's stepwise method (``pipeline.calibration.stepwise``): the model's converged periodic cycle is
integrated for each run's protocol (theta, rotate_at) in the runs' strain measure (the period becomes
``bulk_over_nominal * 1.4``), and ``scipy.optimize.least_squares`` minimises the residuals of the 12, 32,
11, 22 and 13 components of A and tau/p, each divided by its noise per sample (``noise.NoiseModel``:
pooled over runs, cycles and seeds). The covariance of the estimates is the sandwich
``H^-1 J^T Sigma J H^-1`` with ``H = J^T J`` and ``Sigma`` the noise's measured correlation along strain and
between A and tau (``refine``, from ``pipeline.calibration.covariance``): the noise as it is, not a Jacobian scaled
by a reduced chi^2 that is model misfit. ``misfit`` (chi^2 per degree of freedom in noise units) says how far the
model is from the data beyond their noise. Refits on resampled data: ``pipeline.calibration.resampling``.
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

import model

from .. import choices
from ..dataset.derived import states_after_changes
from ..errors import CalibrationError
from ..schema import Estimates
from . import noise as noise_model
from .covariance import covariances, directions
from .fit_cycle import FitCycle
from .naming import STRESS_DEFAULT, WEIGHT_DEFAULT
from .noise import COMPONENTS, QUANTITIES

#: the parameters refined (the persistence exponent and the dilatancy stay as given)
FREE = ("C", "n", "m", "a1", "b1", "a2", "b2")


def free_names(variant: str = model.params.DEFAULT_VARIANT) -> tuple[str, ...]:
    """The parameters refined for the fabric law ``variant``: ``FREE`` and the parameters it adds, but those it reads
    off the DEM (``Parameter.measured``: held at their measured value)."""
    return FREE + tuple(q.name for q in model.laws.law_parameters(variant) if not q.measured)


def start_of(variant: str, **given) -> model.Params:
    """Table 2 with the law's own parameters where its declaration starts a fit (``model.laws``: inside their range,
    where each moves the model) and ``given`` on top."""
    starts = {q.name: q.start for q in model.laws.law_parameters(variant)}
    return model.Params(variant=variant, **starts).replace(**given)


def bounds_of(names) -> tuple[np.ndarray, np.ndarray]:
    """The fit's bounds: a law's own parameters within their declared range (``model.params.EXTRA_RANGES``), Eq. 13's
    free."""
    ranges = [model.params.EXTRA_RANGES.get(n, (-np.inf, np.inf)) for n in names]
    return np.array([lo for lo, _ in ranges]), np.array([hi for _, hi in ranges])


#: the components of tau/p each choice fits (A is fitted over every one of ``COMPONENTS``). "shear", the default,
#: is the paper's (Sec. 4): C from tau12 (Eq. 15), Y from tau:D' (Eq. 16), whose D' has only the 12 and 32
#: components (the gradient along e2), the fabric law from every component of A (Eq. 9). The others carry the DEM's
#: normal-stress differences (tau33/p about +0.07 in steady flow; rotated in the wall plane they give tau13 at
#: oblique angles), which tau = C A + Y D'/|D'| cannot give with |A_ii| < 0.004: fitted, they pull the fabric law's
#: a_i and C (docs/calibration.md). "all" fits them too.
STRESS_FITS = dict(zip(choices.STRESSES, (((0, 1), (2, 1)), COMPONENTS), strict=True))


#: how a protocol's runs (theta, rotate_at; its seeds) share the fit. "runs", the default: each run counts once, so
#: an angle with three seeds pulls three times as hard (the efficient weighting were the model exact). "angles":
#: each protocol counts once, its runs' squared residuals each weighted by 1 / their number (the same as fitting
#: their mean with one run's noise): the paper's design of one run per angle with any number of seeds, whose
#: parameters do not move with how many seeds each angle has while the model misses the runs beyond their noise.
WEIGHTS = choices.WEIGHTS


def check_weight(weight: str) -> str:
    if weight not in WEIGHTS:
        raise CalibrationError(f"weight={weight!r}: the runs are weighted by one of {', '.join(WEIGHTS)}")
    return weight


def weighed(data: list[FitCycle], weight: str = WEIGHT_DEFAULT) -> list[FitCycle]:
    """``data`` with each cycle's ``weight`` set by the scheme ``weight`` (``WEIGHTS``) among these cycles."""
    count = Counter((d.theta_deg, d.rotate_at) for d in data)
    share = (lambda d: 1.0) if check_weight(weight) == "runs" else (lambda d: 1.0 / count[d.theta_deg, d.rotate_at])
    return [dataclasses.replace(d, weight=share(d)) for d in data]


def check_stress(stress: str) -> str:
    if stress not in STRESS_FITS:
        raise CalibrationError(f"stress={stress!r}: the stress components fitted are one of {', '.join(STRESS_FITS)}")
    return stress


def noise_scales(samples: int, noise: noise_model.NoiseModel | None, n_cycles: int,
                 stress: str = STRESS_DEFAULT) -> list[np.ndarray]:
    """Per-sample noise scale ``(samples, 3, 3)`` of A and of tau/p for an ``n_cycles`` mean: each fitted
    component's sigma, 1 elsewhere (and everywhere without a noise model); infinite for the components of tau/p
    that ``stress`` leaves out (``STRESS_FITS``), whose residuals are then zero."""
    scales = []
    for q in QUANTITIES:
        scale = np.ones((samples, 3, 3))
        if noise is not None:
            for (i, j), sigma in zip(COMPONENTS, noise.sigma(q, n_cycles), strict=True):
                scale[:, i, j] = sigma
        if q == "tau_over_p":
            for i, j in set(COMPONENTS) - set(STRESS_FITS[check_stress(stress)]):
                scale[:, i, j] = np.inf
        scales.append(scale)
    return scales


def fitted_residuals(data: list[FitCycle]) -> float:
    """How many residuals the data fit: every sample of every component with a finite scale, each counted with its
    run's weight (with ``WEIGHTS`` "angles", a protocol's seeds count as one run)."""
    i, j = np.array(COMPONENTS).T
    return float(sum(d.weight * (np.isfinite(d.A_scale[:, i, j]).sum() + np.isfinite(d.tau_scale[:, i, j]).sum())
                     for d in data))


def prepare(runs: list, fit_from: float = 0.0, stress: str = STRESS_DEFAULT,
            weight: str = WEIGHT_DEFAULT) -> tuple[list[FitCycle], noise_model.NoiseModel]:
    """The noise model measured on ``runs`` and every run's cycle scaled by it, fitting the components of tau/p that
    ``stress`` names, weighted by ``weight`` (``weighed``); with ``fit_from`` > 0 each cycle is restarted that far
    past each change of direction (``FitCycle.restarted``)."""
    noise = noise_model.estimate(runs)
    return weighed([scaled_cycle(r, noise, fit_from, stress) for r in runs], weight), noise


def scaled_cycle(run, noise: noise_model.NoiseModel | None, fit_from: float = 0.0,
                 stress: str = STRESS_DEFAULT) -> FitCycle:
    """The run's :class:`FitCycle` with each component's noise per sample as its scale (``noise_scales``)."""
    cycle = FitCycle.from_run(run)
    step = run.spec.sample_strain
    states = None if abs(fit_from / step - round(fit_from / step)) <= 1e-6 else states_after_changes(run, fit_from)
    scales = noise_scales(len(cycle.strain), noise, cycle.n_cycles, stress)
    try:
        return cycle.with_scales(*scales).restarted(fit_from, states)
    except ValueError as exc:
        raise CalibrationError(f"{Path(run.path).parent.parent.name}/{Path(run.path).stem}: {exc}") from None


@dataclass(frozen=True)
class GlobalFit:
    params: model.Params
    names: tuple[str, ...]
    values: np.ndarray
    standard_errors: np.ndarray
    correlation: np.ndarray
    misfit: float
    nfev: int
    success: bool
    message: str
    directions: tuple = ()
    chi2: float = float("nan")
    covariance: np.ndarray | None = None
    white_covariance: np.ndarray | None = None
    jacobian: np.ndarray | None = None  # of the scaled residuals at the fit, for shift_covariance

    def estimates(self) -> Estimates:
        """The record ``fit.json`` keeps (infinite or undefined entries as None)."""
        cov = lambda m: None if m is None else np.where(np.isfinite(m), m, None).tolist()  # noqa: E731
        return Estimates(self.params.to_dict(), list(self.names), self.values.tolist(),
                         [v if np.isfinite(v) else None for v in self.standard_errors.tolist()],
                         cov(self.correlation), cov(self.covariance), cov(self.white_covariance), self.misfit,
                         self.chi2, self.nfev, self.success, self.message, list(self.directions))


def scaled_residuals(d: FitCycle, pred, pick=slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """(A, tau) residuals ``(samples, components)`` of ``pred`` against the samples ``pick`` of ``d``, over the
    noise scale."""
    i, j = np.array(COMPONENTS).T
    return ((pred.A[:, i, j] - d.A[pick][:, i, j]) / d.A_scale[pick][:, i, j],
            (pred.tau[:, i, j] - d.tau[pick][:, i, j]) / d.tau_scale[pick][:, i, j])


#: an orthonormal basis of symmetric traceless tensors: the directions in which a restart state may move
TRACELESS_BASIS = np.array([
    np.diag([1.0, -1.0, 0.0]) / np.sqrt(2), np.diag([1.0, 1.0, -2.0]) / np.sqrt(6),
    *[(np.eye(3)[:, [a]] @ np.eye(3)[[b]] + np.eye(3)[:, [b]] @ np.eye(3)[[a]]) / np.sqrt(2)
      for a, b in ((0, 1), (0, 2), (1, 2))]])
#: the step of the restart state's finite-difference sensitivity (A is of order 0.1)
RESTART_STEP = 1e-4


def _restarted_residuals(d: FitCycle, params: model.Params) -> tuple[np.ndarray, np.ndarray]:
    """A restarted cycle's residuals with each segment's restart state profiled out: the DEM's A at a restart is
    one noisy sample, so the model starts from it plus the symmetric traceless offset that fits the segment
    best (linearised: one Gauss-Newton step on five finite-difference sensitivities). Without it the restart
    carries the noise of that sample, correlated with the samples after it, into the fabric law."""
    parts_A, parts_tau = [], []
    for k in range(len(d.restarts)):
        pick = d.segment_mask(k)
        r_A, r_tau = scaled_residuals(d, d.segment_prediction(params, k), pick)
        base = np.concatenate([r_A.ravel(), r_tau.ravel()])
        columns = []
        for E in TRACELESS_BASIS:
            e_A, e_tau = scaled_residuals(d, d.segment_prediction(params, k, RESTART_STEP * E), pick)
            columns.append((np.concatenate([e_A.ravel(), e_tau.ravel()]) - base) / RESTART_STEP)
        sensitivity = np.stack(columns, axis=1)
        offset, *_ = np.linalg.lstsq(sensitivity, -base, rcond=None)
        best = (base + sensitivity @ offset).reshape(2, *r_A.shape)
        parts_A.append(best[0])
        parts_tau.append(best[1])
    return np.concatenate(parts_A), np.concatenate(parts_tau)


def residuals(values: np.ndarray, data: list[FitCycle], base: model.Params, names=FREE) -> np.ndarray:
    """Model minus DEM over the noise scale, times the square root of the run's weight: per run, per component,
    the A block then the tau block (a restarted cycle's restart states profiled out: ``_restarted_residuals``)."""
    params = base.replace(**dict(zip(names, map(float, values), strict=True)))
    out = []
    for d in data:
        try:
            r_A, r_tau = _restarted_residuals(d, params) if d.restarts else scaled_residuals(d, d.prediction(params))
        except (model.SolverError, model.ParameterError):
            return np.full(sum(2 * len(x.strain) * len(COMPONENTS) for x in data), 1e3)
        root = np.sqrt(d.weight)
        for c in range(len(COMPONENTS)):
            out += [root * r_A[:, c], root * r_tau[:, c]]
    return np.concatenate(out)


def refine(data: list[FitCycle], start: model.Params, names=FREE, max_nfev: int = 200,
           noise: noise_model.NoiseModel | None = None) -> GlobalFit:
    """Least squares from ``start``, its covariance with ``noise``'s correlation (white without one);
    a fit that fails raises CalibrationError."""
    if not data:
        raise CalibrationError("no run to fit")
    x0 = np.array([getattr(start, n) for n in names])
    lower, upper = bounds_of(names)
    sol = least_squares(residuals, np.clip(x0, lower, upper), args=(data, start, names),
                        x_scale=np.maximum(np.abs(x0), 1e-2), max_nfev=max_nfev, method="trf", bounds=(lower, upper))
    if not sol.success or not np.all(np.isfinite(sol.x)):
        raise CalibrationError(f"the global fit did not converge ({sol.message})")
    chi2 = float(2 * sol.cost)
    misfit = chi2 / max(fitted_residuals(data) - sol.x.size, 1)
    cov, white = covariances(sol.jac, data, noise)
    se = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore"):
        corr = cov / np.outer(se, se)
    params = start.replace(**dict(zip(names, map(float, sol.x), strict=True)))
    return GlobalFit(params, tuple(names), sol.x, se, corr, misfit, int(sol.nfev), bool(sol.success), sol.message,
                     directions(cov, sol.x, names), chi2, cov, white, sol.jac)


DILATANCY = ("c2_coef", "phi_c")


def _dilatancy_residuals(values, data: list[FitCycle], base: model.Params) -> np.ndarray:
    params = base.replace(**dict(zip(DILATANCY, map(float, values), strict=True)))
    out = []
    for d in data:
        try:
            out.append(d.prediction(params).packing_fraction - d.phi)
        except (model.SolverError, model.ParameterError):
            return np.full(sum(len(x.phi) for x in data), 1.0)
    return np.concatenate(out)


def with_eq19_c1(params: model.Params) -> model.Params:
    """``params`` with c1 = -C (Eq. 19: the second law with the fitted C), whether Eq. 18 is fitted or not."""
    return params.replace(c1=-params.C)


def refine_dilatancy(data: list[FitCycle], params: model.Params) -> GlobalFit:
    """c2_coef and Phi_c of Eq. 18 fitted to the DEM's Phi over every cycle, with c1 = -C (Eq. 19)
    and c3, the c2 exponent and the flow rule and fabric law of ``params`` held fixed."""
    base = with_eq19_c1(params)
    lower, upper = np.array([1e-3, 0.3]), np.array([100.0, model.equations.PHI_MAX])  # Phi_c below Phi_max
    x0 = np.array([base.c2_coef, float(np.mean(np.concatenate([d.phi for d in data])))])
    x0 = np.clip(x0, lower + 1e-3 * (upper - lower), upper - 1e-3 * (upper - lower))
    sol = least_squares(_dilatancy_residuals, x0, args=(data, base), x_scale=[1.0, 0.01],
                        bounds=(lower, upper), max_nfev=100)
    if not sol.success:
        raise CalibrationError(f"the dilatancy fit did not converge ({sol.message})")
    at_bound = [f"{name} = {value:.4g}" for name, value, active in zip(DILATANCY, sol.x, sol.active_mask, strict=True)
                if active]
    if at_bound:
        raise CalibrationError(f"the dilatancy fit sits at a bound: {', '.join(at_bound)}")
    dof = max(sol.fun.size - sol.x.size, 1)
    chi2 = float(2 * sol.cost / dof)
    cov = np.linalg.pinv(sol.jac.T @ sol.jac) * chi2
    se = np.sqrt(np.diag(cov))
    fitted = base.replace(**dict(zip(DILATANCY, map(float, sol.x), strict=True)))
    return GlobalFit(fitted, DILATANCY, sol.x, se, cov / np.outer(se, se), chi2, int(sol.nfev), True, sol.message)


