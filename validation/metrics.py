"""Statistics for comparing two Monte Carlo images: tests, verdict and error metrics. No bpy.

Each image is an Estimate: its per-pixel mean, the variance of that mean and the degrees of
freedom of the variance estimate, and, where the renderer made them, the independent, equally
weighted images it is the mean of (Snell: 16 batches; Cycles: K seeds). The difference of two
unbiased estimates of the same image has mean zero.

The verdict combines four tests. The whole verdict has level ALPHA = 0.01: each test runs at the
Sidak level sidak(ALPHA, 4) = 0.0025 (docs/validation.md has their measured false-alarm rates).
1. pixels: per pixel and channel, t = (a - b) / sqrt(va + vb) with Welch-Satterthwaite degrees of
   freedom (a t-test keeps it honest with few Cycles seeds), Sidak over all pixel channels. A
   pixel passes when all its channels pass. Pass: at least PIXEL_PASS_FRACTION of the pixels
   pass. Where both variances are 0 (lamps seen directly, black background) the values must
   agree to a relative 1e-4.
2. tiles: the same test on the means of BLOCK x BLOCK tiles (catches small errors spread over a
   region, e.g. an IOR or focus error), Sidak over tiles and channels. Pass: every tile passes.
3. image mean: the same test on each channel's image mean, its variance from the spread of the
   images' own means where both sides have images (that counts the correlations between pixels
   a light tracer's splats make), Sidak over the 3 channels.
4. sharpness: a matched filter for blur changes. The template w is the Laplacian of Gaussian
   (sigma LOG_SIGMA px) of the grey image of the first half of the tested images (or, without
   them, of the reference's), clipped at its 95th percentile of |w| so that a few extreme edges
   cannot dominate; S = sum w (a2 - b) over pixels of the grey images of the rest, and the
   variance of S comes from the spread of sum w x over those images (the channels and
   neighbouring pixels are correlated, which a sum of per-pixel variances misses). w does not
   depend on a2 or b, so under agreement S has mean 0 exactly.
The light tracer's allowance (tests 1-3): a path tracer (Cycles) finds the light that only Snell's
light tracer carries (caustics from small lamps) on rare paths, so its mean there is low in most
runs and its variance estimate too small. Where the tested Estimate has such light, "too bright"
is tested on (a - light) - b, which a path tracer's estimate cannot push up, and "too dark" on
a - b as usual; the sharpness test leaves out the pixels where the light tracer carries more
than CAUSTIC_SHARE of the template, and their neighbours where a pixel filter spreads it.
Consistent when all tests pass, inconsistent otherwise. "Not comparable" is decided by the caller
(settings that Cycles cannot match).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ALPHA = 0.01
PIXEL_PASS_FRACTION = 0.9975
BLOCK = 8
RELMSE_EPS = 1e-2
RELMSE_DROP = 1e-3   # fraction of the largest per-value relMSE terms dropped (fireflies)
EXACT_RTOL = 1e-4

CONSISTENT, INCONSISTENT, NOT_COMPARABLE = "consistent", "inconsistent", "not comparable"

RULE = (f"consistent when each of four tests passes at level {ALPHA / 4:.4g} (Sidak, so that "
        f"the whole verdict has level {ALPHA}): (1) at least {PIXEL_PASS_FRACTION:.2%} of pixels "
        f"pass a per-pixel Welch t-test of the difference (Sidak over all pixel channels; "
        f"zero-variance pixels must agree to a relative {EXACT_RTOL:g}), (2) every "
        f"{BLOCK}x{BLOCK}-pixel tile mean passes the same test (Sidak over tiles and channels), "
        f"(3) each channel's image mean passes it and (4) a matched filter of the difference "
        f"against the Laplacian of an independent half of the tested images passes (catches "
        f"blur changes: focus, aperture); variances of (3) and (4) from the spread of the "
        f"renderers' batches and seeds; where Snell's light tracer carries light, Snell is "
        f"'too bright' only if it is so without that light; inconsistent otherwise; not "
        f"comparable when a setting cannot be matched in Cycles")


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


def _gaussian(sigma):
    r = max(1, int(math.ceil(3 * sigma)))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    return k / k.sum()


def _blur(x, sigma, mode="edge"):
    k = _gaussian(sigma)
    r = len(k) // 2
    p = np.pad(x, ((r, r), (0, 0), (0, 0)), mode=mode)
    x = sum(k[i] * p[i:i + x.shape[0]] for i in range(2 * r + 1))
    p = np.pad(x, ((0, 0), (r, r), (0, 0)), mode=mode)
    return sum(k[i] * p[:, i:i + x.shape[1]] for i in range(2 * r + 1))


def laplacian_of_gaussian(img, sigma=LOG_SIGMA):
    g = _blur(np.asarray(img, np.float64), sigma)
    p = np.pad(g, ((1, 1), (1, 1), (0, 0)), mode="edge")
    return p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:] - 4 * g


def relmse(image, reference, eps=RELMSE_EPS, drop=RELMSE_DROP) -> float:
    """Mean of (I - R)^2 / (R^2 + eps) over pixels and channels, the largest `drop` fraction of
    the terms (fireflies) left out."""
    image, reference = np.asarray(image, np.float64), np.asarray(reference, np.float64)
    return float(_without_fireflies((image - reference) ** 2 / (reference * reference + eps),
                                    drop).mean())


def _without_fireflies(terms, drop):
    """The terms, sorted, the largest `drop` fraction of them left out."""
    terms = np.sort(np.ravel(terms))
    return terms[:len(terms) - int(math.floor(drop * len(terms)))]


def relmse_against_estimate(image, reference, reference_var, mask=None, eps=RELMSE_EPS,
                            drop=RELMSE_DROP) -> float:
    """relMSE of image against a reference that is itself a Monte Carlo estimate (its variance
    of the mean reference_var), over the pixels of `mask` (all if None): unbiased by the
    reference's noise, and never below the estimate's own standard error."""
    image, reference = np.asarray(image, np.float64), np.asarray(reference, np.float64)
    # (I - R)^2 overstates (I - mu)^2 by var(R) on average: subtract it. Dividing by R^2 itself
    # would weight each pixel by its own noise, rewarding images darker than the reference
    # (a pixel whose reference sample came out low counts more): the weight comes from the
    # pixel's neighbours instead, whose noise is independent of its own.
    around = neighbour_mean(reference)
    terms = ((image - reference) ** 2 - np.asarray(reference_var, np.float64)) / (
        around * around + eps)
    keep = _without_fireflies(terms if mask is None else terms[mask], drop)
    standard_error = float(keep.std() / math.sqrt(len(keep))) if len(keep) > 1 else 0.0
    return max(float(keep.mean()), standard_error)


def neighbour_mean(image, sigma=1.0):
    """Each pixel's Gaussian-weighted (sigma px) mean of the pixels around it, itself left out."""
    x = np.asarray(image, np.float64)
    k = _gaussian(sigma)
    own = k[len(k) // 2] ** 2
    # Zero outside the image: no pixel is counted twice, none counts in its own padding.
    weight = _blur(np.ones_like(x), sigma, "constant") - own
    if not np.all(weight > 1e-12):
        return x                    # a single pixel: no neighbours
    return (_blur(x, sigma, "constant") - own * x) / weight


def rmse(image, reference) -> float:
    """Root mean square difference over pixels and channels."""
    d = np.asarray(image, np.float64) - np.asarray(reference, np.float64)
    return float(math.sqrt(np.mean(d * d)))


@dataclass
class Estimate:
    """One renderer's image as a Monte Carlo estimate: the per-pixel mean (H, W, 3), the variance
    of that mean and its degrees of freedom. Optionally the independent, equally weighted images
    whose mean it is (a renderer's batches or seeds: the variance of any linear statistic then
    comes from their spread, which counts correlations between pixels and channels), and the part
    of the mean that only a light tracer carries (`light`, with `rest_var` the variance of
    mean - light): light a path tracer finds only on rare paths (caustics from small lamps)."""
    mean: np.ndarray
    var: np.ndarray
    df: float
    images: np.ndarray | None = None
    light: np.ndarray | None = None
    light_images: np.ndarray | None = None
    rest_var: np.ndarray | None = None

    @classmethod
    def from_images(cls, images, light_images=None) -> "Estimate":
        """The estimate that is the mean of n >= 2 independent images (n, H, W, 3)."""
        images = np.asarray(images, np.float64)
        n = len(images)
        light = rest_var = None
        if light_images is not None:
            light_images = np.asarray(light_images, np.float64)
            light = light_images.mean(axis=0)
            rest_var = (images - light_images).var(axis=0, ddof=1) / n
        return cls(images.mean(axis=0), images.var(axis=0, ddof=1) / n, n - 1, images, light,
                   light_images, rest_var)

    def rest(self):
        """(mean, variance) of the part a path tracer carries too: mean - light."""
        if self.light is None:
            return self.mean, self.var
        return self.mean - self.light, self.rest_var


def _allowance(lo, hi):
    """(z, df) of the light tracer's allowance from the Welch (t, df) of a - b (lo) and of
    (a - light) - b (hi): z = lo's t where it is negative (a too dark), hi's where it is positive
    (a too bright even without the light only its light tracer carries), 0 between. hi None:
    no light, lo as it is."""
    if hi is None:
        return lo
    (t_lo, df_lo), (t_hi, df_hi) = lo, hi
    z = np.where(t_hi > 0, t_hi, np.where(t_lo < 0, t_lo, 0.0))
    return z, np.where(t_hi > 0, df_hi, df_lo)


def _pixel_test(a, b, alpha):
    diff = a.mean - b.mean
    hi = None
    if a.light is not None:
        a_rest, va_rest = a.rest()
        hi = welch(a_rest - b.mean, va_rest, b.var, a.df, b.df)[::2]
    z, df = _allowance(welch(diff, a.var, b.var, a.df, b.df)[::2], hi)
    p = np.where(z != 0, _two_sided_p(z, df), 1.0)
    noisy = (a.var + b.var) > 0
    alpha_px = sidak(alpha, int(noisy.sum()))
    exact_ok = np.abs(diff) <= EXACT_RTOL * np.maximum(np.abs(a.mean), np.abs(b.mean)) + 1e-7
    # A difference within float rounding passes even where a variance is not zero: a pixel that
    # sees one constant (a texture's flat region, interpolated with weights that sum to 1 only
    # to rounding) has a variance of rounding size, and its z would be meaningless.
    ok = np.where(noisy, (p >= alpha_px) | exact_ok, exact_ok)
    return z, ok.all(axis=2), int((~exact_ok & ~noisy).any(axis=2).sum()), alpha_px


def _tile_test(a, b, k, alpha):
    n = k * k

    def t(d, va, dfa):
        bd, bva, bvb = _blocks(d, k) / n, _blocks(va, k) / n ** 2, _blocks(b.var, k) / n ** 2
        # Welch-Satterthwaite dof of a sum of variances: (sum v)^2 / sum(v^2 / df)
        with np.errstate(divide="ignore", invalid="ignore"):
            da = _blocks(va * va, k) / n ** 4
            db = _blocks(b.var * b.var, k) / n ** 4
            dfa_t = np.where(da > 0, bva * bva / (da / dfa), np.inf)
            dfb_t = np.where(db > 0, bvb * bvb / (db / b.df), np.inf)
        return welch(bd, bva, bvb, dfa_t, dfb_t)[::2]

    diff = a.mean - b.mean
    hi = None
    if a.light is not None:
        a_rest, va_rest = a.rest()
        hi = t(a_rest - b.mean, va_rest, a.df)
    z, df = _allowance(t(diff, a.var, a.df), hi)
    noisy = (_blocks(a.var, k) + _blocks(b.var, k)) > 0
    alpha_tile = sidak(alpha, int(noisy.sum()))
    p = np.where(z != 0, _two_sided_p(z, df), 1.0)
    bd = _blocks(diff, k) / n
    bexact = np.abs(bd) <= EXACT_RTOL * _blocks(np.abs(a.mean) + np.abs(b.mean), k) / n + 1e-7
    ok = np.where(noisy, (p >= alpha_tile) | bexact, bexact)
    return z, ok


def _image_mean_test(a, b, alpha):
    """Per channel: (z, ok, se of a's mean, se of b's mean, how the variances were estimated)."""
    npx = a.mean.shape[0] * a.mean.shape[1]

    def side(e, rest=False):
        """(mean, variance of the mean, dof) of a side's image mean per channel."""
        if e.images is not None:
            images = e.images - e.light_images if rest and e.light_images is not None else e.images
            m = images.mean(axis=(1, 2))       # each image's mean per channel
            return m.mean(axis=0), m.var(axis=0, ddof=1) / len(m), np.full(3, len(m) - 1.0)
        mean, var = e.rest() if rest else (e.mean, e.var)
        # Welch-Satterthwaite dof of the mean, df (sum v)^2 / sum v^2, with the 1 / npx^4 of
        # both sides cancelled (npx ** 4 passes uint64 from 256x256 pixels on).
        s = var.sum(axis=(0, 1))
        with np.errstate(divide="ignore", invalid="ignore"):
            df = np.where(s > 0, e.df * s ** 2 / (var * var).sum(axis=(0, 1)), np.inf)
        return mean.mean(axis=(0, 1)), s / float(npx) ** 2, df

    ma, sva, dfa = side(a)
    mb, svb, dfb = side(b)
    hi = None
    if a.light is not None:
        mr, svr, dfr = side(a, rest=True)
        hi = welch(mr - mb, svr, svb, dfr, dfb)[::2]
    z, df = _allowance(welch(ma - mb, sva, svb, dfa, dfb)[::2], hi)
    alpha_ch = sidak(alpha, 3)
    p = np.where(z != 0, _two_sided_p(z, df), 1.0)
    ok = np.where((sva + svb) > 0, p >= alpha_ch,
                  np.abs(ma - mb) <= EXACT_RTOL * np.maximum(np.abs(ma), np.abs(mb)) + 1e-7)
    how = "batches" if a.images is not None and b.images is not None else "pixels"
    return z, ok, ma, mb, sva, svb, how


CAUSTIC_SHARE = 0.05   # sharpness: pixels where a light tracer carries more are left out
SPREAD_PIXELS = 4      # ...and their neighbours this far where it carries a tenth as much


def _grey(x):
    return np.asarray(x, np.float64).sum(axis=-1)


def sharpness_test(a: Estimate, b: Estimate):
    """(z, df, template source, share of pixels left out) of the matched filter for blur changes
    (module docstring), or None when neither side has images to build an independent template."""
    half = None
    if a.images is not None and len(a.images) >= 4:
        h = len(a.images) // 2
        template = a.images[:h].mean(axis=0)
        light = a.light_images[:h].mean(axis=0) if a.light_images is not None else None
        a_stat, b_stat, half = a.images[h:], b.images, "tested"
    elif b.images is not None and len(b.images) >= 4:
        h = len(b.images) // 2
        template, light = b.images[:h].mean(axis=0), a.light
        a_stat, b_stat, half = None, b.images[h:], "reference"
    if half is None:
        return None
    w = laplacian_of_gaussian(_grey(template)[..., None])[..., 0]
    # Clip the template so that a few extreme edges (a lamp's outline) cannot dominate: their
    # pixels have heavy-tailed noise and would turn the sum into a test of a handful of pixels.
    q = float(np.percentile(np.abs(w), TEMPLATE_CLIP_PERCENTILE))
    if q > 0:
        w = np.clip(w, -q, q)
    # Where a light tracer carries much of a pixel, the reference's path tracer finds that light
    # on rare paths, and its mean there is low in most runs: leave those pixels out. The mask
    # comes from the template's data, independent of the sums below.
    left_out = 0.0
    if light is not None:
        from scipy.ndimage import binary_dilation
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(_grey(template) > 0, _grey(light) / _grey(template), 0.0)
        caustic = share > CAUSTIC_SHARE
        # A pixel filter wider than a pixel spreads the light tracer's splats into the pixels
        # around (Blackman-Harris 1.5: one pixel), whose share is small but all of one sign, and
        # the template's edges ring there: the mask grows into them, as far as the light reaches.
        caustic = binary_dilation(caustic, np.ones((3, 3), bool), iterations=SPREAD_PIXELS,
                                  mask=share > CAUSTIC_SHARE / 10)
        w = np.where(caustic, 0.0, w)
        left_out = float(caustic.mean())

    def side(images, estimate):
        """(sum w x, its variance, dof) from images, else from per-pixel variances with the
        channels taken as fully correlated (an upper bound: their covariance is unknown)."""
        if images is not None:
            s = np.einsum("hw,nhw->n", w, _grey(images))
            return float(s.mean()), float(s.var(ddof=1) / len(s)), len(s) - 1.0
        sd = np.sqrt(estimate.var).sum(axis=-1)
        return float(np.sum(w * _grey(estimate.mean))), float(np.sum(w * w * sd * sd)), estimate.df

    sa, va, dfa = side(a_stat, a)
    sb, vb, dfb = side(b_stat, b)
    t, _, df = welch(np.array(sa - sb), np.array(va), np.array(vb), dfa, dfb)
    return float(t), float(df), half, left_out


def compare(a, va, dfa, b, vb, dfb, *, error_metrics=True):
    """compare_estimates of two images given as (H, W, 3) means, the variances of those means
    and their degrees of freedom (no images: no light allowance, no sharpness test)."""
    return compare_estimates(Estimate(np.asarray(a, np.float64), np.asarray(va, np.float64), dfa),
                             Estimate(np.asarray(b, np.float64), np.asarray(vb, np.float64), dfb),
                             error_metrics=error_metrics)


def compare_estimates(a: Estimate, b: Estimate, *, error_metrics=True):
    """All statistics of estimate a (tested, e.g. Snell) against estimate b (reference, e.g.
    Cycles): the tests, the verdict and error metrics, plus the maps under "maps" (z, diff,
    pass masks). error_metrics=False leaves out relMSE, RMSE and FLIP."""
    if a.mean.shape != b.mean.shape:
        raise ValueError(f"image shapes differ: {a.mean.shape} vs {b.mean.shape}")
    h, w, _ = a.mean.shape
    diff = a.mean - b.mean
    sharp = sharpness_test(a, b)
    n_tests = 3 + (sharp is not None)
    alpha = sidak(ALPHA, n_tests)

    t, pixel_ok, exact_fail, alpha_px = _pixel_test(a, b, alpha)
    pass_fraction = float(pixel_ok.mean())
    k = BLOCK if min(h, w) >= 2 * BLOCK else max(1, min(h, w) // 2)
    bt, block_ok = _tile_test(a, b, k, alpha)
    tile_fail = (~block_ok).any(axis=2)
    ct, channel_ok, ma, mb, sva, svb, how = _image_mean_test(a, b, alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(mb != 0, ma / mb, np.nan)
        ratio_se = np.where(mb != 0, np.abs(ratio) * np.sqrt(sva / np.maximum(ma, 1e-300) ** 2
                                                             + svb / np.maximum(mb, 1e-300) ** 2),
                            np.nan)

    tests = {
        "pixels": bool(pass_fraction >= PIXEL_PASS_FRACTION),
        "tiles": not tile_fail.any(),
        "image_mean": bool(channel_ok.all()),
    }
    sharp_z = sharp_p = sharp_df = None
    if sharp is not None:
        sharp_z, sharp_df, template, left_out = sharp
        sharp_p = float(_two_sided_p(np.array(sharp_z), np.array(sharp_df)))
        tests["sharpness"] = bool(sharp_p >= alpha)
    verdict = CONSISTENT if all(tests.values()) else INCONSISTENT
    zmap = np.take_along_axis(t, np.argmax(np.abs(t), axis=2)[..., None], axis=2)[..., 0]
    tile_z = np.take_along_axis(bt, np.argmax(np.abs(bt), axis=2)[..., None], axis=2)[..., 0]
    chans = ("r", "g", "b")
    out = {
        "verdict": verdict,
        "tests": tests,
        "failed_tests": [name for name, ok in tests.items() if not ok],
        "rule": RULE,
        "alpha": ALPHA,
        "alpha_test": alpha,
        "z_pass_fraction": pass_fraction,
        "pixels": h * w,
        "pixels_failed": int((~pixel_ok).sum()),
        "pixels_exact_failed": exact_fail,
        "alpha_pixel": alpha_px,
        "z_critical_normal": _z_critical(alpha_px),
        "tile_size": k,
        "tiles": int(block_ok.shape[0] * block_ok.shape[1]),
        "tiles_failed": int(tile_fail.sum()),
        "failing_tiles": [{"row": int(r), "col": int(c), "z": float(tile_z[r, c]),
                           "y0": int(r * k), "x0": int(c * k), "size": k}
                          for r, c in zip(*np.nonzero(tile_fail))],
        "tile_max_abs_z": float(np.max(np.abs(bt))) if bt.size else 0.0,
        "max_abs_z": float(np.max(np.abs(t))) if t.size else 0.0,
        "light_allowance": a.light is not None,
        "sharpness_z": sharp_z,
        "sharpness_p": sharp_p,
        "sharpness_df": sharp_df,
        "sharpness_template": None if sharp is None else f"{template} half",
        "sharpness_left_out": None if sharp is None else left_out,
        "mean_variance_from": how,
        "mean_a": dict(zip(chans, map(float, ma))),
        "mean_b": dict(zip(chans, map(float, mb))),
        "mean_a_se": dict(zip(chans, map(float, np.sqrt(sva)))),
        "mean_b_se": dict(zip(chans, map(float, np.sqrt(svb)))),
        "mean_z": dict(zip(chans, map(float, ct))),
        "mean_ratio": dict(zip(chans, map(float, ratio))),
        "mean_ratio_se": dict(zip(chans, map(float, ratio_se))),
        "maps": {"z": zmap, "diff": diff, "pixel_ok": pixel_ok, "tile_z": tile_z,
                 "tile_ok": ~tile_fail},
    }
    if error_metrics:
        mse = float((diff * diff).mean())
        noise = float((a.var + b.var).mean())
        out.update({"relmse": relmse(a.mean, b.mean), "relmse_eps": RELMSE_EPS,
                    "relmse_dropped_fraction": RELMSE_DROP, "rmse": math.sqrt(mse),
                    "bias_rmse": math.sqrt(max(mse - noise, 0.0)),
                    "noise_rmse": math.sqrt(noise), "flip": flip(b.mean, a.mean)})
    return out

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

