"""The "loading" law: beta2 |D'| removes each part of A by how D' loads it, R = A - 2 chi (A - Q), Q = dev(E A + A E),
E = Dh Dh (``docs/model.md``).

In the frame of a simple shear's D' (tensile t, compressive c, neutral v directions) Q keeps the t-c part of A, halves
the parts that couple v to t or c (which D' neither compresses nor stretches) and keeps a third of dev(v v): R removes
them by the factors 1, 1 - chi and 1 - 4 chi / 3. chi = 0 is Eq. 13; A stays bounded for chi < 3/4.
"""

import numpy as np

from ..jit import jit
from .parameter import Parameter

NAME = "loading"
PARAMETERS = (Parameter("chi", 0.0, 0.0, -0.5, 0.7, "the removal of a part of A that D' does not load, less by this "
                        "fraction"),)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"loading+": {"chi": 0.4}, "loading-": {"chi": -0.3}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {"chi": 0.35}
SPEED_EXAMPLE = {"chi": 0.45}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = True


@jit
def stretching_square(d11, d22, d33, d12, d13, d23):
    """E = Dh Dh packed (11, 22, 33, 12, 13, 23); for a simple shear's D', 2E projects on the plane of the shear
    (its tensile and compressive directions)."""
    return (d11 * d11 + d12 * d12 + d13 * d13, d12 * d12 + d22 * d22 + d23 * d23, d13 * d13 + d23 * d23 + d33 * d33,
            d11 * d12 + d12 * d22 + d13 * d23, d11 * d13 + d12 * d23 + d13 * d33, d12 * d13 + d22 * d23 + d23 * d33)


@jit
def removal(y, a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23, p, s, q):
    """R = A - 2 chi (A - Q), packed (11, 22, 12, 13, 23); chi at ``p[q]``."""
    a33 = -a11 - a22
    e11, e22, e33, e12, e13, e23 = stretching_square(d11, d22, d33, d12, d13, d23)
    x = a11 * e11 + a22 * e22 + a33 * e33 + 2.0 * (a12 * e12 + a13 * e13 + a23 * e23)
    q11 = 2.0 * (e11 * a11 + e12 * a12 + e13 * a13) - 2.0 * x / 3.0
    q22 = 2.0 * (e12 * a12 + e22 * a22 + e23 * a23) - 2.0 * x / 3.0
    q12 = e11 * a12 + e12 * a22 + e13 * a23 + a11 * e12 + a12 * e22 + a13 * e23
    q13 = e11 * a13 + e12 * a23 + e13 * a33 + a11 * e13 + a12 * e23 + a13 * e33
    q23 = e12 * a13 + e22 * a23 + e23 * a33 + a12 * e13 + a22 * e23 + a23 * e33
    f = 2.0 * p[q]
    return (a11 - f * (a11 - q11), a22 - f * (a22 - q22), a12 - f * (a12 - q12), a13 - f * (a13 - q13),
            a23 - f * (a23 - q23))


def reference_removal(A, Dh, values, X, phi):
    """R on 3x3 tensors (plain numpy)."""
    E = Dh @ Dh
    Q = E @ A + A @ E
    Q -= np.trace(Q) * np.eye(3) / 3
    return A - 2 * values["chi"] * (A - Q)
