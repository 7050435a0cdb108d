"""The material-point update for continuum codes: N points, one step of constant velocity gradient each.

``update(A, phi, L, dt)`` advances the fabric (Eq. 13, Jaumann rate) and the packing fraction (Eq. 18)
of every point over a step dt under its velocity gradient L, as ``model.integrate`` does for one point
(the same equations and regularised variable s through S -> 0; the steps in ``model.stepper``), and
returns tau/p of Eq. 14 at the end of the step. The model is rate independent: only the strain of the
step, |D'| dt, and the directions of D' and W matter, not dt itself.

A point with D' = 0 (|D'| <= 1e-12 |L|, round-off) is *stationary*: Eqs. 13 and 18 leave its packing
fraction unchanged and its fabric co-rotating with the spin (A -> R A R^T, R = exp(W dt); unchanged
when W = 0 too), and the flow rule does not define tau/p there (the direction D'/|D'| is undefined),
so tau/p and S are NaN and ``Update.stationary`` says so.
"""

from __future__ import annotations

import math
import numbers
import threading
from dataclasses import dataclass

import numba
import numpy as np

from . import integrator, laws, stepper
from .equations import K_PERSIST, PHI_MAX, fabric_within_bounds, hardening_variable, yield_function
from .equations import C as C_INDEX
from .jit import jit
from .params import Params
from .solver import DEFAULT_S_REF, Result, SolverError, _fabric, _initial_state, _params

DEFAULT_RTOL = 1e-9  # per step: A, Phi and tau/p within 1e-6 of ``model.predict`` over whole cycles
DEFAULT_ATOL = 1e-11
FABRIC_TOL = 1e-8  # allowed asymmetry and trace of an input fabric (absolute)
ROUNDOFF_STRETCHING = 1e-12  # |D'| up to this fraction of |L| is round-off: the point is stationary
MAX_STEPS = 100_000  # integrator steps per point and update
BOUNDS_SLACK = 1e-9  # round-off allowed beyond Eq. 8's eigenvalue bounds, as in ``model.predict``
_BAD_A, _BAD_SYM, _BAD_TRACE, _BAD_PHI, _BAD_L, _BAD_DT, _BAD_BOUNDS, _BAD_STEP = range(1, 9)
#: the largest strain |D'| dt of one step: far past any transient (the fabric is steady within a strain of about 1),
#: and below where the integrator's substeps run out (a strain of about 10^5 at the default tolerances)
MAX_STEP_STRAIN = 1e4
#: what a point's step may end in besides ``model.integrator``'s statuses: a state outside the physics
TOO_DENSE, FABRIC_OUT_OF_BOUNDS = 101, 102
OUTCOMES = {**integrator.STATUS_MESSAGES,
            TOO_DENSE: f"the packing fraction would reach or pass pi/(3 sqrt 2) = {PHI_MAX:.4f}, denser than any "
                       "packing of spheres (Eq. 18's c2, c3, Phi_c or the law's parameters leave the physics)",
            FABRIC_OUT_OF_BOUNDS: "the fabric would leave the bounds of Eq. 8 (eigenvalues within -1/3..2/3)"}
_PROBLEMS = {
    _BAD_A: "A[{i}] has non-finite entries",
    _BAD_SYM: "A[{i}] is not symmetric (asymmetry {value:.3g} > fabric_tol)",
    _BAD_TRACE: "A[{i}] is not traceless (trace {value:.3g} > fabric_tol)",
    _BAD_PHI: f"phi[{{i}}]={{value!r}} must lie in (0, {PHI_MAX:.4f}) (pi/(3 sqrt 2), the densest packing of spheres)",
    _BAD_L: "L[{i}] is not finite or too large: the sum of its squared entries is {value:.3g}",
    _BAD_DT: "dt[{i}]={value!r} must be finite and >= 0",
    _BAD_BOUNDS: "A[{i}] leaves the bounds of Eq. 8 (eigenvalues within -1/3..2/3; |A|^2 = {value:.4g})",
    _BAD_STEP: f"dt[{{i}}] makes a step of strain |D'| dt = {{value:.3g}}, beyond {MAX_STEP_STRAIN:g}: split the step",
}


