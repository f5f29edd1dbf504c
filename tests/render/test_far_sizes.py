"""The pass planner and the compiled stages at the largest renders a user can ask for (8192 x 8192
pixels, 2^24 samples per pixel, pixel x sample indices beyond 2^31 and 2^32), without rendering
them: plan the passes, then run one chunk at the far end (issue 31, item 1).

Compiled code has no bounds checks: a pass whose pixel holds more samples than a chunk's buffers
wrote past them (the segfault of `snell compare --spp 262144`, a batch of 16384 samples).
"""
import numpy as np
import pytest

from support.builders import camera, tiny_scene
from snell.tracer import light_tracer, passes, sampler, wavefront
from snell.tracer.camera import Camera
from snell.tracer.pixel_filter import make_filter
from snell.tracer.integrator import CHUNK, Renderer
from snell.tracer.passes import (LIGHT_SEGMENT, PASS_PATHS, Pass, jobs, light_segments,
                                 samples_per_pass, sub_passes)

BATCHES = 16                   # snell compare's batches (validation/compare.py)
SIDE = 8192
NPIX = SIDE * SIDE             # 2^26 pixels
SPP = 1 << 24                  # 2^24 samples per pixel: pixel x sample beyond 2^50


def test_fixed_windows_of_the_largest_render_are_made_on_demand():
    """2^24 windows of one sample each, not a list of them (gigabytes)."""
    windows = passes.fixed_windows(NPIX, SPP)
    assert len(windows) == SPP
    assert windows[-1] == passes.Window(SPP - 1, SPP - 1, SPP)
    assert windows[0].first == 0 and windows[-1].end == SPP
    assert list(windows[2:4]) == [windows[2], windows[3]]
    with pytest.raises(IndexError):
        windows[SPP]
    # Smaller images: windows of WINDOW_PASSES passes (fewer, larger replies on a cluster); from
    # 2^19 pixels one pass of one sample, as here.
    assert passes.samples_per_window(64 * 64) == 4 * passes.samples_per_pass(64 * 64) == 128
    assert list(passes.fixed_windows(64 * 64, 300)) == [
        passes.Window(0, 0, 128), passes.Window(1, 128, 256), passes.Window(2, 256, 300)]
    assert passes.samples_per_window(512 * 512) == 2 and passes.samples_per_window(1 << 19) == 1


