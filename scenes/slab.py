"""Slab test: the camera looks through a closed flat glass box (IOR 1.5) at an emitter.

Run: python scenes/slab.py OUT.blend
The 2 x 2 x 0.1 m slab floats at z = 1.5 between a camera at z = 4 looking straight down and a
10 x 10 m emission quad of radiance 1 at z = 0; the world is black. At normal incidence the
expected pixel value is the two-interface transmittance (1 - F)^2 / (1 - F^2) = 0.923 (F = 0.04)
with every internal bounce counted, 0.9216 with one pass only.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402


def build(path, ior=1.5, thickness=0.1):
    """Build the slab scene and save it to path."""
    scene = common.reset()
    common.setup_render(scene, (64, 64), max_bounces=31)
    lamp = common.material("Emitter", "emission", (1.0, 1.0, 1.0), Strength=1.0)
    common.quad("Emitter", [(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], lamp)
    glass = common.material("SlabGlass", "glass", (1.0, 1.0, 1.0), IOR=ior)
    import bpy
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 1.5))
    slab = bpy.context.active_object
    slab.name = "Slab"
    slab.scale = (2.0, 2.0, thickness)
    slab.data.materials.append(glass)
    common.camera(scene, (0.0, 0.0, 4.0), (0.0, 0.0, 0.0), lens=50.0)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1])
