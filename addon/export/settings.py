"""The scene's render settings: the file's Cycles settings Snell follows (cycles_settings.py)
over every Blender property of tracer/settings.py's schema (blender_settings, with where each
value came from: setting_sources), and the scene file's render dict (convert_render)."""
from __future__ import annotations

from ...tracer.settings import RUN, SCENE, VIEWPORT, RenderSettings, of_scope
from . import cycles_settings
from .cycles_settings import FROM_CYCLES, FROM_DEFAULT, FROM_SNELL, FROM_SNELL_PANEL


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


def _snell_properties(scene) -> dict:
    """{name: value} of the Snell properties the scene holds (the add-on's, or saved ones)."""
    get = _stored(scene)
    found = {}
    for setting in of_scope(SCENE, RUN, VIEWPORT):
        value = _value(setting, get(setting.name))
        if value is not None:
            found[setting.name] = value
    use_adaptive = get("use_adaptive_sampling")
    if isinstance(use_adaptive, int) and not use_adaptive:
        found["noise_threshold"] = 0.0      # unchecked: the threshold is kept, not used
    return found


def follows_cycles(scene) -> bool:
    """Whether the scene's render follows its Cycles settings (Snell's "Follow Cycles' Settings",
    on unless unchecked) and Cycles' settings can be read (Cycles is registered)."""
    use = _stored(scene)("use_cycles_settings")
    return (use is None or bool(use)) and _cycles(scene) is not None


def overridden(scene) -> set:
    """The followed settings whose Snell value the user chose over Cycles' (the Sampling
    panel's Overrides): names from the add-on's set, or the bit mask saved in the file."""
    stored = _stored(scene)("overrides")
    names = [f.name for f in cycles_settings.FOLLOWED]
    if isinstance(stored, int):
        return {name for k, name in enumerate(names) if stored >> k & 1}
    return {str(item).lower() for item in (stored or ())} & set(names)


def _cycles(scene):
    cycles = getattr(scene, "cycles", None)
    return cycles if cycles is not None and hasattr(cycles, "samples") else None


def _resolve(scene) -> tuple[dict, dict]:
    """({name: value}, {name: where it came from}) of the scene's settings."""
    own = _snell_properties(scene)
    values, sources = {}, {}
    followed = (cycles_settings.followed(_cycles(scene), int(scene.frame_current))
                if follows_cycles(scene) else {})
    over = overridden(scene) if followed else set()
    followed = {name: value for name, value in followed.items() if name not in over}
    follows = {f.name for f in cycles_settings.FOLLOWED}
    for setting in of_scope(SCENE, RUN, VIEWPORT):
        name = setting.name
        if name in followed:
            values[name], sources[name] = followed[name], FROM_CYCLES
            continue
        if name in own:
            values[name] = own[name]
        # Followed settings read from Snell's panel override Cycles' (the user turned following
        # off); Snell's own settings are the user's where they differ from the default (a
        # registered property always reads back, so its default is not a choice).
        if name in over or (name in follows and name in own and not followed
                            and _cycles(scene) is not None):
            sources[name] = FROM_SNELL
        elif values.get(name, setting.default) != setting.default:
            sources[name] = FROM_SNELL_PANEL
        else:
            sources[name] = FROM_DEFAULT
    return values, sources


def blender_settings(scene) -> RenderSettings:
    """The scene's render settings: the file's Cycles settings Snell follows (unless "Follow
    Cycles' Settings" is off), then its Snell properties (the defaults without them); Snell's
    unchecked Noise Threshold is a threshold of 0."""
    return RenderSettings().replace(**_resolve(scene)[0])


def setting_sources(scene) -> dict:
    """{setting name: where its value came from} (cycles_settings' FROM_ names)."""
    return _resolve(scene)[1]


def not_followed(scene) -> list[dict]:
    """The file's Cycles settings Snell does not render (cycles_settings.not_rendered), or none
    when Cycles' settings cannot be read."""
    cycles = _cycles(scene)
    if cycles is None:
        return []
    return cycles_settings.not_rendered(cycles)


def convert_render(scene, warn=None) -> dict:
    """The scene file's render dict of the scene's settings, with where each came from
    ("sources") and the Cycles settings Snell does not render ("cycles_not_rendered"); warn(message)
    for each of those whose value the user set to something Snell renders differently."""
    render = blender_settings(scene).to_render()
    sources = setting_sources(scene)
    render["sources"] = {name: sources[name] for name in render}
    render["cycles_not_rendered"] = not_followed(scene)
    for entry in render["cycles_not_rendered"]:
        if entry["warn"] and warn is not None:
            warn(f"Cycles' {entry['label']} {entry['value']} is not rendered: {entry['snell']}")
    return render


def blender_threads(bl_scene, settings: RenderSettings) -> int:
    """The threads to render with: the setting, or (0) Blender's Performance > Threads."""
    return settings.threads or max(1, int(bl_scene.render.threads))
