"""Compiled pieces of tensor algebra shared by the model's kernels, on symmetric traceless tensors packed as
(11, 22, 12, 13, 23) (the 33 component is -11 - 22)."""

from .jit import jit


@jit
def spin_rate(w12, w13, w23, a11, a22, a12, a13, a23):
    """W A - A W packed (11, 22, 12, 13, 23), W = [[0, w12, w13], [-w12, 0, w23], [-w13, -w23, 0]]: the part of a
    Jaumann rate that turns A with the material (2 sym(W A) for symmetric A)."""
    a33 = -a11 - a22
    m00 = w12 * a12 + w13 * a13
    m01 = w12 * a22 + w13 * a23
    m02 = w12 * a23 + w13 * a33
    m10 = -w12 * a11 + w23 * a13
    m11 = -w12 * a12 + w23 * a23
    m12 = -w12 * a13 + w23 * a33
    m20 = -w13 * a11 - w23 * a12
    m21 = -w13 * a12 - w23 * a22
    return 2.0 * m00, 2.0 * m11, m01 + m10, m02 + m20, m12 + m21


@jit
def double_dot(a11, a22, a12, a13, a23, d11, d22, d33, d12, d13, d23):
    """A:D for traceless A (A33 = -A11 - A22) and symmetric D."""
    return a11 * d11 + a22 * d22 - (a11 + a22) * d33 + 2.0 * (a12 * d12 + a13 * d13 + a23 * d23)
