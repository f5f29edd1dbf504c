"""The stratified sampler: exact net structure per pixel, uniform and unbiased overall."""
import math

import numba
import numpy as np
from scipy import stats

from support.builders import camera, icosphere, make_scene
from support.stats import sidak
from snell.tracer import sampler as S
from snell.tracer.integrator import Renderer


def test_reverse_bits_and_sobol_test_vectors():
    for x in (1, 2, 0x80000000, 0x12345678):
        assert S.reverse_bits(np.uint64(x)) == int(format(x, "032b")[::-1], 2)
    # Sobol's first points: (0, 0), (1/2, 1/2), (1/4, 3/4), (3/4, 1/4).
    first = [S.to_unit(S.reverse_bits(np.uint64(i))) for i in range(4)]
    second = [S.to_unit(S.sobol_second(np.uint64(i))) for i in range(4)]
    assert first == [0, 0.5, 0.25, 0.75] and second == [0, 0.5, 0.75, 0.25]
    for i in (0, 1, 5, 65535, 65536, 2**31 + 3):
        assert S.sobol_second_reversed(np.uint64(i)) == S.reverse_bits(S.sobol_second(np.uint64(i)))


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
    alpha = sidak(0.01, 3)
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
    a = Renderer(scene, scene.settings(sampler="independent")).render()
    b = Renderer(scene, scene.settings(seed=5, sampler="stratified")).render()
    for c in range(3):
        se = math.sqrt(2 * a.variance_of_mean()[..., c].sum()) / (24 * 24)
        assert abs(a.mean()[..., c].mean() - b.mean()[..., c].mean()) < 3.4 * se


# -- exactness: the optimised sampler against a plain reference and recorded values ----------

M32 = 0xFFFF_FFFF


def _ref_hash32(*keys):
    h = 0
    for key in keys:
        h ^= int(key) & M32
        h ^= h >> 16
        h = h * 0x85EBCA6B & M32
        h ^= h >> 13
        h = h * 0xC2B2AE35 & M32
        h ^= h >> 16
        h = (h + 0x9E3779B9) & M32
    return h


def _ref_reverse(x):
    return int(format(x, "032b")[::-1], 2)


def _ref_owen(x, seed):
    x = (_ref_reverse(x) + seed) & M32
    for c in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6):
        x ^= x * c & M32
    return _ref_reverse(x)


def _ref_sobol(index):
    """Sobol's first two dimensions of index, 32-bit fixed point, from the direction numbers."""
    first, second, v = 0, 0, 1 << 31
    for j in range(index.bit_length()):
        if index >> j & 1:
            first ^= 1 << (31 - j)
            second ^= v
        v ^= v >> 1
    return first, second


def _ref_stratified(pixel, sample, seed, dimension, bits):
    """One point of stratified_2d, straight from its definition, in Python integers."""
    base = _ref_hash32(pixel, seed, dimension)
    shift = 32 - bits
    shuffled = _ref_owen((int(sample) << shift) & M32, _ref_hash32(base, 1)) >> shift
    first, second = _ref_sobol(shuffled)
    return [(_ref_owen(v, _ref_hash32(base, k)) >> 8) / (1 << 24)
            for v, k in ((first, 2), (second, 3))]


def _matches_reference(pixel, sample, seed, dimension, bits) -> bool:
    got = S.stratified_2d(pixel, sample, seed, dimension, bits)
    want = np.array([_ref_stratified(p, s, seed, dimension, bits) for p, s in zip(pixel, sample)]).T
    return got.shape == want.shape and got.dtype == np.float64 and np.array_equal(got, want)


def test_stratified_2d_matches_the_reference_bit_for_bit():
    rng = np.random.default_rng(11)
    for bits in range(0, 33):
        n = 60
        pixel = rng.integers(-2**40, 2**40, n)
        sample = rng.integers(0, 1 << bits, n) if bits else np.zeros(n, np.int64)
        sample[:3] = [0, (1 << bits) - 1, 1 << bits]   # both ends, and one past (wraps)
        for seed, dimension in ((0, 0), (int(rng.integers(2**31)), 5), (-3, 2**33 + 1)):
            assert S.stratified_2d(pixel, sample, seed, dimension, bits).shape == (2, n)
            assert _matches_reference(pixel, sample, seed, dimension, bits), (bits, seed, dimension)


def test_stratified_2d_matches_the_reference_for_other_integer_types():
    pixel = np.array([0, 7, 2**31 - 1, 40_000], np.int32)
    for dtype in (np.int32, np.uint32, np.uint64, np.int16):
        sample = np.array([0, 3, 63, 17], dtype)
        assert _matches_reference(pixel, sample, 9, 4, 6), dtype


