"""Per-pixel stratified samples for the camera: Owen-scrambled Sobol (0, 2)-sequences.

The pixel position and the lens position of sample i of a pixel come from the first two Sobol
dimensions, a (0, 2)-sequence, so every power-of-two prefix of a pixel's samples is stratified
in both 2D projections. Each 2D pair gets its own hash-based Owen scramble and its own shuffled
sample order per pixel (Burley 2020, "Practical Hash-based Owen Scrambling"), which keeps every
sample uniformly distributed (the estimate stays unbiased) while the pairs stay uncorrelated.

Everything is vectorised over uint32 arrays; multiplication wraps modulo 2^32, as the hashes
require. The hot path (stratified_2d_keyed) computes in place in per-thread scratch buffers and
replaces bit loops with table look-ups: at the sizes the integrator uses, numpy's per-call
overhead and the page faults of fresh temporaries cost more than the arithmetic.
"""
from __future__ import annotations

import threading
from functools import lru_cache

import numpy as np

U32 = np.uint32

# Sample indices of at most this many bits take the table-driven path of stratified_2d_keyed.
_TABLE_BITS = 16


def _reverse16_table() -> np.ndarray:
    table = np.arange(1 << 16, dtype=U32)
    out = np.zeros_like(table)
    for bit in range(16):
        out |= ((table >> U32(bit)) & U32(1)) << U32(15 - bit)
    return out


# Bit reversal by two 16-bit table look-ups: a few numpy calls instead of twenty mask steps.
_REVERSE16 = _reverse16_table()

# Direction numbers of Sobol's second dimension: v_0 = 2^31, v_j = v_{j-1} ^ (v_{j-1} >> 1).
_V1 = [1 << 31]
for _ in range(31):
    _V1.append(_V1[-1] ^ (_V1[-1] >> 1))
_V1 = np.array(_V1, dtype=U32)


def reverse_bits(x: np.ndarray) -> np.ndarray:
    """Reverse the 32 bits of each element."""
    x = x.astype(U32)
    return (_REVERSE16.take(x & U32(0xFFFF)) << U32(16)) | _REVERSE16.take(x >> U32(16))


_V1_REVERSED = reverse_bits(_V1)


def _sobol_second_reversed_bitwise(index: np.ndarray) -> np.ndarray:
    """Sobol's second dimension of each index, bit-reversed, one index bit at a time."""
    # The XOR of the reversed direction numbers of the index's set bits.
    out = np.zeros_like(index)
    bits = int(index.max()).bit_length() if index.size else 0
    for j in range(bits):
        out ^= np.where((index >> U32(j)) & U32(1), _V1_REVERSED[j], U32(0))
    return out


# The same for every index below 2^_TABLE_BITS: one look-up instead of a pass per index bit.
_SOBOL_SECOND_REVERSED = _sobol_second_reversed_bitwise(np.arange(1 << _TABLE_BITS, dtype=U32))


def _sobol_second_reversed(index: np.ndarray) -> np.ndarray:
    """Sobol's second dimension of each (uint32) index, bit-reversed."""
    if index.size == 0 or int(index.max()) < len(_SOBOL_SECOND_REVERSED):
        return _SOBOL_SECOND_REVERSED.take(index)
    return _sobol_second_reversed_bitwise(index)


def to_unit(x: np.ndarray) -> np.ndarray:
    """32-bit fixed point to floats in [0, 1) (24 bits, so 1.0 is never reached)."""
    unit = (x >> U32(8)).astype(np.float64)
    unit *= 1.0 / (1 << 24)
    return unit


# -- scratch memory -----------------------------------------------------------------------------

class _Workspace(threading.local):
    """This thread's uninitialised scratch buffers for stratified_2d_keyed."""
    # A fresh temporary of a chunk's size costs more in page faults than the arithmetic done in
    # it, so the buffers outlive the calls: they grow to the largest n asked for and are handed
    # out as views of their first n paths. One set per thread: the integrator traces chunks in
    # parallel.
    capacity, n = 0, -1

    def __call__(self, n: int) -> _Workspace:
        """The buffers, as views for n paths."""
        if n != self.n:
            if n > self.capacity:
                self.capacity = n
                self._u32 = np.empty(9 * n, U32)
                self._index = np.empty(2 * n, np.intp)
                self._unit = np.empty(2 * n)
            self.n = n
            u32 = self._u32[:9 * n].reshape(9, n)
            self.base, self.seeds, self.hash, self.fixed = u32[0], u32[1:4], u32[4:7], u32[7:9]
            self.index = self._index[:2 * n].reshape(2, n)
            self.unit = self._unit[:2 * n].reshape(2, n)
        return self


