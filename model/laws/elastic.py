"""The "elastic" law: a part of the fabric, K, follows kappa D'/|D'| over a strain gamma_e instead of at once (the
"jump" law's part, with the finite strain the DEM takes to lose it after a reversal: an elastic origin, faster with
stiffer contacts; ``docs/model.md``). The fabric of Eqs. 14 and 18 is the state A, which follows Eq. 13, plus K, a
state of the law's own:

    K_jaumann = (sqrt2 / gamma_e) (kappa D'/|D'| - K) |D'|,

so K relaxes to kappa D'/|D'| over a nominal shear strain gamma_e (gamma = sqrt2 |D'| t in simple shear) and turns
with the material (the Jaumann rate: objective). kappa = 0 is Eq. 13 (K starts at, and stays, 0); gamma_e -> 0 is the
"jump" law.
"""

import math

import numpy as np

from ..jit import jit
from ..tensors import double_dot, spin_rate
from .parameter import Parameter

NAME = "elastic"
PARAMETERS = (
    Parameter("elastic_fabric", 0.0, -0.01, -0.1, 0.1, "kappa: the part of the fabric that follows D'/|D'| "
              "elastically"),
    Parameter("elastic_strain", 0.005, 0.005, 1e-4, 0.1, "gamma_e: the nominal shear strain over which it follows"),
)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"elastic-": {"elastic_fabric": -0.013, "elastic_strain": 0.005},
            "elastic+": {"elastic_fabric": 0.02, "elastic_strain": 0.02}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"elastic_fabric": -0.013, "elastic_strain": 0.01}
SPEED_EXAMPLE = {"elastic_fabric": -0.035, "elastic_strain": 0.01}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = False
#: the law's own state: K packed (11, 22, 12, 13, 23)
STATE = ("K11", "K22", "K12", "K13", "K23")
#: the material-point update's tolerance on K, in units of A's (``model.stepper``): an error in K decays over
#: gamma_e and enters tau/p (Eq. 14) once, where A's and Phi's add up over the hundreds of updates of a cycle; at
#: 1000 the update stays within 5e-8 of ``model.predict`` over whole cycles (``make bench``)
STATE_TOLERANCE = (1000.0,) * len(STATE)
#: the bounds of each state variable (``model.update`` refuses a state outside them): K relaxes to kappa D'/|D'| and
#: turns with the material, so each of its components stays within kappa's range
STATE_BOUNDS = ((PARAMETERS[0].low, PARAMETERS[0].high),) * len(STATE)


@jit
def state_rates(y, Dh, Wn, p, g, c2, out, scale, first, own):
    """dK/d(|D'| t) times ``scale`` into ``out[first:first + 5]``: the relaxation and the Jaumann spin."""
    k11, k22, k12, k13, k23 = y[first], y[first + 1], y[first + 2], y[first + 3], y[first + 4]
    s11, s22, s12, s13, s23 = spin_rate(Wn[0], Wn[1], Wn[2], k11, k22, k12, k13, k23)
    c = math.sqrt(2.0) / p[own + 1]
    kappa = p[own]
    out[first] = scale * (c * (kappa * Dh[0] - k11) + s11)
    out[first + 1] = scale * (c * (kappa * Dh[1] - k22) + s22)
    out[first + 2] = scale * (c * (kappa * Dh[3] - k12) + s12)
    out[first + 3] = scale * (c * (kappa * Dh[4] - k13) + s13)
    out[first + 4] = scale * (c * (kappa * Dh[5] - k23) + s23)


@jit
def relaxing_part(v, Dh, p, first, own):
    """K:D'/|D'| over K's relaxation rate sqrt2/gamma_e, K packed at ``v[first:first + 5]`` (or, the map being
    linear, the same of its rate): the part of Eq. 18's integral of g/c1 that K's fast relaxation holds
    (``model.stepper``)."""
    return double_dot(v[first], v[first + 1], v[first + 2], v[first + 3], v[first + 4],
                      Dh[0], Dh[1], Dh[2], Dh[3], Dh[4], Dh[5]) * p[own + 1] / math.sqrt(2.0)


@jit
def state_fabric(y, p, first, own):
    """K, the part of the fabric the state holds beyond A, packed (11, 22, 12, 13, 23)."""
    return y[first], y[first + 1], y[first + 2], y[first + 3], y[first + 4]


def start(Dh, phi, values):
    """Where a history starts: the part of the fabric K holds and K packed, K = kappa D'/|D'| of its first segment
    (its steady value)."""
    K = values["elastic_fabric"] * np.asarray(Dh, dtype=float)
    return K, np.stack([K[..., 0, 0], K[..., 1, 1], K[..., 0, 1], K[..., 0, 2], K[..., 1, 2]], axis=-1)


def reference_start(Dh, phi, values):
    """The reference's own state where a history starts: K, 3x3 flattened."""
    return values["elastic_fabric"] * np.asarray(Dh, dtype=float).ravel()


def reference_fabric(X):
    """The part of the fabric the reference's own state holds: K."""
    return X.reshape(3, 3)


def reference_state_rate(X, A, phi, L, values):
    """dK/dt on 3x3 tensors (plain numpy), flattened."""
    K = X.reshape(3, 3)
    D = 0.5 * (L + L.T)
    W = 0.5 * (L - L.T)
    Dd = D - np.trace(D) * np.eye(3) / 3
    nD = np.linalg.norm(Dd)
    return (np.sqrt(2.0) / values["elastic_strain"] * (values["elastic_fabric"] * Dd / nD - K) * nD + W @ K
            - K @ W).ravel()
