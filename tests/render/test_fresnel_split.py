"""The Fresnel split at smooth glass (wavefront.split_fresnel): the light a glass's mirror
reflection finds at its next hit is counted at F whichever way the path went. The image's
expectation stays what it was (held here against renders with the split off, every estimator
unbiased, the independent sampler's honest variances); the glints' noise goes."""
import math

import numpy as np
import pytest
from scipy import stats as scipy_stats

from support.sds_scenes import pool, pool_sun, shadow_caustics, tumbler
from support.stats import renders_agree
from snell.tracer.integrator import Renderer

HONEST = {"sampler": "independent", "noise_threshold": 0.0}
OFF = {**HONEST, "fresnel_split": False, "seed": 11}
ON = {**HONEST, "fresnel_split": True, "seed": 7}


def test_split_leaves_the_pools_image_as_it_was():
    """The pool (the lamp mirrored in the waves, the floor seen through them and lit through
    them by its shadow caustics), without the light tracer: with the split at 1024 spp against
    without it at 8192 (its glints need the samples: a pixel with no hit of the lamp's
    reflection has no variance for it)."""
    scene = shadow_caustics(pool(resolution=(20, 20)))
    renders_agree(scene, {**OFF, "spp": 8192, "caustics": False},
                  {**ON, "spp": 1024, "caustics": False})


def test_split_leaves_the_tumblers_image_as_it_was():
    """The tumbler (light reflected inside the tube's wall and off its outside), without the
    light tracer: paths of many glass bounces, split up to their first diffuse one."""
    scene = shadow_caustics(tumbler(resolution=(24, 24)))
    renders_agree(scene, {**OFF, "spp": 4096, "caustics": False},
                  {**ON, "spp": 1024, "caustics": False})


@pytest.mark.parametrize("make", [pool, tumbler])
def test_one_mirror_ray_per_glass_refraction(make):
    """Each refraction at glass before a path's first diffuse bounce queues one mirror ray and
    nothing else does. At max depth 1 every refraction is the camera's hit, and the tumbler's
    wavefront holds hits on the table (diffuse) beside those on glass: a stale F from a glass
    hit once split the diffuse hits after it too (on glass_wall the image 1% too bright, z up
    to 19)."""
    scene = shadow_caustics(make(resolution=(16, 16), max_depth=1))
    on = Renderer(scene, scene.settings(spp=64, caustics=False)).render().stats
    assert on["fresnel_splits"] == on["transmissions"] > 0
    off = Renderer(scene, scene.settings(spp=64, caustics=False,
                                         fresnel_split=False)).render().stats
    assert off["fresnel_splits"] == 0


def test_no_split_after_a_diffuse_bounce():
    """At the default depth, paths refract at the water again after the floor (light off the
    floor, up through the water and back), and those refractions are not split."""
    scene = shadow_caustics(pool(resolution=(16, 16)))
    stats = Renderer(scene, scene.settings(spp=64, caustics=False)).render().stats
    assert 0 < stats["fresnel_splits"] < stats["transmissions"]


def test_split_under_a_sky_and_a_sun():
    """The world's light is not split: under a grey sky the mirror rays are still traced only
    where they cross the lamp (the others would find nothing they count). A sun of 17 degrees
    is split, and may be found wherever a mirror ray escapes: then every one is traced. Both
    images are the ones without the split."""
    sky = shadow_caustics(pool(resolution=(16, 16), world=(0.3, 0.3, 0.3)))
    sun = shadow_caustics(pool(resolution=(16, 16), lamp=pool_sun(0.3)))
    assert Renderer(sky)._lamps_only and not Renderer(sun)._lamps_only
    # The sun's glints are rarer without the split: it needs more samples to meet them.
    for scene, traced, spp_off in ((sky, lambda rays, splits: 0 < rays < 0.5 * splits, 4096),
                                   (sun, lambda rays, splits: rays == splits, 16384)):
        # The same seed: the paths are the same, and the mirror rays are the difference.
        on = Renderer(scene, scene.settings(spp=64, caustics=False, seed=3)).render()
        off = Renderer(scene, scene.settings(spp=64, caustics=False, seed=3,
                                             fresnel_split=False)).render()
        assert traced(on.rays - off.rays, on.stats["fresnel_splits"]), (on.rays, off.rays)
        renders_agree(scene, {**OFF, "spp": spp_off, "caustics": False},
                      {**ON, "spp": 1024, "caustics": False})


