"""The wavefront path tracer: whole arrays of paths advance one bounce at a time.

A render is a sequence of passes; each pass is cut into fixed-size chunks of paths, and chunks run
on a thread pool (the compiled stages and Embree release the GIL). A chunk runs the stages of
tracer/wavefront.py bounce by bounce: generate, then per bounce one Embree call for every live
ray, emitters, materials, one Embree call for every shadow ray, shadow_rays; film adds the
finished chunk to the image. Every random number is keyed by seed, pixel, sample index and
dimension (tracer/sampler.py), so the image depends on the seed and sample count only, not on
the thread count or the chunking.
"""
from __future__ import annotations

import math
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from . import bsdf, jit, wavefront
from .camera import Camera
from .geometry import Geometry
from .lights import LightSampler
from .scene import FRESNEL_MODELS, MATERIAL_KINDS, Scene

CHUNK = 1 << 13           # paths per chunk: measured best (8k-16k) for Python overhead vs cache
PASS_PATHS = 1 << 17      # aim for about this many paths per progressive pass
SAMPLERS = ("stratified", "independent")


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
        # Divided in float64 and rounded once into the float32 image, without a float64 copy of
        # the image on the way (1.5 GB at 8192x8192).
        image = np.empty(self.sum.shape, np.float32)
        np.divide(self.sum, self.spp, out=image, casting="unsafe")
        return image

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


class _Buffers(threading.local):
    """This thread's chunk buffers, made once and reused by every chunk it runs."""

    def get(self):
        """(paths, next paths, shadow rays, radiance, active rows, counters) for CHUNK paths."""
        if not hasattr(self, "buffers"):
            self.buffers = (wavefront.new_paths(CHUNK), wavefront.new_paths(CHUNK),
                            wavefront.new_shadows(CHUNK), np.empty((CHUNK, 3)),
                            np.empty(CHUNK, np.int64), np.zeros(len(wavefront.STATS), np.int64))
        return self.buffers


