"""The wavefront path tracer: whole arrays of paths advance one bounce at a time.

Each bounce runs the stages of pbrt-v4's wavefront integrator over numpy arrays: intersect all
live rays (one Embree call), add emission from lamps, the world and emissive triangles, scatter
by material kind, trace every shadow ray of the bounce (one Embree call), then Russian roulette
and compaction. Max depth m is the seed's max_ray_depth: emission plus up to m bounces, which is
Cycles' max_bounces = m - 1.

A render is a sequence of passes. Each pass is cut into fixed-size chunks with their own random
streams (keyed by seed, pass and chunk); the stratified camera, light and BSDF samples are keyed
by seed, pixel and sample index. So the image depends on the seed and sample count only, not on
the thread count. Chunks run on a thread pool: Embree and most numpy kernels release the
GIL.
"""
from __future__ import annotations

import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from . import bsdf
from .arrays import count, select
from .bsdf import DIFFUSE, EMISSION, GLASS, MIRROR, REFRACTION, dot
from .camera import Camera
from .geometry import FAR, Geometry, offset_origin
from .lights import LightSampler
from .sampler import pixel_key, stratified_2d_keyed
from .scene import MATERIAL_KINDS, Scene

CHUNK = 1 << 15           # paths per chunk: big enough to amortise Python, small enough for cache
PASS_PATHS = 1 << 17      # aim for about this many paths per progressive pass
SAMPLERS = ("stratified", "independent")
STRATIFIED_BOUNCES = 2    # bounces whose light and BSDF samples are stratified (then random)
RR_START = 3              # Russian roulette from this bounce on ...
RR_THRESHOLD = 0.1        # ... for paths whose throughput has fallen below this


@dataclass
class RenderResult:
    """Per-pixel sums of the samples and of their squares (row 0 = top), plus counters."""
    width: int
    height: int
    sum: np.ndarray
    sum_sq: np.ndarray
    spp: int = 0
    nan_count: int = 0
    time_s: float = 0.0
    build_s: float = 0.0
    embree_time_s: float = 0.0
    rays: int = 0
    threads: int = 1
    cancelled: bool = False
    stats: dict = field(default_factory=dict)

    def mean(self) -> np.ndarray:
        """The image: per-pixel mean radiance, float32 (H, W, 3), linear."""
        if self.spp == 0:
            return np.zeros_like(self.sum, dtype=np.float32)
        return (self.sum / self.spp).astype(np.float32)

    def variance_of_mean(self) -> np.ndarray:
        """Per-pixel variance of the mean (sample variance / n), float64 (H, W, 3)."""
        n = self.spp
        if n < 2:
            return np.full_like(self.sum, np.inf)
        var = (self.sum_sq - self.sum * self.sum / n) / (n - 1)
        return np.maximum(var, 0.0) / n

    @property
    def rays_per_second(self) -> float:
        """All rays traced (camera, bounce and shadow) per second of render wall time."""
        return self.rays / self.time_s if self.time_s > 0 else 0.0

    @property
    def embree_share(self) -> float:
        """Fraction of the threads' wall time spent inside Embree queries."""
        return self.embree_time_s / (self.time_s * self.threads) if self.time_s > 0 else 0.0


def power_heuristic(a, b):
    """MIS weight of strategy a against b (both pdfs in solid angle)."""
    a2, b2 = a * a, b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(a2 + b2 > 0, a2 / (a2 + b2), 0.0)


