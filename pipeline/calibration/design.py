"""Which DEM runs would fix the worst-determined parameters best per CPU-hour (``fit.json`` → ``next_runs``).

For each candidate run (another seed of an angle already run, a reversal before steady state, more
cycles, denser sampling, or a committed run the fit leaves out) the best fit gives its Jacobian J (on the run's
own data where the data set has it or a run of its protocol, else on the model's cycle); with the DEM's
measured noise (scale and correlation Sigma along strain, ``noise.NoiseModel``) that gives its parts of the
fit's least squares, ``J^T J`` and ``J^T Sigma J``. Joined to the fit's own runs with the fit's weighting
(``global_fit.weighed``) they give the sandwich covariance our least squares would have with the run,
``H^-1 M H^-1`` (``H = sum w J^T J``, ``M = sum w^2 J^T Sigma J``), not the information a fit weighting by the
full noise covariance would extract: a run whose samples are many and correlated can widen it.
Reported per candidate: the standard deviation along the present weakest direction and the largest relative
standard error of any parameter, before and after, and the CPU-hours the run costs (from the committed runs' CPU
time per unit strain). Every candidate runs as many cycles as the data set's reversal run, as ``make dem`` with
its preset would, and is fitted as the fit's runs are (past the jump with ``FIT_FROM``)."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

import model

from ..dataset.derived import bulk_over_nominal
from ..errors import CalibrationError
from ..schema import CandidateRun
from . import covariance, global_fit
from .fit_cycle import FitCycle
from .noise import NoiseModel


@dataclasses.dataclass(frozen=True)
class Candidate:
    label: str
    theta_deg: float
    rotate_at: float = 0.7
    n_cycles: int = 2
    sample_strain: float = 0.005
    cost_factor: float = 1.0  # CPU time relative to a run of the same strain at the default sampling
    committed: bool = False  # a committed run the fit leaves out: fitted as it is, at no cost

    def strain_run(self, period: float, pre: float) -> float:
        return pre + self.n_cycles * period


def candidates(existing_rotations: list[tuple[float, float]], n_cycles: int) -> list[Candidate]:
    """The runs considered, each ``n_cycles`` long as the data set's runs are: committed runs the fit leaves out
    first (they cost nothing), then new ones."""
    new = functools.partial(Candidate, n_cycles=n_cycles)
    out = [new(f"fit the committed theta = {t:g}, rotated at {r:g} (no new run)", t, r, cost_factor=0.0,
               committed=True) for t, r in existing_rotations]
    out += [new("another reversal seed (theta = 180)", 180.0)]
    out += [new(f"another seed at theta = {t:g}", t) for t in (30.0, 60.0, 90.0, 120.0, 150.0)]
    out += [new(f"a reversal before steady state (theta = 180 at {r:g})", 180.0, r) for r in (0.1, 0.2, 0.35)]
    out += [new(f"{'another seed of ' if (90.0, r) in existing_rotations else ''}theta = 90 rotated at {r:g} (Fig. 7)",
                90.0, r) for r in (0.1, 0.2)]
    out += [new(f"a reversal run for {2 * n_cycles} cycles instead of {n_cycles}", 180.0, n_cycles=2 * n_cycles),
            new("a reversal sampled every 0.001 strain", 180.0, sample_strain=0.001, cost_factor=1.05)]
    return out


def candidate_data(c: Candidate, period: float, ratio: float, noise: NoiseModel, params: model.Params,
                   stress: str = global_fit.STRESS_DEFAULT, fit_from: float = 0.0) -> FitCycle:
    """A pseudo-run of ``c``: the model's cycle as data (the values do not matter, only the Jacobian) with the
    noise scales of an ``n_cycles`` mean; with ``fit_from`` > 0 restarted that far past each change of direction,
    as the fit's runs are (``FitCycle.restarted``, from the model's own state there). A protocol the model's cycle
    fails for raises ``model.SolverError`` or ``ParameterError``; one whose segments are too short to restart in,
    ``ValueError``."""
    strain = np.arange(round(period / c.sample_strain)) * c.sample_strain
    probe = FitCycle(c.theta_deg, c.rotate_at, period, ratio, c.n_cycles, strain, A=np.zeros((len(strain), 3, 3)),
                     tau=np.zeros((len(strain), 3, 3)), phi=np.zeros(len(strain)))
    restarts = np.array([fit_from, c.rotate_at + fit_from]) if fit_from else np.empty(0)
    times, where = np.unique(np.concatenate([strain, restarts]), return_inverse=True)  # one periodic cycle for both
    pred = dataclasses.replace(probe, strain=times).prediction(params)
    on, at = where[:len(strain)], where[len(strain):]
    scales = global_fit.noise_scales(len(strain), noise, c.n_cycles, stress)
    probe = dataclasses.replace(probe, A=pred.A[on], tau=pred.tau[on], A_scale=scales[0], tau_scale=scales[1],
                                phi=pred.packing_fraction[on])
    return probe.restarted(fit_from, (pred.A[at], pred.packing_fraction[at])) if fit_from else probe


def candidate_parts(data: FitCycle, noise: NoiseModel, fit: global_fit.GlobalFit, cache: dict | None = None) -> tuple:
    """A candidate's pseudo-run's parts of the least squares (``covariance.run_parts``) at the best fit, its
    Jacobian by forward differences."""
    base = fit.params
    f0 = global_fit.residuals(fit.values, [data], base, fit.names)
    jac = np.empty((f0.size, len(fit.names)))
    for k, value in enumerate(fit.values):
        step = 1e-4 * max(abs(value), 1e-2)
        shifted = fit.values.copy()
        shifted[k] += step
        jac[:, k] = (global_fit.residuals(shifted, [data], base, fit.names) - f0) / step
    return covariance.run_parts(jac, [data], noise, cache)[0]


def rank(fit: global_fit.GlobalFit, noise: NoiseModel, runs: list, left_out: list, data: list[FitCycle],
         stress: str = global_fit.STRESS_DEFAULT, weight: str = global_fit.WEIGHT_DEFAULT) -> list[dict]:
    """Every candidate with its effect on the weakest direction and the worst relative error, best per
    CPU-hour first (runs that cost nothing and narrow it first of all); last, any that cannot be weighed (the
    model's cycle fails at the best fit, no restart fits; with its ``error``). ``data``: the fit's runs as fitted;
    each candidate joins them weighted by ``weight`` (``global_fit.weighed``: with "angles", another seed of an
    angle takes its share from that angle's runs) and restarted past each change of direction as they are (their
    ``fit_from``). Another seed of a protocol the fit has, sampled and as long as its run, brings that run's parts;
    a committed run of ``left_out`` (read with the fit's definitions), and another seed of it, its own data's; any
    other candidate, a pseudo-run of the model (``candidate_data``)."""
    scale = np.where(fit.values != 0, np.abs(fit.values), 1.0)
    V = fit.covariance
    if V is None or not np.all(np.isfinite(V)):
        return []
    weakest = np.array([fit.directions[0]["direction"][n] for n in fit.names]) / scale
    reference = next(r for r in runs if r.is_reversal)
    spec = reference.spec
    seconds_per_strain = float(np.mean([r.cpu_seconds / (r.spec.pre_strain + r.spec.n_cycles
                                                         * r.spec.period_strain) for r in runs]))
    ratio = bulk_over_nominal(reference)
    present = covariance.run_parts(fit.jacobian, data, noise)
    fit_from = data[0].fit_from
    committed = {(r.spec.theta_deg, r.spec.rotate_at_strain): r for r in left_out}
    fitted = {}
    for i, d in enumerate(data):
        fitted.setdefault(_protocol(d.theta_deg, d.rotate_at, d.n_cycles, d.sample_step), i)
    cache, own_parts = {}, {}

    def parts_of(c: Candidate) -> tuple[FitCycle, tuple]:
        key = _protocol(c.theta_deg, c.rotate_at, c.n_cycles, c.sample_strain)
        if key in fitted:
            return data[fitted[key]], present[fitted[key]]
        own = committed.get((c.theta_deg, c.rotate_at))
        if own is not None and (c.committed or key == _protocol(c.theta_deg, c.rotate_at, own.spec.n_cycles,
                                                                 own.spec.sample_strain)):
            if key not in own_parts:
                probe = global_fit.scaled_cycle(own, noise, fit_from, stress)
                probe.prediction(fit.params)  # the model's failure named, not read as a run that adds nothing
                own_parts[key] = probe, candidate_parts(probe, noise, fit, cache)
            return own_parts[key]
        probe = candidate_data(c, spec.period_strain, ratio, noise, fit.params, stress, fit_from)
        return probe, candidate_parts(probe, noise, fit, cache)

    def measures(cov):
        return float(np.sqrt(weakest @ cov @ weakest)), float(np.max(np.sqrt(np.diag(cov)) / scale))

    before = measures(V)
    out, failed = [], []
    for c in candidates(list(committed), spec.n_cycles):
        try:
            probe, part = parts_of(c)
        except (model.SolverError, model.ParameterError, ValueError, CalibrationError) as exc:
            failed.append(CandidateRun(c.label, c.theta_deg, c.rotate_at, str(exc)))
            continue
        weights = [d.weight for d in global_fit.weighed([*data, probe], weight)]
        after = measures(covariance.sandwich([*present, part], weights)[0])
        hours = c.cost_factor * c.strain_run(spec.period_strain, spec.pre_strain) * seconds_per_strain / 3600
        gain = 1 - after[0] / before[0]
        out.append(CandidateRun(c.label, c.theta_deg, c.rotate_at, None, c.n_cycles, c.sample_strain, hours,
                                before[0], after[0], before[1], after[1],
                                gain / hours if hours > 0 else float("inf") if gain > 0 else float("-inf")))
    return sorted(out, key=lambda r: -r.gain_per_cpu_hour) + failed


def _protocol(theta_deg: float, rotate_at: float, n_cycles: int, sample_strain: float) -> tuple:
    """What makes two runs' parts of the least squares the same, up to their noise: the protocol, the cycles
    averaged and the sampling."""
    return float(theta_deg), round(float(rotate_at), 9), int(n_cycles), round(float(sample_strain), 9)
