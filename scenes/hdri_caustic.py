"""The world's caustics (issue 34): glass on a table under an HDRI sky with a sun in it, the most
common product shot.

Run: python scenes/hdri_caustic.py OUT.blend
A 4 m table top (Diffuse BSDF) with sun_caustic.py's glass tumbler and icosphere, under an
equirectangular sky made in code (scenes/sky.py: 128 x 256, a sun spot of peak 600 and width
0.03 rad 35 degrees above the horizon behind the glass, so its caustics fall towards the camera),
packed into the file. No lamp: Cycles' shadow caustics do not apply to the world, and Snell's
light tracer starts its light paths on the world. 256x256, Standard view.
"""
import math
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import common  # noqa: E402
import sky  # noqa: E402
from sun_caustic import CAMERA, TARGET, glass_pair  # noqa: E402

SUN_THETA, SUN_PHI = math.radians(55.0), 0.5 * math.pi + 0.3   # polar angle; azimuth
SUN_PEAK, SUN_SIGMA = 600.0, 0.03


def packed_sky(scene):
    """The sky as the world, its EXR packed into the file (the file stands alone)."""
    image = sky.sky(128, 256, sun_theta=SUN_THETA, sun_phi=SUN_PHI, sun_peak=SUN_PEAK,
                    sun_sigma=SUN_SIGMA)
    with tempfile.TemporaryDirectory(prefix="snell-sky-") as tmp:
        world = sky.set_hdri_world(scene, sky.write_exr(os.path.join(tmp, "sky.exr"), image))
        env = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeTexEnvironment")
        env.image.pack()
    return world


def build(path):
    """Build the scene and save it to path."""
    scene = common.reset()
    common.setup_render(scene, (256, 256))
    packed_sky(scene)
    common.floor("Table", 2.0, common.material("Table", "diffuse", (0.6, 0.5, 0.4)))
    glass = common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5, Roughness=0.0)
    glass_pair(glass)
    common.camera(scene, CAMERA, TARGET, lens=40.0)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "hdri_caustic.blend"))
