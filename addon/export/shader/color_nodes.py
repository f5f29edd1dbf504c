"""The colour nodes' compile functions for shader programs: RGB, Mix and MixRGB, Invert,
Hue/Saturation/Value, Gamma, Bright/Contrast, Separate/Combine Color, RGB to BW, Blackbody,
Wavelength, Color Ramp, RGB Curves, Vector Curves, Float Curve (rows of
tracer/shader/color_nodes.py).

Ramps and curves are baked into tables as Blender's Cycles sync bakes them
(intern/cycles/blender/util.h: colorramp_to_array, curvemapping_color_to_array,
curvemapping_float_to_array): RAMP_TABLE_SIZE + 1 entries, evaluated by Blender itself
(ColorRamp.evaluate, CurveMapping.evaluate), so every interpolation and colour mode of a ramp and
every curve handle type come out as Blender computes them."""
from __future__ import annotations

from ....tracer.shader import color_nodes as ops

FLT_MAX = 3.4028234663852886e38


def _index(c, node, names, value, what):
    """The literal int of an enum value, or 0 with a warning if this Blender has a newer one."""
    if value in names:
        return names.index(value)
    c.warn(node, f"{what} {value} is not evaluated", names[0].title())
    return 0


def ramp_table(ramp):
    """A Color Ramp's table: RAMP_TABLE_SIZE + 1 RGBA entries at i / RAMP_TABLE_SIZE, flat."""
    n = ops.RAMP_TABLE_SIZE
    table = []
    for i in range(n + 1):
        table.extend(float(v) for v in ramp.evaluate(i / n))
    return table


def curves_range(mapping, count):
    """(min_x, max_x) over the first count curves' end points (curvemapping_minmax)."""
    lo, hi = FLT_MAX, -FLT_MAX
    for curve in list(mapping.curves)[:count]:
        lo = min(lo, curve.points[0].location[0])
        hi = max(hi, curve.points[-1].location[0])
    return float(lo), float(hi)


def rgb_curves_table(mapping, combined=True):
    """RGB Curves' data (Vector Curves' with combined=False): min_x, max_x, then
    RAMP_TABLE_SIZE + 1 RGB entries at min_x + i / RAMP_TABLE_SIZE (max_x - min_x), each
    channel's curve applied after the combined (C) curve of RGB Curves."""
    mapping.initialize()
    lo, hi = curves_range(mapping, 4 if combined else 3)
    r, g, b = mapping.curves[0], mapping.curves[1], mapping.curves[2]
    n = ops.RAMP_TABLE_SIZE
    table = [lo, hi]
    for i in range(n + 1):
        t = lo + i / n * (hi - lo)
        if combined:
            t = mapping.evaluate(mapping.curves[3], t)
        table += [mapping.evaluate(r, t), mapping.evaluate(g, t), mapping.evaluate(b, t)]
    return table


def float_curve_table(mapping):
    """Float Curve's data: min_x, max_x, then RAMP_TABLE_SIZE + 1 values of its curve."""
    mapping.initialize()
    lo, hi = curves_range(mapping, 1)
    curve = mapping.curves[0]
    n = ops.RAMP_TABLE_SIZE
    return [lo, hi] + [mapping.evaluate(curve, lo + i / n * (hi - lo)) for i in range(n + 1)]


def compile_mix(c, node):
    """Mix: Float, Vector (uniform or non-uniform factor) or Color (every blend mode)."""
    clamp = int(node.clamp_factor)
    if node.data_type == "FLOAT":
        out = c.alloc("float")
        c.emit(ops.MIX_FLOAT, clamp, c.input(node, "Factor_Float", "float"),
               c.input(node, "A_Float", "float"), c.input(node, "B_Float", "float"), out)
        return {"Result_Float": out}
    if node.data_type == "VECTOR":
        out = c.alloc("vector")
        if node.factor_mode == "NON_UNIFORM":
            c.emit(ops.MIX_VECTOR_NONUNIFORM, clamp, c.input(node, "Factor_Vector", "vector"),
                   c.input(node, "A_Vector", "vector"), c.input(node, "B_Vector", "vector"), out)
        else:
            c.emit(ops.MIX_VECTOR, clamp, c.input(node, "Factor_Float", "float"),
                   c.input(node, "A_Vector", "vector"), c.input(node, "B_Vector", "vector"), out)
        return {"Result_Vector": out}
    if node.data_type == "RGBA":
        blend = _index(c, node, ops.BLEND_TYPES, node.blend_type, "blend mode")
        out = c.alloc("color")
        c.emit(ops.MIX_COLOR, blend, clamp, int(node.clamp_result),
               c.input(node, "Factor_Float", "float"), c.input(node, "A_Color", "color"),
               c.input(node, "B_Color", "color"), out)
        return {"Result_Color": out}
    c.warn(node, f"data type {node.data_type} is not evaluated in shaders", "no output")
    return {}


def compile_mix_rgb(c, node):
    """The legacy MixRGB: its factor always clamped (svm_mix_clamped_factor), Clamp on the
    result."""
    blend = _index(c, node, ops.BLEND_TYPES, node.blend_type, "blend mode")
    out = c.alloc("color")
    c.emit(ops.MIX_COLOR, blend, 1, int(node.use_clamp), c.input(node, "Fac", "float"),
           c.input(node, "Color1", "color"), c.input(node, "Color2", "color"), out)
    return {"Color": out}


def compile_invert(c, node):
    """Invert: one INVERT row."""
    out = c.alloc("color")
    c.emit(ops.INVERT, c.input(node, "Fac", "float"), c.input(node, "Color", "color"), out)
    return {"Color": out}


