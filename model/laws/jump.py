"""The "jump" law: a part of the fabric, kappa D'/|D'|, follows D' at once; the fabric of Eqs. 14 and 18 is the state A
(which follows Eq. 13) plus kappa D'/|D'| (``docs/model.md``). kappa = 0 is Eq. 13."""

from ..jit import jit
from .parameter import Parameter

NAME = "jump"
PARAMETERS = (Parameter("jump_fabric", 0.0, 0.0, -0.1, 0.1, "the fabric is the state A plus this times D'/|D'|"),)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"jump-": {"jump_fabric": -0.013}, "jump+": {"jump_fabric": 0.02}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"jump_fabric": -0.013}
SPEED_EXAMPLE = {"jump_fabric": -0.013}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = False


@jit
def offset(p, s, q):
    """kappa, at ``p[q]``."""
    return p[q]


def reference_offset(values):
    return values["jump_fabric"]
