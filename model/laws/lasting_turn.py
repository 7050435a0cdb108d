"""The "lasting_turn" law: the "lasting" law's K and the "turn_compaction" law's gate together, with one strain for
what each keeps of the old direction. Fitted apart on the paper cell, K's neutral part relaxes over gamma_n = 0.69 and
the packing at the turn follows over gamma_r = 0.56 (``docs/results/models.md``); here both take gamma_n:

    fabric = A + K,   K_jaumann = [(sqrt2 / gamma_e) (kappa D'/|D'| - K + N(K)) - (sqrt2 / gamma_n) N(K)] |D'|
    beta2 |D'| removes A - (1 - g) N(A),   g = min(1, max(0, 1 - k (Phi - Phi_r))),
    d(1/Phi_r)/d(|D'| t) = (sqrt2 / gamma_n) w (1/Phi - 1/Phi_r),   w = (1 + c)^2 / 4,   c = -A:D'/(|A| |D'|).

kappa and gamma_e are read off the DEM as in "lasting"; the fit determines gamma_n and k. k = 0 is "lasting", kappa =
0 "turn_compaction" with gamma_r = gamma_n, both zero Eq. 13. Its state: K (packed), then 1/Phi and 1/Phi_r.
"""

import math

import numpy as np

from ..jit import jit
from . import compaction, lasting, turn_compaction
from .elastic import relaxing_part, state_fabric

NAME = "lasting_turn"
PARAMETERS = lasting.PARAMETERS + (turn_compaction.PARAMETERS[0],)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"lasting_turn": {"elastic_fabric": -0.012, "elastic_strain": 0.005, "lasting_strain": 0.6,
                            "turn_gain": 180.0}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"elastic_fabric": -0.012, "elastic_strain": 0.005, "lasting_strain": 0.3, "turn_gain": 100.0}
SPEED_EXAMPLE = EXAMPLES["lasting_turn"]
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = False
STATE = lasting.STATE + compaction.STATE
STATE_TOLERANCE = lasting.STATE_TOLERANCE + (1.0,) * len(compaction.STATE)
STATE_BOUNDS = lasting.STATE_BOUNDS + compaction.STATE_BOUNDS
#: where the gate's state and parameter start after K's and "lasting"'s
GATE_STATE, GATE_PARAMS = len(lasting.STATE), len(lasting.PARAMETERS)

__all__ = ["relaxing_part", "state_fabric"]


@jit
def removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s, q):
    """A - (1 - g) N(A), the gate on the state after K and on k after "lasting"'s parameters."""
    return compaction.removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s + GATE_STATE,
                              q + GATE_PARAMS)


@jit
def state_rates(y, Dh, Wn, p, g, c2, out, scale, first, own):
    """K's rates (``lasting``), then 1/Phi's (Eq. 18) and 1/Phi_r's over gamma_n, times ``scale``."""
    lasting.state_rates(y, Dh, Wn, p, g, c2, out, scale, first, own)
    at = first + GATE_STATE
    w = turn_compaction.alignment(y[0], y[1], y[2], y[3], y[4], Dh[0], Dh[1], Dh[2], Dh[3], Dh[4], Dh[5])
    out[at] = scale * (c2 - g * y[at])
    out[at + 1] = scale * math.sqrt(2.0) / p[own + 2] * w * (y[at] - y[at + 1])


@jit
def set_packing(y, u, first, own):
    """1/Phi where a history or a step starts."""
    y[first + GATE_STATE] = u


def start(Dh, phi, values):
    """K = kappa D'/|D'| (its steady value) and its part of the fabric, then (1/Phi, 1/Phi)."""
    held, K = lasting.start(Dh, phi, values)
    _, packing = compaction.start(Dh, phi, values)
    shape = np.broadcast_shapes(K.shape[:-1], packing.shape[:-1])
    return (np.broadcast_to(held, shape + (3, 3)),
            np.concatenate([np.broadcast_to(K, shape + K.shape[-1:]),
                            np.broadcast_to(packing, shape + packing.shape[-1:])], axis=-1))


def reference_start(Dh, phi, values):
    """K flattened, then 1/Phi_r."""
    return np.concatenate([lasting.reference_start(Dh, phi, values), [1.0 / phi]])


def reference_state_rate(X, A, phi, L, values):
    """dK/dt, then d(1/Phi_r)/dt over gamma_n (``model.reference``)."""
    gate = turn_compaction.reference_state_rate(X[9:], A, phi, L, {"turn_strain": values["lasting_strain"]})
    return np.concatenate([lasting.reference_state_rate(X[:9], A, phi, L, values), gate])


def reference_removal(A, Dh, values, X, phi):
    """A - (1 - g) N(A) (``model.reference``)."""
    return turn_compaction.reference_removal(A, Dh, values, X[9:], phi)


def reference_fabric(X):
    """K of the reference's state."""
    return X[:9].reshape(3, 3)
