"""The "compacted_memory" law: the part of A the new shear does not load, N (the "memory" law's), lost at a rate of
its own that the packing's compaction slows, as the DEM loses it. In the paper cell's contact budget the old
direction's normal part decays first order after every turn, at a rate r per unit strain that falls linearly with
the packing's rise over its steady value, r = r0 (1 - k dPhi): 12-13 after 30 degrees (dPhi 0.0004), 9 after 90
(0.0045), 5-6 after 120 (0.007), 3 after 150 (0.0105), over 0.05-0.2 strain; r0 = 14 and k = 80 are read off these
(``docs/results/models.md``), where Eq. 13's recovery of N follows S instead (slow, then fast, then gone). Here a
share s of N leaves beta2's removal and is removed at that rate:

    beta2 |D'| removes A - s N,   and besides   - s sqrt2 r0 g N |D'|,   g = max(0, 1 - k (Phi - Phi_ss)),

Phi Eq. 18's packing fraction and Phi_ss its value in steady flow without spin (the model's own: Eq. 13's steady
fabric A = -a D'/|D'|, S = 2a, in Eq. 18; a constant of the parameters), so the gate has no state that outlives a
turn. In simple shear the spin turns the steady fabric a little and Phi settles 0.0005 above (Table 2: 0.6399
against 0.6394), 4 % of the gate at k = 80. sqrt2 turns the rate per unit strain into one per unit |D'| t. s = 0
is Eq. 13. Objective (scalars of the parameters and the state, N built from A and D'), rate independent (per unit
strain), bounded (each term only removes N, at a rate g r0 >= 0) and dissipative as "memory" (``docs/model.md``).
"""

import math

import numpy as np

from ..equations import A1, A2, B1, B2, C1, C2_COEF, C2_EXP, C3, PHI_C
from ..jit import jit
from .memory import neutral_part, reference_neutral
from .parameter import Parameter

NAME = "compacted_memory"
#: where r0 and k were read (the paper cell's budget, ``make budget PRESET=paper``)
RATE_READ = ("docs/results/models.md: the paper cell's memory fraction decays at r = r0 (1 - k dPhi) per unit strain "
             "after 30, 90, 120 and 150 degrees")
PARAMETERS = (
    Parameter("compaction_slowing", 0.0, 80.0, 0.0, 500.0, "k: the loss stops where the packing is 1/k denser than "
              "in steady flow", measured=RATE_READ),
    Parameter("memory_loss", 0.0, 14.0, 0.0, 1e3, "r0: the rate per unit strain at which the part D' does not load "
              "is lost, at the steady packing", measured=RATE_READ),
    Parameter("memory_share", 0.0, 0.5, 0.0, 1.0, "the share of that part lost so instead of by beta2's removal"),
)
#: the Eq. 13 and Eq. 18 parameters the reference parts read beside the law's own (``model.laws.law.Part``)
MODEL_VALUES = ("a1", "b1", "a2", "b2", "c1", "c2_coef", "c2_exponent", "phi_c", "c3")
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"compacted-all": {"compaction_slowing": 80.0, "memory_loss": 14.0, "memory_share": 1.0},
            "compacted-half-fast": {"compaction_slowing": 300.0, "memory_loss": 40.0, "memory_share": 0.5}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"compaction_slowing": 80.0, "memory_loss": 14.0, "memory_share": 0.7}
SPEED_EXAMPLE = EXAMPLES["compacted-all"]
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = True
#: the law's own state: 1/Phi
STATE = ("u",)
#: 1/Phi of a packing fraction in (0, pi/(3 sqrt 2)), the densest packing of spheres
STATE_BOUNDS = ((3 * math.sqrt(2) / math.pi, math.inf),)


@jit
def steady_packing(a1, b1, a2, b2, c1, c2_coef, c2_exponent, phi_c, c3):
    """Phi_ss: Eq. 18 at rest on Eq. 13's steady fabric, A = -a D'/|D'| with S = 2a and beta1 = beta2 a, i.e.
    2 b2 a^2 + (a2 - 2 b1) a - a1 = 0 (its root in (0, 2/3))."""
    qa, qb, qc = 2.0 * b2, a2 - 2.0 * b1, -a1
    root = math.sqrt(qb * qb - 4.0 * qa * qc)
    a = (-qb - root) / (2.0 * qa) if qa != 0.0 else -qc / qb
    if not 0.0 < a < 2.0 / 3.0:
        a = (-qb + root) / (2.0 * qa)
    return phi_c + c3 - c1 * a / (c2_coef * (2.0 * a) ** c2_exponent)


@jit
def removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s, q):
    """A - s N (s at ``p[q + 2]``)."""
    share = p[q + 2]
    n11, n22, n12, n13, n23 = neutral_part(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    return a11 - share * n11, a22 - share * n22, a12 - share * n12, a13 - share * n13, a23 - share * n23


@jit
def extra_rate(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s, q):
    """-s sqrt2 r0 g N, g = max(0, 1 - k (Phi - Phi_ss)), 1/Phi at ``y[s]``."""
    steady = steady_packing(p[A1], p[B1], p[A2], p[B2], p[C1], p[C2_COEF], p[C2_EXP], p[PHI_C], p[C3])
    g = max(0.0, 1.0 - p[q] * (1.0 / y[s] - steady))
    rate = p[q + 2] * math.sqrt(2.0) * p[q + 1] * g
    n11, n22, n12, n13, n23 = neutral_part(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    return -(rate * n11), -(rate * n22), -(rate * n12), -(rate * n13), -(rate * n23)


@jit
def state_rates(y, Dh, Wn, p, g, c2, out, scale, first, own):
    """du/d(|D'| t) (Eq. 18: -g u + c2, g and c2 as ``model.equations.fabric_rates`` gives them), times ``scale``."""
    out[first] = scale * (c2 - g * y[first])


@jit
def set_packing(y, u, first, own):
    """The state's u where a history or a step starts at the packing fraction 1/u."""
    y[first] = u


def start(Dh, phi, values):
    """No part of the fabric, and u = 1/Phi (broadcast to the stack of ``Dh``)."""
    u = 1.0 / np.asarray(phi, dtype=float)
    shape = np.broadcast_shapes(np.shape(Dh)[:-2], u.shape)
    return np.zeros(shape + (3, 3)), np.broadcast_to(u, shape)[..., None].copy()


def reference_removal(A, Dh, values, X, phi):
    return A - values["memory_share"] * reference_neutral(A, Dh)


def reference_extra(A, Dh, values, X, phi):
    """-s sqrt2 r0 g N on 3x3 tensors (``model.reference``, on its own Phi)."""
    steady = steady_packing(*(values[name] for name in MODEL_VALUES))
    g = max(0.0, 1.0 - values["compaction_slowing"] * (phi - steady))
    return -values["memory_share"] * math.sqrt(2.0) * values["memory_loss"] * g * reference_neutral(A, Dh)
