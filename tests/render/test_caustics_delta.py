"""Caustics from delta lamps (issue 34): a point or spot lamp of radius 0, a sun of angle 0 and
a collimated (spread 0) area lamp start light paths (tracer/light_tracer.py), the only technique that renders their light through
glass onto a diffuse surface (L S+ D E): no camera path can hit a delta lamp.

The hybrid (path tracer plus light tracer) is held against pure light tracing of the same scene
(every light path connected at every diffuse vertex; Renderer(pure_light_tracing=True)), which
for a delta lamp in a black world renders the whole image by another estimator: unaimed light
paths, direct light included. Both with independent batches, so every variance is honest; the
validator's statistics (per-pixel, 8x8 tiles, image mean) must find them consistent, and the
mean of the caustic region (where the light tracer carries at least 10% of the hybrid's image)
must agree within 3.5 standard errors. Pure light tracing connects diffuse vertices to the lens
directly, so it cannot render what the camera sees in the glass: pixels whose footprint touches
the sphere are left out (both images are set to 0 there, with variance 0). Power: the hybrid without the delta lamps' light paths,
and with their weight doubled, must both be caught.
"""
import math

import numpy as np
import pytest

from support.builders import icosphere, make_scene, quad
from support.caustic_scenes import BATCHES, GLASS, WALLS, WHITE, look_at, room
from support.stats import region_z
from snell.tracer.integrator import Renderer
from snell.validation import metrics

RESOLUTION = (24, 24)
MAX_DEPTH = 4
HYBRID_SPP = 256
# The hybrid's light paths per camera path: where a delta lamp's caustic lights much of the room
# (the collimated lamp's), its light reflected onward is the light tracer's too, and at the
# default 1/8 its few splats in dim pixels gave per-pixel variances too small (1% of pixels
# failed at 256 spp; at 1024 they agreed).
LIGHT_PATHS = 1.0
PURE_SPP = 2048      # pure light tracing carries the whole image with unaimed light paths
REGION_Z = 3.5       # the caustic region's mean: |z| bound (one test per case)


def glass_sphere():
    """A smooth-shaded glass sphere of radius 0.3 whose centre is 0.6 above the floor."""
    pos, tri, normals = icosphere(3, radius=0.3, center=(0.0, 0.0, 0.6))
    return (pos, tri, GLASS, normals)


def camera():
    """Above the floor, looking down at the sphere and the caustic under it."""
    return look_at((0.0, -0.9, 1.5), (0.05, 0.1, 0.1), RESOLUTION)


def point_scene():
    """The closed room lit by a point lamp of radius 0 above the sphere."""
    point = {"name": "Point", "kind": "point", "position": [0.1, 0.05, 1.6],
             "intensity": [3.0, 3.0, 3.0], "radius": 0.0}
    return room([glass_sphere()], camera(), max_depth=MAX_DEPTH, lights=[point])


def spot_scene():
    """The closed room lit by a spot of radius 0 whose cone's blended edge crosses the sphere,
    so that the caustic depends on the spot's profile."""
    m = np.eye(4)
    m[:3, 3] = (0.2, 0.0, 1.6)                 # unrotated: the spot points down (-Z)
    spot = {"name": "Spot", "kind": "spot", "position": [0.2, 0.0, 1.6],
            "intensity": [6.0, 6.0, 6.0], "radius": 0.0, "matrix": m.tolist(),
            "spot_size": math.radians(36.0), "spot_blend": 0.4}
    return room([glass_sphere()], camera(), max_depth=MAX_DEPTH, lights=[spot])


def sun_scene():
    """A white floor and the glass sphere in a black world, lit by a sun of angle 0."""
    sun = {"name": "Sun", "kind": "sun", "direction": [0.15, 0.1, -1.0],
           "irradiance": [2.0, 2.0, 2.0], "angle": 0.0}
    floor = (*quad((0.0, 0.0, 0.0), 1.5, 1.5), WHITE)
    return make_scene([floor, glass_sphere()], WALLS, camera(), lights=[sun],
                      max_depth=MAX_DEPTH)


def collimated_scene():
    """The closed room lit by a collimated (spread 0) area lamp straight above the sphere: a
    delta in direction, like the sun, but from a lamp's area."""
    m = np.eye(4)
    m[:3, 3] = (0.05, 0.0, 1.6)                # unrotated: it emits down (-Z)
    lamp = {"name": "Collimated", "kind": "area", "shape": "square", "matrix": m.tolist(),
            "size": [0.8, 0.8], "radiance": [1.0, 1.0, 1.0], "spread": 0.0}
    return room([glass_sphere()], camera(), max_depth=MAX_DEPTH, lights=[lamp])