def test_split_keeps_cycles_clamp():
    """With Cycles' clamps (direct 1, indirect 0.5; the lamp's reflection is 100 times the
    direct one): the clamp applies to the sample a path would carry alone, before the split's
    F, so the expectation is the clamped estimator's (clamping F x the light instead would
    count the glints 50 times brighter)."""
    scene = shadow_caustics(pool(resolution=(20, 20)))
    clamp = {"sample_clamp_direct": 1.0, "sample_clamp_indirect": 0.5, "caustics": False}
    renders_agree(scene, {**OFF, "spp": 4096, **clamp}, {**ON, "spp": 1024, **clamp})


def test_split_beside_the_light_tracer():
    """The tumbler with its light tracer and shadow caustics as rendered by default: the mirror
    rays carry the path's caustic and shadow-caustics states, so they count none of the light
    those carry. The images' means over the whole image, each from 16 batches (the light
    tracer's splats have no per-sample variance)."""
    scene = shadow_caustics(tumbler(resolution=(24, 24)))
    means = []
    for settings in (OFF, ON):
        result = Renderer(scene, scene.settings(**settings, spp=1024, batches=16,
                                                light_paths_per_camera_path=0.25)).render()
        assert result.light_paths > 0 and result.stats["mnee_paths"] > 0
        batches = result.batch_sum.reshape(16, -1).sum(axis=1)
        light = result.light_batch_sum.reshape(16, -1).sum(axis=1)
        # Each batch's image sum: its camera samples' mean plus its light paths' splats.
        per_batch = (batches / (result.spp / 16) + light / (result.light_paths / 16)) \
            / result.sum.size
        means.append((per_batch.mean(), per_batch.var(ddof=1) / 16))
    (a, va), (b, vb) = means
    t = (b - a) / math.sqrt(va + vb)
    assert abs(t) < scipy_stats.t.isf(0.0005, 30), (a, b, t)


def relative_variance(result):
    """The mean over pixels of one sample's variance relative to the pixel's mean squared."""
    mean = result.mean().astype(np.float64)
    per_sample = result.variance_of_mean() * result.spp
    return float((per_sample / (mean * mean + 1e-2)).mean())


def test_split_takes_the_glints_noise_out():
    """On the pool at equal samples the split's per-sample variance (relative, as the bench's
    relMSE weighs it) is a fraction of the path's alone: the glints, a few samples that meet
    the lamp's reflection among many that do not, were most of it (measured 0.15 x at 20x20,
    1024 spp; 0.17 x at 256x256 with the shadow caustics)."""
    scene = shadow_caustics(pool(resolution=(20, 20)))
    off = Renderer(scene, scene.settings(**OFF, spp=1024, caustics=False)).render()
    on = Renderer(scene, scene.settings(**ON, spp=1024, caustics=False)).render()
    assert relative_variance(on) < 0.3 * relative_variance(off)
    # Each mirror ray is one more ray for a path that refracts at the water.
    assert on.rays < 1.3 * off.rays


def test_split_light_goes_to_the_glossy_pass():
    """The mirror rays' light at the first bounce is Glossy Direct, as the reflection's: the
    pass's image mean with and without the split, over 8 seeds each (Welch's t)."""
    scene = shadow_caustics(pool(resolution=(16, 16)))
    glossy = {True: [], False: []}
    for seed in range(8):
        for split in (False, True):
            result = Renderer(scene, scene.settings(**HONEST, fresnel_split=split,
                                                    seed=seed + (100 if split else 0),
                                                    spp=256, caustics=False,
                                                    light_passes=True)).render()
            glossy[split].append(float(result.light_pass_images()["Glossy Direct"].mean()))
    on, off = np.array(glossy[True]), np.array(glossy[False])
    assert on.mean() > 0.0
    assert scipy_stats.ttest_ind(on, off, equal_var=False).pvalue > 0.001, (on, off)
    assert on.std() < 0.5 * off.std()


@pytest.mark.parametrize("kind, splits", [("glass", True), ("mirror", False),
                                          ("refraction", False)])
def test_split_runs_where_glass_chooses(kind, splits):
    """Only a Glass BSDF chooses between reflection and refraction; a mirror or a
    refraction-only surface has nothing to split, and the stage says so."""
    scene = pool(resolution=(8, 8))
    scene.materials[1] = {**scene.materials[1], "kind": kind}     # not the shared dict
    renderer = Renderer(scene)
    assert renderer.fresnel_split == splits
    assert renderer.stages()["Fresnel split"][0] == splits
    assert not Renderer(scene, scene.settings(fresnel_split=False)).fresnel_split