def compile_hue_saturation(c, node):
    """Hue/Saturation/Value: one HUE_SAT row."""
    out = c.alloc("color")
    c.emit(ops.HUE_SAT, c.input(node, "Hue", "float"), c.input(node, "Saturation", "float"),
           c.input(node, "Value", "float"), c.input(node, "Fac", "float"),
           c.input(node, "Color", "color"), out)
    return {"Color": out}


def compile_gamma(c, node):
    """Gamma: one GAMMA row."""
    out = c.alloc("color")
    c.emit(ops.GAMMA, c.input(node, "Gamma", "float"), c.input(node, "Color", "color"), out)
    return {"Color": out}


def compile_bright_contrast(c, node):
    """Bright/Contrast: one BRIGHT_CONTRAST row."""
    out = c.alloc("color")
    c.emit(ops.BRIGHT_CONTRAST, c.input(node, "Bright", "float"),
           c.input(node, "Contrast", "float"), c.input(node, "Color", "color"), out)
    return {"Color": out}


def compile_separate_color(c, node):
    """Separate Color (RGB, HSV, HSL): one SEPARATE_COLOR row."""
    mode = _index(c, node, ops.COLOR_MODES, node.mode, "mode")
    r, g, b = c.alloc("float"), c.alloc("float"), c.alloc("float")
    c.emit(ops.SEPARATE_COLOR, mode, c.input(node, "Color", "color"), r, g, b)
    return {"Red": r, "Green": g, "Blue": b}


def compile_combine_color(c, node):
    """Combine Color (RGB, HSV, HSL): one COMBINE_COLOR row."""
    mode = _index(c, node, ops.COLOR_MODES, node.mode, "mode")
    out = c.alloc("color")
    c.emit(ops.COMBINE_COLOR, mode, c.input(node, "Red", "float"), c.input(node, "Green", "float"),
           c.input(node, "Blue", "float"), out)
    return {"Color": out}


def compile_rgb_to_bw(c, node):
    """RGB to BW: one RGB_TO_BW row."""
    out = c.alloc("float")
    c.emit(ops.RGB_TO_BW, c.input(node, "Color", "color"), out)
    return {"Val": out}


def compile_blackbody(c, node):
    """Blackbody: one BLACKBODY row."""
    out = c.alloc("color")
    c.emit(ops.BLACKBODY, c.input(node, "Temperature", "float"), out)
    return {"Color": out}


def compile_wavelength(c, node):
    """Wavelength: one WAVELENGTH row."""
    out = c.alloc("color")
    c.emit(ops.WAVELENGTH, c.input(node, "Wavelength", "float"), out)
    return {"Color": out}


def compile_color_ramp(c, node):
    """Color Ramp: its table in data and one COLOR_RAMP row (Constant does not interpolate)."""
    ramp = node.color_ramp
    color, alpha = c.alloc("color"), c.alloc("float")
    table = ramp_table(ramp)
    c.emit(ops.COLOR_RAMP, int(ramp.interpolation != "CONSTANT"), c.data(table), len(table),
           c.input(node, "Fac", "float"), color, alpha)
    return {"Color": color, "Alpha": alpha}


def compile_rgb_curves(c, node):
    """RGB Curves: its table in data and one RGB_CURVES row."""
    out = c.alloc("color")
    table = rgb_curves_table(node.mapping)
    c.emit(ops.RGB_CURVES, int(node.mapping.extend == "EXTRAPOLATED"), c.data(table), len(table),
           c.input(node, "Fac", "float"), c.input(node, "Color", "color"), out)
    return {"Color": out}


def compile_vector_curves(c, node):
    """Vector Curves: Cycles runs it as RGB Curves without the combined curve."""
    out = c.alloc("vector")
    table = rgb_curves_table(node.mapping, combined=False)
    c.emit(ops.RGB_CURVES, int(node.mapping.extend == "EXTRAPOLATED"), c.data(table), len(table),
           c.input(node, "Fac", "float"), c.input(node, "Vector", "vector"), out)
    return {"Vector": out}


def compile_float_curve(c, node):
    """Float Curve: its table in data and one FLOAT_CURVE row."""
    out = c.alloc("float")
    table = float_curve_table(node.mapping)
    c.emit(ops.FLOAT_CURVE, int(node.mapping.extend == "EXTRAPOLATED"), c.data(table), len(table),
           c.input(node, "Factor", "float"), c.input(node, "Value", "float"), out)
    return {"Value": out}


def compile_rgb(c, node):
    """RGB: a constant colour (Cycles' ColorNode; alpha dropped)."""
    return {"Color": c.constant(tuple(float(v) for v in node.outputs[0].default_value[:3]))}


COMPILERS = {
    "ShaderNodeRGB": compile_rgb,
    "ShaderNodeMix": compile_mix,
    "ShaderNodeMixRGB": compile_mix_rgb,
    "ShaderNodeInvert": compile_invert,
    "ShaderNodeHueSaturation": compile_hue_saturation,
    "ShaderNodeGamma": compile_gamma,
    "ShaderNodeBrightContrast": compile_bright_contrast,
    "ShaderNodeSeparateColor": compile_separate_color,
    "ShaderNodeCombineColor": compile_combine_color,
    "ShaderNodeRGBToBW": compile_rgb_to_bw,
    "ShaderNodeBlackbody": compile_blackbody,
    "ShaderNodeWavelength": compile_wavelength,
    "ShaderNodeValToRGB": compile_color_ramp,
    "ShaderNodeRGBCurve": compile_rgb_curves,
    "ShaderNodeVectorCurve": compile_vector_curves,
    "ShaderNodeFloatCurve": compile_float_curve,
}
