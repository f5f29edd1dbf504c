"""The procedural texture nodes compiled into shader program rows (the tracer's
tracer/shader/procedural_textures.py runs them): Checker, Brick, Gradient, Noise, Voronoi, Wave,
Magic, White Noise and Gabor. Blender's enum strings map here to the tracer's enums, which are
Cycles'.

A texture whose Vector input is unlinked reads Generated coordinates, as in Cycles (White Noise
excepted: Cycles reads its unlinked Vector's value).
"""
from __future__ import annotations

from ....tracer.shader import gabor as gb
from ....tracer.shader import noise as nz
from ....tracer.shader import patterns as pt
from ....tracer.shader import procedural_textures as op
from ....tracer.shader import voronoi as vr

DIMENSIONS = {"1D": 1, "2D": 2, "3D": 3, "4D": 4}
NOISE_TYPES = {"MULTIFRACTAL": nz.MULTIFRACTAL, "FBM": nz.FBM,
               "HYBRID_MULTIFRACTAL": nz.HYBRID_MULTIFRACTAL,
               "RIDGED_MULTIFRACTAL": nz.RIDGED_MULTIFRACTAL,
               "HETERO_TERRAIN": nz.HETERO_TERRAIN}
FEATURES = {"F1": vr.F1, "F2": vr.F2, "SMOOTH_F1": vr.SMOOTH_F1,
            "DISTANCE_TO_EDGE": vr.DISTANCE_TO_EDGE, "N_SPHERE_RADIUS": vr.N_SPHERE_RADIUS}
METRICS = {"EUCLIDEAN": vr.EUCLIDEAN, "MANHATTAN": vr.MANHATTAN, "CHEBYCHEV": vr.CHEBYCHEV,
           "MINKOWSKI": vr.MINKOWSKI}
GRADIENTS = {"LINEAR": pt.LINEAR, "QUADRATIC": pt.QUADRATIC, "EASING": pt.EASING,
             "DIAGONAL": pt.DIAGONAL, "RADIAL": pt.RADIAL,
             "QUADRATIC_SPHERE": pt.QUADRATIC_SPHERE, "SPHERICAL": pt.SPHERICAL}
WAVE_TYPES = {"BANDS": pt.BANDS, "RINGS": pt.RINGS}
WAVE_DIRECTIONS = {"X": pt.DIRECTION_X, "Y": pt.DIRECTION_Y, "Z": pt.DIRECTION_Z,
                   "DIAGONAL": pt.DIRECTION_DIAGONAL_OR_SPHERICAL,
                   "SPHERICAL": pt.DIRECTION_DIAGONAL_OR_SPHERICAL}
WAVE_PROFILES = {"SIN": pt.SIN, "SAW": pt.SAW, "TRI": pt.TRI}
GABOR_TYPES = {"2D": gb.TYPE_2D, "3D": gb.TYPE_3D}


def _enum(c, node, prop, table, default):
    """table[node.prop], or default with a warning for a value this Blender does not have."""
    value = getattr(node, prop)
    if value in table:
        return table[value]
    name = next(k for k, v in table.items() if v == default)
    c.warn(node, f"has {prop} {value!r}, which Snell does not know", f"{name}")
    return default


def _identity_mapping(tm):
    """Whether a node's texture_mapping (set from Python only) leaves points as they are."""
    return (tuple(tm.translation) == (0.0, 0.0, 0.0) and tuple(tm.rotation) == (0.0, 0.0, 0.0)
            and tuple(tm.scale) == (1.0, 1.0, 1.0) and not tm.use_min and not tm.use_max
            and (tm.mapping_x, tm.mapping_y, tm.mapping_z) == ("X", "Y", "Z"))


def _vector(c, node):
    """The Vector input, or Generated coordinates where it is unlinked (as Cycles reads it)."""
    tm = getattr(node, "texture_mapping", None)
    if tm is not None and not _identity_mapping(tm):
        c.warn(node, "has a texture mapping (set from Python), which Snell does not apply",
               "the points unmapped", input="Vector")
    vector = next(s for s in node.inputs if s.identifier == "Vector")
    if not vector.enabled:
        # a 1D texture reads W only
        return c.constant((0.0, 0.0, 0.0))
    if c.is_linked(node, "Vector"):
        return c.input(node, "Vector", "vector")
    return c.texcoord(node, "generated")


def _params(c, node, *names):
    """A block of three registers holding the named float inputs (None: 0), or constants."""
    regs = []
    for name in names:
        if name is None:
            regs.append(c.constant(0.0))
        elif isinstance(name, (int, float)):
            regs.append(c.constant(float(name)))
        else:
            regs.append(c.input(node, name, "float"))
    block = c.alloc("vector")
    c.emit(op.PARAMS, block, *regs)
    return block


def _linked(node, identifier):
    """Whether an output is used (a link leaves it; read from the tree's links, since a socket's
    is_linked waits for the tree's next update)."""
    return any(link.from_node.name == node.name and link.from_socket.identifier == identifier
               and not link.is_muted for link in node.id_data.links)


def _component(c, block, index):
    """A float register holding register `index` (0-2) of a 3-wide block."""
    out = c.alloc("float")
    c.emit(op.COMPONENT, block, out, index)
    return out


def _grey(c, fac):
    color = c.alloc("color")
    c.emit(op.GREY, fac, color)
    return color


def compile_checker(c, node):
    """Checker Texture."""
    color, fac = c.alloc("color"), c.alloc("float")
    c.emit(op.CHECKER, _vector(c, node), c.input(node, "Color1", "color"),
           c.input(node, "Color2", "color"), c.input(node, "Scale", "float"), color, fac)
    return {"Color": color, "Fac": fac}


