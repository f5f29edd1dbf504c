"""Statistics for comparing two Monte Carlo images: tests, verdict and error metrics. No bpy.

Each image comes with its per-pixel mean, the variance of that mean and the degrees of freedom of
the variance estimate (Snell: spp - 1, from its per-pixel sums of squares; Cycles: K - 1 for K
independent seeds). The difference of two unbiased estimates of the same image has mean zero.

The verdict combines three tests, each at family-wise level ALPHA = 0.01 (Sidak):
1. pixels: per pixel and channel, t = (a - b) / sqrt(va + vb) with Welch-Satterthwaite degrees of
   freedom (a z-test when both variances are well estimated; the t distribution keeps it honest
   with few Cycles seeds). A pixel passes when all its channels pass. Pass: at least
   PIXEL_PASS_FRACTION of the pixels pass (the slack absorbs the heavy tails of caustic pixels).
   Where both variances are 0 (lamps seen directly, black background) the values must agree to a
   relative 1e-4.
2. blocks: the same test on the means of BLOCK x BLOCK pixel tiles (catches small errors spread
   over a region, e.g. an IOR or focus error). Pass: every tile passes.
3. image: the same test on each channel's image mean (catches small global errors, e.g. one more
   bounce). Pass: all three channels pass.
4. sharpness (when the reference comes as two independent halves, e.g. Cycles seeds split in
   two): a matched filter for blur changes. The template w = Laplacian of Gaussian (sigma
   LOG_SIGMA px) of half A; S = sum w (a - b_B) over pixels and channels, with variance
   sum w^2 (va + vb_B); w is clipped at the 95th percentile of |w| (from half A) so that a few
   extreme, heavy-tailed edges (a lamp's outline) cannot dominate. w does not depend on a or b_B, so under agreement S has mean 0 exactly;
   a focus or aperture error changes the image by about its Laplacian and adds up here instead of
   cancelling inside tiles. Pass: |z| below the two-sided ALPHA level.
Consistent when all tests pass, inconsistent otherwise. "Not comparable" is decided by the caller
(settings that Cycles cannot match).
"""
from __future__ import annotations

import math

import numpy as np

ALPHA = 0.01
PIXEL_PASS_FRACTION = 0.9975
BLOCK = 8
RELMSE_EPS = 1e-2
RELMSE_DROP = 1e-3   # fraction of the largest per-value relMSE terms dropped (fireflies)
EXACT_RTOL = 1e-4

CONSISTENT, INCONSISTENT, NOT_COMPARABLE = "consistent", "inconsistent", "not comparable"

RULE = (f"consistent when (1) at least {PIXEL_PASS_FRACTION:.2%} of pixels pass a per-pixel "
        f"two-sided Welch z/t-test of the difference (Sidak-corrected over all pixel channels to a "
        f"family-wise alpha of {ALPHA}; zero-variance pixels must agree to a relative "
        f"{EXACT_RTOL:g}), (2) every {BLOCK}x{BLOCK}-pixel tile mean passes the same test "
        f"(Sidak over tiles and channels, alpha {ALPHA}) and (3) each channel's image mean passes "
        f"it (Sidak over 3 channels, alpha {ALPHA}) and (4) a matched-filter test of the difference against "
        f"the Laplacian of an independent half of the Cycles seeds passes at alpha {ALPHA} "
        f"(catches blur changes: focus, aperture); inconsistent otherwise; not comparable when a "
        f"setting cannot be matched in Cycles")


def sidak(alpha: float, m: int) -> float:
    """Per-test level giving family-wise level alpha over m independent tests."""
    return -math.expm1(math.log1p(-alpha) / max(int(m), 1))


def _two_sided_p(t, df):
    from scipy import stats
    df = np.asarray(df, np.float64)
    df = np.where(np.isfinite(df), df, 1e12)
    return 2.0 * stats.t.sf(np.abs(t), df)


def welch(diff, va, vb, dfa, dfb):
    """(t, p, df) of the difference of two means with variances va, vb estimated with dfa, dfb dof.

    Where va + vb == 0, t is 0 and p is 1 (the exact check is done separately).
    """
    v = va + vb
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(v > 0, diff / np.sqrt(v), 0.0)
        denom = va * va / dfa + vb * vb / dfb
        df = np.where(denom > 0, v * v / denom, np.inf)
    p = np.where(v > 0, _two_sided_p(t, df), 1.0)
    return t, p, df


