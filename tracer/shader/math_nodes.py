"""Cycles' value nodes for shader programs: Math, Vector Math, Clamp, Map Range (float and
vector), Mapping and Separate/Combine XYZ (opcodes 100-199).

Each formula is a scalar function of floats and 3-tuples, copied from Blender 5.0's Cycles:
kernel/svm/math_util.h (svm_math, svm_vector_math), math.h, clamp.h, map_range.h, mapping.h,
mapping_util.h, sepcomb_vector.h, and the helpers of util/math_base.h, util/math_float3.h and
util/transform.h (safe_divide, safe_powf, wrapf, pingpongf, smoothminf, euler_to_transform, ...).
Cycles evaluates in float32, Snell in float64: the formulas are the same, the rounding is finer.

Enums (the Math operation, ...) are literal ints in a row: their order is defined here, by the
Blender identifiers, and the exporter (addon/export/shader/math_nodes.py) maps names to it.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import jit
from ..vec import add, cross, dot, mul, neg, normalize, sub, vmul  # normalize: safe_normalize
from .closures import vector as _load3
from .inputs import store3 as _store3

MATH = 100              # Math: one operation of Value, Value_001, Value_002 (clamped to [0, 1])
VECTOR_MATH = 101       # Vector Math: one operation, a Value and a Vector output
CLAMP = 102             # Clamp: Min Max or Range
MAP_RANGE = 103         # Map Range (float): value, from/to ranges and steps gathered in 2 vectors
VECTOR_MAP_RANGE = 104  # Map Range (vector): the factor of each component
VECTOR_MAP_APPLY = 105  # Map Range (vector): to_min + factor (to_max - to_min), clamped
MAPPING = 106           # Mapping: Point, Texture, Vector or Normal
SEPARATE_XYZ = 107      # Separate XYZ
COMBINE_XYZ = 108       # Combine XYZ

# Blender's identifiers, in the order of the literal int in a row.
MATH_OPERATIONS = (
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM", "SQRT",
    "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN", "GREATER_THAN",
    "SIGN", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "ROUND", "FLOOR", "CEIL", "TRUNC", "FRACT",
    "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG", "SINE", "COSINE", "TANGENT",
    "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH", "COSH", "TANH", "RADIANS",
    "DEGREES")
VECTOR_MATH_OPERATIONS = (
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT", "PROJECT",
    "REFLECT", "REFRACT", "FACEFORWARD", "DOT_PRODUCT", "DISTANCE", "LENGTH", "SCALE",
    "NORMALIZE", "ABSOLUTE", "POWER", "SIGN", "MINIMUM", "MAXIMUM", "FLOOR", "CEIL", "FRACTION",
    "MODULO", "WRAP", "SNAP", "SINE", "COSINE", "TANGENT")
CLAMP_TYPES = ("MINMAX", "RANGE")
MAP_RANGE_TYPES = ("LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP")
MAPPING_TYPES = ("POINT", "TEXTURE", "VECTOR", "NORMAL")

SPECS = {
    MATH: ("Math: operation i of a, b, c, clamped to [0, 1] if i", "iiffff-",
           {1: len(MATH_OPERATIONS), 2: 2}),
    VECTOR_MATH: ("Vector Math: operation i of a, b, c, scale to a value and a vector",
                  "ivvvffv", {1: len(VECTOR_MATH_OPERATIONS)}),
    CLAMP: ("Clamp: value between min and max (Range: either order)", "iffff--",
            {1: len(CLAMP_TYPES)}),
    MAP_RANGE: ("Map Range (float): (value, from_min, from_max), (to_min, to_max, steps)",
                "iivvf--", {1: len(MAP_RANGE_TYPES), 2: 2}),
    VECTOR_MAP_RANGE: ("Map Range (vector): the factor of value in [from_min, from_max]",
                       "ivvvvv-", {1: len(MAP_RANGE_TYPES)}),
    VECTOR_MAP_APPLY: ("Map Range (vector): to_min + factor (to_max - to_min), clamped",
                       "ivvvv--", {1: 2}),
    MAPPING: ("Mapping: vector transformed by location, rotation, scale", "ivvvvv-",
              {1: len(MAPPING_TYPES)}),
    SEPARATE_XYZ: ("Separate XYZ: a vector's components", "vfff---"),
    COMBINE_XYZ: ("Combine XYZ: a vector of three values", "fffv---"),
}

FLT_EPSILON = 1.1920928955078125e-07


# Operation numbers, for the formulas below (numba reads these module globals as constants).
(M_ADD, M_SUB, M_MUL, M_DIV, M_MADD, M_POW, M_LOG, M_SQRT, M_INVSQRT, M_ABS, M_EXP, M_MIN,
 M_MAX, M_LT, M_GT, M_SIGN, M_CMP, M_SMIN, M_SMAX, M_ROUND, M_FLOOR, M_CEIL, M_TRUNC, M_FRACT,
 M_MOD, M_FMOD, M_WRAP, M_SNAP, M_PINGPONG, M_SIN, M_COS, M_TAN, M_ASIN, M_ACOS, M_ATAN,
 M_ATAN2, M_SINH, M_COSH, M_TANH, M_RAD, M_DEG) = range(len(MATH_OPERATIONS))
(V_ADD, V_SUB, V_MUL, V_DIV, V_MADD, V_CROSS, V_PROJECT, V_REFLECT, V_REFRACT, V_FACEFORWARD,
 V_DOT, V_DISTANCE, V_LENGTH, V_SCALE, V_NORMALIZE, V_ABS, V_POW, V_SIGN, V_MIN, V_MAX, V_FLOOR,
 V_CEIL, V_FRACT, V_MOD, V_WRAP, V_SNAP, V_SIN, V_COS, V_TAN) = range(len(VECTOR_MATH_OPERATIONS))
CLAMP_MINMAX, CLAMP_RANGE = 0, 1
RANGE_LINEAR, RANGE_STEPPED, RANGE_SMOOTHSTEP, RANGE_SMOOTHERSTEP = 0, 1, 2, 3
MAPPING_POINT, MAPPING_TEXTURE, MAPPING_VECTOR, MAPPING_NORMAL = 0, 1, 2, 3


# --- util/math_base.h -------------------------------------------------------------------------

@jit
def clampf(a, lo, hi):
    """min(max(a, lo), hi), as Cycles' clamp."""
    return min(max(a, lo), hi)