def compile_brick(c, node):
    """Brick Texture."""
    q1 = _params(c, node, "Scale", "Mortar Size", "Mortar Smooth")
    q2 = _params(c, node, "Bias", "Brick Width", "Row Height")
    q3 = _params(c, node, float(node.offset), float(node.squash), None)
    tint_mortar = c.alloc("vector")
    c.emit(op.BRICK, _vector(c, node), q1, q2, q3, tint_mortar, int(node.offset_frequency),
           int(node.squash_frequency))
    color = c.alloc("color")
    c.emit(op.BRICK_COLOR, tint_mortar, c.input(node, "Color1", "color"),
           c.input(node, "Color2", "color"), c.input(node, "Mortar", "color"), color)
    return {"Color": color, "Fac": _component(c, tint_mortar, 1)}


def compile_gradient(c, node):
    """Gradient Texture."""
    fac = c.alloc("float")
    c.emit(op.GRADIENT, _vector(c, node), fac,
           _enum(c, node, "gradient_type", GRADIENTS, pt.LINEAR))
    return {"Color": _grey(c, fac), "Fac": fac}


def compile_noise(c, node):
    """Noise Texture."""
    dims = _enum(c, node, "noise_dimensions", DIMENSIONS, 3)
    kind = _enum(c, node, "noise_type", NOISE_TYPES, nz.FBM)
    q1 = _params(c, node, "W", "Scale", "Detail")
    q2 = _params(c, node, "Roughness", "Lacunarity", "Distortion")
    q3 = _params(c, node, "Offset", "Gain", None)
    out = c.alloc("color")
    c.emit(op.NOISE, _vector(c, node), q1, q2, q3, out,
           op.settings(dims, kind, int(bool(node.normalize))), int(_linked(node, "Color")))
    # Fac is the colour's red channel
    return {"Fac": _component(c, out, 0), "Color": out}


def compile_voronoi(c, node):
    """Voronoi Texture."""
    s = op.settings(_enum(c, node, "voronoi_dimensions", DIMENSIONS, 3),
                    _enum(c, node, "feature", FEATURES, vr.F1),
                    _enum(c, node, "distance", METRICS, vr.EUCLIDEAN),
                    int(bool(node.normalize)))
    vector = _vector(c, node)
    q1 = _params(c, node, "W", "Scale", "Detail")
    q2 = _params(c, node, "Roughness", "Lacunarity", "Smoothness")
    q3 = _params(c, node, "Exponent", "Randomness", None)
    scalars, color = c.alloc("vector"), c.alloc("color")
    c.emit(op.VORONOI, vector, q1, q2, q3, scalars, color, s)
    outputs = {"Distance": _component(c, scalars, 0), "Radius": _component(c, scalars, 2),
               "Color": color, "W": _component(c, scalars, 1)}
    if _linked(node, "Position"):
        position, w = c.alloc("vector"), c.alloc("float")
        c.emit(op.VORONOI_POSITION, vector, q1, q2, q3, position, w, s)
        outputs["Position"] = position
    return outputs


def compile_wave(c, node):
    """Wave Texture."""
    kind = _enum(c, node, "wave_type", WAVE_TYPES, pt.BANDS)
    prop = "bands_direction" if kind == pt.BANDS else "rings_direction"
    direction = _enum(c, node, prop, WAVE_DIRECTIONS, pt.DIRECTION_X)
    q1 = _params(c, node, "Scale", "Distortion", "Detail")
    q2 = _params(c, node, "Detail Scale", "Detail Roughness", "Phase Offset")
    fac = c.alloc("float")
    c.emit(op.WAVE, _vector(c, node), q1, q2, fac, kind, direction,
           _enum(c, node, "wave_profile", WAVE_PROFILES, pt.SIN))
    return {"Color": _grey(c, fac), "Fac": fac}


def compile_magic(c, node):
    """Magic Texture."""
    color, fac = c.alloc("color"), c.alloc("float")
    c.emit(op.MAGIC, _vector(c, node), c.input(node, "Scale", "float"),
           c.input(node, "Distortion", "float"), color, fac, int(node.turbulence_depth))
    return {"Color": color, "Fac": fac}


def compile_white_noise(c, node):
    """White Noise Texture."""
    value, color = c.alloc("float"), c.alloc("color")
    # Cycles gives White Noise's Vector no default coordinates: unlinked, it is its value
    c.emit(op.WHITE_NOISE, c.input(node, "Vector", "vector"), c.input(node, "W", "float"), value,
           color,
           _enum(c, node, "noise_dimensions", DIMENSIONS, 3))
    return {"Value": value, "Color": color}


def compile_gabor(c, node):
    """Gabor Texture."""
    kind = _enum(c, node, "gabor_type", GABOR_TYPES, gb.TYPE_2D)
    q = _params(c, node, "Scale", "Frequency", "Anisotropy")
    out = c.alloc("vector")
    c.emit(op.GABOR, _vector(c, node), q, c.input(node, "Orientation 2D", "float"),
           c.input(node, "Orientation 3D", "vector"), out, kind)
    return {"Value": _component(c, out, 0), "Phase": _component(c, out, 1),
            "Intensity": _component(c, out, 2)}


COMPILERS = {
    "ShaderNodeTexChecker": compile_checker,
    "ShaderNodeTexBrick": compile_brick,
    "ShaderNodeTexGradient": compile_gradient,
    "ShaderNodeTexNoise": compile_noise,
    "ShaderNodeTexVoronoi": compile_voronoi,
    "ShaderNodeTexWave": compile_wave,
    "ShaderNodeTexMagic": compile_magic,
    "ShaderNodeTexWhiteNoise": compile_white_noise,
    "ShaderNodeTexGabor": compile_gabor,
}