_workspace = _Workspace()


# -- hashing ------------------------------------------------------------------------------------

# Constants as 0-d arrays: ufuncs take them with less overhead than numpy scalars.
_MIX_1, _MIX_2 = np.array(0x85EBCA6B, U32), np.array(0xC2B2AE35, U32)
_GOLDEN = np.array(0x9E3779B9, U32)
_SHIFT_13, _SHIFT_16 = np.array(13, U32), np.array(16, U32)


def _as_u32(key) -> np.ndarray | np.uint32:
    """The low 32 bits of an integer array or scalar, as uint32."""
    if isinstance(key, (int, np.integer)):
        return U32(key & 0xFFFF_FFFF)
    key = np.asarray(key)
    # Integer casts to uint32 wrap modulo 2^32 already; other types (floats) keep the uint64
    # round trip their hashes have always had.
    if key.dtype.kind in "biu":
        return key.astype(U32, copy=False)
    return key.astype(np.uint64).astype(U32)


def _mix(h: np.ndarray, scratch: np.ndarray) -> None:
    """h = fmix32(h) + golden ratio, in place: a round of hash32 once its key is xored in."""
    np.right_shift(h, _SHIFT_16, out=scratch)
    h ^= scratch
    h *= _MIX_1
    np.right_shift(h, _SHIFT_13, out=scratch)
    h ^= scratch
    h *= _MIX_2
    np.right_shift(h, _SHIFT_16, out=scratch)
    h ^= scratch
    h += _GOLDEN


def hash32(*keys) -> np.ndarray:
    """A well-mixed 32-bit hash of integer arrays or scalars (murmur3 finaliser, chained)."""
    h = np.zeros(np.broadcast(*[np.asarray(k) for k in keys]).shape, U32)
    scratch = np.empty_like(h)
    for key in keys:
        h ^= _as_u32(key)
        _mix(h, scratch)
    return h


def pixel_key(pixel: np.ndarray, seed: int) -> np.ndarray:
    """Each path's key for stratified_2d_keyed: hash32's state after its pixel and the seed."""
    return hash32(pixel, seed)


# The keys of the last hash32 of each 2D pair: its sample shuffle and its two dimensions.
_SEED_KEYS = np.array([[1], [2], [3]], U32)


def _scramble_seeds(key: np.ndarray, dimension: int, work: _Workspace) -> np.ndarray:
    """(3, n) seeds hash32(hash32(pixel, seed, dimension), k), k = 1, 2, 3, from pixel_key."""
    base, seeds, scratch = work.base, work.seeds, work.hash
    np.bitwise_xor(key, _as_u32(dimension), out=base)
    _mix(base, scratch[0])
    # hash32(base, k) begins with a round on 0 ^ base, the same for every k.
    _mix(base, scratch[0])
    np.bitwise_xor(base, _SEED_KEYS, out=seeds)
    _mix(seeds, scratch)
    return seeds


# -- scrambling ---------------------------------------------------------------------------------

_LAINE_KARRAS = [np.array(c, U32) for c in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6)]


def _laine_karras_mix(x: np.ndarray, scratch: np.ndarray) -> None:
    """The Laine-Karras permutation of x, in place, once its seed is added."""
    for constant in _LAINE_KARRAS:
        np.multiply(x, constant, out=scratch)
        x ^= scratch