@dataclass
class Update:
    """State after a step, per point: ``A`` (N, 3, 3) fabric (the fabric law's state: the fabric less the part the
    law holds beyond it, kappa D'/|D'| of "jump", K of "elastic"); ``phi`` (N,) packing fraction; ``tau_over_p``
    (N, 3, 3) tau/p of Eq. 14 (tension positive); ``S`` (N,) hardening variable of Eq. 10 (both NaN where
    ``stationary``); ``substeps`` (N,) integrator steps taken (accepted and rejected); ``stationary`` (N,)
    D' = 0 over the step; ``law_state`` (N, k) the fabric law's own state (``model.laws``; k = 0 for most laws)."""

    A: np.ndarray
    phi: np.ndarray
    tau_over_p: np.ndarray
    S: np.ndarray
    substeps: np.ndarray
    stationary: np.ndarray
    law_state: np.ndarray = None

    def __post_init__(self):
        if self.law_state is None:
            self.law_state = np.empty((self.phi.shape[0], 0))

    @classmethod
    def empty(cls, n: int, params: Params | None = None) -> Update:
        """Arrays for ``n`` points (and the fabric law of ``params``), to pass as ``out`` and reuse step after
        step."""
        own = len(laws.state_names(_params(params).variant))
        return cls(np.empty((n, 3, 3)), np.empty(n), np.empty((n, 3, 3)), np.empty(n),
                   np.empty(n, dtype=np.int64), np.empty(n, dtype=np.bool_), np.empty((n, own)))

    def __len__(self) -> int:
        return self.phi.shape[0]


@jit
def _check_inputs(A, phi, L, dt, fabric_tol):
    """(problem code, point, value) of the first bad input; code 0 when all are good."""
    for i in range(A.shape[0]):
        a = A[i]
        total = 0.0
        for j in range(3):
            for k in range(3):
                total += a[j, k]
        if not math.isfinite(total):
            return _BAD_A, i, total
        asym = max(abs(a[0, 1] - a[1, 0]), abs(a[0, 2] - a[2, 0]), abs(a[1, 2] - a[2, 1]))
        if asym > fabric_tol:
            return _BAD_SYM, i, asym
        trace = a[0, 0] + a[1, 1] + a[2, 2]
        if abs(trace) > fabric_tol:
            return _BAD_TRACE, i, trace
        if not fabric_within_bounds(a[0, 0], a[1, 1], 0.5 * (a[0, 1] + a[1, 0]), 0.5 * (a[0, 2] + a[2, 0]),
                                    0.5 * (a[1, 2] + a[2, 1]), BOUNDS_SLACK):
            norm2 = 0.0
            for j in range(3):
                for k in range(3):
                    norm2 += a[j, k] * a[j, k]
            return _BAD_BOUNDS, i, norm2
        if not 0.0 < phi[i] < PHI_MAX:
            return _BAD_PHI, i, phi[i]
    for i in range(L.shape[0]):
        total = 0.0
        for j in range(3):
            for k in range(3):
                total += L[i, j, k] * L[i, j, k]  # overflows where |L| is too large to integrate
        if not math.isfinite(total):
            return _BAD_L, i, total
    for i in range(dt.shape[0]):
        if not (math.isfinite(dt[i]) and dt[i] >= 0.0):
            return _BAD_DT, i, dt[i]
    for i in range(max(L.shape[0], dt.shape[0])):
        grad, d = L[i if L.shape[0] > 1 else 0], dt[i if dt.shape[0] > 1 else 0]
        trace = (grad[0, 0] + grad[1, 1] + grad[2, 2]) / 3.0
        norm2 = 0.0
        for j in range(3):
            for k in range(3):
                dev = 0.5 * (grad[j, k] + grad[k, j]) - (trace if j == k else 0.0)
                norm2 += dev * dev
        if math.sqrt(norm2) * d > MAX_STEP_STRAIN:
            return _BAD_STEP, i, math.sqrt(norm2) * d
    return 0, 0, 0.0


