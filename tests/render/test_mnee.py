"""Manifold next-event estimation (tracer/mnee.py, issue 34's caustics seen through glass): where
it runs, the split of path space with the path tracer and the light tracer, and the pool
against Snell's own path-traced reference.

The reference (tests/references/sds_pool.npz: merging off, no shadow-caustics flags, 655360
spp) renders the same paths by other techniques; MNEE's own bias (one solution per lamp sample,
none where the seed segment misses the water) is what these tests bound. Seeds are fixed; the
bounds come from the renders' own per-pixel variances (an independent sampler) and the
reference's.
"""
import os

import numpy as np
import pytest

from sds_geometry import water_surface                      # scenes/ (conftest.py's path)
from support.builders import make_scene, quad
from support.caustic_scenes import look_at
from support.paths import TESTS
from support import sds_scenes
from support.sds_scenes import (POOL_MATERIALS, TUMBLER_IOR, ball, pool, pool_area, pool_sun,
                                shadow_caustics, tumbler)
from snell.tracer import manifold, mnee
from snell.tracer.integrator import Renderer
from snell.tracer.lights.codes import VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION
from snell.tracer.material_kinds import DIFFUSE, GLASS, LAYERED, MIRROR, PROGRAM

CASTER_TRI, RECEIVER_TRI, PLAIN_TRI = 0, 1, 2
POOL_SUN_ANGLE = 0.2           # tools/measure_photon_merging.py's pool_sun reference
# The pool seen from under its water (pool's camera replaced): the camera sees the receiver.
UNDER_WATER = look_at((0.0, -0.15, 0.3), (0.1, 0.1, 0.0), (12, 12), lens=18.0)
FLAGS = np.array([mnee.CASTER, mnee.RECEIVER, 0], np.int64)


def _state(steps):
    """A camera path's mnee state after scattering at (triangle, kind, ray kind[, whether the
    sample is one the stage renders: mnee.reflected, default yes]) steps."""
    state = mnee.NO_CHAIN
    for tri, kind, ray_kind, *taken in steps:
        state = mnee.mnee_after(FLAGS, state, tri, kind, ray_kind, taken[0] if taken else True)
    return state


def test_the_path_tracer_leaves_exactly_the_refractions_at_casters_after_a_receiver():
    """The path tracer leaves a caustics lamp's light to MNEE after a receiver's sample the
    stage renders (diffuse, layered or a shader program's: mnee.reflected) and one to
    MAX_CASTERS refractions at casters, and keeps it after anything else: a reflection (MNEE
    renders refraction only), a non-caster, a receiver's singular or transmitted sample, a
    mirror receiver, a diffuse non-receiver, more refractions than a chain holds; other lamps
    always. (With mnee_after's transmission test removed, a caster's reflection falls to MNEE;
    without its test of the receiver's sample, a singular one does: both caught.)"""
    down = (RECEIVER_TRI, DIFFUSE, VISIBLE_DIFFUSE)
    through = (CASTER_TRI, GLASS, VISIBLE_TRANSMISSION)
    lamps = np.array([False, True])            # lamps_to_cross's rows: MNEE samples lamp 1
    for chain in ([down, through], [down] + [through] * mnee.MAX_CASTERS,
                  [(PLAIN_TRI, MIRROR, VISIBLE_GLOSSY), down, through, through],
                  [(RECEIVER_TRI, LAYERED, VISIBLE_GLOSSY), through],
                  [(RECEIVER_TRI, PROGRAM, VISIBLE_DIFFUSE), through]):
        state = _state(chain)
        assert mnee.left_to_mnee(lamps, state, 1) and not mnee.left_to_mnee(lamps, state, 0)
    for chain in ([down], [through], [down, (CASTER_TRI, GLASS, VISIBLE_GLOSSY)],
                  [down, (PLAIN_TRI, GLASS, VISIBLE_TRANSMISSION)],
                  [(RECEIVER_TRI, LAYERED, VISIBLE_GLOSSY, False), through],
                  [(RECEIVER_TRI, PROGRAM, VISIBLE_TRANSMISSION, False), through],
                  [(RECEIVER_TRI, MIRROR, VISIBLE_GLOSSY), through],
                  [(PLAIN_TRI, DIFFUSE, VISIBLE_DIFFUSE), through],
                  [down, through, (PLAIN_TRI, DIFFUSE, VISIBLE_DIFFUSE)],
                  [down] + [through] * (mnee.MAX_CASTERS + 1)):
        assert not mnee.left_to_mnee(lamps, _state(chain), 1), chain
    assert not mnee.left_to_mnee(np.zeros(0, bool), _state([down, through]), 0)