def _laine_karras(x: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """The Laine-Karras permutation of x keyed by seed (Owen's scramble, bit-reversed)."""
    x = x + seed
    _laine_karras_mix(x, np.empty_like(x))
    return x


def owen_scramble(x: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """Nested uniform (Owen) scramble of 32-bit fixed-point values, keyed by seed."""
    return reverse_bits(_laine_karras(reverse_bits(x), seed))


def sobol_pair(index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The first two Sobol dimensions (32-bit fixed point) of each index."""
    return reverse_bits(index), reverse_bits(_sobol_second_reversed(index.astype(U32)))


# -- the stratified samples ---------------------------------------------------------------------

@lru_cache(maxsize=None)
def _index_tables(bits: int) -> tuple[np.ndarray, np.ndarray]:
    """The bit-reversed Sobol pair (2, 2^bits) of each index's bits-digit reversal; the mask."""
    # The first row is that reversal itself: the first dimension bit-reversed is the index.
    reverse = _REVERSE16[:1 << bits] >> U32(16 - bits)
    tables = np.stack([reverse, _SOBOL_SECOND_REVERSED.take(reverse)])
    return tables, np.array((1 << bits) - 1, U32)


def _shuffled_sobol(sample: np.ndarray, seed: np.ndarray, bits: int, out: np.ndarray,
                    index: np.ndarray) -> None:
    """Into out (2, n): the bit-reversed Sobol pair of each shuffled sample index."""
    # index: intp scratch of sample's shape.
    if not (1 <= bits <= _TABLE_BITS and sample.dtype.kind in "iu"):
        shift = U32(32 - bits)
        shuffled = owen_scramble(sample.astype(U32) << shift, seed) >> shift
        out[0] = shuffled
        out[1] = _sobol_second_reversed(shuffled)
        return
    # The shuffle is owen_scramble(sample << s) >> s = reverse(LK(reverse(sample << s))) >> s,
    # s = 32 - bits. reverse(sample << s) is the bits-digit reversal of sample's low bits and
    # reverse(z) >> s that of z's low bits: both 32-bit reversals become 2^bits-entry look-ups.
    tables, mask = _index_tables(bits)
    # mode="clip" takes straight into out ("raise" would buffer); masked indices are in range.
    np.bitwise_and(sample, mask, out=index, casting="unsafe")
    x = out[0]
    tables[0].take(index, out=x, mode="clip")
    x += seed
    _laine_karras_mix(x, scratch=out[1])
    np.bitwise_and(x, mask, out=index)
    tables[0].take(index, out=out[0], mode="clip")
    tables[1].take(index, out=out[1], mode="clip")


# to_unit(reverse_bits(z)) is bits 0..23 of z reversed: bits 0..11 of z make the high 12 bits
# of the fraction, bits 12..23 the low 12. Two small float tables (L1-sized) hold both halves;
# their sum is exact, the bits being disjoint.
_REVERSE12 = _REVERSE16[:1 << 12] >> U32(4)
_UNIT_HIGH12 = _REVERSE12 * (1.0 / (1 << 12))
_UNIT_LOW12 = _REVERSE12 * (1.0 / (1 << 24))
_MASK_12, _SHIFT_12 = np.array(0xFFF, U32), np.array(12, U32)


def _unit_of_reversed(z: np.ndarray, out: np.ndarray, work: _Workspace) -> np.ndarray:
    """to_unit(reverse_bits(z)) into out, by two table look-ups."""
    index, low = work.index, work.unit
    np.bitwise_and(z, _MASK_12, out=index)
    _UNIT_HIGH12.take(index, out=out, mode="clip")
    np.right_shift(z, _SHIFT_12, out=index)
    index &= _MASK_12
    _UNIT_LOW12.take(index, out=low, mode="clip")
    out += low
    return out


def stratified_2d_keyed(key: np.ndarray, sample: np.ndarray, dimension: int,
                        bits: int = 16) -> np.ndarray:
    """stratified_2d(pixel, sample, seed, dimension, bits), given key = pixel_key(pixel, seed)."""
    # A path draws several dimensions with one pixel and seed: keying it once saves two of the
    # seven hash rounds of each draw.
    if np.shape(key) != np.shape(sample):
        key, sample = np.broadcast_arrays(key, sample)
    work = _workspace(len(key))
    seeds, fixed = _scramble_seeds(key, dimension, work), work.fixed
    _shuffled_sobol(sample, seeds[0], bits, out=fixed, index=work.index[0])
    # Scramble both dimensions: owen_scramble(v) = reverse(LK(reverse(v))), and the Sobol
    # dimensions are at hand bit-reversed. Their seeds are spent after the add, so they serve
    # as the scratch buffer.
    fixed += seeds[1:]
    _laine_karras_mix(fixed, scratch=seeds[1:])
    return _unit_of_reversed(fixed, np.empty(fixed.shape), work)


def stratified_2d(pixel: np.ndarray, sample: np.ndarray, seed: int, dimension: int,
                  bits: int = 16) -> np.ndarray:
    """Uniform (2, n) points for the given pixels and per-pixel sample indices (< 2^bits).

    `dimension` tells the 2D pairs of one path apart (0 = pixel position, 1 = lens position,
    then the pairs of each bounce). The sample order is shuffled within [0, 2^bits): an Owen
    scramble of the index read as a bits-digit fraction permutes that range, so every
    power-of-two prefix of a pixel's samples is still a stratified set.
    """
    return stratified_2d_keyed(pixel_key(pixel, seed), sample, dimension, bits)