@jit
def _co_rotate(a, w12, w13, w23, dt, k, r, out):
    """out = R a R^T with R = exp(W dt) (Rodrigues), W = [[0, w12, w13], [-w12, 0, w23], [-w13, -w23, 0]];
    k and r are 3x3 scratch."""
    theta = math.sqrt(w12 * w12 + w13 * w13 + w23 * w23) * dt
    s1 = 1.0 if theta == 0.0 else math.sin(theta) / theta
    s2 = 0.5 if theta == 0.0 else (1.0 - math.cos(theta)) / (theta * theta)
    k[0, 0], k[0, 1], k[0, 2] = 0.0, w12 * dt, w13 * dt
    k[1, 0], k[1, 1], k[1, 2] = -w12 * dt, 0.0, w23 * dt
    k[2, 0], k[2, 1], k[2, 2] = -w13 * dt, -w23 * dt, 0.0
    for i in range(3):
        for j in range(3):
            kk = 0.0
            for m in range(3):
                kk += k[i, m] * k[m, j]
            r[i, j] = (1.0 if i == j else 0.0) + s1 * k[i, j] + s2 * kk
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for m in range(3):
                for q in range(3):
                    acc += r[i, m] * a[m, q] * r[j, q]
            out[i, j] = acc


@jit
def _write_state(y, Dh, p, A_out, tau_out):
    """The packed state y into A_out (3, 3), tau/p of Eq. 14 into tau_out (on the fabric y + kappa Dh, kappa the law's
    offset); returns S (Eq. 10) of the state."""
    a11, a22, a12, a13, a23 = y[0], y[1], y[2], y[3], y[4]
    a33 = -a11 - a22
    A_out[0, 0], A_out[1, 1], A_out[2, 2] = a11, a22, a33
    A_out[0, 1] = A_out[1, 0] = a12
    A_out[0, 2] = A_out[2, 0] = a13
    A_out[1, 2] = A_out[2, 1] = a23
    S = hardening_variable(a11, a22, a12, a13, a23, Dh[0], Dh[1], Dh[2], Dh[3], Dh[4], Dh[5])
    Y = yield_function(S, p)
    c = p[C_INDEX]  # Eq. 14: tau/p = C A + Y(S) D'/|D'|
    Y += c * laws.offset(p)  # C (A + kappa Dh) + Y Dh, kappa the law's offset (model.laws)
    if y.shape[0] > integrator.N_STATE:  # C (A + K) + Y Dh, K the part of the fabric the law's own state holds
        k11, k22, k12, k13, k23 = laws.state_fabric(y, p)
        a11, a22, a33, a12, a13, a23 = a11 + k11, a22 + k22, a33 - k11 - k22, a12 + k12, a13 + k13, a23 + k23
    tau_out[0, 0] = c * a11 + Y * Dh[0]
    tau_out[1, 1] = c * a22 + Y * Dh[1]
    tau_out[2, 2] = c * a33 + Y * Dh[2]
    tau_out[0, 1] = tau_out[1, 0] = c * a12 + Y * Dh[3]
    tau_out[0, 2] = tau_out[2, 0] = c * a13 + Y * Dh[4]
    tau_out[1, 2] = tau_out[2, 1] = c * a23 + Y * Dh[5]
    return S


