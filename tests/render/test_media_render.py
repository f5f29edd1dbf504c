"""Absorbing media (tracer/media.py) on scenes with exact answers: a camera looking through a slab
of absorbing index-1 "glass" (a Refraction BSDF of IOR 1 is a pass-through) at an emitter sees
exp(-sigma d) times the emitter; a camera inside the medium likewise over the whole distance;
and a floor inside an absorbing box lit by a lamp inside it loses exp(-sigma (camera segment +
shadow ray)) of its light. Each holds to float and pixel-footprint precision, so a density off
by 10% is far outside the bound."""
from __future__ import annotations

import numpy as np
import pytest

from support.builders import box, camera, make_scene, quad
from support.caustic_scenes import GLASS, caustic_room, hybrid_agrees
from snell.tracer.camera import Camera
from snell.tracer.integrator import Renderer
from snell.tracer.media import camera_in_medium
from snell.tracer.scene import validate
from snell.validation import metrics

SIGMA = [0.2, 0.7, 1.5]
EMISSION = 2.0
CLEAR = {"name": "Slab", "kind": "refraction", "color": [1.0, 1.0, 1.0], "ior": 1.0}
LAMP = {"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": EMISSION}
RES = 16


def _render(scene):
    return Renderer(scene, scene.settings(threads=2)).render().mean().astype(np.float64)


def _pixel_rays(scene, grid=4):
    """Unit directions (H, W, grid^2, 3) through a grid of points of each pixel."""
    cam = Camera(scene.camera)
    g = (np.arange(grid) + 0.5) / grid
    u = np.stack(np.meshgrid(g, g, indexing="ij"), 0).reshape(2, -1)
    pixels = np.repeat(np.arange(RES * RES), u.shape[1])
    o, d, _ = cam.generate(pixels, np.tile(u, (1, RES * RES)), None)
    return o.T.reshape(RES, RES, -1, 3), d.T.reshape(RES, RES, -1, 3)


def _slab_scene(sigma, camera_z=5.0, slab=(-0.5, 0.5)):
    mats = [dict(CLEAR, absorption=list(sigma)), LAMP]
    cam = camera((0.0, 0.0, camera_z), (RES, RES), lens=200.0)
    return make_scene([(*box((-4, -4, slab[0]), (4, 4, slab[1])), 0),
                       (*quad((0, 0, -2), 6, 6), 1)], mats, cam, spp=16, max_depth=8)


def _expected_slab(scene, sigma, length_along_z, start=0.0):
    """EMISSION x the mean over each pixel of exp(-sigma (length / cos - start))."""
    _, d = _pixel_rays(scene)
    path = length_along_z / np.abs(d[..., 2]) - start                  # (H, W, k)
    return EMISSION * np.exp(-np.asarray(sigma) * path[..., None]).mean(axis=2)


def test_slab_of_absorbing_clear_glass():
    """Through 1 m of sigma (0.2, 0.7, 1.5) / m: the image is 2 exp(-sigma / cos theta) to
    within 2e-4 (measured: 3.2e-5 at most; the bound is the pixel's footprint). A density
    off by 10% (sigma x 1.1) renders 0.98/0.93/0.86 of it (measured) and is caught far outside
    the bound; a scene without absorption is 2 everywhere (media off)."""
    scene = _slab_scene(SIGMA)
    image = _render(scene)
    expected = _expected_slab(scene, SIGMA, 1.0)
    err = np.abs(image / expected - 1.0).max()
    assert err < 2e-4, err
    denser = _render(_slab_scene([1.1 * s for s in SIGMA]))
    assert np.abs(denser / expected - 1.0).max() > 0.03
    clear = _render(_slab_scene([0.0, 0.0, 0.0]))
    assert np.abs(clear - EMISSION).max() < 1e-5


