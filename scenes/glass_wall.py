"""A drinking glass in front of a textured wall: the wall is seen through two glass walls, the
case where a denoiser's guiding passes must follow the specular chain (issue 33's bench scene).

Run: python scenes/glass_wall.py OUT.blend
A hollow tumbler (smooth Glass BSDF, IOR 1.5, walls 4 cm thick, a 6 cm base) stands on a white
floor before a wall with a checker image (16 x 16 cells, Closest, packed into the .blend), lit
by an area lamp and a dim grey world. 256x256, Standard view.
"""
import math
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import bmesh  # noqa: E402  (bpy's module: importable after bpy)
import numpy as np  # noqa: E402
import common  # noqa: E402
from textured_floors import image_material, write_png  # noqa: E402

# The tumbler's profile (radius, height) in metres, revolved about the z axis.
RADIUS, HEIGHT, WALL, BASE = 0.38, 0.95, 0.04, 0.06
SEGMENTS = 64


def checker_png(path, cells=16, cell_px=8):
    """A cells x cells checker of two colours (8-bit sRGB), cell_px pixels a cell, with a thin
    dark line through each light cell so that the wall has detail finer than a cell."""
    n = cells * cell_px
    rows, cols = np.indices((n, n))
    light = ((rows // cell_px + cols // cell_px) % 2 == 0)
    image = np.where(light[..., None], np.array([235, 215, 150]), np.array([35, 60, 140]))
    image[light & (rows % cell_px == cell_px // 2)] = (90, 30, 30)
    return write_png(path, image.astype(np.uint8))


def tumbler(name, location, mat):
    """A closed hollow glass: the profile below revolved, its outward normals recomputed, the
    outer and inner walls smooth and the rim, base and floor of the inside flat (sharp edges
    between them, so the walls' normals stay horizontal at the rim)."""
    profile = [(RADIUS, 0.0), (RADIUS, HEIGHT), (RADIUS - WALL, HEIGHT),
               (RADIUS - WALL, BASE)]                     # bottom outer edge to inner bottom edge
    bm = bmesh.new()
    bottom, inside = bm.verts.new((0.0, 0.0, 0.0)), bm.verts.new((0.0, 0.0, BASE))
    rings = []
    for r, z in profile:
        rings.append([bm.verts.new((r * math.cos(2 * math.pi * k / SEGMENTS),
                                    r * math.sin(2 * math.pi * k / SEGMENTS), z))
                      for k in range(SEGMENTS)])
    smooth = {0, 2}                                       # outer wall, inner wall
    for k in range(SEGMENTS):
        j = (k + 1) % SEGMENTS
        bm.faces.new((bottom, rings[0][j], rings[0][k]))
        bm.faces.new((inside, rings[-1][k], rings[-1][j]))
        for i in range(len(rings) - 1):
            face = bm.faces.new((rings[i][k], rings[i][j], rings[i + 1][j], rings[i + 1][k]))
            face.smooth = i in smooth
    bm.normal_update()
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces)
    for edge in bm.edges:                                 # the rims of the two smooth walls
        edge.smooth = all(f.smooth for f in edge.link_faces)
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    mesh.materials.append(mat)
    return common.place(name, mesh, location)


def build(path):
    """Build the scene (its checker image packed into it) and save it to path."""
    scene = common.new_scene((0.08, 0.08, 0.09))
    with tempfile.TemporaryDirectory() as folder:
        checker = checker_png(os.path.join(folder, "glass_wall_checker.png"))
        wall_mat = image_material("CheckerWall", "diffuse", checker, "Color", "Closest", "sRGB")
        image = next(n for n in wall_mat.node_tree.nodes if n.bl_idname == "ShaderNodeTexImage")
        image.image.pack()                                # one self-contained file
    bpy.ops.mesh.primitive_plane_add(size=3.0, location=(0.0, 0.7, 1.2),
                                     rotation=(math.pi / 2, 0.0, 0.0))
    wall = bpy.context.active_object                      # 3 m square, facing -y, into the floor
    wall.name = "Wall"
    wall.data.materials.append(wall_mat)
    white = common.material("Floor", "diffuse", (0.5, 0.5, 0.5))
    common.quad("Floor", [(-2, -3, 0), (2, -3, 0), (2, 0.7, 0), (-2, 0.7, 0)], white)
    glass = common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5)
    # 2 mm above the floor: a base coplanar with the floor is two surfaces at one depth, which
    # the two renderers order differently (measured: Snell's base came out light grey where
    # Cycles' is dark, a relMSE floor of 0.09 in the bench).
    tumbler("Tumbler", (0.0, 0.1, 0.002), glass)
    common.area_lamp("Lamp", 120.0, 1.0, (1.2, -1.4, 2.4), (0.6, 0.0, 0.7))
    common.camera(scene, (0.0, -1.7, 0.8), (0.0, 0.1, 0.45), lens=40.0)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "glass_wall.blend"))
