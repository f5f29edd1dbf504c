"""The seed's Cornell box with its spheres made rough: brushed metal and frosted glass.

Run: python scenes/cornell_rough.py OUT.blend
cornell_spheres.py with the mirror sphere a Glossy BSDF of roughness 0.3 and the glass sphere a
Glass BSDF of roughness 0.2, both with Blender's default distribution (Multiscatter GGX). The
bench times it against the smooth scene to measure what roughness costs.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cornell_spheres  # noqa: E402

GLOSSY_ROUGHNESS = 0.3
GLASS_ROUGHNESS = 0.2


def build(path):
    """Build the scene and save it to path."""
    return cornell_spheres.build(path, GLOSSY_ROUGHNESS, GLASS_ROUGHNESS,
                                 names=("BrushedMetal", "FrostedGlass"))


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "cornell_rough.blend"))
