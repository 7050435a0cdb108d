"""An independent implementation of the model for validation: plain numpy, full 3x3 tensors, no
regularisation, integrated in t with scipy's ``solve_ivp``. Slow; only valid while S > 0 at every
segment start (it cannot start from an isotropic fabric or an exact reversal of a 2D state).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from . import laws
from .kinematics import History
from .params import Params


def law_parts(params: Params) -> laws.ReferenceParts:
    """The fabric law's parts on 3x3 tensors (``model.laws``), with the set's own parameters."""
    return laws.reference_parts(params.variant, params.law_dict())


def fabric_rate(A: np.ndarray, L: np.ndarray, params: Params, X=None, phi: float = 0.0) -> np.ndarray:
    """dA/dt from Eq. 13 with the Jaumann rate A_dot + A W - W A; beta2 removes the law's ``removal`` in place of A
    (which may read the law's own state X and Phi) and the law's ``extra`` rate adds beside the spin (Eq. 13: A and
    none)."""
    D = 0.5 * (L + L.T)
    W = 0.5 * (L - L.T)
    Dd = D - np.trace(D) * np.eye(3) / 3
    nD = np.linalg.norm(Dd)
    S = np.linalg.norm(A) - np.sum(A * Dd) / nD
    beta1 = params.a1 + params.b1 * S
    beta2 = params.a2 + params.b2 * S
    lam = S**params.persistence_exponent
    law = law_parts(params)
    removed = law.removal(A, Dd / nD, X, phi)
    return (beta1 * Dd + beta2 * nD * removed) / lam - A @ W + W @ A + nD * law.extra(A, Dd / nD)


def jump(L: np.ndarray, params: Params) -> np.ndarray:
    """kappa D'/|D'|, the part of the fabric beyond the state (kappa the law's ``offset``: zero but for "jump")."""
    D = 0.5 * (L + L.T)
    Dd = D - np.trace(D) * np.eye(3) / 3
    return law_parts(params).offset * Dd / np.linalg.norm(Dd)


def packing_rate(A: np.ndarray, phi: float, L: np.ndarray, params: Params, K=None) -> float:
    """dPhi/dt from Eq. 18, on the fabric A + ``jump`` + K (K the part the law's own state holds; S from the state
    A)."""
    D = 0.5 * (L + L.T)
    Dd = D - np.trace(D) * np.eye(3) / 3
    nD = np.linalg.norm(Dd)
    S = np.linalg.norm(A) - np.sum(A * Dd) / nD
    c2 = params.c2_coef * S**params.c2_exponent
    fabric = A + jump(L, params) + (0.0 if K is None else K)
    return phi * (params.c1 * np.sum(fabric * Dd) + c2 * (params.phi_c - phi + params.c3) * nD)


def solve(history: History, A0: np.ndarray, phi0: float, params: Params, strains: np.ndarray,
          rtol: float = 1e-13, atol: float = 1e-15, method: str = "DOP853"):
    """Fabric (n, 3, 3), packing fraction (n,) and the number of right-hand-side calls. The law's state A is the
    fabric less ``jump`` of the segment acting and less the part its own state X holds where it has one (``A0``: the
    fabric at the start, where X starts at its value under the first segment at ``phi0``, ``model.laws.start``)."""
    t_out = np.asarray(strains, dtype=float) / history.shear_rate
    A_out = np.full((t_out.size, 3, 3), np.nan)
    phi_out = np.full(t_out.size, np.nan)
    law = law_parts(params)
    L0 = history.segments[0].L
    D0 = 0.5 * (L0 + L0.T)
    Dd0 = D0 - np.trace(D0) * np.eye(3) / 3
    part, _ = laws.start(params.variant, Dd0 / np.linalg.norm(Dd0), params.law_dict(), phi0)
    X0 = law.state_start(Dd0 / np.linalg.norm(Dd0), phi0) if law.state_rate else np.empty(0)
    y = np.concatenate([(np.asarray(A0, float) - part).ravel(), [phi0], X0])
    held = (lambda X: law.state_fabric(X)) if law.state_rate else (lambda X: 0.0)
    bounds = history.boundaries
    nfev = 0
    for k, seg in enumerate(history.segments):
        t0, t1 = bounds[k], bounds[k + 1]
        last = k == len(history.segments) - 1
        mask = (t_out >= t0) & ((t_out < t1) | (last & (t_out <= t1)))

        def rhs(_t, z, L=seg.L):
            A, phi, X = z[:9].reshape(3, 3), z[9], z[10:]
            rates = [fabric_rate(A, L, params, X, phi).ravel(), [packing_rate(A, phi, L, params, held(X))]]
            return np.concatenate(rates + ([law.state_rate(X, A, phi, L)] if law.state_rate else []))

        sol = solve_ivp(rhs, (t0, t1), y, method=method, rtol=rtol, atol=atol,
                        t_eval=t_out[mask] if mask.any() else None, dense_output=False)
        if not sol.success:
            raise RuntimeError(f"reference solver failed: {sol.message}")
        nfev += sol.nfev
        if mask.any():
            A_out[mask] = sol.y[:9].T.reshape(-1, 3, 3) + jump(seg.L, params)
            A_out[mask] += np.array([held(X) for X in sol.y[10:].T]).reshape(-1, 3, 3) if law.state_rate else 0.0
            phi_out[mask] = sol.y[9]
        end = solve_ivp(rhs, (t0, t1), y, method=method, rtol=rtol, atol=atol, t_eval=[t1]) if sol.t[-1] != t1 else sol
        y = end.y[:, -1]
        nfev += end.nfev if end is not sol else 0
    return A_out, phi_out, nfev
