"""The instructions of a shader program that read the hit: Light Path, Geometry, Texture
Coordinate (and UV Map), Fresnel, Layer Weight, Image Texture; and the conversions Blender makes
on a link between sockets of different types, and copies into a block of inputs.

Cycles is the model: kernel/svm/light_path.h, geometry.h, tex_coord.h, fresnel.h, image.h,
convert.h. The hit is program.run's tuple: (point, geometric normal and shading normal both
facing the ray, direction to the viewer, entering (not backfacing), triangle, barycentrics b1 and
b2, the ray's Light Path flags (bit LP_* set), its depth, its length).
"""
from __future__ import annotations

from ..fresnel import fresnel_dielectric
from ..jit import jit
from ..lights.codes import VISIBLE_CAMERA, VISIBLE_DIFFUSE, VISIBLE_GLOSSY
from ..textures import sample_image, srgb_to_linear
from .colorspace import RGB_TO_Y
from ..vec import dot, madd, mul

# Opcodes 20-39 (40-99: object_inputs.py).
(LIGHT_PATH, GEOMETRY, TEXCOORD, REFLECTION, IMAGE, FRESNEL, LAYER_WEIGHT, COLOR_TO_FLOAT,
 VECTOR_TO_FLOAT, FLOAT_TO_VECTOR, COPY_FLOAT, COPY_VECTOR) = range(20, 32)
FIRST, LAST = 20, 39

# Light Path outputs (LIGHT_PATH's literal): the first seven are bits of the hit's flags.
(LP_CAMERA, LP_SHADOW, LP_DIFFUSE, LP_GLOSSY, LP_SINGULAR, LP_REFLECTION, LP_TRANSMISSION,
 LP_BACKFACING, LP_RAY_LENGTH, LP_RAY_DEPTH) = range(10)
LIGHT_PATH_OUTPUTS = 10
# The hit's flags from this bit on hold the caustics the hit drops (path_limits.dropped_at),
# which the closures read as Cycles' closure nodes read PATH_RAY_DIFFUSE and its switches.
DROP_SHIFT = 16
# Geometry outputs (GEOMETRY's literal).
G_POSITION, G_NORMAL, G_TRUE_NORMAL, G_INCOMING = range(4)
GEOMETRY_OUTPUTS = 4

SPECS = {
    LIGHT_PATH: ("Light Path: output i (LP_*)", "fi-----", {2: LIGHT_PATH_OUTPUTS}),
    GEOMETRY: ("Geometry: output i (G_*)", "vi-----", {2: GEOMETRY_OUTPUTS}),
    TEXCOORD: ("Texture Coordinate or UV Map: the scene's texture coordinates i at the hit",
               "vi-----", {2: "texcoords"}),
    REFLECTION: ("Texture Coordinate Reflection: the view mirrored about the normal", "v------"),
    IMAGE: ("Image Texture: colour v, alpha f at vector v of scene image i, closest i, "
            "extension i (textures.REPEAT ...)", "vfviii-", {4: "images", 5: 2, 6: 4}),
    FRESNEL: ("Fresnel: dielectric reflectance of IOR f about normal n", "ffn----"),
    LAYER_WEIGHT: ("Layer Weight: Fresnel f and Facing f of blend f about normal n", "fffn---"),
    COLOR_TO_FLOAT: ("a colour linked to a number: its luminance", "fv-----"),
    VECTOR_TO_FLOAT: ("a vector linked to a number: its average", "fv-----"),
    FLOAT_TO_VECTOR: ("a number linked to a colour or vector: in every component", "vf-----"),
    COPY_FLOAT: ("a linked input of a block of inputs (the Principled BSDF's): a copy", "ff-----"),
    COPY_VECTOR: ("a linked colour input of a block of inputs: a copy", "vv-----"),
}


@jit
def ray_flags(ray_kind, pdf_bsdf):
    """The Light Path node's flags (1 << LP_*) of a ray of this kind (a lights.codes VISIBLE_*
    flag) sampled with this density (0: singular). A transmitted ray is glossy too, as Cycles
    flags glossy refraction; Snell's rays do not say whether a transmission was diffuse (the
    Translucent BSDF's are diffuse rays)."""
    if ray_kind == VISIBLE_CAMERA:
        return 1 << LP_CAMERA
    flags = 1 << LP_SINGULAR if pdf_bsdf == 0.0 else 0
    if ray_kind == VISIBLE_DIFFUSE:
        return flags | 1 << LP_DIFFUSE | 1 << LP_REFLECTION
    if ray_kind == VISIBLE_GLOSSY:
        return flags | 1 << LP_GLOSSY | 1 << LP_REFLECTION
    return flags | 1 << LP_GLOSSY | 1 << LP_TRANSMISSION


@jit
def store3(regs, slot, v):
    """Write a vector into three registers from slot."""
    regs[slot], regs[slot + 1], regs[slot + 2] = v[0], v[1], v[2]


