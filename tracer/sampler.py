"""Per-pixel stratified samples for the camera: Owen-scrambled Sobol (0, 2)-sequences.

The pixel position and the lens position of sample i of a pixel come from the first two Sobol
dimensions, a (0, 2)-sequence, so every power-of-two prefix of a pixel's samples is stratified
in both 2D projections. Each 2D pair gets its own hash-based Owen scramble and its own shuffled
sample order per pixel (Burley 2020, "Practical Hash-based Owen Scrambling"), which keeps every
sample uniformly distributed (the estimate stays unbiased) while the pairs stay uncorrelated.

Everything is vectorised over uint32 arrays; multiplication wraps modulo 2^32, as the hashes
require.
"""
from __future__ import annotations

import numpy as np

U32 = np.uint32


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


def hash32(*keys) -> np.ndarray:
    """A well-mixed 32-bit hash of integer arrays or scalars (murmur3 finaliser, chained)."""
    h = np.zeros(np.broadcast(*[np.asarray(k) for k in keys]).shape, U32)
    for key in keys:
        h = h ^ np.asarray(key).astype(np.uint64).astype(U32)
        h ^= h >> U32(16)
        h *= U32(0x85EBCA6B)
        h ^= h >> U32(13)
        h *= U32(0xC2B2AE35)
        h ^= h >> U32(16)
        h += U32(0x9E3779B9)
    return h


def _laine_karras(x: np.ndarray, seed: np.ndarray) -> np.ndarray:
    x = x + seed
    x ^= x * U32(0x6C50B47C)
    x ^= x * U32(0xB82F1E52)
    x ^= x * U32(0xC7AFE638)
    x ^= x * U32(0x8D22F6E6)
    return x


def owen_scramble(x: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """Nested uniform (Owen) scramble of 32-bit fixed-point values, keyed by seed."""
    return reverse_bits(_laine_karras(reverse_bits(x), seed))


def sobol_pair(index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The first two Sobol dimensions (32-bit fixed point) of each index."""
    return reverse_bits(index), reverse_bits(_sobol_second_reversed(index.astype(U32)))


def _sobol_second_reversed(index: np.ndarray) -> np.ndarray:
    # The second dimension with its bits reversed: the XOR of the reversed direction numbers.
    out = np.zeros_like(index)
    bits = int(index.max()).bit_length() if index.size else 0
    for j in range(bits):
        out ^= np.where((index >> U32(j)) & U32(1), _V1_REVERSED[j], U32(0))
    return out


def to_unit(x: np.ndarray) -> np.ndarray:
    """32-bit fixed point to floats in [0, 1) (24 bits, so 1.0 is never reached)."""
    return (x >> U32(8)).astype(np.float64) * (1.0 / (1 << 24))


def stratified_2d(pixel: np.ndarray, sample: np.ndarray, seed: int, dimension: int,
                  bits: int = 16) -> np.ndarray:
    """Uniform (2, n) points for the given pixels and per-pixel sample indices (< 2^bits).

    `dimension` tells the 2D pairs of one path apart (0 = pixel position, 1 = lens position,
    then the pairs of each bounce). The sample order is shuffled within [0, 2^bits): an Owen
    scramble of the index read as a bits-digit fraction permutes that range, so every
    power-of-two prefix of a pixel's samples is still a stratified set.
    """
    base = hash32(pixel, seed, dimension)
    shift = U32(32 - bits)
    shuffled = owen_scramble(sample.astype(U32) << shift, hash32(base, 1)) >> shift
    # owen_scramble(v) = reverse(LK(reverse(v))), and the Sobol dimensions are cheapest to form
    # bit-reversed: the first one reversed is the index itself.
    x = reverse_bits(_laine_karras(shuffled, hash32(base, 2)))
    y = reverse_bits(_laine_karras(_sobol_second_reversed(shuffled), hash32(base, 3)))
    out = np.empty((2, len(x)))
    out[0] = to_unit(x)
    out[1] = to_unit(y)
    return out
