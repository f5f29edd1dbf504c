"""Cycles' colour nodes for shader programs: Mix (float, vector, colour with every blend mode;
and the legacy MixRGB), Invert, Hue/Saturation/Value, Gamma, Bright/Contrast, Separate/Combine
Color (RGB, HSV, HSL), RGB to BW, Blackbody, Wavelength, Color Ramp, RGB Curves and Float Curve
(opcodes 200-299).

Formulas from Blender 5.0's Cycles: kernel/svm/color_util.h (svm_mix and its blend modes,
svm_brightness_contrast, svm_combine_color, svm_separate_color), mix.h, hsv.h, gamma.h and
math_util.h (svm_math_gamma_color, svm_math_blackbody_color_rec709,
svm_math_wavelength_color_xyz), brightness.h, invert.h, sepcomb_color.h, convert.h (RGB to BW),
blackbody.h, wavelength.h, ramp.h (rgb_ramp_lookup, float_ramp_lookup, svm_node_curves,
svm_node_curve), util/color.h (rgb_to_hsv, hsv_to_rgb, rgb_to_hsl, hsl_to_rgb); the tables of
kernel/tables.h. Ramps and curves are tables in the program's data, baked by the exporter as
Blender's Cycles sync bakes them (RAMP_TABLE_SIZE + 1 entries).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import jit
from .closures import vector as _load3
from .colorspace import RGB_TO_Y, XYZ_TO_REC709
from .inputs import store3 as _store3

MIX_COLOR = 200        # Mix (Color) and the legacy MixRGB: a blend mode of A and B
MIX_FLOAT = 201        # Mix (Float)
MIX_VECTOR = 202       # Mix (Vector), uniform factor
MIX_VECTOR_NONUNIFORM = 203  # Mix (Vector), a factor per component
INVERT = 204           # Invert
HUE_SAT = 205          # Hue/Saturation/Value
GAMMA = 206            # Gamma
BRIGHT_CONTRAST = 207  # Brightness/Contrast
SEPARATE_COLOR = 208   # Separate Color (RGB, HSV, HSL)
COMBINE_COLOR = 209    # Combine Color (RGB, HSV, HSL)
RGB_TO_BW = 210        # RGB to BW
BLACKBODY = 211        # Blackbody
WAVELENGTH = 212       # Wavelength
COLOR_RAMP = 213       # Color Ramp: a table of RGBA entries
RGB_CURVES = 214       # RGB Curves: min_x, max_x and a table of RGB entries
FLOAT_CURVE = 215      # Float Curve: min_x, max_x and a table of values

# Blender's identifiers, in the order of the literal int in a row.
BLEND_TYPES = ("MIX", "DARKEN", "MULTIPLY", "BURN", "LIGHTEN", "SCREEN", "DODGE", "ADD",
               "OVERLAY", "SOFT_LIGHT", "LINEAR_LIGHT", "DIFFERENCE", "EXCLUSION", "SUBTRACT",
               "DIVIDE", "HUE", "SATURATION", "COLOR", "VALUE")
(B_MIX, B_DARKEN, B_MULTIPLY, B_BURN, B_LIGHTEN, B_SCREEN, B_DODGE, B_ADD, B_OVERLAY, B_SOFT,
 B_LINEAR, B_DIFFERENCE, B_EXCLUSION, B_SUBTRACT, B_DIVIDE, B_HUE, B_SATURATION, B_COLOR,
 B_VALUE) = range(len(BLEND_TYPES))
COLOR_MODES = ("RGB", "HSV", "HSL")
MODE_RGB, MODE_HSV, MODE_HSL = 0, 1, 2

SPECS = {
    MIX_COLOR: ("Mix (Color) / MixRGB: blend i of A and B at factor f; factor, result clamped "
                "if asked", "iiifvvv", {1: len(BLEND_TYPES), 2: 2, 3: 2}),
    MIX_FLOAT: ("Mix (Float): A (1 - factor) + B factor", "iffff--", {1: 2}),
    MIX_VECTOR: ("Mix (Vector): A (1 - factor) + B factor", "ifvvv--", {1: 2}),
    MIX_VECTOR_NONUNIFORM: ("Mix (Vector, non-uniform): per component", "ivvvv--", {1: 2}),
    INVERT: ("Invert: factor (1 - colour) + (1 - factor) colour", "fvv----"),
    HUE_SAT: ("Hue/Saturation/Value: hue, saturation, value, factor, colour", "ffffvv-"),
    GAMMA: ("Gamma: colour^gamma", "fvv----"),
    BRIGHT_CONTRAST: ("Bright/Contrast: brightness, contrast, colour", "ffvv---"),
    SEPARATE_COLOR: ("Separate Color: mode i, colour to three values", "ivfff--",
                     {1: len(COLOR_MODES)}),
    COMBINE_COLOR: ("Combine Color: mode i, three values to a colour", "ifffv--",
                    {1: len(COLOR_MODES)}),
    RGB_TO_BW: ("RGB to BW: the luminance of a colour", "vf-----"),
    BLACKBODY: ("Blackbody: the colour of a temperature in kelvin", "fv-----"),
    WAVELENGTH: ("Wavelength: the colour of a wavelength in nm", "fv-----"),
    COLOR_RAMP: ("Color Ramp: interpolate i, a table of RGBA entries; factor to colour, alpha",
                 "idifvf-", {1: 2}),
    RGB_CURVES: ("RGB Curves: extrapolate i, (min_x, max_x, a table of RGB entries); factor, "
                 "colour", "idifvv-", {1: 2}),
    FLOAT_CURVE: ("Float Curve: extrapolate i, (min_x, max_x, a table of values); factor, "
                  "value", "idifff-", {1: 2}),
}

# Cycles' ramp and curve tables have RAMP_TABLE_SIZE + 1 entries (kernel/types.h; blender/util.h
# colorramp_to_array and curvemapping_*_to_array evaluate at i / RAMP_TABLE_SIZE).
RAMP_TABLE_SIZE = 256


# kernel/tables.h: the blackbody fit's coefficients for 7 temperature ranges, and the CIE 1931
# colour matching functions every 5 nm from 380 nm.
BLACKBODY_R = np.array([
    [1.61919106e+03, -2.05010916e-03, 5.02995757e+00],
    [2.48845471e+03, -1.11330907e-03, 3.22621544e+00],
    [3.34143193e+03, -4.86551192e-04, 1.76486769e+00],
    [4.09461742e+03, -1.27446582e-04, 7.25731635e-01],
    [4.67028036e+03, 2.91258199e-05, 1.26703442e-01],
    [4.59509185e+03, 2.87495649e-05, 1.50345020e-01],
    [3.78717450e+03, 9.35907826e-06, 3.99075871e-01]], dtype=np.float32).astype(np.float64)
BLACKBODY_G = np.array([
    [-4.88999748e+02, 6.04330754e-04, -7.55807526e-02],
    [-7.55994277e+02, 3.16730098e-04, 4.78306139e-01],
    [-1.02363977e+03, 1.20223470e-04, 9.36662319e-01],
    [-1.26571316e+03, 4.87340896e-06, 1.27054498e+00],
    [-1.42529332e+03, -4.01150431e-05, 1.43972784e+00],
    [-1.17554822e+03, -2.16378048e-05, 1.30408023e+00],
    [-5.00799571e+02, -4.59832026e-06, 1.09098763e+00]], dtype=np.float32).astype(np.float64)
BLACKBODY_B = np.array([
    [5.96945309e-11, -4.85742887e-08, -9.70622247e-05, -4.07936148e-03],
    [2.40430366e-11, 5.55021075e-08, -1.98503712e-04, 2.89312858e-02],
    [-1.40949732e-11, 1.89878968e-07, -3.56632824e-04, 9.10767778e-02],
    [-3.61460868e-11, 2.84822009e-07, -4.93211319e-04, 1.56723440e-01],
    [-1.97075738e-11, 1.75359352e-07, -2.50542825e-04, -2.22783266e-02],
    [-1.61997957e-13, -1.64216008e-08, 3.86216271e-04, -7.38077418e-01],
    [6.72650283e-13, -2.73078809e-08, 4.24098264e-04, -7.52335691e-01]],
    dtype=np.float32).astype(np.float64)
CIE_COLOR_MATCH = np.array([
    0.0014, 0.0000, 0.0065, 0.0022, 0.0001, 0.0105, 0.0042, 0.0001, 0.0201,
    0.0076, 0.0002, 0.0362, 0.0143, 0.0004, 0.0679, 0.0232, 0.0006, 0.1102,
    0.0435, 0.0012, 0.2074, 0.0776, 0.0022, 0.3713, 0.1344, 0.0040, 0.6456,
    0.2148, 0.0073, 1.0391, 0.2839, 0.0116, 1.3856, 0.3285, 0.0168, 1.6230,
    0.3483, 0.0230, 1.7471, 0.3481, 0.0298, 1.7826, 0.3362, 0.0380, 1.7721,
    0.3187, 0.0480, 1.7441, 0.2908, 0.0600, 1.6692, 0.2511, 0.0739, 1.5281,
    0.1954, 0.0910, 1.2876, 0.1421, 0.1126, 1.0419, 0.0956, 0.1390, 0.8130,
    0.0580, 0.1693, 0.6162, 0.0320, 0.2080, 0.4652, 0.0147, 0.2586, 0.3533,
    0.0049, 0.3230, 0.2720, 0.0024, 0.4073, 0.2123, 0.0093, 0.5030, 0.1582,
    0.0291, 0.6082, 0.1117, 0.0633, 0.7100, 0.0782, 0.1096, 0.7932, 0.0573,
    0.1655, 0.8620, 0.0422, 0.2257, 0.9149, 0.0298, 0.2904, 0.9540, 0.0203,
    0.3597, 0.9803, 0.0134, 0.4334, 0.9950, 0.0087, 0.5121, 1.0000, 0.0057,
    0.5945, 0.9950, 0.0039, 0.6784, 0.9786, 0.0027, 0.7621, 0.9520, 0.0021,
    0.8425, 0.9154, 0.0018, 0.9163, 0.8700, 0.0017, 0.9786, 0.8163, 0.0014,
    1.0263, 0.7570, 0.0011, 1.0567, 0.6949, 0.0010, 1.0622, 0.6310, 0.0008,
    1.0456, 0.5668, 0.0006, 1.0026, 0.5030, 0.0003, 0.9384, 0.4412, 0.0002,
    0.8544, 0.3810, 0.0002, 0.7514, 0.3210, 0.0001, 0.6424, 0.2650, 0.0000,
    0.5419, 0.2170, 0.0000, 0.4479, 0.1750, 0.0000, 0.3608, 0.1382, 0.0000,
    0.2835, 0.1070, 0.0000, 0.2187, 0.0816, 0.0000, 0.1649, 0.0610, 0.0000,
    0.1212, 0.0446, 0.0000, 0.0874, 0.0320, 0.0000, 0.0636, 0.0232, 0.0000,
    0.0468, 0.0170, 0.0000, 0.0329, 0.0119, 0.0000, 0.0227, 0.0082, 0.0000,
    0.0158, 0.0057, 0.0000, 0.0114, 0.0041, 0.0000, 0.0081, 0.0029, 0.0000,
    0.0058, 0.0021, 0.0000, 0.0041, 0.0015, 0.0000, 0.0029, 0.0010, 0.0000,
    0.0020, 0.0007, 0.0000, 0.0014, 0.0005, 0.0000, 0.0010, 0.0004, 0.0000,
    0.0007, 0.0002, 0.0000, 0.0005, 0.0002, 0.0000, 0.0003, 0.0001, 0.0000,
    0.0002, 0.0001, 0.0000, 0.0002, 0.0001, 0.0000, 0.0001, 0.0000, 0.0000,
    0.0001, 0.0000, 0.0000, 0.0001, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000],
    dtype=np.float32).astype(np.float64)


@jit
def _clamp01(a):
    return min(max(a, 0.0), 1.0)


@jit
def _lerp3(a, b, t):
    # interp(a, b, t) = a + t (b - a)
    return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2]))


@jit
def _saturate3(c):
    return (_clamp01(c[0]), _clamp01(c[1]), _clamp01(c[2]))


# --- util/color.h -------------------------------------------------------------------------------

@jit
def rgb_to_hsv(rgb):
    """Hue, saturation, value of an RGB colour (hue in [0, 1))."""
    r, g, b = rgb
    cmax = max(r, max(g, b))
    cmin = min(r, min(g, b))
    cdelta = cmax - cmin
    v = cmax
    h = 0.0
    s = cdelta / cmax if cmax != 0.0 else 0.0
    if s != 0.0:
        cr, cg, cb = (cmax - r) / cdelta, (cmax - g) / cdelta, (cmax - b) / cdelta
        if r == cmax:
            h = cb - cg
        elif g == cmax:
            h = 2.0 + cr - cb
        else:
            h = 4.0 + cg - cr
        h /= 6.0
        if h < 0.0:
            h += 1.0
    return (h, s, v)


@jit
def hsv_to_rgb(hsv):
    """The RGB colour of hue, saturation, value."""
    h, s, v = hsv
    if s == 0.0:
        return (v, v, v)
    if h == 1.0:
        h = 0.0
    h *= 6.0
    i = np.floor(h)
    f = h - i
    p = v * (1.0 - s)
    q = v * (1.0 - (s * f))
    t = v * (1.0 - (s * (1.0 - f)))
    if i == 0.0:
        return (v, t, p)
    elif i == 1.0:
        return (q, v, p)
    elif i == 2.0:
        return (p, v, t)
    elif i == 3.0:
        return (p, q, v)
    elif i == 4.0:
        return (t, p, v)
    return (v, p, q)


@jit
def rgb_to_hsl(rgb):
    """Hue, saturation, lightness of an RGB colour."""
    r, g, b = rgb
    cmax = max(r, max(g, b))
    cmin = min(r, min(g, b))
    l = min(1.0, (cmax + cmin) / 2.0)  # noqa: E741 (Cycles' name)
    if cmax == cmin:
        h = 0.0
        s = 0.0
    else:
        cdelta = cmax - cmin
        s = cdelta / (2.0 - cmax - cmin) if l > 0.5 else cdelta / (cmax + cmin)
        if cmax == r:
            h = (g - b) / cdelta + (6.0 if g < b else 0.0)
        elif cmax == g:
            h = (b - r) / cdelta + 2.0
        else:
            h = (r - g) / cdelta + 4.0
    h /= 6.0
    return (h, s, l)


@jit
def hsl_to_rgb(hsl):
    """The RGB colour of hue, saturation, lightness."""
    h, s, l = hsl  # noqa: E741 (Cycles' name)
    nr = _clamp01(abs(h * 6.0 - 3.0) - 1.0)
    ng = _clamp01(2.0 - abs(h * 6.0 - 2.0))
    nb = _clamp01(2.0 - abs(h * 6.0 - 4.0))
    chroma = (1.0 - abs(2.0 * l - 1.0)) * s
    return ((nr - 0.5) * chroma + l, (ng - 0.5) * chroma + l, (nb - 0.5) * chroma + l)


# --- Mix (color_util.h) -------------------------------------------------------------------------

@jit
def _overlay1(t, a, b):
    if a < 0.5:
        return a * ((1.0 - t) + 2.0 * t * b)
    return 1.0 - ((1.0 - t) + 2.0 * t * (1.0 - b)) * (1.0 - a)


@jit
def _divide1(t, a, b):
    return (1.0 - t) * a + t * a / b if b != 0.0 else a


@jit
def _dodge1(t, a, b):
    if a == 0.0:
        return a
    tmp = 1.0 - t * b
    if tmp <= 0.0:
        return 1.0
    tmp = a / tmp
    return 1.0 if tmp > 1.0 else tmp


@jit
def _burn1(t, a, b):
    tmp = (1.0 - t) + t * b
    if tmp <= 0.0:
        return 0.0
    tmp = 1.0 - (1.0 - a) / tmp
    if tmp < 0.0:
        return 0.0
    return 1.0 if tmp > 1.0 else tmp


@jit
def _soft1(t, a, b):
    scr = 1.0 - (1.0 - b) * (1.0 - a)
    return (1.0 - t) * a + t * ((1.0 - a) * b * a + a * scr)


@jit
def mix_blend(kind, t, a, b):
    """svm_mix: blend mode kind (an index of BLEND_TYPES) of colours a and b at factor t."""
    if kind == B_MIX:
        return _lerp3(a, b, t)
    elif kind == B_ADD:
        return _lerp3(a, (a[0] + b[0], a[1] + b[1], a[2] + b[2]), t)
    elif kind == B_MULTIPLY:
        return _lerp3(a, (a[0] * b[0], a[1] * b[1], a[2] * b[2]), t)
    elif kind == B_SCREEN:
        tm = 1.0 - t
        return (1.0 - (tm + t * (1.0 - b[0])) * (1.0 - a[0]),
                1.0 - (tm + t * (1.0 - b[1])) * (1.0 - a[1]),
                1.0 - (tm + t * (1.0 - b[2])) * (1.0 - a[2]))
    elif kind == B_OVERLAY:
        return (_overlay1(t, a[0], b[0]), _overlay1(t, a[1], b[1]), _overlay1(t, a[2], b[2]))
    elif kind == B_SUBTRACT:
        return _lerp3(a, (a[0] - b[0], a[1] - b[1], a[2] - b[2]), t)
    elif kind == B_DIVIDE:
        return (_divide1(t, a[0], b[0]), _divide1(t, a[1], b[1]), _divide1(t, a[2], b[2]))
    elif kind == B_DIFFERENCE:
        return _lerp3(a, (abs(a[0] - b[0]), abs(a[1] - b[1]), abs(a[2] - b[2])), t)
    elif kind == B_EXCLUSION:
        e = _lerp3(a, (a[0] + b[0] - 2.0 * a[0] * b[0], a[1] + b[1] - 2.0 * a[1] * b[1],
                       a[2] + b[2] - 2.0 * a[2] * b[2]), t)
        return (max(e[0], 0.0), max(e[1], 0.0), max(e[2], 0.0))
    elif kind == B_DARKEN:
        return _lerp3(a, (min(a[0], b[0]), min(a[1], b[1]), min(a[2], b[2])), t)
    elif kind == B_LIGHTEN:
        return _lerp3(a, (max(a[0], b[0]), max(a[1], b[1]), max(a[2], b[2])), t)
    elif kind == B_DODGE:
        return (_dodge1(t, a[0], b[0]), _dodge1(t, a[1], b[1]), _dodge1(t, a[2], b[2]))
    elif kind == B_BURN:
        return (_burn1(t, a[0], b[0]), _burn1(t, a[1], b[1]), _burn1(t, a[2], b[2]))
    elif kind == B_HUE:
        hsv2 = rgb_to_hsv(b)
        if hsv2[1] != 0.0:
            hsv = rgb_to_hsv(a)
            return _lerp3(a, hsv_to_rgb((hsv2[0], hsv[1], hsv[2])), t)
        return a
    elif kind == B_SATURATION:
        hsv = rgb_to_hsv(a)
        if hsv[1] != 0.0:
            hsv2 = rgb_to_hsv(b)
            return hsv_to_rgb((hsv[0], (1.0 - t) * hsv[1] + t * hsv2[1], hsv[2]))
        return a
    elif kind == B_VALUE:
        hsv = rgb_to_hsv(a)
        hsv2 = rgb_to_hsv(b)
        return hsv_to_rgb((hsv[0], hsv[1], (1.0 - t) * hsv[2] + t * hsv2[2]))
    elif kind == B_COLOR:
        hsv2 = rgb_to_hsv(b)
        if hsv2[1] != 0.0:
            hsv = rgb_to_hsv(a)
            return _lerp3(a, hsv_to_rgb((hsv2[0], hsv2[1], hsv[2])), t)
        return a
    elif kind == B_SOFT:
        return (_soft1(t, a[0], b[0]), _soft1(t, a[1], b[1]), _soft1(t, a[2], b[2]))
    elif kind == B_LINEAR:
        return (a[0] + t * (2.0 * b[0] - 1.0), a[1] + t * (2.0 * b[1] - 1.0),
                a[2] + t * (2.0 * b[2] - 1.0))
    return (0.0, 0.0, 0.0)


@jit
def mix_color(kind, clamp_factor, clamp_result, t, a, b):
    """The Mix node (Color) and the legacy MixRGB (whose factor is always clamped, and whose
    Clamp clamps the result): mix_blend with the factor and result clamped to [0, 1] if asked."""
    if clamp_factor:
        t = _clamp01(t)
    r = mix_blend(kind, t, a, b)
    return _saturate3(r) if clamp_result else r


@jit
def mix_float(clamp_factor, t, a, b):
    """The Mix node (Float): a (1 - t) + b t."""
    if clamp_factor:
        t = _clamp01(t)
    return a * (1.0 - t) + b * t


@jit
def mix_vector(clamp_factor, t, a, b):
    """The Mix node (Vector, uniform factor t)."""
    if clamp_factor:
        t = _clamp01(t)
    return (a[0] * (1.0 - t) + b[0] * t, a[1] * (1.0 - t) + b[1] * t,
            a[2] * (1.0 - t) + b[2] * t)


@jit
def mix_vector_nonuniform(clamp_factor, t, a, b):
    """The Mix node (Vector, a factor t per component)."""
    if clamp_factor:
        t = _saturate3(t)
    return (a[0] * (1.0 - t[0]) + b[0] * t[0], a[1] * (1.0 - t[1]) + b[1] * t[1],
            a[2] * (1.0 - t[2]) + b[2] * t[2])


# --- the other colour nodes ---------------------------------------------------------------------

@jit
def invert(factor, c):
    """The Invert node."""
    return (factor * (1.0 - c[0]) + (1.0 - factor) * c[0],
            factor * (1.0 - c[1]) + (1.0 - factor) * c[1],
            factor * (1.0 - c[2]) + (1.0 - factor) * c[2])


@jit
def hue_saturation_value(hue, sat, val, fac, c):
    """The Hue/Saturation/Value node (svm_node_hsv)."""
    hsv = rgb_to_hsv(c)
    h = hsv[0] + hue + 0.5
    h = h - np.floor(h)
    rgb = hsv_to_rgb((h, _clamp01(hsv[1] * sat), hsv[2] * val))
    return (max(fac * rgb[0] + (1.0 - fac) * c[0], 0.0),
            max(fac * rgb[1] + (1.0 - fac) * c[1], 0.0),
            max(fac * rgb[2] + (1.0 - fac) * c[2], 0.0))


@jit
def gamma(c, g):
    """The Gamma node (svm_math_gamma_color): positive components to the power g."""
    if g == 0.0:
        return (1.0, 1.0, 1.0)
    return (math.pow(c[0], g) if c[0] > 0.0 else c[0],
            math.pow(c[1], g) if c[1] > 0.0 else c[1],
            math.pow(c[2], g) if c[2] > 0.0 else c[2])


@jit
def bright_contrast(c, bright, contrast):
    """The Bright/Contrast node (svm_brightness_contrast)."""
    a = 1.0 + contrast
    b = bright - contrast * 0.5
    return (max(a * c[0] + b, 0.0), max(a * c[1] + b, 0.0), max(a * c[2] + b, 0.0))


@jit
def combine_color(mode, c):
    """Combine Color: (r, g, b), (h, s, v) or (h, s, l) to RGB."""
    if mode == MODE_HSV:
        return hsv_to_rgb(c)
    elif mode == MODE_HSL:
        return hsl_to_rgb(c)
    return c


@jit
def separate_color(mode, c):
    """Separate Color: RGB to (r, g, b), (h, s, v) or (h, s, l)."""
    if mode == MODE_HSV:
        return rgb_to_hsv(c)
    elif mode == MODE_HSL:
        return rgb_to_hsl(c)
    return c


@jit
def rgb_to_bw(c):
    """RGB to BW: the colour's luminance Y in the scene linear space (linear_rgb_to_gray)."""
    return RGB_TO_Y[0] * c[0] + RGB_TO_Y[1] * c[1] + RGB_TO_Y[2] * c[2]


