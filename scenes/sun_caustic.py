"""A delta lamp's caustics (issue 34): a glass tumbler and a glass icosphere on a checker floor
under a sun of angle 0, the caustics falling in their shadows towards the camera.

Run: python scenes/sun_caustic.py OUT.blend
A 4 m floor of 8 x 8 tiles (a Checker Texture into a Diffuse BSDF), a thick-walled glass
tube (smooth Glass BSDF, IOR 1.5, 0.22 m radius, 4 cm walls, 0.45 m tall, 2 mm above the floor:
a tumbler without its base) and a smooth glass icosphere (radius 0.22, 3 subdivisions), a sun of angle 0
(a delta direction: no camera path can hit it, so only a light tracer renders its light through
the glass) and a dim grey world. Cycles' shadow caustics are on (the sun a caustics light, the
glass casters, the floor a receiver), as a user renders this with Cycles. 256x256, Standard
view.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import common  # noqa: E402
from sds_geometry import TUBE_LIFT, tube  # noqa: E402

SUN_DIRECTION, SUN_IRRADIANCE = (0.25, -0.8, -0.55), 3.0    # travel direction; W/m^2
CAMERA, TARGET = (0.3, -2.4, 1.7), (0.0, -0.3, 0.1)


def checker_floor(half=2.0, n=8):
    """A square floor of n x n tiles, a Checker Texture into a Diffuse BSDF (a node-tree
    material: light paths end on it, tracer/receivers.py)."""
    checker = common.checker_material("Checker", (0.8, 0.8, 0.8), (0.2, 0.2, 0.25), float(n))
    return [common.floor("Floor", half, checker)]


def icosphere(name, location, radius, mat):
    """A smooth icosphere (3 subdivisions) in a fixed polygon order."""
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=radius, location=location)
    obj = common.canonical_polygons(bpy.context.active_object)
    obj.name = obj.data.name = name
    obj.data.shade_smooth()
    obj.data.materials.append(mat)
    return obj


def glass_pair(glass):
    """The tumbler (left) and the icosphere (right) on the floor."""
    positions, triangles, normals = tube(outer=0.22, inner=0.18, height=0.45)
    positions = positions + [-0.35, 0.1, TUBE_LIFT]     # TUBE_LIFT: see sds_geometry.py
    tumbler = common.mesh_object("Tumbler", positions, triangles, glass, smooth=True)
    tumbler.data.normals_split_custom_set_from_vertices([tuple(n) for n in normals])
    ball = icosphere("Icosphere", (0.35, 0.0, 0.22), 0.22, glass)
    return tumbler, ball


def build(path):
    """Build the scene and save it to path."""
    scene = common.new_scene((0.05, 0.05, 0.05))
    floors = checker_floor()
    glass = common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5, Roughness=0.0)
    casters = glass_pair(glass)
    lamp = common.sun("Sun", SUN_DIRECTION, SUN_IRRADIANCE)
    common.shadow_caustics(lamp, casters, floors)
    common.camera(scene, CAMERA, TARGET, lens=40.0)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "sun_caustic.blend"))