SCENES = {"point": point_scene, "spot": spot_scene, "sun": sun_scene,
          "collimated": collimated_scene}
KINDS = {"point": "point", "spot": "spot", "sun": "sun", "collimated": "area"}


def render(scene, **settings):
    return Renderer(scene, scene.settings(sampler="independent", batches=BATCHES,
                                          **settings)).render()


class Case:
    """A scene's hybrid render and its pure light tracing reference, both masked."""

    def __init__(self, name):
        scene = SCENES[name]()
        renderer = Renderer(scene)
        # Pixels whose 4x4 camera rays all see the floor or the room, not the glass.
        glass = np.flatnonzero([m["kind"] == "glass" for m in scene.materials])
        glass_objects = np.unique(scene.object_ids[np.isin(scene.material_ids, glass)])
        self.keep = ~np.isin(renderer.object_index(4), glass_objects).any(axis=2)
        hybrid = render(scene, spp=HYBRID_SPP, light_paths_per_camera_path=LIGHT_PATHS)
        pure = render(scene, seed=1, spp=PURE_SPP, pure_light_tracing=True,
                      light_paths_per_camera_path=0.5)
        self.name, self.hybrid = name, hybrid
        self.mean = self.masked(hybrid.mean())
        self.var, self.dof = hybrid.variance_and_dof()
        self.var = self.masked(self.var)
        self.light = self.masked(hybrid.light_image())
        self.pure = self.masked(pure.light_image())
        self.pure_var = self.masked(pure.light_variance_of_mean())
        share = self.light.sum(axis=2) / np.maximum(self.mean.sum(axis=2), 1e-12)
        self.region = share >= 0.1       # the caustic region

    def masked(self, image):
        return np.where(self.keep[..., None], image, 0.0)

    def compare(self, image):
        """The validator's statistics of image (with the hybrid's variance) against pure light
        tracing, and the caustic region's z."""
        stats = metrics.compare(image, self.var, self.dof, self.pure, self.pure_var,
                                BATCHES - 1, error_metrics=False)
        stats.pop("maps")
        return stats, region_z(image, self.var, self.pure, self.pure_var, self.region)


@pytest.fixture(scope="module", params=sorted(SCENES))
def case(request):
    return Case(request.param)


def test_delta_lamps_start_light_paths():
    """A delta lamp over glass runs the light tracer, named in the render's stages; its light
    paths reach the camera."""
    for name, build in SCENES.items():
        renderer = Renderer(build())
        assert renderer.caustics is not None and renderer.split, name
        why = renderer.stages()["light tracing"][1]
        assert why == f"from '{name.capitalize()}' ({KINDS[name]}, delta)", why


def test_hybrid_matches_pure_light_tracing(case):
    """The hybrid (the delta lamp's caustics by aimed light paths, the rest path traced) and
    pure light tracing estimate the same image: the validator's tests and the caustic region's
    mean agree."""
    assert case.hybrid.light_paths > 0 and case.hybrid.stats["caustic_splats"] > 0
    assert case.region.sum() >= 10, f"{case.name}: a caustic of {case.region.sum()} pixels"
    stats, z = case.compare(case.mean)
    assert stats["verdict"] == metrics.CONSISTENT, (case.name, stats)
    assert abs(z) < REGION_Z, (case.name, z, case.region.sum())


@pytest.mark.parametrize("error", ["dropped", "doubled"])
def test_a_missing_or_doubled_caustic_is_caught(case, error):
    """Power: without the delta lamp's light paths (the path tracer alone, as before issue 34),
    or with their weight doubled, the same comparison fails."""
    wrong = case.mean + (-1.0 if error == "dropped" else 1.0) * case.light
    stats, z = case.compare(wrong)
    assert stats["verdict"] == metrics.INCONSISTENT, (case.name, error)
    assert abs(z) > 3 * REGION_Z, (case.name, error, z)


def test_info_and_the_render_summary_name_the_delta_lamp(tmp_path):
    """`snell info`'s caustics line and `snell render`'s summary say which lamps light paths
    start on, delta lamps named so."""
    import subprocess
    import sys

    from snell import cli
    from snell.tracer.scene import save

    scene = point_scene().with_render(spp=1)
    info = {line.split()[0]: line for line in cli.describe(scene)}["caustics"]
    assert "light tracing from 'Point' (point, delta) through mirrors and glass" in info, info
    path = tmp_path / "point.snell"
    save(scene, str(path))
    proc = subprocess.run([sys.executable, "-m", "snell.cli", "render", str(path), "-o",
                           str(tmp_path / "out.exr"), "--threads", "1"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "light paths from 'Point' (point, delta) (" in proc.stdout, proc.stdout
