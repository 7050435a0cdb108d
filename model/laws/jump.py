"""The "jump" law: a part of the fabric, kappa D'/|D'|, follows D' at once; the fabric of Eqs. 14 and 18 is the state A
(which follows Eq. 13) plus kappa D'/|D'| (``docs/model.md``). kappa = 0 is Eq. 13."""

from ..jit import jit
from .parameter import OWN, Parameter

NAME = "jump"
PARAMETERS = (Parameter("jump_fabric", 0.0, 0.0, -0.1, 0.1, "the fabric is the state A plus this times D'/|D'|"),)
KAPPA = OWN


@jit
def offset(p):
    return p[KAPPA]


def reference_offset(values):
    return values["jump_fabric"]
