"""Blender's startup scene (the default cube, lamp and camera) as a user first sees it.

Run: python scenes/startup.py OUT.blend [WIDTH HEIGHT]
Factory settings, the render size set to WIDTH x HEIGHT (default 64 x 64) and Cycles chosen:
a scene the project did not build for Snell, for the validator's false-alarm runs.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import common  # noqa: E402


def build(path, width=64, height=64):
    """Build the scene and save it to path."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.render.resolution_x, scene.render.resolution_y = int(width), int(height)
    scene.render.resolution_percentage = 100
    return common.save(path)


if __name__ == "__main__":
    size = [int(x) for x in sys.argv[2:4]] or [64, 64]
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "startup.blend"), *size)
