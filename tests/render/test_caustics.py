"""The caustics light tracer (tracer/light_tracer.py) against the path tracer.

Pure light tracing (every light path connected to the camera at every diffuse vertex) estimates
the same image as the path tracer wherever the camera does not see an emitter directly, so the
two are held against each other pixel by pixel: that checks the camera connection (raster
position, lens, importance, render region) and the shading-normal correction. The hybrid (light
tracer for L S+ D E, path tracer for the rest) must render the path tracer's image at every max
depth. Renders use independent samples and K independent batches, so every variance is honest.
"""
import copy
import math

import numpy as np
import pytest

from support.builders import icosphere
from support.caustic_scenes import (BATCHES, GLASS, WHITE, caustic_room, room,
                                     room_camera)
from snell.addon import window
from snell.validation import metrics
from snell.tracer.integrator import Renderer


def agree(a, va, dfa, b, vb, dfb):
    """The validator's statistics (validation/metrics.py: per-pixel Welch t-tests, 8x8 tiles and
    image means, with degrees of freedom) find the two estimates consistent; returns them."""
    stats = metrics.compare(a, va, dfa, b, vb, dfb)
    stats.pop("maps")
    assert stats["verdict"] == metrics.CONSISTENT, stats
    return stats


# -- scenes (the room and its materials: support/caustic_scenes.py) -----------------------------

def smooth_sphere(material, center, radius):
    """A coarse icosphere with smooth normals: shading and geometric normals differ a lot."""
    pos, tri, nrm = icosphere(1, radius=radius, center=center)
    return (pos, tri, material, nrm)


def pure(scene, spp):
    """(path tracer mean, variance, dof, light tracer mean, variance, dof) of one pure render:
    variances from BATCHES independent batches."""
    # Pure light tracing carries the whole image: more light paths than the hybrid's share.
    result = Renderer(scene, scene.settings(sampler="independent", pure_light_tracing=True,
                                            light_paths_per_camera_path=0.5, spp=spp,
                                            batches=BATCHES)).render()
    assert result.light_paths > 0 and result.batches == BATCHES
    return (result.mean().astype(np.float64), result.variance_of_mean(), BATCHES - 1,
            result.light_image(), result.light_variance_of_mean(), BATCHES - 1)


# -- pure light tracing against the path tracer ------------------------------------------------------

# Light tracing is the noisier technique here (a few light paths carry the indirect light on the
# sphere's underside): 2048 samples at 16x16 give every pixel enough of them (about 1 s). At 8192
# the image means agreed to 0.1% (z 0.3, -0.2, -0.5 without a sphere, smooth, flat).
PURE_SPP = 2048


def tilted_panel():
    """A panel in front of the back wall whose shading normals lean 40 degrees towards the
    ceiling: light from above meets it at very different shading and geometric cosines."""
    pos = np.array([[-0.9, 0.9, 0.1], [0.9, 0.9, 0.1], [0.9, 0.9, 1.9], [-0.9, 0.9, 1.9]],
                   np.float32)
    tri = np.array([[0, 1, 2], [0, 2, 3]], np.int32)          # facing -Y, the camera
    a = math.radians(40.0)
    normals = np.tile(np.array([0.0, -math.cos(a), math.sin(a)], np.float32), (4, 1))
    return (pos, tri, WHITE, normals)


def pure_room(cam=None):
    """The diffuse room with a coarse smooth-shaded sphere before a panel of tilted shading
    normals, 16x16, max depth 3."""
    return room([smooth_sphere(WHITE, (0.3, 0.3, 0.5), 0.4), tilted_panel()],
                cam or room_camera((16, 16)), max_depth=3, lamp_half=0.4)


FILTERS = {"blackman_harris": ("blackman_harris", 1.5), "gaussian": ("gaussian", 2.0)}


@pytest.mark.parametrize("case", ["pinhole", "dof", "region", "blackman_harris", "gaussian"])
def test_pure_light_tracing_matches_the_path_tracer(case):
    """The light tracer's image (all of it but emitters seen directly) equals the path tracer's,
    with smooth shading normals (the adjoint correction), depth of field, a render region and
    pixel filters (the light tracer's splats spread by the filter's density, the camera's samples
    drawn from it; Gaussian 2 reaches 2.5 pixels past the image)."""
    dof = {"use_dof": True, "focus_distance": 1.2, "fstop": 0.5} if case == "dof" else None
    scene = pure_room(room_camera((16, 16), dof=dof))
    if case == "region":
        x0, y0, w, h = window.border_pixels(16, 16, (0.25, 0.75, 0.1, 0.6))
        scene = scene.with_camera(**window.window_camera(scene.camera, x0, y0, w, h))
    if case in FILTERS:
        kind, width = FILTERS[case]
        scene = scene.with_render(pixel_filter=kind, filter_width=width)
    agree(*pure(scene, PURE_SPP))