def test_the_stage_renders_a_receivers_non_singular_samples_above_both_normals():
    """mnee.reflected: a direction sampled by a non-singular lobe, above the geometric and the
    shading normal (each facing the viewer); not one of a singular lobe (density 0), nor one
    below either normal."""
    ng, ns = (0.0, 0.0, 1.0), (0.6, 0.0, 0.8)
    assert mnee.reflected((0.0, 0.0, 1.0), ng, ns, 0.3)
    assert not mnee.reflected((0.0, 0.0, 1.0), ng, ns, 0.0)
    assert not mnee.reflected((0.6, 0.0, -0.8), ng, ns, 0.3)      # below the geometric normal
    assert not mnee.reflected((-0.9, 0.0, 0.436), ng, ns, 0.3)    # below the shading normal


def test_mnee_runs_only_where_the_flags_say():
    """The stage runs with a caustics light, a caster and a receiver, and not without the
    flags, with the setting off, without light sampling or with refractive caustics off; it says
    why."""
    flagged = shadow_caustics(pool(resolution=(4, 4)))
    runs, why = Renderer(flagged).stages()["shadow caustics"]
    assert runs and "caustics light" in why
    for scene, overrides, reason in ((pool(resolution=(4, 4)), {}, "no shadow-caustics"),
                                     (flagged, {"shadow_caustics": False}, "off"),
                                     (flagged, {"next_event": False}, "no light sampling"),
                                     # Cycles renders no shadow caustics then either.
                                     (flagged, {"caustics_refractive": False},
                                      "refractive caustics off")):
        runs, why = Renderer(scene, scene.settings(**overrides)).stages()["shadow caustics"]
        assert not runs and reason in why, why
    # A lamp of radius 0 is the light tracer's (a delta lamp: no chain ends on it).
    point = shadow_caustics(pool(resolution=(4, 4), lamp_radius=0.0))
    assert not Renderer(point).stages()["shadow caustics"][0]


def _render(scene, spp, seeds, seed_offset=0, **settings):
    """(mean image, its variance of the mean, each seed's image mean) over seeds (100 +
    seed_offset on)."""
    images, variances = [], []
    for seed in range(seed_offset, seed_offset + seeds):
        s = scene.settings(spp=spp, threads=2, seed=100 + seed, noise_threshold=0.0,
                           sampler="independent", **settings)
        result = Renderer(scene, s).render()
        images.append(result.mean()[..., 0].astype(np.float64))
        variances.append(result.variance_of_mean()[..., 0])
    return (np.mean(images, 0), np.mean(variances, 0) / seeds,
            np.array([im.mean() for im in images]))


def _pool_reference():
    ref = np.load(os.path.join(TESTS, "references", "sds_pool.npz"))
    return ref["mean"][..., 0].astype(np.float64), ref["var"][..., 0].astype(np.float64)


def _assert_consistent(image, var, means, reference, reference_var):
    """Per pixel z = (image - reference) / sqrt(both variances) (pixels both see as black left
    out): their RMS within 1.3 (1.0 for an unbiased estimate with honest variances) and at most
    4 beyond 4 (the Jacobian has no bound near the caustic's folds: a pixel's few largest
    samples decide its variance, which a sample estimate then under-states: at 512 spp x 4
    three pixels of the pool at z -4.7 to -5.5 were within z 2.7 at 2048 x 4); the image mean
    within 3 standard errors (the seeds' spread) plus 1% of the reference's."""
    lit = (var + reference_var) > 0.0
    z = (image - reference)[lit] / np.sqrt((var + reference_var)[lit])
    rms = float(np.sqrt(np.mean(z ** 2)))
    assert rms < 1.3 and int(np.sum(np.abs(z) > 4.0)) <= 4, (rms, np.sort(np.abs(z))[-6:])
    error = 3.0 * means.std(ddof=1) / np.sqrt(len(means)) + 0.01 * reference.mean()
    assert abs(means.mean() - reference.mean()) < error, (means.mean() / reference.mean())


