"""Global refinement: every flow-rule and fabric parameter fitted at once to the cycles of every angle.

Beyond the paper's stepwise method (``pipeline.calibration.stepwise``): the model's converged periodic cycle is
integrated for each run's protocol (theta, rotate_at) with the strain measured in *bulk* strain
(the period becomes ``bulk_over_nominal * 1.4``), and ``scipy.optimize.least_squares`` minimises
the residuals of the off-diagonal and normal components of A and tau/p, each divided by its
noise scale: the cycle's standard error, or with one cycle the rms scatter of that component about
its smoothed cycle; floored at ``FLOOR``. Standard errors
and the correlation matrix come from the Jacobian at the optimum, scaled by the reduced chi-square.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

import model

from ..dataset.derived import bulk_over_nominal, cycle_D_dev, resampled_cycle
from ..errors import CalibrationError
from .estimators import smooth_segments

#: the parameters refined (the persistence exponent and the dilatancy stay as given)
FREE = ("C", "n", "m", "a1", "b1", "a2", "b2")
COMPONENTS = ((0, 1), (2, 1), (0, 0), (1, 1), (0, 2))
FLOOR = {"A": 2e-3, "tau": 1e-2}  # smallest noise scale per sample (fabric, tau/p)


@dataclass(frozen=True)
class CycleData:
    """One run's cycle, as the global fit needs it (strain on the nominal grid)."""

    theta_deg: float
    rotate_at: float
    period: float
    bulk_over_nominal: float
    strain: np.ndarray
    A: np.ndarray
    tau: np.ndarray
    A_scale: np.ndarray
    tau_scale: np.ndarray
    phi: np.ndarray

    @classmethod
    def from_run(cls, run) -> CycleData:
        c = run.cycle
        ratio = bulk_over_nominal(run)
        A_sem, tau_sem = c["A_sem"], c["tau_over_p_sem"]
        if np.isnan(A_sem).all():  # one cycle: the scatter about the smoothed cycle, per component
            D = cycle_D_dev(run)
            A_sem = _scatter(c["strain"], c["A"], D)
            tau_sem = _scatter(c["strain"], c["tau_over_p"], D)
        # the last sample closes the period: the DEM has turned back to e1 there, the model's output
        # at the period's end has not, so it is left out
        keep = slice(0, -1)
        return cls(run.spec["theta_deg"], run.spec["rotate_at_strain"], run.spec["period_strain"], ratio,
                   c["strain"][keep], c["A"][keep], c["tau_over_p"][keep], np.maximum(A_sem, FLOOR["A"])[keep],
                   np.maximum(tau_sem, FLOOR["tau"])[keep], c["packing_fraction"][keep])


def _scatter(strain, X, D, window: float = 0.05) -> np.ndarray:
    """Per-component rms deviation of X from its segment-wise smoothed self, broadcast to X's shape."""
    smooth, _ = smooth_segments(strain, X, D, window_strain=window)
    rms = np.sqrt(np.nanmean((X - smooth) ** 2, axis=0))
    return np.broadcast_to(rms, X.shape).copy()


@dataclass(frozen=True)
class GlobalFit:
    params: model.Params
    names: tuple[str, ...]
    values: np.ndarray
    standard_errors: np.ndarray
    correlation: np.ndarray
    reduced_chi2: float
    nfev: int
    success: bool
    message: str
    directions: tuple = ()

    def to_dict(self) -> dict:
        return {"params": self.params.to_dict(), "free": list(self.names), "values": self.values.tolist(),
                "standard_errors": self.standard_errors.tolist(), "correlation": self.correlation.tolist(),
                "reduced_chi2": self.reduced_chi2, "nfev": self.nfev, "success": self.success,
                "message": self.message, "fisher_directions": list(self.directions)}


def fisher_directions(jac: np.ndarray, values: np.ndarray, names, reduced_chi2: float) -> tuple[dict, ...]:
    """Eigen-directions of the Fisher matrix in relative parameters (d ln theta), weakest first.

    ``relative_step`` is the relative change along a direction that raises chi^2 by the reduced chi^2
    (one unit of noise if the misfit were noise): a large step is a combination the data do not fix.
    """
    scaled = jac * np.where(values != 0, np.abs(values), 1.0)[None, :]
    strength, vectors = np.linalg.eigh(scaled.T @ scaled)
    out = []
    for lam, v in zip(strength, vectors.T, strict=True):
        v = v * np.sign(v[np.argmax(np.abs(v))])
        out.append({"relative_step": float(np.sqrt(reduced_chi2 / max(lam, 1e-300))),
                    "direction": {n: float(c) for n, c in zip(names, v, strict=True)}})
    return tuple(out)


def predict_cycle(data: CycleData, params: model.Params) -> model.Result:
    """The model's periodic cycle for ``data``'s protocol, in bulk strain, at its samples."""
    r = data.bulk_over_nominal
    history = model.periodic_cycle(data.theta_deg, rotate_at=r * data.rotate_at, period=r * data.period)
    return model.periodic(history, params=params, times=r * data.strain)


