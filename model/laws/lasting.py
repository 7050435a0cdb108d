"""The "lasting" law: the "elastic" law's part K of the fabric, whose part the new shear does not load outlives its
jump. After a large turn the DEM keeps the old direction's part normal to the new shear (``docs/results/budget.md``)
while every law with K unloads it within gamma_e; here only the part of K that D' loads, K - N(K) with N the
"memory" law's neutral part (N(K) = K - dev(P K P), P = 2 Dh Dh), relaxes to kappa D'/|D'| over gamma_e, and N(K)
relaxes over a strain gamma_n of its own:

    K_jaumann = [(sqrt2 / gamma_e) (kappa D'/|D'| - K + N(K)) - (sqrt2 / gamma_n) N(K)] |D'|.

The jump's size and strain are read off the DEM, not fitted (``docs/results/jump.md``: a reversal loses J = 0.017 of
A over 0.004-0.006 strain, J = sqrt2 |kappa|); the fit determines gamma_n. N(kappa D'/|D'|) = 0, so the steady
state is the "elastic" law's; gamma_n = gamma_e is that law, kappa = 0 Eq. 13. Objective (K turns with the Jaumann
rate; N is built from K and D'), rate independent (rates per unit strain), bounded (each relaxation pulls K toward
kappa D'/|D'| or zero) and dissipative as "elastic" (``docs/model.md``).
"""

import math

import numpy as np

from ..jit import jit
from ..tensors import spin_rate
from . import elastic
from .elastic import reference_fabric, reference_start, relaxing_part, start, state_fabric
from .memory import neutral_part, reference_neutral
from .parameter import Parameter

NAME = "lasting"
#: where the jump was read (J = sqrt2 |kappa| at a reversal of the paper cell)
JUMP_READ = "docs/results/jump.md: the paper cell's reversal loses J = 0.017 of A over 0.004-0.006 strain"
PARAMETERS = (
    Parameter("elastic_fabric", 0.0, -0.012, -0.1, 0.1, "kappa: the part of the fabric that follows D'/|D'| "
              "elastically", measured=JUMP_READ),
    Parameter("elastic_strain", 0.005, 0.005, 1e-4, 0.1, "gamma_e: the nominal shear strain over which it follows",
              measured=JUMP_READ),
    Parameter("lasting_strain", 0.005, 0.1, 1e-4, 10.0, "gamma_n: the nominal shear strain over which K's part "
              "that D' does not load relaxes"),
)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"lasting-": {"elastic_fabric": -0.012, "elastic_strain": 0.005, "lasting_strain": 0.2},
            "lasting+": {"elastic_fabric": 0.02, "elastic_strain": 0.02, "lasting_strain": 1.0}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"elastic_fabric": -0.012, "elastic_strain": 0.005, "lasting_strain": 0.1}
SPEED_EXAMPLE = {"elastic_fabric": -0.012, "elastic_strain": 0.005, "lasting_strain": 0.2}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = False
STATE = elastic.STATE
STATE_TOLERANCE = elastic.STATE_TOLERANCE
STATE_BOUNDS = elastic.STATE_BOUNDS

__all__ = ["reference_fabric", "reference_start", "relaxing_part", "start", "state_fabric"]


@jit
def state_rates(y, Dh, Wn, p, g, c2, out, scale, first, own):
    """dK/d(|D'| t) times ``scale`` into ``out[first:first + 5]``: the loaded part's relaxation over gamma_e, the
    neutral part's over gamma_n, and the Jaumann spin."""
    k11, k22, k12, k13, k23 = y[first], y[first + 1], y[first + 2], y[first + 3], y[first + 4]
    d11, d22, d33, d12, d13, d23 = Dh[0], Dh[1], Dh[2], Dh[3], Dh[4], Dh[5]
    s11, s22, s12, s13, s23 = spin_rate(Wn[0], Wn[1], Wn[2], k11, k22, k12, k13, k23)
    n11, n22, n12, n13, n23 = neutral_part(k11, k22, k12, k13, k23, d11, d22, d33, d12, d13, d23)
    c = math.sqrt(2.0) / p[own + 1]
    lag = c - math.sqrt(2.0) / p[own + 2]  # what the neutral part keeps of the loaded part's relaxation
    kappa = p[own]
    out[first] = scale * (c * (kappa * d11 - k11) + lag * n11 + s11)
    out[first + 1] = scale * (c * (kappa * d22 - k22) + lag * n22 + s22)
    out[first + 2] = scale * (c * (kappa * d12 - k12) + lag * n12 + s12)
    out[first + 3] = scale * (c * (kappa * d13 - k13) + lag * n13 + s13)
    out[first + 4] = scale * (c * (kappa * d23 - k23) + lag * n23 + s23)


def reference_state_rate(X, A, phi, L, values):
    """dK/dt on 3x3 tensors (plain numpy), flattened."""
    K = X.reshape(3, 3)
    D = 0.5 * (L + L.T)
    W = 0.5 * (L - L.T)
    Dd = D - D.trace() * np.eye(3) / 3
    nD = np.linalg.norm(Dd)
    Dh = Dd / nD
    N = reference_neutral(K, Dh)
    relaxed = (math.sqrt(2.0) / values["elastic_strain"] * (values["elastic_fabric"] * Dh - K + N)
               - math.sqrt(2.0) / values["lasting_strain"] * N)
    return (relaxed * nD + W @ K - K @ W).ravel()
