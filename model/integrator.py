"""Compiled integrators for the fabric equation through the reversal singularity.

The fabric rate is dA/dt = [beta1 D' + beta2 |D'| A]/Lambda(S) - A W + W A (Eqs. 13/23) and
Lambda(S) = S**k vanishes right after a reversal and at an isotropic start. We integrate in a
regularised variable s (a Sundman transformation) with

    dt/ds = Lambda / ((Lambda + Lambda_ref) |D'|),

so that every rate is bounded for S -> 0 while s ~ |D'| t wherever S >> S_ref. The state is
y = (A11, A22, A12, A13, A23, t, G, v) with G, v the two integrals that give the packing fraction of
Eq. 18 in closed form: 1/Phi(t) = exp(-G(t))/Phi(0) + v(t).

``dop853`` is an embedded 8(5,3) Runge-Kutta method (Dormand & Prince, Hairer's DOP853;
coefficients from scipy) with adaptive steps that land exactly on segment ends and output times.
``explicit_euler`` is the paper's method (Sec. 4): fixed steps in t, no regularisation.

Kernel status codes: 0 success, 1 step size underflow, 2 too many steps, 3 non-finite state,
4 explicit Euler met S = 0.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop

from . import laws
from .equations import C1, C3, PHI_C, C, dilatancy_c2, fabric_rates, observables_into
from .jit import inline, jit

N_STATE = laws.BASE  # A packed (5), t, G, v; a fabric law's own state follows (model.laws)
ROUNDOFF = 1e-13  # relative time difference treated as equal (segment ends vs output times)
NEAR_END = 1e-3  # a crossing this close to a step's end is taken from the interpolant
T_INDEX, G_INDEX, V_INDEX = 5, 6, 7
N_STAGES = _dop.N_STAGES
RK_A = np.ascontiguousarray(_dop.A)
RK_B = np.ascontiguousarray(_dop.B)
RK_E3 = np.ascontiguousarray(_dop.E3)
RK_E5 = np.ascontiguousarray(_dop.E5)
RK_D = np.ascontiguousarray(_dop.D)

SUCCESS, STEP_UNDERFLOW, TOO_MANY_STEPS, NOT_FINITE, EULER_SINGULAR = range(5)
STATUS_MESSAGES = {
    SUCCESS: "integration successful",
    STEP_UNDERFLOW: "step size fell below round-off: the requested tolerance cannot be honoured",
    TOO_MANY_STEPS: "too many steps: the solution stalls (S stays at 0 with a vanishing fabric rate?)",
    NOT_FINITE: "the state became non-finite",
    EULER_SINGULAR: "explicit Euler met S = 0, where the fabric rate is infinite",
}


@jit
def _rhs_s(y, Dh, Wn, rate, p, lam_ref, out):
    """dy/ds in the regularised variable s."""
    n11, n22, n12, n13, n23, lam, g, c2 = fabric_rates(y, Dh, Wn, p)
    w = 1.0 / (lam + lam_ref)
    out[0] = n11 * w
    out[1] = n22 * w
    out[2] = n12 * w
    out[3] = n13 * w
    out[4] = n23 * w
    dgam = lam * w  # d(|D'| t)/ds
    out[T_INDEX] = dgam / rate
    out[G_INDEX] = g * dgam
    out[V_INDEX] = (c2 - g * y[V_INDEX]) * dgam
    if y.shape[0] > N_STATE:  # the fabric law's own state (model.laws)
        laws.state_rates(y, Dh, Wn, p, g, c2, out, dgam)


@jit
def _emit_state(y, t_out, iout, y_out):
    """Outputs at t_out[iout:] up to y's time (within round-off) take the state y; returns the next index."""
    limit = y[T_INDEX] + ROUNDOFF * max(1.0, abs(y[T_INDEX]))
    while iout < t_out.shape[0] and t_out[iout] <= limit:
        y_out[iout, :] = y
        y_out[iout, T_INDEX] = t_out[iout]
        iout += 1
    return iout


