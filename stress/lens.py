"""Stress cases of the thin-lens camera: circles of confusion, polygonal apertures, the pinhole
limit."""
from __future__ import annotations

import math

import numpy as np

from .cases import AT_MOST, STATISTICAL, Case, Outcome, render, settings_of
from .geometry import WHITE, camera, quad, scene


# ---------------------------------------------------------------------------------------------
# Thin lens


LENS_WIDTH = 48          # pixels
COC_PIXELS = 12.0        # the circle of confusion's radius each lens case is set up for
SENSOR_MM = 36.0


def lens_setup(focus, fstop):
    """(lens mm, aperture radius m, CoC radius px) putting an on-axis object at twice the focus
    distance into a circle of confusion of COC_PIXELS: tangent radius a (1/f - 1/2f) over a pixel
    of sensor / (lens width), with a = lens / (2 fstop)."""
    lens_mm = math.sqrt(COC_PIXELS * SENSOR_MM * 4000.0 * fstop * focus / LENS_WIDTH)
    aperture = lens_mm * 1e-3 / (2.0 * fstop)
    pixel = SENSOR_MM / (lens_mm * LENS_WIDTH)
    return lens_mm, aperture, aperture * (1.0 / focus - 1.0 / (2.0 * focus)) / pixel


def lens_scene(focus, fstop, blades=0, emitter="square", spp=64, use_dof=True):
    """An emitter of radiance 1 at twice the focus distance on the axis of a thin-lens camera.

    emitter "square": a square of half-size = half the CoC (in the image); "point": a point lamp
    of radius a tenth of the CoC. Returns (scene, CoC px, emitter half-size px).
    """
    z = 2.0 * focus
    lens_mm, aperture, coc_px = lens_setup(focus, fstop)
    pixel = SENSOR_MM / (lens_mm * LENS_WIDTH)
    dof = {"use_dof": use_dof, "focus_distance": focus, "fstop": fstop, "blades": blades}
    cam = camera(position=(0, 0, 0), resolution=(LENS_WIDTH, LENS_WIDTH), lens=lens_mm, dof=dof,
                 clip_start=z * 1e-4, clip_end=z * 10.0)
    if emitter == "square":
        half_px = coc_px / 2.0
        pos, tri = quad((0.0, 0.0, -z), half_px * pixel * z, half_px * pixel * z)
        mats = [{"name": "lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
        return scene([(pos, tri, 0)], mats, cam, spp=spp, max_depth=0), coc_px, half_px
    radius_px = coc_px / 10.0
    lamp = {"name": "point", "kind": "point", "position": [0.0, 0.0, -z], "intensity": WHITE,
            "radius": radius_px * pixel * z, "soft_falloff": True}
    return scene([], [], cam, lights=[lamp], spp=spp, max_depth=0), coc_px, radius_px


def _pixel_offsets(w, h):
    """Squared distance in pixels of every pixel centre from the image centre."""
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    return (xs - w / 2.0) ** 2 + (ys - h / 2.0) ** 2


def coc_radius(result, half_px):
    """The circle of confusion's radius in pixels from the image's second moment about the centre,
    with its standard error (delta method): E[r^2] = R^2/2 + 2 h^2/3 (square) + 1/6 (pixel box)."""
    v = result.mean()[..., 0].astype(np.float64)
    var = result.variance_of_mean()[..., 0]
    r2 = _pixel_offsets(result.width, result.height)
    total = v.sum()
    m = float((r2 * v).sum() / total)
    se_m = math.sqrt(float((((r2 - m) / total) ** 2 * var).sum()))
    radius2 = 2.0 * (m - 1.0 / 6.0 - 2.0 * half_px ** 2 / 3.0)
    radius = math.sqrt(max(radius2, 0.0))
    return radius, se_m / max(radius, 1e-12)


def _coc_case(focus, fstop, blades=0, quick=False):
    lens_mm, aperture, coc_px = lens_setup(focus, fstop)
    # A regular polygon inscribed in radius a has E[r^2] = a^2 (2 + cos(2 pi / B)) / 6 (its B
    # triangles from the centre); a disk a^2 / 2. Measured as sqrt(2 E[r^2]).
    expected = coc_px * (math.sqrt((2.0 + math.cos(2.0 * math.pi / blades)) / 3.0)
                         if blades else 1.0)
    shape = f"{blades}-blade polygon" if blades else "disk"

    def run(threads, seed):
        scn, coc, half_px = lens_scene(focus, fstop, blades)
        result = render(scn, threads, seed)
        radius, se = coc_radius(result, half_px)
        return Outcome(radius, se=se, nan_count=result.nan_count, image=result.mean(),
                       error_map=result.mean()[..., 0] - result.mean()[..., 0].mean(),
                       error_label="image - its mean (the blur's shape)", settings=settings_of(scn),
                       note=f"lens {lens_mm:.4g} mm, aperture radius {aperture:.3g} m")
    return Case(f"CoC focus {focus:g} f/{fstop:g} {shape}", "thin lens",
                f"RMS circle-of-confusion radius (px) of a square at twice the focus distance, "
                f"{shape} aperture",
                "the lens samples, the focus plane or the aperture size are wrong at this scale",
                STATISTICAL, expected, run, quick)


def _pinhole_limit_case(quick):
    focus, fstop = 1.0, 1e6
    lens_mm = 50.0

    def run(threads, seed):
        scn = _pinhole_scene(focus, fstop, lens_mm, True)
        pin = _pinhole_scene(focus, fstop, lens_mm, False)
        a, b = render(scn, threads, seed), render(pin, threads, seed)
        differing = float(np.abs(a.sum[..., 0] - b.sum[..., 0]).sum())
        # A sample differs only if the lens moves its ray across the emitter's edge: within the
        # CoC radius of it. Expected count: samples x (edge length x 2 CoC) / image area; the
        # allowance is its Poisson quantile at the case's share of alpha.
        aperture = lens_mm * 1e-3 / (2 * fstop)
        pixel = SENSOR_MM / (lens_mm * LENS_WIDTH)
        coc = aperture * (1 / focus - 1 / 2.0) / pixel
        n = LENS_WIDTH ** 2 * a.spp
        expected_flips = n * (4 * 2 * LENS_WIDTH / 3) * 2 * coc / LENS_WIDTH ** 2
        allowed = float(poisson_quantile(expected_flips, 1e-4))
        return Outcome(differing, allowance=allowed, nan_count=a.nan_count + b.nan_count,
                       image=a.mean(), error_map=(a.mean() - b.mean())[..., 0],
                       error_label="depth of field - pinhole", settings=settings_of(scn),
                       note=f"CoC {coc:.2g} px; expected differing samples {expected_flips:.2g}")
    return Case("pinhole limit f/1e6", "thin lens",
                "samples that differ from the pinhole render (same seed)",
                "a vanishing aperture still moves rays: "
                "the lens sampling or focus math is unstable",
                AT_MOST, 0.0, run, quick)


def poisson_quantile(mean: float, alpha: float) -> int:
    """The smallest k with P(K > k) <= alpha for K ~ Poisson(mean)."""
    k, pmf = 0, math.exp(-mean)
    cdf = pmf
    while 1.0 - cdf > alpha:
        k += 1
        pmf *= mean / k
        cdf += pmf
    return k


def _pinhole_scene(focus, fstop, lens_mm, use_dof):
    z = 2.0 * focus
    half = z * SENSOR_MM / (2 * lens_mm) / 3.0   # a square a third of the image wide
    dof = {"use_dof": use_dof, "focus_distance": focus, "fstop": fstop}
    cam = camera(position=(0, 0, 0), resolution=(LENS_WIDTH, LENS_WIDTH), lens=lens_mm, dof=dof)
    pos, tri = quad((0.0, 0.0, -z), half, half)
    mats = [{"name": "lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
    return scene([(pos, tri, 0)], mats, cam, spp=16, max_depth=0)


def point_light_area(result, coc_px, radius_px):
    """Area (px^2) of an out-of-focus lamp's image as its total over its plateau level, with the
    delta-method standard error; the plateau is the pixels wholly inside radius R - r."""
    v = result.mean()[..., 0].astype(np.float64)
    var = result.variance_of_mean()[..., 0]
    r = np.sqrt(_pixel_offsets(result.width, result.height))
    plateau = r + math.sqrt(0.5) <= coc_px - radius_px
    total, level = v.sum(), v[plateau].mean()
    grad = np.full(v.shape, 1.0 / level)
    grad[plateau] -= total / (level ** 2 * plateau.sum())
    return total / level, math.sqrt(float((grad ** 2 * var).sum()))


def _point_light_case(focus, fstop, quick):
    _, _, coc_px = lens_setup(focus, fstop)

    def run(threads, seed):
        scn, coc, radius_px = lens_scene(focus, fstop, emitter="point", spp=256)
        result = render(scn, threads, seed)
        area, se = point_light_area(result, coc, radius_px)
        return Outcome(area, se=se, nan_count=result.nan_count, image=result.mean(),
                       error_map=result.mean()[..., 0] - result.mean()[..., 0].mean(),
                       error_label="image - its mean (the blur's shape)",
                       settings=settings_of(scn),
                       note=f"CoC {coc:.2f} px, lamp radius {radius_px:.2f} px")
    return Case(f"point lamp out of focus, focus {focus:g} f/{fstop:g}", "thin lens",
                "area (px^2) of the lamp's blurred image: total / plateau = pi R^2",
                "an out-of-focus lamp spreads over the wrong area (lens sampling or lamp hits)",
                STATISTICAL, math.pi * coc_px ** 2, run, quick)


def lens_cases():
    """CoC across focus 1e-3 to 1e6 and f/0.5 to f/1e6, polygons, pinhole limit, point lamp."""
    cases = []
    for focus, fstop in ((1e-3, 0.5), (1e-3, 1e6), (1.0, 2.8), (1e6, 0.5), (1e6, 1e6)):
        cases.append(_coc_case(focus, fstop, quick=(focus, fstop) in ((1e-3, 0.5), (1e6, 1e6))))
    cases.append(_coc_case(1.0, 2.8, blades=6, quick=True))
    cases.append(_coc_case(1.0, 2.8, blades=3))
    cases.append(_pinhole_limit_case(quick=True))
    cases.append(_point_light_case(1.0, 2.8, quick=True))
    return cases