@jit
def safe_divide(a, b):
    """a / b, 0 where b is 0."""
    return a / b if b != 0.0 else 0.0


@jit
def compatible_powf(x, y):
    """x^y with x^0 = 1 and 0^y = 0."""
    if y == 0.0:
        return 1.0
    if x == 0.0:
        return 0.0
    return math.pow(x, y)


@jit
def safe_powf(a, b):
    """a^b, 0 for a negative a and a non-integer b."""
    if a < 0.0 and b != np.trunc(b):
        return 0.0
    return compatible_powf(a, b)


@jit
def safe_logf(a, b):
    """log(a) / log(b), 0 where either is not positive."""
    if a <= 0.0 or b <= 0.0:
        return 0.0
    return safe_divide(math.log(a), math.log(b))


@jit
def safe_modulo(a, b):
    """C's fmod(a, b) (the sign of a), 0 where b is 0."""
    return np.fmod(a, b) if b != 0.0 else 0.0


@jit
def safe_floored_modulo(a, b):
    """a - floor(a / b) b (the sign of b), 0 where b is 0."""
    return a - np.floor(a / b) * b if b != 0.0 else 0.0


@jit
def wrapf(value, hi, lo):
    """value wrapped into [lo, hi)."""
    r = hi - lo
    return value - r * np.floor((value - lo) / r) if r != 0.0 else lo


@jit
def pingpongf(a, b):
    """a bounced back and forth between 0 and b."""
    if b == 0.0:
        return 0.0
    q = (a - b) / (b * 2.0)
    return abs((q - np.floor(q)) * b * 2.0 - b)


@jit
def smoothminf(a, b, k):
    """The polynomial smooth minimum of a and b over a distance k."""
    if k != 0.0:
        h = max(k - abs(a - b), 0.0) / k
        return min(a, b) - h * h * h * k * (1.0 / 6.0)
    return min(a, b)


