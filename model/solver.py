"""Drivers: integrate a shear history, find the periodic cycle, steady states, and ``predict``.

Times in the public API are strains t*gamma_dot (``History.shear_rate`` converts); stresses are
tau/p (tension positive); work rates are per unit p*gamma_dot.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from . import integrator, laws
from .equations import FABRIC_BOUNDS, PHI_C, PHI_MAX, fabric_rates
from .kinematics import (
    ROTATE_AT_STRAIN,
    History,
    Segment,
    deviator,
    modulus,
    periodic_cycle,
    shear_velocity_gradient,
    stretching,
)
from .params import PAPER, VARIANTS, Params

DEFAULT_RTOL = 1e-10
DEFAULT_ATOL = 1e-12
DEFAULT_S_REF = 1e-2  # regularisation scale of the s variable; changes cost, not the solution
DEFAULT_CYCLE_TOL = 1e-10
OUTPUT_STRAIN_STEP = 0.005
#: where the persistence exponent k of Eq. 12 sits in ``Params.as_array()``
PERSISTENCE_INDEX = Params.names().index("persistence_exponent")
MIN_RTOL = 1e-13


class SolverError(RuntimeError):
    """The integration failed or cannot deliver what was asked; the message says why."""


@dataclass
class Result:
    """Solution of the model along a history, sampled at ``strain``.

    Attributes
    ----------
    strain : (n,) t*gamma_dot.
    t : (n,) time, in the units of 1/shear_rate.
    A : (n, 3, 3) fabric tensor (Eq. 8), traceless and symmetric.
    tau : (n, 3, 3) tau/p, the stress deviator over the pressure (Eq. 14), tension positive.
    S : (n,) hardening variable (Eq. 10), >= 0.
    packing_fraction : (n,) Phi (Eq. 18).
    D_dev : (n, 3, 3) the acting D'/gamma_dot (a segment owns [start, end)).
    w_shear, w_vol, w_total : (n,) tau:D', p Phi_dot/Phi and their sum, per unit p*gamma_dot (Eq. 17).
    nfev, nsteps, nrejected : solver work.
    periods : number of periods integrated to converge the cycle (0 if not periodic).
    cycle_residual : max |A(T) - A(0)| of the last period (periodic solutions).
    phi_contraction : exp(-int g) over one period, the factor by which a period shrinks an error
        in 1/Phi; plain period iteration would need log(tol)/log(factor) periods for Phi.
    law_state : (n, k) the fabric law's own state (``model.laws``; k = 0 for most laws): with the fabric
        ``A`` at a strain, what ``integrate`` (``law_state0``) needs to go on from there.
    params : the ``model.Params`` it was made with (``model.update_inputs`` refuses others).
    method, success, message.
    """

    strain: np.ndarray
    t: np.ndarray
    A: np.ndarray
    tau: np.ndarray
    S: np.ndarray
    packing_fraction: np.ndarray
    D_dev: np.ndarray
    w_shear: np.ndarray
    w_vol: np.ndarray
    w_total: np.ndarray
    nfev: int
    nsteps: int
    nrejected: int
    method: str
    periods: int = 0
    cycle_residual: float = float("nan")
    phi_contraction: float = float("nan")
    success: bool = True
    message: str = "integration successful"
    law_state: np.ndarray | None = None
    params: Params | None = None


def pack_fabric(A: np.ndarray) -> np.ndarray:
    """(3, 3) traceless symmetric A -> (A11, A22, A12, A13, A23)."""
    return np.array([A[0, 0], A[1, 1], A[0, 1], A[0, 2], A[1, 2]])


def unpack_fabric(y: np.ndarray) -> np.ndarray:
    """(..., >=5) packed -> (..., 3, 3) fabric."""
    y = np.asarray(y)
    A = np.empty(y.shape[:-1] + (3, 3))
    A[..., 0, 0], A[..., 1, 1], A[..., 2, 2] = y[..., 0], y[..., 1], -y[..., 0] - y[..., 1]
    A[..., 0, 1] = A[..., 1, 0] = y[..., 2]
    A[..., 0, 2] = A[..., 2, 0] = y[..., 3]
    A[..., 1, 2] = A[..., 2, 1] = y[..., 4]
    return A


def _start(params: Params, D_unit, phi: float) -> tuple[np.ndarray, np.ndarray]:
    """Where a history starts under the unit stretching ``D_unit`` (packed 11, 22, 33, 12, 13, 23) at the packing
    fraction ``phi``: the part of the fabric beyond the law's state A (3x3; zero but for "jump" and "elastic") and
    the law's own state (``model.laws``: empty for most laws)."""
    d = np.asarray(D_unit, dtype=float)
    Dh = np.array([[d[0], d[3], d[4]], [d[3], d[1], d[5]], [d[4], d[5], d[2]]])
    return laws.start(params.variant, Dh, params.law_dict(), phi)


