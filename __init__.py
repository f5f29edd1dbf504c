"""Snell: a Blender render engine with its own Embree path tracer.

Blender loads this file as the extension's entry point. It imports bpy only inside register()
so that `snell.tracer` and the `snell` command line work without Blender.
"""


def register():
    """Register Snell's classes with Blender."""
    from .addon import registration
    registration.register()


def unregister():
    """Remove every class and property Snell registered."""
    from .addon import registration
    registration.unregister()