@jit
def _dense_component(F, y_old, x, i):
    """Component i of the DOP853 dense output at fraction x of the step (``_dense_value_slope``)."""
    return _dense_value_slope(F, y_old, x, i)[0]


@jit
def _dense_eval(F, y_old, x, out):
    for i in range(y_old.shape[0]):
        out[i] = _dense_component(F, y_old, x, i)


@jit
def _dense_value_slope(F, y_old, x, i):
    """Component i of the DOP853 dense output (Hairer's form, as in scipy) and its slope dP/dx:
    P = y_old + x (F0 + (1-x) (F1 + x (F2 + (1-x) (F3 + x (F4 + (1-x) (F5 + x F6))))))."""
    u = 1.0 - x
    q = F[5, i] + x * F[6, i]
    dq = F[6, i]
    dq = -q + u * dq
    q = F[4, i] + u * q
    dq = q + x * dq
    q = F[3, i] + x * q
    dq = -q + u * dq
    q = F[2, i] + u * q
    dq = q + x * dq
    q = F[1, i] + x * q
    dq = -q + u * dq
    q = F[0, i] + u * q
    return y_old[i] + x * q, q + x * dq


@jit
def _dense_defect(F, y_old, h, Dh, Wn, rate, p, lam_ref, rtol, atol, ymid, dmid, fmid):
    """Defect of the dense output at mid-step, |P'(1/2) - h f(P(1/2))|, in the error norm.

    The step's error estimate controls only its end. Where the stiff fabric relaxation (large
    |b2|) limits the step, the interpolant P in between can be off by far more; the defect of P in
    the ODE (its residual, times h) bounds that error for stiff and non-stiff components alike.
    """
    n = y_old.shape[0]
    for i in range(n):
        ymid[i], dmid[i] = _dense_value_slope(F, y_old, 0.5, i)
    _rhs_s(ymid, Dh, Wn, rate, p, lam_ref, fmid)
    acc = 0.0
    for i in range(n):
        scale = atol + rtol * abs(ymid[i])
        acc += ((dmid[i] - h * fmid[i]) / scale) ** 2
    return math.sqrt(acc / n)


@jit
def _dense_solve_time(F, y_old, target):
    """Fraction x in [0, 1] of the step where the interpolated time equals ``target``.

    Newton from the linear guess, safeguarded by bisection; t(x) is monotone and nearly linear
    away from S = 0, so two or three iterations suffice.
    """
    lo, hi = 0.0, 1.0
    t_lo = y_old[T_INDEX]
    t_hi = y_old[T_INDEX] + F[0, T_INDEX]  # P(1) = y_new
    if target <= t_lo:
        return 0.0
    if target >= t_hi:
        return 1.0
    x = (target - t_lo) / (t_hi - t_lo)
    for _ in range(60):
        value, slope = _dense_value_slope(F, y_old, x, T_INDEX)
        f = value - target
        if f == 0.0:
            return x
        if f > 0.0:
            hi = x
        else:
            lo = x
        step = f / slope if slope > 0.0 else math.inf
        if abs(step) <= 1e-15:
            return min(max(x - step, lo), hi)
        x = x - step
        if not (lo < x < hi):
            x = 0.5 * (lo + hi)
    return x


@jit
def _dense_outputs(F, y_old, t_out, iout, limit, y_out):
    """Outputs t_out[iout:] below ``limit`` from the step's dense output; returns the next index."""
    while iout < t_out.shape[0] and t_out[iout] < limit:
        x = _dense_solve_time(F, y_old, t_out[iout])
        _dense_eval(F, y_old, x, y_out[iout])
        y_out[iout, T_INDEX] = t_out[iout]
        iout += 1
    return iout


@jit
def _shrunk(h, err):
    """The step to retry after a rejection with error norm ``err`` > 1 (a non-finite one: h / 5)."""
    return h * max(0.2, 0.9 * err ** (-1.0 / 8.0)) if math.isfinite(err) else 0.2 * h