@jit
def _update_range(start, stop, A, phi, X, L, dt, p, lam_ref, rtol, atol, scale,
                  A_out, phi_out, X_out, tau_out, S_out, steps_out, stationary_out):
    """Points start..stop-1; returns (failures, first failing point, its status). A failing point keeps
    its input state. Scratch is allocated once per call, not per point; ``A_out`` may be ``A``, ``X_out`` ``X``
    (the fabric law's own state per point, (N, k); k = 0 for most laws)."""
    n_own = X.shape[1]
    y = np.empty(integrator.N_STATE + n_own)
    work = np.empty((stepper.WORK_ROWS, integrator.N_STATE + n_own))
    Dh = np.empty(6)
    Wn = np.empty(3)
    rotation = np.empty((3, 3, 3))  # the co-rotated fabric and two scratch matrices
    failures = 0
    first_failure = -1
    first_status = 0
    for i in range(start, stop):
        li = L[i if L.shape[0] > 1 else 0]
        dti = dt[i if dt.shape[0] > 1 else 0]
        a = A[i]
        trace = (li[0, 0] + li[1, 1] + li[2, 2]) / 3.0
        d11, d22, d33 = li[0, 0] - trace, li[1, 1] - trace, li[2, 2] - trace
        d12 = 0.5 * (li[0, 1] + li[1, 0])
        d13 = 0.5 * (li[0, 2] + li[2, 0])
        d23 = 0.5 * (li[1, 2] + li[2, 1])
        w12 = 0.5 * (li[0, 1] - li[1, 0])
        w13 = 0.5 * (li[0, 2] - li[2, 0])
        w23 = 0.5 * (li[1, 2] - li[2, 1])
        rate = math.sqrt(d11 * d11 + d22 * d22 + d33 * d33 + 2.0 * (d12 * d12 + d13 * d13 + d23 * d23))
        size = 0.0
        for j in range(3):
            for k in range(3):
                size += li[j, k] * li[j, k]
        if rate <= ROUNDOFF_STRETCHING * math.sqrt(size):
            # D' = 0: Phi fixed, A co-rotates with the spin (Eq. 13 with a vanishing right-hand side)
            _co_rotate(a, w12, w13, w23, dti, rotation[1], rotation[2], rotation[0])
            for j in range(3):
                for k in range(3):
                    A_out[i, j, k] = rotation[0, j, k]
                    tau_out[i, j, k] = math.nan
            phi_out[i] = phi[i]
            S_out[i] = math.nan
            steps_out[i] = 0
            stationary_out[i] = True
            for j in range(n_own):  # the law's own state is held
                X_out[i, j] = X[i, j]
            continue
        Dh[0], Dh[1], Dh[2] = d11 / rate, d22 / rate, d33 / rate
        Dh[3], Dh[4], Dh[5] = d12 / rate, d13 / rate, d23 / rate
        Wn[0], Wn[1], Wn[2] = w12 / rate, w13 / rate, w23 / rate
        y[0], y[1] = a[0, 0], a[1, 1]
        y[2] = 0.5 * (a[0, 1] + a[1, 0])
        y[3] = 0.5 * (a[0, 2] + a[2, 0])
        y[4] = 0.5 * (a[1, 2] + a[2, 1])
        y[integrator.T_INDEX] = 0.0
        y[integrator.G_INDEX] = 0.0
        y[integrator.V_INDEX] = 0.0
        for j in range(n_own):
            y[integrator.N_STATE + j] = X[i, j]
        laws.set_packing(y, 1.0 / phi[i], p)  # what the law holds of the packing is the point's phi
        steps, status = stepper.advance(y, Dh, Wn, rate, p, lam_ref, dti, rtol, atol, scale, MAX_STEPS, work)
        steps_out[i] = steps
        stationary_out[i] = False
        # Eq. 18 in closed form: 1/Phi(dt) = exp(-G)/Phi(0) + v (see model.integrator)
        phi_new = 1.0 / (math.exp(-y[integrator.G_INDEX]) / phi[i] + y[integrator.V_INDEX])
        if status == integrator.SUCCESS and not 0.0 < phi_new < PHI_MAX:
            status = TOO_DENSE
        if status == integrator.SUCCESS and not fabric_within_bounds(y[0], y[1], y[2], y[3], y[4], BOUNDS_SLACK):
            status = FABRIC_OUT_OF_BOUNDS
        if status != integrator.SUCCESS:
            failures += 1
            if first_failure < 0:
                first_failure, first_status = i, status
            for j in range(3):
                for k in range(3):
                    tau_out[i, j, k] = math.nan
            S_out[i] = math.nan
            continue  # A_out[i] and phi_out[i] are left alone: the input state, when out is the input
        phi_out[i] = phi_new
        for j in range(n_own):
            X_out[i, j] = y[integrator.N_STATE + j]
        S_out[i] = _write_state(y, Dh, p, A_out[i], tau_out[i])
    return failures, first_failure, first_status


@jit
def _update_serial(A, phi, X, L, dt, p, lam_ref, rtol, atol, scale, A_out, phi_out, X_out, tau_out, S_out,
                   steps_out, stationary_out):
    return _update_range(0, A.shape[0], A, phi, X, L, dt, p, lam_ref, rtol, atol, scale,
                         A_out, phi_out, X_out, tau_out, S_out, steps_out, stationary_out)