def _blocks(x, k):
    """Sum over k x k tiles (edges cropped to whole tiles)."""
    h, w = (x.shape[0] // k) * k, (x.shape[1] // k) * k
    x = x[:h, :w]
    return x.reshape(h // k, k, w // k, k, -1).sum(axis=(1, 3))


LOG_SIGMA = 1.0
TEMPLATE_CLIP_PERCENTILE = 95.0


def _blur(x, sigma):
    r = max(1, int(math.ceil(3 * sigma)))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    p = np.pad(x, ((r, r), (0, 0), (0, 0)), mode="edge")
    x = sum(k[i] * p[i:i + x.shape[0]] for i in range(2 * r + 1))
    p = np.pad(x, ((0, 0), (r, r), (0, 0)), mode="edge")
    return sum(k[i] * p[:, i:i + x.shape[1]] for i in range(2 * r + 1))


def laplacian_of_gaussian(img, sigma=LOG_SIGMA):
    g = _blur(np.asarray(img, np.float64), sigma)
    p = np.pad(g, ((1, 1), (1, 1), (0, 0)), mode="edge")
    return p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:] - 4 * g


def sharpness_test(a, va, dfa, half_a, half_b, vb_half, dfb_half):
    """(z, p, df) of the matched-filter test described in the module docstring."""
    w = laplacian_of_gaussian(half_a)
    # Clip the template so that a few extreme edges (a lamp's outline) cannot dominate: their
    # pixels have heavy-tailed noise and would turn the sum into a test of a handful of pixels.
    # The clip level comes from half A only, so w stays independent of a and b_B.
    q = float(np.percentile(np.abs(w), TEMPLATE_CLIP_PERCENTILE))
    if q > 0:
        w = np.clip(w, -q, q)
    d = np.asarray(a, np.float64) - half_b
    s = float(np.sum(w * d))
    wa, wb = w * w * va, w * w * vb_half
    var = float(wa.sum() + wb.sum())
    if var <= 0:
        return 0.0, 1.0, float("inf")
    denom = float((wa * wa).sum() / dfa + (wb * wb).sum() / dfb_half)
    df = var * var / denom if denom > 0 else float("inf")
    z = s / math.sqrt(var)
    return z, float(_two_sided_p(np.array(z), np.array(df))), df


def relmse(image, reference, eps=RELMSE_EPS, drop=RELMSE_DROP) -> float:
    """Mean of (I - R)^2 / (R^2 + eps) over pixels and channels, the largest `drop` fraction of
    the terms (fireflies) left out."""
    image, reference = np.asarray(image, np.float64), np.asarray(reference, np.float64)
    rel = np.sort(((image - reference) ** 2 / (reference * reference + eps)).ravel())
    keep = len(rel) - int(math.floor(drop * len(rel)))
    return float(rel[:keep].mean())


def rmse(image, reference) -> float:
    """Root mean square difference over pixels and channels."""
    d = np.asarray(image, np.float64) - np.asarray(reference, np.float64)
    return float(math.sqrt(np.mean(d * d)))


def compare(a, va, dfa, b, vb, dfb, *, halves=None):
    """All statistics of image a (test, e.g. Snell) against image b (reference, e.g. Cycles).

    a, b: (H, W, 3) means; va, vb: variances of those means; dfa, dfb: their degrees of freedom.
    halves: optional (mean A, mean B, variance of mean B, dof of B) of two independent halves
    of the reference for the sharpness test (skipped without them).
    Returns a dict of plain numbers plus the maps under "maps" (z, diff, pass mask).
    """
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    va, vb = np.asarray(va, np.float64), np.asarray(vb, np.float64)
    if a.shape != b.shape:
        raise ValueError(f"image shapes differ: {a.shape} vs {b.shape}")
    h, w, _ = a.shape
    diff = a - b

    # 1. pixels
    t, p, _ = welch(diff, va, vb, dfa, dfb)
    noisy = (va + vb) > 0
    m = int(noisy.sum())
    alpha_px = sidak(ALPHA, m)
    exact_ok = np.abs(diff) <= EXACT_RTOL * np.maximum(np.abs(a), np.abs(b)) + 1e-7
    # A difference within float rounding passes even where a variance is not zero: a pixel that
    # sees one constant (a texture's flat region, interpolated with weights that sum to 1 only
    # to rounding) has a variance of rounding size, and its z would be meaningless.
    ok = np.where(noisy, (p >= alpha_px) | exact_ok, exact_ok)
    pixel_ok = ok.all(axis=2)
    pass_fraction = float(pixel_ok.mean())
    exact_fail = int((~exact_ok & ~noisy).any(axis=2).sum())

    # 2. tiles
    k = BLOCK if min(h, w) >= 2 * BLOCK else max(1, min(h, w) // 2)
    n = k * k
    bd, bva, bvb = _blocks(diff, k) / n, _blocks(va, k) / n ** 2, _blocks(vb, k) / n ** 2
    # Welch-Satterthwaite dof of a sum of variances: (sum v)^2 / sum(v^2 / df)
    bdfa = _blocks(va * va, k) / n ** 4
    bdfb = _blocks(vb * vb, k) / n ** 4
    with np.errstate(divide="ignore", invalid="ignore"):
        bdfa = np.where(bdfa > 0, bva * bva / (bdfa / dfa), np.inf)
        bdfb = np.where(bdfb > 0, bvb * bvb / (bdfb / dfb), np.inf)
    bt, bp, _ = welch(bd, bva, bvb, bdfa, bdfb)
    bnoisy = (bva + bvb) > 0
    alpha_blk = sidak(ALPHA, int(bnoisy.sum()))
    babs = _blocks(np.abs(a) + np.abs(b), k) / n
    bexact = np.abs(bd) <= EXACT_RTOL * babs + 1e-7
    block_ok = np.where(bnoisy, (bp >= alpha_blk) | bexact, bexact)
    blocks_failed = int((~block_ok).any(axis=2).sum())

    # 3. image means per channel
    npx = h * w
    ma, mb = a.mean(axis=(0, 1)), b.mean(axis=(0, 1))
    sva, svb = va.sum(axis=(0, 1)) / float(npx) ** 2, vb.sum(axis=(0, 1)) / float(npx) ** 2
    # Welch-Satterthwaite dof of the mean, df (sum v)^2 / sum v^2, with the 1 / npx^4 of both
    # sides cancelled: npx ** 4 as a Python int passes uint64 from 256x256 pixels on, and numpy
    # then divides in object dtype (scipy's t-distribution cannot take that).
    with np.errstate(divide="ignore", invalid="ignore"):
        cdfa = np.where(sva > 0, dfa * va.sum(axis=(0, 1)) ** 2 / (va * va).sum(axis=(0, 1)), np.inf)
        cdfb = np.where(svb > 0, dfb * vb.sum(axis=(0, 1)) ** 2 / (vb * vb).sum(axis=(0, 1)), np.inf)
    ct, cp, _ = welch(ma - mb, sva, svb, cdfa, cdfb)
    alpha_ch = sidak(ALPHA, 3)
    channel_ok = np.where((sva + svb) > 0, cp >= alpha_ch,
                          np.abs(ma - mb) <= EXACT_RTOL * np.maximum(np.abs(ma), np.abs(mb)) + 1e-7)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(mb != 0, ma / mb, np.nan)
        ratio_se = np.where(mb != 0, np.abs(ratio) * np.sqrt(sva / np.maximum(ma, 1e-300) ** 2
                                                             + svb / np.maximum(mb, 1e-300) ** 2), np.nan)

    tests = {
        "pixels": bool(pass_fraction >= PIXEL_PASS_FRACTION),
        "tiles": blocks_failed == 0,
        "image_mean": bool(channel_ok.all()),
    }
    sharp_z = sharp_p = None
    if halves is not None:
        sharp_z, sharp_p, _ = sharpness_test(a, va, dfa, *halves)
        tests["sharpness"] = bool(sharp_p >= ALPHA)
    verdict = CONSISTENT if all(tests.values()) else INCONSISTENT

    # error metrics (b is the reference)
    mse = float((diff * diff).mean())
    noise = float((va + vb).mean())
    zmap = np.take_along_axis(t, np.argmax(np.abs(t), axis=2)[..., None], axis=2)[..., 0]

    chans = ("r", "g", "b")
    return {
        "verdict": verdict,
        "tests": tests,
        "rule": RULE,
        "z_pass_fraction": pass_fraction,
        "pixels": npx,
        "pixels_failed": int((~pixel_ok).sum()),
        "pixels_exact_failed": exact_fail,
        "alpha": ALPHA,
        "alpha_pixel": alpha_px,
        "z_critical_normal": _z_critical(alpha_px),
        "tile_size": k,
        "tiles": int(block_ok.shape[0] * block_ok.shape[1]),
        "tiles_failed": blocks_failed,
        "tile_max_abs_z": float(np.max(np.abs(bt))) if bt.size else 0.0,
        "max_abs_z": float(np.max(np.abs(t))) if t.size else 0.0,
        "sharpness_z": sharp_z,
        "sharpness_p": sharp_p,
        "mean_a": dict(zip(chans, map(float, ma))),
        "mean_b": dict(zip(chans, map(float, mb))),
        "mean_a_se": dict(zip(chans, map(float, np.sqrt(sva)))),
        "mean_b_se": dict(zip(chans, map(float, np.sqrt(svb)))),
        "mean_z": dict(zip(chans, map(float, ct))),
        "mean_ratio": dict(zip(chans, map(float, ratio))),
        "mean_ratio_se": dict(zip(chans, map(float, ratio_se))),
        "relmse": relmse(a, b),
        "relmse_eps": RELMSE_EPS,
        "relmse_dropped_fraction": RELMSE_DROP,
        "rmse": math.sqrt(mse),
        "bias_rmse": math.sqrt(max(mse - noise, 0.0)),
        "noise_rmse": math.sqrt(noise),
        "flip": flip(b, a),
        "maps": {"z": zmap, "diff": diff, "pixel_ok": pixel_ok},
    }


def _z_critical(alpha):
    from scipy import stats
    return float(stats.norm.isf(alpha / 2))


def flip(reference, test):
    """Mean HDR-FLIP of test against reference (NVIDIA's flip-evaluator), or None if absent."""
    try:
        import flip_evaluator
    except ImportError:
        return None
    ref = np.ascontiguousarray(np.clip(np.nan_to_num(reference), 0, None), np.float32)
    tst = np.ascontiguousarray(np.clip(np.nan_to_num(test), 0, None), np.float32)
    if not ref.any() and not tst.any():
        return 0.0
    _, mean, _ = flip_evaluator.evaluate(ref, tst, "HDR", applyMagma=False)
    return float(mean)