def test_camera_inside_the_medium():
    """The camera inside an absorbing box that also holds the emitter: the whole 7 m to it is
    inside (the camera's stack found by a ray straight up, as Cycles finds it) but for the
    clip start, where camera rays begin (measured: 2e-5 at most). Without the camera's stack
    the image would be 2 (no attenuation)."""
    sigma = [0.05, 0.1, 0.2]
    scene = _slab_scene(sigma, camera_z=5.0, slab=(-3.0, 10.0))
    renderer = Renderer(scene, scene.settings(threads=2))
    assert camera_in_medium(renderer.media)
    image = renderer.render().mean().astype(np.float64)
    expected = _expected_slab(scene, sigma, 7.0, start=scene.camera["clip_start"])
    assert np.abs(image / expected - 1.0).max() < 2e-4


def _lit_floor(sigma, spp=16):
    """A diffuse floor at z = 0 inside an absorbing clear box (z from -0.5 to 2) with a point
    lamp at z = 1 inside it; the camera above the box; max depth 2: the box's top, then the
    floor's direct light only."""
    mats = [dict(CLEAR, absorption=list(sigma)),
            {"name": "Floor", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}]
    lamp = {"name": "Point", "kind": "point", "position": [0.0, 0.0, 1.0],
            "intensity": [1.0, 1.0, 1.0]}
    cam = camera((0.0, 0.0, 6.0), (RES, RES), lens=80.0)
    return make_scene([(*box((-3, -3, -0.5), (3, 3, 2.0)), 0), (*quad((0, 0, 0), 3, 3), 1)],
                      mats, cam, lights=[lamp], spp=spp, max_depth=2)


def test_shadow_rays_inside_a_medium_are_attenuated():
    """The floor's direct light from a lamp in the same medium: the ratio to the clear box's
    image (the same samples) is exp(-sigma (2 / cos + r)) (r = |lamp - floor point|), averaged
    over each pixel with the clear image's weight cos / r^2 = 1 / r^3, to within 2e-3 (measured
    8e-4). Leaving the shadow ray unattenuated is caught (measured: off
    by up to 242%)."""
    sigma = [0.1, 0.3, 0.6]
    clear = _render(_lit_floor([0.0, 0.0, 0.0]))
    dense = _render(_lit_floor(sigma))
    o, d = _pixel_rays(_lit_floor(sigma))
    on_floor = o + (-o[..., 2] / d[..., 2])[..., None] * d
    r = np.linalg.norm(on_floor - np.array([0.0, 0.0, 1.0]), axis=-1)
    weight = 1.0 / r ** 3
    tr = np.exp(-np.asarray(sigma) * (2.0 / np.abs(d[..., 2]) + r)[..., None])
    expected = (tr * weight[..., None]).sum(axis=2) / weight.sum(axis=2)[..., None]
    lit = clear[..., 0] > 0.0
    assert lit.sum() == RES * RES
    err = np.abs(dense[lit] / clear[lit] / expected[lit] - 1.0).max()
    assert err < 2e-3, err


# -- the light tracer and light vertices in media ------------------------------------------------

def _fog_room(max_depth=8):
    """The caustic room (support/caustic_scenes.py: a glass sphere focusing a ceiling lamp onto
    the floor, a mirror sphere) with an absorbing glass sphere, the whole room (camera and lamp
    included) inside a clear absorbing box: every segment is attenuated, the glass's by the two
    media added."""
    scene = caustic_room(max_depth)
    mats = [dict(m) for m in scene.materials] + [dict(CLEAR, name="Fog",
                                                      absorption=[0.15, 0.3, 0.45])]
    mats[GLASS]["absorption"] = [0.5, 1.5, 3.0]
    fog = box((-1.5, -1.5, -0.5), (1.5, 1.5, 2.5))
    n = len(scene.positions)
    scene.positions = np.concatenate([scene.positions, fog[0]]).astype(np.float32)
    scene.triangles = np.concatenate([scene.triangles, fog[1] + n]).astype(np.int32)
    scene.material_ids = np.concatenate([scene.material_ids,
                                         np.full(len(fog[1]), len(mats) - 1)]).astype(np.int32)
    scene.object_ids = np.concatenate([scene.object_ids, np.full(
        len(fog[1]), scene.object_ids.max() + 1)]).astype(np.int32)
    scene.objects = scene.objects + [{"name": "Fog", "closed": True}]
    if scene.normals is not None:
        scene.normals = np.concatenate([scene.normals, np.tile([0.0, 0.0, 1.0], (len(fog[0]), 1))
                                        ]).astype(np.float32)
    scene.materials = mats
    return validate(scene)