def test_the_pool_agrees_with_the_path_traced_reference():
    """The pool (16x16) with the files' shadow caustics, 4 seeds x 512 spp, against the
    reference (_assert_consistent). Measured: z RMS 1.15, mean ratio 1.004 (at 2048 x 4: 0.95
    and 0.9996). Deliberate error caught: the shading normal's derivatives dropped from the
    Jacobian (flat normals: the caustic's focus moves)."""
    reference, reference_var = _pool_reference()
    scene = shadow_caustics(pool(resolution=(16, 16)))
    _assert_consistent(*_render(scene, 512, 4), reference, reference_var)



def test_a_round_lamps_light_is_the_path_tracers_disk_facing_the_last_vertex():
    """The pool (16x16) under a round lamp of radius 1 m (a disk that faces whoever sees it:
    lights/point.py), 4 seeds x 256 spp, against the path tracer alone (without the flags, 4
    seeds x 4096 spp, rendered here: the large lamp is easy to find through the water):
    _assert_consistent's bounds. The lamp point turns with the chain's last vertex
    (mnee.face_last_vertex). Measured: z RMS 1.07, mean ratio 0.998 +- 0.0015. Deliberate error
    caught: the disk held facing the receiver (the lamp point fixed, as before): z RMS 2.1, 7
    pixels beyond 4, mean ratio 1.050."""
    scene = pool(resolution=(16, 16), lamp_radius=1.0)
    reference, reference_var, _ = _render(scene, 4096, 4)
    _assert_consistent(*_render(shadow_caustics(scene), 256, 4), reference, reference_var)


def test_a_refraction_only_water_carries_no_fresnel_through_the_chain(monkeypatch):
    """The pool (16x16) with its water a Refraction BSDF of IOR 1.5 (Cycles' has no Fresnel;
    specular.sample_specular carries its colour alone), 4 seeds x 256 spp, against the path
    tracer alone (4 seeds x 8192 spp, rendered here): _assert_consistent's bounds. Measured:
    z RMS 1.12, mean ratio 0.997 +- 0.0012. Deliberate error caught: the chain's (1 - F) at
    the refraction-only vertex too (as before), mean ratio 0.957."""
    water = dict(POOL_MATERIALS[1], kind="refraction", ior=1.5)
    monkeypatch.setattr(sds_scenes, "POOL_MATERIALS", [POOL_MATERIALS[0], water])
    scene = pool(resolution=(16, 16))
    reference, reference_var, _ = _render(scene, 8192, 4)
    _assert_consistent(*_render(shadow_caustics(scene), 256, 4), reference, reference_var)


def test_the_stratified_sampler_stratifies_the_stages_lamp_samples():
    """A flat water surface over the floor, under a 1 m area lamp (16x16, max depth 3): the
    stage's light varies with the lamp point and hardly across a pixel, so where the sampler
    stratifies the lamp points over a pixel's samples, as it does direct light's, the image's
    noise falls well below the independent sampler's. 8 seeds x 64 spp each: the median over
    pixels of the ratio of the seeds' variances is at most 0.25 (measured 0.137; a median of
    256 ratios of two 8-seed variances is within a factor 1.15 of the true one at 2 standard
    errors), and the two samplers agree on the mean (3 standard errors). Deliberate error
    caught: the stage's pairs independent under either sampler (the old code): ratio 0.468."""
    floor, water = quad((0.0, 0.0, 0.0), 1.0, 1.0), quad((0.0, 0.0, 0.5), 1.0, 1.0)
    cam = look_at((0.0, -0.25, 1.9), (0.0, 0.0, 0.0), (16, 16), lens=50.0)
    scene = shadow_caustics(make_scene([(*floor, 0), (*water, 1)], POOL_MATERIALS, cam,
                                       lights=[pool_area(1.0)], max_depth=3))
    images = {}
    for sampler in "stratified", "independent":
        images[sampler] = np.array([Renderer(scene, scene.settings(
            spp=64, threads=2, seed=100 + seed, noise_threshold=0.0, sampler=sampler)).render()
            .mean()[..., 0] for seed in range(8)], np.float64)
    stratified, independent = images["stratified"], images["independent"]
    ratio = stratified.var(0, ddof=1) / independent.var(0, ddof=1)
    assert np.median(ratio) < 0.25, np.median(ratio)
    means = [im.mean((1, 2)) for im in (stratified, independent)]
    error = 3.0 * np.sqrt(sum(m.var(ddof=1) / len(m) for m in means))
    assert abs(means[0].mean() - means[1].mean()) < error, [m.mean() for m in means]