@jit
def compatible_signf(f):
    """-1, 0 or 1."""
    if f == 0.0:
        return 0.0
    return -1.0 if f < 0.0 else 1.0


@jit
def inversesqrtf(f):
    """1 / sqrt(f), 0 where f is not positive."""
    return 1.0 / math.sqrt(f) if f > 0.0 else 0.0


@jit
def compatible_atan2(y, x):
    """atan2(y, x), 0 at the origin."""
    return 0.0 if (x == 0.0 and y == 0.0) else math.atan2(y, x)


@jit
def smoothstep(edge0, edge1, x):
    """Hermite smoothstep of x between edge0 and edge1 (0 below, 1 from edge1 on)."""
    if x < edge0:
        return 0.0
    if x >= edge1:
        return 1.0
    t = (x - edge0) / (edge1 - edge0)
    return (3.0 - 2.0 * t) * (t * t)


@jit
def smootherstep(edge0, edge1, x):
    """Perlin's smootherstep of x between edge0 and edge1 (map_range.h)."""
    x = clampf(safe_divide(x - edge0, edge1 - edge0), 0.0, 1.0)
    return x * x * x * (x * (x * 6.0 - 15.0) + 10.0)


# --- Math (math_util.h svm_math) ---------------------------------------------------------------

@jit
def math_op(op, a, b, c):
    """The Math node's operation op (an index of MATH_OPERATIONS) of a, b and c."""
    if op == M_ADD:
        return a + b
    elif op == M_SUB:
        return a - b
    elif op == M_MUL:
        return a * b
    elif op == M_DIV:
        return safe_divide(a, b)
    elif op == M_MADD:
        return a * b + c
    elif op == M_POW:
        return safe_powf(a, b)
    elif op == M_LOG:
        return safe_logf(a, b)
    elif op == M_SQRT:
        return math.sqrt(max(a, 0.0))
    elif op == M_INVSQRT:
        return inversesqrtf(a)
    elif op == M_ABS:
        return abs(a)
    elif op == M_EXP:
        return math.exp(a)
    elif op == M_MIN:
        return min(a, b)
    elif op == M_MAX:
        return max(a, b)
    elif op == M_LT:
        return 1.0 if a < b else 0.0
    elif op == M_GT:
        return 1.0 if a > b else 0.0
    elif op == M_SIGN:
        return compatible_signf(a)
    elif op == M_CMP:
        return 1.0 if (a == b or abs(a - b) <= max(c, FLT_EPSILON)) else 0.0
    elif op == M_SMIN:
        return smoothminf(a, b, c)
    elif op == M_SMAX:
        return -smoothminf(-a, -b, c)
    elif op == M_ROUND:
        return np.floor(a + 0.5)
    elif op == M_FLOOR:
        return np.floor(a)
    elif op == M_CEIL:
        return np.ceil(a)
    elif op == M_TRUNC:
        return np.floor(a) if a >= 0.0 else np.ceil(a)
    elif op == M_FRACT:
        return a - np.floor(a)
    elif op == M_MOD:
        return safe_modulo(a, b)
    elif op == M_FMOD:
        return safe_floored_modulo(a, b)
    elif op == M_WRAP:
        return wrapf(a, b, c)
    elif op == M_SNAP:
        return np.floor(safe_divide(a, b)) * b
    elif op == M_PINGPONG:
        return pingpongf(a, b)
    elif op == M_SIN:
        return math.sin(a)
    elif op == M_COS:
        return math.cos(a)
    elif op == M_TAN:
        return math.tan(a)
    elif op == M_ASIN:
        return math.asin(clampf(a, -1.0, 1.0))
    elif op == M_ACOS:
        return math.acos(clampf(a, -1.0, 1.0))
    elif op == M_ATAN:
        return math.atan(a)
    elif op == M_ATAN2:
        return compatible_atan2(a, b)
    elif op == M_SINH:
        return math.sinh(a)
    elif op == M_COSH:
        return math.cosh(a)
    elif op == M_TANH:
        return math.tanh(a)
    elif op == M_RAD:
        return a * (math.pi / 180.0)
    elif op == M_DEG:
        return a * (180.0 / math.pi)
    return 0.0