def _initial_state(A: np.ndarray, own=()) -> np.ndarray:
    """Kernel state at t = 0: packed fabric, G = v = 0 (see ``model.integrator``), the law's own state after."""
    y0 = np.zeros(integrator.N_STATE + len(own))
    y0[:5] = pack_fabric(A)
    y0[integrator.N_STATE:] = own
    return y0


def _fabric(y: np.ndarray, params: Params, D_unit) -> np.ndarray:
    """The fabric of a kernel state under the unit stretching ``D_unit``: the state A plus kappa D'/|D'| and the
    part the law's own state holds."""
    A = unpack_fabric(y[:5])
    kappa = laws.offset(params.as_array())
    d = np.asarray(D_unit, dtype=float)
    A = A + kappa * np.array([[d[0], d[3], d[4]], [d[3], d[1], d[5]], [d[4], d[5], d[2]]])
    if y.shape[0] > integrator.N_STATE:
        A = A + unpack_fabric(np.array(laws.state_fabric(y, params.as_array())))
    return A


def _check_fabric(A0) -> np.ndarray:
    A0 = np.array(A0, dtype=float)
    if A0.shape != (3, 3):
        raise SolverError(f"initial fabric must be 3x3, got shape {A0.shape}")
    if not math.isfinite(float(np.sum(A0 * A0))):
        raise SolverError("initial fabric has non-finite entries")
    asym = max(abs(A0[0, 1] - A0[1, 0]), abs(A0[0, 2] - A0[2, 0]), abs(A0[1, 2] - A0[2, 1]))
    if asym > 1e-12 or abs(A0[0, 0] + A0[1, 1] + A0[2, 2]) > 1e-12:
        raise SolverError("initial fabric must be symmetric and traceless (Eq. 8)")
    _check_bounds(A0[None], "initial fabric")
    return A0


def _check_bounds(A: np.ndarray, what: str) -> None:
    # a traceless A has eigenvalues within +-sqrt(2/3)|A|: only larger ones need a closer look
    large = np.einsum("nij,nij->n", A, A) > 1.0 / 6.0
    if not np.any(large):
        return
    eig = np.linalg.eigvalsh(A[large])
    lo, hi = FABRIC_BOUNDS
    if eig.min() < lo - 1e-9 or eig.max() > hi + 1e-9:
        raise SolverError(
            f"{what} leaves the physical bounds of Eq. 8 (eigenvalues {eig.min():.4g}..{eig.max():.4g}, "
            f"allowed {lo:.4g}..{hi:.4g})"
        )


def _check_tolerances(rtol: float, atol: float) -> None:
    if not (math.isfinite(rtol) and MIN_RTOL <= rtol < 1.0):
        raise SolverError(f"rtol={rtol!r} cannot be honoured: use {MIN_RTOL:g} <= rtol < 1")
    if not (math.isfinite(atol) and atol > 0):
        raise SolverError(f"atol={atol!r} must be > 0")


