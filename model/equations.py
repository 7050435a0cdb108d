"""The model's equations (paper Table 1, Sec. 5), compiled with numba.

Symmetric tensors are packed as the six components (11, 22, 33, 12, 13, 23); the traceless fabric
state as the five (11, 22, 12, 13, 23) with A33 = -A11 - A22. ``Dh`` is the unit deviatoric
stretching D'/|D'| and ``Wn`` the spin over |D'|, packed as (W12, W13, W23). ``p`` is
``Params.as_array()``.
"""

from __future__ import annotations

import math

import numpy as np

from . import laws
from .jit import jit
from .tensors import double_dot, spin_rate

# indices into Params.as_array() of Eq. 13's parameters; the fabric law's code and its own follow (model.laws)
(C, N, M, A1, B1, A2, B2, K_PERSIST, C1, C2_COEF, C2_EXP, C3, PHI_C) = range(13)

#: the densest packing of spheres, pi/(3 sqrt 2) = 0.7405 (Kepler; equal spheres): a packing fraction of Eq. 18 at
#: or above it is no packing. Not the random close packing of the paper's grains (diameters uniform on [0.5d, 1.5d]:
#: about 0.65-0.67), which Table 2's own Eq. 18 passes (0.672 after a reversal); see docs/model.md
PHI_MAX = math.pi / (3.0 * math.sqrt(2.0))
#: eigenvalues of A = <n n> - I/3 (Eq. 8)
FABRIC_BOUNDS = (-1.0 / 3.0, 2.0 / 3.0)


@jit
def fabric_within_bounds(a11, a22, a12, a13, a23, slack):
    """Whether the traceless fabric's eigenvalues lie within ``FABRIC_BOUNDS`` (widened by ``slack``): in closed
    form (a traceless symmetric A has eigenvalues 2 sqrt(J2/3) cos(t + 2 pi k/3), J2 = |A|^2/2, cos 3t =
    (3 sqrt 3 / 2) det A / J2^(3/2)); any A with |A|^2 <= 1/6 is within them."""
    a33 = -a11 - a22
    norm2 = a11 * a11 + a22 * a22 + a33 * a33 + 2.0 * (a12 * a12 + a13 * a13 + a23 * a23)
    if norm2 <= 1.0 / 6.0:
        return True
    j2 = 0.5 * norm2
    det = (a11 * (a22 * a33 - a23 * a23) - a12 * (a12 * a33 - a23 * a13) + a13 * (a12 * a23 - a22 * a13))
    c = min(1.0, max(-1.0, 1.5 * math.sqrt(3.0) * det / j2 ** 1.5))
    t = math.acos(c) / 3.0
    r = 2.0 * math.sqrt(j2 / 3.0)
    lo, hi = FABRIC_BOUNDS
    return r * math.cos(t) <= hi + slack and r * math.cos(t + 2.0 * math.pi / 3.0) >= lo - slack