@jit
def blackbody(t):
    """The Blackbody node: the colour of temperature t in kelvin, negative parts cut
    (svm_math_blackbody_color_rec709, then max(0) as blackbody.h)."""
    if t >= 12000.0:
        rgb = (0.8262954810464208, 0.9945080501520986, 1.566307710274283)
    elif t < 800.0:
        rgb = (5.413294490189271, -0.20319390035873933, -0.0822535242887164)
    else:
        if t >= 6365.0:
            i = 6
        elif t >= 3315.0:
            i = 5
        elif t >= 1902.0:
            i = 4
        elif t >= 1449.0:
            i = 3
        elif t >= 1167.0:
            i = 2
        elif t >= 965.0:
            i = 1
        else:
            i = 0
        r = BLACKBODY_R[i]
        g = BLACKBODY_G[i]
        b = BLACKBODY_B[i]
        t_inv = 1.0 / t
        rgb = (r[0] * t_inv + r[1] * t + r[2], g[0] * t_inv + g[1] * t + g[2],
               ((b[0] * t + b[1]) * t + b[2]) * t + b[3])
    return (max(rgb[0], 0.0), max(rgb[1], 0.0), max(rgb[2], 0.0))


@jit
def wavelength(lambda_nm):
    """The Wavelength node: the colour of a wavelength in nm (svm_node_wavelength: CIE XYZ
    interpolated every 5 nm, to RGB, / 2.52, negative parts cut)."""
    ii = (lambda_nm - 380.0) * (1.0 / 5.0)
    if not (ii > -1.0 and ii < 80.0):  # float_to_int truncates: i in [0, 80) (NaN: outside)
        return (0.0, 0.0, 0.0)
    i = int(ii)
    f = ii - i
    c = CIE_COLOR_MATCH
    x = c[3 * i] + f * (c[3 * i + 3] - c[3 * i])
    y = c[3 * i + 1] + f * (c[3 * i + 4] - c[3 * i + 1])
    z = c[3 * i + 2] + f * (c[3 * i + 5] - c[3 * i + 2])
    m = XYZ_TO_REC709
    s = 1.0 / 2.52
    return (max((m[0][0] * x + m[0][1] * y + m[0][2] * z) * s, 0.0),
            max((m[1][0] * x + m[1][1] * y + m[1][2] * z) * s, 0.0),
            max((m[2][0] * x + m[2][1] * y + m[2][2] * z) * s, 0.0))


