"""Every random number of a path, keyed by (seed, pixel, sample index, dimension).

Two kinds of uniform 2D points, both a pure function of their key (no random state), so an image
depends on the seed and the sample count only, never on chunking or threads:

- stratified_pair: Owen-scrambled Sobol (0, 2)-sequences. Sample i of a pixel in one dimension
  (a 2D pair: pixel position, lens position, then the light and BSDF pairs of the first bounces)
  is point i of a Sobol pair, so every power-of-two prefix of a pixel's samples is stratified in
  both 2D projections. Each pair gets its own hash-based Owen scramble and its own shuffled sample
  order per pixel (Burley 2020, "Practical Hash-based Owen Scrambling"), which keeps every sample
  uniformly distributed (the estimate stays unbiased) while different pairs stay uncorrelated.
- random_pair: a hash of the key, independent between samples and dimensions; used beyond the
  stratified bounces, and everywhere by the "independent" sampler that the validator needs for
  honest per-pixel variances.

Integers are 32-bit values held in uint64 with explicit masks, so products wrap modulo 2^32 as
the hashes require.
"""
from __future__ import annotations

import numpy as np

from .jit import jit

U = np.uint64
M32 = U(0xFFFF_FFFF)
SHIFT_8, SHIFT_13, SHIFT_16 = U(8), U(13), U(16)
MIX_1, MIX_2, GOLDEN = U(0x85EBCA6B), U(0xC2B2AE35), U(0x9E3779B9)
LAINE_KARRAS = (U(0x6C50B47C), U(0xB82F1E52), U(0xC7AFE638), U(0x8D22F6E6))
# Keys that set random_pair's hashes apart from the stratified pairs' ones.
RANDOM_DOMAIN = U(0x5EED_0001)
UNIT_24 = 1.0 / (1 << 24)


def _sobol_second_directions() -> np.ndarray:
    """Direction numbers of Sobol's second dimension: v_0 = 2^31, v_j = v_{j-1} ^ (v_{j-1} >> 1)."""
    v = [1 << 31]
    for _ in range(31):
        v.append(v[-1] ^ (v[-1] >> 1))
    return np.array(v, np.uint64)


def _reverse32(x: int) -> int:
    return int(format(x, "032b")[::-1], 2)


SOBOL_SECOND = _sobol_second_directions()
SOBOL_SECOND_REVERSED = np.array([_reverse32(int(v)) for v in SOBOL_SECOND], np.uint64)


def _sobol_second_reversed_table(bits: int) -> np.ndarray:
    """sobol_second_reversed of every index below 2^bits, built by doubling."""
    table = np.zeros(1, np.uint32)
    for j in range(bits):
        table = np.concatenate([table, table ^ np.uint32(SOBOL_SECOND_REVERSED[j])])
    return table


# Sample indices below 2^16 (all but enormous sample counts) look theirs up: 256 KB.
TABLE_BITS = 16
SOBOL_SECOND_REVERSED_TABLE = _sobol_second_reversed_table(TABLE_BITS)


@jit
def mix(h, key):
    """One round of hash32: xor the key in, murmur3's finaliser, plus the golden ratio."""
    h = (h ^ key) & M32
    h ^= h >> SHIFT_16
    h = (h * MIX_1) & M32
    h ^= h >> SHIFT_13
    h = (h * MIX_2) & M32
    h ^= h >> SHIFT_16
    return (h + GOLDEN) & M32


@jit
def pixel_key(pixel, seed):
    """A path's key: hash32(pixel, seed), with both taken modulo 2^32."""
    return mix(mix(U(0), U(pixel) & M32), U(seed) & M32)


@jit
def reverse_bits(x):
    """The 32 bits of x in reverse order."""
    x = ((x >> U(1)) & U(0x55555555)) | ((x & U(0x55555555)) << U(1))
    x = ((x >> U(2)) & U(0x33333333)) | ((x & U(0x33333333)) << U(2))
    x = ((x >> U(4)) & U(0x0F0F0F0F)) | ((x & U(0x0F0F0F0F)) << U(4))
    x = ((x >> U(8)) & U(0x00FF00FF)) | ((x & U(0x00FF00FF)) << U(8))
    return ((x >> SHIFT_16) | (x << SHIFT_16)) & M32


@jit
def laine_karras(x, seed):
    """The Laine-Karras permutation of x keyed by seed: Owen's scramble of the reversed bits."""
    x = (x + seed) & M32
    for c in LAINE_KARRAS:
        x ^= (x * c) & M32
    return x


