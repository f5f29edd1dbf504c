"""The stratified sampler: exact net structure per pixel, uniform and unbiased overall."""
import math

import numpy as np
from scipy import stats

from builders import camera, icosphere, make_scene
from snell.tracer import sampler as S
from snell.tracer.integrator import Renderer


def test_reverse_bits_and_sobol_test_vectors():
    x = np.array([1, 2, 0x80000000, 0x12345678], np.uint32)
    assert [int(v) for v in S.reverse_bits(x)] == [int(format(int(a), "032b")[::-1], 2) for a in x]
    first, second = S.sobol_pair(np.arange(4))
    # Sobol's first points: (0, 0), (1/2, 1/2), (1/4, 3/4), (3/4, 1/4).
    assert np.allclose(S.to_unit(first), [0, 0.5, 0.25, 0.75])
    assert np.allclose(S.to_unit(second), [0, 0.5, 0.75, 0.25])


def test_every_power_of_two_prefix_of_a_pixel_is_a_stratified_net():
    spp, bits = 64, 6
    pixels = np.repeat(np.arange(50), spp)
    samples = np.tile(np.arange(spp), 50)
    for dimension in (0, 1, 5):
        u = S.stratified_2d(pixels, samples, seed=3, dimension=dimension, bits=bits)
        for p in range(50):
            for n in (4, 16, 64):
                pts = u[:, (pixels == p) & (samples < n)]
                # (0, m, 2)-net: each elementary interval of area 1/n holds exactly one point.
                for k in range(int(math.log2(n)) + 1):
                    cols, rows = 2 ** k, n // 2 ** k
                    cell = np.floor(pts[0] * cols) * rows + np.floor(pts[1] * rows)
                    assert len(np.unique(cell)) == n


def test_points_are_uniform_across_pixels_and_pairs_are_independent():
    pixels = np.arange(400_000)
    alpha = 1 - (1 - 0.01) ** (1 / 3)
    for sample in (0, 5):
        u = S.stratified_2d(pixels, np.full(len(pixels), sample), seed=7, dimension=2, bits=4)
        h = np.histogram2d(u[0], u[1], bins=16, range=[[0, 1], [0, 1]])[0].ravel()
        assert stats.chisquare(h).pvalue > alpha
    a = S.stratified_2d(pixels, np.full(len(pixels), 3), seed=7, dimension=0, bits=4)
    b = S.stratified_2d(pixels, np.full(len(pixels), 3), seed=7, dimension=1, bits=4)
    h = np.histogram2d(a[0], b[0], bins=16, range=[[0, 1], [0, 1]])[0].ravel()
    assert stats.chisquare(h).pvalue > alpha


def test_stratified_renders_are_unbiased():
    """Same image mean as independent sampling, within the independent render's error."""
    pos, tri, nrm = icosphere(3)
    mats = [{"name": "Grey", "kind": "diffuse", "color": [0.6, 0.6, 0.6]}]
    dof = {"use_dof": True, "focus_distance": 3.0, "aperture_radius": 0.3}
    scene = make_scene([(pos, tri, 0, nrm)], mats, camera(resolution=(24, 24), dof=dof),
                       world=[1.0, 0.9, 0.8], spp=256, max_depth=4)
    a = Renderer(scene, sampler="independent").render()
    b = Renderer(scene.with_render(seed=5), sampler="stratified").render()
    for c in range(3):
        se = math.sqrt(2 * a.variance_of_mean()[..., c].sum()) / (24 * 24)
        assert abs(a.mean()[..., c].mean() - b.mean()[..., c].mean()) < 3.4 * se