@pytest.mark.parametrize("under", [False, True], ids=["through the water", "under the water"])
def test_a_principled_receiver_of_a_lambert_lobe_alone_renders_as_the_diffuse_one(under):
    """The pool's floor a Principled BSDF without specular (Specular IOR Level 0: its Lambert
    lobe alone, a LAYERED material whose lobes the stage builds and evaluates) against the
    plain diffuse floor, both with the shadow-caustics flags, 2 seeds x 256 spp each, seen
    through the water (16x16) and from under it (12x12, max depth 2: the camera sees the
    receiver, where the light tracer's paths onto it are the stage's too): consistent
    (_assert_consistent, the diffuse render as the reference). Measured: the two renders are
    equal (z RMS 0: the one Lambert lobe is sampled and evaluated as the plain surface).
    Deliberate errors caught: the layered receiver's light 5% brighter (z RMS 2.8 through the
    water); the path tracer keeping the caustics lamp after a layered receiver (its light
    counted twice: z RMS 1.7); the light tracer connecting its paths onto a layered receiver
    (its light counted twice: z RMS 321 under the water)."""
    scenes = []
    for material in POOL_MATERIALS[0], {"name": "Floor", "kind": "principled",
                                         "color": [0.8, 0.8, 0.8], "specular_ior_level": 0.0}:
        scene = shadow_caustics(pool(resolution=(12, 12) if under else (16, 16)))
        scene.materials = [material] + list(scene.materials[1:])
        if under:
            scene.camera = UNDER_WATER
        assert Renderer(scene).stages()["shadow caustics"][0]
        scenes.append(scene)
    assert Renderer(scenes[1]).materials.kind[0] == LAYERED
    depth = {"max_depth": 2} if under else {}
    reference, reference_var, _ = _render(scenes[0], 256, 2, **depth)
    _assert_consistent(*_render(scenes[1], 256, 2, **depth), reference, reference_var)


@pytest.mark.parametrize("lamp", [None, pool_sun(0.0), pool_sun(POOL_SUN_ANGLE), pool_area()],
                         ids=["point", "sun of angle 0", "sun", "area"])
def test_photon_merging_leaves_mnee_its_paths(lamp):
    """With photon merging on too, the light tracer stores no photon for MNEE's paths
    (light_bounce) and the path tracer skips both strategies' paths: in the pool every
    specular, diffuse, specular path is MNEE's, so merging adds nothing and the image is the
    one without it; under the round lamp, a sun (the light tracer's delta lamp at angle 0) and
    an area lamp. Deliberate error caught: photons stored for MNEE's paths (their light
    counted twice); the light tracer marking only point lamps' paths (the three others'
    merged images differ)."""
    scene = shadow_caustics(pool(resolution=(8, 8), lamp=lamp))
    alone, _, _ = _render(scene, 64, 1)
    merged, _, _ = _render(scene, 64, 1, photon_merging="on")
    assert np.allclose(merged, alone, rtol=1e-9, atol=0.0), np.abs(merged / alone - 1).max()


def _reference(name):
    """(mean, variance of the mean) of a stored path-traced reference (tests/references/
    sds_NAME.npz: tools/measure_photon_merging.py reference --scene NAME)."""
    ref = np.load(os.path.join(TESTS, "references", f"sds_{name}.npz"))
    return ref["mean"][..., 0].astype(np.float64), ref["var"][..., 0].astype(np.float64)


@pytest.mark.parametrize("name, lamp", [("pool_sun", pool_sun(POOL_SUN_ANGLE)),
                                        ("pool_area", pool_area())], ids=["sun", "area"])
def test_suns_and_area_lamps_agree_with_the_path_traced_reference(name, lamp):
    """The pool (16x16) under a sun of angle 0.2 rad, and under a 0.5 m square area lamp, as
    caustics lights, 4 seeds x 256 spp, against Snell's own reference without the flags (the
    path tracer finding the lamp through the water, and the light tracer; 131072 spp):
    _assert_consistent's bounds. Measured: the sun z RMS 1.17, mean ratio 0.996 +- 0.006; the
    area lamp 1.25, 1.005 +- 0.005. Deliberate error caught: the lamp 5% brighter in the
    rendered scene, as a 5% error in the stage's lamp radiance (z RMS 1.74 and 1.81, mean
    ratios 1.046 and 1.055)."""
    reference, reference_var = _reference(name)
    scene = shadow_caustics(pool(resolution=(16, 16), lamp=lamp))
    assert Renderer(scene).stages()["shadow caustics"][0]
    _assert_consistent(*_render(scene, 256, 4), reference, reference_var)


