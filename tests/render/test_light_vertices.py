"""Light vertices (tracer/light_vertices.py): connections of camera paths to a point that lamp
light reaches first, weighted against the path tracer's two strategies.

The connections change the noise, never the image: with and without them the renders estimate
the same image, pixel by pixel (independent samples, z-tests with a Sidak bound), and with a
lamp right under a ceiling they take most of the noise away.
"""
import math

import numpy as np
import pytest

from snell.tracer import light_vertices
from snell.tracer.integrator import Renderer
from snell.tracer.lights.codes import AREA, EMISSIVE_TRIANGLE

from support.builders import box, camera, make_scene, quad
from support.stats import z_bound

WHITE = [0.7, 0.7, 0.7]


def _view():
    m = np.eye(4)
    m[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]         # level, looking along +Y
    m[:3, 3] = (0.0, -1.4, 1.0)
    return camera(resolution=(16, 16), lens=18.0, matrix=m.tolist())


def _room(lamp="mesh", light_vertices=True, glossy_box=True, max_depth=4, gap=0.01,
          glossy_floor=False):
    """A closed room seen from inside, a box on its floor and a lamp near the ceiling: a mesh
    lamp `gap` under it (two-sided, its back face lighting the ceiling next to it), an area lamp
    facing down with a spread, or a point lamp (which starts no light vertices)."""
    mats = [{"name": "White", "kind": "diffuse", "color": WHITE},
            {"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": 10.0},
            {"name": "Rough", "kind": "glossy", "color": [0.8, 0.6, 0.4], "roughness": 0.4}
            if glossy_box else {"name": "Red", "kind": "diffuse", "color": [0.7, 0.2, 0.2]}]
    meshes = [(*box((-1.5, -1.5, 0.0), (1.5, 1.5, 2.0)), 0),
              (*box((-0.5, -0.3, 0.0), (0.1, 0.3, 0.7)), 2)]
    if glossy_floor:       # a rough glossy rug over the floor: layered vertices connect
        meshes.append((*quad((0.0, 0.0, 0.001), 1.2, 1.2), 2))
    lights = []
    if lamp in ("mesh", "panel"):
        half = 0.15 if lamp == "mesh" else 1.2     # a panel: BSDF samples find it often
        meshes.append((*quad((0.3, 0.2, 2.0 - gap), half, half, normal_sign=-1), 1))
    elif lamp == "area":
        m = np.eye(4)                                 # emits towards -Z, with a spread
        m[:3, 3] = (0.3, 0.2, 1.9)
        lights.append({"name": "A", "kind": "area", "shape": "square", "matrix": m.tolist(),
                       "size": [0.4, 0.4], "radiance": [8.0] * 3, "spread": math.radians(120)})
    else:
        lights.append({"name": "P", "kind": "point", "position": [0.3, 0.2, 1.7],
                       "intensity": [5.0] * 3, "radius": 0.0})
    scene = make_scene(meshes, mats, _view(), lights=lights, max_depth=max_depth)
    scene.render["light_vertices"] = light_vertices
    return scene


def _render(scene, spp, **options):
    return Renderer(scene, scene.settings(sampler="independent", **options, spp=spp,
                                          noise_threshold=0.0)).render()


def _assert_same_image(a, b):
    """Per-pixel and whole-image z-tests between two renders of one scene."""
    ma, mb = a.mean().astype(np.float64), b.mean().astype(np.float64)
    va, vb = a.variance_of_mean(), b.variance_of_mean()
    noisy = (va > 0) & (vb > 0)
    assert noisy.mean() > 0.75      # all but the lamp seen directly
    z = np.abs(ma - mb)[noisy] / np.sqrt((va + vb)[noisy])
    assert z.max() < z_bound(z.size), np.sort(z)[-5:]
    for c in range(3):
        se = math.sqrt(va[..., c].sum() + vb[..., c].sum()) / ma[..., c].size
        assert abs(ma[..., c].mean() - mb[..., c].mean()) < z_bound(3) * se


@pytest.mark.parametrize("lamp, glossy_floor", [("mesh", False), ("panel", False),
                                                ("area", False), ("mesh", True)])
def test_light_vertices_leave_the_image_unchanged(lamp, glossy_floor):
    """The three strategies' weights sum to one on every path: the same image with and without
    the connections, on diffuse and rough glossy (layered) vertices. (Leaving the light vertex
    out of the weight of lamps that BSDF samples find puts the panel's image 0.9% too bright:
    z = 11.)"""
    # 20 cm under the ceiling: at 1 cm the path tracer alone sees the ceiling above the lamp
    # through a 1 cm slit, light of so heavy a tail that its variance estimates fail (measured:
    # pixels 8% dark at 4096 samples, z = 8; right at 65536).
    with_vertices = _render(_room(lamp, gap=0.2, glossy_floor=glossy_floor), 1024)
    without = _render(_room(lamp, light_vertices=False, gap=0.2, glossy_floor=glossy_floor), 1024)
    assert with_vertices.stats["light_vertex_connections"] > 0
    assert without.stats["light_vertex_connections"] == 0
    _assert_same_image(with_vertices, without)


def test_light_vertices_take_the_noise_of_a_ceiling_next_to_a_lamp():
    """The lamp's back face lights the ceiling from 1 cm: that bright patch lights the room, and
    the path tracer finds it rarely. With light vertices the relative variance at equal samples
    is under half the path tracer's (measured: 0.27 of it at 64 samples)."""
    def relative_variance(result):
        mean = result.mean().astype(np.float64)
        return float(np.mean(result.variance_of_mean() / (mean * mean + 1e-2)))

    scene = _room(glossy_box=False)
    with_vertices = relative_variance(_render(scene, 128))
    without = relative_variance(_render(scene, 128, light_vertices=False))
    assert with_vertices < without / 2, (with_vertices, without)


