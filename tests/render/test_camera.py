"""The camera follows Cycles' rules for sensor fit, shift, aspect, clipping and the thin lens."""
import numpy as np
import pytest

from support.builders import camera, make_scene, quad
from support.stats import z_bound
from snell.tracer.camera import Camera
from snell.tracer.integrator import render
from snell.tracer.pixel_filter import make_filter


def test_auto_fit_uses_sensor_width_on_the_larger_dimension():
    land = Camera(camera(resolution=(40, 20), lens=50.0))
    assert land.half_x == pytest.approx(36 / 100) and land.half_y == pytest.approx(18 / 100)
    # Portrait 20x40 with AUTO: the 36 mm width is fitted vertically (cycles-conventions.md).
    port = Camera(camera(resolution=(20, 40), lens=50.0))
    assert port.half_y == pytest.approx(36 / 100) and port.half_x == pytest.approx(18 / 100)
    vert = Camera(camera(resolution=(40, 20), lens=50.0, sensor_fit="VERTICAL"))
    assert vert.half_y == pytest.approx(24 / 100) and vert.half_x == pytest.approx(48 / 100)
    horiz = Camera(camera(resolution=(20, 40), lens=50.0, sensor_fit="HORIZONTAL"))
    assert horiz.half_x == pytest.approx(36 / 100) and horiz.half_y == pytest.approx(72 / 100)


def test_pixel_aspect_and_percentage():
    cam = Camera(camera(resolution=(101, 50), resolution_percentage=50, pixel_aspect=[1.0, 2.0]))
    assert (cam.width, cam.height) == (50, 25)      # integer truncation as in Blender
    # xratio = 50, yratio = 25 * 2 = 50: not larger, so AUTO fits vertically.
    assert cam.half_y == pytest.approx(0.36) and cam.half_x == pytest.approx(0.36)


def test_shift_moves_the_window_by_shift_times_sensor_over_lens():
    cam = Camera(camera(resolution=(64, 32), lens=35.0, shift_x=0.25, shift_y=-0.1))
    centre = cam.raster_to_camera(np.array([32.0]), np.array([16.0]))[:, 0]
    assert centre[0] == pytest.approx(0.25 * 36 / 35) and centre[1] == pytest.approx(-0.1 * 36 / 35)


def test_raster_y_zero_is_the_bottom_and_images_are_top_first():
    cam = Camera(camera(resolution=(8, 8)))
    o, d, _ = cam.generate(np.array([0, 63]), np.full((2, 2), 0.5), None)
    assert d[1, 0] > 0 and d[0, 0] < 0       # image row 0, column 0: top left
    assert d[1, 1] < 0 and d[0, 1] > 0       # last pixel: bottom right
    pts = o + d * 3.0
    assert np.allclose(cam.project(pts).T, [[0.5, 7.5], [7.5, 0.5]])


def test_rotation_ignores_object_scale():
    m = np.diag([2.0, 2.0, 2.0, 1.0])
    m[:3, 3] = (1, 2, 3)
    cam = Camera(camera(matrix=m.tolist()))
    assert np.allclose(cam.rotation, np.eye(3)) and np.allclose(cam.position, (1, 2, 3))


def test_clip_start_and_end_hide_geometry():
    lamp = quad((0, 0, 0), 10, 10)
    mats = [{"name": "Lamp", "kind": "emission", "color": [1, 1, 1], "strength": 1.0}]
    seen = render(make_scene([(*lamp, 0)], mats, camera(position=(0, 0, 5), resolution=(4, 4)),
                             max_depth=0, spp=1)).mean()
    assert np.all(seen == 1.0)
    near = render(make_scene([(*lamp, 0)], mats, camera(position=(0, 0, 5), resolution=(4, 4), clip_start=5.5),
                             max_depth=0, spp=1)).mean()
    far = render(make_scene([(*lamp, 0)], mats, camera(position=(0, 0, 5), resolution=(4, 4), clip_end=4.5),
                            max_depth=0, spp=1)).mean()
    assert np.all(near == 0.0) and np.all(far == 0.0)