CHUNK = 256  # points per parallel task
#: held while numba's pool runs an update: numba's "workqueue" layer (where neither TBB nor OpenMP is installed)
#: aborts the process when two Python threads enter a parallel kernel at once, so parallel updates take turns
_POOL = threading.Lock()


@numba.njit(parallel=True, cache=True, nogil=True, error_model="numpy")
def _update_parallel(A, phi, X, L, dt, p, lam_ref, rtol, atol, scale, A_out, phi_out, X_out, tau_out, S_out,
                     steps_out, stationary_out):
    n = A.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    failures = np.zeros(n_chunks, dtype=np.int64)
    first = np.full(n_chunks, -1, dtype=np.int64)
    status = np.zeros(n_chunks, dtype=np.int64)
    for c in numba.prange(n_chunks):
        failures[c], first[c], status[c] = _update_range(
            c * CHUNK, min(n, (c + 1) * CHUNK), A, phi, X, L, dt, p, lam_ref, rtol, atol, scale,
            A_out, phi_out, X_out, tau_out, S_out, steps_out, stationary_out)
    total = 0
    first_failure, first_status = -1, 0
    for c in range(n_chunks):
        total += failures[c]
        if first_failure < 0 and first[c] >= 0:
            first_failure, first_status = first[c], status[c]
    return total, first_failure, first_status


def _array(name: str, value, shapes: tuple[tuple, ...]) -> np.ndarray:
    """``value`` as a read-only C-contiguous float array of one of ``shapes`` (one layout, so the kernels
    compile once whatever the caller hands them); a one-line error otherwise."""
    if np.iscomplexobj(value):
        raise SolverError(f"{name} is complex: the model takes real numbers (its imaginary part would be dropped)")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SolverError(f"{name} must be an array of numbers, got {type(value).__name__}") from None
    if array.shape not in shapes:
        wanted = " or ".join(str(s) for s in shapes)
        raise SolverError(f"{name} has shape {array.shape}, expected {wanted}")
    view = np.ascontiguousarray(array).view()
    view.flags.writeable = False
    return view


#: every array of an ``Update``
OUTPUTS = ("A", "phi", "tau_over_p", "S", "substeps", "stationary", "law_state")


def _out(out, n: int, params: Params) -> Update:
    if out is None:
        return Update.empty(n, params)
    if not isinstance(out, Update):
        raise SolverError(f"out must be a model.Update (see Update.empty), got {type(out).__name__}")
    expected = Update.empty(0, params)
    for name in OUTPUTS:
        array, like = getattr(out, name), getattr(expected, name)
        if (not isinstance(array, np.ndarray) or array.shape != (n,) + like.shape[1:] or array.dtype != like.dtype
                or not array.flags.c_contiguous or not array.flags.writeable):
            raise SolverError(f"out.{name} must be a writable C-contiguous {like.dtype} array of shape "
                              f"{(n,) + like.shape[1:]}")
    return out


#: the outputs that may be their input itself, for an update in place
IN_PLACE = {("A", "A"), ("phi", "phi"), ("law_state", "law_state")}


def _check_overlaps(inputs: dict, out: Update) -> None:
    """No two outputs share memory, and no output shares memory with an input, but ``out.A`` and ``out.phi`` each
    with its own input when it is that very array: the kernels read a point's input after writing other points'
    outputs, so an overlap would return wrong numbers without a word."""
    outs = {name: getattr(out, name) for name in OUTPUTS if getattr(out, name).size}
    names = list(outs)
    for k, a in enumerate(names):
        for b in names[k + 1:]:
            if np.may_share_memory(outs[a], outs[b]):
                raise SolverError(f"out.{a} and out.{b} share memory: give each output an array of its own")
        for name, given in inputs.items():
            same = (a, name) in IN_PLACE and _same_memory(outs[a], given)
            if not same and np.may_share_memory(outs[a], given):
                raise SolverError(f"out.{a} overlaps the input {name}" + (" without being it (an update in place "
                                  f"passes {name} itself)" if (a, name) in IN_PLACE else ""))


def _same_memory(a: np.ndarray, b: np.ndarray) -> bool:
    return (a.__array_interface__["data"][0] == b.__array_interface__["data"][0] and a.shape == b.shape
            and a.strides == b.strides)