@jit
def hardening_variable(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23):
    """S = |A| - A:D'/|D'| (Eqs. 10/21) for unit D' given as Dh; always >= 0.

    Where A is nearly parallel to D' the difference is formed as |A_perp|^2 / (|A| + A:Dh),
    A_perp = A - (A:Dh) Dh, so it keeps full relative accuracy down to S = 0.
    """
    a33 = -a11 - a22
    norm_a = math.sqrt(a11 * a11 + a22 * a22 + a33 * a33 + 2.0 * (a12 * a12 + a13 * a13 + a23 * a23))
    x = double_dot(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    if x <= 0.0:
        return norm_a - x
    q11 = a11 - x * d11
    q22 = a22 - x * d22
    q33 = a33 - x * d33
    q12 = a12 - x * d12
    q13 = a13 - x * d13
    q23 = a23 - x * d23
    perp2 = q11 * q11 + q22 * q22 + q33 * q33 + 2.0 * (q12 * q12 + q13 * q13 + q23 * q23)
    return perp2 / (norm_a + x)


@jit
def persistence(S, p):
    """Contact persistence Lambda(S) = S**k (Eqs. 12, 24; paper k = 3/4, taken as two square roots)."""
    k = p[K_PERSIST]
    if k == 0.75:
        return math.sqrt(S * math.sqrt(S))
    return S ** k


@jit
def yield_function(S, p):
    """Y(S) = n + m S (Eq. 22)."""
    return p[N] + p[M] * S


@jit
def dilatancy_c2(S, p):
    """c2(S) = c2_coef * S**c2_exponent (Sec. 5; paper 5.6 S**(1/3))."""
    return p[C2_COEF] * S ** p[C2_EXP]


@jit
def fabric_rates(y, Dh, Wn, p):
    """Rates per unit |D'| t of the packed fabric and the two dilatancy integrals.

    Returns (n11, n22, n12, n13, n23, lam, g, c2) with
    Lambda(S) dA/d(|D'|t) = (n11, ..., n23) (Eqs. 13/23 with the Jaumann rate A_dot + A W - W A, beta2 removing the
    law's ``removal`` in place of A and the law's ``extra_rate`` added beside the spin: ``model.laws``),
    g = c1 (A + kappa Dh + K):Dh + c2 (phi_c + c3) and c2 (kappa the law's ``offset``, K the part of the fabric
    its own state holds, ``state_fabric``), from which (Eq. 18, with u = 1/Phi) du/d(|D'|t) = -g u + c2. ``y`` is
    the kernels' state (``model.integrator``), the law's own after its first ``laws.BASE`` components.
    """
    a11, a22, a12, a13, a23 = y[0], y[1], y[2], y[3], y[4]
    d11, d22, d33, d12, d13, d23 = Dh[0], Dh[1], Dh[2], Dh[3], Dh[4], Dh[5]
    w12, w13, w23 = Wn[0], Wn[1], Wn[2]
    S = hardening_variable(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    lam = persistence(S, p)
    beta1 = p[A1] + p[B1] * S
    beta2 = p[A2] + p[B2] * S
    r11, r22, r12, r13, r23 = laws.removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p)
    s11, s22, s12, s13, s23 = spin_rate(w12, w13, w23, a11, a22, a12, a13, a23)
    e11, e22, e12, e13, e23 = laws.extra_rate(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p)
    j11, j22, j12, j13, j23 = s11 + e11, s22 + e22, s12 + e12, s13 + e13, s23 + e23
    n11 = beta1 * d11 + beta2 * r11 + lam * j11
    n22 = beta1 * d22 + beta2 * r22 + lam * j22
    n12 = beta1 * d12 + beta2 * r12 + lam * j12
    n13 = beta1 * d13 + beta2 * r13 + lam * j13
    n23 = beta1 * d23 + beta2 * r23 + lam * j23
    c2 = dilatancy_c2(S, p)
    g = p[C1] * double_dot(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23) + c2 * (p[PHI_C] + p[C3])
    g += p[C1] * laws.offset(p)  # Eq. 18 on the fabric A + kappa Dh: (A + kappa Dh):Dh = A:Dh + kappa
    if y.shape[0] > laws.BASE:  # and on the part of the fabric the law's own state holds
        k11, k22, k12, k13, k23 = laws.state_fabric(y, p)
        g += p[C1] * double_dot(k11, k22, k12, k13, k23, d11, d22, d33, d12, d13, d23)
    return n11, n22, n12, n13, n23, lam, g, c2


@jit
def observables_into(A, Dh, p, S, tau, w_shear, w_vol_base):
    """Fill S, tau/p (Eq. 14), tau:D'/(p |D'|) and c1 A:Dh for stacks of states A and Dh = D'/|D'| (n, 3, 3); the
    fabric in Eqs. 14 and 18 is A + kappa Dh, kappa the law's ``offset`` (``model.laws``), S that of A."""
    kappa = laws.offset(p)
    for i in range(A.shape[0]):
        a = A[i]
        d = Dh[i]
        s = hardening_variable(a[0, 0], a[1, 1], a[0, 1], a[0, 2], a[1, 2],
                               d[0, 0], d[1, 1], d[2, 2], d[0, 1], d[0, 2], d[1, 2])
        S[i] = s
        y = yield_function(s, p)
        x = 0.0
        for j in range(3):
            for k in range(3):
                tau[i, j, k] = p[C] * (a[j, k] + kappa * d[j, k]) + y * d[j, k]
                x += a[j, k] * d[j, k]
        x += kappa
        w_shear[i] = p[C] * x + y  # tau:D'/(p |D'|) = C A:Dh + Y   (Eq. 17, first term)
        w_vol_base[i] = p[C1] * x  # c1 A:Dh; the Phi-dependent part is added by the caller


@jit
def _hardening_stack(A, Dh, S):
    for i in range(A.shape[0]):
        a = A[i]
        d = Dh[i]
        S[i] = hardening_variable(a[0, 0], a[1, 1], a[0, 1], a[0, 2], a[1, 2],
                                  d[0, 0], d[1, 1], d[2, 2], d[0, 1], d[0, 2], d[1, 2])


def _unit_stack(A, D_dev):
    A = np.ascontiguousarray(A, dtype=float).reshape(-1, 3, 3)
    D = np.ascontiguousarray(D_dev, dtype=float).reshape(-1, 3, 3)
    norm = np.sqrt(np.sum(D * D, axis=(1, 2)))
    if np.any(norm == 0) or not np.all(np.isfinite(norm)):
        raise ValueError("D' must be finite and non-zero")
    return A, D / norm[:, None, None]


def hardening_variable_stack(A: np.ndarray, D_dev: np.ndarray) -> np.ndarray:
    """S (Eq. 10) for stacks of fabric (n, 3, 3) and deviatoric stretching (n, 3, 3)."""
    A, Dh = _unit_stack(A, D_dev)
    S = np.empty(A.shape[0])
    _hardening_stack(A, Dh, S)
    return S


def observables(A: np.ndarray, D_dev: np.ndarray, p: np.ndarray, packing_fraction=None) -> dict:
    """S, tau/p (Eq. 14) and the work rates of Sec. 5 (Eq. 17) per unit p |D'|.

    ``A`` and ``D_dev`` are stacks (n, 3, 3); only the direction of D' matters. With a packing
    fraction Phi the volumetric work rate p Phi_dot/Phi (Eq. 18) is included.
    """
    A, Dh = _unit_stack(A, D_dev)
    n = A.shape[0]
    S = np.empty(n)
    tau = np.empty((n, 3, 3))
    w_shear = np.empty(n)
    w_vol = np.empty(n)
    observables_into(A, Dh, np.asarray(p, dtype=float), S, tau, w_shear, w_vol)
    out = {"S": S, "tau": tau, "w_shear": w_shear}
    if packing_fraction is not None:
        phi = np.asarray(packing_fraction, dtype=float)
        c2 = p[C2_COEF] * S ** p[C2_EXP]
        w_vol = w_vol + c2 * (p[PHI_C] - phi + p[C3])  # Eq. 18 over |D'|
        out["w_vol"] = w_vol
    return out


def eq13_terms(A: np.ndarray, L: np.ndarray, params) -> dict:
    """Eq. 13's three terms for stacks of fabrics ``A`` and velocity gradients ``L`` (n, 3, 3), as rates of A per
    unit |D'| t: the input ``beta1(S) D'/|D'| / Lambda(S)``, the recovery ``beta2(S) A / Lambda(S)`` (Eqs. 12, 13,
    24, 25) and the spin ``W A - A W`` per |D'| that the Jaumann rate adds (their sum is dA/d(|D'|t)). ``params`` a
    ``model.Params`` of the paper's law; S is Eq. 10's. NaN where S = 0 (no persistence: the rate diverges)."""
    A = np.asarray(A, dtype=float).reshape(-1, 3, 3)
    L = np.asarray(L, dtype=float).reshape(-1, 3, 3)
    D = 0.5 * (L + np.swapaxes(L, 1, 2))
    W = 0.5 * (L - np.swapaxes(L, 1, 2))
    D_dev = D - np.trace(D, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3
    norm = np.sqrt(np.sum(D_dev * D_dev, axis=(1, 2)))[:, None, None]
    S = hardening_variable_stack(A, D_dev)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.where(S > 0, S ** params.persistence_exponent, np.nan)[:, None, None]
        beta1 = (params.a1 + params.b1 * S)[:, None, None]
        beta2 = (params.a2 + params.b2 * S)[:, None, None]
        return {"S": S, "input": beta1 * D_dev / norm / lam, "recovery": beta2 * A / lam,
                "spin": (W @ A - A @ W) / norm}