@pytest.mark.parametrize("rows, samples", [(NPIX, SPP // BATCHES), (128 * 128, 262144 // BATCHES),
                                           (1, SPP), (3, 3 * CHUNK + 5)])
def test_a_batch_pass_larger_than_a_chunk_is_cut_into_sub_passes(rows, samples):
    """A batch of more samples per pixel than a chunk holds is traced as sub-passes whose jobs
    hold whole pixels and at most CHUNK paths, with a bounded number of jobs per sub-pass."""
    step = Pass(samples * 7, samples)              # the eighth batch
    subs = sub_passes(step, rows)
    assert subs[0].first == step.first and sum(s.samples for s in subs) == samples
    assert all(a.first + a.samples == b.first for a, b in zip(subs, subs[1:]))
    assert all(0 < s.samples <= samples_per_pass(rows) <= CHUNK for s in subs)
    for sub in (subs[0], subs[-1]):
        split = jobs(0, rows * sub.samples, sub.samples)
        assert len(split) <= max(rows, PASS_PATHS) // CHUNK + passes.JOB_MULTIPLE
        assert all(n % sub.samples == 0 and 0 < n <= CHUNK for _, n in split)


def test_jobs_refuse_a_pixel_larger_than_a_chunk():
    with pytest.raises(ValueError, match="exceed a chunk"):
        jobs(0, 2 * (CHUNK + 1), CHUNK + 1)


def test_a_progressive_pass_is_its_own_sub_pass():
    for rows in (1, 7, 4096, NPIX):
        step = Pass(5, samples_per_pass(rows))
        assert sub_passes(step, rows) == [step]


def test_trace_chunk_refuses_more_paths_than_its_buffers():
    """The last guard before the compiled stages: an exception, not memory corruption."""
    scene = tiny_scene()
    renderer = Renderer(scene, scene.settings(threads=1))
    film = (np.zeros((64, 3)), np.zeros((64, 3)), passes.NO_ROWS)
    with pytest.raises(ValueError, match="do not fit"):
        renderer.trace_chunk(0, 2 * CHUNK, 2 * CHUNK, 0, passes.ALL_PIXELS, 16, *film)
    with pytest.raises(ValueError, match="do not fit"):
        renderer.trace_light_chunk(0, 0, CHUNK + 1)


def test_a_batch_of_more_samples_than_a_chunk_renders():
    """The segfault's case at a tiny size: one pixel, a batch of 2 CHUNK + 5 samples (in
    compare, 262144 spp in 16 batches is 16384 samples a batch). Its sums are the samples'."""
    scene = tiny_scene(spp=2 * CHUNK + 5, noise_threshold=0.0).with_camera(resolution=[1, 1])
    result = Renderer(scene, scene.settings(threads=2, sampler="independent",
                                             batches=1)).render()
    assert result.spp == 2 * CHUNK + 5 and result.batches == 1
    fixed = Renderer(scene, scene.settings(threads=2, sampler="independent")).render()
    assert fixed.spp == result.spp
    np.testing.assert_allclose(result.sum, fixed.sum, rtol=1e-9)
    np.testing.assert_allclose(result.sum_sq, fixed.sum_sq, rtol=1e-9)


@pytest.mark.parametrize("stratified", [True, False])
def test_generate_at_the_far_end_of_the_largest_render(stratified):
    """One chunk of the last sub-pass of the last batch of an 8192 x 8192 render of 2^24 spp:
    every path's pixel, sample index and key are those of its place (64-bit arithmetic), and its
    ray is finite."""
    bits = (SPP - 1).bit_length()
    cam = Camera(camera(resolution=(SIDE, SIDE))).params()
    last = sub_passes(Pass(SPP - SPP // BATCHES, SPP // BATCHES), NPIX)[-1]
    assert last.first + last.samples == SPP
    start, n = jobs(0, NPIX * last.samples, last.samples)[-1]
    assert start + n == NPIX * last.samples and n <= CHUNK
    paths, stats = wavefront.new_paths(CHUNK), np.zeros(len(wavefront.STATS), np.int64)
    seed = 2 ** 31 - 1
    wavefront.generate(cam, make_filter(), seed, start, last.samples, last.first, passes.ALL_PIXELS, bits,
                       stratified, n, paths, stats, False)
    g = start + np.arange(n, dtype=np.int64)
    pixel = g // last.samples
    sample = last.first + g % last.samples
    assert pixel[-1] == NPIX - 1 and sample[-1] == SPP - 1
    assert np.array_equal(paths.sample[:n], sample)
    keys = np.empty(n, np.uint64)
    sampler._pixel_keys(pixel, np.uint64(seed), keys)
    assert np.array_equal(paths.key[:n], keys)
    assert np.isfinite(paths.o[:n]).all() and np.isfinite(paths.d[:n]).all()
    # The adaptive pixels' list at the far end: int64 indices, the same keys.
    far = np.arange(NPIX - 4, NPIX, dtype=np.int64)
    wavefront.generate(cam, make_filter(), seed, 0, 1, SPP - 1, far, bits, stratified, 4, paths, stats,
                       False)
    assert np.array_equal(paths.key[:4], keys[-4:]) and (paths.sample[:4] == SPP - 1).all()


def test_sample_indices_up_to_the_largest_spp_stay_in_range():
    """The stratified sampler at the last index of 2^24 and of 2^31 - 1 samples (bits 24, 31):
    points in [0, 1), and distinct samples give distinct points."""
    for spp in (SPP, 2 ** 31 - 1):
        bits = (spp - 1).bit_length()
        samples = np.array([spp - 1, spp - 2, 1 << 16, (1 << 16) + 1], np.int64)
        points = sampler.stratified_2d(np.full(4, NPIX - 1), samples, 7, 0, bits)
        assert ((points >= 0) & (points < 1)).all()
        assert len({tuple(p) for p in points.T}) == len(samples)


def test_light_paths_beyond_2_to_32_in_a_pass_keep_their_own_keys():
    """A batch of a big render has more than 2^32 light paths in a pass: path i and path
    i + 2^32 must not share their random numbers; below 2^32 the keys are unchanged."""
    base = np.uint64(12345)
    for i in (0, 1, 2 ** 31 + 5, 2 ** 32 - 1):
        assert light_tracer.light_path_key(base, i) == sampler.mix(base, np.uint64(i))
        assert (light_tracer.light_path_key(base, i + 2 ** 32)
                != light_tracer.light_path_key(base, i))


def test_a_light_pass_beyond_the_segment_runs_in_segments():
    n_light = NPIX * (SPP // BATCHES) // 8         # 2^43 light paths in one batch
    n_a = n_light // 2
    previous, count, ends = 0, 0, set()
    for a, b in light_segments(n_light, n_a):     # made one by one: 2^20 segments
        assert a == previous and 0 < b - a <= LIGHT_SEGMENT
        previous, count = b, count + 1
        ends.add(b)
    assert previous == n_light and n_a in ends     # no segment straddles half A
    assert count == n_light // LIGHT_SEGMENT
    assert list(light_segments(1000, 500)) == [(0, 500), (500, 1000)]
    assert list(light_segments(1000, 1000)) == [(0, 1000)]


def test_sub_passes_add_the_same_sums_as_one_pass(monkeypatch):
    """A batch cut into sub-passes adds each pixel's samples in the same order as one pass of
    whole pixels: the same bits (a batch of more than samples_per_pass samples was one pass
    before the cut)."""
    scene = tiny_scene(spp=2 * 2048 + 3, noise_threshold=0.0)        # 8x8: 2048 a pass
    settings = scene.settings(threads=2, sampler="independent", batches=1)
    cut = Renderer(scene, settings).render()
    monkeypatch.setattr(passes, "samples_per_pass", lambda rows: CHUNK)
    whole = Renderer(scene, settings).render()
    assert np.array_equal(cut.sum, whole.sum) and np.array_equal(cut.sum_sq, whole.sum_sq)
    assert cut.stats == whole.stats
