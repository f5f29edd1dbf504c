"""Blender's lamps in the tracer: exact irradiance, the spot profile, visibility and shadow flags,
and light sampling against BSDF sampling for every lamp that rays can hit."""
import math

import numba
import numpy as np
import pytest

from support.builders import camera, make_scene, quad
from snell.tracer.integrator import Renderer, render
from snell.tracer.lights.area import area_lamp_hit, intersect_area_lamp, spread_constants
from snell.tracer.lights.codes import AREA, POINT, SUN, VISIBLE_DIFFUSE
from snell.tracer.lights.dispatch import pick_light, sample_light
from snell.tracer.lights.point import intersect_point_lamp, point_lamp_hit
from snell.tracer.lights.sun import sun_hit
from support.stats import estimators_agree as _estimators_agree

WHITE = [1.0, 1.0, 1.0]
GREY = {"name": "Grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}


def _floor_scene(lights, spp=256, max_depth=1, occluder=False, resolution=(9, 9), lens=5000.0):
    """A white floor at z = 0 under the lights, seen straight down from z = 5 through a long lens
    (the centre pixel covers a few millimetres around the origin); max depth 1 is direct light."""
    meshes = [(*quad((0, 0, 0), 50, 50), 0)]
    mats = [{"name": "White", "kind": "diffuse", "color": WHITE}]
    if occluder:       # a small plate on the way from (1, 0, 1) to the floor's centre
        meshes.append((*quad((0.5, 0, 0.5), 0.05, 0.05, normal_sign=-1), 1))
        mats.append(GREY)
    return make_scene(meshes, mats, camera(position=(0, 0, 5), resolution=resolution, lens=lens),
                      lights=lights, spp=spp, max_depth=max_depth)


def _centre(result):
    """The centre pixel's mean and standard error (red channel)."""
    img, var = result.mean(), result.variance_of_mean()
    cy, cx = img.shape[0] // 2, img.shape[1] // 2
    return float(img[cy, cx, 0]), math.sqrt(float(var[cy, cx, 0]))


def _point(position=(0, 0, 1), intensity=1.0, **extra):
    return {"name": "P", "kind": "point", "position": list(position), "intensity": [intensity] * 3,
            "visible_camera": False, **extra}


def _spot(position, matrix, size, blend, **extra):
    return _point(position, **extra) | {"kind": "spot", "matrix": matrix, "spot_size": size,
                                         "spot_blend": blend}


# The floor's radiance is albedo / pi x irradiance; albedo 1.
@pytest.mark.parametrize("light, irradiance", [
    (_point(radius=0.0), 1.0),                                      # I / d^2
    (_point(radius=0.3, soft_falloff=False), 1.0),                  # a whole sphere: as a point
    (_point(radius=0.3), 1.0 / (0.09 + 1.0)),                       # the facing disk: I / (r^2 + d^2)
    (_point(position=(0, 0, 0.2), radius=0.5, soft_falloff=False), 1.0 / 0.25),  # inside: pi L
])
def test_point_lamp_irradiance(light, irradiance):
    """Exact irradiance below point lamps of intensity 1 (Cycles' formulas, docs/lights.md)."""
    result = render(_floor_scene([light]))
    value, se = _centre(result)
    expected = irradiance / math.pi
    assert abs(value - expected) < 4.5 * se + 2e-4 * expected, (value, expected, se)


@pytest.mark.parametrize("angle_deg, tilt_deg", [(0, 0), (10, 0), (10, 60), (60, 30)])
def test_sun_irradiance_is_its_strength_times_cosine(angle_deg, tilt_deg):
    """A sun of strength S gives E = S cos(tilt) for any angle while its disc is above the
    horizon (the disc's radiance is S / (pi sin^2(angle / 2)))."""
    tilt = math.radians(tilt_deg)
    sun = {"name": "Sun", "kind": "sun", "direction": [math.sin(tilt), 0.0, -math.cos(tilt)],
           "irradiance": [3.0] * 3, "angle": math.radians(angle_deg)}
    value, se = _centre(render(_floor_scene([sun])))
    expected = 3.0 * math.cos(tilt) / math.pi
    assert abs(value - expected) < 4.5 * se + 2e-4 * expected, (value, expected, se)


def test_spot_profile_is_cycles_smoothstep():
    """A spot of radius 0 over the floor: I cos^3 / h^2 x smoothstep((z - cos(size/2)) /
    ((1 - cos(size/2)) blend)) along a line, pixel by pixel (delta light: no noise)."""
    size, blend, h = math.radians(60), 0.5, 1.0
    m = np.eye(4)
    m[:3, 3] = (0, 0, h)                      # unrotated: the spot points down (-Z)
    spot = _spot((0, 0, h), m.tolist(), size, blend, intensity=1.0)
    # A 1.6 m wide view of the floor, 33 px across; the pixel's radiance is its average, so
    # compare with the average of the profile over the pixel's footprint.
    lens = 36.0 * 5.0 / 1.6
    scene = _floor_scene([spot], spp=64, resolution=(33, 33), lens=lens)
    img = render(scene).mean()[16, :, 0].astype(np.float64)
    cos_half = math.cos(size / 2)
    xs = (np.arange(33)[:, None] + (np.arange(64)[None, :] + 0.5) / 64) / 33 * 1.6 - 0.8
    cos_t = h / np.sqrt(h * h + xs ** 2)
    f = np.clip((cos_t - cos_half) / ((1 - cos_half) * blend), 0, 1)
    expected = (cos_t ** 3 / (h * h) * f * f * (3 - 2 * f) / math.pi).mean(axis=1)
    assert np.allclose(img, expected, rtol=0.02, atol=1e-3), np.c_[img, expected]
    assert img[16] == pytest.approx(1 / math.pi, rel=1e-3) and img[0] == 0.0


def test_spot_scale_makes_an_elliptical_cone():
    """Scaled x2 along its x axis, a spot reaches twice as far in tan along x as along y."""
    m = np.diag([2.0, 1.0, 1.0, 1.0])
    m[:3, 3] = (0, 0, 1)
    spot = _spot((0, 0, 1), m.tolist(), math.radians(40), 0.0, intensity=1.0)
    img = render(_floor_scene([spot], spp=4, resolution=(65, 65), lens=36.0 * 5.0 / 2.0)).mean()
    lit = img[..., 0] > 0
    width_x, width_y = lit[32].sum(), lit[:, 32].sum()
    expected = 2 * math.tan(math.radians(20)) * 65 / 2.0          # px across the footprint
    assert width_y == pytest.approx(expected, abs=2) and width_x == pytest.approx(2 * expected, abs=3)


def test_area_spread_keeps_power_and_narrows_the_beam():
    """Spread 45 degrees: on axis the radiance rises by tan a / (tan a - a); outside the cone
    (here from 1 m below, beyond 0.7 m off axis) nothing arrives."""
    m = np.eye(4)
    m[:3, 3] = (0, 0, 1)
    lamp = {"name": "A", "kind": "area", "shape": "disk", "matrix": m.tolist(), "size": [0.02, 0.02],
            "radiance": [1.0] * 3, "spread": math.radians(45)}
    value, se = _centre(render(_floor_scene([lamp], spp=1024)))
    tan_a, k = spread_constants(math.radians(45))
    # A small disk of radius R at height 1 straight above: att = (tan a - rho) K at radius rho
    # (cosines are 1 to 1e-4), so E = L K (tan a pi R^2 - 2 pi R^3 / 3).
    radius = 0.01
    expected = k * (tan_a * math.pi * radius ** 2 - 2 * math.pi * radius ** 3 / 3) / math.pi
    assert abs(value - expected) < 4.5 * se + 1e-3 * expected, (value, expected, se)
    m[:3, 3] = (0.75, 0, 1)
    off = dict(lamp, matrix=m.tolist())
    assert render(_floor_scene([off], spp=64)).mean()[4, 4, 0] == 0.0


def test_spread_constants_match_the_power_integral():
    """K makes the integral of att(theta) cos(theta) over the hemisphere pi (power kept)."""
    for deg in (2.0, 20.0, 45.0, 120.0):
        tan_a, k = spread_constants(math.radians(deg))
        theta = np.linspace(0, math.radians(deg) / 2, 200_001)
        att = np.maximum((tan_a - np.tan(theta)) * k, 0)
        total = 2 * math.pi * np.trapz(att * np.cos(theta) * np.sin(theta), theta)
        assert total == pytest.approx(math.pi, rel=1e-3 if deg > 5.7 else 2e-3), deg


def test_visibility_flags_and_shadowless_lamps():
    """visible_diffuse False: a diffuse floor gets nothing from the lamp. cast_shadow False: the
    occluder does not stop the light samples of a delta lamp (which BSDF rays cannot find)."""
    dark = render(_floor_scene([_point(visible_diffuse=False)], spp=16)).mean()
    assert dark.max() == 0.0
    lamp = _point((1, 0, 1))
    shadowed = render(_floor_scene([lamp], spp=16, occluder=True)).mean()
    assert shadowed[4, 4, 0] == 0.0
    through = render(_floor_scene([dict(lamp, cast_shadow=False)], spp=16, occluder=True)).mean()
    assert through[4, 4, 0] == pytest.approx(0.5 ** 1.5 / math.pi, rel=1e-4)


def test_camera_sees_lamps_by_their_flags():
    """A sphere lamp of radius 0.5 right under the camera fills the centre pixel with its
    radiance I / (pi r^2) when visible to the camera, and nothing else when not."""
    seen = _point(position=(0, 0, 2), intensity=1.0, radius=0.5, soft_falloff=False,
                  visible_camera=True)
    scene = _floor_scene([seen], spp=4, max_depth=0)
    assert render(scene).mean()[4, 4, 0] == pytest.approx(1 / (math.pi * 0.25), rel=1e-6)
    hidden = dict(seen, visible_camera=False)
    assert render(_floor_scene([hidden], spp=4, max_depth=0)).mean()[4, 4, 0] == 0.0


def _lamp_room(light, max_depth=3):
    """A floor, a ceiling and the lamp between them, seen at an angle (lamps visible)."""
    floor, ceiling = quad((0, 0, 0), 3, 3), quad((0, 0, 2.0), 3, 3, normal_sign=-1)
    mats = [{"name": "White", "kind": "diffuse", "color": [0.7, 0.7, 0.7]}]
    m = np.eye(4)
    m[:3, :3] = [[1, 0, 0], [0, 0.8, -0.6], [0, 0.6, 0.8]]
    m[:3, 3] = (0.2, -2.0, 1.6)
    cam = camera(resolution=(16, 16), lens=18.0, matrix=m.tolist())
    return make_scene([(*floor, 0), (*ceiling, 0)], mats, cam, lights=[light], max_depth=max_depth)


def _spot_matrix(position):
    m = np.eye(4)
    m[:3, 3] = position
    return m.tolist()


@pytest.mark.parametrize("light", [
    _point((0.3, 0.5, 1.2), 2.0, radius=0.3),
    _point((0.3, 0.5, 1.2), 2.0, radius=0.3, soft_falloff=False),
    _spot((0.3, 0.5, 1.2), _spot_matrix((0.3, 0.5, 1.2)), math.radians(70), 0.4, intensity=2.0,
          radius=0.2),
    {"name": "A", "kind": "area", "shape": "square", "matrix": _spot_matrix((0.2, 0.4, 1.5)),
     "size": [0.6, 0.6], "radiance": [2.0] * 3, "spread": math.radians(60)},
], ids=["disk", "sphere", "spot", "spread"])
def test_light_sampling_and_bsdf_sampling_agree_for_lamps_rays_can_hit(light):
    """Light samples with MIS and BSDF samples alone estimate the same image: the densities a
    hit reports (point_lamp_hit, area_lamp_hit) are those the light sampler used. Without light
    vertices: BSDF samples alone find the spread lamp from the ceiling so rarely that some pixels
    hold one hit in 2048 samples, whose variance estimate is then far too small, and the light
    vertices make the other image's so small that such pixels fail (test_light_vertices.py
    holds light vertices to the path tracer without them)."""
    _estimators_agree(_lamp_room(light), 256, 2048, light_vertices=False)


def test_light_sampling_and_bsdf_sampling_agree_for_a_sun_disc():
    sun = {"name": "Sun", "kind": "sun", "direction": [0.3, 0.1, -0.95], "irradiance": [2.0] * 3,
           "angle": math.radians(20)}
    floor = quad((0, 0, 0), 3, 3)
    scene = make_scene([(*floor, 0)], [{"name": "W", "kind": "diffuse", "color": [0.7] * 3}],
                       camera(position=(0, 0, 4), resolution=(12, 12), lens=30.0),
                       lights=[sun], max_depth=2)
    _estimators_agree(scene, 256, 4096)


def test_renderer_accepts_a_scene_of_every_lamp_kind():
    """All kinds together, lamps inside and outside each other's reach: no NaN, no error."""
    lights = [_point((0.5, 0, 1), radius=0.2), _point((-0.5, 0, 1), radius=0.2, soft_falloff=False),
              _point((0, 0.5, 1)),
              _spot((0, -0.5, 1), _spot_matrix((0, -0.5, 1)), 1.0, 0.0),
              {"name": "S", "kind": "sun", "direction": [0, 0, -1], "irradiance": WHITE,
               "angle": 0.1}]
    result = Renderer(_floor_scene(lights, spp=16, max_depth=3, occluder=True,
                                   lens=30.0)).render()
    assert result.nan_count == 0 and np.isfinite(result.mean()).all() and result.mean().max() > 0


@numba.njit(cache=True)
def _sampled_and_hit(lights, mesh, p, n, u, out):
    """Per light sample from p: [pdf, radiance (red)] as sample_light gave them and as a ray
    along the sampled direction finds the same lamp (its *_hit function)."""
    for j in range(u.shape[1]):
        wi, _, _, weight, pdf, _ = sample_light(lights, mesh, p, n, VISIBLE_DIFFUSE, u[0, j],
                                                u[1, j], u[2, j])
        kind, i, pmf = pick_light(lights, u[0, j])
        light, density = (0.0, 0.0, 0.0), 0.0
        if kind == POINT:
            t = intersect_point_lamp(lights, i, p, wi)
            if t > 0.0:
                cos_n = wi[0] * n[0] + wi[1] * n[1] + wi[2] * n[2]
                light, density = point_lamp_hit(lights, i, p, wi, t, cos_n / np.pi)
        elif kind == AREA:
            t = intersect_area_lamp(lights, i, p, wi)
            if t > 0.0:
                light, density = area_lamp_hit(lights, i, wi, t)
        elif kind == SUN:
            light, density = sun_hit(lights, i, wi)
        out[j, 0], out[j, 1] = pdf, weight[0] * pdf
        out[j, 2], out[j, 3] = pmf * density, light[0]


@pytest.mark.parametrize("light, p", [
    (_point((0.3, 0.2, 1.0), 2.0, radius=0.3), (0.0, 0.0, 0.0)),
    (_point((0.3, 0.2, 1.0), 2.0, radius=0.3, soft_falloff=False), (0.0, 0.0, 0.0)),
    (_point((0.3, 0.2, 0.2), 2.0, radius=0.5, soft_falloff=False), (0.0, 0.0, 0.0)),   # inside
    (_spot((0.3, 0.2, 1.0), _spot_matrix((0.3, 0.2, 1.0)), 1.2, 0.6, intensity=2.0, radius=0.3),
     (0.0, 0.0, 0.0)),
    (_spot((0.3, 0.2, 1.0), _spot_matrix((0.3, 0.2, 1.0)), 1.2, 0.6, intensity=2.0, radius=0.3,
           soft_falloff=False), (0.0, 0.0, 0.0)),
    ({"name": "A", "kind": "area", "shape": "ellipse", "matrix": _spot_matrix((0.2, 0.1, 1.0)),
      "size": [0.8, 0.5], "radiance": [2.0] * 3, "spread": math.radians(70)}, (0.0, 0.0, 0.0)),
    ({"name": "S", "kind": "sun", "direction": [0.3, 0.1, -0.95], "irradiance": [2.0] * 3,
      "angle": math.radians(20)}, (0.0, 0.0, 0.0)),
], ids=["disk", "sphere", "inside-sphere", "spot-disk", "spot-sphere", "spread", "sun"])
def test_a_hit_reports_the_density_and_radiance_of_the_light_sample(light, p):
    """For every light sample, a ray along its direction finds the same lamp with the same
    solid-angle density (to 1e-9) and the same radiance: MIS weights of the two techniques sum
    to one and both see the same light."""
    renderer = Renderer(_floor_scene([light]))
    out = np.zeros((4000, 4))
    u = np.random.default_rng(9).random((3, 4000))
    _sampled_and_hit(renderer.lights.tables, renderer.geometry.mesh, p, (0.0, 0.0, 1.0), u, out)
    sampled = out[:, 0] > 0
    assert sampled.mean() > 0.5
    assert np.allclose(out[sampled, 2], out[sampled, 0], rtol=1e-9, atol=0)
    assert np.allclose(out[sampled, 3], out[sampled, 1], rtol=1e-9, atol=1e-12)


def test_light_below_the_surface_but_above_the_shading_normal_lights_it():
    """Cycles evaluates a light sample with the shading normal alone: a smooth sheet whose normals
    tilt towards a lamp just below its plane is lit by it, I cos_s / d^2, when the shadow ray
    (from the sheet's far side) is free."""
    pos, tri = quad((0, 0, 0), 0.5, 0.5)
    tilt = np.array([0.6, 0.0, 0.8], np.float32)
    mats = [{"name": "White", "kind": "diffuse", "color": WHITE}]
    lamp = _point((3.0, 0.0, -0.3))
    scene = make_scene([(pos, tri, 0, np.tile(tilt, (4, 1)))], mats,
                       camera(position=(0, 0, 5), resolution=(9, 9), lens=5000.0),
                       lights=[lamp], spp=16, max_depth=1)
    value = render(scene).mean()[4, 4, 0]
    to_lamp = np.array([3.0, 0.0, -0.3])
    d2 = to_lamp @ to_lamp
    expected = (tilt @ to_lamp) / math.sqrt(d2) / d2 / math.pi
    assert value == pytest.approx(expected, rel=1e-3)