def test_a_sun_of_angle_0_is_the_limit_of_narrow_suns():
    """A sun of angle 0 (its irradiance over density 1) against one of 0.02 rad (its radiance
    over the cone's density), the same irradiance, the pool at 8x8, 4 seeds x 128 spp: the
    image means agree within 3 standard errors of their difference plus 1% (the narrow sun's
    disc moves the caustic's folds a little). Measured: 0.4837 and 0.4830 (seeds' spread
    0.0014). Deliberate error caught: the delta sun 5% brighter (0.5079 against 0.4830). Both
    suns are hidden from glossy rays: the narrow sun's disc mirrored in the water is a glint
    the delta sun has no counterpart of (0.635 with it, which the Fresnel split finds in every
    pixel it lights; without the split few samples met it)."""
    means = []
    for angle in (0.0, 0.02):
        sun = {**pool_sun(angle), "visible_glossy": False}
        scene = shadow_caustics(pool(resolution=(8, 8), lamp=sun))
        _, _, per_seed = _render(scene, 128, 4)
        means.append(per_seed)
    delta, narrow = means
    error = 3.0 * np.sqrt(delta.var(ddof=1) / 4 + narrow.var(ddof=1) / 4) + 0.01 * narrow.mean()
    assert narrow.mean() > 0.0
    assert abs(delta.mean() - narrow.mean()) < error, (delta.mean(), narrow.mean())


def test_a_delta_suns_caustic_seen_directly_is_the_light_tracers():
    """A flagged sun of angle 0's light at the camera ray's own hit on a receiver is the light
    tracer's connection, not a chain (mnee.seed_chains, light_tracer.receiving_vertex): the
    pool seen from under the water, 12x12, at max depth 2, where every caustic path is sun,
    water, floor, camera, renders bit for bit as without the flags (where the light tracer
    renders it all), and a quarter of its pixels or more see caustic light; `snell info`'s line
    for the stage says so. Deliberate errors caught: the code before, chains at depth 0 and no
    connection (the images differ: MNEE's estimate); chains at depth 0 as well as the
    connection (the light twice: they differ by up to 1.09)."""
    images = []
    for flagged in (True, False):
        scene = shadow_caustics(pool(resolution=(12, 12), lamp=pool_sun(0.0)), on=flagged)
        scene.camera = UNDER_WATER
        runs, why = Renderer(scene).stages()["shadow caustics"]
        assert runs == flagged, why
        if flagged:       # `snell info`'s line for the stage names the split
            assert "'Sun' (a sun of angle 0: the light tracer's where the camera sees" in why, why
        images.append(_render(scene, 16, 1, max_depth=2)[0])
    flagged, plain = images
    assert np.count_nonzero(plain) > plain.size // 4
    assert np.array_equal(flagged, plain), np.abs(flagged - plain).max()


def test_a_lamps_caustic_through_two_casters_seen_directly_is_the_light_tracers():
    """A flagged round lamp's light through two or more caster refractions onto a plain diffuse
    receiver the camera ray itself hits is the light tracer's connection, not a chain
    (mnee.seed_chains' one refraction at most there, light_tracer.receiving_vertex): a glass
    ball above the floor at max depth 3 (16x16, 64 spp, the light paths per camera path fixed:
    the pilot counts the stage's rays; every caustic path is lamp, ball, ball, floor, camera,
    and no receiver past depth 0 has room for a chain) renders bit for bit as without the
    flags, where the light tracer renders it all, and a fifth of its pixels are lit through
    the ball; `snell info`'s line for the stage says so. Deliberate errors caught: the code
    before (chains at depth 0 and no connection: the images differ by up to 11, the mean 5%
    low); the light tracer not connecting them (the caustic missing); chains of two
    refractions at depth 0 as well as the connections (the light twice)."""
    images = []
    for flagged in (True, False):
        scene = shadow_caustics(ball(), on=flagged)
        runs, why = Renderer(scene).stages()["shadow caustics"]
        assert runs == flagged, why
        if flagged:
            assert "'Lamp' (the light tracer's through two or more casters" in why, why
        images.append(_render(scene, 64, 1, max_depth=3, light_paths_per_camera_path=1.0)[0])
    flagged, plain = images
    assert np.count_nonzero(plain > 0.01) > plain.size // 5
    assert np.array_equal(flagged, plain), np.abs(flagged - plain).max()


