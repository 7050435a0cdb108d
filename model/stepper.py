"""The integrator of the material-point update (``model.update``): one point, one constant L, no outputs.

Each call advances one point's packed state (``model.integrator``'s layout) under one constant
velocity gradient to a given time. A continuum code's step spans a small strain, so there are two paths:

1. Where Lambda(S) >= Lambda_ref at the start, the whole interval is tried as one Cash-Karp 5(4)
   step in the strain |D'| t itself (``_direct``: six evaluations, lands on the end exactly),
   accepted if its embedded error estimate passes. Most updates end here.
2. Otherwise, or if that step fails, Dormand-Prince 5(4) in the regularised variable s of
   ``model.integrator`` (dt/ds = Lambda/((Lambda + Lambda_ref)|D'|), so the rates stay bounded
   through S -> 0), with step-size control. Each step aims ``OVERSHOOT`` past the end in t and the end
   state comes from the step's fourth-order interpolant; unless the end lies near the step's end,
   the interpolant's residual in the ODE there must pass the error norm (the defect check of
   ``model.integrator``), otherwise the step is retaken shorter.

For a law whose state holds a part K of the fabric that relaxes over a small strain (``laws.relaxing_part``),
Eq. 18's integral of g is carried as H = G + c1 K:Dh / c, whose rate has no part of that relaxation (``_rhs``), and
each state variable's tolerance is scaled by the law's ``STATE_TOLERANCE``.

Nothing is allocated: the caller passes the scratch. Coefficients: Cash & Karp (1990); scipy's
RK45 (Dormand & Prince 1980, dense output of Shampine 1986).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate._ivp.rk import RK45

from . import laws
from .equations import C1, hardening_variable, jit, persistence
from .integrator import G_INDEX, NOT_FINITE, STEP_UNDERFLOW, SUCCESS, T_INDEX, TOO_MANY_STEPS, _rhs_s, _stage_state
from .jit import inline

OVERSHOOT = 1.02  # a step aims this far past the end in t; most updates then take one step
NEAR_END = 0.9  # an end this close to the step's end is taken from the interpolant without a defect check
DP_A = np.ascontiguousarray(RK45.A)  # (6, 5)
DP_B = np.ascontiguousarray(RK45.B)  # (6,)
DP_E = np.ascontiguousarray(RK45.E)  # (7,) error weights, FSAL stage last
DP_P = np.ascontiguousarray(RK45.P)  # (7, 4) dense output: y(x) = y + h K^T P (x, x^2, x^3, x^4)
N_K = DP_E.shape[0]
N_DENSE = DP_P.shape[1]
#: rows of an ``advance`` workspace: the 7 stages, the 4 interpolation rows Q, y_new, ytmp, f0
WORK_ROWS = N_K + N_DENSE + 3
# Cash & Karp (1990) 5(4), six stages without first-same-as-last: the one-step path (``_direct``),
# which needs no interpolant, takes one evaluation fewer than DP5
CK_A = np.array([
    [0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0],
    [3 / 10, -9 / 10, 6 / 5, 0, 0],
    [-11 / 54, 5 / 2, -70 / 27, 35 / 27, 0],
    [1631 / 55296, 175 / 512, 575 / 13824, 44275 / 110592, 253 / 4096],
])
CK_B = np.array([37 / 378, 0, 250 / 621, 125 / 594, 0, 512 / 1771])
CK_E = CK_B - np.array([2825 / 27648, 0, 18575 / 48384, 13525 / 55296, 277 / 14336, 1 / 4])
ERROR_EXPONENT = -1.0 / 5.0


@inline
def _rhs(y, Dh, Wn, rate, p, lam_ref, out):
    """dy/ds as ``model.integrator``'s, with G's place holding H = G + c1 K:Dh / c (``laws.relaxing_part``; 0 but for
    a law whose state holds a fast-relaxing part K of the fabric). Eq. 18's g carries c1 K:Dh, which after a change
    of direction relaxes over a strain 1/c a step would otherwise have to resolve; H's rate cancels it
    (dK/d(|D'| t) = c (kappa Dh - K) + spin), leaving the slow kappa and the spin's part over c."""
    _rhs_s(y, Dh, Wn, rate, p, lam_ref, out)
    out[G_INDEX] += p[C1] * laws.relaxing_part(out, Dh, p)


@inline
def _stage(tableau, s, y, h, Dh, Wn, rate, p, lam_ref, K, ytmp):
    """Stage s >= 1 of an explicit Runge-Kutta step of size h from y: K[s] = f(y + h sum_j a_sj K[j])."""
    _stage_state(tableau, s, y, h, K, ytmp)
    _rhs(ytmp, Dh, Wn, rate, p, lam_ref, K[s])


@inline
def _combine(weights, y, h, K, out):
    """out = y + h sum_j weights_j K[j]."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(weights.shape[0]):
            acc += weights[j] * K[j, i]
        out[i] = y[i] + h * acc


@inline
def _error_norm(weights, y, y_new, K, h, rtol, atol, scale):
    """RMS over the components of the embedded error estimate h sum_j weights_j K[j], scaled by
    scale_i (atol + rtol max(|y|, |y_new|))."""
    acc = 0.0
    n = y.shape[0]
    for i in range(n):
        e = 0.0
        for j in range(weights.shape[0]):
            e += weights[j] * K[j, i]
        acc += (h * e / (scale[i] * (atol + rtol * max(abs(y[i]), abs(y_new[i]))))) ** 2
    return math.sqrt(acc / n)


@jit
def _dp5_step(y, h, Dh, Wn, rate, p, lam_ref, K, y_new, ytmp):
    """A DP5 step from y with K[0] = f(y): stages K[1:6], y_new, and K[6] = f(y_new) (first same as last)."""
    for s in range(1, DP_A.shape[0]):
        _stage(DP_A, s, y, h, Dh, Wn, rate, p, lam_ref, K, ytmp)
    _combine(DP_B, y, h, K, y_new)
    _rhs(y_new, Dh, Wn, rate, p, lam_ref, K[N_K - 1])


@jit
def _interpolant(K, Q):
    """Q = K^T P, the interpolation rows: y(x) = y + h sum_r Q[r] x^(r+1)."""
    for r in range(N_DENSE):
        for i in range(K.shape[1]):
            acc = 0.0
            for j in range(N_K):
                acc += K[j, i] * DP_P[j, r]
            Q[r, i] = acc


@inline
def _value_slope(Q, y, h, x, i):
    """Component i of the interpolant at fraction x of the step, and its slope d/ds."""
    value = 0.0
    slope = 0.0
    power = 1.0
    for r in range(N_DENSE):
        slope += (r + 1) * Q[r, i] * power
        power *= x
        value += Q[r, i] * power
    return y[i] + h * value, slope


@jit
def _crossing(Q, y, h, target):
    """Fraction x in (0, 1] of the step where the interpolated time reaches ``target`` (Newton,
    safeguarded by bisection; t(x) is monotone)."""
    lo, hi = 0.0, 1.0
    x = (target - y[T_INDEX]) / (h * (Q[0, T_INDEX] + Q[1, T_INDEX] + Q[2, T_INDEX] + Q[3, T_INDEX]))
    for _ in range(60):
        value, slope = _value_slope(Q, y, h, x, T_INDEX)
        f = value - target
        if f > 0.0:
            hi = x
        elif f < 0.0:
            lo = x
        else:
            return x
        step = f / (h * slope) if slope > 0.0 else math.inf
        if abs(step) <= 1e-15:
            return min(max(x - step, lo), hi)
        x -= step
        if not lo < x < hi:
            x = 0.5 * (lo + hi)
    return x


REJECTED, ADVANCED, FINISHED = range(3)


@jit
def _aim(y, f0, rate, t_end, h):
    """The step to try: ``h``, but no longer than OVERSHOOT times the s that reaches t_end at the
    current dt/ds (where S = 0, dt/ds = 0: the shortest s that could reach it)."""
    remaining = t_end - y[T_INDEX]
    aim = OVERSHOOT * remaining / f0[T_INDEX] if f0[T_INDEX] > 0.0 else remaining * rate
    return aim if h == 0.0 else min(h, aim)


@jit
def _conclude(y, h, Dh, Wn, rate, p, lam_ref, t_end, rtol, atol, scale, work):
    """Judge a computed step (work holds its stages): (REJECTED, next h), (ADVANCED, next h) with y moved
    to the step's end, or (FINISHED, h) with y at t_end, taken from the interpolant."""
    n = y.shape[0]
    K = work[:N_K]
    Q = work[N_K:N_K + N_DENSE]
    y_new = work[N_K + N_DENSE]
    ytmp = work[N_K + N_DENSE + 1]
    f0 = work[N_K + N_DENSE + 2]
    err = _error_norm(DP_E, y, y_new, K, h, rtol, atol, scale)
    if not err <= 1.0:
        return REJECTED, h * (max(0.2, 0.9 * err ** ERROR_EXPONENT) if math.isfinite(err) else 0.2)
    h_next = h * (10.0 if err == 0.0 else min(10.0, 0.9 * err ** ERROR_EXPONENT))
    if y_new[T_INDEX] < t_end:
        for i in range(n):
            y[i] = y_new[i]
            f0[i] = K[N_K - 1, i]
        return ADVANCED, h_next
    # the end lies inside the step: take it from the interpolant. Near the step's end (x >= NEAR_END)
    # the interpolant meets y_new with its slope, so its error there is a small fraction of the
    # step's; further inside, its residual in the ODE must pass the error norm (the defect check)
    _interpolant(K, Q)
    x = _crossing(Q, y, h, t_end)
    for i in range(n):
        ytmp[i] = _value_slope(Q, y, h, x, i)[0]
    if x < NEAR_END:
        _rhs(ytmp, Dh, Wn, rate, p, lam_ref, y_new)  # y_new now holds f at the end
        defect = 0.0
        for i in range(n):
            slope = _value_slope(Q, y, h, x, i)[1]
            defect += (h * (slope - y_new[i]) / (scale[i] * (atol + rtol * abs(ytmp[i])))) ** 2
        defect = math.sqrt(defect / n)
        if not defect <= 1.0:
            return REJECTED, h * (max(0.2, 0.9 * defect ** ERROR_EXPONENT) if math.isfinite(defect) else 0.2)
    for i in range(n):
        y[i] = ytmp[i]
    y[T_INDEX] = t_end
    return FINISHED, h


@jit
def _status(y, steps, max_steps, outcome):
    if outcome != FINISHED:
        return TOO_MANY_STEPS if steps >= max_steps else STEP_UNDERFLOW
    for i in range(y.shape[0]):
        if not math.isfinite(y[i]):
            return NOT_FINITE
    return SUCCESS


@jit
def _direct(y, Dh, Wn, rate, p, t_end, rtol, atol, scale, work):
    """One Cash-Karp step in the strain |D'| t itself (the rates without regularisation, lam_ref = 0)
    over the whole interval, so it lands on t_end exactly; True, with y at t_end, if its error passes."""
    K = work[:N_K]
    y_new = work[N_K + N_DENSE]
    _rhs(y, Dh, Wn, rate, p, 0.0, K[0])
    h = (t_end - y[T_INDEX]) * rate
    for s in range(1, CK_A.shape[0]):
        _stage(CK_A, s, y, h, Dh, Wn, rate, p, 0.0, K, work[N_K + N_DENSE + 1])
    _combine(CK_B, y, h, K, y_new)
    if not _error_norm(CK_E, y, y_new, K, h, rtol, atol, scale) <= 1.0:
        return False
    for i in range(y.shape[0]):
        y[i] = y_new[i]
    y[T_INDEX] = t_end
    return True


@jit
def advance(y, Dh, Wn, rate, p, lam_ref, t_end, rtol, atol, scale, max_steps, work):
    """Integrate the packed state ``y`` in place under one constant L from y[t] to ``t_end``.

    ``Dh``, ``Wn``, ``rate``, ``p``, ``lam_ref`` as in ``model.integrator``; ``scale`` (len(y)) multiplies each
    component's tolerance (1 but for a law's state whose errors do not accumulate: ``model.laws.state_tolerance``);
    ``work`` is scratch of shape (WORK_ROWS, len(y)). Where Lambda(S) at the start is at least ``lam_ref`` the whole
    interval is first tried as one step in the strain itself (``_direct``); otherwise, or if that step fails its
    error test, in the regularised s. G is integrated as H (``_rhs``). Returns (steps taken, accepted and rejected;
    status code).
    """
    y[G_INDEX] += p[C1] * laws.relaxing_part(y, Dh, p)
    steps, status = _advance(y, Dh, Wn, rate, p, lam_ref, t_end, rtol, atol, scale, max_steps, work)
    y[G_INDEX] -= p[C1] * laws.relaxing_part(y, Dh, p)
    return steps, status


@jit
def _advance(y, Dh, Wn, rate, p, lam_ref, t_end, rtol, atol, scale, max_steps, work):
    """``advance`` on the state with H in G's place."""
    steps = 0
    if y[T_INDEX] < t_end and lam_ref > 0.0:
        a11, a22, a12, a13, a23 = y[0], y[1], y[2], y[3], y[4]
        S = hardening_variable(a11, a22, a12, a13, a23, Dh[0], Dh[1], Dh[2], Dh[3], Dh[4], Dh[5])
        if persistence(S, p) >= lam_ref:
            steps = 1
            if _direct(y, Dh, Wn, rate, p, t_end, rtol, atol, scale, work):
                return steps, _status(y, steps, max_steps, FINISHED)
    f0 = work[N_K + N_DENSE + 2]
    _rhs(y, Dh, Wn, rate, p, lam_ref, f0)
    outcome = ADVANCED if y[T_INDEX] < t_end else FINISHED
    h = 0.0
    h_min = 1e-14 * (t_end - y[T_INDEX]) * rate  # round-off against the whole interval's s
    while outcome != FINISHED and steps < max_steps:
        h = _aim(y, f0, rate, t_end, h)
        if h < h_min:
            break
        steps += 1
        for i in range(y.shape[0]):
            work[0, i] = f0[i]
        _dp5_step(y, h, Dh, Wn, rate, p, lam_ref, work[:N_K], work[N_K + N_DENSE], work[N_K + N_DENSE + 1])
        outcome, h = _conclude(y, h, Dh, Wn, rate, p, lam_ref, t_end, rtol, atol, scale, work)
    return steps, _status(y, steps, max_steps, outcome)