@jit
def math_node(op, use_clamp, a, b, c):
    """The Math node: math_op, clamped to [0, 1] when use_clamp (Cycles adds a Clamp node)."""
    r = math_op(op, a, b, c)
    return clampf(r, 0.0, 1.0) if use_clamp else r


# --- Vector Math (math_util.h svm_vector_math, util/math_float3.h) -----------------------------

@jit
def _fmod_trunc(a, b):
    # Cycles' SSE4.2 fmod: a - trunc(a / b) b, 0 where b is 0 (safe_fmod).
    return a - np.trunc(a / b) * b if b != 0.0 else 0.0


@jit
def _wrap_component(value, hi, lo):
    # wrap(): safe_floored_fmod(value - min, max - min) + min.
    r = hi - lo
    m = (value - lo) - np.floor((value - lo) / r) * r if r != 0.0 else 0.0
    return m + lo


@jit
def vector_math(op, a, b, c, scale):
    """The Vector Math node's operation op (an index of VECTOR_MATH_OPERATIONS): (value,
    vector); the output an operation does not write is 0."""
    zero = (0.0, 0.0, 0.0)
    if op == V_ADD:
        return 0.0, add(a, b)
    elif op == V_SUB:
        return 0.0, sub(a, b)
    elif op == V_MUL:
        return 0.0, vmul(a, b)
    elif op == V_DIV:
        return 0.0, (safe_divide(a[0], b[0]), safe_divide(a[1], b[1]), safe_divide(a[2], b[2]))
    elif op == V_MADD:
        return 0.0, (a[0] * b[0] + c[0], a[1] * b[1] + c[1], a[2] * b[2] + c[2])
    elif op == V_CROSS:
        return 0.0, cross(a, b)
    elif op == V_PROJECT:
        l2 = dot(b, b)
        return 0.0, (mul(b, dot(a, b) / l2) if l2 != 0.0 else zero)
    elif op == V_REFLECT:
        n = normalize(b)
        d = 2.0 * dot(a, n)
        return 0.0, (a[0] - d * n[0], a[1] - d * n[1], a[2] - d * n[2])
    elif op == V_REFRACT:
        n = normalize(b)
        d = dot(n, a)
        k = 1.0 - scale * scale * (1.0 - d * d)
        if k < 0.0:
            return 0.0, zero
        f = scale * d + math.sqrt(k)
        return 0.0, (scale * a[0] - f * n[0], scale * a[1] - f * n[1], scale * a[2] - f * n[2])
    elif op == V_FACEFORWARD:
        return 0.0, (a if dot(c, b) < 0.0 else neg(a))
    elif op == V_DOT:
        return dot(a, b), zero
    elif op == V_DISTANCE:
        d = sub(a, b)
        return math.sqrt(dot(d, d)), zero
    elif op == V_LENGTH:
        return math.sqrt(dot(a, a)), zero
    elif op == V_SCALE:
        return 0.0, mul(a, scale)
    elif op == V_NORMALIZE:
        return 0.0, normalize(a)
    elif op == V_ABS:
        return 0.0, (abs(a[0]), abs(a[1]), abs(a[2]))
    elif op == V_POW:
        return 0.0, (safe_powf(a[0], b[0]), safe_powf(a[1], b[1]), safe_powf(a[2], b[2]))
    elif op == V_SIGN:
        return 0.0, (compatible_signf(a[0]), compatible_signf(a[1]), compatible_signf(a[2]))
    elif op == V_MIN:
        return 0.0, (min(a[0], b[0]), min(a[1], b[1]), min(a[2], b[2]))
    elif op == V_MAX:
        return 0.0, (max(a[0], b[0]), max(a[1], b[1]), max(a[2], b[2]))
    elif op == V_FLOOR:
        return 0.0, (np.floor(a[0]), np.floor(a[1]), np.floor(a[2]))
    elif op == V_CEIL:
        return 0.0, (np.ceil(a[0]), np.ceil(a[1]), np.ceil(a[2]))
    elif op == V_FRACT:
        return 0.0, (a[0] - np.floor(a[0]), a[1] - np.floor(a[1]), a[2] - np.floor(a[2]))
    elif op == V_MOD:
        return 0.0, (_fmod_trunc(a[0], b[0]), _fmod_trunc(a[1], b[1]), _fmod_trunc(a[2], b[2]))
    elif op == V_WRAP:
        return 0.0, (_wrap_component(a[0], b[0], c[0]), _wrap_component(a[1], b[1], c[1]),
                     _wrap_component(a[2], b[2], c[2]))
    elif op == V_SNAP:
        return 0.0, (np.floor(safe_divide(a[0], b[0])) * b[0],
                     np.floor(safe_divide(a[1], b[1])) * b[1],
                     np.floor(safe_divide(a[2], b[2])) * b[2])
    elif op == V_SIN:
        return 0.0, (math.sin(a[0]), math.sin(a[1]), math.sin(a[2]))
    elif op == V_COS:
        return 0.0, (math.cos(a[0]), math.cos(a[1]), math.cos(a[2]))
    elif op == V_TAN:
        return 0.0, (math.tan(a[0]), math.tan(a[1]), math.tan(a[2]))
    return 0.0, zero


