"""From raw DEM samples to model-ready series and the cycle-averaged periodic cycle (no file I/O).

Computed when a run file is read (``DemRun.series``, ``DemRun.cycle``), never stored in it.

Conventions (README): walls normal to e2, shear direction s(phi) = cos(phi) e1 + sin(phi) e3, strain
t*gamma_dot from the start of the first period (negative in the preceding half period), stress
tension-positive and normalised by the controlled wall normal stress p (= 1 in the DEM's units),
tau = sigma', fabric A of Eq. 8, S of Eq. 10, work rates of Sec. 5 per unit p*gamma_dot.
"""

from __future__ import annotations

import numpy as np

from model import deviator, hardening_variable_stack, shear_direction, stretching

from ..schema.definitions import Definitions

#: the series averaged into the periodic cycle
CYCLE_KEYS = ("strain_bulk", "A", "tau_over_p", "mean_stress_over_p", "S", "packing_fraction", "w_shear", "w_vol",
              "shear_rate_bulk")

DEFAULT = Definitions()
#: the paper's own: strain t*2U/H (Sec. 2) and Phi of the whole gap; what ``make fit`` reports first
#: (its Table 2 matches the nominal strain: docs/calibration.md, "Definitions the paper leaves open")
PAPER_DEFINITIONS = Definitions(strain="nominal", phi="gap", pressure="target")


def shear_rate_tensor(gradient):
    """D = sym(g e2) for the velocity gradient L = g (x) e2 of a flow between walls normal to e2."""
    L = np.zeros(gradient.shape[:-1] + (3, 3))
    L[..., :, 1] = gradient
    return stretching(L)


def cycle_D_dev(run) -> np.ndarray:
    """D' per unit nominal gamma_dot along the run's cycle grid: phi = 0 before ``rotate_at``, theta after."""
    strain = run.cycle["strain"]
    angle = np.where(strain < run.spec.rotate_at_strain - 1e-9, 0.0, run.spec.theta_deg)
    return deviator(shear_rate_tensor(shear_direction(angle)))


def bulk_over_nominal(run) -> float:
    """Strain per unit nominal strain in the run's strain measure: for ``bulk``, the central band's
    strain over the nominal strain across the cycles (the preceding half period excluded); 1 for ``nominal``."""
    if run.definitions.strain == "nominal":
        return 1.0
    nominal, bulk = run.series["strain_nominal"], run.series["strain_bulk"]
    last = int(np.argmax(nominal))
    return float((bulk[last] - bulk[np.argmin(np.abs(nominal))]) / nominal[last])


def bulk_strain(time, strain, direction_deg, gradient, gamma_dot):
    """Strain of the central band, integral of s . dv/dy in time from the start of the first period.

    Each sampling interval is integrated along the direction it was sheared in, that of its first
    sample: a sample taken at a change of direction already carries the new direction while the
    grains still move the old way, and must not count that motion backwards.
    """
    s = shear_direction(direction_deg)
    rate = np.where(np.isfinite(gradient), gradient, 0.0)
    fallback = ~np.all(np.isfinite(gradient), axis=-1)
    left = np.where(fallback[:-1], gamma_dot, np.einsum("ni,ni->n", s[:-1], rate[:-1]))
    right = np.where(fallback[1:], gamma_dot, np.einsum("ni,ni->n", s[:-1], rate[1:]))
    out = np.concatenate([[0.0], np.cumsum(0.5 * (left + right) * np.diff(time))])
    return out - out[np.argmin(np.abs(strain))]


def gap_packing_fraction(gap, width, grain_diameter):
    """All grains' volume over the cell between the walls' surfaces, W^2 (H - d) (wall spheres of diameter d)."""
    return (np.pi / 6 * np.sum(np.asarray(grain_diameter) ** 3)) / (width**2 * (np.asarray(gap) - 1.0))


def model_series(raw: dict, parameters: dict, definitions: Definitions = DEFAULT, grain_diameter=None) -> dict:
    """Per-sample model-ready quantities (shear phase, preceding half period included).

    ``strain_bulk``: :func:`bulk_strain`; ``D_dev_nominal`` is per unit nominal
    gamma_dot (so |D'| = 1/sqrt(2)); ``D_dev_measured`` is in units of sqrt(p/rho)/d. Work rates use
    the nominal D' and are per unit p*gamma_dot: ``w_shear = tau:D'``, ``w_vol = (dPhi/dstrain)/Phi``.
    """
    strain = raw["strain"]
    gamma_dot = parameters["gamma_dot_nominal"]
    s = shear_direction(raw["direction_deg"])
    gradient = raw["velocity_gradient"]
    parallel_rate = np.einsum("ni,ni->n", s, gradient)
    strain_bulk = bulk_strain(raw["time"], strain, raw["direction_deg"], gradient, gamma_dot)

    stress = raw["stress_contact"] + raw["stress_kinetic"]
    # the unit of stress is the controlled p; "wall": the wall stress measured over each sampling interval
    p_wall = 1.0 + raw["wall_stress_error_mean"][:, None, None] if definitions.pressure == "wall" else 1.0
    tau = deviator(stretching(stress)) / p_wall
    D_nominal = deviator(shear_rate_tensor(s))
    D_measured = deviator(shear_rate_tensor(gradient))
    A = raw["fabric"]
    if definitions.phi == "gap":
        if grain_diameter is None:
            raise ValueError("the gap packing fraction needs the grain diameters")
        phi = gap_packing_fraction(raw["gap"], parameters["width_d"], grain_diameter)
    else:
        phi = raw["packing_fraction"]
    dphi = np.gradient(phi, strain)
    return {
        "strain_nominal": strain,
        "strain_bulk": strain_bulk,
        "shear_rate_bulk": parallel_rate,
        "D_dev_nominal": D_nominal,
        "D_dev_measured": D_measured,
        "A": A,
        "tau_over_p": tau,
        "mean_stress_over_p": -np.trace(stress, axis1=1, axis2=2) / 3 / np.reshape(p_wall, -1),
        "S": hardening_variable_stack(A, D_nominal),
        "packing_fraction": phi,
        "w_shear": np.einsum("nij,nij->n", tau, D_nominal),
        "w_vol": dphi / phi,
    }