@pytest.mark.slow        # two pure renders (about 80 s on 2 loaded cores): a one-off check of power
def test_a_light_tracer_that_ignores_the_filter_is_caught():
    """The check above sees splats spread by another filter than the camera samples': the light
    image of a Gaussian 4 render (sigma 1 pixel) against the path tracer's with a 1-pixel box.
    (Box against Blackman-Harris 1.5 is within this smooth 16 x 16 room's noise at 2048 spp:
    the filters' own tests are tests/unit/test_pixel_filter.py and test_camera's lamp edge.)"""
    scene = pure_room()
    box = pure(scene, PURE_SPP)
    blurred = pure(scene.with_render(pixel_filter="gaussian", filter_width=4.0), PURE_SPP)
    with pytest.raises(AssertionError):
        agree(*box[:3], *blurred[3:])


def test_the_comparison_sees_a_two_percent_error():
    """The check above has the power to see a light tracer 2% too bright. (A light tracer
    without the shading-normal correction at the camera connection fails it too: checked by
    hand, on the tilted panel.)"""
    pt, pt_var, pt_dof, lt, lt_var, lt_dof = pure(pure_room(), PURE_SPP)
    agree(pt, pt_var, pt_dof, lt, lt_var, lt_dof)
    with pytest.raises(AssertionError):
        agree(pt, pt_var, pt_dof, 1.02 * lt, lt_var, lt_dof)


# -- the hybrid against the path tracer ----------------------------------------------------------

@pytest.mark.parametrize("max_depth", [1, 2, 3, 8])
def test_hybrid_renders_the_path_tracers_image(max_depth):
    """The split of path space is disjoint and complete: at every max depth the hybrid and the
    path tracer alone (independent seeds) agree in every 8x8 tile and in the image mean."""
    scene = caustic_room(max_depth)
    hybrid = Renderer(scene, scene.settings(sampler="independent", spp=512,
                                            batches=BATCHES)).render()
    assert hybrid.light_in_image and hybrid.light_paths > 0
    path = Renderer(scene, scene.settings(seed=1, sampler="independent", caustics=False, spp=512,
                                          batches=BATCHES)).render()
    assert not path.light_in_image and path.light_paths == 0
    # Variances from batches: the path tracer finds the caustics by rare paths, and its
    # per-sample variance underestimates the error there. Single pixels stay heavy-tailed (with
    # other seeds about one case in six failed the per-pixel test by one pixel of 576, never the
    # tiles or the image mean), so pixels are held to 99% here, tiles and means to the rule.
    va, dfa = hybrid.variance_and_dof()
    vb, dfb = path.variance_and_dof()
    stats = metrics.compare(hybrid.mean(), va, dfa, path.mean(), vb, dfb)
    assert stats["tests"]["tiles"] and stats["tests"]["image_mean"], stats
    assert stats["z_pass_fraction"] >= 0.99, stats
    splats = hybrid.stats["caustic_splats"]
    assert (splats == 0) if max_depth < 2 else (splats > 0)


def test_the_hybrid_image_depends_on_the_seed_only():
    """Light splats are added in chunk order: one thread or two give the same bits."""
    # One pass of 64x64 x 64 samples: 4 chunks of light paths, many splats per caustic pixel.
    scene = caustic_room(8, (64, 64)).with_render(spp=64)
    a = Renderer(scene, scene.settings(threads=1, batches=1)).render()
    b = Renderer(scene, scene.settings(threads=2, batches=1)).render()
    assert a.light_paths > 3 * 8192 and a.stats["caustic_splats"] > 0
    # The float64 sums, not only the float32 image (which would round most differences away).
    assert np.array_equal(a.light_sum, b.light_sum) and np.array_equal(a.sum, b.sum)
    assert not np.array_equal(a.mean(), Renderer(scene, scene.settings(seed=1)).render().mean())


def test_filtered_splats_depend_on_the_seed_only_and_count_light_paths():
    """With Blackman-Harris 1.5 each light path that reaches the camera spreads over up to 3 x 3
    pixels, added in chunk order (one thread or two give the same bits); the summary counts the
    light paths that reached the camera, not their splats: at most the light paths traced, and
    at least the box's (the filter also keeps points just past the image)."""
    scene = caustic_room(8, (32, 32)).with_render(spp=32)
    filtered = scene.with_render(pixel_filter="blackman_harris", filter_width=1.5)
    # The same light paths with either filter: a fixed share (the pilot's follows the filter).
    share = {"light_paths_per_camera_path": 0.125}
    a = Renderer(filtered, filtered.settings(threads=1, batches=1, **share)).render()
    b = Renderer(filtered, filtered.settings(threads=2, batches=1, **share)).render()
    assert np.array_equal(a.light_sum, b.light_sum) and np.array_equal(a.sum, b.sum)
    box = Renderer(scene, scene.settings(threads=2, batches=1, **share)).render()
    assert 0 < box.stats["caustic_splats"] <= a.stats["caustic_splats"] <= a.light_paths