def test_a_lamps_caustic_through_one_caster_seen_directly_stays_the_stages():
    """Through one caster (the pool seen from under the water, 12x12, max depth 2: lamp, water,
    floor, camera) the stage keeps the light at the camera ray's own hit, whose chains are far
    smoother there than light paths spread over the floor: 4 seeds x 32 spp with the flags and
    without them (the light tracer's), the seeds' relative variance of the image with them is
    under a tenth of the one without (measured 0.017 against 0.39; at 32x32, 6 x 64 spp, 0.00065
    against 0.157), and the means agree (3 standard errors and 1% of the mean, for the stage's
    bias). Deliberate error caught: the light tracer's at any number of casters (the two
    images' variances alike)."""
    images = []
    for flagged in (True, False):
        scene = shadow_caustics(pool(resolution=(12, 12)), on=flagged)
        scene.camera = UNDER_WATER
        images.append(np.array([_render(scene, 32, 1, max_depth=2, seed_offset=k)[0]
                                for k in range(4)]))
    flagged, plain = images
    lit = plain.mean(0) > 0.01
    relative = [(im.var(0, ddof=1)[lit] / im.mean(0)[lit] ** 2).mean() for im in images]
    assert relative[0] < 0.1 * relative[1], relative
    means = [im.mean((1, 2)) for im in images]
    error = 3.0 * np.sqrt(sum(m.var(ddof=1) / len(m) for m in means)) + 0.01 * means[1].mean()
    assert abs(means[0].mean() - means[1].mean()) < error, [m.mean() for m in means]


def test_without_light_paths_the_stage_keeps_a_delta_suns_light_seen_directly():
    """With Snell's caustics off (no light paths), a flagged sun of angle 0's light at the
    camera ray's own hit on a receiver is the stage's (mnee_tables' light_traced): the pool
    from under the water, as above, 2 seeds x 256 spp, renders it, its mean within 10% of the
    light tracer's image, and `snell info` no longer calls it the light tracer's. Measured:
    0.963 of it; 0.971 +- 0.017 of 8 light-tracer seeds (their spread 4.8% a seed; MNEE's own
    bias, one solution per sample, is the rest). Deliberate error caught: the code before,
    which left it to a light tracer that did not run (the image black)."""
    scene = shadow_caustics(pool(resolution=(12, 12), lamp=pool_sun(0.0)))
    scene.camera = UNDER_WATER
    runs, why = Renderer(scene, scene.settings(caustics=False)).stages()["shadow caustics"]
    assert runs and "light tracer" not in why, why
    _, _, alone = _render(scene, 256, 2, max_depth=2, caustics=False)
    _, _, traced = _render(scene, 256, 2, max_depth=2)
    assert abs(alone.mean() / traced.mean() - 1.0) < 0.1, alone.mean() / traced.mean()


LAMP_CENTRE = np.array([1.4, 0.3, 0.55])        # support.sds_scenes.tumbler's lamp


def _tumbler_chains(renderer):
    """Chains (mnee.Chains, count) from a grid of table points beyond the tube from the lamp,
    outside the tube, to the lamp's centre and four points of its rim, probing from their
    straight seeds."""
    xs, ys = np.meshgrid(np.linspace(-1.2, -0.45, 24), np.linspace(-1.3, 1.1, 48))
    x0 = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], -1)
    x0 = x0[np.hypot(x0[:, 0], x0[:, 1]) > 0.45]
    offsets = [(0.0, 0.0), (0.09, 0.0), (-0.09, 0.0), (0.0, 0.09), (0.0, -0.09)]
    x0 = np.repeat(x0, len(offsets), 0)
    n = len(x0)
    chains = mnee.new_chains(n)
    for c in range(n):
        facing = (x0[c] - LAMP_CENTRE) / np.linalg.norm(x0[c] - LAMP_CENTRE)
        a = np.cross(facing, (0.0, 0.0, 1.0))
        a /= np.linalg.norm(a)
        b = np.cross(facing, a)
        du, dv = offsets[c % len(offsets)]
        chains.x0[c], chains.y[c] = x0[c], LAMP_CENTRE + du * a + dv * b
        chains.y_ab[c] = a, b
    chains.ng0[:n] = chains.ns0[:n] = (0.0, 0.0, 1.0)
    chains.eps0[:n] = 1e-5
    chains.room_diffuse[:n] = manifold.MAX_CASTERS
    chains.state[:n], chains.k[:n], chains.bent[:n] = mnee.PROBING, 0, 0
    chains.ray_o[:n] = chains.x0[:n] + 1e-5 * chains.ng0[:n]
    rest = chains.y[:n] - chains.ray_o[:n]
    chains.ray_t[:n] = np.linalg.norm(rest, axis=1)
    chains.ray_d[:n] = rest / chains.ray_t[:n, None]
    return chains, n