def residuals(values: np.ndarray, data: list[CycleData], base: model.Params, names=FREE) -> np.ndarray:
    params = base.replace(**dict(zip(names, map(float, values), strict=True)))
    out = []
    for d in data:
        try:
            pred = predict_cycle(d, params)
        except (model.SolverError, model.ParameterError):
            return np.full(sum(2 * len(x.strain) * len(COMPONENTS) for x in data), 1e3)
        for i, j in COMPONENTS:
            out.append((pred.A[:, i, j] - d.A[:, i, j]) / d.A_scale[:, i, j])
            out.append((pred.tau[:, i, j] - d.tau[:, i, j]) / d.tau_scale[:, i, j])
    return np.concatenate(out)


def refine(data: list[CycleData], start: model.Params, names=FREE, max_nfev: int = 200) -> GlobalFit:
    """Least squares from ``start``; a fit that fails or sits at a bound raises CalibrationError."""
    if not data:
        raise CalibrationError("no run to fit")
    x0 = np.array([getattr(start, n) for n in names])
    sol = least_squares(residuals, x0, args=(data, start, names), x_scale=np.maximum(np.abs(x0), 1e-2),
                        max_nfev=max_nfev, method="trf")
    if not sol.success or not np.all(np.isfinite(sol.x)):
        raise CalibrationError(f"the global fit did not converge ({sol.message})")
    dof = max(sol.fun.size - sol.x.size, 1)
    chi2 = float(2 * sol.cost / dof)
    jtj = sol.jac.T @ sol.jac
    try:
        cov = np.linalg.inv(jtj) * chi2
    except np.linalg.LinAlgError:
        raise CalibrationError("the global fit is degenerate (singular Jacobian): fit fewer parameters") from None
    se = np.sqrt(np.diag(cov))
    corr = cov / np.outer(se, se)
    params = start.replace(**dict(zip(names, map(float, sol.x), strict=True)))
    return GlobalFit(params, tuple(names), sol.x, se, corr, chi2, int(sol.nfev), bool(sol.success), sol.message,
                     fisher_directions(sol.jac, sol.x, names, chi2))


DILATANCY = ("c2_coef", "phi_c")


def _dilatancy_residuals(values, data: list[CycleData], base: model.Params) -> np.ndarray:
    params = base.replace(**dict(zip(DILATANCY, map(float, values), strict=True)))
    out = []
    for d in data:
        try:
            out.append(predict_cycle(d, params).packing_fraction - d.phi)
        except (model.SolverError, model.ParameterError):
            return np.full(sum(len(x.phi) for x in data), 1.0)
    return np.concatenate(out)


def refine_dilatancy(data: list[CycleData], params: model.Params) -> GlobalFit:
    """c2_coef and Phi_c of Eq. 18 fitted to the DEM's Phi over every cycle, with c1 = -C (Eq. 19)
    and c3, the c2 exponent and the flow rule and fabric law of ``params`` held fixed."""
    base = params.replace(c1=-params.C)
    lower, upper = np.array([1e-3, 0.3]), np.array([100.0, 0.9])
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


def resampled(data: CycleData, run, rng: np.random.Generator) -> CycleData:
    """``data`` with its cycle means recomputed from cycles drawn with replacement (same noise scales)."""
    c = resampled_cycle(run, rng)  # the last sample is left out, as in from_run
    return CycleData(data.theta_deg, data.rotate_at, data.period, data.bulk_over_nominal, data.strain,
                     c["A"][:-1], c["tau_over_p"][:-1], data.A_scale, data.tau_scale, c["packing_fraction"][:-1])


def bootstrap(runs: list, start: model.Params, replicates: int, seed: int = 0,
              progress=None) -> dict:
    """Refit C, n, m, a_i, b_i on ``replicates`` resamplings of every run's cycles (runs with one cycle
    stay as they are). Returns the replicates' values, standard deviations and 2.5/97.5 percentiles."""
    if not any(r.spec["n_cycles"] > 1 for r in runs):
        raise CalibrationError("a bootstrap over cycles needs runs with more than one cycle")
    rng = np.random.default_rng(seed)
    base = [CycleData.from_run(r) for r in runs]
    values = []
    for k in range(replicates):
        data = [resampled(d, r, rng) if r.spec["n_cycles"] > 1 else d for d, r in zip(base, runs, strict=True)]
        values.append(refine(data, start).values)
        if progress:
            progress(k + 1, replicates)
    v = np.array(values)
    return {"free": list(FREE), "replicates": v.tolist(), "standard_deviation": v.std(axis=0, ddof=1).tolist(),
            "percentile_2.5": np.percentile(v, 2.5, axis=0).tolist(),
            "percentile_97.5": np.percentile(v, 97.5, axis=0).tolist(), "seed": seed}
