"""Snell's render settings, stored on every scene as `scene.snell`: one Blender property per
setting of tracer/settings.py that Blender shows (scopes SCENE, RUN and VIEWPORT), made from the
schema's name, documentation, default and range.

addon/export/settings.py reads them back (blender_settings); the viewport reads viewport_spp and
viewport_time_limit, the render engine threads and where F12 renders (render_on, with the
scheduler's address or the local workers: addon/final.py).
"""
import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from ..tracer.settings import RUN, SCENE, VIEWPORT, of_scope
from .export.cycles_settings import FOLLOWED

# The Sampling panel's checkbox, as Cycles has it: unchecked, the noise threshold is kept but not
# used (the scene file says noise_threshold 0). Blender's alone: the file has no such setting.
USE_ADAPTIVE_SAMPLING = BoolProperty(
    name="Noise Threshold", default=True,
    description="Stop sampling each pixel once its noise is below the threshold (adaptive "
                "sampling, as Cycles')")

# Snell follows the file's Cycles sampling and light-path settings (addon/export/cycles_settings.py)
# unless this is unchecked; then Snell's own Sampling and Light Paths settings override them.
USE_CYCLES_SETTINGS = BoolProperty(
    name="Follow Cycles' Settings", default=True,
    description="Render with the file's Cycles settings (samples, noise threshold, min samples, "
                "time limit, seed, max bounces), as a Cycles render of it would; off: Snell's "
                "own settings below override them")


# Per setting, Snell's own value over the file's Cycles one while Snell follows the rest
# (addon/export/settings.py: overridden). Saved as a bit mask in FOLLOWED's order.
OVERRIDES = EnumProperty(
    name="Overrides", options={"ENUM_FLAG"},
    items=[(f.name.upper(), f.label.rsplit(" > ", 1)[-1], f"Snell's own {f.name} instead of "
            f"Cycles' {f.label}", 1 << k) for k, f in enumerate(FOLLOWED)],
    description="The Cycles settings Snell's own values override")


# Where F12 renders (addon/final.py's cluster_of): Blender's alone, as the Performance panel's
# threads are; `snell batch --workers/--cluster` overrides it. Never the viewport.
RENDER_ON = EnumProperty(
    name="Render On", default="THIS_COMPUTER",
    items=[("THIS_COMPUTER", "This Computer", "Render in Blender's process"),
           ("DASK_SCHEDULER", "Dask Scheduler",
            "Send the frame's sample windows to the workers of a Dask scheduler (each with the "
            "same Snell installed): the same image, bit for bit"),
           ("LOCAL_WORKERS", "Local Dask Workers",
            "Start Dask worker processes on this computer for the render and stop them after "
            "it (a test of the cluster on one machine): the same image, bit for bit")],
    description="Where F12 renders: in Blender, or on the workers of a Dask cluster "
                "(pip install distributed in Blender's Python)")
CLUSTER_ADDRESS = StringProperty(
    name="Scheduler", default="tcp://127.0.0.1:8786",
    description="The Dask scheduler's address (printed by `dask scheduler`)")
CLUSTER_WORKERS = IntProperty(
    name="Workers", default=2, min=1, soft_max=64, max=1024,
    description="Dask worker processes started on this computer for the render (one thread "
                "each)")


def enum_items(setting) -> list:
    """A choice setting's Blender enum items: (VALUE, Value, what it means)."""
    return [(value.upper(), value.replace("_", "-").title(), doc) for value, doc in setting.choices]


def property_options(setting) -> tuple[str, dict]:
    """(bpy.props function name, its keywords) of a setting's Blender property."""
    options = {"name": setting.label or setting.name.replace("_", " ").title(),
               "description": setting.doc, **setting.ui}
    if setting.type is bool:
        return "BoolProperty", {**options, "default": setting.default}
    if setting.type is str:
        return "EnumProperty", {**options, "items": enum_items(setting),
                                "default": setting.default.upper()}
    limits = {"min": setting.least}
    if setting.greatest is not None:
        limits["max"] = setting.greatest
    kind = "IntProperty" if setting.type is int else "FloatProperty"
    return kind, {**options, **limits, "default": setting.default}


def _annotations() -> dict:
    """The property group's properties: the schema's, and the adaptive sampling checkbox."""
    props = {}
    for setting in of_scope(SCENE, RUN, VIEWPORT):
        kind, options = property_options(setting)
        props[setting.name] = getattr(bpy.props, kind)(**options)
    props["use_adaptive_sampling"] = USE_ADAPTIVE_SAMPLING
    props["use_cycles_settings"] = USE_CYCLES_SETTINGS
    props["overrides"] = OVERRIDES
    props["render_on"] = RENDER_ON
    props["cluster_address"] = CLUSTER_ADDRESS
    props["cluster_workers"] = CLUSTER_WORKERS
    return props


SnellRenderSettings = type("SnellRenderSettings", (bpy.types.PropertyGroup,),
                           {"__annotations__": _annotations(), "__module__": __name__,
                            "__doc__": "Snell's render settings (tracer/settings.py)."})


def register():
    bpy.types.Scene.snell = bpy.props.PointerProperty(type=SnellRenderSettings, name="Snell")


def unregister():
    del bpy.types.Scene.snell


_standalone = False


def ensure_readable():
    """Make scene.snell readable without the add-on (the `snell` command exporting a .blend).

    Blender 5 keeps add-on properties out of reach until their type is registered; only the
    property group is registered here, and registration.register() takes it over.
    """
    global _standalone
    if hasattr(bpy.types.Scene, "snell"):
        return
    bpy.utils.register_class(SnellRenderSettings)
    register()
    _standalone = True


def drop_standalone():
    """Undo ensure_readable() before the full registration."""
    global _standalone
    if _standalone:
        unregister()
        bpy.utils.unregister_class(SnellRenderSettings)
        _standalone = False