def test_light_vertex_density_of_each_lamp_kind():
    """q = pick probability / area x sides / pi: two sides for emissive triangles, one for area
    lamps; none for point lamps."""
    mesh = Renderer(_room("mesh")).lights.tables
    k = int(np.flatnonzero(mesh.kind == EMISSIVE_TRIANGLE)[0])
    i = mesh.index[k]
    assert light_vertices.light_vertex_density(mesh, EMISSIVE_TRIANGLE, i, mesh.pmf[k]) == \
        pytest.approx(mesh.pmf[k] / mesh.tri_area[i] * 0.5 / math.pi, rel=1e-12)
    assert mesh.tri_area[i] == pytest.approx(0.3 * 0.3 / 2, rel=1e-6)
    area = Renderer(_room("area")).lights.tables
    assert light_vertices.light_vertex_density(area, AREA, 0, 1.0) == \
        pytest.approx(1.0 / (0.4 * 0.4) / math.pi, rel=1e-12)
    point = Renderer(_room("point")).lights.tables
    assert not light_vertices.starts_light_vertices(point)


def test_scenes_without_light_vertices_say_why_and_never_connect():
    point = _render(_room("point"), 4)
    assert point.stages["light vertices"] == (False, "no mesh light or area lamp with a spread, "
                                              "MIS, shadows and diffuse rays")
    assert point.stats["light_vertex_connections"] == 0
    off = _render(_room("mesh", light_vertices=False), 4)
    assert off.stages["light vertices"] == (False, "light vertices off")
    turned_off = _render(_room("mesh"), 4, light_vertices=False)     # Renderer's own option
    assert turned_off.stages["light vertices"] == (False, "light vertices off")
    assert turned_off.stats["light_vertex_connections"] == 0
    shallow = _render(_room("mesh", max_depth=1), 4)
    assert shallow.stages["light vertices"] == (False, "max depth below 2")
    on = _render(_room("mesh"), 4)
    assert on.stages["light vertices"][0] is True and on.stats["light_vertex_connections"] > 0


def test_light_vertices_give_the_same_image_for_any_thread_count():
    scene = _room()
    one = Renderer(scene, scene.settings(threads=1, spp=8, noise_threshold=0.0)).render().mean()
    two = Renderer(scene, scene.settings(threads=2, spp=8, noise_threshold=0.0)).render().mean()
    assert np.array_equal(one, two)


@pytest.mark.parametrize("lamp, glossy_floor", [("mesh", False), ("area", False), ("mesh", True)])
def test_the_pilot_counts_every_sample_as_the_render_without_light_vertices(lamp, glossy_floor):
    """An adaptive render's pilot adds each path's light as it would be without light vertices
    to second sums: the same camera paths, the two-strategy weights and no connections, so
    those sums are, bit for bit, a render's without them."""
    scene = _room(lamp, glossy_floor=glossy_floor)
    pixels, in_pass = 16 * 16, 4

    def chunk(renderer, pilot=None):
        total, total_sq = np.zeros((pixels, 3)), np.zeros((pixels, 3))
        renderer.trace_chunk(0, pixels * in_pass, in_pass, 0, np.zeros(0, np.int64), 2, total,
                             total_sq, np.zeros((0, 3)), pilot=pilot)
        return total, total_sq

    without = (np.zeros((pixels, 3)), np.zeros((pixels, 3)))
    with_vertices = chunk(Renderer(scene), without)
    plain = chunk(Renderer(scene, scene.settings(light_vertices=False)))
    assert np.array_equal(without[0], plain[0]) and np.array_equal(without[1], plain[1])
    assert not np.array_equal(with_vertices[0], plain[0])


@pytest.mark.parametrize("lamp, gap, pays", [("mesh", 0.2, True), ("panel", 0.01, False)])
def test_adaptive_renders_keep_light_vertices_where_they_pay(lamp, gap, pays):
    """The pilot predicts the rays adaptive sampling needs to the threshold with and without
    light vertices and keeps the cheaper (measured predictions, 3 seeds: 0.26-0.36x with them
    for a small lamp 20 cm under the ceiling, 1.39-1.44x for a panel that BSDF samples find
    often). Either way the image is the one a fixed-sample render gives, and without light
    vertices nothing after the pilot traces a ray from a lamp."""
    scene = _room(lamp, gap=gap)
    pilot_paths = 64 * 16 * 16          # every pixel's first 64 samples (the minimum at 0.01)
    for seed in (0, 1, 2):
        result = Renderer(scene, scene.settings(seed=seed, sampler="independent", spp=1024,
                                                noise_threshold=0.01)).render()
        runs, why = result.stages["light vertices"]
        assert runs is pays and "measured" in why, why
        rays = result.stats["light_vertex_rays"]
        assert rays > pilot_paths if pays else rays == pilot_paths
    forced = _render(scene, 512, light_vertices=pays)
    _assert_same_image(result, forced)
    kept = Renderer(scene, scene.settings(light_vertex_pilot=False, spp=128,
                                          noise_threshold=0.01)).render()
    assert kept.stages["light vertices"] == (True, "mesh lights or area lamps light diffuse "
                                                   "surfaces")
    assert kept.stats["light_vertex_rays"] > pilot_paths


def test_a_scene_file_with_light_vertices_not_a_boolean_is_refused():
    from snell.tracer.scene import SceneError, validate
    scene = _room()
    scene.render["light_vertices"] = "yes"
    with pytest.raises(SceneError, match="render.light_vertices: expected true or false"):
        validate(scene)