# --- ramps and curves (ramp.h) ------------------------------------------------------------------

@jit
def table_lookup(data, base, stride, channel, size, f, interpolate, extrapolate):
    """One channel of Cycles' ramp lookup (rgb_ramp_lookup / float_ramp_lookup) at f in [0, 1]:
    entry k of the table is data[base + k stride + channel], k < size. Outside [0, 1] it
    extrapolates the end segments when asked, and holds the end entries otherwise."""
    if (f < 0.0 or f > 1.0) and extrapolate:
        if f < 0.0:
            t0 = data[base + channel]
            dy = t0 - data[base + stride + channel]
            f = -f
        else:
            t0 = data[base + (size - 1) * stride + channel]
            dy = t0 - data[base + (size - 2) * stride + channel]
            f = f - 1.0
        return t0 + dy * f * (size - 1)
    if not (f >= 0.0):  # NaN too: Cycles clamps the index
        f = 0.0
    f = min(f, 1.0) * (size - 1)
    i = min(int(f), size - 1)
    t = f - i
    a = data[base + i * stride + channel]
    if interpolate and t > 0.0:
        a = (1.0 - t) * a + t * data[base + (i + 1) * stride + channel]
    return a


@jit
def color_ramp(data, base, size, interpolate, fac):
    """The Color Ramp node: (colour, alpha) at fac from a table of size RGBA entries."""
    r = table_lookup(data, base, 4, 0, size, fac, interpolate, False)
    g = table_lookup(data, base, 4, 1, size, fac, interpolate, False)
    b = table_lookup(data, base, 4, 2, size, fac, interpolate, False)
    a = table_lookup(data, base, 4, 3, size, fac, interpolate, False)
    return (r, g, b), a


