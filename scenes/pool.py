"""A pool: the caustic the waves focus onto its floor, seen from above through the water
(specular, diffuse, specular paths: issue 34; photon merging, tracer/photon_merging.py).

Run: python scenes/pool.py OUT.blend
A 2 m white floor 0.5 m under a wavy water surface (smooth Glass BSDF, IOR 1.33, 4 cm waves), a
point lamp of radius 0.25 m 2 m above the water, the camera 1.4 m above the water looking down
through it. Black world, 256x256, Standard view. Cycles' shadow caustics are on (the lamp a
caustics light, the water a caster, the floor a receiver), as a user renders this with Cycles,
and Snell follows them (tracer/mnee.py). The same scene as tests/support/sds_scenes.pool.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from sds_geometry import POOL_HALF, water_surface  # noqa: E402

LAMP_POSITION, LAMP_RADIUS, LAMP_INTENSITY = (0.3, 0.2, 2.5), 0.25, 20.0   # W/sr
CAMERA, TARGET = (0.0, -0.25, 1.9), (0.0, 0.0, 0.0)


# The lamp's alternatives (tests/validation/test_mnee_compare.py): a sun of angle 0 of about the
# point lamp's irradiance at the water, and a square area lamp where the point lamp is.
SUN_DIRECTION, SUN_IRRADIANCE = (-0.12, -0.08, -1.0), 3.0
AREA_SIZE, AREA_POWER = 0.5, 78.5          # W: radiance P / (pi A) = 100


def build(path, light="point", floor=None, caustics=True):
    """Build the scene and save it to path; light: "point", "sun" or "area"; floor: a function
    making the floor's material (default: white diffuse); caustics: Cycles' shadow-caustics
    flags set (off: Cycles renders the water's caustic with its plain path tracer)."""
    scene = common.new_scene((0.0, 0.0, 0.0))
    floor = common.floor("Floor", POOL_HALF, floor() if floor else
                         common.material("Floor", "diffuse", (0.8, 0.8, 0.8)))
    water = common.material("Water", "glass", (1.0, 1.0, 1.0), IOR=1.33, Roughness=0.0)
    positions, triangles, _ = water_surface()
    water = common.mesh_object("Water", positions, triangles, water, smooth=True)
    lamp = {"point": lambda: common.point_lamp("Lamp", LAMP_POSITION, LAMP_INTENSITY,
                                               LAMP_RADIUS),
            "sun": lambda: common.sun("Sun", SUN_DIRECTION, SUN_IRRADIANCE),
            "area": lambda: common.area_lamp("Area", AREA_POWER, AREA_SIZE, LAMP_POSITION,
                                             None)}[light]()
    if caustics:
        common.shadow_caustics(lamp, [water], [floor])
    common.camera(scene, CAMERA, TARGET, lens=50.0)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "pool.blend"))