@jit
def owen_scramble(x, seed):
    """Nested uniform (Owen) scramble of a 32-bit fixed-point value, keyed by seed."""
    return reverse_bits(laine_karras(reverse_bits(x), seed))


@jit
def sobol_second(index):
    """Sobol's second dimension of index, 32-bit fixed point (the first is reverse_bits(index))."""
    out = U(0)
    j = 0
    while index != U(0):
        if index & U(1):
            out ^= SOBOL_SECOND[j]
        index >>= U(1)
        j += 1
    return out


@jit
def sobol_second_reversed(index):
    """reverse_bits(sobol_second(index)), by table for indices below 2^TABLE_BITS."""
    if index < U(1 << TABLE_BITS):
        return U(SOBOL_SECOND_REVERSED_TABLE[index])
    out = U(0)
    j = 0
    while index != U(0):
        if index & U(1):
            out ^= SOBOL_SECOND_REVERSED[j]
        index >>= U(1)
        j += 1
    return out


@jit
def to_unit(x):
    """32-bit fixed point to a float in [0, 1) (24 bits, so 1.0 is never reached)."""
    return float(x >> SHIFT_8) * UNIT_24


@jit
def stratified_pair(key, sample, dimension, bits):
    """Point `sample` (< 2^bits) of the pixel's Owen-scrambled Sobol pair `dimension`.

    The sample order is shuffled within [0, 2^bits): an Owen scramble of the index read as a
    bits-digit fraction permutes that range, so every power-of-two prefix stays stratified.
    """
    base = mix(key, U(dimension) & M32)
    hashed = mix(U(0), base)                       # hash32(base, k) = mix(mix(0, base), k)
    shift = U(32 - bits)
    # owen_scramble(v, s) = reverse(LK(reverse(v), s)): written out, the reversals that meet
    # cancel, and the Sobol pair is needed only bit-reversed.
    index = U(sample) & ((U(1) << U(bits)) - U(1))
    shuffled = reverse_bits(laine_karras(reverse_bits(index) >> shift, mix(hashed, U(1)))) >> shift
    first = laine_karras(shuffled, mix(hashed, U(2)))
    second = laine_karras(sobol_second_reversed(shuffled), mix(hashed, U(3)))
    return to_unit(reverse_bits(first)), to_unit(reverse_bits(second))


@jit
def random_pair(key, sample, dimension):
    """Two independent uniform numbers in [0, 1) for this key, sample and dimension."""
    h = mix(mix(key ^ RANDOM_DOMAIN, U(dimension) & M32), U(sample) & M32)
    return to_unit(mix(h, U(1))), to_unit(mix(h, U(2)))


@jit
def sample_pair(key, sample, dimension, bits, stratified):
    """The path's pair `dimension`: stratified_pair if `stratified`, else random_pair."""
    if stratified:
        return stratified_pair(key, sample, dimension, bits)
    return random_pair(key, sample, dimension)


# -- arrays, for tests and callers outside compiled code ----------------------------------------

def _as_u32(values) -> np.ndarray:
    """Integer arrays modulo 2^32 as uint64 (floats keep their old uint64 round trip)."""
    a = np.asarray(values)
    if a.dtype.kind not in "biu":
        a = a.astype(np.uint64)
    return a.astype(np.uint32).astype(np.uint64)


@jit
def _stratified_rows(key, sample, dimension, bits, out):
    for i in range(key.shape[0]):
        out[0, i], out[1, i] = stratified_pair(key[i], sample[i], dimension, bits)


@jit
def _pixel_keys(pixel, seed, out):
    for i in range(pixel.shape[0]):
        out[i] = pixel_key(pixel[i], seed)


def stratified_2d(pixel, sample, seed: int, dimension: int, bits: int = 16) -> np.ndarray:
    """(2, n) stratified_pair points for arrays (or scalars) of pixels and sample indices."""
    pixel, sample = np.broadcast_arrays(_as_u32(pixel), _as_u32(sample))
    keys = np.empty(pixel.size, np.uint64)
    _pixel_keys(np.ascontiguousarray(pixel.ravel()), U(int(seed) & 0xFFFF_FFFF), keys)
    out = np.empty((2, pixel.size))
    _stratified_rows(keys, np.ascontiguousarray(sample.ravel()), U(int(dimension) & 0xFFFF_FFFF),
                     int(bits), out)
    return out