@jit
def normal_in(regs, slot, ns):
    """A node's Normal input: the register's vector, or the hit's shading normal for -1."""
    return ns if slot < 0 else (regs[slot], regs[slot + 1], regs[slot + 2])


@jit
def light_path(hit, which):
    """A Light Path output at the hit (Cycles' svm_node_light_path)."""
    if which < LP_BACKFACING:
        return 1.0 if hit[8] & (1 << which) else 0.0
    if which == LP_BACKFACING:
        return 0.0 if hit[4] else 1.0
    if which == LP_RAY_LENGTH:
        return hit[10]
    # Ray Depth: shadow rays are one bounce further (Cycles adds 1 for them).
    return float(hit[9]) + (1.0 if hit[8] & (1 << LP_SHADOW) else 0.0)


@jit
def interpolate(coords, tri, b1, b2):
    """A per-corner attribute (T, 3, 3) interpolated at barycentrics (b1, b2) of triangle tri."""
    c = coords[tri]
    b0 = 1.0 - b1 - b2
    return (b0 * c[0, 0] + b1 * c[1, 0] + b2 * c[2, 0],
            b0 * c[0, 1] + b1 * c[1, 1] + b2 * c[2, 1],
            b0 * c[0, 2] + b1 * c[1, 2] + b2 * c[2, 2])


@jit
def fresnel(ior, wi, n, backfacing):
    """The Fresnel node: dielectric reflectance at index ior (inverted on a back face)."""
    eta = max(ior, 1e-5)
    if backfacing:
        eta = 1.0 / eta
    return fresnel_dielectric(abs(dot(wi, n)), eta)[0]


@jit
def layer_weight(blend, wi, n, backfacing):
    """The Layer Weight node's (Fresnel, Facing) (Cycles' svm_node_layer_weight)."""
    eta = max(1.0 - blend, 1e-5)
    if not backfacing:
        eta = 1.0 / eta
    fresnel_out = fresnel_dielectric(abs(dot(wi, n)), eta)[0]
    facing = abs(dot(wi, n))
    if blend != 0.5:
        b = min(max(blend, 0.0), 1.0 - 1e-5)
        b = 2.0 * b if b < 0.5 else 0.5 / (1.0 - b)
        facing = facing ** b
    return fresnel_out, 1.0 - facing


@jit
def image(mats, i, x, y, closest, extension):
    """Scene image i at texture coordinate (x, y) (its sRGB decoded after interpolation)."""
    k = mats.image_slot[i]
    rgb = sample_image(mats.pool, mats.img_offset[k], mats.img_width[k], mats.img_height[k],
                       x, y, closest, extension)
    if mats.img_srgb[k]:
        return (srgb_to_linear(rgb[0]), srgb_to_linear(rgb[1]), srgb_to_linear(rgb[2]))
    return rgb


@jit
def execute(ins, regs, hit, mats):
    """Run one hit-reading instruction."""
    op = ins[0]
    ns, view, backfacing = hit[2], hit[3], not hit[4]
    if op == LIGHT_PATH:
        regs[ins[1]] = light_path(hit, ins[2])
    elif op == GEOMETRY:
        which = ins[2]
        store3(regs, ins[1], hit[0] if which == G_POSITION else ns if which == G_NORMAL else
               hit[1] if which == G_TRUE_NORMAL else view)
    elif op == TEXCOORD:
        store3(regs, ins[1], interpolate(mats.coords[ins[2]], hit[5], hit[6], hit[7]))
    elif op == REFLECTION:
        store3(regs, ins[1], madd(mul(view, -1.0), 2.0 * dot(ns, view), ns))
    elif op == IMAGE:
        rgb = image(mats, ins[4], regs[ins[3]], regs[ins[3] + 1], ins[5] != 0, ins[6])
        store3(regs, ins[1], rgb)
        regs[ins[2]] = 1.0
    elif op == FRESNEL:
        regs[ins[1]] = fresnel(regs[ins[2]], view, normal_in(regs, ins[3], ns), backfacing)
    elif op == LAYER_WEIGHT:
        f, facing = layer_weight(regs[ins[3]], view, normal_in(regs, ins[4], ns), backfacing)
        regs[ins[1]] = f
        regs[ins[2]] = facing
    elif op == COLOR_TO_FLOAT:
        s = ins[2]
        y = RGB_TO_Y
        regs[ins[1]] = y[0] * regs[s] + y[1] * regs[s + 1] + y[2] * regs[s + 2]
    elif op == VECTOR_TO_FLOAT:
        s = ins[2]
        regs[ins[1]] = (regs[s] + regs[s + 1] + regs[s + 2]) / 3.0
    elif op == FLOAT_TO_VECTOR:
        v = regs[ins[2]]
        store3(regs, ins[1], (v, v, v))
    elif op == COPY_FLOAT:
        regs[ins[1]] = regs[ins[2]]
    elif op == COPY_VECTOR:
        for k in range(3):
            regs[ins[1] + k] = regs[ins[2] + k]