def _refracts_at_every_vertex(chains, c):
    """Whether chain c's vertices obey Snell's law (the constraint below the stage's tolerance)
    with the light passing each surface."""
    ends = [chains.x0[c]] + [chains.pos[c, i] for i in range(chains.k[c])] + [chains.y[c]]
    for i in range(chains.k[c]):
        prev, p, nxt = (tuple(map(float, e)) for e in ends[i:i + 3])
        n = tuple(map(float, chains.n[c, i]))
        s, t = manifold.constraint(prev, p, nxt, n, tuple(map(float, chains.ta[c, i])),
                                   tuple(map(float, chains.ng[c, i])), TUMBLER_IOR, False)
        if not (np.hypot(s, t) < mnee.TOLERANCE
                and np.dot(n, ends[i] - ends[i + 1]) * np.dot(n, ends[i + 2] - ends[i + 1]) < 0):
            return False
    return True


def test_walks_whose_straight_seed_crosses_only_the_tubes_outer_wall_find_the_path_through_it():
    """A straight seed from a table point outside the tumbler's tube that crosses only the
    tube's outer wall (twice: a chord through the wall's edge) has no solution: a ray entering
    a tube of radii R > r and index n meets the inner wall (in the horizontal plane its distance
    from the axis shrinks by more than n, and R / n < r). The light there passes the whole tube,
    four refractions, and the walk from the seed refracted at each caster (mnee.reseed) finds
    it. Measured on this grid: 524 chord seeds; from the straight seed 13 walks converge, each
    with its second vertex moved onto the inner wall (its last segment crosses the tube: the
    shadow ray blocks it), from the refracted seed 91, each a four-vertex chain obeying Snell's
    law (and 125 of the 136 four-vertex straight seeds whose walk failed). Deliberate error
    caught: no second seed (mnee.reseed seeding none, as in Cycles: 0 found)."""
    renderer = Renderer(shadow_caustics(tumbler(resolution=(4, 4))))
    geometry, tables, mats = renderer.geometry, renderer.mnee, renderer.materials
    chains, n = _tumbler_chains(renderer)
    mnee.probe(geometry, tables, mats, chains, n)
    chords = np.flatnonzero(chains.k[:n] == 2)
    chains, n = _tumbler_chains(renderer)
    mnee.solve(geometry, tables, mats, chains, n)
    found = chords[chains.state[chords] == mnee.CONVERGED]
    refracted = found[chains.bent[found] == 1]
    assert len(chords) > 200, len(chords)
    assert len(refracted) > 0.12 * len(chords), (len(chords), len(found), len(refracted))
    assert all(chains.k[c] == 4 and _refracts_at_every_vertex(chains, c) for c in refracted)


def _foreground_means(scene, seeds, spp, **settings):
    """Each seed's mean over the table in front of the tumbler (image rows 10-15: the tube's
    shadow, lit through the tube)."""
    return np.array([Renderer(scene, scene.settings(
        spp=spp, threads=2, seed=100 + seed, noise_threshold=0.0, sampler="independent",
        **settings)).render().mean()[10:, :, 0].astype(np.float64).mean()
        for seed in range(seeds)])


def test_the_refracted_seeds_add_light_in_the_tumblers_shadow(monkeypatch):
    """The tumbler (16x16) with the second seed and without it (mnee.reseed seeding none, as
    Cycles), the same seeds (2 x 256 spp), Snell's caustics off (the stage then renders the
    foreground, which the camera sees directly: with them on, the light tracer's connections
    render its light through the tube): the second seed only adds light where the first walk
    failed, so each seed's foreground gains, measured 1.93% and 2.04% of the reference's mean
    there (sds_tumbler.npz; paired, the seeds' spread of that gain is under 0.1%: bounds 1-4%;
    over 4096 spp the foreground is 0.93 of the reference with it, 0.91 without). Deliberate
    error caught: no second seed (no gain)."""
    reference = np.load(os.path.join(TESTS, "references", "sds_tumbler.npz"))["mean"]
    expected = float(reference[10:, :, 0].astype(np.float64).mean())
    scene = shadow_caustics(tumbler(resolution=(16, 16)))
    reseeded = _foreground_means(scene, 2, 256, caustics=False)
    monkeypatch.setattr(mnee, "reseed", lambda chains, n: 0)
    gain = (reseeded - _foreground_means(scene, 2, 256, caustics=False)) / expected
    assert np.all((gain > 0.01) & (gain < 0.04)), gain