def test_the_light_tracer_attenuates_as_the_path_tracer_does():
    """In the fog room the hybrid (the light tracer renders the caustic through the absorbing
    sphere, its paths starting in the fog around the lamp) and the path tracer alone render the
    same image: every 8x8 tile and the image mean agree, and 99% of pixels. A light tracer
    whose paths start outside the fog (an empty stack at the lamp) is caught (measured: tiles
    and image mean fail)."""
    scene = _fog_room()
    assert camera_in_medium(Renderer(scene).media)
    hybrid, _ = hybrid_agrees(scene)
    assert hybrid.light_in_image and hybrid.light_paths > 0


def _fog_lit_room(light_vertices, lamp):
    """A closed white room (a box on its floor) lit by a mesh lamp or an area lamp 20 cm under
    its ceiling, all inside a clear absorbing box: light vertices start in the fog."""
    mats = [{"name": "White", "kind": "diffuse", "color": [0.7, 0.7, 0.7]},
            {"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": 10.0},
            {"name": "Red", "kind": "diffuse", "color": [0.7, 0.2, 0.2]},
            dict(CLEAR, name="Fog", absorption=[0.2, 0.4, 0.6])]
    meshes = [(*box((-1.5, -1.5, 0.0), (1.5, 1.5, 2.0)), 0),
              (*box((-0.5, -0.3, 0.0), (0.1, 0.3, 0.7)), 2),
              (*box((-2.0, -2.0, -0.5), (2.0, 2.0, 2.5)), 3)]
    lights = []
    if lamp == "mesh":
        meshes.append((*quad((0.3, 0.2, 1.8), 0.15, 0.15, normal_sign=-1), 1))
    else:
        m = np.eye(4)
        m[:3, 3] = (0.3, 0.2, 1.8)
        lights.append({"name": "A", "kind": "area", "shape": "square", "matrix": m.tolist(),
                       "size": [0.4, 0.4], "radiance": [8.0] * 3, "spread": np.radians(120)})
    m = np.eye(4)
    m[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]         # level, looking along +Y
    m[:3, 3] = (0.0, -1.4, 1.0)
    cam = camera(resolution=(16, 16), lens=18.0, matrix=m.tolist())
    scene = make_scene(meshes, mats, cam, lights=lights, max_depth=4)
    scene.render["light_vertices"] = light_vertices
    return scene


@pytest.mark.parametrize("lamp", ["mesh", "area"])
def test_light_vertices_in_a_medium_leave_the_image_unchanged(lamp):
    """With and without light vertices the fog-filled room renders the same image: the light
    vertex's emission ray is attenuated in the fog around its lamp, the connection like any
    shadow ray. Held as the hybrid is, tiles and image mean to the validator's rule, and 98% of
    pixels: a few dim pixels of the fog-darkened room are heavy-tailed without light vertices
    (measured with the mesh lamp: 98.4% pass, 17 of 768 pixel channels beyond 4 sigma, all
    brighter with light vertices, image means within 0.07%, no tile failed; with the area lamp
    100%). Light vertices whose emission ray ignores the fog are caught: mesh lamp 3 tiles
    failed, 90.2% of pixels pass; area lamp image means 9-17% bright (mean z 37-80)."""
    def render(vertices):
        scene = _fog_lit_room(vertices, lamp)
        return Renderer(scene, scene.settings(sampler="independent", spp=1024,
                                              noise_threshold=0.0)).render()
    a, b = render(True), render(False)
    assert a.stats["light_vertex_connections"] > 0
    va, dfa = a.variance_and_dof()
    vb, dfb = b.variance_and_dof()
    stats = metrics.compare(a.mean(), va, dfa, b.mean(), vb, dfb)
    assert stats["tests"]["tiles"] and stats["tests"]["image_mean"], stats
    assert stats["z_pass_fraction"] >= 0.98, stats
