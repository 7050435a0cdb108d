"""The "compacted_memory" law: the part of A the new shear does not load, N (the "memory" law's), lost at a rate of
its own that the compaction since the turn slows, as the DEM loses it. In the paper cell's contact budget the old
direction's normal part decays first order after every turn, at a rate r per unit strain that falls linearly with
the packing's rise since the turn, r = r0 (1 - k dPhi): 12-17 after 30 degrees (dPhi 0.0004), 9 after 90 (0.0045),
5-6 after 120 (0.007), 3 after 150 (0.0105), over 0.02-0.2 strain; r0 = 14 and k = 80 are read off these
(``docs/results/models.md``), where Eq. 13's recovery of N follows S instead (slow, then fast, then gone). Here a
share s of N leaves beta2's removal and is removed at that rate:

    beta2 |D'| removes A - s N,   and besides   - s sqrt2 r0 g N |D'|,   g = max(0, 1 - k (Phi - Phi_r)),

Phi Eq. 18's packing fraction and Phi_r the packing at the turn as "turn_compaction" holds it (it follows Phi over
gamma_r once A is aligned as the shear aligns it). sqrt2 turns the rate per unit strain into one per unit |D'| t.
s = 0 is Eq. 13. Objective (scalars of the state and N, built from A and D'), rate independent (per unit strain),
bounded (each term only removes N, at a rate 0 <= g r0) and dissipative as "memory" (``docs/model.md``).
"""

import math

from ..jit import jit
from . import compaction, turn_compaction
from .compaction import reference_start, set_packing, start
from .memory import neutral_part, reference_neutral
from .parameter import Parameter

NAME = "compacted_memory"
#: where r0 and k were read (the paper cell's budget, ``make budget PRESET=paper``)
RATE_READ = ("docs/results/models.md: the paper cell's memory fraction decays at r = r0 (1 - k dPhi) per unit strain "
             "after 30, 90, 120 and 150 degrees")
PARAMETERS = (
    Parameter("compaction_slowing", 0.0, 80.0, 0.0, 500.0, "k: the loss stops where the packing is 1/k denser than "
              "at the turn", measured=RATE_READ),
    Parameter("turn_strain", 0.5, 0.05, 1e-3, 5.0, "gamma_r: the nominal shear strain over which the packing at "
              "the turn follows the packing once the fabric is aligned with the shear"),
    Parameter("memory_share", 0.0, 0.5, 0.0, 1.0, "the share of the part D' does not load taken from beta2's "
              "removal"),
    Parameter("memory_loss", 0.0, 14.0, 0.0, 1e3, "r0: ... and lost instead at this rate per unit strain, "
              "uncompacted", measured=RATE_READ),
)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"compacted-all": {"compaction_slowing": 80.0, "turn_strain": 0.3, "memory_share": 1.0,
                              "memory_loss": 14.0},
            "compacted-half-fast": {"compaction_slowing": 300.0, "turn_strain": 0.02, "memory_share": 0.5,
                                    "memory_loss": 40.0}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"compaction_slowing": 80.0, "turn_strain": 0.1, "memory_share": 0.7, "memory_loss": 14.0}
SPEED_EXAMPLE = EXAMPLES["compacted-all"]
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = True
STATE = compaction.STATE
STATE_BOUNDS = compaction.STATE_BOUNDS

__all__ = ["reference_start", "set_packing", "start"]

state_rates = turn_compaction.state_rates


@jit
def removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s, q):
    """A - s N (s at ``p[q + 2]``)."""
    share = p[q + 2]
    n11, n22, n12, n13, n23 = neutral_part(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    return a11 - share * n11, a22 - share * n22, a12 - share * n12, a13 - share * n13, a23 - share * n23


@jit
def extra_rate(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s, q):
    """-s sqrt2 r0 g N, g = max(0, 1 - k (Phi - Phi_r)) with 1/Phi, 1/Phi_r at ``y[s]``, ``y[s + 1]``."""
    g = max(0.0, 1.0 - p[q] * (1.0 / y[s] - 1.0 / y[s + 1]))
    rate = p[q + 2] * math.sqrt(2.0) * p[q + 3] * g
    n11, n22, n12, n13, n23 = neutral_part(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    return -(rate * n11), -(rate * n22), -(rate * n12), -(rate * n13), -(rate * n23)


def reference_removal(A, Dh, values, X, phi):
    return A - values["memory_share"] * reference_neutral(A, Dh)


def reference_extra(A, Dh, values, X, phi):
    """-s sqrt2 r0 g N (``model.reference``: its own state X = (1/Phi_r,) and its Phi)."""
    g = max(0.0, 1.0 - values["compaction_slowing"] * (phi - 1.0 / X[0]))
    return -values["memory_share"] * math.sqrt(2.0) * values["memory_loss"] * g * reference_neutral(A, Dh)


def reference_state_rate(X, A, phi, L, values):
    """d(1/Phi_r)/dt as "turn_compaction"'s (``model.reference``)."""
    return turn_compaction.reference_state_rate(X, A, phi, L, values)

