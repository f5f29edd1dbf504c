"""The seed's depth-of-field scene (CBdragon) with a procedural stand-in for the dragon.

Run: python scenes/cornell_dragon.py OUT.blend
The dragon is replaced by a bumpy (2, 3) torus-knot tube of 1600 x 40 quads (128,000 triangles,
a closed smooth mesh, diffuse), standing in the same Cornell box as cornell_spheres.py.

Mapping of the seed's thin-lens parameters to Blender's camera:
- lens radius b (metres) -> Cycles aperture radius lens_mm * 1e-3 / (2 fstop), so
  fstop = lens_mm * 1e-3 / (2 b); the seed's b = 0.1 with a 35 mm lens gives fstop 0.175.
- focal distance d (metres) -> dof.focus_distance, measured along the camera axis (Cycles focuses
  on a plane). The camera is 3.3 m from the mesh centre, so the seed's d = 2.9 ... 4.1 sweeps
  the focus plane from the front of the knot to the back wall region; 3.3 is the default.
"""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

LENS_MM = 35.0
LENS_RADIUS = 0.1
FOCUS_DISTANCE = 3.3
CENTER = np.array([0.0, 0.0, 0.45])


def knot(n_along=1600, n_around=40, p=2, q=3):
    """Vertices (V, 3) and quads (F, 4) of a bumpy torus-knot tube with outward normals."""
    t = np.linspace(0, 2 * np.pi, n_along, endpoint=False)
    R, r, a = 0.42, 0.16, 0.11

    def curve(t):
        rad = R + r * np.cos(q * t)
        return np.stack([rad * np.cos(p * t), rad * np.sin(p * t), r * np.sin(q * t)], axis=-1)

    c = curve(t)
    tangent = curve(t + 1e-4) - curve(t - 1e-4)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    # A frame from the radial direction (never parallel to the tangent of this knot).
    radial = c * [1, 1, 0]
    n1 = radial - np.sum(radial * tangent, axis=1, keepdims=True) * tangent
    n1 /= np.linalg.norm(n1, axis=1, keepdims=True)
    n2 = np.cross(tangent, n1)
    phi = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    # A few sines make the surface bumpy, like scales.
    bump = 1 + 0.18 * np.sin(5 * phi[None, :] + 17 * t[:, None]) * np.cos(11 * t[:, None])
    radius = a * bump[..., None]
    offset = np.cos(phi)[None, :, None] * n1[:, None] + np.sin(phi)[None, :, None] * n2[:, None]
    verts = (c[:, None] + radius * offset).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_along), np.arange(n_around), indexing="ij")
    i1, j1 = (i + 1) % n_along, (j + 1) % n_around
    idx = lambda a, b: (a * n_around + b).ravel()
    quads = np.stack([idx(i, j), idx(i1, j), idx(i1, j1), idx(i, j1)], axis=1)
    # Make the winding outward: compare one face normal with the offset direction.
    v = verts[quads[0]]
    if np.dot(np.cross(v[1] - v[0], v[3] - v[0]), offset[0, 0]) < 0:
        quads = quads[:, ::-1]
    return verts, quads


def build(path):
    """Build the scene and save it to path."""
    scene = common.reset()
    common.setup_render(scene, (256, 256))
    common.cornell_box()
    verts, quads = knot()
    # Scale the knot (about 1.16 m across) and set it on the floor.
    verts = verts * 1.0 + CENTER
    mat = common.material("DragonWhite", "diffuse", (0.8, 0.8, 0.8))
    common.mesh_object("Dragon", verts, quads, mat, smooth=True)
    # Camera 3.3 m from the mesh centre, looking slightly down at it through the open front.
    height = 1.0
    dy = math.sqrt(FOCUS_DISTANCE ** 2 - (height - CENTER[2]) ** 2)
    cam = common.camera(scene, (0.0, CENTER[1] - dy, height), tuple(CENTER), lens=LENS_MM)
    dof = cam.data.dof
    dof.use_dof = True
    dof.focus_distance = FOCUS_DISTANCE
    dof.aperture_fstop = common.aperture_fstop(LENS_MM, LENS_RADIUS)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "cornell_dragon.blend"))