@jit
def rgb_curves(data, base, size, extrapolate, fac, c):
    """The RGB Curves node (svm_node_curves): data[base], data[base + 1] are the curves'
    min_x, max_x; a table of size RGB entries follows."""
    min_x = data[base]
    range_x = data[base + 1] - min_x
    t = base + 2
    r = table_lookup(data, t, 3, 0, size, (c[0] - min_x) / range_x, True, extrapolate)
    g = table_lookup(data, t, 3, 1, size, (c[1] - min_x) / range_x, True, extrapolate)
    b = table_lookup(data, t, 3, 2, size, (c[2] - min_x) / range_x, True, extrapolate)
    return ((1.0 - fac) * c[0] + fac * r, (1.0 - fac) * c[1] + fac * g,
            (1.0 - fac) * c[2] + fac * b)


@jit
def float_curve(data, base, size, extrapolate, fac, value):
    """The Float Curve node (svm_node_curve): data[base], data[base + 1] are min_x, max_x; a
    table of size values follows."""
    lo = data[base]
    v = table_lookup(data, base + 2, 1, 0, size, (value - lo) / (data[base + 1] - lo), True,
                     extrapolate)
    return (1.0 - fac) * value + fac * v


# --- the interpreter's side ---------------------------------------------------------------------

@jit
def execute(ins, regs, data):
    """Run one instruction of this family: read its inputs from regs, write its outputs."""
    op = ins[0]
    if op == MIX_COLOR:
        _store3(regs, ins[7], mix_color(ins[1], ins[2] != 0, ins[3] != 0, regs[ins[4]],
                                        _load3(regs, ins[5]), _load3(regs, ins[6])))
    elif op == MIX_FLOAT:
        regs[ins[5]] = mix_float(ins[1] != 0, regs[ins[2]], regs[ins[3]], regs[ins[4]])
    elif op == MIX_VECTOR:
        _store3(regs, ins[5], mix_vector(ins[1] != 0, regs[ins[2]], _load3(regs, ins[3]),
                                         _load3(regs, ins[4])))
    elif op == MIX_VECTOR_NONUNIFORM:
        _store3(regs, ins[5], mix_vector_nonuniform(ins[1] != 0, _load3(regs, ins[2]),
                                                    _load3(regs, ins[3]),
                                                    _load3(regs, ins[4])))
    elif op == INVERT:
        _store3(regs, ins[3], invert(regs[ins[1]], _load3(regs, ins[2])))
    elif op == HUE_SAT:
        _store3(regs, ins[6], hue_saturation_value(regs[ins[1]], regs[ins[2]], regs[ins[3]],
                                                   regs[ins[4]], _load3(regs, ins[5])))
    elif op == GAMMA:
        _store3(regs, ins[3], gamma(_load3(regs, ins[2]), regs[ins[1]]))
    elif op == BRIGHT_CONTRAST:
        _store3(regs, ins[4], bright_contrast(_load3(regs, ins[3]), regs[ins[1]], regs[ins[2]]))
    elif op == SEPARATE_COLOR:
        c = separate_color(ins[1], _load3(regs, ins[2]))
        regs[ins[3]] = c[0]
        regs[ins[4]] = c[1]
        regs[ins[5]] = c[2]
    elif op == COMBINE_COLOR:
        _store3(regs, ins[5], combine_color(ins[1], (regs[ins[2]], regs[ins[3]],
                                                     regs[ins[4]])))
    elif op == RGB_TO_BW:
        regs[ins[2]] = rgb_to_bw(_load3(regs, ins[1]))
    elif op == BLACKBODY:
        _store3(regs, ins[2], blackbody(regs[ins[1]]))
    elif op == WAVELENGTH:
        _store3(regs, ins[2], wavelength(regs[ins[1]]))
    elif op == COLOR_RAMP:
        # the data holds 4 values an entry; a table needs two entries
        size = ins[3] // 4
        color, alpha = ((0.0, 0.0, 0.0), 0.0) if size < 2 else \
            color_ramp(data, ins[2], size, ins[1] != 0, regs[ins[4]])
        _store3(regs, ins[5], color)
        regs[ins[6]] = alpha
    elif op == RGB_CURVES:
        size = (ins[3] - 2) // 3
        c = _load3(regs, ins[5])
        _store3(regs, ins[6], c if size < 2 else
                rgb_curves(data, ins[2], size, ins[1] != 0, regs[ins[4]], c))
    elif op == FLOAT_CURVE:
        size = ins[3] - 2
        v = regs[ins[5]]
        regs[ins[6]] = v if size < 2 else float_curve(data, ins[2], size, ins[1] != 0,
                                                      regs[ins[4]], v)
