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

import copy
import math
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from . import adaptive, bsdf, jit, light_paths, lobes, wavefront
from . import light_vertices as light_vertices_module
from .camera import Camera
from .geometry import Geometry
from .lights import LightSampler
from .materials import material_tables
from .microfacet_tables import shipped_tables
from .scene import DEFAULT_RENDER, FRESNEL_MODELS, Scene

CHUNK = 1 << 13           # paths per chunk: measured best (8k-16k) for Python overhead vs cache
PASS_PATHS = 1 << 17      # aim for about this many paths per progressive pass
JOB_MULTIPLE = 4          # a pass's jobs come in multiples of this: 1, 2 or 4 threads end together
SAMPLERS = ("stratified", "independent")
# Light paths traced per camera path when the light tracer runs (light_paths.py): the value of
# least relMSE x time on cornell_spheres at 32 spp (tools/measure_caustics_split.py; README,
# Caustics). From 1/64 to 1/8 the product is flat within the timing noise; more light paths only
# cost time, since the camera paths' own noise then dominates even in the caustics.
LIGHT_PATHS_PER_CAMERA_PATH = 0.125
_NO_ROWS = np.zeros((0, 3))     # film: no class-A image


@dataclass
class RenderResult:
    """Per-pixel sums (row 0 = top) of the camera samples and of their squares, and of the light
    tracer's splats; with batches, sums of each pass's image and light image and their squares;
    plus counters."""
    width: int
    height: int
    sum: np.ndarray
    sum_sq: np.ndarray
    light_sum: np.ndarray | None = None
    batch_sum: np.ndarray | None = None
    batch_sq: np.ndarray | None = None
    light_batch_sum: np.ndarray | None = None
    light_batch_sq: np.ndarray | None = None
    # With batches, each pass's whole image (camera samples plus the light tracer's share) and,
    # in the hybrid, the light tracer's share alone, float32 (H, W, 3) in pass order: the
    # validator estimates the variance of any linear statistic (a tile mean, the image mean, a
    # filtered sum) from their spread, and knows which light only the light tracer carries.
    batch_images: list = field(default_factory=list)
    light_batch_images: list = field(default_factory=list)
    spp: int = 0
    light_paths: int = 0
    light_in_image: bool = False     # the hybrid: the light tracer's splats are part of the image
    batches: int = 0
    nan_count: int = 0
    time_s: float = 0.0
    build_s: float = 0.0
    embree_time_s: float = 0.0
    rays: int = 0
    threads: int = 1
    cancelled: bool = False
    stats: dict = field(default_factory=dict)
    stages: dict = field(default_factory=dict)   # Renderer.stages(): what the scene runs, skips
    # Adaptive sampling (tracer/adaptive.py): each pixel's samples (None: spp everywhere) and
    # its two halves' sums, the settings, the share of pixels still sampling, and the light
    # tracer's half A and per-pass sums for its variance.
    spp_budget: int = 0
    noise_threshold: float = 0.0
    sample_count: np.ndarray | None = None
    halves: adaptive.Halves | None = None
    active_share: float = 1.0
    light_paths_a: int = 0
    light_pass_sq: np.ndarray | None = None
    light_passes: int = 0

    def mean(self) -> np.ndarray:
        """The image: per-pixel mean radiance (each pixel's sum over its own sample count),
        float32 (H, W, 3), linear."""
        if self.spp == 0:
            return np.zeros_like(self.sum, dtype=np.float32)
        # Divided in float64 and rounded once into the float32 image, a band at a time, without
        # a float64 copy of the image on the way (1.5 GB at 8192x8192).
        image = np.empty(self.sum.shape, np.float32)
        light = self.light_in_image and self.light_paths
        rows = max(1, (1 << 14) // self.width)
        for r in range(0, image.shape[0], rows):
            band = slice(r, r + rows)
            if self.halves is None:
                part = self.sum[band] / self.spp
            else:
                end = min(r + rows, self.height)
                part = self.halves.mean(slice(r * self.width, end * self.width)).reshape(
                    end - r, self.width, 3)
            if light:
                part += self.light_sum[band] / self.light_paths
            image[band] = part
        return image

    def samples(self) -> np.ndarray:
        """Each pixel's camera samples, int32 (H, W)."""
        if self.sample_count is not None:
            return self.sample_count
        return np.full((self.height, self.width), self.spp, np.int32)

    @property
    def saved_share(self) -> float:
        """The share of the sample budget (spp_budget in every pixel) adaptive sampling saved."""
        budget = self.spp_budget * self.width * self.height
        if self.sample_count is None or budget == 0:
            return 0.0
        return 1.0 - float(self.sample_count.sum(dtype=np.int64)) / budget

    def light_image(self) -> np.ndarray:
        """The light tracer's splats per light path, float64 (H, W, 3): its part of the hybrid's
        image, or pure light tracing's whole image."""
        if self.light_sum is None:
            return np.zeros_like(self.sum)
        return self.light_sum / max(self.light_paths, 1)

    def variance_of_mean(self) -> np.ndarray:
        """Per-pixel variance of the mean image, float64 (H, W, 3): see variance_and_dof."""
        return self.variance_and_dof()[0]

    def variance_and_dof(self):
        """Per-pixel variance of the mean image and its degrees of freedom, (H, W, 3) and a number.

        With K >= 2 batches (Renderer.render(batches=K)), from the spread of the K passes'
        images (K - 1 degrees of freedom): the light tracer's splats have no per-sample variance,
        and where rare paths carry much of the light the per-sample variance underestimates the
        error far more than batch means do. Without batches, from the camera samples' sums of
        squares (n - 1), which then leave the light tracer's part out.
        """
        if self.batches >= 2 and self.batch_sum is not None:
            return _variance_of_mean(self.batch_sum, self.batch_sq, self.batches), \
                self.batches - 1
        if self.halves is not None:
            return self._adaptive_variance_and_dof()
        n = self.spp
        if n < 2:
            return np.full_like(self.sum, np.inf), 1
        return _variance_of_mean(self.sum, self.sum_sq, n), n - 1

    def _adaptive_variance_and_dof(self):
        """With per-pixel sample counts: the variance of the mean of the halves' means from each
        half's samples (count - 1 degrees of freedom) plus, in the hybrid, the light tracer's
        from its passes; the degrees of freedom are the smallest of any pixel's half
        (conservative for the tests)."""
        variance, dof = self.halves.variance_of_mean()
        variance = variance.reshape(self.sum.shape)
        if self.light_in_image and self.light_passes >= 2:
            variance = variance + self.light_variance_of_mean()
            dof = min(dof, self.light_passes - 1)
        return variance, max(dof, 1)

    def light_variance_of_mean(self) -> np.ndarray:
        """Per-pixel variance of light_image() from its batches (K - 1 degrees of freedom)."""
        if self.light_pass_sq is not None and self.light_passes >= 2:
            # Passes of unequal light path counts L_k and sums S_k: the variance of one light
            # path's splats is sum_k (S_k - L_k mean)^2 / L_k / (K - 1), that of the mean
            # that over L.
            total, k = self.light_paths, self.light_passes
            spread = self.light_pass_sq - self.light_sum * self.light_sum / total
            return np.maximum(spread, 0.0) / (k - 1) / total
        if self.batches < 2 or self.light_batch_sum is None:
            return np.full_like(self.sum, np.inf)
        return _variance_of_mean(self.light_batch_sum, self.light_batch_sq, self.batches)

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
        """(paths, next paths, shadow rays (a light sample and a light-vertex connection per
        path), radiance, radiance without light vertices (a pilot's), active rows, counters,
        lobe scratch, Principled parameter scratch, light vertices) for CHUNK paths."""
        if not hasattr(self, "buffers"):
            self.buffers = (wavefront.new_paths(CHUNK), wavefront.new_paths(CHUNK),
                            wavefront.new_shadows(2 * CHUNK), np.empty((CHUNK, 3)),
                            np.empty((CHUNK, 3)),
                            np.empty(CHUNK, np.int64), np.zeros(len(wavefront.STATS), np.int64),
                            np.empty((lobes.MAX_LOBES, lobes.FIELDS)), np.empty(lobes.P_FIELDS),
                            light_vertices_module.new_light_vertices(CHUNK))
        return self.buffers

    def light(self):
        """(light paths, next light paths, camera connections) for CHUNK light paths."""
        if not hasattr(self, "light_buffers"):
            self.light_buffers = (light_paths.new_light_paths(CHUNK),
                                  light_paths.new_light_paths(CHUNK), wavefront.new_shadows(CHUNK))
        return self.light_buffers


class Renderer:
    """A scene prepared for rendering: camera, Embree geometry, materials and lights."""

    def __init__(self, scene: Scene, threads: int = 2, next_event: bool = True,
                 sampler: str = "stratified", caustics: bool | str | None = None,
                 light_paths_per_camera_path: float = LIGHT_PATHS_PER_CAMERA_PATH,
                 geometry: Geometry | None = None, env_sampling: bool = True,
                 light_vertices: bool | None = None, light_vertex_pilot: bool = True):
        """next_event=False turns light sampling off (BSDF sampling only): a second, independent
        estimator of the same image, which tests use to check the first one. caustics=False
        renders with the path tracer alone (default: the scene's render setting); the light
        tracer runs only where it has something to do (light_paths.caustics_tables).
        caustics="pure" runs pure light tracing beside a full path tracer, for tests: the
        result's light image (light_sum / light_paths) is then a second estimate of the image
        but for emitters seen directly or through specular vertices only.

        sampler "stratified" draws each pixel's camera samples (pixel and lens position) and the
        light and BSDF samples of the first bounces from Owen-scrambled Sobol points,
        "independent" from a hash of the path's key. Both are unbiased; the stratified one
        converges faster, but its samples are not independent, so the per-pixel variance from
        the sums over-estimates the error of the mean. The Cycles validator uses "independent"
        for honest variances.

        geometry: an already built Geometry of the same positions, triangles and normals (the
        viewport keeps its BVH while materials, lamps, world or camera change).
        env_sampling=False samples an environment map's directions uniformly instead of by its
        image (an unbiased, noisier estimator, for measurements and tests).

        light_vertices=False leaves out the connections of camera paths to light vertices
        (light_vertices.py; default: the scene's render setting): the same image, noisier where
        surfaces next to lamps light the scene. They run only where they can: light sampling on,
        a lamp that starts them, a diffuse surface and a max depth of 2 or more. Where they run,
        an adaptive render measures whether they pay (render, _pilot_choice) unless
        light_vertex_pilot=False, which keeps them throughout as a fixed-sample render does.
        """
        if sampler not in SAMPLERS:
            raise ValueError(f"sampler: expected one of {SAMPLERS}, got {sampler!r}")
        self.sampler = sampler
        start = time.perf_counter()
        self.scene = scene
        self.threads = max(1, int(threads))
        self.next_event = next_event
        self.camera = Camera(scene.camera)
        self.geometry = (Geometry(scene.positions, scene.triangles, scene.normals)
                         if geometry is None else geometry)
        self.materials = material_tables(scene.materials, scene.material_ids, scene.images,
                                         scene.texcoords)
        self.tables = shipped_tables()
        kind = self.materials.kind
        self.lights = LightSampler(scene, self.geometry, self.materials.radiance,
                                   env_sampling=env_sampling)
        render = scene.render
        self.max_depth = int(render["max_depth"])
        self.seed = int(render["seed"])
        self.fresnel = FRESNEL_MODELS.index(render["fresnel"])
        want_caustics = render.get("caustics", True) if caustics is None else caustics
        # Built whatever the camera, so that with_camera can switch the light tracer either way.
        self._caustic_tables = (light_paths.caustics_tables(scene, self.lights, self.geometry,
                                                            kind, pure=want_caustics == "pure")
                                if want_caustics else None)
        self._use_camera_for_caustics()
        self.light_paths_per_camera_path = float(light_paths_per_camera_path)
        self.light_vertices, self._why_vertices = self._choose_light_vertices(
            render.get("light_vertices", True) if light_vertices is None else light_vertices)
        self.light_vertex_pilot = bool(light_vertex_pilot)
        self._buffers = _Buffers()
        self._film_lock = threading.Lock()
        self.build_s = time.perf_counter() - start

    def with_camera(self, camera: dict) -> "Renderer":
        """This renderer with another camera (scene format), sharing geometry and tables."""
        other = copy.copy(self)
        other.scene = copy.copy(self.scene)
        other.scene.camera = camera
        other.camera = Camera(camera)
        other._use_camera_for_caustics()
        other._buffers = _Buffers()
        other._film_lock = threading.Lock()
        return other

    def _use_camera_for_caustics(self):
        """Run the light tracer (where the scene has one) unless the camera is orthographic:
        the light tracer connects to a pinhole or a thin lens, so an orthographic camera leaves
        every path to the path tracer (the same image, noisier caustics)."""
        self.caustics = None if self.camera.ortho else self._caustic_tables
        # The path tracer leaves the light tracer's paths to it (not in the pure test mode).
        self.split = self.caustics is not None and not self.caustics.pure

    def stages(self) -> dict:
        """Which optional stages this scene runs: {stage: (runs, why)}."""
        used = self.materials.kind[self.materials.of_triangle]
        dielectric = bool(np.isin(used, (bsdf.GLASS, bsdf.REFRACTION)).any())
        layered = bool((used == bsdf.LAYERED).any())
        lights = self.lights.tables
        next_event = bool(self.next_event and lights.cdf.shape[0] > 0 and lights.cdf[-1] > 0.0)
        world, env = bool(lights.has_world), bool(lights.has_env)
        if not self.scene.render.get("caustics", True):
            why_no_light = "caustics off"
        elif self.camera.ortho:
            why_no_light = "orthographic camera"
        else:
            why_no_light = "no smooth mirror or glass, or no lamp that rays can hit sees one"
        return {
            "lens sampling": (self.camera.has_lens, "depth of field" if self.camera.has_lens
                              else "no depth of field"),
            "dielectric sampling": (dielectric, "glass" if dielectric else "no smooth glass"),
            "microfacet sampling": (layered, "rough or Principled surfaces" if layered
                                    else "no rough or Principled surfaces"),
            "next-event estimation": (next_event, "lamps or world light to sample" if next_event
                                      else "no lamps and a black world"),
            "world": (world, "world light" if world else "black world"),
            "environment": (env, "an environment map" if env else "no environment map"),
            "light tracing": (self.caustics is not None,
                              "lamps through mirrors and glass" if self.caustics is not None
                              else why_no_light),
            "light vertices": (self.light_vertices, self._why_vertices),
        }

    def _choose_light_vertices(self, wanted: bool) -> tuple[bool, str]:
        """(whether camera paths connect to light vertices, why or why not)."""
        if not wanted:
            return False, "light vertices off"
        if not self.next_event:
            return False, "no light sampling"
        if self.max_depth < 2:
            return False, "max depth below 2"
        if not light_vertices_module.starts_light_vertices(self.lights.tables):
            return False, "no mesh light or area lamp with a spread, MIS, shadows and diffuse rays"
        used = self.materials.kind[self.materials.of_triangle]
        if not np.any(used == bsdf.DIFFUSE):
            return False, "no diffuse surface"
        return True, "mesh lights or area lamps light diffuse surfaces"

    # -- one chunk of paths ---------------------------------------------------------------

    def trace_chunk(self, start: int, n: int, in_pass: int, first_sample: int, pixels: np.ndarray,
                    bits: int, total: np.ndarray, total_sq: np.ndarray, class_a: np.ndarray,
                    vertices: bool | None = None, pilot: tuple | None = None):
        """Trace paths start .. start + n of a pass (in_pass samples per pixel of `pixels`, or of
        every pixel when it is empty; the first sample being first_sample) and add them to the
        (pixels, 3) sums, class-A samples also to `class_a` if it has rows (adaptive.py), with
        light vertices if `vertices` (default: where they run). pilot: (sums, sums of squares)
        that get the same samples without light vertices (wavefront.emitters). Returns (NaN/Inf
        samples, event counters)."""
        geom, lights, mats = self.geometry, self.lights.tables, self.materials
        mesh = geom.mesh
        (paths, out, shadows, radiance, without, active, stats, scratch, params,
         lv) = self._buffers.get()
        without = without[:n] if pilot is not None else without[:0]
        stats[:] = 0
        stratified = self.sampler == "stratified"
        wavefront.clear(radiance, n)
        wavefront.clear(without, without.shape[0])
        wavefront.generate(self.camera.params(), self.seed, start, in_pass, first_sample, pixels,
                           bits, stratified, n, paths, stats)
        last_connection = -1
        if self.light_vertices and (vertices is None or vertices):
            # Every camera path's light vertex, before its first bounce (light_vertices.py).
            last_connection = self.max_depth - 2
            n_light = light_vertices_module.emit(lights, mesh, bits, stratified, n, paths.key,
                                                 paths.sample, lv)
            prim, u, v, _ = geom.intersect(lv.o32[:n_light], lv.d32[:n_light],
                                           lv.tmax[:n_light])
            stats[wavefront.VERTEX_RAYS] += n_light
            light_vertices_module.hits(lights, mesh, mats, n_light, lv, prim, u, v)
        m = n
        for depth in range(self.max_depth + 1):
            prim, u, v, t = geom.intersect(paths.o32[:m], paths.d32[:m], paths.tmax[:m])
            kept = wavefront.emitters(lights, mats, self.next_event, self.split,
                                      depth, self.max_depth, m, paths, prim, t, radiance,
                                      without, active, stats)
            if kept == 0:
                break
            m, n_shadow = wavefront.materials(lights, mesh, mats, self.tables, self.fresnel,
                                              self.next_event, bits, stratified, depth, kept,
                                              active, paths, prim, u, v, out, shadows, radiance,
                                              without, scratch, params, stats, lv,
                                              last_connection)
            if n_shadow:
                blocked = geom.occluded(shadows.o32[:n_shadow], shadows.d32[:n_shadow],
                                        shadows.tmax[:n_shadow])
                wavefront.shadow_rays(n_shadow, blocked, shadows, radiance, without)
            paths, out = out, paths
            if m == 0:
                break
        with self._film_lock:
            bad = wavefront.film(radiance, n, start, in_pass, first_sample, pixels, total,
                                 total_sq, class_a)
            if pilot is not None:
                wavefront.film(without, n, start, in_pass, first_sample, pixels, *pilot,
                               _NO_ROWS)
        return bad, stats.copy()

    def trace_light_chunk(self, pass_index: int, start: int, n: int):
        """Trace light paths start .. start + n of a pass; returns their splats that reached the
        camera, (pixels, contributions). The caller adds them in chunk order, so that the image
        does not depend on which thread finished first (float sums depend on their order)."""
        geom, lights, mats, caustics = self.geometry, self.lights.tables, self.materials, self.caustics
        mesh, cam = geom.mesh, self.camera.params()
        paths, out, connections = self._buffers.light()
        m = light_paths.emit_light_paths(caustics, lights, mesh, self.seed, pass_index, start, n,
                                         paths)
        pixels, contributions = [], []
        for _ in range(self.max_depth):
            if m == 0:
                break
            prim, u, v, _ = geom.intersect(paths.o32[:m], paths.d32[:m], paths.tmax[:m])
            m, n_conn = light_paths.light_bounce(caustics, lights, mesh, mats, cam, self.fresnel,
                                                 self.max_depth, m, paths, prim, u, v, out,
                                                 connections)
            if n_conn:
                visible = geom.occluded(connections.o32[:n_conn], connections.d32[:n_conn],
                                        connections.tmax[:n_conn]) != 0   # Embree: 0 if blocked
                pixels.append(connections.path[:n_conn][visible])
                contributions.append(connections.contrib[:n_conn][visible])
            paths, out = out, paths
        if not pixels:
            return np.zeros(0, np.int64), np.zeros((0, 3))
        return np.concatenate(pixels), np.concatenate(contributions)

    def object_index(self, per_side: int = 2) -> np.ndarray:
        """The object each pixel sees first, int32 (H, W, per_side^2): one camera ray through
        the lens centre at each of per_side x per_side points of the pixel; -1 where a ray
        misses (the validator names the objects under the tiles that fail)."""
        w, h = self.camera.width, self.camera.height
        grid = (np.arange(per_side) + 0.5) / per_side
        u = np.stack(np.meshgrid(grid, grid, indexing="ij"), 0).reshape(2, -1)
        pixels = np.repeat(np.arange(w * h, dtype=np.int64), u.shape[1])
        o, d, far = self.camera.generate(pixels, np.tile(u, (1, w * h)), None)
        prim, _, _, _ = self.geometry.intersect(np.ascontiguousarray(o.T, np.float32),
                                                np.ascontiguousarray(d.T, np.float32),
                                                far.astype(np.float32))
        objects = np.where(prim >= 0, self.scene.object_ids[np.maximum(prim, 0)], -1)
        return objects.astype(np.int32).reshape(h, w, -1)

    # -- passes ----------------------------------------------------------------------------

    def render(self, spp: int | None = None, progress=None, batches: int | None = None,
               noise_threshold: float | None = None, min_spp: int | None = None,
               stop: threading.Event | None = None) -> RenderResult:
        """Render progressively; `progress(result, pass_index, pass_count)` may return False to
        stop (with adaptive sampling pass_count is an estimate: result.spp / spp is the share of
        the budget done).

        Each pass adds its samples to the image, and the light tracer (where it runs) as many
        light paths per camera path as light_paths_per_camera_path says. `batches=K` renders in
        K passes (of equal samples, give or take one) and keeps each pass's image as a batch, for
        variances of the mean from independent batches (RenderResult.variance_and_dof).

        noise_threshold > 0 (default: the scene's noise_threshold) samples adaptively
        (tracer/adaptive.py): spp is then each pixel's most, min_spp (default the scene's; 0 =
        Cycles' automatic minimum) its least. Batches need equal samples in every pixel: with
        batches adaptive sampling is off.

        stop: once set, the chunks not yet started are skipped and the render ends cancelled
        without counting its unfinished pass, whose samples are already in the sums: the result
        is then no image (the viewport drops it for the next one's). Waits one chunk at most.
        """
        render = self.scene.render
        spp = int(spp if spp is not None else render["spp"])
        threshold = 0.0 if batches is not None else float(
            noise_threshold if noise_threshold is not None
            else render.get("noise_threshold", DEFAULT_RENDER["noise_threshold"]))
        least = int(min_spp if min_spp is not None
                    else render.get("min_spp", DEFAULT_RENDER["min_spp"]))
        if threshold > 0.0 and least <= 0:
            least = adaptive.auto_min_spp(threshold)
        adapt = threshold > 0.0 and adaptive.first_check(least) < spp
        w, h = self.camera.width, self.camera.height
        npix = w * h
        result = RenderResult(w, h, np.zeros((h, w, 3)), np.zeros((h, w, 3)), threads=self.threads,
                              build_s=self.build_s, light_in_image=self.split,
                              stages=self.stages(), spp_budget=spp,
                              noise_threshold=threshold if adapt else 0.0)
        bits = max(1, (spp - 1).bit_length())   # sample indices run over [0, 2^bits)
        traces_light = self.caustics is not None
        keep_batches = batches is not None
        total, total_sq = result.sum.reshape(-1, 3), result.sum_sq.reshape(-1, 3)
        all_pixels = np.zeros(0, np.int64)      # film and generate: every pixel, in order
        sampling = all_pixels
        halves = None
        if adapt:
            result.sample_count = np.zeros((h, w), np.int32)
            halves = result.halves = adaptive.Halves(w, h, threshold, least)
        if traces_light:
            result.light_sum = np.zeros((h, w, 3))
            pass_light = np.zeros((npix, 3))
            if adapt:
                light_half, pass_light_a = np.zeros((npix, 3)), np.zeros((npix, 3))
                result.light_pass_sq = np.zeros((h, w, 3))
        if keep_batches:
            result.batch_sum, result.batch_sq = np.zeros((h, w, 3)), np.zeros((h, w, 3))
            pass_sum = np.zeros((npix, 3))
            if traces_light:
                result.light_batch_sum = np.zeros((h, w, 3))
                result.light_batch_sq = np.zeros((h, w, 3))
            passes = max(1, min(batches, spp))
        embree_before, rays_before = self.geometry.embree_time, self.geometry.ray_count
        counters = np.zeros(len(wavefront.STATS), np.int64)
        # Adaptive renders measure whether light vertices pay (_pilot_choice): until the first
        # error estimate every path also carries its light as it would without them.
        pilot = None
        if adapt and self.light_vertices and self.light_vertex_pilot:
            pilot = (np.zeros((npix, 3)), np.zeros((npix, 3)))
        vertices = self.light_vertices
        pilot_rays = 0
        start = time.perf_counter()
        light_share = 1.0
        union = None                            # adaptive: the pixels either half samples
        k = 0
        with ThreadPoolExecutor(max_workers=self.threads) as pool:
            while result.spp < spp:
                done = result.spp
                if adapt:
                    # A pass stays inside one window, whose half's pixels take its samples.
                    window_end = min(spp, (done // adaptive.STEP + 1) * adaptive.STEP)
                    sampling = halves.pixels(done)
                    if sampling.size == 0:
                        result.spp = window_end     # this half has stopped everywhere
                        continue
                n_rows = npix if sampling is all_pixels else sampling.shape[0]
                if keep_batches:
                    in_pass = spp // passes + (1 if k < spp % passes else 0)
                else:
                    # Enough paths per pass to fill the threads' chunks; no more samples than
                    # reach the budget or adaptive sampling's window's end.
                    in_pass = max(1, min(PASS_PATHS // n_rows, CHUNK, spp - done))
                    if adapt:
                        in_pass = min(in_pass, window_end - done)
                count = n_rows * in_pass
                film, film_sq, class_a = total, total_sq, _NO_ROWS
                if keep_batches:
                    film = pass_sum
                    pass_sum[:] = 0.0
                elif adapt:
                    film, film_sq, class_a = halves.film(done)
                # Chunks hold whole pixels' samples, so that each pixel's sum is added in the same
                # order with any number of threads (float addition is not associative).
                jobs = _jobs(0, count, in_pass)
                rays_then = self.geometry.ray_count
                for bad, stats in pool.map(
                        lambda job: (0, 0) if stop is not None and stop.is_set() else
                        self.trace_chunk(job[0], job[1], in_pass, done, sampling, bits, film,
                                         film_sq, class_a, vertices, pilot), jobs):
                    result.nan_count += bad
                    counters += stats
                if pilot is not None:
                    pilot_rays += self.geometry.ray_count - rays_then
                if stop is not None and stop.is_set():
                    result.cancelled = True
                    break
                n_light = 0
                if traces_light:
                    n_light = max(2, int(round(self.light_paths_per_camera_path * npix * in_pass
                                               * light_share)))
                    n_a = n_light // 2 if adapt else n_light
                    result.nan_count += self._trace_light_pass(
                        pool, k, n_light, n_a, pass_light, pass_light_a if adapt else None,
                        counters)
                    result.light_sum.reshape(-1, 3)[:] += pass_light
                    result.light_paths += n_light
                    if adapt:
                        light_half += pass_light_a
                        result.light_paths_a += n_a
                        result.light_pass_sq.reshape(-1, 3)[:] += pass_light * pass_light / n_light
                        result.light_passes += 1
                if keep_batches:
                    total += pass_sum
                    image = pass_sum / in_pass
                    if traces_light:
                        light_image = pass_light / n_light
                        _add_batch(result.light_batch_sum, result.light_batch_sq, light_image)
                        if self.split:
                            image += light_image
                            result.light_batch_images.append(
                                light_image.reshape(h, w, 3).astype(np.float32))
                    _add_batch(result.batch_sum, result.batch_sq, image)
                    result.batch_images.append(image.reshape(h, w, 3).astype(np.float32))
                    result.batches += 1
                result.spp += in_pass
                if adapt:
                    halves.add(done, in_pass)
                    np.add(halves.count[0], halves.count[1], out=result.sample_count.reshape(-1))
                    np.add(halves.sum[0], halves.sum[1], out=total)
                    np.add(halves.sum_sq[0], halves.sum_sq[1], out=total_sq)
                    if pilot is not None and result.spp == halves.first:
                        light = (result.light_sum.reshape(-1, 3) / result.light_paths
                                 if self.split else 0.0)
                        vertices, why = _pilot_choice(total, total_sq, pilot, result.spp, light,
                                                      halves, spp, pilot_rays, counters)
                        result.stages["light vertices"] = (vertices, why)
                        pilot = None
                    if result.spp < spp:
                        halves.check(result.spp, (result.light_sum.reshape(-1, 3), light_half,
                                                  result.light_paths, result.light_paths_a)
                                     if self.split else ())
                        if halves.union() is not union:      # a check changed the halves
                            union = halves.union()
                            result.active_share = union.shape[0] / npix
                            if traces_light:
                                light_share = _share_on(pass_light, union)
                        sampling = union
                result.time_s = time.perf_counter() - start
                result.embree_time_s = self.geometry.embree_time - embree_before
                result.rays = self.geometry.ray_count - rays_before
                result.stats = dict(zip(wavefront.STATS, counters.tolist()))
                k += 1
                converged = sampling.shape[0] == 0 and sampling is not all_pixels
                estimate = (passes if keep_batches else k if converged
                            else k + math.ceil((spp - result.spp) / max(in_pass, 1)))
                if progress is not None and progress(result, k, estimate) is False:
                    result.cancelled = result.spp < spp and not converged
                    break
                if converged:
                    break                 # every pixel has converged
        result.time_s = time.perf_counter() - start
        return result

    def _trace_light_pass(self, pool, pass_index, n_light, n_a, film, film_a, counters) -> int:
        """Trace a pass's n_light light paths into film (rows of (pixels, 3)); film_a (if not
        None) gets those of the first n_a, adaptive sampling's half A of the light tracer.
        Returns how many splats were NaN or Inf (left out)."""
        film[:] = 0.0
        if film_a is not None:
            film_a[:] = 0.0
        # Jobs never straddle n_a, so each job's splats belong to one half.
        jobs = _jobs(0, n_a, 1) + _jobs(n_a, n_light, 1)
        bad = 0
        for (first, _), (pixels, contributions) in zip(jobs, pool.map(
                lambda job: self.trace_light_chunk(pass_index, job[0], job[1]), jobs)):
            bad += wavefront.splat(pixels, contributions, film)
            if film_a is not None and first < n_a:
                wavefront.splat(pixels, contributions, film_a)
            counters[wavefront.CAUSTIC_SPLATS] += len(pixels)
        return bad


def _jobs(begin: int, end: int, unit: int) -> list:
    """(start, count) jobs covering begin .. end in whole units (a pixel's samples in a pass),
    at most CHUNK paths each, of equal size give or take a unit, and as many as the next multiple
    of JOB_MULTIPLE (the units allowing): adaptive sampling's small passes then keep every thread
    busy. The split depends on the counts alone, so the image does not depend on the threads."""
    units = (end - begin) // unit
    if units <= 0:
        return []
    count = -(-units // max(1, CHUNK // unit))
    count = min(units, -(-count // JOB_MULTIPLE) * JOB_MULTIPLE)
    bounds = [begin + i * units // count * unit for i in range(count + 1)]
    return [(a, b - a) for a, b in zip(bounds, bounds[1:])]


def _pilot_choice(total, total_sq, without, n, light, halves, most, rays, counters):
    """(whether the rest of an adaptive render uses light vertices, why), from its first n
    samples in every pixel: their sums and sums of squares with light vertices (total,
    total_sq) and without (`without`), `light` the light tracer's image (or 0), `halves` the
    render's adaptive.Halves, `most` its cap, `rays` the camera rays the samples took and
    `counters` their wavefront.STATS.

    Each estimator's cost is the samples adaptive sampling is predicted to give all pixels
    (adaptive.predicted_samples) times its rays per sample; without light vertices a path saves
    their rays (the ray from the lamp and the connections). Rays, not seconds, so that the
    choice, and the image, depend on the seed alone. A pixel's own samples sway the choice by
    one pixel's share of an image-wide sum; either way every sample is unbiased."""
    saved = counters[wavefront.VERTEX_RAYS] + counters[wavefront.CONNECTIONS]
    mean = total / n + light
    cost = [float(adaptive.predicted_samples(s, sq, n, mean, halves.threshold, halves.first,
                                             most, halves.width, halves.height).sum()) * r
            for (s, sq), r in (((total, total_sq), rays), (without, rays - saved))]
    ratio = cost[0] / cost[1] if cost[1] > 0.0 else 1.0
    if ratio <= 1.0:
        return True, (f"mesh lights or area lamps light diffuse surfaces; measured: {ratio:.2f}x "
                      "the rays to the noise threshold with them")
    return False, f"measured: {ratio:.2f}x the rays to the noise threshold with them"


def _share_on(light, pixels) -> float:
    """The share of a light image's energy (rows of (pixels, 3)) on the given pixels."""
    whole = float(light.sum())
    return float(light[pixels].sum()) / whole if whole > 0.0 else 1.0


def _add_batch(total, total_sq, image):
    """Add one batch image, (pixels, 3) rows, to (H, W, 3) sums of batches and of their squares."""
    total.reshape(-1, 3)[:] += image
    total_sq.reshape(-1, 3)[:] += image * image


def describe_stages(stages: dict) -> tuple[str, str]:
    """('stage (why), ...' of the stages run, the same of those skipped) for a summary line."""
    run = ", ".join(f"{name} ({why})" for name, (runs, why) in stages.items() if runs)
    skipped = ", ".join(f"{name} ({why})" for name, (runs, why) in stages.items() if not runs)
    return run or "none", skipped or "none"


def _variance_of_mean(total, total_sq, k):
    """The variance of the mean of k independent values (samples, or batch images) per pixel,
    from their sum and sum of squares."""
    return np.maximum((total_sq - total * total / k) / (k - 1), 0.0) / k


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
    # A diffuse triangle and a mirror one under a lamp that rays can hit: the light tracer runs.
    triangles = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0],
                          [-1, -1, 0.5], [1, -1, 0.5], [0, 1, 0.5]], np.float32)
    lamp = {"name": "lamp", "kind": "point", "position": [0.0, 0.0, 1.0],
            "intensity": [1.0, 1.0, 1.0], "radius": 0.1}
    scene = Scene(positions=triangles, triangles=np.array([[0, 1, 2], [3, 4, 5]], np.int32),
                  material_ids=np.array([0, 1], np.int32), object_ids=np.array([0, 1], np.int32),
                  materials=[{"name": "grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]},
                             {"name": "mirror", "kind": "mirror", "color": [1.0, 1.0, 1.0]}],
                  lights=[lamp], camera=camera, world={"color": [0.1, 0.1, 0.1]},
                  render={"spp": 1, "max_depth": 2, "seed": 0, "fresnel": "exact"},
                  objects=[{"name": "triangle", "closed": False}, {"name": "mirror", "closed": False}],
                  normals=np.tile(np.array([0, 0, 1], np.float32), (6, 1)))
    for sampler in SAMPLERS:
        Renderer(scene, threads=1, sampler=sampler).render()
    jit.mark_warm()
    return time.perf_counter() - start


def kernels_compiled() -> bool:
    """Whether the kernels are compiled and cached on disk (else the first render compiles them,
    which takes a while: callers say so, then call warm_up)."""
    return jit.is_warm()
