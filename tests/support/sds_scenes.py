"""Caustics seen through glass (specular, diffuse, specular paths), built in code (no Blender):
a pool (a diffuse floor under a wavy water surface, seen from above the water) and a tumbler
whose caustic on its inside floor is seen through its wall. Used by the photon merging tests
(render/test_photon_merging.py) and tools/measure_photon_merging.py; scenes/pool.py and
scenes/tumbler_caustic.py build the same scenes as .blend files.
"""
from __future__ import annotations

import numpy as np

from sds_geometry import POOL_HALF, tube, water_surface   # scenes/ (conftest.py's path)
from support.builders import camera, icosphere, make_scene, quad
from support.caustic_scenes import look_at

WATER_IOR = 1.33
LAMP_RADIUS = 0.25


POOL_MATERIALS = [{"name": "Floor", "kind": "diffuse", "color": [0.8, 0.8, 0.8]},
                  {"name": "Water", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": WATER_IOR}]


def shadow_caustics(scene, on=True):
    """The scene with Cycles' shadow-caustics flags as scenes/common.py sets them: the lamps
    caustics lights, object 0 (the floor or table) a receiver, object 1 (the glass) a caster
    (tracer/mnee.py); on=False: none."""
    if on:
        scene.objects[0]["caustics_receiver"] = True
        scene.objects[1]["caustics_caster"] = True
        for light in scene.lights:
            light["caustics_light"] = True
    return scene


def pool(resolution=(32, 32), max_depth=8, lamp_radius=LAMP_RADIUS, lamp=None,
         world=(0.0, 0.0, 0.0), **render):
    """The pool: a 2 m diffuse floor 0.5 m under a wavy water surface (glass, IOR 1.33), a small
    round lamp 2 m above the water (or `lamp`: pool_sun's, pool_area's), the camera 1.4 m above
    the water looking down at the floor through it (every pixel sees the floor through the
    water), a black world (or `world`'s colour). No shadow-caustics flags (shadow_caustics sets
    them)."""
    floor = quad((0.0, 0.0, 0.0), POOL_HALF, POOL_HALF)
    water = water_surface()
    lamp = lamp or {"name": "Lamp", "kind": "point", "position": [0.3, 0.2, 2.5],
                    "intensity": [20.0, 20.0, 20.0], "radius": lamp_radius}
    cam = look_at((0.0, -0.25, 1.9), (0.0, 0.0, 0.0), resolution, lens=50.0)
    return make_scene([(*floor, 0, _up(len(floor[0]))), (*water[:2], 1, water[2])],
                      POOL_MATERIALS, cam, world=world, lights=[lamp], max_depth=max_depth,
                      **render)


def pool_sun(angle, irradiance=3.0):
    """A sun for pool(lamp=...), shining down at a slant, of this angle (radians) and
    irradiance (W/m^2; the point lamp's at the water is 3.2)."""
    return {"name": "Sun", "kind": "sun", "direction": [-0.12, -0.08, -1.0],
            "irradiance": [irradiance] * 3, "angle": angle}


def pool_area(size=0.5, radiance=100.0):
    """A square area lamp for pool(lamp=...), facing down where the point lamp is."""
    matrix = np.eye(4)
    matrix[:3, 3] = (0.3, 0.2, 2.5)
    return {"name": "Area", "kind": "area", "shape": "square", "matrix": matrix.tolist(),
            "size": [size, size], "radiance": [radiance] * 3}


def _up(n):
    """n vertex normals facing +Z."""
    return np.tile(np.array([[0.0, 0.0, 1.0]], np.float32), (n, 1))


def tilted(tilt):
    """The unit shading normal tilted by `tilt` radians from +Z towards +X."""
    return np.array([np.sin(tilt), 0.0, np.cos(tilt)])


def flat_plane(resolution=(16, 16), albedo=0.5, intensity=10.0, height=2.5, tilt=0.0,
               **render):
    """A diffuse plane z = 0 seen from 3 m above through a flat sheet of IOR 1 at z = 1 (a
    specular vertex that does not bend light, and whose Fresnel reflection is 0), lit through
    the sheet by a point lamp of radius 0 at (0, 0, height): the irradiance at (x, y, 0) is
    intensity height / (x^2 + y^2 + height^2)^(3/2). No camera path reaches the lamp and no
    shadow ray passes the sheet, so the image is photon merging's alone (analytic_plane).
    tilt: the floor's shading normal tilted by this many radians from +Z towards +X (its
    radiance then albedo / pi x intensity (ns . wi) / d^2, Lambert about the shading normal)."""
    floor = quad((0.0, 0.0, 0.0), 4.0, 4.0)
    sheet = quad((0.0, 0.0, 1.0), 0.75, 0.75)
    mats = [{"name": "Floor", "kind": "diffuse", "color": [albedo] * 3},
            {"name": "Sheet", "kind": "refraction", "color": [1.0, 1.0, 1.0], "ior": 1.0}]
    lamp = {"name": "Lamp", "kind": "point", "position": [0.0, 0.0, height],
            "intensity": [intensity] * 3, "radius": 0.0}
    cam = camera(position=(0.0, 0.0, 3.0), resolution=resolution, lens=50.0)
    normals = np.tile(tilted(tilt).astype(np.float32), (len(floor[0]), 1))
    return make_scene([(*floor, 0, normals), (*sheet, 1, _up(len(sheet[0])))], mats, cam,
                      lights=[lamp], max_depth=4, **render)


def analytic_plane(resolution=(16, 16), albedo=0.5, intensity=10.0, height=2.5, tilt=0.0,
                   sub=16):
    """flat_plane's image: each pixel's mean over its footprint on the floor (sub x sub points)
    of the radiance albedo / pi x irradiance."""
    w, h = resolution
    half = 3.0 * 36.0 / (2.0 * 50.0)           # the floor's half-width seen at 3 m
    t = (np.arange(sub) + 0.5) / sub
    col = (np.arange(w)[:, None] + t[None, :]).ravel()
    row = (np.arange(h)[:, None] + t[None, :]).ravel()
    x = -half + 2.0 * half * col / w
    y = half * h / w - 2.0 * half * row / w     # row 0 at the top (square pixels)
    xx, yy = np.meshgrid(x, y)
    n = tilted(tilt)
    cos_s = np.maximum(n[2] * height - n[0] * xx - n[1] * yy, 0.0)   # ns . (lamp - x), unnormalised
    e = intensity * cos_s / (xx ** 2 + yy ** 2 + height ** 2) ** 1.5
    radiance = albedo / np.pi * e
    return radiance.reshape(h, sub, w, sub).mean(axis=(1, 3))


TUMBLER_IOR = 1.5


TUMBLER_MATERIALS = [{"name": "Table", "kind": "diffuse", "color": [0.8, 0.8, 0.8]},
                     {"name": "Glass", "kind": "glass", "color": [1.0, 1.0, 1.0],
                      "ior": TUMBLER_IOR}]


def tumbler(resolution=(32, 32), max_depth=8, lamp_radius=0.1, **render):
    """A glass tube (IOR 1.5, walls 6 cm thick) on a diffuse table, lit from one side by a
    small round lamp whose light the wall focuses onto the table inside it; the camera, on the
    other side and low, sees that caustic through the near wall."""
    table = quad((0.0, 0.0, 0.0), 2.0, 2.0)
    glass = tube()
    lamp = {"name": "Lamp", "kind": "point", "position": [1.4, 0.3, 0.55],
            "intensity": [20.0, 20.0, 20.0], "radius": lamp_radius}
    cam = look_at((-2.2, -0.4, 1.1), (0.0, 0.0, 0.25), resolution, lens=50.0)
    return make_scene([(*table, 0, _up(len(table[0]))), (*glass[:2], 1, glass[2])],
                      TUMBLER_MATERIALS, cam, lights=[lamp], max_depth=max_depth, **render)


def ball(resolution=(16, 16), max_depth=8, **render):
    """A glass ball (IOR 1.5, smooth normals) above a diffuse floor under a small round lamp,
    the camera above the floor: it sees the ball's caustic (lamp, two refractions, floor)
    directly, and no light reaches the floor through one refraction alone."""
    floor = quad((0.0, 0.0, 0.0), 1.5, 1.5)
    glass = icosphere(3, 0.3, (0.0, 0.0, 0.45))
    lamp = {"name": "Lamp", "kind": "point", "position": [0.5, 0.2, 1.8],
            "intensity": [30.0, 30.0, 30.0], "radius": 0.1}
    cam = look_at((0.0, -1.6, 1.6), (-0.15, 0.0, 0.0), resolution, lens=35.0)
    return make_scene([(*floor, 0, _up(len(floor[0]))), (glass[0], glass[1], 1, glass[2])],
                      TUMBLER_MATERIALS, cam, lights=[lamp], max_depth=max_depth, **render)