def test_light_tracing_runs_only_where_it_has_something_to_do():
    """No mirror or glass: no light tracing; no diffuse surface for light paths to end on, or
    a lamp whose MIS option is off (glass does not see it), neither. A point lamp of radius 0
    (a delta lamp, which no ray can hit) does start light paths (test_caustics_delta.py)."""
    diffuse = room([smooth_sphere(WHITE, (0.3, 0.3, 0.5), 0.4)])
    assert Renderer(diffuse).caustics is None
    specular = caustic_room(8)
    assert Renderer(specular).caustics is not None
    assert Renderer(specular, specular.settings(caustics=False)).caustics is None
    no_diffuse = copy.copy(specular)
    no_diffuse.materials = [dict(m, kind="mirror") if m["kind"] == "diffuse" else m
                            for m in specular.materials]
    assert Renderer(no_diffuse).caustics is None
    point = {"name": "Point", "kind": "point", "position": [0.0, 0.0, 1.9],
             "intensity": [5.0, 5.0, 5.0], "radius": 0.0}
    glass = [(*icosphere(2, 0.3, (0, 0, 0.5))[:2], GLASS)]
    assert Renderer(room(glass, lights=[point])).caustics is not None
    assert Renderer(room(glass, lights=[dict(point, use_mis=False)])).caustics is None
    result = Renderer(diffuse, diffuse.settings(spp=2)).render()
    assert result.light_paths == 0 and not result.light_in_image


def test_the_command_line_says_whether_light_tracing_runs(tmp_path):
    """`snell info` names the technique; `snell render` counts light paths, or says there were
    none with --caustics off; the scene file keeps the setting."""
    import subprocess
    import sys

    from snell import cli
    from snell.tracer.scene import load, save

    path = tmp_path / "caustics.snell"
    save(caustic_room(3, (8, 8)).with_render(spp=2), str(path))
    assert load(str(path)).render["caustics"] is True
    info = {line.split()[0]: line for line in cli.describe(load(str(path)))}
    assert "light tracing" in info["caustics"]
    off = load(str(path)).with_render(caustics=False)
    assert "path tracer only (caustics off)" in {line.split()[0]: line for line in cli.describe(off)}["caustics"]
    diffuse = room(cam=room_camera((8, 8)))
    assert "no smooth mirror or glass" in {line.split()[0]: line for line in cli.describe(diffuse)}["caustics"]

    def render(*extra):
        proc = subprocess.run([sys.executable, "-m", "snell.cli", "render", str(path), "-o",
                               str(tmp_path / "out.exr"), "--threads", "1", *extra],
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr
        return proc.stdout
    assert "light paths" in render()
    assert "no light tracing" in render("--caustics", "off")


def test_a_render_skips_what_the_scene_does_not_need():
    """No glass: the dielectric code is never entered; no depth of field: no lens samples;
    each skip is named, with its reason."""
    room = pure_room()                                   # diffuse only, pinhole, no world
    plain = Renderer(room, room.settings(spp=2)).render()
    assert plain.stats["dielectric_samples"] == 0 and plain.stats["lens_samples"] == 0
    assert plain.stages["dielectric sampling"] == (False, "no smooth glass")
    assert plain.stages["lens sampling"] == (False, "no depth of field")
    assert plain.stages["world"] == (False, "black world")
    assert plain.stages["light tracing"][0] is False
    assert plain.stages["next-event estimation"][0] is True
    dof = {"use_dof": True, "focus_distance": 1.2, "fstop": 0.5}
    glass = Renderer(caustic_room(3, (16, 16)).with_camera(dof=dof).with_render(spp=2)).render()
    assert glass.stats["dielectric_samples"] > 0 and glass.stats["lens_samples"] == 16 * 16 * 2
    assert glass.stages["dielectric sampling"] == (True, "glass")
    assert glass.stages["lens sampling"] == (True, "depth of field")
    assert glass.stages["light tracing"][0] is True


def test_the_light_tracer_follows_the_camera_between_orthographic_and_perspective():
    """The light tracer connects to a pinhole or a thin lens: an orthographic camera turns it off
    and a perspective one back on, whichever the renderer was built with (the viewport switches
    views on one renderer)."""
    scene = caustic_room(8)
    ortho_scene = scene.with_camera(type="ORTHO", ortho_scale=2.0)
    for built in (Renderer(scene), Renderer(ortho_scene)):
        ortho = built.with_camera(ortho_scene.camera)
        assert ortho.caustics is None and not ortho.split
        assert ortho.stages()["light tracing"] == (False, "orthographic camera")
        perspective = built.with_camera(scene.camera)
        assert perspective.caustics is not None and perspective.split
        assert perspective.stages()["light tracing"][0]
        assert perspective.with_sampling(spp=2).render().light_paths > 0
