"""Register and unregister everything Snell adds to Blender, in one place.

Order: the property group and `scene.snell`, the render engine, the panels, then SNELL in the
COMPAT_ENGINES of Blender's own panels. unregister() undoes it in reverse, so enable, disable,
enable again leaves Blender as it was.
"""
import bpy

from . import engine, properties, ui

classes = (properties.SnellRenderSettings, engine.SnellRenderEngine, *ui.classes)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def is_registered() -> bool:
    return engine.SnellRenderEngine.is_registered


def register():
    properties.drop_standalone()
    _register_classes()
    properties.register()
    ui.add_compat_engine()


def unregister():
    ui.remove_compat_engine()
    properties.unregister()
    _unregister_classes()


def ensure_registered():
    """Register unless already registered (for `snell batch` through the bpy module)."""
    if not is_registered():
        register()
