"""The seed's Cornell box with its spheres made rough: brushed metal and frosted glass.

Run: python scenes/cornell_rough.py OUT.blend
cornell_spheres.py with the mirror sphere a Glossy BSDF of roughness 0.3 and the glass sphere a
Glass BSDF of roughness 0.2, both with Blender's default distribution (Multiscatter GGX). The
bench times it against the smooth scene to measure what roughness costs.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from cornell_spheres import SPHERE_RADIUS  # noqa: E402

GLOSSY_ROUGHNESS = 0.3
GLASS_ROUGHNESS = 0.2


def build(path):
    """Build the scene and save it to path."""
    scene = common.reset()
    common.setup_render(scene, (256, 256))
    common.cornell_box()
    r = SPHERE_RADIUS
    metal = common.material("BrushedMetal", "glossy", (1.0, 1.0, 1.0), Roughness=GLOSSY_ROUGHNESS)
    frosted = common.material("FrostedGlass", "glass", (1.0, 1.0, 1.0), IOR=1.5,
                              Roughness=GLASS_ROUGHNESS)
    common.uv_sphere("MetalSphere", (-0.45, 0.35, r), r, metal)
    common.uv_sphere("FrostedSphere", (0.45, -0.3, r), r, frosted)
    common.cornell_camera(scene)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "cornell_rough.blend"))