def _output_strains(history: History, times) -> np.ndarray:
    total = history.duration * history.shear_rate
    if times is None:
        n = int(round(total / OUTPUT_STRAIN_STEP))
        return np.linspace(0.0, total, n + 1)
    times = np.atleast_1d(np.asarray(times, dtype=float))
    if times.ndim != 1 or times.size == 0:
        raise SolverError("times must be a non-empty 1-D list of strains")
    if not (times[0] >= 0 and times[-1] <= total * (1 + 1e-12) and np.all(times[1:] >= times[:-1])):
        # slow path, only to name the problem (NaN fails every comparison above)
        bad = times[~np.isfinite(times)]
        if bad.size:
            raise SolverError(f"times contains the non-finite value {float(bad[0])!r}")
        outside = times[(times < 0) | (times > total * (1 + 1e-12))]
        if outside.size:
            raise SolverError(f"time {outside[0]:g} lies outside the history's strain range [0, {total:g}]")
        raise SolverError("times must be in increasing order")
    return times


def _run(history, y0, p, strains, method, rtol, atol, s_ref, strain_step, max_steps):
    packed = history.packed
    t_out = strains / history.shear_rate
    if method == "dop853":
        lam_ref = s_ref ** p[PERSISTENCE_INDEX]
        y_out, y_end, stats = integrator.dop853(
            y0, packed.end, packed.D_unit, packed.W_unit, packed.rate, p, t_out,
            rtol, atol, lam_ref, max_steps,
        )
    elif method == "euler":
        if strain_step is None or not strain_step > 0:
            raise SolverError(f"explicit Euler needs a strain_step > 0, got {strain_step!r}")
        y_out, y_end, stats = integrator.explicit_euler(
            y0, packed.end, packed.D_unit, packed.W_unit, packed.rate, p, t_out,
            float(strain_step), history.shear_rate,
        )
    else:
        raise SolverError(f"unknown method {method!r}; expected 'dop853' or 'euler'")
    status = int(stats[3])
    if status != integrator.SUCCESS:
        raise SolverError(f"{method}: {integrator.STATUS_MESSAGES[status]} (at t*gamma_dot = "
                          f"{y_end[integrator.T_INDEX] * history.shear_rate:.6g})")
    return y_out, y_end, stats


def _assemble(history, strains, y_out, params, packing_fraction, stats, method, **extra) -> Result:
    n = y_out.shape[0]
    p = params.as_array()
    packed = history.packed
    A, Dh, tau = np.empty((n, 3, 3)), np.empty((n, 3, 3)), np.empty((n, 3, 3))
    S, w_shear, w_vol, seg = np.empty(n), np.empty(n), np.empty(n), np.empty(n, dtype=np.int64)
    t = strains / history.shear_rate
    phi = np.asarray(packing_fraction, dtype=float)
    finite, min_S, max_norm2 = integrator.outputs(
        y_out, t, packed.end, packed.D_unit, packed.rate, history.shear_rate, p, phi,
        A, Dh, seg, S, tau, w_shear, w_vol,
    )
    if not finite:
        raise SolverError(f"{method}: non-finite fabric or packing fraction in the output")
    if np.max(phi) >= PHI_MAX:
        raise SolverError(f"{method}: the packing fraction reaches {np.max(phi):.4g} at strain "
                          f"{strains[int(np.argmax(phi))]:.4g}, denser than any packing of spheres (pi/(3 sqrt 2) = "
                          f"{PHI_MAX:.4f}): the parameters (Eq. 18's c2, c3, Phi_c, or the law's) leave the physics")
    if min_S < 0:
        raise SolverError(f"{method}: negative S in the output")
    if max_norm2 > 1.0 / 6.0:
        _check_bounds(A, f"{method}: the fabric")
    return Result(
        strain=strains, t=t, A=A, tau=tau, S=S, packing_fraction=phi, D_dev=packed.D_dev[seg] / history.shear_rate,
        w_shear=w_shear, w_vol=w_vol, w_total=w_shear + w_vol, law_state=y_out[:, integrator.N_STATE:].copy(),
        nfev=int(stats[0]), nsteps=int(stats[1]), nrejected=int(stats[2]), method=method, params=params, **extra,
    )


def _params(params) -> Params:
    if params is None:
        return PAPER
    if not isinstance(params, Params):
        raise SolverError(f"params must be a model.Params, got {type(params).__name__}")
    return params


