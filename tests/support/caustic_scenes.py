"""The caustics tests' room, built in code (no Blender): a closed 2 m room with a red floor and a
small emissive lamp under the ceiling, and the caustic room (a glass sphere focusing the lamp onto
the floor, a mirror sphere beside it), and the check that the hybrid renders the path tracer's
image. Used by render/test_caustics.py, test_caustics_switches.py, test_media_render.py and
test_adaptive.py.
"""
from __future__ import annotations

import numpy as np

from support.builders import box, camera, icosphere, make_scene, quad
from snell.tracer.integrator import Renderer
from snell.validation import metrics

BATCHES = 16    # independent batches per render: the variances of the caustics tests

WALLS = [{"name": "White", "kind": "diffuse", "color": [0.8, 0.8, 0.8]},
         {"name": "Red", "kind": "diffuse", "color": [0.8, 0.2, 0.2]},
         {"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": 20.0},
         {"name": "Glass", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": 1.5},
         {"name": "Mirror", "kind": "mirror", "color": [0.9, 0.9, 0.9]}]
WHITE, RED, LAMP, GLASS, MIRROR = range(5)


def room_camera(resolution=(24, 24), dof=None):
    """Inside the room at y = -0.9 looking along +Y at the back wall; the ceiling lamp is out of
    the view (47 degrees up, the half field of view is 27)."""
    m = np.array([[1.0, 0, 0, 0], [0, 0, -1.0, -0.9], [0, 1.0, 0, 1.0], [0, 0, 0, 1.0]])
    return camera(resolution=resolution, lens=35.0, matrix=m.tolist(), dof=dof)


def flat_faces(pos, tri):
    """The mesh with its own vertices per triangle (so that per-vertex normals are flat)."""
    return pos[tri].reshape(-1, 3), np.arange(3 * len(tri), dtype=np.int32).reshape(-1, 3)


def room(objects=(), cam=None, max_depth=3, lamp_half=0.15, lights=()):
    """A closed 2 m room (red floor), a small emissive lamp under the ceiling (none if lights
    are given), and objects."""
    walls = flat_faces(*box((-1, -1, 0), (1, 1, 2)))
    floor = quad((0, 0, 0.001), 0.99, 0.99)
    lamp = [] if lights else [(*quad((0, 0, 1.98), lamp_half, lamp_half, normal_sign=-1), LAMP)]
    meshes = [(*walls, WHITE), (*floor, RED), *lamp, *objects]
    return make_scene(meshes, WALLS, cam or room_camera(), max_depth=max_depth, lights=lights)


def look_at(eye, target, resolution=(24, 24), lens=35.0):
    """A camera at eye looking at target, world Z up."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    back = (eye - target) / np.linalg.norm(eye - target)
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(back, right), back, eye
    return camera(resolution=resolution, lens=lens, matrix=m.tolist())


def caustic_room(max_depth, resolution=(24, 24)):
    """A glass sphere focusing a small lamp onto the floor, seen from above; a mirror sphere
    beside it."""
    glass = (*icosphere(3, radius=0.3, center=(0.0, 0.0, 0.6))[:2], GLASS)
    mirror = (*icosphere(3, radius=0.25, center=(0.55, 0.45, 0.25))[:2], MIRROR)
    cam = look_at((0.0, -0.9, 1.5), (0.1, 0.1, 0.1), resolution)
    return room([glass, mirror], cam, max_depth=max_depth, lamp_half=0.25)


def hybrid_agrees(scene, spp=512):
    """Render the scene with the hybrid and with the path tracer alone (another seed), each in
    BATCHES independent batches, and assert that they agree: every 8x8 tile and the image mean,
    and 99% of pixels (single pixels stay heavy-tailed where the path tracer finds caustics by
    rare paths). Returns the two results."""
    hybrid = Renderer(scene, scene.settings(sampler="independent", spp=spp,
                                            batches=BATCHES)).render()
    path = Renderer(scene, scene.settings(seed=1, sampler="independent", caustics=False, spp=spp,
                                          batches=BATCHES)).render()
    va, dfa = hybrid.variance_and_dof()
    vb, dfb = path.variance_and_dof()
    stats = metrics.compare(hybrid.mean(), va, dfa, path.mean(), vb, dfb)
    assert stats["tests"]["tiles"] and stats["tests"]["image_mean"], stats
    assert stats["z_pass_fraction"] >= 0.99, stats
    return hybrid, path
