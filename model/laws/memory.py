"""The "memory" law: the part of A that D' neither compresses nor stretches, N = A - dev(P A P) with P = 2 Dh Dh (for a
simple shear's D', the couplings of the neutral direction with the plane of the shear and two thirds of dev(v v)),
is taken out of beta2's removal in the share ``memory_share`` and removed instead at ``memory_rate`` per unit |D'| t
(``docs/model.md``). memory_share = 0 is Eq. 13.
"""

import numpy as np

from ..jit import jit
from .parameter import Parameter

NAME = "memory"
PARAMETERS = (
    Parameter("memory_share", 0.0, 0.5, 0.0, 1.0, "the share of the part D' does not load taken from beta2's removal"),
    Parameter("memory_rate", 0.0, 5.0, 0.0, 1e3, "... and removed instead at this rate per unit |D'| t"),
)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"memory-slow": {"memory_share": 1.0, "memory_rate": 3.0},
            "memory-half-fast": {"memory_share": 0.5, "memory_rate": 40.0}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"memory_share": 0.6, "memory_rate": 8.0}
SPEED_EXAMPLE = {"memory_share": 0.45, "memory_rate": 5.0}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = True


@jit
def neutral_part(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23):
    """N = A - dev(P A P), P = 2 Dh Dh, packed (11, 22, 12, 13, 23); zero for a fabric in the plane of the shear (a
    reversal's)."""
    a33 = -a11 - a22
    p11 = 2.0 * (d11 * d11 + d12 * d12 + d13 * d13)
    p22 = 2.0 * (d12 * d12 + d22 * d22 + d23 * d23)
    p33 = 2.0 * (d13 * d13 + d23 * d23 + d33 * d33)
    p12 = 2.0 * (d11 * d12 + d12 * d22 + d13 * d23)
    p13 = 2.0 * (d11 * d13 + d12 * d23 + d13 * d33)
    p23 = 2.0 * (d12 * d13 + d22 * d23 + d23 * d33)
    b00 = a11 * p11 + a12 * p12 + a13 * p13
    b01 = a11 * p12 + a12 * p22 + a13 * p23
    b02 = a11 * p13 + a12 * p23 + a13 * p33
    b10 = a12 * p11 + a22 * p12 + a23 * p13
    b11 = a12 * p12 + a22 * p22 + a23 * p23
    b12 = a12 * p13 + a22 * p23 + a23 * p33
    b20 = a13 * p11 + a23 * p12 + a33 * p13
    b21 = a13 * p12 + a23 * p22 + a33 * p23
    b22 = a13 * p13 + a23 * p23 + a33 * p33
    m11 = p11 * b00 + p12 * b10 + p13 * b20
    m22 = p12 * b01 + p22 * b11 + p23 * b21
    m33 = p13 * b02 + p23 * b12 + p33 * b22
    m12 = p11 * b01 + p12 * b11 + p13 * b21
    m13 = p11 * b02 + p12 * b12 + p13 * b22
    m23 = p12 * b02 + p22 * b12 + p23 * b22
    third = (m11 + m22 + m33) / 3.0
    return a11 - (m11 - third), a22 - (m22 - third), a12 - m12, a13 - m13, a23 - m23


@jit
def removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s, q):
    """A - memory_share N (memory_share, memory_rate at ``p[q]``, ``p[q + 1]``)."""
    share = p[q]
    q11, q22, q12, q13, q23 = neutral_part(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    return a11 - share * q11, a22 - share * q22, a12 - share * q12, a13 - share * q13, a23 - share * q23


@jit
def extra_rate(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s, q):
    """-memory_share memory_rate N."""
    rate = p[q] * p[q + 1]
    q11, q22, q12, q13, q23 = neutral_part(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23)
    return -(rate * q11), -(rate * q22), -(rate * q12), -(rate * q13), -(rate * q23)


def reference_neutral(A, Dh):
    """N on 3x3 tensors (plain numpy)."""
    P = 2 * Dh @ Dh
    M = P @ A @ P
    return A - (M - np.trace(M) * np.eye(3) / 3)


def reference_removal(A, Dh, values, X, phi):
    return A - values["memory_share"] * reference_neutral(A, Dh)


def reference_extra(A, Dh, values):
    return -values["memory_share"] * values["memory_rate"] * reference_neutral(A, Dh)
