"""The "turn_compaction" law: the "compaction" law's gate on the packing's rise since the turn, not over a running
past that spans cycles. After a large turn the DEM keeps the old direction's part normal to the new shear while the
packing the turn compacted stays dense, and loses it as the compaction falls back (``docs/results/budget.md``: at the
paper cell's 150 degrees Phi rises by +0.011 over 0.05-0.2 strain). beta2 |D'| removes A - (1 - g) N in place of A,
N the "memory" law's neutral part, with the gate of "compaction",

    g = min(1, max(0, 1 - k (Phi - Phi_r))),

but Phi_r follows Phi only while the fabric is aligned as the shear aligns it (A = -|A| D'/|D'| in steady flow,
where S = 2 |A|):

    d(1/Phi_r)/d(|D'| t) = (sqrt2 / gamma_r) w (1/Phi - 1/Phi_r),   w = (1 + c)^2 / 4,   c = -A:D'/(|A| |D'|).

A large turn leaves A about against the new shear (w = 0.004 right after 150 degrees), so Phi_r holds the packing at
the turn until A turns over: Phi - Phi_r is the compaction since the turn, and it resets with each turn (no state
outlives a cycle: in steady flow c = 1, Phi_r = Phi, g = 1, Eq. 13). A small turn leaves Phi_r following (w = 0.87
right after 30 degrees). w is smooth in A (a kink would cost the integrator its order).
k = 0 is Eq. 13. Objective (scalars of the state and of D'), rate independent, bounded and dissipative as
"compaction" (``docs/model.md``).
"""

import math

import numpy as np

from ..jit import jit
from ..tensors import double_dot
from . import compaction
from .compaction import reference_start, removal, set_packing, start
from .memory import reference_neutral
from .parameter import Parameter

NAME = "turn_compaction"
PARAMETERS = (
    Parameter("turn_gain", 0.0, 50.0, 0.0, 500.0, "k: the recovery stops where the packing is 1/k denser than at "
              "the turn"),
    Parameter("turn_strain", 0.5, 0.05, 1e-3, 5.0, "gamma_r: the nominal shear strain over which the packing at "
              "the turn follows the packing once the fabric is aligned with the shear"),
)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"turn-slow": {"turn_gain": 100.0, "turn_strain": 0.5},
            "turn-fast": {"turn_gain": 400.0, "turn_strain": 0.02}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"turn_gain": 100.0, "turn_strain": 0.05}
SPEED_EXAMPLE = {"turn_gain": 190.0, "turn_strain": 0.05}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = True
STATE = compaction.STATE
STATE_BOUNDS = compaction.STATE_BOUNDS

__all__ = ["reference_start", "removal", "set_packing", "start"]


@jit
def alignment(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23):
    """w = (1 + c)^2 / 4, c = -A:D'/(|A| |D'|), D' given as the unit Dh: 1 for the steady fabric, 1/4 for A = 0."""
    a33 = -a11 - a22
    norm = math.sqrt(a11 * a11 + a22 * a22 + a33 * a33 + 2.0 * (a12 * a12 + a13 * a13 + a23 * a23))
    if norm == 0.0:
        return 0.25
    c = -double_dot(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23) / norm
    return 0.25 * (1.0 + c) * (1.0 + c)


@jit
def state_rates(y, Dh, Wn, p, g, c2, out, scale, first, own):
    """du/d(|D'| t) (Eq. 18: -g u + c2, g and c2 as ``model.equations.fabric_rates`` gives them) and du_r/d(|D'| t),
    times ``scale``, into ``out[first:first + 2]``."""
    u, u_ref = y[first], y[first + 1]
    w = alignment(y[0], y[1], y[2], y[3], y[4], Dh[0], Dh[1], Dh[2], Dh[3], Dh[4], Dh[5])
    out[first] = scale * (c2 - g * u)
    out[first + 1] = scale * math.sqrt(2.0) / p[own + 1] * w * (u - u_ref)


def reference_state_rate(X, A, phi, L, values):
    """d(1/Phi_r)/dt (``model.reference``)."""
    D = 0.5 * (L + L.T)
    Dd = D - np.trace(D) * np.eye(3) / 3
    nD = np.linalg.norm(Dd)
    nA = np.linalg.norm(A)
    c = -float(np.sum(A * Dd)) / (nA * nD) if nA > 0 else 0.0
    w = 0.25 * (1.0 + c) ** 2
    return np.array([math.sqrt(2.0) / values["turn_strain"] * w * (1.0 / phi - X[0]) * nD])


def reference_removal(A, Dh, values, X, phi):
    """A - (1 - g) N on 3x3 tensors (``model.reference``: its own state X = (1/Phi_r,) and its Phi)."""
    g = min(1.0, max(0.0, 1.0 - values["turn_gain"] * (phi - 1.0 / X[0])))
    return A - (1.0 - g) * reference_neutral(A, Dh)