# --- Clamp (clamp.h) and Map Range (map_range.h) ------------------------------------------------

@jit
def clamp_node(kind, value, lo, hi):
    """The Clamp node: Min Max clamps to [lo, hi]; Range also when lo > hi, to [hi, lo]."""
    if kind == CLAMP_RANGE and lo > hi:
        return clampf(value, hi, lo)
    return clampf(value, lo, hi)


@jit
def map_range(kind, use_clamp, value, from_min, from_max, to_min, to_max, steps):
    """The float Map Range node (svm_node_map_range; Clamp as the Range clamp Cycles adds)."""
    if from_max == from_min:
        result = 0.0
    else:
        factor = value
        if kind == RANGE_STEPPED:
            factor = (value - from_min) / (from_max - from_min)
            factor = np.floor(factor * (steps + 1.0)) / steps if steps > 0.0 else 0.0
        elif kind == RANGE_SMOOTHSTEP:
            factor = (1.0 - smoothstep(from_max, from_min, factor) if from_min > from_max
                      else smoothstep(from_min, from_max, factor))
        elif kind == RANGE_SMOOTHERSTEP:
            factor = (1.0 - smootherstep(from_max, from_min, factor) if from_min > from_max
                      else smootherstep(from_min, from_max, factor))
        else:
            factor = (value - from_min) / (from_max - from_min)
        result = to_min + factor * (to_max - to_min)
    if use_clamp:
        result = clamp_node(CLAMP_RANGE, result, to_min, to_max)
    return result


@jit
def map_range_factor(kind, value, from_min, from_max, steps):
    """One component's factor in the vector Map Range node (svm_node_vector_map_range)."""
    f = safe_divide(value - from_min, from_max - from_min)
    if kind == RANGE_STEPPED:
        return np.floor(f * (steps + 1.0)) / steps if steps > 0.0 else 0.0
    elif kind == RANGE_SMOOTHSTEP:
        f = clampf(f, 0.0, 1.0)
        return (3.0 - 2.0 * f) * (f * f)
    elif kind == RANGE_SMOOTHERSTEP:
        f = clampf(f, 0.0, 1.0)
        return f * f * f * (f * (f * 6.0 - 15.0) + 10.0)
    return f


@jit
def map_range_apply(use_clamp, factor, to_min, to_max):
    """One component of the vector Map Range's result: to_min + factor (to_max - to_min),
    clamped to the to-range when use_clamp (which Cycles ignores for the smooth steps: the
    exporter passes 0 for them)."""
    r = to_min + factor * (to_max - to_min)
    if use_clamp:
        r = clampf(r, to_max, to_min) if to_min > to_max else clampf(r, to_min, to_max)
    return r


# --- Mapping (mapping_util.h, util/transform.h euler_to_transform) ------------------------------

@jit
def euler_rows(r):
    """The rows of Cycles' euler_to_transform(r) (XYZ Euler angles), as three 3-tuples."""
    cx, cy, cz = math.cos(r[0]), math.cos(r[1]), math.cos(r[2])
    sx, sy, sz = math.sin(r[0]), math.sin(r[1]), math.sin(r[2])
    return ((cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz),
            (cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz),
            (-sy, cy * sx, cy * cx))


