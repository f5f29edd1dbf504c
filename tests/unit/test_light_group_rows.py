"""tracer/light_groups.py's pieces, directly: where a contribution goes, how the rows are filmed,
and each kind of light's group from the scene file."""
from __future__ import annotations

import math

import numpy as np

from snell.tracer import light_groups as lg, light_passes
from snell.tracer.lights.codes import AREA, EMISSIVE_TRIANGLE, POINT, SUN, WORLD
from snell.tracer.lights.tables import LightSampler
from snell.tracer.geometry import Geometry
from snell.tracer.scene import validate
from support.builders import camera, make_scene, quad


def test_a_contribution_goes_to_combined_and_its_group():
    """Combined's three columns always; the group's three only where the row has them and the
    light is in a group. Deliberate error: the group's offset 3 * group without Combined's 3
    writes group 1's light into group 0's columns and fails the first check."""
    rows = np.zeros((2, lg.columns(2)))
    lg.add_grouped(rows, 1, 1, (1.0, 2.0, 3.0))
    assert rows[1].tolist() == [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0]
    lg.add_grouped(rows, 1, lg.NONE, (1.0, 1.0, 1.0))
    assert rows[1].tolist() == [2.0, 3.0, 4.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0]
    lg.add_to_group(rows, 0, 0, (5.0, 5.0, 5.0))
    assert rows[0].tolist() == [0.0, 0.0, 0.0, 5.0, 5.0, 5.0, 0.0, 0.0, 0.0]
    plain = np.zeros((1, 3))
    lg.add_grouped(plain, 0, 1, (1.0, 2.0, 3.0))       # no group columns: Combined only
    assert plain[0].tolist() == [1.0, 2.0, 3.0]
    assert lg.pass_name("fill 2") == "Combined_fill 2"


def test_film_adds_each_paths_groups_to_its_pixel_and_leaves_out_non_finite_rows():
    """Paths 0 .. 3 of 2 samples per pixel: pixels 0 and 1 (or the listed pixels); a row with
    a NaN in Combined or in a group adds nothing and is counted, as film leaves it out."""
    rows = np.zeros((4, lg.columns(1)))
    rows[:, 3:] = [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [4.0, 4.0, 4.0], [8.0, 8.0, 8.0]]
    rows[2, 0] = math.nan
    rows[3, 4] = math.inf
    total = np.zeros((3, 3))
    bad = light_passes.film_rows(rows, 3, 4, 0, 2, np.zeros(0, np.int64), total)
    assert bad == 2 and total[:, 0].tolist() == [3.0, 0.0, 0.0]
    total[:] = 0.0
    bad = light_passes.film_rows(rows[:2], 3, 2, 0, 1, np.array([2, 0], np.int64), total)
    assert bad == 0 and total[:, 0].tolist() == [2.0, 0.0, 1.0]


def test_splats_go_to_their_groups_and_none_to_no_group():
    total = np.zeros((2, 6))
    pixels = np.array([0, 1, 1], np.int64)
    contributions = np.array([[1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [math.nan, 0.0, 0.0]])
    bad = lg.splat_groups(pixels, contributions, np.array([1, lg.NONE, 0], np.int64), total)
    assert bad == 1 and total.tolist() == [[0, 0, 0, 1, 1, 1], [0, 0, 0, 0, 0, 0]]


def test_each_kind_of_light_reads_its_group():
    """The scene file's light_group of each lamp (by kind, in the file's order), each emissive
    triangle's object and the world, through the tables compiled code reads."""
    floor = (*quad((0.0, 0.0, -1.0), 2.0, 2.0), 0)
    panel = (*quad((0.0, 0.0, 1.0), 0.5, 0.5, -1.0), 1)
    m = np.eye(4).tolist()
    lights = [{"name": "p", "kind": "point", "position": [0, 0, 2], "intensity": [1, 1, 1]},
              {"name": "a", "kind": "area", "shape": "square", "matrix": m, "size": [1, 1],
               "radiance": [1, 1, 1]},
              {"name": "s", "kind": "sun", "direction": [0, 0, -1], "irradiance": [1, 1, 1]},
              {"name": "q", "kind": "spot", "position": [0, 0, 2], "intensity": [1, 1, 1],
               "matrix": m, "spot_size": 1.0, "spot_blend": 0.1}]
    mats = [{"name": "f", "kind": "diffuse", "color": [0.5, 0.5, 0.5]},
            {"name": "e", "kind": "emission", "color": [1, 1, 1], "strength": 1.0}]
    scene = make_scene([floor, panel], mats, camera(resolution=(4, 4)), world=(0.1, 0.1, 0.1),
                       lights=lights)
    scene.light_groups = ["g0", "g1", "g2", "g3"]
    for light, group in zip(scene.lights, (0, 1, 2, 3)):
        light["light_group"] = group
    scene.objects[1]["light_group"] = 2
    scene.world["light_group"] = 3
    validate(scene)
    geometry = Geometry(scene.positions, scene.triangles, scene.normals)
    t = LightSampler(scene, geometry, np.array([[0.0] * 3, [1.0] * 3])).tables
    assert t.point_group.tolist() == [0, 3] and t.area_group.tolist() == [1]
    assert t.sun_group.tolist() == [2] and t.world_group == 3
    assert t.prim_group.tolist() == [lg.NONE, lg.NONE, 2, 2]
    assert lg.light_group(t, EMISSIVE_TRIANGLE, 0) == 2
    assert [lg.light_group(t, kind, i) for kind, i in ((AREA, 0), (POINT, 1), (SUN, 0),
                                                       (WORLD, 0))] == [1, 3, 2, 3]
    assert [lg.lamp_group(t, k) for k in range(3)] == [1, 0, 3]     # area lamps first
    assert [lg.escape_group(t, k) for k in range(2)] == [3, 2]      # the world, then suns
    assert lg.emitter_group(t, 3) == 2 and lg.emitter_group(t, -1) == 1