def integrate(
    history: History,
    *,
    A0=None,
    packing_fraction0: float | None = None,
    params: Params | None = None,
    times=None,
    method: str = "dop853",
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    s_ref: float = DEFAULT_S_REF,
    strain_step: float | None = None,
    max_steps: int = 1_000_000,
    law_state0=None,
) -> Result:
    """Integrate the model (Eqs. 13, 14, 18) along ``history`` from a given state.

    Parameters
    ----------
    history : the shear history (segments of constant velocity gradient).
    A0 : (3, 3) initial fabric; default isotropic (A = 0, where S = 0). With the "jump" variant, the fabric at
        the start of the first segment (its state is A0 less kappa D'/|D'|); the isotropic default is a state of 0.
    packing_fraction0 : initial Phi; default ``params.phi_c``.
    times : output strains t*gamma_dot in [0, total strain]; default every 0.005.
    method : 'dop853' (adaptive, regularised; default) or 'euler' (the paper's fixed-step baseline,
        needs ``strain_step``).
    rtol, atol : local error tolerances of 'dop853'.
    law_state0 : the fabric law's own state at the start (``Result.law_state`` of an earlier run; ``model.laws``);
        default its value where a history starts under the first segment (K = kappa D'/|D'| for "elastic").
    """
    params = _params(params)
    _check_tolerances(rtol, atol)
    p = params.as_array()
    # the law's state A is the fabric less the part the law holds beyond it where the history starts (kappa D'/|D'|
    # of "jump", K of "elastic"); an isotropic start is a state of zero, before any shear
    phi0 = params.phi_c if packing_fraction0 is None else float(packing_fraction0)
    if not (math.isfinite(phi0) and 0 < phi0 < PHI_MAX):
        raise SolverError(f"packing_fraction0={packing_fraction0!r} must lie in (0, {PHI_MAX:.4f}) (pi/(3 sqrt 2), "
                          "the densest packing of spheres)")
    part, own = _start(params, history.packed.D_unit[0], phi0)
    if law_state0 is not None:  # the law's own state given: the fabric less kappa D'/|D'| and its part is A
        own = np.asarray(law_state0, dtype=float).reshape(-1)
        if own.shape != (len(laws.state_names(params.variant)),) or not np.all(np.isfinite(own)):
            raise SolverError(f"law_state0 must be {len(laws.state_names(params.variant))} finite number(s) "
                              f"({', '.join(laws.state_names(params.variant)) or 'none for this law'})")
        part = _fabric(_initial_state(np.zeros((3, 3)), own), params, history.packed.D_unit[0])
    A0 = np.zeros((3, 3)) if A0 is None else _check_fabric(A0) - part
    strains = _output_strains(history, times)
    y0 = _initial_state(A0, own)
    laws.set_packing(y0, 1.0 / phi0, p)  # what the law holds of the packing is packing_fraction0
    y_out, _, stats = _run(history, y0, p, strains, method, rtol, atol, s_ref, strain_step, max_steps)
    phi = 1.0 / (np.exp(-y_out[:, integrator.G_INDEX]) / phi0 + y_out[:, integrator.V_INDEX])
    return _assemble(history, strains, y_out, params, phi, stats, method)


#: how still a fabric law's own state must be, chunk to chunk, for the steady state: its fast relaxation leaves
#: about 1e-12 of the integrator's round-off in it at a high shear rate
OWN_STATE_TOL = 1e-10


