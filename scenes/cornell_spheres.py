"""The seed's CS184 project 3-2 scene (CBspheres): a Cornell box with a mirror and a glass sphere.

Run: python scenes/cornell_spheres.py OUT.blend
The mirror sphere (Glossy BSDF, roughness 0, white) stands back-left, the glass sphere (Glass BSDF,
IOR 1.5, roughness 0, white) front-right; a two-sided emissive quad just below the ceiling lights
the box and is visible to the camera. 256x256, no depth of field, Standard view transform.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

SPHERE_RADIUS = 0.45


def build(path, mirror_roughness=0.0, glass_roughness=0.0, names=("Mirror", "Glass")):
    """Build the scene and save it to path (rough spheres for cornell_rough.py)."""
    scene = common.reset()
    common.setup_render(scene, (256, 256))
    common.cornell_box()
    r = SPHERE_RADIUS
    mirror = common.material(names[0], "glossy", (1.0, 1.0, 1.0), Roughness=mirror_roughness)
    glass = common.material(names[1], "glass", (1.0, 1.0, 1.0), IOR=1.5,
                            Roughness=glass_roughness)
    common.uv_sphere(f"{names[0]}Sphere", (-0.45, 0.35, r), r, mirror)
    common.uv_sphere(f"{names[1]}Sphere", (0.45, -0.3, r), r, glass)
    common.cornell_camera(scene)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "cornell_spheres.blend"))