def _law_state(law_state, params: Params, L: np.ndarray, phi: np.ndarray, n: int) -> np.ndarray:
    """The fabric law's own state per point, (n, k): as given, checked, or where a history starts under each
    point's L at its packing fraction."""
    own = len(laws.state_names(params.variant))
    if law_state is not None and own:
        X = _array("law_state", law_state, ((n, own),))
        if not np.all(np.isfinite(X)):
            raise SolverError(f"law_state[{int(np.argmin(np.isfinite(X).all(axis=1)))}] is not finite")
        names = laws.state_names(params.variant)
        for k, (low, high) in enumerate(laws.state_bounds(params.variant)):
            outside = (X[:, k] < low) | (X[:, k] > high)
            if outside.any():
                i = int(np.argmax(outside))
                raise SolverError(f"law_state[{i}] has {names[k]}={float(X[i, k])!r} outside [{low:.4g}, "
                                  f"{high:.4g}], the bounds the {params.variant} law declares")
        return X
    if not own:
        return _array("law_state", np.empty((n, 0)), ((n, 0),))
    D = 0.5 * (L + np.swapaxes(L, 1, 2))
    D = D - np.trace(D, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3
    norm = np.sqrt(np.sum(D * D, axis=(1, 2)))[:, None, None]
    scale = np.sqrt(np.sum(L * L, axis=(1, 2)))[:, None, None]  # a stationary point's D' is round-off: no direction
    Dh = np.divide(D, norm, out=np.zeros_like(D), where=norm > ROUNDOFF_STRETCHING * scale)
    _, X = laws.start(params.variant, Dh, params.law_dict(), phi)
    return _array("law_state", np.broadcast_to(X, (n, own)), ((n, own),))  # the layout of a given one


def update_inputs(result: Result, params: Params | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, phi, law_state) at each output of ``model.predict`` or ``model.integrate`` (``result``, run with
    ``params``) as ``update`` takes them: the fabric less the part the law holds beyond it under the acting D'
    (``Result.D_dev``; kappa D'/|D'| of "jump", K of "elastic"), the packing fraction and the law's own state. A
    result made with other parameters than ``params`` (default Table 2) is refused in one line."""
    if not isinstance(result, Result):
        raise SolverError(f"update_inputs takes a model.Result (of model.predict or model.integrate), got "
                          f"{type(result).__name__}")
    params = _params(params)
    if result.params is not None and result.params != params:
        raise SolverError(f"the result was made with other parameters ({result.params.variant}) than those given "
                          f"({params.variant}): pass update_inputs(result, params=<the params of the run>)")
    own = result.law_state if result.law_state is not None else np.empty((len(result.strain), 0))
    if own.shape[1] != len(laws.state_names(params.variant)):
        raise SolverError(f"the result carries {own.shape[1]} law state variables, {params.variant!r} has "
                          f"{len(laws.state_names(params.variant))}: it was not made with these params")
    D = np.asarray(result.D_dev, dtype=float)
    norm = np.sqrt(np.sum(D * D, axis=(1, 2)))[:, None, None]
    Dh = np.divide(D, norm, out=np.zeros_like(D), where=norm > 0)
    packed = Dh[:, [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]  # 11, 22, 33, 12, 13, 23
    held = np.array([_fabric(_initial_state(np.zeros((3, 3)), x), params, d) for x, d in zip(own, packed, strict=True)])
    return result.A - held, np.array(result.packing_fraction, dtype=float), np.array(own, dtype=float)


def update(A, phi, L, dt, params: Params | None = None, out: Update | None = None, *, law_state=None,
           rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL, s_ref: float = DEFAULT_S_REF,
           fabric_tol: float = FABRIC_TOL, threads: int = 1) -> Update:
    """Advance N material points over one step of constant velocity gradient (Eqs. 13, 14, 18).

    Parameters
    ----------
    A : (N, 3, 3) fabric at the start of the step, symmetric and traceless within ``fabric_tol``
        (it is symmetrised and its trace dropped).
    phi : (N,) packing fraction at the start of the step, in (0, 1).
    L : (N, 3, 3) or (3, 3) velocity gradient dv_i/dx_j over the step (1/time), constant in the step.
    dt : float or (N,) step duration (time, >= 0); the step's strain is |D'| dt (``model.kinematics``).
    params : model.Params (default Table 2).
    out : an ``Update`` to fill (``Update.empty(N, params)``); ``out.A``, ``out.phi`` and ``out.law_state`` may be
        the inputs themselves, for an update in place.
    law_state : (N, k) the fabric law's own state at the start of the step (``Update.law_state`` of the step
        before; ``model.laws``); default, for a law that has one, its value where a history starts under each
        point's L (for "elastic": K = kappa D'/|D'|). Ignored by a law without (k = 0).
    rtol, atol, s_ref : per-step tolerances and regularisation of the integrator
        (``model.stepper``); see docs/model.md for their cost against accuracy.
    threads : 1 (default) or more: points are shared among that many numba threads; safe from several Python
        threads at once under every threading layer numba may pick (updates on the pool take turns).

    Returns the ``Update``. Raises ``SolverError`` on bad input (one line, naming the first bad point)
    before any work, and after the step if a point could not be integrated or would leave the physics (Phi at or
    above pi/(3 sqrt 2), the densest packing of spheres; A outside Eq. 8's bounds), as ``model.predict`` does
    (those points keep their start state).
    """
    params = _params(params)
    p = params.as_array()
    if not (np.ndim(A) == 3 and np.shape(A)[0] > 0 and np.shape(A)[1:] == (3, 3)):
        raise SolverError(f"A has shape {np.shape(A)}, expected (N, 3, 3) with N >= 1")
    A = _array("A", A, (np.shape(A),))
    n = A.shape[0]
    phi = _array("phi", phi, ((n,),))
    L = _array("L", L, ((3, 3), (n, 3, 3))).reshape(-1, 3, 3)
    dt = _array("dt", dt, ((), (n,))).reshape(-1)
    for name, value in (("rtol", rtol), ("atol", atol), ("s_ref", s_ref), ("fabric_tol", fabric_tol)):
        if not (isinstance(value, numbers.Real) and not isinstance(value, bool) and 0 < value < 1):
            raise SolverError(f"{name}={value!r} must be a number in (0, 1)")
    rtol, atol, s_ref, fabric_tol = float(rtol), float(atol), float(s_ref), float(fabric_tol)
    if not (isinstance(threads, numbers.Integral) and not isinstance(threads, bool)
            and 1 <= threads <= numba.config.NUMBA_NUM_THREADS):
        raise SolverError(f"threads={threads!r} must be an integer in 1..{numba.config.NUMBA_NUM_THREADS}")
    threads = int(threads)
    code, index, value = _check_inputs(A, phi, L, dt, fabric_tol)
    if code:
        raise SolverError(_PROBLEMS[code].format(i=index, value=float(value)))
    X = _law_state(law_state, params, L, phi, n)
    out = _out(out, n, params)
    _check_overlaps({"A": A, "phi": phi, "L": L, "dt": dt, "law_state": X}, out)
    lam_ref = s_ref ** p[K_PERSIST]
    scale = np.concatenate([np.ones(integrator.N_STATE), laws.state_tolerance(params.variant)])
    arrays = (out.A, out.phi, out.law_state, out.tau_over_p, out.S, out.substeps, out.stationary)
    if threads == 1 and (n < CHUNK or threading.current_thread() is not threading.main_thread()):
        # a few points, or a caller's own thread (numba's workqueue pool takes one caller at a time): no pool
        failures, first, status = _update_serial(A, phi, X, L, dt, p, lam_ref, rtol, atol, scale, *arrays)
    else:  # the pool's kernel, on one thread too: compiled as a parallel loop it runs about 15 % faster per thread
        with _POOL:
            previous = numba.get_num_threads()
            numba.set_num_threads(threads)
            try:
                failures, first, status = _update_parallel(A, phi, X, L, dt, p, lam_ref, rtol, atol, scale, *arrays)
            finally:
                numba.set_num_threads(previous)
    if failures:
        raise SolverError(f"update failed at {failures} point(s), first at point {first}: {OUTCOMES[int(status)]}")
    return out

