"""A caustic inside a glass seen through its wall (specular, diffuse, specular paths: issue 34;
photon merging, tracer/photon_merging.py).

Run: python scenes/tumbler_caustic.py OUT.blend
A thick-walled glass tube (smooth Glass BSDF, IOR 1.5, 0.4 m radius, 6 cm walls, 0.9 m tall;
a tumbler whose floor is the table) on a white table, lit from one side by a point lamp of
radius 0.1 m whose light the wall brings onto the table inside; the camera, on the other side,
sees it through the near wall. Black world, 256x256, Standard view. Cycles' shadow caustics are
on (the lamp a caustics light, the tube a caster, the table a receiver), as a user renders this
with Cycles; Snell ignores those flags. The same scene as tests/support/sds_scenes.tumbler, but
for the tube standing 2 mm above the table (a bottom rim coplanar with the table is resolved
differently by Snell and Cycles).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from sds_geometry import TUBE_LIFT, tube  # noqa: E402

LAMP_POSITION, LAMP_RADIUS, LAMP_INTENSITY = (1.4, 0.3, 0.55), 0.1, 20.0   # W/sr
CAMERA, TARGET = (-2.2, -0.4, 1.1), (0.0, 0.0, 0.25)


def build(path):
    """Build the scene and save it to path."""
    scene = common.new_scene((0.0, 0.0, 0.0))
    table = common.floor("Table", 2, common.material("Table", "diffuse", (0.8, 0.8, 0.8)))
    glass = common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5, Roughness=0.0)
    positions, triangles, normals = tube()
    obj = common.mesh_object("Tumbler", positions, triangles, glass, smooth=True)
    obj.data.normals_split_custom_set_from_vertices([tuple(n) for n in normals])
    obj.location.z = TUBE_LIFT     # see sds_geometry.py
    lamp = common.point_lamp("Lamp", LAMP_POSITION, LAMP_INTENSITY, LAMP_RADIUS)
    common.shadow_caustics(lamp, [obj], [table])
    common.camera(scene, CAMERA, TARGET, lens=50.0)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "tumbler_caustic.blend"))