def test_a_one_vertex_walk_that_failed_walks_again_gently(monkeypatch):
    """The pool's water of index 2.0 (16x16, max depth 8, Snell's caustics off), with the second
    seed and without it (mnee.reseed seeding none), the same seeds (2 x 256 spp): there the walks
    from a full first step fail in 6% of the pool's one-vertex chains (0.05% at index 1.33),
    and walked again from the same vertex with a gentle one (BENT_FIRST_STEP) a third of the
    light they missed is found: each seed's image gains 2.5-2.8% (measured over 4 seeds; bounds
    1.5-4%). Deliberate error caught: one-vertex chains not seeded again (the code before: no
    gain)."""
    scene = shadow_caustics(pool(resolution=(16, 16)))
    scene.materials = [scene.materials[0], {**scene.materials[1], "ior": 2.0}]
    reseeded = _render(scene, 256, 2, caustics=False)[2]
    monkeypatch.setattr(mnee, "reseed", lambda chains, n: 0)
    gain = reseeded / _render(scene, 256, 2, caustics=False)[2] - 1.0
    assert np.all((gain > 0.015) & (gain < 0.04)), gain


def test_chains_the_probe_rejected_at_one_vertex_are_not_seeded_again():
    """Chains whose seed crosses more casters than they may hold (here one, as at the camera's
    own hits, where the light tracer renders the rest) are rejected by the probe and not seeded
    again: a refracted seed through the tube crosses as many. The tumbler's grid of chains
    (_tumbler_chains) probed with room for one refraction: hundreds rejected at one vertex, and
    reseed seeds none of them (the others are walks not yet run, or seeds that met no caster).
    Deliberate error caught: the probe marking its rejections FAILED, as a walk that fails (none
    then REJECTED, and every one seeded again)."""
    renderer = Renderer(shadow_caustics(tumbler(resolution=(4, 4))))
    chains, n = _tumbler_chains(renderer)
    chains.room_diffuse[:n] = 1
    mnee.probe(renderer.geometry, renderer.mnee, renderer.materials, chains, n)
    rejected = (chains.state[:n] == mnee.REJECTED) & (chains.k[:n] == 1)
    assert rejected.sum() > 200, rejected.sum()
    assert mnee.reseed(chains, n) == 0


def open_pool(resolution=(20, 20)):
    """A wavy glass sheet over part of a diffuse floor, a round lamp above: the camera sees the
    floor directly, beside and through the sheet (its caustic, L S D E, is the light tracer's
    without MNEE and MNEE's with it)."""
    floor = quad((0.0, 0.0, 0.0), 2.0, 2.0)
    sheet = water_surface(n=16, half=0.6, height=0.5)
    mats = [{"name": "Floor", "kind": "diffuse", "color": [0.8, 0.8, 0.8]},
            {"name": "Water", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": 1.33}]
    lamp = {"name": "Lamp", "kind": "point", "position": [0.2, 0.1, 2.0],
            "intensity": [10.0, 10.0, 10.0], "radius": 0.2}
    cam = look_at((0.0, -2.2, 1.6), (0.0, 0.0, 0.0), resolution, lens=35.0)
    up = np.tile(np.array([[0.0, 0.0, 1.0]], np.float32), (len(floor[0]), 1))
    return make_scene([(*floor, 0, up), (*sheet[:2], 1, sheet[2])], mats, cam, lights=[lamp],
                      max_depth=6)


@pytest.mark.slow
def test_the_light_tracer_leaves_mnee_its_paths():
    """The open pool with the flags (MNEE, light tracer and path tracer, 4 seeds x 256 spp)
    against the same scene's path tracer alone (no flags, caustics off, 4 x 4096 spp): the
    bounds of test_the_pool_agrees_with_the_path_traced_reference. Deliberate error caught: the
    light tracer's connections kept for MNEE's paths (the directly seen caustic counted twice:
    mean ratio 1.2)."""
    reference, reference_var, _ = _render(open_pool(), 4096, 4, caustics=False)
    _assert_consistent(*_render(shadow_caustics(open_pool()), 256, 4), reference,
                       reference_var)
