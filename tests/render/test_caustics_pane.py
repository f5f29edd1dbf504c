"""The light tracer through an open glass pane (issue 34's image bug): a single quad of glass,
IOR 1.45, between an emissive quad and a diffuse floor, so that light reaches the floor through
one refraction only (no second face to leave the glass by).

The hybrid (light tracer on) and the path tracer alone (off) estimate the same image, so they
are held against each other with the validator's statistics (validation/metrics.py: per-pixel
Welch t-tests, 8x8 tiles and the image mean, Sidak-corrected), variances from 16 independent
batches, fixed seeds. The pane is tried with its front face towards the camera (the light
meets its back face: "leaving" glass, n_i / n_t = 1.45) and towards the lamp ("entering",
1 / 1.45): Cycles decides the side of a glass surface by its face, so the two are different
scenes, and the path tracer's images differ (mean 0.263 and 0.185).

Measured at these seeds: the hybrid's image mean 0.2620 against the path tracer's 0.2626
(image-mean z -0.25) with the front to the camera, 0.1870 against 0.1847 (z +1.84) with it to
the lamp; at 2048 spp and two other pairs of seeds |z| <= 0.62. The old code (a light path's
refraction weighed as the camera path's, without the adjoint's (n_i / n_t)^2 of
specular.light_refraction_scale) fails both: 0.2420 (z -11.6, 5 of 9 tiles; the light
tracer's share 0.0216 instead of 0.0416) and 0.2041 (z +11.9, 4 tiles). The factor unsquared
(n_i / n_t) fails them too: z -6.1 and +6.7, 2 tiles each.
"""
import numpy as np
import pytest

from support.builders import make_scene
from support.caustic_scenes import BATCHES, look_at
from snell.tracer.integrator import Renderer
from snell.validation import metrics

IOR = 1.45
SPP = 256
MATERIALS = [{"name": "Floor", "kind": "diffuse", "color": [0.8, 0.8, 0.8]},
             {"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": 4.0},
             {"name": "Pane", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": IOR}]
FLOOR, LAMP, PANE = range(3)


def quad(corners):
    """Two triangles over four corners in order (facing by the right-hand rule)."""
    return np.array(corners, np.float32), np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def pane_scene(front_to_camera):
    """A 6 m diffuse floor, a 0.8 x 1 m emissive quad at y = 1.4 facing -Y and a 1 x 1.2 m
    glass pane at y = 1.0 before part of it, seen from the front and above; 24x24, max depth 4."""
    pane = [(0.8, 1.0, 0.0), (1.8, 1.0, 0.0), (1.8, 1.0, 1.2), (0.8, 1.0, 1.2)]  # faces -Y
    if not front_to_camera:
        pane = pane[::-1]
    meshes = [(*quad([(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)]), FLOOR),
              (*quad([(1.2, 1.4, 1.6), (1.2, 1.4, 0.6), (2.0, 1.4, 0.6), (2.0, 1.4, 1.6)]), LAMP),
              (*quad(pane), PANE)]
    cam = look_at((1.3, -1.5, 2.0), (1.3, 0.5, 0.0), (24, 24))
    scene = make_scene(meshes, MATERIALS, cam, max_depth=4)
    scene.objects = [dict(o, closed=False) for o in scene.objects]
    return scene


def render(scene, caustics, seed):
    """A render of BATCHES independent batches, with the light tracer on or off, at the fixed
    light share these figures were measured with. The pilot gives this scene's light tracer 4
    and 1.8 light paths per camera path: the hybrid's caustic is then cleaner than the path
    tracer's batches can show (their rare caustic paths missed two to nine pixels at z up to
    17; a path tracer of 16 times the samples agrees with that hybrid, max |z| 5.5)."""
    return Renderer(scene, scene.settings(sampler="independent", caustics=caustics, spp=SPP,
                                          seed=seed, batches=BATCHES,
                                          light_paths_per_camera_path=0.125)).render()


@pytest.fixture(scope="module", params=[True, False], ids=["front_to_camera", "front_to_lamp"])
def renders(request):
    """(the light's (n_i / n_t)^2 at the pane, hybrid, path tracer alone) of the pane scene,
    independent seeds."""
    scene = pane_scene(request.param)
    # With its front to the camera the pane meets the lamp's light on its back face: leaving.
    scale = IOR ** 2 if request.param else 1.0 / IOR ** 2
    return scale, render(scene, True, 1), render(scene, False, 2)


def compared(a, a_image, b):
    """The validator's statistics of image a_image (with a's variances) against b's."""
    va, dfa = a.variance_and_dof()
    vb, dfb = b.variance_and_dof()
    stats = metrics.compare(a_image, va, dfa, b.mean(), vb, dfb)
    stats.pop("maps")
    return stats


def test_the_hybrid_renders_the_path_tracers_image_through_an_open_pane(renders):
    """The light tracer carries the caustic (at least 5% of the image mean: measured 16% and
    8.4%) and the hybrid agrees with the path tracer alone in every test of the validator."""
    _, hybrid, path = renders
    assert hybrid.light_paths > 0 and not path.light_in_image
    assert hybrid.light_image().mean() > 0.05 * hybrid.mean().mean()
    stats = compared(hybrid, hybrid.mean(), path)
    assert stats["verdict"] == metrics.CONSISTENT, stats


def test_the_old_weight_is_caught(renders):
    """Power: the hybrid with its light tracer's share weighed as before the fix (divided by
    the pane's (n_i / n_t)^2 for the direction light crosses it) is inconsistent (measured:
    image-mean z -8.8 and 2 tiles with the front to the camera, +16.0 and 6 tiles with it to the
    lamp)."""
    scale, hybrid, path = renders
    light = hybrid.light_image()
    # Nearly every splat crossed the pane once, the emitter lying behind it (one whose light
    # reflected off the pane is scaled too: the old image is only approximated).
    stats = compared(hybrid, hybrid.mean() - light + light / scale, path)
    assert stats["verdict"] == metrics.INCONSISTENT, stats