class Renderer:
    """A scene prepared for rendering: camera, Embree geometry, materials and lights."""

    def __init__(self, scene: Scene, threads: int = 2, next_event: bool = True,
                 sampler: str = "stratified"):
        """next_event=False turns light sampling off (BSDF sampling only): a second, independent
        estimator of the same image, which tests use to check the first one.

        sampler "stratified" draws each pixel's camera samples (pixel and lens position) from
        Owen-scrambled Sobol points (tracer/sampler.py), "independent" from the random stream.
        Both are unbiased; the stratified one converges faster, but its samples are not
        independent, so the per-pixel variance from the sums over-estimates the error of the
        mean. The Cycles validator uses "independent" for honest variances.
        """
        if sampler not in SAMPLERS:
            raise ValueError(f"sampler: expected one of {SAMPLERS}, got {sampler!r}")
        self.sampler = sampler
        start = time.perf_counter()
        self.scene = scene
        self.threads = max(1, int(threads))
        self.next_event = next_event
        self.camera = Camera(scene.camera)
        self.geometry = Geometry(scene.positions, scene.triangles, scene.normals)
        mats = scene.materials
        self.kind = np.array([MATERIAL_KINDS.index(m["kind"]) for m in mats], np.int64)
        # Per-material colours as (3, M) columns, gathered per hit like every vector array.
        self.color = np.array([m["color"] for m in mats], np.float64).reshape(-1, 3).T.copy()
        self.trans_color = np.array([m.get("transmission_color", m["color"]) for m in mats],
                                    np.float64).reshape(-1, 3).T.copy()
        self.ior = np.array([m.get("ior", 1.0) for m in mats], np.float64)
        strength = np.array([m.get("strength", 0.0) if m["kind"] == "emission" else 0.0 for m in mats])
        self.radiance = self.color * strength
        self.tri_material = scene.material_ids.astype(np.int64)
        self.lights = LightSampler(scene, self.geometry, self.kind, self.radiance.T)
        self.world = np.asarray(scene.world["color"], np.float64)
        self.has_world = bool(np.any(self.world > 0))
        render = scene.render
        self.max_depth = int(render["max_depth"])
        self.seed = int(render["seed"])
        self.fresnel = bsdf.FRESNEL[render["fresnel"]]
        self.build_s = time.perf_counter() - start

    # -- one chunk of paths ---------------------------------------------------------------

    def trace(self, pixel: np.ndarray, rng: np.random.Generator, sample: np.ndarray | None = None,
              sample_bits: int = 16):
        """Radiance of one path per entry of `pixel`: (L (3, n) float64, event counters).

        `sample` holds each path's sample index within its pixel (all below 2^sample_bits), for
        the stratified sampler; without it every number comes from rng.
        """
        n = len(pixel)
        geom, lights, area = self.geometry, self.lights, self.lights.area_lights
        cam = self.camera
        stratified = self.sampler == "stratified" and sample is not None

        key = pixel_key(pixel, self.seed) if stratified else None

        def uniform(rows, dimension, depth=0):
            """(2, len(rows)) uniform numbers for the paths at rows: a stratified 2D pair of
            dimension `dimension` over the first bounces, the random stream after that."""
            if stratified and depth < STRATIFIED_BOUNCES:
                return stratified_2d_keyed(key[rows], sample[rows], dimension, sample_bits)
            return rng.random((2, n if isinstance(rows, slice) else len(rows)))

        everyone = slice(None)
        o, d, tmax = cam.generate(pixel, uniform(everyone, 0),
                                  uniform(everyone, 1) if cam.has_lens else None)
        radiance = np.zeros((3, n))
        path = np.arange(n)
        beta = np.ones((3, n))
        specular = np.ones(n, bool)   # the camera ray counts as specular: no MIS on what it sees
        pdf_prev = np.zeros(n)
        stats = dict.fromkeys(("tir", "tir_absorbed", "rejected", "transmissions", "reflections", "diffuse",
                               "rr_killed", "depth_limited"), 0)

        for depth in range(self.max_depth + 1):
            # Stage 1: intersect.
            prim, u, v, t = geom.intersect(o, d, tmax)     # t stays float32: few paths use it
            alive = prim >= 0

            # Stage 2: lamps, world and emissive surfaces add their light. Lamps have no
            # surface, as in Cycles: a ray adds the light of every lamp it crosses before its
            # hit (or escape) and goes on as if the lamp were not there.
            if area.count:
                t_surface = np.where(alive, np.minimum(t, tmax), tmax)
                for lamp, hit, t_lamp in area.crossings(o, d, t_surface, camera_rays=depth == 0):
                    w = self._mis(specular[hit], pdf_prev[hit],
                                  lambda: lights.pdf_area(lamp, d[:, hit], t_lamp))
                    radiance[:, path[hit]] += beta[:, hit] * area.radiance[:, lamp:lamp + 1] * w
            missed = np.flatnonzero(~alive)
            if len(missed) and self.has_world:
                w = self._mis(specular[missed], pdf_prev[missed], lights.pdf_world)
                radiance[:, path[missed]] += beta[:, missed] * self.world[:, None] * w
            if not alive.any():
                break
            # Emissive triangles add their light before any compaction: one gather per bounce
            # then serves every array, and emitters get no hit reconstruction they do not use.
            mat = self.tri_material.take(prim)          # misses (-1) read garbage, masked below
            kind = self.kind.take(mat)
            emits = alive & (kind == EMISSION)
            if emits.any():
                e = np.flatnonzero(emits)
                w = self._mis(specular[e], pdf_prev[e],
                              lambda: lights.pdf_triangle(prim[e], o[:, e], d[:, e],
                                                          t[e].astype(np.float64)))
                radiance[:, path[e]] += beta[:, e] * self.radiance[:, mat[e]] * w
            scatters = alive & ~emits
            if depth == self.max_depth:
                # Paths that would scatter again: the depth limit, not the scene, ends them.
                stats["depth_limited"] += int(scatters.sum())
                break

            # Stage 3: materials. Emitters do not scatter; the rest are sampled by kind.
            keep = select(scatters)
            path, beta, d, mat, kind = path[keep], beta[:, keep], d[:, keep], mat[keep], kind[keep]
            if len(path) == 0:
                break
            hits = geom.hits(prim[keep], u[keep], v[keep])
            p, ng, ns, eps = hits.p, hits.ng, hits.ns, hits.eps
            # Face the normals towards the incoming ray (two-sided surfaces, inside of glass).
            entering = dot(d, ng) < 0.0
            side = np.where(entering, 1.0, -1.0)
            ng_f, ns_f = ng * side, ns * side
            m = len(path)
            new_d = np.empty((3, m))
            specular = np.ones(m, bool)
            pdf_prev = np.zeros(m)
            shadow = None

            sel = select(kind == DIFFUSE)
            if count(sel, m):
                stats["diffuse"] += count(sel, m)
                albedo = self.color[:, mat[sel]]
                if self.next_event and lights.has_any:
                    shadow = self._next_event(sel, p[:, sel], ng_f[:, sel], ns_f[:, sel], eps[sel],
                                              albedo * beta[:, sel],
                                              np.vstack([uniform(path[sel], 2 + 3 * depth, depth)[:1],
                                                         uniform(path[sel], 3 + 3 * depth, depth)]))
                wi, pdf = bsdf.sample_cosine_hemisphere(ns_f[:, sel], uniform(path[sel], 4 + 3 * depth, depth))
                below = dot(wi, ng_f[:, sel]) <= 0.0   # shading normals can point a sample inside
                beta[:, sel] *= np.where(below, 0.0, albedo)
                new_d[:, sel] = wi
                specular[sel] = False
                pdf_prev[sel] = pdf

            sel = select((kind == MIRROR) | (kind == GLASS) | (kind == REFRACTION))
            if count(sel, m):
                self._specular(sel, d, ng_f, ns_f, entering, mat, kind, beta, new_d, rng, stats)

            # Stage 4: shadow rays of the whole bounce in one Embree call.
            if shadow is not None:
                rows, origin, direction, length, contrib = shadow
                free = ~geom.occluded(origin, direction, length)
                radiance[:, path[rows[free]]] += contrib[:, free]

            # Stage 5: next rays, Russian roulette on the throughput, compaction.
            o = offset_origin(p, ng, eps, new_d)
            d = new_d
            peak = np.maximum(np.maximum(beta[0], beta[1]), beta[2])
            live = peak > 0.0
            if depth + 1 >= RR_START:
                # Survival probability throughput / 0.1: in a closed room a path's remaining light
                # is large, and killing paths at throughput 0.5 (q = throughput) cost more
                # variance than it saved time (measured: 1.5x worse relMSE x time).
                q = np.minimum(peak * (1.0 / RR_THRESHOLD), 1.0)
                survive = rng.random(m) < q
                stats["rr_killed"] += int((live & ~survive).sum())
                live &= survive
                beta = beta / np.where(q > 0, q, 1.0)
            keep = select(live)
            path, beta, specular, pdf_prev = path[keep], beta[:, keep], specular[keep], pdf_prev[keep]
            o, d = o[:, keep], d[:, keep]
            tmax = np.full(len(path), FAR, np.float64)
            if len(path) == 0:
                break
        return radiance, stats

    def _mis(self, specular, pdf_prev, light_pdf):
        """MIS weight of BSDF-sampled emitter hits; after specular bounces it is 1 (no light pdf)."""
        if not self.next_event or specular.all():
            return 1.0
        return np.where(specular, 1.0, power_heuristic(pdf_prev, light_pdf()))

    def _next_event(self, rows, p, ng_f, ns_f, eps, f_beta, u):
        """Light samples at diffuse vertices: (rows, shadow origins, directions, lengths, contributions).

        f_beta is albedo x throughput; the Lambert BRDF is albedo / pi.
        """
        wi, target, weight, pdf_light = self.lights.sample(p, u)
        cos = dot(wi, ns_f)
        ok = (cos > 0.0) & (dot(wi, ng_f) > 0.0) & ((weight[0] > 0.0) | (weight[1] > 0.0) | (weight[2] > 0.0))
        idx = np.flatnonzero(ok)
        if len(idx) == 0:
            return None
        cos = cos[idx]
        w = np.where(pdf_light[idx] > 0, power_heuristic(pdf_light[idx], cos * (1.0 / np.pi)), 1.0)
        contrib = f_beta[:, idx] * weight[:, idx] * (cos * (1.0 / np.pi) * w)
        wi = wi[:, idx]
        origin = offset_origin(p[:, idx], ng_f[:, idx], eps[idx], wi)
        # Aim from the offset origin at the (offset) light point.
        segment = target[:, idx] - origin
        finite = np.isfinite(segment[0])
        length = np.sqrt(dot(segment, segment))
        direction = np.where(finite, segment / np.where(finite, length, 1.0), wi)
        length = np.where(finite, length, FAR)
        rows = idx if isinstance(rows, slice) else rows[idx]   # a slice here selects every row
        return rows, origin, direction, length, contrib

    def _specular(self, sel, d, ng_f, ns_f, entering, mat, kind, beta, new_d, rng, stats):
        """Mirrors, smooth glass (reflect with probability F, else refract) and refraction-only
        surfaces, with Cycles' rules for shading normals (cycles-conventions.md):

        - mirror and glass normals are bent until their mirror reflection clears the surface
          (ensure_valid_specular_reflection);
        - a sample is rejected (its path ends) when the shading normal faces away from the viewer,
          or when the new direction is not on the side its event implies for both normals;
        - refraction-only surfaces have nothing to give under total internal reflection.
        """
        k = kind[sel]
        dd, ng, n = d[:, sel], ng_f[:, sel], ns_f[:, sel]
        if self.geometry.corner_normals is not None:
            bend = k != REFRACTION
            n = np.where(bend, bsdf.valid_reflection_normal(ng, -dd, n), n)
        cos_i = -dot(dd, n)
        color = self.color[:, mat[sel]]
        reflects = k == MIRROR
        weight = color
        dielectric = ~reflects
        if dielectric.any():
            ior = self.ior[mat[sel]]
            eta = np.where(entering[sel], ior, 1.0 / ior)
            f, cos_t = self.fresnel(np.clip(cos_i, 0.0, 1.0), eta)
            tir = dielectric & (f >= 1.0)
            glass = k == GLASS
            reflects = reflects | (glass & (rng.random(len(f)) < f))
            weight = np.where(reflects, color, self.trans_color[:, mat[sel]])
            out = np.where(reflects, bsdf.reflect(dd, n), bsdf.refract(dd, n, eta, cos_i, cos_t))
            stats["tir"] += int((tir & glass).sum())
            stats["tir_absorbed"] += int((tir & ~glass).sum())
            stats["transmissions"] += int((dielectric & ~reflects & ~tir).sum())
        else:
            tir = np.zeros(len(k), bool)
            out = bsdf.reflect(dd, n)
        refracts = ~reflects
        valid = ((cos_i > 0.0) & ((dot(ng, out) < 0.0) == refracts) & ((dot(n, out) < 0.0) == refracts)
                 & ~(tir & (k == REFRACTION)))
        stats["reflections"] += int((reflects & ~tir).sum())
        stats["rejected"] += int((~valid & ~(tir & (k == REFRACTION))).sum())
        new_d[:, sel] = out
        beta[:, sel] *= np.where(valid, weight, 0.0)

    # -- passes ----------------------------------------------------------------------------

    def render(self, spp: int | None = None, progress=None) -> RenderResult:
        """Render progressively; `progress(result, pass_index, pass_count)` may return False to stop."""
        spp = int(spp if spp is not None else self.scene.render["spp"])
        w, h = self.camera.width, self.camera.height
        npix = w * h
        result = RenderResult(w, h, np.zeros((h, w, 3)), np.zeros((h, w, 3)), threads=self.threads,
                              build_s=self.build_s)
        per_pass = max(1, min(spp, PASS_PATHS // npix))
        sample_bits = max(1, (spp - 1).bit_length())   # sample indices run over [0, 2^bits)
        passes = math.ceil(spp / per_pass)
        embree_before, rays_before = self.geometry.embree_time, self.geometry.ray_count
        totals: dict = {}
        start = time.perf_counter()
        flat_sum = result.sum.reshape(-1, 3)
        flat_sq = result.sum_sq.reshape(-1, 3)
        with ThreadPoolExecutor(max_workers=self.threads) as pool:
            for k in range(passes):
                in_pass = min(per_pass, spp - k * per_pass)
                pixels = np.repeat(np.arange(npix, dtype=np.int64), in_pass)
                # Sample index of each path within its pixel (for the stratified sampler).
                samples = np.tile(np.arange(k * per_pass, k * per_pass + in_pass, dtype=np.int64), npix)
                chunks = [(k, c, pixels[s:s + CHUNK], samples[s:s + CHUNK], sample_bits)
                          for c, s in enumerate(range(0, len(pixels), CHUNK))]
                for pix, value, stats in pool.map(self._run_chunk, chunks):
                    bad = ~np.isfinite(value).all(axis=0)
                    if bad.any():
                        result.nan_count += int(bad.sum())
                        value[:, bad] = 0.0
                    for c in range(3):
                        flat_sum[:, c] += np.bincount(pix, value[c], minlength=npix)
                        flat_sq[:, c] += np.bincount(pix, value[c] * value[c], minlength=npix)
                    for key, val in stats.items():
                        totals[key] = totals.get(key, 0) + val
                result.spp += in_pass
                result.time_s = time.perf_counter() - start
                result.embree_time_s = self.geometry.embree_time - embree_before
                result.rays = self.geometry.ray_count - rays_before
                result.stats = totals
                if progress is not None and progress(result, k + 1, passes) is False:
                    result.cancelled = k + 1 < passes
                    break
        result.time_s = time.perf_counter() - start
        return result

    def _run_chunk(self, job):
        pass_index, chunk_index, pixels, samples, sample_bits = job
        rng = np.random.default_rng([self.seed, pass_index, chunk_index])
        value, stats = self.trace(pixels, rng, samples, sample_bits)
        return pixels, value, stats


def render(scene: Scene, *, threads: int = 2, progress=None, spp: int | None = None) -> RenderResult:
    """Render a scene with its own settings; see Renderer.render."""
    return Renderer(scene, threads=threads).render(spp=spp, progress=progress)
