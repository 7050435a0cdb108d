"""The fabric's rate split into its terms, for any law of the registry (the law's counterpart of the DEM's contact
budget, ``docs/results/budget.md``): per unit |D'| t,

    dF/d(|D'| t) = input + recovery + spin + own,

F the fabric (the state A plus the parts a law holds beyond it), input = beta1(S) D'/|D'| / Lambda(S) (Eq. 13's),
recovery = (beta2(S) R + Lambda(S) E) / Lambda(S), R what the law's beta2 removes in place of A and E its rate beside
the spin (Eq. 13: R = A, E = 0), spin = W A - A W per unit |D'| (the Jaumann rate's), and own the rate of the part
of the fabric the law's own state holds (K of "elastic": its relaxation and spin). A jump of kappa D'/|D'| at a
change of direction is not a rate and is in none of them.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import laws
from .equations import fabric_rates, hardening_variable, persistence
from .integrator import N_STATE
from .params import Params
from .solver import pack_fabric, unpack_fabric
from .tensors import spin_rate


@dataclasses.dataclass(frozen=True)
class FabricTerms:
    """Each term of the fabric's rate per unit |D'| t, (n, 3, 3) (see the module)."""

    input: np.ndarray
    recovery: np.ndarray
    spin: np.ndarray
    own: np.ndarray

    def total(self) -> np.ndarray:
        return self.input + self.recovery + self.spin + self.own


def _packed_stretching(L: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(Dh packed (11, 22, 33, 12, 13, 23), W/|D'| packed (12, 13, 23), |D'|) of a velocity gradient."""
    D = 0.5 * (L + L.T)
    W = 0.5 * (L - L.T)
    Dd = D - np.trace(D) * np.eye(3) / 3.0
    norm = float(np.linalg.norm(Dd))
    Dh = Dd / norm
    return (np.array([Dh[0, 0], Dh[1, 1], Dh[2, 2], Dh[0, 1], Dh[0, 2], Dh[1, 2]]),
            np.array([W[0, 1], W[0, 2], W[1, 2]]) / norm, norm)


def fabric_terms(fabric: np.ndarray, law_state: np.ndarray, L: np.ndarray, params: Params) -> FabricTerms:
    """The terms at each of n states: the fabric (n, 3, 3) and the law's own state (n, k) as ``model.integrate``
    returns them (``Result.A``, ``Result.law_state``), under the velocity gradients L (n, 3, 3) of a deviatoric
    stretching (|D'| > 0)."""
    fabric, L = np.asarray(fabric, dtype=float), np.asarray(L, dtype=float)
    law_state = np.asarray(law_state, dtype=float).reshape(len(fabric), -1)
    p = params.as_array()
    out = {name: np.zeros_like(fabric) for name in ("input", "recovery", "spin", "own")}
    for k in range(len(fabric)):
        Dh, Wn, _ = _packed_stretching(L[k])
        y = np.zeros(N_STATE + law_state.shape[1])
        y[N_STATE:] = law_state[k]
        held = unpack_fabric(np.array(laws.state_fabric(y, p))) if law_state.shape[1] else 0.0
        Dt = unpack_fabric(np.array([Dh[0], Dh[1], Dh[3], Dh[4], Dh[5]]))
        A = fabric[k] - laws.offset(p) * Dt - held
        y[:5] = pack_fabric(A)
        n11, n22, n12, n13, n23, lam, g, c2 = fabric_rates(y, Dh, Wn, p)
        S = hardening_variable(*y[:5], *Dh)
        beta1 = params.a1 + params.b1 * S
        spin = np.array(spin_rate(Wn[0], Wn[1], Wn[2], *y[:5]))
        out["input"][k] = beta1 * Dt / persistence(S, p)
        out["spin"][k] = unpack_fabric(spin)
        out["recovery"][k] = unpack_fabric(np.array([n11, n22, n12, n13, n23]) / lam) - out["input"][k] - out["spin"][k]
        if law_state.shape[1]:
            rates = np.zeros_like(y)
            laws.state_rates(y, Dh, Wn, p, g, c2, rates, 1.0)
            out["own"][k] = unpack_fabric(np.array(laws.state_fabric(rates, p)))
    return FabricTerms(**out)
