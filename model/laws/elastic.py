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
from .parameter import OWN, Parameter

NAME = "elastic"
PARAMETERS = (
    Parameter("elastic_fabric", 0.0, -0.01, -0.1, 0.1, "kappa: the part of the fabric that follows D'/|D'| "
              "elastically"),
    Parameter("elastic_strain", 0.005, 0.005, 1e-4, 0.1, "gamma_e: the nominal shear strain over which it follows"),
)
KAPPA, STRAIN = OWN, OWN + 1
#: the law's own state: K packed (11, 22, 12, 13, 23)
STATE = ("K11", "K22", "K12", "K13", "K23")
FIRST = 8  # where the law's state sits in the kernels' state (model.integrator: A, t, G, v before it)


@jit
def state_rates(y, Dh, Wn, p, out, scale):
    """dK/d(|D'| t) times ``scale`` into ``out[FIRST:FIRST + 5]``: the relaxation and the Jaumann spin."""
    k11, k22, k12, k13, k23 = y[FIRST], y[FIRST + 1], y[FIRST + 2], y[FIRST + 3], y[FIRST + 4]
    k33 = -k11 - k22
    w12, w13, w23 = Wn[0], Wn[1], Wn[2]
    c = math.sqrt(2.0) / p[STRAIN]
    kappa = p[KAPPA]
    # W K - K W = 2 sym(W K), W per |D'|
    m00 = w12 * k12 + w13 * k13
    m01 = w12 * k22 + w13 * k23
    m02 = w12 * k23 + w13 * k33
    m10 = -w12 * k11 + w23 * k13
    m11 = -w12 * k12 + w23 * k23
    m12 = -w12 * k13 + w23 * k33
    m20 = -w13 * k11 - w23 * k12
    m21 = -w13 * k12 - w23 * k22
    out[FIRST] = scale * (c * (kappa * Dh[0] - k11) + 2.0 * m00)
    out[FIRST + 1] = scale * (c * (kappa * Dh[1] - k22) + 2.0 * m11)
    out[FIRST + 2] = scale * (c * (kappa * Dh[3] - k12) + m01 + m10)
    out[FIRST + 3] = scale * (c * (kappa * Dh[4] - k13) + m02 + m20)
    out[FIRST + 4] = scale * (c * (kappa * Dh[5] - k23) + m12 + m21)


@jit
def state_fabric(y):
    """K, the part of the fabric the state holds beyond A, packed (11, 22, 12, 13, 23)."""
    return y[FIRST], y[FIRST + 1], y[FIRST + 2], y[FIRST + 3], y[FIRST + 4]


def start(Dh, values):
    """K where a history starts: kappa D'/|D'| of its first segment (3x3), its steady value."""
    return values["elastic_fabric"] * np.asarray(Dh, dtype=float)


def reference_state_rate(K, A, L, values):
    """dK/dt on 3x3 tensors (plain numpy)."""
    D = 0.5 * (L + L.T)
    W = 0.5 * (L - L.T)
    Dd = D - np.trace(D) * np.eye(3) / 3
    nD = np.linalg.norm(Dd)
    return np.sqrt(2.0) / values["elastic_strain"] * (values["elastic_fabric"] * Dd / nD - K) * nD + W @ K - K @ W
