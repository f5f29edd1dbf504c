"""A caustic on the floor: a glass sphere under a small lamp in the Cornell box, seen from above.

Run: python scenes/caustic_floor.py OUT.blend
The light that the sphere focuses onto the floor reaches a camera path only when a BSDF sample
from the floor passes through the sphere and hits the small lamp: the case the caustics light
tracer is for (README, Caustics). The lamp is a fifth of cornell_spheres' in width and 25 times as
bright, so the box gets the same power. 256x256, no depth of field.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

LAMP_SIZE = 0.1
SPHERE_RADIUS = 0.35


def build(path):
    """Build the scene and save it to path."""
    scene = common.reset()
    common.setup_render(scene, (256, 256))
    common.cornell_box(light_strength=15.0 * (0.5 / LAMP_SIZE) ** 2, light_size=LAMP_SIZE)
    glass = common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5, Roughness=0.0)
    common.uv_sphere("GlassSphere", (0.0, 0.0, 0.55), SPHERE_RADIUS, glass)
    common.camera(scene, (0.0, -1.7, 1.6), (0.0, 0.05, 0.2), lens=35.0)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "caustic_floor.blend"))