def test_focus_plane_is_a_plane_not_a_sphere():
    """Lens rays for any pixel meet on the plane z = -focus (Cycles' ft = focus / D.z)."""
    cam = Camera(camera(position=(0, 0, 0), resolution=(16, 16), lens=20.0,
                        dof={"use_dof": True, "focus_distance": 3.0, "fstop": 0.5}))
    assert cam.has_lens and cam.lens_radius == pytest.approx(0.02)
    rng = np.random.default_rng(0)
    pix = np.repeat([0, 135, 255], 200)
    u_pix = np.tile(rng.random((2, 1)), (1, 600))
    o, d, _ = cam.generate(pix, u_pix, rng.random((2, 600)))
    t = (-3.0 - o[2]) / d[2]
    hits = (o + t * d).T
    for k in range(3):
        block = hits[200 * k:200 * (k + 1)]
        assert np.ptp(block[:, 0]) < 1e-9 and np.ptp(block[:, 1]) < 1e-9


def test_polygonal_aperture_and_ratio():
    cam = Camera(camera(dof={"use_dof": True, "aperture_radius": 1.0, "blades": 6,
                             "rotation": 0.0, "ratio": 2.0}))
    p = cam.lens_samples(np.random.default_rng(3).random((2, 20000))).T
    # Corners at rotation + k 60deg +- 30deg: 30, 90, 150, ... so the hexagon reaches y = 1 and
    # x = cos 30 = 0.866, which ratio 2 halves.
    assert np.abs(p[:, 0]).max() == pytest.approx(0.5 * np.cos(np.pi / 6), abs=0.01)
    assert np.abs(p[:, 0]).max() <= 0.5 * np.cos(np.pi / 6) + 1e-12
    assert np.abs(p[:, 1]).max() == pytest.approx(1.0, abs=0.01)


# -- pixel filters (tracer/pixel_filter.py) ---------------------------------------------------------

EDGE = 8.3      # raster x of the lamp's edge: the lamp covers x < EDGE of the 16 x 8 image


def edge_scene(**render):
    """An emissive quad (radiance 1) behind the left of a 16 x 8 pinhole view, its edge at raster
    x = EDGE, seen directly (max depth 1): a pixel's value is the share of its samples' positions
    left of the edge."""
    cam = camera(resolution=(16, 8), lens=50.0)
    pixel = 2 * 5.0 * 18.0 / 50.0 / 16           # the view's width at distance 5 over 16 pixels
    edge = (EDGE - 8.0) * pixel
    lamp = [{"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": 1.0}]
    return make_scene([(*quad((edge - 2.0, 0.0, 0.0), 2.0, 2.0), 0)], lamp, cam, max_depth=1,
                      **render)


def filter_cdf(kind, width, p):
    """The probability that a sample's position in its pixel (offset from its corner) is below p,
    from the table's piecewise-linear inverse (the distribution the samples have)."""
    filt = make_filter(kind, width)
    t = filt.table
    return np.interp(p, t, np.linspace(0.0, 1.0, len(t)), left=0.0, right=1.0)


@pytest.mark.parametrize("kind,width", [("box", 1.0), ("blackman_harris", 1.5),
                                        ("gaussian", 2.0), ("box", 2.5)])
def test_a_lamp_edge_is_blurred_by_the_filter(kind, width):
    """Across a sharp edge each pixel is the filter's CDF at the edge (z-tests per pixel,
    Bernoulli variances, Sidak over the pixels), and a wrong filter fails the same test."""
    spp = 1024
    scene = edge_scene(spp=spp, pixel_filter=kind, filter_width=width)
    img = render(scene, scene.settings(sampler="independent", noise_threshold=0.0)).mean()[..., 0]
    cols = np.arange(16)

    def worst_z(k, w):
        expected = filter_cdf(k, w, EDGE - cols)
        var = np.maximum(expected * (1 - expected), 0.25 / spp) / (8 * spp)   # row means
        return np.max(np.abs(img.mean(axis=0) - expected) / np.sqrt(var))

    assert np.allclose(img, img[0:1], atol=0.2)          # every row sees the same edge
    assert worst_z(kind, width) < z_bound(16)
    wrong = {"box": ("blackman_harris", 1.5), "blackman_harris": ("blackman_harris", 1.7),
             "gaussian": ("gaussian", 2.3)}[kind]
    if (kind, width) != ("box", 2.5):
        assert worst_z(*wrong) > z_bound(16)
    else:
        assert worst_z("box", 2.0) > z_bound(16)