@inline
def _stage_state(tableau, s, y, h, K, ytmp):
    """ytmp = y + h sum_j a_sj K[j], where stage s >= 1 of an explicit Runge-Kutta step of size h from y is taken."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(s):
            acc += tableau[s, j] * K[j, i]
        ytmp[i] = y[i] + h * acc


@jit
def _stage(tableau, s, y, h, Dh, Wn, rate, p, lam_ref, K, ytmp):
    """Stage s >= 1 of an explicit Runge-Kutta step of size h from y: K[s] = f(y + h sum_j a_sj K[j])."""
    _stage_state(tableau, s, y, h, K, ytmp)
    _rhs_s(ytmp, Dh, Wn, rate, p, lam_ref, K[s])


@jit
def _stages(y, h, first, last, Dh, Wn, rate, p, lam_ref, K, ytmp):
    """DOP853 stages first..last-1 (``RK_A``)."""
    for s in range(first, last):
        _stage(RK_A, s, y, h, Dh, Wn, rate, p, lam_ref, K, ytmp)


@jit
def _rk_step(y, f0, h, Dh, Wn, rate, p, lam_ref, K, y_new, ytmp):
    """One DOP853 step of size h in s; fills K[0:13] and y_new."""
    n = y.shape[0]
    for i in range(n):
        K[0, i] = f0[i]
    _stages(y, h, 1, N_STAGES, Dh, Wn, rate, p, lam_ref, K, ytmp)
    for i in range(n):
        acc = 0.0
        for j in range(N_STAGES):
            acc += RK_B[j] * K[j, i]
        y_new[i] = y[i] + h * acc
    _rhs_s(y_new, Dh, Wn, rate, p, lam_ref, K[N_STAGES])


@jit
def _error_norm(y, y_new, K, h, rtol, atol):
    n = y.shape[0]
    e5 = 0.0
    e3 = 0.0
    for i in range(n):
        scale = atol + rtol * max(abs(y[i]), abs(y_new[i]))
        a5 = 0.0
        a3 = 0.0
        for j in range(N_STAGES + 1):
            a5 += RK_E5[j] * K[j, i]
            a3 += RK_E3[j] * K[j, i]
        e5 += (a5 / scale) ** 2
        e3 += (a3 / scale) ** 2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * n)


@jit
def _dense_coefficients(y, y_new, h, Dh, Wn, rate, p, lam_ref, K, F, ytmp):
    """The three extra stages and the 7 interpolation coefficients of DOP853."""
    n = y.shape[0]
    _stages(y, h, N_STAGES + 1, RK_A.shape[0], Dh, Wn, rate, p, lam_ref, K, ytmp)
    for i in range(n):
        dy = y_new[i] - y[i]
        F[0, i] = dy
        F[1, i] = h * K[0, i] - dy
        F[2, i] = 2.0 * dy - h * (K[N_STAGES, i] + K[0, i])
        for r in range(RK_D.shape[0]):
            acc = 0.0
            for j in range(RK_D.shape[1]):
                acc += RK_D[r, j] * K[j, i]
            F[3 + r, i] = h * acc


@jit
def _initial_step(y, f0, Dh, Wn, rate, p, lam_ref, rtol, atol, span, ytmp, ftmp):
    """Hairer's starting step (as scipy's select_initial_step), in s."""
    n = y.shape[0]
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        scale = atol + abs(y[i]) * rtol
        d0 += (y[i] / scale) ** 2
        d1 += (f0[i] / scale) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, span)
    for i in range(n):
        ytmp[i] = y[i] + h0 * f0[i]
    _rhs_s(ytmp, Dh, Wn, rate, p, lam_ref, ftmp)
    d2 = 0.0
    for i in range(n):
        scale = atol + abs(y[i]) * rtol
        d2 += ((ftmp[i] - f0[i]) / scale) ** 2
    d2 = math.sqrt(d2 / n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, span)


@jit
def _begin(y0, t_out):
    """An integrator's start: the state (a copy of y0), the outputs (NaN until reached) with those at y0's time
    filled, and the index of the next output."""
    y = y0.copy()
    y_out = np.full((t_out.shape[0], y0.shape[0]), np.nan)
    return y, y_out, _emit_state(y, t_out, 0, y_out)


@jit
def dop853(y0, seg_end, seg_Dh, seg_Wn, seg_rate, p, t_out, rtol, atol, lam_ref, max_steps):
    """Integrate the packed state through consecutive constant-L segments.

    seg_end: (m,) end times; seg_Dh: (m, 6) unit D'; seg_Wn: (m, 3) W/|D'|; seg_rate: (m,) |D'|;
    t_out: sorted output times within [y0[t], seg_end[-1]]. Steps land exactly on every segment
    end, where the right-hand side jumps; outputs between step ends come from the dense output,
    so the step size is set by the tolerance alone, not by the output spacing.
    Returns (y_out (len(t_out), 8), y_end (8,), stats (nfev, accepted, rejected, status)).
    """
    n = y0.shape[0]
    y, y_out, iout = _begin(y0, t_out)
    y_new = np.empty(n)
    ytmp = np.empty(n)
    ftmp = np.empty(n)
    fmid = np.empty(n)
    f0 = np.empty(n)
    K = np.empty((RK_A.shape[0], n))
    F = np.empty((7, n))
    nfev = 0
    accepted = 0
    rejected = 0
    status = SUCCESS
    for iseg in range(seg_end.shape[0]):
        Dh, Wn, rate, t_end = seg_Dh[iseg], seg_Wn[iseg], seg_rate[iseg], seg_end[iseg]
        if y[T_INDEX] >= t_end:
            continue
        _rhs_s(y, Dh, Wn, rate, p, lam_ref, f0)
        span = (t_end - y[T_INDEX]) * rate
        h = _initial_step(y, f0, Dh, Wn, rate, p, lam_ref, rtol, atol, span, ytmp, ftmp)
        nfev += 2
        while y[T_INDEX] < t_end:
            if accepted + rejected >= max_steps:
                status = TOO_MANY_STEPS
                break
            h_free = h
            landing = f0[T_INDEX] > 0.0 and y[T_INDEX] + h * f0[T_INDEX] > t_end
            if landing:
                h = (t_end - y[T_INDEX]) / f0[T_INDEX]
            if h < 1e-14 * (1.0 + abs(y[T_INDEX]) * rate):
                status = STEP_UNDERFLOW
                break
            _rk_step(y, f0, h, Dh, Wn, rate, p, lam_ref, K, y_new, ytmp)
            nfev += N_STAGES
            err = _error_norm(y, y_new, K, h, rtol, atol)
            if err > 1.0 or not math.isfinite(err):
                rejected += 1
                h = _shrunk(h, err)
                continue
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
            h_next = h * factor
            if landing:
                h_next = max(h_next, h_free)  # a short landing step does not shrink the next one
            dense_ready = False
            if y_new[T_INDEX] > t_end:
                # passed the segment end (the RHS jumps there): locate the crossing on the
                # interpolant; close to the step end (where the interpolant matches y_new and its
                # slope) take the interpolated state, otherwise retake the step to the crossing
                _dense_coefficients(y, y_new, h, Dh, Wn, rate, p, lam_ref, K, F, ytmp)
                nfev += 3
                x = _dense_solve_time(F, y, t_end)
                if x > 1.0 - NEAR_END:
                    _dense_eval(F, y, x, y_new)
                    dense_ready = True  # F still describes this step, up to fraction x
                else:
                    h *= x
                    _rk_step(y, f0, h, Dh, Wn, rate, p, lam_ref, K, y_new, ytmp)
                    nfev += N_STAGES
            if abs(t_end - y_new[T_INDEX]) <= ROUNDOFF * max(1.0, t_end):
                y_new[T_INDEX] = t_end
            for i in range(n):
                if not math.isfinite(y_new[i]):
                    status = NOT_FINITE
            if status != SUCCESS:
                break
            # outputs inside the step come from DOP853's 7th-order dense output; an output at the
            # step's end takes the step's own state
            limit = y_new[T_INDEX] - ROUNDOFF * max(1.0, abs(y_new[T_INDEX]))
            if iout < t_out.shape[0] and t_out[iout] < limit:
                if not dense_ready:
                    _dense_coefficients(y, y_new, h, Dh, Wn, rate, p, lam_ref, K, F, ytmp)
                    nfev += 3
                defect = _dense_defect(F, y, h, Dh, Wn, rate, p, lam_ref, rtol, atol, ytmp, ftmp, fmid)
                nfev += 1
                if not defect <= 1.0:
                    # the interpolant is not good enough for the outputs: retake a shorter step
                    rejected += 1
                    h = _shrunk(h, defect)
                    continue
                iout = _dense_outputs(F, y, t_out, iout, limit, y_out)
            accepted += 1
            iout = _emit_state(y_new, t_out, iout, y_out)
            if dense_ready:
                _rhs_s(y_new, Dh, Wn, rate, p, lam_ref, K[N_STAGES])
                nfev += 1
            for i in range(n):
                y[i] = y_new[i]
                f0[i] = K[N_STAGES, i]
            h = h_next
        if status != SUCCESS:
            break
    if status == SUCCESS:
        _emit_state(y, t_out, iout, y_out)
    stats = np.array([nfev, accepted, rejected, status], dtype=np.int64)
    return y_out, y, stats


@jit
def explicit_euler(y0, seg_end, seg_Dh, seg_Wn, seg_rate, p, t_out, strain_step, shear_rate):
    """The paper's explicit Euler (Sec. 4) with a fixed strain step; outputs interpolated linearly."""
    n = y0.shape[0]
    y, y_out, iout = _begin(y0, t_out)
    y_prev = y0.copy()
    own = np.zeros(n)
    nfev = 0
    status = SUCCESS
    for iseg in range(seg_end.shape[0]):
        Dh, Wn, rate = seg_Dh[iseg], seg_Wn[iseg], seg_rate[iseg]
        t_start = y[T_INDEX]
        duration = seg_end[iseg] - t_start
        if duration <= 0.0:
            continue
        nsteps = max(1, int(round(duration * shear_rate / strain_step)))
        dt = duration / nsteps
        dgam = rate * dt
        for k in range(nsteps):
            n11, n22, n12, n13, n23, lam, g, c2 = fabric_rates(y, Dh, Wn, p)
            nfev += 1
            if lam == 0.0:
                status = EULER_SINGULAR
                break
            if n > N_STATE:  # the law's own state's increments, from the state before this step
                laws.state_rates(y, Dh, Wn, p, g, c2, own, dgam)
            for i in range(n):
                y_prev[i] = y[i]
            for i in range(N_STATE, n):
                y[i] += own[i]
            y[0] += dgam * n11 / lam
            y[1] += dgam * n22 / lam
            y[2] += dgam * n12 / lam
            y[3] += dgam * n13 / lam
            y[4] += dgam * n23 / lam
            y[G_INDEX] += dgam * g
            y[V_INDEX] += dgam * (c2 - g * y_prev[V_INDEX])
            y[T_INDEX] = seg_end[iseg] if k == nsteps - 1 else t_start + (k + 1) * dt
            while iout < t_out.shape[0] and t_out[iout] <= y[T_INDEX]:
                x = (t_out[iout] - y_prev[T_INDEX]) / (y[T_INDEX] - y_prev[T_INDEX])
                for i in range(n):
                    y_out[iout, i] = y_prev[i] + x * (y[i] - y_prev[i])
                iout += 1
        if status != SUCCESS:
            break
    for i in range(n):
        if not math.isfinite(y[i]):
            status = NOT_FINITE
    stats = np.array([nfev, nfev, 0, status], dtype=np.int64)
    return y_out, y, stats


