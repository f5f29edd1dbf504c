"""The scene's Snell render settings as the scene file's render dict (convert_render)."""
from __future__ import annotations

from ...tracer import scene as scene_mod


def convert_render(scene):
    """Render settings from scene.snell if the add-on registered them, else the defaults.

    Without the add-on registered (`snell render file.blend`), the settings the add-on saved in
    the file are still there as ID properties (only non-default values; the Fresnel enum as its
    item index, booleans as integers), so they are read from there.
    """
    render = dict(scene_mod.DEFAULT_RENDER)
    props = getattr(scene, "snell", None)
    if props is not None:
        get = lambda key: getattr(props, key, None)  # noqa: E731
    else:
        stored = scene.get("snell") if hasattr(scene, "get") else None
        if stored is None or not hasattr(stored, "get"):
            return render
        get = stored.get
    for key in ("spp", "max_depth", "seed", "min_spp"):
        if isinstance(get(key), int):
            render[key] = int(get(key))
    fresnel = get("fresnel")
    if isinstance(fresnel, str):
        render["fresnel"] = fresnel.lower()
    elif isinstance(fresnel, int) and 0 <= fresnel < len(scene_mod.FRESNEL_MODELS):
        render["fresnel"] = scene_mod.FRESNEL_MODELS[fresnel]  # items: EXACT, SCHLICK
    for key in ("caustics", "light_vertices"):
        if isinstance(get(key), int):
            render[key] = bool(get(key))
    if isinstance(get("noise_threshold"), (int, float)):
        # Blender keeps the value as a 32-bit float: 7 digits give back the 0.01 typed in.
        render["noise_threshold"] = float(f"{float(get('noise_threshold')):.7g}")
    if isinstance(get("use_adaptive_sampling"), int) and not get("use_adaptive_sampling"):
        render["noise_threshold"] = 0.0     # unchecked: the threshold is kept, not used
    return render