@functools.lru_cache(maxsize=256)
def _steady_state_cached(L_bytes: bytes, p_bytes: bytes, tol: float) -> tuple[np.ndarray, float, np.ndarray]:
    L = np.frombuffer(L_bytes).reshape(3, 3)
    p = np.frombuffer(p_bytes)
    segment = Segment(1.0 / modulus(deviator(stretching(L))), L)  # strain |D'| t = 1 per chunk
    history = History((segment,))
    name = laws.name_of(p)
    values = dict(zip(VARIANTS[name], p[laws.OWN:], strict=True))
    _, own = laws.start(name, unpack_fabric(history.packed.D_unit[0][[0, 1, 3, 4, 5]]), values, p[PHI_C])
    y = _initial_state(np.zeros((3, 3)), own)
    base = integrator.N_STATE
    for _ in range(200):
        y0 = y.copy()
        y0[integrator.T_INDEX:base] = 0.0
        _, y, _ = _run(history, y0, p, np.empty(0), "dop853", 1e-12, 1e-14, DEFAULT_S_REF, None, 1_000_000)
        # the law's own state relaxes fast and settles within the integrator's round-off, not within ``tol``
        if (np.max(np.abs(y[:5] - y0[:5])) < tol
                and np.max(np.abs(y[base:] - y0[base:]), initial=0.0) < max(tol, OWN_STATE_TOL)):
            break
    else:
        raise SolverError("no steady state reached for this velocity gradient")
    A = unpack_fabric(y[:5])
    _, _, _, _, _, _, g, c2 = fabric_rates(y, history.packed.D_unit[0], np.zeros(3), p)
    return A, g / c2, y[base:].copy()  # du/dt = 0 in Eq. 18 with u = 1/Phi: Phi = g / c2


def steady_state(L, params: Params | None = None, tol: float = 1e-13) -> tuple[np.ndarray, float]:
    """Steady fabric A and packing fraction Phi under a constant velocity gradient L.

    Found by integrating from the isotropic state until A (and the fabric law's own state) changes by less than
    ``tol`` over a strain |D'| t = 1; Phi then solves Eq. 18 with Phi_dot = 0.
    """
    params = _params(params)
    A, phi, own = _steady_state(L, params, tol)
    L = np.ascontiguousarray(L, dtype=float)
    state = _initial_state(A, own)
    return _fabric(state, params, History((Segment(1.0, L),)).packed.D_unit[0]), phi


def _steady_state(L, params: Params, tol: float = 1e-13) -> tuple[np.ndarray, float, np.ndarray]:
    """The steady state (the model's state A: the fabric less the part the law holds beyond it), Phi and the law's
    own state."""
    L = np.ascontiguousarray(L, dtype=float)
    A, phi, own = _steady_state_cached(L.tobytes(), params.as_array().tobytes(), tol)
    return A.copy(), phi, own.copy()


def reversal_start_rate(params: Params | None = None) -> float:
    """a1 + a2 |A| (Eq. 13 at S = 0, times Lambda/|D'|): the rate at which the fabric's component along the new
    D' changes right after an instantaneous reversal of steady simple shear, where A = |A| D'/|D'| and S = 0.
    Negative: the fabric turns towards its new steady state. Positive: it starts by growing along its old
    direction, S stays near 0 where Lambda = S^k vanishes, and the model's own reversal can run away (Table 2:
    +3e-5, on the edge)."""
    params = _params(params)
    A, _, _ = _steady_state(shear_velocity_gradient(0.0), params)
    return float(params.a1 + params.a2 * modulus(A))


def periodic(
    history: History,
    *,
    params: Params | None = None,
    times=None,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    cycle_tol: float = DEFAULT_CYCLE_TOL,
    max_periods: int = 100,
    s_ref: float = DEFAULT_S_REF,
) -> Result:
    """The periodic solution of a history repeated forever (paper Sec. 4: start = end of a period).

    The fabric is iterated period by period, starting from the steady state of the last segment,
    until max |A(T) - A(0)| < ``cycle_tol``; the reported cycle is one more period from there. The
    packing fraction follows in closed form: 1/Phi obeys a linear ODE (Eq. 18), so its periodic
    initial value is v(T) / (1 - exp(-G(T))) without iterating.
    """
    params = _params(params)
    _check_tolerances(rtol, atol)
    if not (math.isfinite(cycle_tol) and cycle_tol > 0):
        raise SolverError(f"cycle_tol={cycle_tol!r} must be > 0")
    strains = _output_strains(history, times)
    try:
        return _periodic(history, params, strains, rtol, atol, cycle_tol, max_periods, s_ref)
    except SolverError as exc:
        raise SolverError(f"{exc}{_off_table2(params)}") from None


