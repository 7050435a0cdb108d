"""Synthetic DEM runs made by the model: raw samples in the scene's format, with a known truth.

``synthetic_raw(theta_deg, params, n_cycles, noise, seed)`` returns ``(raw, meta)`` as
``dem/yade/scene.py`` would write them to ``raw.npz``, for the Fig. 1 protocol (the preceding half
period at theta, then ``n_cycles`` periods), sampled every 0.005 strain, in DEM units (p = 1).
The fabric, stress and packing fraction are the model's converged periodic cycle plus Gaussian
noise of standard deviation ``noise`` (fabric and tau/p) and ``noise / 10`` (packing fraction); with
``correlation_strain`` > 0 the noise is DEM-like: an AR(1) process along strain, correlation
exp(-lag/correlation_strain), and the tau noise of each component correlated with its fabric noise
by ``a_tau_correlation``.
Walls and profiles are placeholders (one bin). Used to test the post-processing against the
model and to calibrate on data whose parameters are known.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

import model
from dem.core.schema import check_row
from pipeline.config import load_presets, protocol_defaults
from pipeline.engines import ENGINES
from pipeline.spec import run_folder, run_name

PERIOD, PRE, STEP = (protocol_defaults()[k] for k in ("period_strain", "pre_strain", "sample_strain"))
#: a 10d x 8.5d cell of grains of diameter d: the gap follows Phi, so Phi of the gap is the model's Phi too
WIDTH, N_GRAINS = 10.0, 860
GRAIN_VOLUME = N_GRAINS * np.pi / 6


def _symmetric_traceless(m):
    m = (m + np.swapaxes(m, 1, 2)) / np.sqrt(2)  # off-diagonal components keep the standard deviation
    return m - np.trace(m, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3


def _ar1(white, rho: float):
    """x_t = rho x_(t-1) + sqrt(1 - rho^2) e_t along the first axis, stationary from the first sample."""
    out = np.empty_like(white)
    out[0] = white[0]
    for t in range(1, len(white)):
        out[t] = rho * out[t - 1] + np.sqrt(1 - rho**2) * white[t]
    return out


def dem_like_noise(rng, n: int, scale: float, correlation_strain: float = 0.0, a_tau_correlation: float = 0.0,
                   step: float = 0.005):
    """Noise for A and tau/p, ``(n, 3, 3)`` each: symmetric, traceless, standard deviation ``scale`` off the
    diagonal, correlated along strain and between A and tau (see the module docstring)."""
    rho = np.exp(-step / correlation_strain) if correlation_strain > 0 else 0.0
    a = _ar1(rng.normal(size=(n, 3, 3)), rho)
    b = _ar1(rng.normal(size=(n, 3, 3)), rho)
    c = a_tau_correlation
    return scale * _symmetric_traceless(a), scale * _symmetric_traceless(c * a + np.sqrt(1 - c**2) * b)


def jump_cycle(theta_deg: float, params: model.Params, jump: float, iterations: int = 40):
    """The periodic cycle of a model whose fabric loses the fraction ``jump`` of itself at once at each change of
    direction, then follows Eq. 13: a jump the paper's model cannot make. Outputs every 0.005 over a period;
    the sample at a change carries the state after the jump."""
    grid = np.round(np.arange(0.0, PERIOD + STEP / 2, STEP), 10)
    half = PERIOD / 2
    start = model.predict(theta_deg, params=params)
    A, phi = start.A[0], start.packing_fraction[0]
    first = grid[grid < half - 1e-9]
    second = grid[grid >= half - 1e-9] - half
    for _ in range(iterations):
        one = model.integrate(model.History((model.shear_segment(half, 0.0),)), A0=(1 - jump) * A,
                              packing_fraction0=phi, params=params, times=np.append(first, half))
        two = model.integrate(model.History((model.shear_segment(half, theta_deg),)), A0=(1 - jump) * one.A[-1],
                              packing_fraction0=one.packing_fraction[-1], params=params, times=second)
        done = np.max(np.abs(two.A[-1] - A)) < 1e-12
        A, phi = two.A[-1], two.packing_fraction[-1]
        if done:
            break
    return SimpleNamespace(strain=grid, **{k: np.concatenate([getattr(one, k)[:-1], getattr(two, k)])
                                           for k in ("A", "tau", "packing_fraction")})


def synthetic_raw(theta_deg: float, params: model.Params | None = None, n_cycles: int = 2, noise: float = 0.0,
                  seed: int = 0, gamma_dot: float = 1e-3, bulk_ratio: float = 1.0,
                  overrides: dict | None = None, correlation_strain: float = 0.0,
                  a_tau_correlation: float = 0.0, jump: float = 0.0, preset: str = "synthetic",
                  engine: str = "yade") -> tuple[dict, dict]:
    """Raw samples and metadata of a synthetic run (rotation at half the period, Fig. 1) of ``preset``; with
    ``jump`` > 0 the fabric loses that fraction of itself at each change of direction (``jump_cycle``)."""
    params = params or model.Params()
    # strain 0, 0.005, ..., 1.4
    cycle = jump_cycle(theta_deg, params, jump) if jump else model.predict(theta_deg, params=params)
    per_period = len(cycle.strain) - 1
    strain = np.round(np.arange(-PRE, n_cycles * PERIOD + STEP / 2, STEP), 10)
    # a sample on a period boundary takes the new direction, as in the scene (the model's output at
    # strain 1.4 still has the old one: only tau, S and the work rates differ there)
    phase_index = np.round(np.mod(strain, PERIOD) / STEP).astype(int) % per_period
    n = len(strain)
    rng = np.random.default_rng(seed)
    noise_A, noise_tau = dem_like_noise(rng, n, noise, correlation_strain, a_tau_correlation, STEP)
    A = cycle.A[phase_index] + noise_A
    tau = cycle.tau[phase_index] + noise_tau
    phi = cycle.packing_fraction[phase_index] + rng.normal(scale=noise / 10, size=n)
    within = strain - PERIOD * np.floor(strain / PERIOD + 1e-12)
    direction_deg = np.where((strain < 0) | (within >= PERIOD / 2 - 1e-9), float(theta_deg), 0.0)
    # the grains' flow at a sample follows the direction of the interval that ends there: at a change of
    # direction the sample carries the new wall direction while the central band still moves the old way
    flowing = model.shear_direction(np.concatenate([direction_deg[:1], direction_deg[:-1]]))
    edges = np.array([0.0, 8.5])
    raw = {
        "iteration": np.arange(n) * 1000, "time": (strain + PRE) / gamma_dot, "strain": strain,
        "direction_deg": direction_deg, "gap": 1.0 + GRAIN_VOLUME / (WIDTH**2 * phi),
        "region": np.tile([2.5, 6.0], (n, 1)),
        "top_position": np.zeros((n, 3)), "bottom_position": np.zeros((n, 3)), "top_velocity": np.zeros((n, 3)),
        "bottom_velocity": np.zeros((n, 3)), "top_force": np.zeros((n, 3)), "bottom_force": np.zeros((n, 3)),
        "wall_stress_error_mean": np.zeros(n), "wall_stress_error_max": np.zeros(n),
        "stress_contact": tau - np.eye(3), "stress_kinetic": np.zeros((n, 3, 3)), "fabric": A,
        "contacts": np.full(n, 1000), "grains": np.full(n, 300), "coordination": np.full(n, 4.0),
        "packing_fraction": phi, "velocity_gradient": bulk_ratio * gamma_dot * flowing,
        "profile_edges": np.tile(edges, (n, 1)), "profile_velocity": np.zeros((n, 1, 3)),
        "profile_packing_fraction": phi[:, None], "profile_stress": (tau - np.eye(3))[:, None],
        "profile_fabric": A[:, None], "profile_contacts": np.full((n, 1), 1000),
    }
    check_row(raw)
    # a whole spec (``dem.core.spec.DemSpec``): the reduced preset's values, with the synthetic run's protocol and
    # no dense samples
    values = {**load_presets()["reduced"], "width_d": WIDTH, "period_strain": PERIOD, "sample_strain": STEP,
              "n_cycles": int(n_cycles), "pre_strain": PRE, "inertial_number": gamma_dot, "seed": int(seed),
              "dense_window_strain": 0.0, "dense_sample_strain": 0.0, **(overrides or {})}
    spec = {"spec_version": 1, "preset": preset, "engine": engine, "overrides": dict(overrides or {}),
            "theta_deg": float(theta_deg), "rotate_at_strain": PERIOD / 2,
            "name": run_name(theta_deg, PERIOD / 2, PERIOD / 2),
            "folder": run_folder(preset, engine, overrides) if engine in ENGINES else preset,
            **values}
    meta = {"spec": spec, "yade_version": "none (synthetic, made by the model)", "dt": 1.0, "kn": 0.0, "kt": 0.0,
            "cn": 0.0, "ct": 0.0, "n_grains": N_GRAINS, "n_wall_spheres": 0, "gap0": 8.5, "wall_speed": 0.0,
            "gamma_dot_nominal": gamma_dot, "t_shear0": 0.0, "iterations": int(n * 1000), "callback_seconds": 0.0,
            "loop_seconds": 0.0, "grain_radius": [0.5] * N_GRAINS}
    return raw, meta