# stratified_2d(PIXELS, SAMPLES, seed, dimension, bits) * 2^24, recorded before the sampler was
# optimised: an optimisation must not move a single sample.
PIXELS = [0, 1, 2, 3, 1023, 123456, 2073599, 2**31 + 7, 2**40 + 3]
SAMPLES = [0, 1, 2, 3, 5, 31, 63, 1, 62]
RECORDED = {
    (0, 0, 6): (
        [6225621, 10293856, 5202739, 16559362, 12032353, 9004316, 4807164, 7986828, 2681977],
        [16266939, 15061663, 10987949, 6057566, 15366494, 5287836, 11654856, 14860819, 225622]),
    (3, 1, 6): (
        [13126524, 10146208, 15765295, 8956661, 5628161, 8928212, 10399941, 3269419, 6861013],
        [4373982, 12637683, 7778782, 5551241, 3983905, 8094330, 14756080, 5548285, 922354]),
    (7, 2, 1): (
        [7353794, 11974460, 6716097, 1742300, 4683078, 13636077, 14397124, 5483553, 12171519],
        [852083, 8789524, 11994639, 15592237, 5892439, 2281235, 4648691, 6355949, 3019207]),
    (1, 4, 10): (
        [9401044, 9927692, 14606755, 4021172, 8110014, 7788386, 2962300, 8083568, 2750370],
        [5691395, 5992923, 16210673, 12803775, 2411682, 3037369, 11830867, 12418301, 15342197]),
    (5, 7, 16): (
        [10005637, 6311021, 3133570, 9051517, 4322083, 15721870, 13543941, 7403804, 12371733],
        [13820728, 13362636, 16645495, 12939657, 12949803, 6782212, 9767551, 2779980, 913359]),
    (2, 9, 20): (
        [12074889, 10991083, 9194318, 2074884, 13162595, 12574900, 1358563, 8879480, 515401],
        [10482206, 1934695, 10782822, 10174371, 6965817, 1612323, 9051602, 15484006, 5473922]),
    (11, 3, 32): (
        [16136864, 2459637, 10694590, 11270564, 3488851, 1555260, 1935634, 306597, 14863518],
        [2738563, 12229567, 14695492, 552040, 6351779, 5234134, 13409784, 4579766, 8842374]),
}


def test_stratified_2d_reproduces_the_recorded_values():
    for (seed, dimension, bits), want in RECORDED.items():
        got = S.stratified_2d(np.array(PIXELS), np.array(SAMPLES), seed, dimension, bits)
        assert np.array_equal(got * (1 << 24), want), (seed, dimension, bits)


def test_stratified_2d_broadcasts_and_handles_empty_input():
    one = S.stratified_2d(np.int64(5), np.arange(8), 1, 2, 3)
    many = S.stratified_2d(np.full(8, 5), np.arange(8), 1, 2, 3)
    assert np.array_equal(one, many)
    assert np.array_equal(S.stratified_2d(np.arange(8), np.int64(3), 1, 2, 3),
                          S.stratified_2d(np.arange(8), np.full(8, 3), 1, 2, 3))
    assert S.stratified_2d(np.zeros(0, np.int64), np.zeros(0, np.int64), 1, 2, 3).shape == (2, 0)


@numba.njit(cache=True)
def _random_pairs(pixels, samples, seed, dimension):
    out = np.empty((2, len(pixels)))
    for i in range(len(pixels)):
        out[0, i], out[1, i] = S.random_pair(S.pixel_key(pixels[i], seed), samples[i], dimension)
    return out


def test_random_pairs_are_uniform_and_independent():
    """The independent sampler: uniform in 2D, and no correlation between a pixel's consecutive
    samples, between dimensions, or with the stratified pair of the same key."""
    n, spp = 100_000, 4
    pixels = np.repeat(np.arange(n // spp), spp)
    samples = np.tile(np.arange(spp), n // spp)
    alpha = sidak(0.01, 4)
    u = _random_pairs(pixels, samples, 3, 7)
    assert u.min() >= 0.0 and u.max() < 1.0
    assert stats.chisquare(np.histogram2d(u[0], u[1], bins=16, range=[[0, 1], [0, 1]])[0].ravel()).pvalue > alpha
    consecutive = u[0].reshape(-1, spp)
    h = np.histogram2d(consecutive[:, 0], consecutive[:, 1], bins=16, range=[[0, 1], [0, 1]])[0]
    assert stats.chisquare(h.ravel()).pvalue > alpha
    other = _random_pairs(pixels, samples, 3, 8)
    h = np.histogram2d(u[0], other[0], bins=16, range=[[0, 1], [0, 1]])[0]
    assert stats.chisquare(h.ravel()).pvalue > alpha
    strat = S.stratified_2d(pixels, samples, 3, 7, 2)
    h = np.histogram2d(u[0], strat[0], bins=16, range=[[0, 1], [0, 1]])[0]
    assert stats.chisquare(h.ravel()).pvalue > alpha
