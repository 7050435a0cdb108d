"""The "elastic_compaction" law: the "elastic" law's jump over a finite strain and the "compaction" law's recovery held
back while the packing stays compacted, together. They act on different strains after a change of direction (the
jump within gamma_e ~ 0.01, the memory over 0.1-0.4; ``docs/results/models.md``) and on different parts of the
fabric (K, a part following D'/|D'|; N, the part of A that D' does not load), so each keeps its own parameters,
state and meaning:

    fabric = A + K,   K_jaumann = (sqrt2 / gamma_e) (kappa D'/|D'| - K) |D'|          ("elastic")
    beta2 |D'| removes A - (1 - g) N,   g = min(1, max(0, 1 - k (Phi - Phi_r)))        ("compaction")

kappa = 0 is the "compaction" law, k = 0 the "elastic" law, both zero Eq. 13. Objective, rate independent, bounded
and dissipative as each of the two is (``docs/model.md``).
"""

import numpy as np

from . import compaction, elastic
from .parameter import OWN

NAME = "elastic_compaction"
#: the laws it joins, whose parameters it owns in this order
JOINS = (elastic.NAME, compaction.NAME)
PARAMETERS = elastic.PARAMETERS + compaction.PARAMETERS
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"elastic_compaction": {"elastic_fabric": -0.013, "elastic_strain": 0.01, "compaction_gain": 190.0,
                                   "compaction_strain": 0.8}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {**elastic.FIT_EXAMPLE, **compaction.FIT_EXAMPLE}
SPEED_EXAMPLE = {**elastic.SPEED_EXAMPLE, **compaction.SPEED_EXAMPLE}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = False
#: the law's own state: K packed, then 1/Phi and 1/Phi_r
STATE = elastic.STATE + compaction.STATE
#: the material-point update's tolerance on each (``model.laws.state_tolerance``)
STATE_TOLERANCE = elastic.STATE_TOLERANCE + (1.0,) * len(compaction.STATE)
STATE_BOUNDS = elastic.STATE_BOUNDS + compaction.STATE_BOUNDS
#: where each part's state and parameters sit (``model.laws`` hands them to the two laws' kernels)
ELASTIC_FIRST, ELASTIC_OWN = elastic.FIRST, OWN
COMPACTION_FIRST, COMPACTION_OWN = elastic.FIRST + len(elastic.STATE), OWN + len(elastic.PARAMETERS)
_K = len(elastic.STATE)
#: K's size in the reference's own state (3x3, flattened), before 1/Phi_r
_K_FLAT = 9


def start(Dh, phi, values):
    """Where a history starts: K = kappa D'/|D'| of its first segment and (1/Phi, 1/Phi)."""
    K, k_state = elastic.start(Dh, phi, values)
    _, u_state = compaction.start(Dh, phi, values)
    shape = np.broadcast_shapes(k_state.shape[:-1], u_state.shape[:-1])
    K = np.broadcast_to(K, shape + (3, 3))
    return K, np.concatenate([np.broadcast_to(k_state, shape + (_K,)), u_state], axis=-1)


def reference_start(Dh, phi, values):
    """The reference's own state where a history starts: K (3x3 flattened), then 1/Phi_r."""
    return np.concatenate([elastic.reference_start(Dh, phi, values), compaction.reference_start(Dh, phi, values)])


def reference_fabric(X):
    """The part of the fabric the reference's own state holds: K."""
    return elastic.reference_fabric(X[:_K_FLAT])


def reference_removal(A, Dh, values, X, phi):
    """A - (1 - g) N on 3x3 tensors (``model.reference``)."""
    return compaction.reference_removal(A, Dh, values, X[_K_FLAT:], phi)


def reference_state_rate(X, A, phi, L, values):
    """dK/dt (flattened) and d(1/Phi_r)/dt (``model.reference``)."""
    return np.concatenate([elastic.reference_state_rate(X[:_K_FLAT], A, phi, L, values),
                           compaction.reference_state_rate(X[_K_FLAT:], A, phi, L, values)])
