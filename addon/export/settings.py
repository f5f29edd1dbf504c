"""The scene's Snell render settings: every Blender property of tracer/settings.py's schema read
back (blender_settings), and the scene file's render dict (convert_render)."""
from __future__ import annotations

from ...tracer.settings import RUN, SCENE, VIEWPORT, RenderSettings, of_scope


def _stored(scene):
    """A getter of the scene's Snell properties: scene.snell if the add-on registered them, else
    the ID properties the add-on saved in the file (only non-default values; enums as their
    item index, booleans as integers), else nothing."""
    props = getattr(scene, "snell", None)
    if props is not None:
        return lambda key: getattr(props, key, None)
    stored = scene.get("snell") if hasattr(scene, "get") else None
    if stored is None or not hasattr(stored, "get"):
        return lambda key: None
    return stored.get


def _value(setting, value):
    """A property's value as the setting holds it, or None if it is not one."""
    if setting.type is str:
        if isinstance(value, str):
            return value.lower()             # enum identifiers are the values in capitals
        if isinstance(value, int) and 0 <= value < len(setting.choices):
            return setting.values[value]
        return None
    if not isinstance(value, (int, float)):
        return None
    if setting.type is float:
        # Blender keeps the value as a 32-bit float: 7 digits give back the 0.01 typed in.
        return float(f"{float(value):.7g}")
    if isinstance(value, float):
        return None
    return bool(value) if setting.type is bool else int(value)


def blender_settings(scene) -> RenderSettings:
    """The settings of the scene's Snell properties (the defaults without them); the Sampling
    panel's unchecked Noise Threshold is a threshold of 0."""
    get = _stored(scene)
    found = {}
    for setting in of_scope(SCENE, RUN, VIEWPORT):
        value = _value(setting, get(setting.name))
        if value is not None:
            found[setting.name] = value
    use_adaptive = get("use_adaptive_sampling")
    if isinstance(use_adaptive, int) and not use_adaptive:
        found["noise_threshold"] = 0.0      # unchecked: the threshold is kept, not used
    return RenderSettings().replace(**found)


def convert_render(scene) -> dict:
    """The scene file's render dict of the scene's Snell properties."""
    return blender_settings(scene).to_render()


def blender_threads(bl_scene, settings: RenderSettings) -> int:
    """The threads to render with: the setting, or (0) Blender's Performance > Threads."""
    return settings.threads or max(1, int(bl_scene.render.threads))