#: nominal strain before each change of direction over which a run's steady values are taken
STEADY_WINDOW = 0.3


def change_strains(spec) -> np.ndarray:
    """Nominal strains where the shear direction changes: 0, rotate_at, period, ..., and the run's end."""
    period, rotate, n = spec.period_strain, spec.rotate_at_strain, spec.n_cycles
    starts = period * np.arange(n + 1)
    return np.unique(np.concatenate([starts, starts[:-1] + rotate]))


def means_before(strain: np.ndarray, values: np.ndarray, ends, window: float = STEADY_WINDOW) -> np.ndarray:
    """The mean of ``values`` over the ``window`` of nominal ``strain`` before each of ``ends`` (a run's steady
    windows, with ``change_strains``)."""
    return np.array([np.mean(values[(strain > e - window - 1e-9) & (strain < e - 1e-9)]) for e in ends])


def cycle_indices(strain, period: float, step: float, n_cycles: int) -> tuple[np.ndarray, np.ndarray]:
    """The grid 0, step, ..., period and, per cycle, the index of the sample nearest to each grid
    point (``(n_cycles, n_grid)``); samples land within a few time steps of the grid."""
    n_grid = int(round(period / step)) + 1
    grid = np.arange(n_grid) * step
    targets = np.arange(n_cycles)[:, None] * period + grid[None, :]
    idx = np.abs(strain[None, None, :] - targets[..., None]).argmin(axis=-1)
    if np.max(np.abs(strain[idx] - targets)) > 0.5 * step:
        raise ValueError("samples do not cover every cycle on the sampling grid")
    return grid, idx


def cycle_average(strain, values: dict, period: float, step: float, n_cycles: int) -> dict:
    """Mean and standard error across cycles on the grid 0, step, ..., period (inclusive).

    Samples with ``strain < 0`` (the preceding half period) are excluded. Sample ``k`` of cycle
    ``c`` is the one nearest to strain ``c*period + k*step``. With one cycle the standard error is NaN.
    """
    grid, idx = cycle_indices(strain, period, step, n_cycles)
    out = {"strain": grid}
    for key, v in values.items():
        per_cycle = v[idx]  # (n_cycles, n_grid, ...)
        out[key] = per_cycle.mean(axis=0)
        out[key + "_sem"] = (per_cycle.std(axis=0, ddof=1) / np.sqrt(n_cycles) if n_cycles > 1
                             else np.full(per_cycle.shape[1:], np.nan))
    return out


def run_cycle(run) -> dict:
    """The run's periodic cycle: mean and standard error of every ``CYCLE_KEYS`` series across its cycles."""
    spec = run.spec
    return cycle_average(run.series["strain_nominal"], {k: run.series[k] for k in CYCLE_KEYS},
                         spec.period_strain, spec.sample_strain, spec.n_cycles)


def states_after_changes(run, offset: float):
    """Cycle means of A and Phi ``offset`` (nominal strain) past each of a period's two changes of direction
    (at 0 and at ``rotate_at``), from every sample, the dense ones included: (A (2, 3, 3), Phi (2,)), or None
    where some cycle has no sample there (a run without dense sampling at that strain)."""
    spec, series = run.spec, run.series_all
    strain = series["strain_nominal"]
    fine = spec.dense_sample_strain if spec.dense_window_strain > offset else 0.0
    tol = 0.25 * (fine if fine > 0 else spec.sample_strain)
    A, phi = [], []
    for at in (0.0, spec.rotate_at_strain):
        targets = np.arange(spec.n_cycles) * spec.period_strain + at + offset
        idx = np.abs(strain[None, :] - targets[:, None]).argmin(axis=1)
        if np.max(np.abs(strain[idx] - targets)) > tol:
            return None
        A.append(series["A"][idx].mean(axis=0))
        phi.append(float(series["packing_fraction"][idx].mean()))
    return np.array(A), np.array(phi)


def resampled_cycle(run, rng: np.random.Generator, keys=("A", "tau_over_p", "packing_fraction")) -> dict:
    """The cycle means of ``keys`` over the run's cycles drawn with replacement (a bootstrap sample),
    on the grid of ``cycle_indices``."""
    n = run.spec.n_cycles
    _, idx = cycle_indices(run.series["strain_nominal"], run.spec.period_strain, run.spec.sample_strain, n)
    pick = idx[rng.integers(0, n, n)]
    return {key: run.series[key][pick].mean(axis=0) for key in keys}
