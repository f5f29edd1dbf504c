"""Register and unregister everything Snell adds to Blender, in one place.

Order: the property group and `scene.snell`, the render engine, the panels, SNELL in the
COMPAT_ENGINES of Blender's own panels, then the watch that compiles the kernels in the
background once Snell is the engine (kernel_warmup). unregister() undoes it in reverse,
so enable, disable,
enable again leaves Blender as it was.
"""
import os

import bpy

from . import engine, kernel_warmup, properties, ui

classes = (properties.SnellRenderSettings, engine.SnellRenderEngine, *ui.classes)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def is_registered() -> bool:
    return engine.SnellRenderEngine.is_registered


def _kernel_cache_in_user_directory():
    """Installed as an extension, keep compiled kernels in the extension's own user directory
    (kept across Blender versions and removed with the extension); must run before any kernel
    module is imported, since Numba fixes a kernel's cache directory when it is defined."""
    package = __package__.rsplit(".", 1)[0]          # bl_ext.<repository>.snell
    if not package.startswith("bl_ext.") or os.environ.get("SNELL_KERNEL_CACHE"):
        return
    from ..tracer import jit
    jit.set_cache_dir(bpy.utils.extension_path_user(package, path="kernels", create=True))


def register():
    _kernel_cache_in_user_directory()
    properties.drop_standalone()
    _register_classes()
    properties.register()
    ui.add_compat_engine()
    kernel_warmup.register()


def unregister():
    kernel_warmup.unregister()
    ui.remove_compat_engine()
    properties.unregister()
    _unregister_classes()


def ensure_registered():
    """Register unless already registered (for `snell batch` through the bpy module)."""
    if not is_registered():
        register()