@jit
def mapping(kind, v, location, rotation, scale):
    """The Mapping node of vector v (svm_mapping)."""
    m = euler_rows(rotation)
    if kind == MAPPING_POINT:
        s = (v[0] * scale[0], v[1] * scale[1], v[2] * scale[2])
        return (dot(m[0], s) + location[0], dot(m[1], s) + location[1],
                dot(m[2], s) + location[2])
    elif kind == MAPPING_TEXTURE:
        d = (v[0] - location[0], v[1] - location[1], v[2] - location[2])
        # transform_direction_transposed: the columns of m
        t = (m[0][0] * d[0] + m[1][0] * d[1] + m[2][0] * d[2],
             m[0][1] * d[0] + m[1][1] * d[1] + m[2][1] * d[2],
             m[0][2] * d[0] + m[1][2] * d[1] + m[2][2] * d[2])
        return (safe_divide(t[0], scale[0]), safe_divide(t[1], scale[1]),
                safe_divide(t[2], scale[2]))
    elif kind == MAPPING_VECTOR:
        s = (v[0] * scale[0], v[1] * scale[1], v[2] * scale[2])
        return (dot(m[0], s), dot(m[1], s), dot(m[2], s))
    elif kind == MAPPING_NORMAL:
        s = (safe_divide(v[0], scale[0]), safe_divide(v[1], scale[1]),
             safe_divide(v[2], scale[2]))
        return normalize((dot(m[0], s), dot(m[1], s), dot(m[2], s)))
    return (0.0, 0.0, 0.0)


# --- the interpreter's side ---------------------------------------------------------------------

@jit
def execute(ins, regs, data):
    """Run one instruction of this family: read its inputs from regs, write its outputs."""
    op = ins[0]
    if op == MATH:
        regs[ins[6]] = math_node(ins[1], ins[2] != 0, regs[ins[3]], regs[ins[4]], regs[ins[5]])
    elif op == VECTOR_MATH:
        value, vector = vector_math(ins[1], _load3(regs, ins[2]), _load3(regs, ins[3]),
                                    _load3(regs, ins[4]), regs[ins[5]])
        regs[ins[6]] = value
        _store3(regs, ins[7], vector)
    elif op == CLAMP:
        regs[ins[5]] = clamp_node(ins[1], regs[ins[2]], regs[ins[3]], regs[ins[4]])
    elif op == MAP_RANGE:
        p, q = ins[3], ins[4]
        regs[ins[5]] = map_range(ins[1], ins[2] != 0, regs[p], regs[p + 1], regs[p + 2],
                                 regs[q], regs[q + 1], regs[q + 2])
    elif op == VECTOR_MAP_RANGE:
        kind, v, lo, hi, st, out = ins[1], ins[2], ins[3], ins[4], ins[5], ins[6]
        for k in range(3):
            regs[out + k] = map_range_factor(kind, regs[v + k], regs[lo + k], regs[hi + k],
                                             regs[st + k])
    elif op == VECTOR_MAP_APPLY:
        use_clamp, f, lo, hi, out = ins[1] != 0, ins[2], ins[3], ins[4], ins[5]
        for k in range(3):
            regs[out + k] = map_range_apply(use_clamp, regs[f + k], regs[lo + k], regs[hi + k])
    elif op == MAPPING:
        _store3(regs, ins[6], mapping(ins[1], _load3(regs, ins[2]), _load3(regs, ins[3]),
                                      _load3(regs, ins[4]), _load3(regs, ins[5])))
    elif op == SEPARATE_XYZ:
        v = ins[1]
        regs[ins[2]] = regs[v]
        regs[ins[3]] = regs[v + 1]
        regs[ins[4]] = regs[v + 2]
    elif op == COMBINE_XYZ:
        # read all three before writing: the output may overlap an input
        x, y, z = regs[ins[1]], regs[ins[2]], regs[ins[3]]
        _store3(regs, ins[4], (x, y, z))