class Renderer:
    """A scene prepared for rendering: camera, Embree geometry, materials and lights."""

    def __init__(self, scene: Scene, threads: int = 2, next_event: bool = True,
                 sampler: str = "stratified"):
        """next_event=False turns light sampling off (BSDF sampling only): a second, independent
        estimator of the same image, which tests use to check the first one.

        sampler "stratified" draws each pixel's camera samples (pixel and lens position) and the
        light and BSDF samples of the first bounces from Owen-scrambled Sobol points,
        "independent" from a hash of the path's key. Both are unbiased; the stratified one
        converges faster, but its samples are not independent, so the per-pixel variance from
        the sums over-estimates the error of the mean. The Cycles validator uses "independent"
        for honest variances.
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
        kind = np.array([MATERIAL_KINDS.index(m["kind"]) for m in mats], np.int64)
        color = np.array([m["color"] for m in mats], np.float64).reshape(-1, 3)
        strength = np.array([m.get("strength", 0.0) if m["kind"] == "emission" else 0.0 for m in mats])
        self.materials = wavefront.Materials(
            kind=kind, color=color,
            trans_color=np.array([m.get("transmission_color", m["color"]) for m in mats],
                                 np.float64).reshape(-1, 3),
            ior=np.array([m.get("ior", 1.0) for m in mats], np.float64),
            radiance=np.ascontiguousarray(color * strength[:, None]),
            of_triangle=scene.material_ids.astype(np.int64))
        self.lights = LightSampler(scene, self.geometry, kind, self.materials.radiance)
        render = scene.render
        self.max_depth = int(render["max_depth"])
        self.seed = int(render["seed"])
        self.fresnel = FRESNEL_MODELS.index(render["fresnel"])
        self._buffers = _Buffers()
        self._film_lock = threading.Lock()
        self.build_s = time.perf_counter() - start

    # -- one chunk of paths ---------------------------------------------------------------

    def trace_chunk(self, start: int, n: int, in_pass: int, first_sample: int, bits: int,
                    total: np.ndarray, total_sq: np.ndarray):
        """Trace paths start .. start + n of a pass (in_pass samples per pixel, the first being
        sample first_sample) and add them to the (pixels, 3) sums. Returns (NaN/Inf samples,
        event counters)."""
        geom, lights, mats = self.geometry, self.lights.tables, self.materials
        mesh = geom.mesh
        paths, out, shadows, radiance, active, stats = self._buffers.get()
        stats[:] = 0
        stratified = self.sampler == "stratified"
        wavefront.clear(radiance, n)
        wavefront.generate(self.camera.params(), self.seed, start, in_pass, first_sample, bits,
                           stratified, n, paths)
        m = n
        for depth in range(self.max_depth + 1):
            prim, u, v, t = geom.intersect(paths.o32[:m], paths.d32[:m], paths.tmax[:m])
            kept = wavefront.emitters(lights, mats, self.next_event, depth, self.max_depth, m,
                                      paths, prim, t, radiance, active, stats)
            if kept == 0:
                break
            m, n_shadow = wavefront.materials(lights, mesh, mats, self.fresnel, self.next_event,
                                              bits, stratified, depth, kept, active, paths, prim,
                                              u, v, out, shadows, radiance, stats)
            if n_shadow:
                blocked = geom.occluded(shadows.o32[:n_shadow], shadows.d32[:n_shadow],
                                        shadows.tmax[:n_shadow])
                wavefront.shadow_rays(n_shadow, blocked, shadows, radiance)
            paths, out = out, paths
            if m == 0:
                break
        with self._film_lock:
            bad = wavefront.film(radiance, n, start, in_pass, total, total_sq)
        return bad, stats.copy()

    # -- passes ----------------------------------------------------------------------------

    def render(self, spp: int | None = None, progress=None) -> RenderResult:
        """Render progressively; `progress(result, pass_index, pass_count)` may return False to stop."""
        spp = int(spp if spp is not None else self.scene.render["spp"])
        w, h = self.camera.width, self.camera.height
        npix = w * h
        result = RenderResult(w, h, np.zeros((h, w, 3)), np.zeros((h, w, 3)), threads=self.threads,
                              build_s=self.build_s)
        per_pass = max(1, min(spp, PASS_PATHS // npix))
        bits = max(1, (spp - 1).bit_length())   # sample indices run over [0, 2^bits)
        passes = math.ceil(spp / per_pass)
        embree_before, rays_before = self.geometry.embree_time, self.geometry.ray_count
        counters = np.zeros(len(wavefront.STATS), np.int64)
        start = time.perf_counter()
        total, total_sq = result.sum.reshape(-1, 3), result.sum_sq.reshape(-1, 3)
        with ThreadPoolExecutor(max_workers=self.threads) as pool:
            for k in range(passes):
                in_pass = min(per_pass, spp - k * per_pass)
                count = npix * in_pass
                jobs = [(s, min(CHUNK, count - s)) for s in range(0, count, CHUNK)]
                for bad, stats in pool.map(
                        lambda job: self.trace_chunk(job[0], job[1], in_pass, k * per_pass, bits,
                                                     total, total_sq), jobs):
                    result.nan_count += bad
                    counters += stats
                result.spp += in_pass
                result.time_s = time.perf_counter() - start
                result.embree_time_s = self.geometry.embree_time - embree_before
                result.rays = self.geometry.ray_count - rays_before
                result.stats = dict(zip(wavefront.STATS, counters.tolist()))
                if progress is not None and progress(result, k + 1, passes) is False:
                    result.cancelled = k + 1 < passes
                    break
        result.time_s = time.perf_counter() - start
        return result


def render(scene: Scene, *, threads: int = 2, progress=None, spp: int | None = None) -> RenderResult:
    """Render a scene with its own settings; see Renderer.render."""
    return Renderer(scene, threads=threads).render(spp=spp, progress=progress)


def warm_up() -> float:
    """Compile (first run) or load (cached) every kernel a render uses; returns the seconds it
    took. A render calls them anyway; warming up first keeps that one-time cost out of timings
    and lets a caller say "compiling kernels" before it happens."""
    start = time.perf_counter()
    m = np.eye(4)
    m[:3, 3] = (0.0, 0.0, 2.0)
    camera = {"matrix": m.tolist(), "lens": 50.0, "sensor_width": 36.0, "sensor_height": 24.0,
              "clip_start": 0.01, "clip_end": 100.0, "resolution": [2, 2],
              "dof": {"use_dof": True, "focus_distance": 2.0, "fstop": 1.0}}
    triangle = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32)
    lamp = {"name": "lamp", "kind": "point", "position": [0.0, 0.0, 1.0],
            "intensity": [1.0, 1.0, 1.0], "radius": 0.1}
    scene = Scene(positions=triangle, triangles=np.array([[0, 1, 2]], np.int32),
                  material_ids=np.zeros(1, np.int32), object_ids=np.zeros(1, np.int32),
                  materials=[{"name": "grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}],
                  lights=[lamp], camera=camera, world={"color": [0.1, 0.1, 0.1]},
                  render={"spp": 1, "max_depth": 2, "seed": 0, "fresnel": "exact"},
                  objects=[{"name": "triangle", "closed": False}],
                  normals=np.tile(np.array([0, 0, 1], np.float32), (3, 1)))
    for sampler in SAMPLERS:
        Renderer(scene, threads=1, sampler=sampler).render()
    jit.mark_warm()
    return time.perf_counter() - start


def kernels_compiled() -> bool:
    """Whether the kernels are compiled and cached on disk (else the first render compiles them,
    which takes a while: callers say so, then call warm_up)."""
    return jit.is_warm()
