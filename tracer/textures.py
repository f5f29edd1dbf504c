"""Image lookups as Cycles does them (kernel/device/cpu/image.h), for image textures and the
environment map.

An image is a block of rows of a flat (N, 3) float32 pixel pool, top row first (as OpenImageIO
reads it); (x, y) are Cycles' texture coordinates, y = 0 at the image's bottom. Linear
interpolation blends the four texels around (x w - 0.5, y h - 0.5); Closest reads the texel
(x w, y h) falls in. Extensions: Repeat wraps, Extend clamps, Clip gives 0 outside the image
(Linear: 0 for the texels outside, and 0 once the four are all outside), Mirror reflects.
"""
from __future__ import annotations

import math

from .jit import jit, jit_inline

REPEAT, EXTEND, CLIP, MIRROR = range(4)      # positions in scene.EXTENSIONS


@jit
def _wrap(i, n, extension):
    """Texel index i along an axis of n texels, wrapped by the extension (-1: outside, Clip)."""
    if extension == REPEAT:
        i = i % n
        return i + n if i < 0 else i
    if extension == EXTEND:
        return min(max(i, 0), n - 1)
    if extension == MIRROR:
        m = abs(i + (1 if i < 0 else 0)) % (2 * n)
        return 2 * n - m - 1 if m >= n else m
    return i if 0 <= i < n else -1


@jit
def _read(pixels, offset, w, h, ix, iy):
    """Texel (ix, iy) (iy from the bottom; -1 is outside: black) as float64 RGB."""
    if ix < 0 or iy < 0:
        return (0.0, 0.0, 0.0)
    k = offset + (h - 1 - iy) * w + ix
    return (float(pixels[k, 0]), float(pixels[k, 1]), float(pixels[k, 2]))


@jit
def sample_image(pixels, offset, w, h, x, y, closest, extension):
    """The image (rows offset .. offset + w h of the pool) at texture coordinate (x, y)."""
    if closest:
        ix = _wrap(int(math.floor(x * w)), w, extension)
        iy = _wrap(int(math.floor(y * h)), h, extension)
        return _read(pixels, offset, w, h, ix, iy)
    fx, fy = x * w - 0.5, y * h - 0.5
    x0f, y0f = math.floor(fx), math.floor(fy)
    tx, ty = fx - x0f, fy - y0f
    ix, iy = int(x0f), int(y0f)
    if extension == CLIP and (ix < -1 or ix >= w or iy < -1 or iy >= h):
        return (0.0, 0.0, 0.0)
    x0, x1 = _wrap(ix, w, extension), _wrap(ix + 1, w, extension)
    y0, y1 = _wrap(iy, h, extension), _wrap(iy + 1, h, extension)
    a, b = _read(pixels, offset, w, h, x0, y0), _read(pixels, offset, w, h, x1, y0)
    c, d = _read(pixels, offset, w, h, x0, y1), _read(pixels, offset, w, h, x1, y1)
    return ((1 - ty) * ((1 - tx) * a[0] + tx * b[0]) + ty * ((1 - tx) * c[0] + tx * d[0]),
            (1 - ty) * ((1 - tx) * a[1] + tx * b[1]) + ty * ((1 - tx) * c[1] + tx * d[1]),
            (1 - ty) * ((1 - tx) * a[2] + tx * b[2]) + ty * ((1 - tx) * c[2] + tx * d[2]))


@jit
def srgb_to_linear(c):
    """The exact sRGB decoding of one channel (Cycles' color_srgb_to_linear)."""
    if c < 0.04045:
        return 0.0 if c < 0.0 else c * (1.0 / 12.92)
    return math.pow((c + 0.055) * (1.0 / 1.055), 2.4)


@jit
def srgb_to_linear_array(values, out):
    """srgb_to_linear of every value of a flat array, into out (the exporter's sRGB images)."""
    for i in range(values.shape[0]):
        out[i] = srgb_to_linear(values[i])


# A material's texture slots (Materials.tex columns, scene.TEXTURE_SLOTS).
COLOR_SLOT, ROUGHNESS_SLOT, METALLIC_SLOT = range(3)
REC709 = (0.2126, 0.7152, 0.0722)     # luminance weights of linear Rec.709 RGB


@jit_inline
def texture_value(mats, k, tri, b1, b2):
    """Texture k at barycentrics (b1, b2) of triangle tri: its coordinate interpolated from the
    triangle's corners, through its Mapping, read from its image (x, y of the coordinate, as
    Cycles' flat projection), sRGB images decoded after interpolation (Cycles' compress_as_srgb)."""
    c = mats.coords[mats.tex_coord[k], tri]
    b0 = 1.0 - b1 - b2
    p = (b0 * c[0, 0] + b1 * c[1, 0] + b2 * c[2, 0], b0 * c[0, 1] + b1 * c[1, 1] + b2 * c[2, 1],
         b0 * c[0, 2] + b1 * c[1, 2] + b2 * c[2, 2])
    m, o = mats.tex_matrix[k], mats.tex_offset[k]
    x = m[0, 0] * p[0] + m[0, 1] * p[1] + m[0, 2] * p[2] + o[0]
    y = m[1, 0] * p[0] + m[1, 1] * p[1] + m[1, 2] * p[2] + o[1]
    i = mats.tex_image[k]
    rgb = sample_image(mats.pool, mats.img_offset[i], mats.img_width[i], mats.img_height[i], x, y,
                       mats.tex_closest[k], mats.tex_extension[k])
    if mats.img_srgb[i]:
        return (srgb_to_linear(rgb[0]), srgb_to_linear(rgb[1]), srgb_to_linear(rgb[2]))
    return rgb


@jit_inline
def material_color(mats, mat, tri, b1, b2):
    """The material's colour at a hit: its texture's, or its constant."""
    k = mats.tex[mat, COLOR_SLOT]
    if k < 0:
        return (mats.color[mat, 0], mats.color[mat, 1], mats.color[mat, 2])
    return texture_value(mats, k, tri, b1, b2)


@jit_inline
def surface_colors(mats, mat, tri, b1, b2):
    """(colour, transmission colour) of the material at a hit: a colour texture gives both."""
    if mats.textured[mat]:
        color = material_color(mats, mat, tri, b1, b2)
        return color, color
    return ((mats.color[mat, 0], mats.color[mat, 1], mats.color[mat, 2]),
            (mats.trans_color[mat, 0], mats.trans_color[mat, 1], mats.trans_color[mat, 2]))


@jit_inline
def material_number(mats, mat, slot, tri, b1, b2, constant):
    """A number input of the material at a hit: its texture's colour as grey (Cycles' colour to
    float conversion, Rec.709 luminance), clamped to [0, 1] as the inputs are, or constant."""
    k = mats.tex[mat, slot]
    if k < 0:
        return constant
    rgb = texture_value(mats, k, tri, b1, b2)
    grey = REC709[0] * rgb[0] + REC709[1] * rgb[1] + REC709[2] * rgb[2]
    return min(max(grey, 0.0), 1.0)