def _packing_suspect(y_out: np.ndarray, history: History, params: Params) -> str:
    """Why Phi may leave (0, 1): the fabric running away (it drives Eq. 18 through c1 A:D'), else phi_c and c3."""
    steady = modulus(steady_state(history.segments[-1].L, params)[0])
    peak = float(np.max(modulus(unpack_fabric(y_out[:, :5]))))
    if peak > 1.5 * steady:
        return (f"the fabric grows to {peak / steady:.2g} times its steady |A| = {steady:.3g} (after a reversal "
                f"a1 + a2 |A| = {reversal_start_rate(params):+.3g}: positive, it grows along its old direction), "
                f"so check the fabric law")
    return (f"Eq. 18 relaxes Phi towards about Phi_c + c3 = {params.phi_c + params.c3:.3g}, so check phi_c "
            f"and c3")


def _off_table2(params: Params) -> str:
    """The parameters that differ from Table 2, for a failure's message: the suspects."""
    changed = [f"{name} = {value:+.4g}" if isinstance(value, float) else f"{name} = {value}"
               for name, value in params.to_dict().items()
               if name not in PAPER.to_dict() or value != getattr(PAPER, name)]
    return f" (parameters off Table 2: {', '.join(changed)})" if changed else ""


def _periodic(history, params, strains, rtol, atol, cycle_tol, max_periods, s_ref) -> Result:
    p = params.as_array()
    A_start, _, own = _steady_state(history.segments[-1].L, params)
    base = integrator.N_STATE
    residual = math.inf
    no_output = np.empty(0)
    nfev = nsteps = nrejected = periods = 0
    while periods < max_periods:
        # iterate without outputs; the converged start is then integrated once more with them
        periods += 1
        y0 = _initial_state(A_start, own)
        _, y_end, stats = _run(history, y0, p, no_output, "dop853", rtol, atol, s_ref, None, 1_000_000)
        nfev, nsteps, nrejected = nfev + stats[0], nsteps + stats[1], nrejected + stats[2]
        residual = float(max(np.max(np.abs(y_end[:5] - y0[:5])), np.max(np.abs(y_end[base:] - y0[base:]),
                                                                           initial=0.0)))
        A_start, own = unpack_fabric(y_end[:5]), y_end[base:].copy()
        if residual < cycle_tol:
            break
    if not residual < cycle_tol:
        raise SolverError(f"the cycle did not converge in {max_periods} periods (residual {residual:.3g} "
                          f"> cycle_tol {cycle_tol:g})")
    y0 = _initial_state(A_start, own)
    y_out, y_end, stats = _run(history, y0, p, strains, "dop853", rtol, atol, s_ref, None, 1_000_000)
    nfev, nsteps, nrejected = nfev + stats[0], nsteps + stats[1], nrejected + stats[2]
    periods += 1
    contraction = math.exp(-y_end[integrator.G_INDEX])
    u0 = y_end[integrator.V_INDEX] / (1.0 - contraction)
    phi = 1.0 / (np.exp(-y_out[:, integrator.G_INDEX]) * u0 + y_out[:, integrator.V_INDEX])
    if not np.all((phi > 0) & (phi < 1)):
        raise SolverError(f"the packing fraction leaves (0, 1) over the cycle (Phi from {np.min(phi):.3g} to "
                          f"{np.max(phi):.3g}): {_packing_suspect(y_out, history, params)}")
    stats = np.array([nfev, nsteps, nrejected])
    return _assemble(history, strains, y_out, params, phi, stats, "dop853", periods=periods,
                     cycle_residual=residual, phi_contraction=contraction)


def predict(
    theta_deg: float,
    *,
    rotate_at: float = ROTATE_AT_STRAIN,
    params: Params | None = None,
    times=None,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    cycle_tol: float = DEFAULT_CYCLE_TOL,
) -> Result:
    """Converged periodic cycle of the paper's protocol (Fig. 1; Fig. 7 with ``rotate_at``).

    phi = 0 for 0 <= t*gamma_dot < rotate_at, phi = theta_deg up to the period 1.4; ``times`` are
    strains from the start of a period (default every 0.005 from 0 to 1.4).
    """
    history = periodic_cycle(theta_deg, rotate_at=rotate_at)
    return periodic(history, params=params, times=times, rtol=rtol, atol=atol, cycle_tol=cycle_tol)
