"""Blender lamps as the scene file's light dicts (convert_light): area, point, spot and sun
lamps, their strength from the lamp's colour, energy and Emission node, and their ray visibility.
"""
from __future__ import annotations

import math
import warnings as _pywarnings

import numpy as np

from ...tracer.scene import SceneError
from .camera import unit_columns
from .nodes import Inputs, active_output, follow


# The lamp's numbers as Blender's Light properties panel names them (energy: Power, or Strength
# for a sun).
LABELS = {"energy": "Power", "color": "Color", "shadow_soft_size": "Radius", "size": "Size",
          "size_y": "Size Y", "spot_size": "Beam Angle", "spot_blend": "Blend", "angle": "Angle",
          "spread": "Spread", "exposure": "Exposure"}


def _check_finite(obj):
    """Refuse a lamp with a NaN or Inf property or a negative power, naming the lamp and the
    property (Blender's fields take them from Python; the scene file's check would name its own
    field instead)."""
    light = obj.data
    for attr, label in LABELS.items():
        value = getattr(light, attr, None)
        if value is None:
            continue
        values = [float(v) for v in value] if hasattr(value, "__len__") else [float(value)]
        if not all(math.isfinite(v) for v in values):
            if attr == "energy" and light.type == "SUN":
                label = "Strength"
            shown = values[0] if len(values) == 1 else values
            raise SceneError(f"light {obj.name!r}: {label} is {shown} (not a finite number)")
    if light.energy < 0:    # Cycles lets it subtract light; the scene file has no such lamp
        label = "Strength" if light.type == "SUN" else "Power"
        raise SceneError(f"light {obj.name!r}: {label} is {light.energy:g}: Snell renders no "
                         "negative lights")


def _light_color(light):
    """Cycles' light strength: colour x temperature colour x energy x 2^exposure (RGB)."""
    color = np.array(light.color[:3], np.float64)
    if getattr(light, "use_temperature", False):
        color = color * np.array(light.temperature_color[:3])
    return color * light.energy * 2.0 ** getattr(light, "exposure", 0.0)


def _light_nodes_factor(obj, warn):
    """The light's node tree's Emission Color x Strength (1 without nodes), as Cycles uses it."""
    light = obj.data
    with _pywarnings.catch_warnings():
        _pywarnings.simplefilter("ignore", DeprecationWarning)  # use_nodes goes in Blender 6
        use_nodes = getattr(light, "use_nodes", False)
    tree = light.node_tree if use_nodes else None
    if tree is None:
        return np.ones(3)
    out = active_output(tree, "ShaderNodeOutputLight")
    node = follow(out.inputs["Surface"]) if out is not None else None
    if node is None:
        return np.zeros(3)              # an unconnected output: Cycles' lamp emits nothing
    if node.bl_idname != "ShaderNodeEmission":
        warn(f"light {obj.name!r}: node {node.name!r} ({node.bl_idname}) is not supported, "
             f"using the light's colour and strength alone")
        return np.ones(3)
    issues = []
    inputs = Inputs(node, issues)
    factor = np.array(inputs.color("Color")) * inputs.value("Strength")
    for issue in issues:
        warn(f"light {obj.name!r}: {issue}")
    return factor


def _light_flags(obj):
    """The light object's ray visibility and its lamp's shadow and MIS options."""
    light = obj.data
    cycles = getattr(light, "cycles", None)
    return {"visible_camera": bool(obj.visible_camera),
            "visible_diffuse": bool(obj.visible_diffuse),
            "visible_glossy": bool(obj.visible_glossy),
            "visible_transmission": bool(obj.visible_transmission),
            "cast_shadow": bool(getattr(light, "use_shadow", True)),
            "use_mis": bool(getattr(cycles, "use_multiple_importance_sampling", True)),
            # Cycles' shadow caustics (tracer/mnee.py): written only when on.
            **({"caustics_light": True} if getattr(cycles, "is_caustics_light", False) else {})}


def convert_light(obj, matrix, warn):
    """Light dict for a light object with world matrix (numpy 4x4), or None if skipped.

    Strengths follow Cycles (docs/lights.md): normalize (Blender 5; always on in 4.x) divides a
    lamp's power by its area; point and spot lamps store the intensity I of their centre, and a
    radius r > 0 emits radiance I / (pi r^2).
    """
    light = obj.data
    _check_finite(obj)
    with np.errstate(over="ignore", invalid="ignore"):
        strength = _light_color(light) * _light_nodes_factor(obj, warn)
    if not np.all(np.isfinite(strength)):
        raise SceneError(f"light {obj.name!r}: its strength (Color x Power x its Emission "
                         f"node) is {strength.tolist()}, not finite")
    normalize = bool(getattr(light, "normalize", True))
    common = {"name": obj.name, **_light_flags(obj)}
    if light.type == "AREA":
        scale = np.linalg.norm(matrix[:3, :3], axis=0)
        shape = light.shape.lower()
        sx = light.size
        sy = light.size_y if shape in ("rectangle", "ellipse") else light.size
        size = [float(sx * scale[0]), float(sy * scale[1])]
        area = size[0] * size[1] * (math.pi / 4 if shape in ("disk", "ellipse") else 1.0)
        if area <= 0:
            warn(f"light {obj.name!r}: zero-area area light skipped")
            return None
        unit = unit_columns(matrix)
        if unit is None:
            warn(f"light {obj.name!r}: zero scale, skipped")
            return None
        radiance = strength / (math.pi * (area if normalize else 1.0))
        return {**common, "kind": "area", "shape": shape, "matrix": unit.tolist(),
                "size": size, "radiance": radiance.tolist(), "spread": float(light.spread)}
    if light.type in ("POINT", "SPOT"):
        radius = float(light.shadow_soft_size)
        # I = P / (4 pi) normalised; unnormalised, a radius r > 0 emits P / pi (so I = P r^2)
        # and radius 0 has I = P / pi (Blender 5.0; 4.2 kept P / (4 pi)).
        if normalize:
            intensity = strength / (4.0 * math.pi)
        else:
            intensity = strength * (radius * radius if radius > 0 else 1.0 / math.pi)
        entry = {**common, "kind": light.type.lower(), "position": matrix[:3, 3].tolist(),
                 "intensity": intensity.tolist(), "radius": radius,
                 "soft_falloff": bool(getattr(light, "use_soft_falloff", True))}
        if light.type == "SPOT":
            if abs(np.linalg.det(matrix[:3, :3])) < 1e-30:
                warn(f"light {obj.name!r}: zero scale, skipped")
                return None
            entry.update(matrix=matrix.tolist(), spot_size=float(light.spot_size),
                         spot_blend=float(light.spot_blend))
        return entry
    if light.type == "SUN":
        d = matrix[:3, :3] @ np.array([0.0, 0.0, -1.0])
        angle = float(light.angle)
        # Unnormalised, the disc's radiance is the strength itself: irradiance pi sin^2(a/2) L.
        irradiance = (strength if normalize or angle == 0
                      else strength * math.pi * math.sin(0.5 * angle) ** 2)
        return {**common, "kind": "sun", "direction": (d / np.linalg.norm(d)).tolist(),
                "irradiance": irradiance.tolist(), "angle": angle}
    warn(f"light {obj.name!r}: {light.type.lower()} lights are not supported, skipped")
    return None
