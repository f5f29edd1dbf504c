"""Three-vectors as tuples (x, y, z) for compiled code: Numba keeps them in registers."""
from __future__ import annotations

import math

from .jit import jit


@jit
def add(a, b):
    """a + b."""
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@jit
def sub(a, b):
    """a - b."""
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@jit
def mul(a, s):
    """a scaled by the number s."""
    return (a[0] * s, a[1] * s, a[2] * s)


@jit
def madd(a, s, b):
    """a + s b."""
    return (a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2])


@jit
def vmul(a, b):
    """The component-wise product."""
    return (a[0] * b[0], a[1] * b[1], a[2] * b[2])


@jit
def mean3(a):
    """The mean of the three components."""
    return (a[0] + a[1] + a[2]) / 3.0


@jit
def neg(a):
    """-a."""
    return (-a[0], -a[1], -a[2])


@jit
def dot(a, b):
    """The dot product."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jit
def cross(a, b):
    """The cross product."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jit
def length(a):
    """The Euclidean length."""
    return math.sqrt(dot(a, a))


@jit
def normalize(a):
    """a scaled to unit length (a zero vector stays zero)."""
    n = length(a)
    return mul(a, 1.0 / n) if n > 0.0 else a


@jit
def mat_vec(m, a):
    """m a for a 3 x 3 matrix m."""
    return (m[0, 0] * a[0] + m[0, 1] * a[1] + m[0, 2] * a[2],
            m[1, 0] * a[0] + m[1, 1] * a[1] + m[1, 2] * a[2],
            m[2, 0] * a[0] + m[2, 1] * a[1] + m[2, 2] * a[2])


@jit
def row(array, i):
    """Row i of an (n, 3) array as a vector."""
    return (array[i, 0], array[i, 1], array[i, 2])


@jit
def store(array, i, a):
    """Write the vector a into row i of an (n, 3) array."""
    array[i, 0] = a[0]
    array[i, 1] = a[1]
    array[i, 2] = a[2]


@jit
def max3(a):
    """The largest component."""
    return max(a[0], max(a[1], a[2]))


@jit
def finite_row(array, i):
    """Whether row i of an (n, 3) array is finite (no NaN or Inf)."""
    return math.isfinite(array[i, 0]) and math.isfinite(array[i, 1]) and math.isfinite(array[i, 2])
