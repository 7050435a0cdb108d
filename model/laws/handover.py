"""The "handover" law: the "elastic_compaction" law, but the part of the elastic fabric K that the new D' neither
compresses nor stretches is handed to A instead of unloading with the rest of K. After a reversal that part is zero
and the law is "elastic_compaction"; after a turn the contact budget shows the contacts about neutral to the new shear
keeping their part of the old fabric, in the strong network, while those the turn stretches unload
(``docs/results/budget.md``): the elastic part unloads only where D' loads, and what it held elsewhere becomes
fabric that Eq. 13's recovery (held back by compaction) removes:

    K_jaumann = (sqrt2 / gamma_e) (kappa D'/|D'| - K) |D'|,
    A gains (sqrt2 / gamma_e) N(K) |D'| beside its spin,  N(K) = K - dev(P K P),  P = 2 D'D'/|D'|^2,

so A + K keeps N(K) while K relaxes (N(kappa D'/|D'|) = 0: K's relaxation to its steady value is untouched), and
beta2 |D'| removes A - (1 - g) N(A) as in "compaction". kappa = 0 is the "compaction" law, both kappa and k zero
Eq. 13. Objective (N is an isotropic function of K and D'), rate independent (rates per unit strain), bounded (the
handed part is at most |kappa|, which A's recovery then removes) and dissipative as Eq. 13 (Eqs. 14 and 18 stay).
"""

import math

import numpy as np

from ..jit import jit
from . import compaction, elastic
from . import elastic_compaction as places
from .memory import neutral_part, reference_neutral

NAME = "handover"
#: the laws it joins, whose parameters it owns in this order
JOINS = (elastic.NAME, compaction.NAME)
PARAMETERS = elastic.PARAMETERS + compaction.PARAMETERS
#: the law's own state: K packed, then 1/Phi and 1/Phi_r (``elastic_compaction``'s places)
STATE = places.STATE


@jit
def extra_rate(y, d11, d22, d33, d12, d13, d23, p):
    """(sqrt2 / gamma_e) N(K), per unit |D'| t: what K hands to A."""
    first = places.ELASTIC_FIRST
    c = math.sqrt(2.0) / p[places.ELASTIC_OWN + 1]
    q11, q22, q12, q13, q23 = neutral_part(y[first], y[first + 1], y[first + 2], y[first + 3], y[first + 4],
                                           d11, d22, d33, d12, d13, d23)
    return c * q11, c * q22, c * q12, c * q13, c * q23


start = places.start
reference_start = places.reference_start
reference_fabric = places.reference_fabric
reference_removal = places.reference_removal
reference_state_rate = places.reference_state_rate


def reference_extra(A, Dh, values, X):
    """(sqrt2 / gamma_e) N(K) on 3x3 tensors (``model.reference``)."""
    return np.sqrt(2.0) / values["elastic_strain"] * reference_neutral(elastic.reference_fabric(X[:9]), Dh)
