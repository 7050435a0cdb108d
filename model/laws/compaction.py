"""The "compaction" law: Eq. 13's recovery of the part of A that D' neither compresses nor stretches held back while
the packing is denser than in its recent past (the DEM keeps the old direction's part normal to the new shear after
a large turn as long as the packing compacted by the turn stays dense; ``docs/results/budget.md``, ``docs/model.md``).
beta2 |D'| removes A - (1 - g) N in place of A, N = A - dev(P A P) the part D' does not load (the "memory" law's;
zero in a reversal, where A stays in the plane of the shear), with the gate

    g = min(1, max(0, 1 - k (Phi - Phi_r))),

Phi the packing fraction of Eq. 18 and Phi_r its recent past: 1/Phi_r follows 1/Phi over a nominal shear strain
gamma_r (d(1/Phi_r)/d(|D'| t) = (sqrt2 / gamma_r) (1/Phi - 1/Phi_r)). In steady flow Phi_r = Phi and g = 1 (Eq. 13);
after a turn Eq. 18 compacts the packing (A:D' < 0), Phi rises above Phi_r and N's recovery slows, until Phi_r
catches up or the packing dilates back. k = 0 is Eq. 13. The gate is a scalar of the state (objective), the rates
are per unit strain (rate independent), and 0 <= g <= 1 only slows a removal Eq. 13 makes (bounded).

The kernels carry the law's state as u = 1/Phi (integrated by Eq. 18 beside the closed form of ``model.integrator``)
and u_r = 1/Phi_r; u is set from the packing fraction where a history or a step starts (``set_packing``).
"""

import math

import numpy as np

from ..jit import jit
from .memory import neutral_part, reference_neutral
from .parameter import Parameter

NAME = "compaction"
PARAMETERS = (
    Parameter("compaction_gain", 0.0, 50.0, 0.0, 500.0, "k: the recovery stops where the packing is 1/k denser "
              "than its recent past"),
    Parameter("compaction_strain", 0.5, 0.5, 0.01, 5.0, "gamma_r: the nominal shear strain over which the recent "
              "past follows the packing"),
)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"compaction-slow": {"compaction_gain": 100.0, "compaction_strain": 0.5},
            "compaction-fast": {"compaction_gain": 400.0, "compaction_strain": 0.05}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"compaction_gain": 100.0, "compaction_strain": 0.3}
SPEED_EXAMPLE = {"compaction_gain": 190.0, "compaction_strain": 0.8}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = True
#: the law's own state: 1/Phi and 1/Phi_r
STATE = ("u", "u_ref")
#: the bounds of each state variable (``model.update`` refuses a state outside them): 1/Phi of a packing fraction in
#: (0, pi/(3 sqrt 2)), the densest packing of spheres
STATE_BOUNDS = ((3 * math.sqrt(2) / math.pi, math.inf),) * len(STATE)


@jit
def gate(y, p, first, own):
    """g = min(1, max(0, 1 - k (Phi - Phi_r))), the fraction of N's recovery the law keeps."""
    return min(1.0, max(0.0, 1.0 - p[own] * (1.0 / y[first] - 1.0 / y[first + 1])))


@jit
def removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, first, own):
    """A - (1 - g) N, packed (11, 22, 12, 13, 23)."""
    held = 1.0 - gate(y, p, first, own)
    q11, q22, q12, q13, q23 = neutral_part(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    return a11 - held * q11, a22 - held * q22, a12 - held * q12, a13 - held * q13, a23 - held * q23


@jit
def state_rates(y, Dh, Wn, p, g, c2, out, scale, first, own):
    """du/d(|D'| t) (Eq. 18: -g u + c2, g and c2 as ``model.equations.fabric_rates`` gives them) and du_r/d(|D'| t),
    times ``scale``, into ``out[first:first + 2]``."""
    u, u_ref = y[first], y[first + 1]
    out[first] = scale * (c2 - g * u)
    out[first + 1] = scale * math.sqrt(2.0) / p[own + 1] * (u - u_ref)


@jit
def set_packing(y, u, first, own):
    """The state's u where a history or a step starts at the packing fraction 1/u."""
    y[first] = u


def start(Dh, phi, values):
    """Where a history starts at the packing fraction ``phi`` (broadcast to the stack of ``Dh``): no part of the
    fabric, and (u, u_r) = (1/Phi, 1/Phi) (its recent past is itself: steady flow before the start)."""
    u = 1.0 / np.asarray(phi, dtype=float)
    shape = np.broadcast_shapes(np.shape(Dh)[:-2], u.shape)
    u = np.broadcast_to(u, shape)
    return np.zeros(shape + (3, 3)), np.stack([u, u], axis=-1)


def reference_start(Dh, phi, values):
    """The reference's own state where a history starts: (1/Phi_r,) (its Phi is the reference's own)."""
    return np.array([1.0 / phi])


def reference_removal(A, Dh, values, X, phi):
    """A - (1 - g) N on 3x3 tensors (``model.reference``: its own state X = (1/Phi_r,) and its Phi)."""
    g = min(1.0, max(0.0, 1.0 - values["compaction_gain"] * (phi - 1.0 / X[0])))
    return A - (1.0 - g) * reference_neutral(A, Dh)


def reference_state_rate(X, A, phi, L, values):
    """d(1/Phi_r)/dt (``model.reference``)."""
    D = 0.5 * (L + L.T)
    Dd = D - np.trace(D) * np.eye(3) / 3
    return np.array([math.sqrt(2.0) / values["compaction_strain"] * (1.0 / phi - X[0]) * np.linalg.norm(Dd)])