@jit
def outputs(y_out, t_out, seg_end, D_unit, rate, shear_rate, p, phi, A, Dh, seg, S, tau, w_shear, w_vol):
    """Observables at the outputs of a kernel run, filled into the given arrays.

    A, Dh: (n, 3, 3) fabric and D'/|D'|; seg: (n,) acting segment (a segment owns [start, end), the
    last one its end too); S, tau (Eq. 14) and the work rates of Eqs. 17-18 per unit p*gamma_dot.
    A is the fabric: the state plus kappa Dh, kappa the fabric law's ``offset`` (``model.laws``: 0 but for the "jump"
    law), plus the part the law's own state holds (``laws.state_fabric``; S is the state's, as Eq. 13 evolves it).
    Returns (all finite, min S, max |state|^2) for the caller's checks.
    """
    k = 0
    finite = True
    max_norm2 = 0.0
    for i in range(y_out.shape[0]):
        while k < seg_end.shape[0] - 1 and t_out[i] >= seg_end[k]:
            k += 1
        seg[i] = k
        a11, a22, a12, a13, a23 = y_out[i, 0], y_out[i, 1], y_out[i, 2], y_out[i, 3], y_out[i, 4]
        a33 = -a11 - a22
        A[i, 0, 0], A[i, 1, 1], A[i, 2, 2] = a11, a22, a33
        A[i, 0, 1] = A[i, 1, 0] = a12
        A[i, 0, 2] = A[i, 2, 0] = a13
        A[i, 1, 2] = A[i, 2, 1] = a23
        d = D_unit[k]
        Dh[i, 0, 0], Dh[i, 1, 1], Dh[i, 2, 2] = d[0], d[1], d[2]
        Dh[i, 0, 1] = Dh[i, 1, 0] = d[3]
        Dh[i, 0, 2] = Dh[i, 2, 0] = d[4]
        Dh[i, 1, 2] = Dh[i, 2, 1] = d[5]
        norm2 = a11 * a11 + a22 * a22 + a33 * a33 + 2.0 * (a12 * a12 + a13 * a13 + a23 * a23)
        max_norm2 = max(max_norm2, norm2)
        finite = finite and math.isfinite(norm2) and math.isfinite(phi[i])
    observables_into(A, Dh, p, S, tau, w_shear, w_vol)
    kappa = laws.offset(p)
    if kappa != 0.0:
        for i in range(y_out.shape[0]):
            for j in range(3):
                for m in range(3):
                    A[i, j, m] += kappa * Dh[i, j, m]
    if y_out.shape[1] > N_STATE:  # the part of the fabric the law's own state holds, K: in Eqs. 14, 17 and 18 too
        for i in range(y_out.shape[0]):
            k11, k22, k12, k13, k23 = laws.state_fabric(y_out[i], p)
            K = np.array([[k11, k12, k13], [k12, k22, k23], [k13, k23, -k11 - k22]])
            x = 0.0
            for j in range(3):
                for m in range(3):
                    A[i, j, m] += K[j, m]
                    tau[i, j, m] += p[C] * K[j, m]
                    x += K[j, m] * Dh[i, j, m]
            w_shear[i] += p[C] * x
            w_vol[i] += p[C1] * x
    min_S = math.inf
    for i in range(y_out.shape[0]):
        scale = rate[seg[i]] / shear_rate  # per-|D'| rates to per-gamma_dot
        c2 = dilatancy_c2(S[i], p)
        w_vol[i] = (w_vol[i] + c2 * (p[PHI_C] - phi[i] + p[C3])) * scale  # Eq. 18 over |D'|
        w_shear[i] *= scale
        min_S = min(min_S, S[i])
    return finite, min_S, max_norm2
