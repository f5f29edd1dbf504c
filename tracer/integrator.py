"""The wavefront path tracer: whole arrays of paths advance one bounce at a time.

A render is a sequence of passes, which a scheduler per mode hands out (tracer/passes.py: fixed
samples, batches, adaptive sampling); each pass is cut into fixed-size chunks of paths, and chunks
run on a thread pool (the compiled stages and Embree release the GIL). A chunk runs the stages of
tracer/wavefront.py bounce by bounce: generate, then per bounce one Embree call for every live
ray, emitters, materials, one Embree call for every shadow ray, shadow_rays; film adds the
finished chunk to the image. Every random number is keyed by seed, pixel, sample index and
dimension (tracer/sampler.py), so the image depends on the seed and sample count only, not on
the thread count or the chunking.
"""
from __future__ import annotations

import copy
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import (adaptive, jit, light_budget, light_groups, light_passes, light_tracer, lobes,
               mnee, passes, path_limits, photon_merging, wavefront)
from . import light_vertices as light_vertices_module
from .camera import Camera
from .counters import MNEE_PATHS
from .geometry import Geometry
from .lights.codes import WORLD
from .lights.tables import LightSampler
from .material_kinds import DIFFUSE, GLASS, LAYERED, PROGRAM, REFRACTION
from .materials import material_tables
from .media import camera_in_medium, media_tables
from .microfacet_tables import shipped_tables
from .passes import CHUNK
from .pixel_filter import make_filter, spread_splats
from .result import ExtraRows, RenderResult, Window, WindowSums
from .scene import Scene, material_field
from .settings import (FRESNEL_MODELS, LIGHT_PATHS_PER_CAMERA_PATH, SAMPLERS, SAMPLING,
                       RenderSettings)
from .shader import closures, program
from .shader.bump import with_view
from .shader.object_inputs import camera_table


NO_PHOTONS = photon_merging.new_photons(0)   # light_bounce records none


class _BudgetSlot:
    """The light-budget pilot's choice, once measured, shared by a renderer and its copies."""

    def __init__(self):
        self.lock = threading.Lock()
        self.budget = None


class _Buffers(threading.local):
    """This thread's chunk buffers, made once and reused by every chunk it runs; the radiance
    rows are `width` wide (light_groups.columns: Combined, then each light group's share)."""

    def __init__(self, width: int = 3):
        self.width = width

    def get(self):
        """(paths, next paths, shadow rays (a light sample and a light-vertex connection per
        path), radiance, radiance without light vertices (a pilot's), active rows, counters,
        lobe scratch, (Principled parameter, shader program register and program hit row)
        scratch, light vertices, the paths' denoising albedo and normal, their uncovered
        shares, their light passes' rows) for CHUNK paths."""
        if not hasattr(self, "buffers"):
            self.buffers = (wavefront.new_paths(CHUNK), wavefront.new_paths(CHUNK),
                            wavefront.new_shadows(2 * CHUNK),
                            np.zeros((CHUNK, self.width)), np.empty((CHUNK, 3)),
                            np.empty(CHUNK, np.int64), np.zeros(len(wavefront.STATS), np.int64),
                            np.empty((lobes.MAX_LOBES, lobes.FIELDS)),
                            (np.empty(lobes.P_FIELDS), program.new_registers(),
                             np.empty(CHUNK, np.int64)),
                            light_vertices_module.new_light_vertices(CHUNK),
                            (np.zeros((CHUNK, 3)), np.zeros((CHUNK, 3))), np.zeros(CHUNK),
                            np.zeros((CHUNK, light_passes.COLUMNS)))
        return self.buffers

    def light(self):
        """(light paths, next light paths, camera connections, their raster points) for CHUNK
        light paths."""
        if not hasattr(self, "light_buffers"):
            self.light_buffers = (light_tracer.new_light_paths(CHUNK),
                                  light_tracer.new_light_paths(CHUNK), wavefront.new_shadows(CHUNK),
                                  np.empty((CHUNK, 2)))
        return self.light_buffers

    def split(self, lamps_only: bool):
        """The Fresnel split's mirror rays for CHUNK paths, its scratch counters (its rays'
        Russian roulette and depth limits are not the paths' events) and lamps_only
        (wavefront.split_fresnel)."""
        if not hasattr(self, "split_buffers"):
            self.split_buffers = (wavefront.new_paths(CHUNK),
                                  np.zeros(len(wavefront.STATS), np.int64))
        return (*self.split_buffers, lamps_only)

    def photons(self):
        """A photon buffer for CHUNK light paths (photon merging)."""
        if not hasattr(self, "photon_buffer"):
            self.photon_buffer = photon_merging.new_photons(CHUNK)
        return self.photon_buffer


class Renderer:
    """A scene prepared for rendering: camera, Embree geometry, materials and lights."""

    def __init__(self, scene: Scene, settings: RenderSettings | None = None,
                 geometry: Geometry | None = None):
        """settings: every setting of the render (tracer/settings.py; default: the scene's).

        caustics=False renders with the path tracer alone; the light tracer runs only where it
        has something to do (light_tracer.caustics_tables). pure_light_tracing runs it beside a
        full path tracer, for tests: the result's light image (light_sum / light_paths) is then
        a second estimate of the image but for emitters seen directly or through specular
        vertices only. next_event=False turns light sampling off (BSDF sampling only): a second,
        independent estimator of the same image, which tests use to check the first one.

        sampler "stratified" draws each pixel's camera samples (pixel and lens position) and the
        light and BSDF samples of the first bounces from Owen-scrambled Sobol points,
        "independent" from a hash of the path's key. Both are unbiased; the stratified one
        converges faster, but its samples are not independent, so the per-pixel variance from
        the sums over-estimates the error of the mean. The Cycles validator uses "independent"
        for honest variances. env_sampling=False samples an environment map's directions
        uniformly instead of by its image (an unbiased, noisier estimator, for measurements and
        tests).

        light_vertices=False leaves out the connections of camera paths to light vertices
        (light_vertices.py): the same image, noisier where surfaces next to lamps light the
        scene. They run only where they can: light sampling on, a lamp that starts them, a
        diffuse surface and a max depth of 2 or more. Where they run, an adaptive render
        measures whether they pay (pilot.py) unless light_vertex_pilot=False, which keeps them
        throughout as a fixed-sample render does.

        geometry: an already built Geometry of the same positions, triangles and normals (the
        viewport keeps its BVH while materials, lamps, world or camera change).
        """
        settings = scene.settings() if settings is None else settings
        self.settings = settings
        self.sampler = settings.sampler
        start = time.perf_counter()
        self.scene = scene
        self.threads = settings.render_threads
        self.next_event = settings.next_event
        self.camera = Camera(scene.camera)
        self.pixel_filter = make_filter(settings.pixel_filter, settings.filter_width)
        self.geometry = (Geometry(scene.positions, scene.triangles, scene.normals)
                         if geometry is None else geometry)
        self.materials = with_view(material_tables(scene.materials, scene.material_ids,
                                                   scene.images, scene.texcoords, scene.objects,
                                                   scene.object_ids, self.camera),
                                   self.geometry.corners, self.camera)
        self.tables = shipped_tables()
        self.lights = LightSampler(scene, self.geometry, self.materials.radiance,
                                   env_sampling=settings.env_sampling)
        self.media = media_tables(scene, self.lights.tables)
        self.max_depth = settings.max_depth
        # Cycles' bounce limits and clamping, as the stages read them (path_limits.py).
        self.limits = path_limits.bounce_limits(
            settings.max_depth, settings.transparent_max_bounces, settings.diffuse_bounces,
            settings.glossy_bounces, settings.transmission_bounces,
            path_limits.caustics_bits(settings.caustics_reflective, settings.caustics_refractive))
        self.clamp = path_limits.clamp_limits(settings.sample_clamp_direct,
                                              settings.sample_clamp_indirect)
        self.seed = settings.seed
        self.fresnel = FRESNEL_MODELS.index(settings.fresnel)
        pure = settings.pure_light_tracing
        # Built whatever the camera, so that with_camera can switch the light tracer either way.
        self._caustic_tables = (light_tracer.caustics_tables(scene, self.lights, self.geometry,
                                                             self.materials, pure=pure)
                                if (settings.caustics and self._any_caustics()) or pure
                                else None)
        self._use_camera_for_caustics()
        used = np.unique(self.materials.of_triangle)
        # Shadow rays look through surfaces only where a program may be transparent.
        programs = used[self.materials.kind[used] == PROGRAM]
        flags = self.materials.programs.flags[programs]
        self.transparent_shadows = bool(np.any(flags & program.MAY_BE_TRANSPARENT))
        # Whether program_emitters runs: a program whose emission no light sample finds.
        self.programs_emit = bool(np.any(flags & program.EMISSION_VARIES))
        # The film's alpha: Film > Transparent, or a Holdout, which Cycles renders either way.
        self.film_transparent = settings.film_transparent
        self.clear = clear_glass(scene.materials, self.materials.kind, settings)
        # The Fresnel split runs where glass chooses between reflection and refraction; where
        # lamps are the only light it shares (the world's it does not), its mirror rays that
        # cross none are not traced.
        self.fresnel_split = settings.fresnel_split and bool(np.any(self.materials.kind[used]
                                                                    == GLASS))
        self._lamps_only = not (self.lights.tables.sun_one_minus_cos.shape[0] > 0
                                or self.programs_emit
                                or np.any(self.materials.radiance[used] > 0.0))
        self.alpha = self.film_transparent or bool(np.any(flags & program.HAS_HOLDOUT))
        # The setting's light paths per camera path, or 0: the light-budget pilot's, measured
        # on first use and shared with this renderer's copies (light_budget.py).
        self._light_paths = settings.light_paths_per_camera_path
        self._budget = _BudgetSlot()
        self.light_vertices, self._why_vertices = self._choose_light_vertices(
            settings.light_vertices)
        self.light_vertex_pilot = settings.light_vertex_pilot
        self.features = settings.wants_features
        self.light_passes = settings.light_passes
        # The light groups' passes (light_groups.py): the scene's groups, when asked for.
        self.light_groups = light_groups.wanted(scene, settings)
        self._buffers = _Buffers(light_groups.columns(len(self.light_groups)))
        self._film_lock = threading.Lock()
        self.build_s = time.perf_counter() - start

    def with_camera(self, camera: dict) -> "Renderer":
        """This renderer with another camera (scene format), sharing geometry and tables."""
        other = self._copy()
        other._budget = _BudgetSlot()       # the pilot measures through the camera
        other.scene = copy.copy(self.scene)
        other.scene.camera = camera
        other.camera = Camera(camera)
        other.materials = with_view(self.materials._replace(camera=camera_table(other.camera)),
                                    self.geometry.corners, other.camera)
        if self.media.on:         # the stack at the camera
            other.media = media_tables(other.scene, self.lights.tables)
        other._use_camera_for_caustics()
        return other

    def with_seed(self, seed: int) -> "Renderer":
        """This renderer with another seed, sharing everything it built."""
        other = self._copy()
        other.seed = seed
        return other

    @property
    def light_paths_per_camera_path(self) -> float:
        """Light paths the light tracer traces per camera path: the setting's, or where it is 0
        and the light tracer splits the paths with the camera, the light-budget pilot's."""
        budget = self.light_budget()
        if budget is not None:
            return budget.ratio
        return self._light_paths or LIGHT_PATHS_PER_CAMERA_PATH

    def light_budget(self) -> "light_budget.Budget | None":
        """The light-budget pilot's choice (measured on first call), or None where the setting
        fixes the ratio or the light tracer does not split the paths."""
        if self._light_paths > 0.0 or not self.split:
            return None
        slot = self._budget
        with slot.lock:
            if slot.budget is None:
                slot.budget = light_budget.measure(self)
            return slot.budget

    def with_sampling(self, **overrides) -> "Renderer":
        """This renderer with other settings of the ones a render reads pass by pass (spp,
        batches, noise_threshold, min_spp, time_limit), sharing everything it built."""
        for key in overrides:
            if key not in SAMPLING:
                raise ValueError(f"with_sampling: {key} is fixed when a Renderer is built "
                                 f"(only {', '.join(SAMPLING)} may change)")
        other = self._copy()
        other._budget = _BudgetSlot()       # the pilot's size follows the samples
        other.settings = self.settings.replace(**overrides)
        return other

    def _copy(self) -> "Renderer":
        """A shallow copy with its own chunk buffers and film lock (renders may overlap)."""
        other = copy.copy(self)
        other._buffers = _Buffers(self._buffers.width)
        other._film_lock = threading.Lock()
        return other

    def _any_caustics(self) -> bool:
        """Whether Cycles' caustics switches leave the light tracer any path: with both off, a
        camera path drops every mirror and glass lobe after a diffuse bounce (path_limits)."""
        return self.settings.caustics_reflective or self.settings.caustics_refractive

    def _use_camera_for_caustics(self):
        """Run the light tracer (where the scene has one) unless the camera is orthographic:
        the light tracer connects to a pinhole or a thin lens, so an orthographic camera leaves
        every path to the path tracer (the same image, noisier caustics)."""
        self.caustics = None if self.camera.ortho else self._caustic_tables
        # Which lamps' light at the camera's own hits MNEE leaves to the light tracer.
        self.mnee, self._why_mnee = self._choose_mnee()
        # The path tracer leaves the light tracer's paths to it (not in the pure test mode),
        # those lit by the world too where the light tracer starts paths on it.
        self.split = self.caustics is not None and not self.caustics.pure
        self.world_split = self.split and bool(np.any(self.caustics.emitter_kind == WORLD))
        self.merging, self._why_merging = self._choose_merging()
        self.split_mode = (light_tracer.SPLIT_MERGE if self.merging is not None else
                           light_tracer.SPLIT_LIGHT if self.split else light_tracer.SPLIT_NONE)

    def _choose_merging(self) -> tuple[float | None, str]:
        """(photon merging's first radius, or None where it does not run; why or why not)."""
        mode = self.settings.photon_merging
        if not self.settings.merges_photons:
            return None, ("photon merging off" if mode == "off" else
                          "not a denoised image: merging is consistent, not unbiased")
        if not self.split:
            return None, "no light tracer"
        if self.media.on:
            return None, "absorbing volumes"
        if self.settings.light_passes:
            return None, "light passes asked for"
        if self.settings.light_groups:
            return None, "light groups asked for"     # merged light goes to no group
        r1 = self.settings.merge_radius or photon_merging.first_radius(
            self.camera, self.caustics.aim_center, self.caustics.aim_radius)
        denoised = ", the image denoised" if mode == "denoised" else ""
        return r1, f"caustics seen through mirrors and glass{denoised}, first radius {r1:.3g}"

    def stages(self) -> dict:
        """Which optional stages this scene runs: {stage: (runs, why)}."""
        used = self.materials.kind[self.materials.of_triangle]
        dielectric = bool(np.isin(used, (GLASS, REFRACTION)).any())
        glass = bool((used == GLASS).any())
        layered = bool(np.isin(used, (LAYERED, PROGRAM)).any())
        lights = self.lights.tables
        next_event = bool(self.next_event and lights.cdf.shape[0] > 0 and lights.cdf[-1] > 0.0)
        world, env = bool(lights.has_world), bool(lights.has_env)
        if not (self.settings.caustics or self.settings.pure_light_tracing):
            why_no_light = "caustics off"
        elif not self._any_caustics():
            why_no_light = "Cycles' reflective and refractive caustics off"
        elif self.camera.ortho:
            why_no_light = "orthographic camera"
        else:
            why_no_light = ("no smooth mirror or glass, no diffuse surface, or no lamp that "
                            "lights one")
        return {
            "lens sampling": (self.camera.has_lens, "depth of field" if self.camera.has_lens
                              else "no depth of field"),
            "dielectric sampling": (dielectric, "glass" if dielectric else "no smooth glass"),
            "Fresnel split": (self.fresnel_split, "smooth glass: the light its reflections meet "
                              "counted whichever way a path goes" if self.fresnel_split else
                              "off" if glass and not self.settings.fresnel_split else
                              "no Glass BSDF"),
            "microfacet sampling": (layered, "rough, Principled or node-tree surfaces" if layered
                                    else "no rough, Principled or node-tree surfaces"),
            "transparent shadows": (self.transparent_shadows,
                                    "transparent surfaces" if self.transparent_shadows
                                    else "no transparent surfaces"),
            "next-event estimation": (next_event, "lamps or world light to sample" if next_event
                                      else "no lamps and a black world"),
            "world": (world, "world light" if world else "black world"),
            "environment": (env, "an environment map" if env else "no environment map"),
            "light tracing": (self.caustics is not None, self._light_tracing_words()
                              if self.caustics is not None else why_no_light),
            "light vertices": (self.light_vertices, self._why_vertices),
            "photon merging": (self.merging is not None, self._why_merging),
            "shadow caustics": (self.mnee.lamp.shape[0] > 0, self._why_mnee),
            "absorbing media": (self.media.on, ("absorbing volumes, the camera inside one"
                                                if camera_in_medium(self.media) else
                                                "absorbing volumes") if self.media.on else
                                "no absorbing volumes"),
        }

    def _light_tracing_words(self) -> str:
        """What the light tracer emits from and, past plain diffuse surfaces, ends on."""
        words = "from " + ", ".join(light_tracer.emitter_names(self.scene, self.caustics))
        onto = light_tracer.receiver_names(self.scene, self.materials)
        return words + (" onto " + ", ".join(onto) if onto else "")

    def _choose_mnee(self) -> tuple[mnee.MneeTables, str]:
        """(manifold next-event estimation's tables, mnee.OFF where it does not run; why or why
        not)."""
        settings = self.settings
        for off, why in ((not settings.shadow_caustics, "shadow caustics off"),
                         # Cycles' casters are seen after a diffuse bounce: with refractive
                         # caustics off it renders no shadow caustics at all (cyclesflags' read
                         # of kernel/integrator/mnee.h).
                         (not settings.caustics_refractive, "refractive caustics off"),
                         (not self.next_event, "no light sampling"),
                         (self.media.on, "absorbing volumes"),
                         (settings.light_passes, "light passes asked for"),
                         (settings.light_groups, "light groups asked for")):
            if off:
                return mnee.OFF, why
        # The lamps whose light at the camera's own hits MNEE leaves to the light tracer: those
        # it starts paths from where the path tracer leaves it their caustics (not in the pure
        # test mode, where the path tracer renders every path).
        caustics = self.caustics
        traced = frozenset() if caustics is None or caustics.pure else frozenset(
            zip(caustics.emitter_kind.tolist(), caustics.emitter_index.tolist()))
        return mnee.mnee_tables(self.scene, self.lights.tables, self.materials.kind,
                                self.materials.of_triangle, traced)

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
        if not np.any(used == DIFFUSE):
            return False, "no diffuse surface"
        if self.transparent_shadows:
            # A light vertex's density is the one of a path from its camera vertex that no
            # transparent surface bends; the MIS weights through one are not derived.
            return False, "transparent surfaces"
        return True, "mesh lights or area lamps light diffuse surfaces"

    # -- one chunk of paths ---------------------------------------------------------------

    def trace_chunk(self, start: int, n: int, in_pass: int, first_sample: int, pixels: np.ndarray,
                    bits: int, total: np.ndarray, total_sq: np.ndarray, class_a: np.ndarray,
                    vertices: bool | None = None, pilot: tuple | None = None,
                    merge: bool = False, extra: ExtraRows | None = None):
        """Trace paths start .. start + n of a pass (in_pass samples per pixel of `pixels`, or of
        every pixel when it is empty; the first sample being first_sample) and add them to the
        (pixels, 3) sums, class-A samples also to `class_a` if it has rows (adaptive.py), with
        light vertices if `vertices` (default: where they run). pilot: (sums, sums of squares)
        that get the same samples without light vertices (wavefront.emitters). merge: add the
        chunk's pixels' sums of the pass, from zero, to total and total_sq (a window merged into
        a render, RenderResult.add). extra: the rows that get the Denoising Albedo and Normal
        passes' samples (features.py), the alpha's and the light passes' (RenderResult.
        extra_rows).
        Returns (NaN/Inf samples, event counters)."""
        radiance, without, stats = self._trace_paths(start, n, in_pass, first_sample, pixels,
                                                     bits, vertices, pilot is not None, extra)
        if merge:
            return self._merge_chunk(radiance, n, start, in_pass, first_sample, pixels, total,
                                     total_sq), stats.copy()
        with self._film_lock:
            bad = wavefront.film(radiance, n, start, in_pass, first_sample, pixels, total,
                                 total_sq, class_a)
            if pilot is not None:
                wavefront.film(without, n, start, in_pass, first_sample, pixels, *pilot,
                               passes.NO_ROWS)
        return bad, stats.copy()

    def trace_rows(self, in_pass: int, first_sample: int, pixels: np.ndarray, bits: int,
                   film: tuple, vertices: bool | None = None, pilot: tuple | None = None):
        """Trace in_pass samples from first_sample of each of `pixels` (image indices, at most a
        chunk of paths) and add them to film: their rows of (sums, sums of squares, class-A sums
        or NO_ROWS), which hold the pixels' sums so far, in the order trace_chunk adds them to
        the whole image's, so that the rows come back as that image's (a pass traced on a
        cluster, farm/remote.py). pilot: its two sums' rows likewise. Returns (NaN/Inf samples,
        event counters)."""
        n = pixels.shape[0] * in_pass
        radiance, without, stats = self._trace_paths(0, n, in_pass, first_sample, pixels, bits,
                                                     vertices, pilot is not None)
        bad = wavefront.film(radiance, n, 0, in_pass, first_sample, passes.ALL_PIXELS, *film)
        if pilot is not None:
            wavefront.film(without, n, 0, in_pass, first_sample, passes.ALL_PIXELS, *pilot,
                           passes.NO_ROWS)
        return bad, stats.copy()

    def _trace_paths(self, start: int, n: int, in_pass: int, first_sample: int,
                     pixels: np.ndarray, bits: int, vertices: bool | None, pilot: bool,
                     extra: ExtraRows | None = None):
        """Trace a chunk's paths (trace_chunk's), adding their denoising features and alpha to
        `extra` (trace_chunk's) where it has their rows; returns this thread's buffers of their
        radiance, of their radiance without light vertices (rows when pilot) and counters."""
        if not 0 < n <= CHUNK or n % in_pass or in_pass > CHUNK:
            # The compiled stages write n paths into buffers of CHUNK, unchecked.
            raise ValueError(f"trace_chunk: {n} paths of {in_pass} samples per pixel do not fit "
                             f"a chunk of {CHUNK}")
        geom, lights, mats = self.geometry, self.lights.tables, self.materials
        mesh = geom.mesh
        (paths, out, shadows, radiance, without, active, stats, scratch, (params, regs, programs),
         lv, (feature_albedo, feature_normal), transparent, pass_sums) = self._buffers.get()
        with_features = extra is not None and extra.albedo is not None
        with_alpha = extra is not None and extra.transparent is not None
        with_passes = extra is not None and extra.light is not None
        transparent = transparent[:n] if with_alpha else transparent[:0]
        transparent[:] = 0.0
        # What the render does not make is None, so that the stages it runs are compiled
        # without its code (wavefront.py).
        pass_sums = pass_sums[:n] if with_passes else None
        if with_passes:
            pass_sums[:] = 0.0
        without = without[:n] if pilot else without[:0]
        stats[:] = 0
        stratified = self.sampler == "stratified"
        split = self._buffers.split(self._lamps_only) if self.fresnel_split else None
        wavefront.clear(radiance, n)
        radiance[:n, 3:] = 0.0         # the light groups' columns, where the render has them
        wavefront.clear(without, without.shape[0])
        if with_features:
            wavefront.clear(feature_albedo, n)
            wavefront.clear(feature_normal, n)
        else:
            feature_albedo = feature_normal = None
        wavefront.generate(self.camera.params(), self.pixel_filter, self.seed, start, in_pass,
                           first_sample, pixels, bits, stratified, n, paths, stats, with_features)
        if self.media.on:
            paths.medium[:n] = self.media.camera
        last_connection = -1
        if self.light_vertices and (vertices is None or vertices):
            last_connection = self._light_vertices(n, bits, stratified, paths, lv, stats)
        m = n
        # Passing a transparent surface is no bounce (wavefront.Paths.bounce): the wavefront
        # goes as deep as the bounces and transparent bounces together allow.
        limits, clamp = self.limits, self.clamp
        deepest = self.max_depth + (limits[1] if self.transparent_shadows else 0)
        for depth in range(deepest + 1):
            prim, u, v, t = geom.intersect(paths.o32[:m], paths.d32[:m], paths.tmax[:m])
            kept = wavefront.emitters(lights, mats, self.media, self.next_event, self.split_mode,
                                      self.world_split, depth, limits, clamp, m, paths, prim, t,
                                      radiance, without, active, stats, feature_albedo,
                                      self.film_transparent, transparent,
                                      pass_sums, self.mnee.lamp)
            if self.programs_emit:
                wavefront.program_emitters(lights, mesh, mats, self.tables, self.split_mode,
                                           depth, m, paths, prim, u, v, t, radiance, without,
                                           feature_albedo, scratch, regs,
                                           pass_sums, clamp)
            if kept == 0:
                break
            m, n_shadow, n_programs, n_split = wavefront.materials(
                lights, mesh, mats, self.media, self.tables, self.fresnel, self.next_event, bits,
                stratified, depth, limits, clamp, self.clear, kept, active, paths, prim, u, v, out,
                shadows, radiance, without, scratch, params, stats, lv, last_connection,
                feature_albedo, feature_normal, programs, pass_sums,
                self.mnee.tri_flags, split)
            if self.mnee.lamp.shape[0] > 0:
                stats[MNEE_PATHS] += mnee.stage(
                    geom, self.mnee, lights, mats, self.tables, self.fresnel, depth, bits,
                    stratified and depth < wavefront.STRATIFIED_BOUNCES, limits, clamp, kept,
                    active, paths, prim, u, v, radiance, without, (scratch, regs, params))
            if n_programs:
                m, n_shadow = wavefront.program_materials(
                    lights, mesh, mats, self.media, self.tables, self.next_event, bits,
                    stratified, depth, limits, clamp, self.clear, n_programs, programs, paths,
                    prim, u, v, out, m, shadows, n_shadow, radiance, without, scratch, regs,
                    stats, lv, last_connection, feature_albedo, feature_normal,
                    transparent, pass_sums, self.mnee.tri_flags)
            if n_shadow:
                blocked = geom.occluded(shadows.o32[:n_shadow], shadows.d32[:n_shadow],
                                        shadows.tmax[:n_shadow])
                if self.transparent_shadows:
                    self._through_transparency(n_shadow, blocked, shadows, scratch, regs)
                wavefront.shadow_rays(n_shadow, blocked, shadows, radiance, without, pass_sums,
                                      clamp)
            if n_split and depth < deepest:     # else the reflections would not be traced
                self._split_light(split, n_split, depth + 1, radiance, without, active,
                                  feature_albedo, transparent, pass_sums, (scratch, regs))
            paths, out = out, paths
            if m == 0:
                break
        if extra is not None:
            self._film_extra(extra, n, start, in_pass, first_sample, pixels, radiance,
                             (feature_albedo, feature_normal), pass_sums, transparent)
        return radiance, without, stats

    def _split_light(self, split, n, depth, radiance, without, active, feature_albedo,
                     transparent, pass_sums, program_scratch) -> None:
        """The light the Fresnel split's n mirror rays find at their hits
        (wavefront.split_fresnel), as the emitters of bounce `depth` add it; the rays then
        end. `active` and program_scratch: scratch."""
        geom, lights, mats = self.geometry, self.lights.tables, self.materials
        rays, counters, _ = split
        prim, u, v, t = geom.intersect(rays.o32[:n], rays.d32[:n], rays.tmax[:n])
        wavefront.emitters(lights, mats, self.media, self.next_event, self.split_mode,
                           self.world_split, depth, self.limits, self.clamp, n, rays, prim, t,
                           radiance, without, active, counters, feature_albedo,
                           self.film_transparent, transparent, pass_sums, self.mnee.lamp)
        if self.programs_emit:
            wavefront.program_emitters(lights, geom.mesh, mats, self.tables, self.split_mode,
                                       depth, n, rays, prim, u, v, t, radiance, without,
                                       feature_albedo, *program_scratch, pass_sums, self.clamp)

    def _light_vertices(self, n, bits, stratified, paths, lv, stats) -> int:
        """Every camera path's light vertex, before its first bounce (light_vertices.py);
        returns the last bounce that connects to it."""
        geom, lights, mesh = self.geometry, self.lights.tables, self.geometry.mesh
        n_light = light_vertices_module.emit(lights, mesh, bits, stratified, n, paths.key,
                                             paths.sample, lv)
        prim, u, v, _ = geom.intersect(lv.o32[:n_light], lv.d32[:n_light], lv.tmax[:n_light])
        stats[wavefront.VERTEX_RAYS] += n_light
        light_vertices_module.hits(lights, mesh, self.materials, self.media, n_light, lv, prim,
                                   u, v)
        return self.max_depth - 2

    def _film_extra(self, extra, n, start, in_pass, first_sample, pixels, radiance, features,
                    pass_sums, transparent):
        """Add a chunk's denoising features, light passes, light groups and alpha to the rows
        `extra` has (trace_chunk's), counting the paths left out as NaN or Inf."""
        half = adaptive.half_of(first_sample)
        with self._film_lock:
            if extra.albedo is not None:
                extra.feature_nans[0] += wavefront.film_features(
                    features[0], features[1], n, start, in_pass, pixels, extra.albedo,
                    extra.normal)
            if extra.light is not None:
                # The sums of the half of the sample indices this chunk's samples are in: an
                # adaptive pass's samples are all in one half (passes.py).
                extra.light_nans[0] += light_passes.film_light_passes(
                    pass_sums, n, start, in_pass, pixels, extra.light[half])
            if extra.groups is not None:
                # A group's columns follow Combined's three (light_groups.columns).
                extra.group_nans[0] += light_passes.film_rows(radiance, 3, n, start, in_pass,
                                                              pixels, extra.groups[half])
            if extra.transparent is not None:
                extra.alpha_nans[0] += wavefront.film_alpha(transparent, n, start, in_pass,
                                                            pixels, extra.transparent,
                                                            extra.transparent_sq)

    def _through_transparency(self, n_shadow, blocked, shadows, scratch, regs):
        """Let the blocked shadow rays through transparent surfaces (wavefront.
        shadow_transparency), one surface per Embree call, as many as Cycles' Transparent
        bounces allow: a ray with more in its way stays blocked."""
        pending = np.flatnonzero(blocked == 0)
        # A round per surface passed, and one more to find nothing behind the last.
        for _ in range(self.settings.transparent_max_bounces + 1):
            if len(pending) == 0:
                return
            prim, u, v, t = self.geometry.intersect(shadows.o32[pending],
                                                    shadows.d32[pending],
                                                    shadows.tmax[pending])
            left = wavefront.shadow_transparency(self.geometry.mesh, self.materials,
                                                 self.tables, len(pending), pending,
                                                 prim, u, v, t, shadows, blocked, scratch, regs)
            pending = pending[:left]

    def _merge_chunk(self, radiance, n, start, in_pass, first_sample, pixels, total,
                     total_sq) -> int:
        """Add a chunk's pixels' sums of the pass, each from zero, to total and total_sq; returns
        the NaN/Inf samples. The chunk holds all the pass's samples of its pixels, so this adds
        what the pass's own sums would, without a whole image of them (memory at 8k x 8k)."""
        row0, rows = start // in_pass, n // in_pass
        local, local_sq = np.zeros((rows, 3)), np.zeros((rows, 3))
        bad = wavefront.film(radiance, n, start - row0 * in_pass, in_pass, first_sample,
                             passes.ALL_PIXELS, local, local_sq, passes.NO_ROWS)
        target = slice(row0, row0 + rows) if pixels.shape[0] == 0 else pixels[row0:row0 + rows]
        with self._film_lock:
            total[target] += local
            total_sq[target] += local_sq
        return bad

    def trace_light_chunk(self, pass_index: int, start: int, n: int,
                          photons: dict | None = None):
        """Trace light paths start .. start + n of a pass; returns the splats of those that
        reached the camera, (pixels, contributions, how many reached it: a pixel filter wider
        than a pixel spreads one over several pixels, the light groups' splats: None when the
        render makes no light groups, else (pixels, contributions, each one's group) of the
        splats of lights in a group). The caller adds them in chunk order, so that the image
        does not depend on which thread finished first (float sums depend on their order).
        photons: where photon merging gets the chunk's photons (photons[start])."""
        if not 0 < n <= CHUNK:
            raise ValueError(f"trace_light_chunk: {n} paths do not fit a chunk of {CHUNK}")
        geom, lights, mats, caustics = (self.geometry, self.lights.tables, self.materials,
                                        self.caustics)
        mesh, cam = geom.mesh, self.camera.params()
        paths, out, connections, raster = self._buffers.light()
        chunk = self._buffers.get()           # the hits' lobes: scratch shared with camera paths
        scratch = (chunk[7], chunk[8][1], chunk[8][0])
        filt = self.pixel_filter
        margin = max(0.0, filt.reach - 0.5)     # how far past the image the filter reaches
        m = light_tracer.emit_light_paths(caustics, lights, mesh, self.media, self.seed,
                                          pass_index, start, n, paths, self.mnee.lamp)
        pixels, contributions, reached = [], [], 0
        grouped = [] if self.light_groups else None
        buffer = self._buffers.photons() if photons is not None else NO_PHOTONS
        stored = []
        for _ in range(self.max_depth):
            if m == 0:
                break
            prim, u, v, _ = geom.intersect(paths.o32[:m], paths.d32[:m], paths.tmax[:m])
            m, n_conn, n_photons = light_tracer.light_bounce(
                caustics, lights, mesh, mats, self.media, cam, margin, self.fresnel, self.limits,
                m, paths, prim, u, v, out, connections, raster, buffer, self.tables, scratch,
                self.mnee.tri_flags)
            if n_photons:
                stored.append(photon_merging.Photons(*(f[:n_photons].copy() for f in buffer)))
            if n_conn:
                visible = geom.occluded(connections.o32[:n_conn], connections.d32[:n_conn],
                                        connections.tmax[:n_conn]) != 0   # Embree: 0 if blocked
                reached += int(visible.sum())
                if filt.unit_box:       # the pixel the point lands in, weight 1
                    pixels.append(connections.path[:n_conn][visible])
                    contributions.append(connections.contrib[:n_conn][visible])
                else:
                    spread = spread_splats(filt, cam.width, cam.height, raster[:n_conn][visible],
                                           connections.contrib[:n_conn][visible])
                    pixels.append(spread[0])
                    contributions.append(spread[1])
                if grouped is not None:
                    grouped.append(self._group_splats(connections, raster, n_conn, visible))
            paths, out = out, paths
        if grouped is not None:
            grouped = tuple(np.concatenate(parts) for parts in zip(*grouped)) if grouped else \
                (np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.int64))
        if photons is not None:
            photons[start] = (n, photon_merging.concatenate(stored))
        if not pixels:
            return np.zeros(0, np.int64), np.zeros((0, 3)), 0, grouped
        return np.concatenate(pixels), np.concatenate(contributions), reached, grouped

    def _group_splats(self, connections, raster, n_conn, visible):
        """(pixels, contributions, groups) of the visible connections whose light is in a
        light group, spread by the pixel filter as the image's splats."""
        group = connections.group[:n_conn][visible]
        contrib, points = connections.contrib[:n_conn][visible], raster[:n_conn][visible]
        keep = group >= 0
        if self.pixel_filter.unit_box:
            return connections.path[:n_conn][visible][keep], contrib[keep], group[keep]
        parts = [spread_splats(self.pixel_filter, self.camera.width, self.camera.height,
                               points[group == g], contrib[group == g]) + (g,)
                 for g in np.unique(group[keep])]
        return (np.concatenate([p[0] for p in parts] + [np.zeros(0, np.int64)]),
                np.concatenate([p[1] for p in parts] + [np.zeros((0, 3))]),
                np.concatenate([np.full(len(p[0]), p[2], np.int64) for p in parts]
                               + [np.zeros(0, np.int64)]))

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

    def render(self, progress=None, stop: threading.Event | None = None,
               every_pass: bool = False) -> RenderResult:
        """Render progressively with the settings' spp, batches, noise_threshold and min_spp;
        `progress(result, pass_index, pass_count)` may return False to stop (with adaptive
        sampling pass_count is an estimate: result.spp / spp is the share of the budget done).

        Each pass adds its samples to the image, and the light tracer (where it runs) as many
        light paths per camera path as light_paths_per_camera_path says. batches=K renders in
        K passes (of equal samples, give or take one) and keeps each pass's image as a batch, for
        variances of the mean from independent batches (RenderResult.variance_and_dof).

        noise_threshold > 0 samples adaptively (tracer/adaptive.py): spp is then each pixel's
        most, min_spp (0 = Cycles' automatic minimum) its least. Batches need equal samples in
        every pixel: with batches adaptive sampling is off.

        stop: once set, the chunks not yet started are skipped and the render ends cancelled
        without counting its unfinished pass: the result is then no image (the viewport drops
        it for the next one's). Waits one chunk at most.

        every_pass: fixed samples in windows of one pass, so that progress comes after each
        pass (the viewport) rather than each window of up to passes.WINDOW_PASSES; the sums then
        differ in the last bits from the default's (and a cluster's).
        """
        threshold, _ = passes.adaptive_settings(self.settings)
        # The light-budget pilot first, so that the result carries its choice; its time is the
        # render's.
        pilot_start = time.perf_counter()
        budget = self.light_budget()
        pilot_s = time.perf_counter() - pilot_start
        w, h = self.camera.width, self.camera.height
        result = RenderResult(w, h, np.zeros((h, w, 3)), np.zeros((h, w, 3)), threads=self.threads,
                              build_s=self.build_s, light_in_image=self.split,
                              stages=self.stages(), spp_budget=self.settings.spp,
                              noise_threshold=threshold, exposure=self.settings.film_exposure)
        if self.features:
            result.start_features(self.camera.rotation)
        if self.alpha:
            result.start_alpha(self.film_transparent)
        if self.light_passes:
            result.start_light_passes()
        if self.light_groups:
            result.start_light_groups(self.light_groups)
        scheduler = passes.scheduler(self, result, self.settings, every_pass)
        with ThreadPoolExecutor(max_workers=self.threads) as pool:
            result = passes.drive(self, scheduler, pool, progress, stop,
                                  self.settings.time_limit)
        result.time_s += pilot_s
        result.light_budget = budget
        return result

    @property
    def ray_count(self) -> int:
        """Rays traced by this renderer so far (the pass interface's, as embree_time)."""
        return self.geometry.ray_count

    @property
    def embree_time(self) -> float:
        """Seconds spent in Embree so far."""
        return self.geometry.embree_time

    # -- windows ---------------------------------------------------------------------------

    def windows(self, spp: int) -> list[Window]:
        """The windows of a fixed render of spp samples per pixel, in the order it adds them."""
        return passes.fixed_windows(self.camera.width * self.camera.height, spp)

    def render_window(self, window: Window, spp: int, pixels: np.ndarray | None = None,
                      stop: threading.Event | None = None) -> WindowSums | None:
        """The sums of the samples window.first .. window.end of `pixels` (image indices
        y * width + x, sorted; default all) in a render of spp samples per pixel; None if `stop`
        was set. Keeps nothing between calls: a fixed render of spp samples is the sum of its
        windows (windows(spp)) added in order (RenderResult.add), wherever each was traced.

        spp fixes the sampler's sequences; window.index keys the light tracer's paths, whose
        count follows the window's camera paths and whose splats land anywhere in the image.
        A window of some pixels traces no light paths: tiles of one window would all trace the
        same ones (the same keys); its light belongs to a window of every pixel."""
        npix = self.camera.width * self.camera.height
        light = np.zeros((npix, 3)) if self.caustics is not None and pixels is None else None
        pixels = passes.ALL_PIXELS if pixels is None else np.ascontiguousarray(pixels, np.int64)
        film = (np.zeros((npix, 3)), np.zeros((npix, 3)))
        bits = max(1, (int(spp) - 1).bit_length())
        with ThreadPoolExecutor(max_workers=self.threads) as pool:
            return self.trace_window(pool, window, bits, pixels, film, False, light, stop)

    def trace_window(self, pool, window: Window, bits: int, pixels: np.ndarray, film,
                     merge: bool, light: np.ndarray | None, stop,
                     extra: ExtraRows | None = None) -> WindowSums | None:
        """Trace a window: its camera samples in progressive passes into film (sums, sums of
        squares; with `merge` each pass's sums from zero, added as RenderResult.add adds a
        window's, which takes a window of one pass), then its light paths into `light` (cleared
        first). Returns the window's sums (its camera sums None when merged), None if `stop`
        was set. extra: as trace_chunk's."""
        sums = WindowSums(window, None if merge else film[0], None if merge else film[1], light,
                          counters=np.zeros(len(wavefront.STATS), np.int64))
        rows = pixels.shape[0] or self.camera.width * self.camera.height
        step = passes.samples_per_pass(rows)
        for first in range(window.first, window.end, step):
            sums.nan_count += self.camera_pass(
                pool, passes.Pass(first, min(step, window.end - first)), pixels, bits,
                (*film, passes.NO_ROWS), sums.counters, stop, merge=merge, extra=extra)
            if stop is not None and stop.is_set():
                return None
        if light is not None:
            self.window_light(pool, sums, rows, extra is not None and extra.group_light is not None)
        return sums

    def window_light(self, pool, sums: WindowSums, rows: int, grouped: bool) -> None:
        """Trace a window's light paths (as many as its camera samples of `rows` pixels ask)
        into its sums' light_sum; with `grouped`, the light groups' splats into its own
        group_light, from zero (added to the render's in window order by RenderResult.add, so
        that a window traced on a cluster adds the same sums)."""
        window = sums.window
        sums.light_paths = self.light_count(rows, window.end - window.first)
        if grouped:
            npix = self.camera.width * self.camera.height
            sums.group_light = np.zeros((npix, 3 * len(self.light_groups)))
        sums.nan_count += self.light_pass(pool, window.index, sums.light_paths, sums.light_paths,
                                          sums.light_sum, None, sums.counters, sums.group_light)

    # -- one pass --------------------------------------------------------------------------

    def camera_pass(self, pool, step, pixels, bits, film, counters, stop, vertices=None,
                    pilot=None, merge=False, extra=None) -> int:
        """Trace a pass's camera samples (step: passes.Pass) of `pixels` into film (sums, sums
        of squares, class-A sums; trace_chunk's merge and extra) and count their events;
        returns the NaN or Inf samples."""
        rows = pixels.shape[0] or self.camera.width * self.camera.height
        # Chunks hold whole pixels' samples, so that each pixel's sum is added in the same
        # order with any number of threads (float addition is not associative); a pass of more
        # samples than a chunk holds is traced as sub-passes, one after the other.
        bad = 0
        for sub in passes.sub_passes(step, rows):
            for chunk_bad, stats in pool.map(
                    lambda job, sub=sub: (0, 0) if stop is not None and stop.is_set() else
                    self.trace_chunk(job[0], job[1], sub.samples, sub.first, pixels, bits, *film,
                                     vertices, pilot, merge, extra),
                    passes.jobs(0, rows * sub.samples, sub.samples)):
                bad += chunk_bad
                counters += stats
        return bad

    def light_count(self, rows: int, samples: int, share: float = 1.0) -> int:
        """passes.light_count of this renderer's light paths per camera path."""
        return passes.light_count(self.light_paths_per_camera_path, rows, samples, share)

    def light_pass(self, pool, pass_index, n_light, n_a, film, film_a, counters,
                   groups=None) -> int:
        """Trace a pass's n_light light paths into film (rows of (pixels, 3)); film_a (if not
        None) gets those of the first n_a, adaptive sampling's half A of the light tracer;
        groups (if not None) the light groups' splats, added to its sums (rows of (pixels,
        3 x groups)). Returns how many splats were NaN or Inf (left out)."""
        film[:] = 0.0
        if film_a is not None:
            film_a[:] = 0.0
        # Jobs never straddle n_a, so each job's splats belong to one half; a big pass's jobs
        # come segment by segment (passes.light_segments), splatted in chunk order.
        bad = 0
        photons = {} if self.merging is not None else None
        for begin, end in passes.light_segments(n_light, n_a):
            jobs = passes.jobs(begin, end, 1)
            bad += passes.add_splats(jobs, pool.map(
                lambda job: self.trace_light_chunk(
                    pass_index, job[0], job[1],
                    photons if job[0] - (n_a if job[0] >= n_a else 0)
                    < photon_merging.MAX_PHOTON_PATHS else None), jobs),
                n_a, film, film_a, counters, groups)
        if photons is not None:
            bad += self.merge_pass(pool, pass_index, n_light, n_a, photons, film, film_a)
        return bad

    def merge_pass(self, pool, pass_index, n_light, n_a, photons, film, film_a) -> int:
        """Photon merging's pass (photon_merging.py): the pass's photons (by chunk start) in a
        grid of the pass's radius, gathered by camera walks, as many per pixel as the pass
        traced camera samples, into film weighted by the pass's n_light light paths (so that
        the light image averages the passes' estimates). With film_a (adaptive sampling), the
        light paths' two halves (before and after n_a) merge apart, each with its own walks and
        half of them, and film_a gets half A's: the halves' difference then holds the merged
        noise too, as adaptive sampling's error estimate needs. A half of more than
        MAX_PHOTON_PATHS light paths merges the photons of its first chunks only, weighted up
        to all of them; walks are at most MAX_WALKS. Returns how many gathers were NaN or Inf
        (left out)."""
        halves = [(0, n_a), (n_a, n_light)] if film_a is not None and 0 < n_a < n_light \
            else [(0, n_light)]
        r = photon_merging.radius(self.merging, pass_index + 1)
        npix = self.camera.width * self.camera.height
        bad = 0
        for half, (begin, end) in enumerate(halves):
            kept = [k for k in sorted(photons) if begin <= k < end]
            stored = sum(photons[k][0] for k in kept)    # light paths whose photons are kept
            grid = photon_merging.build_grid(
                photon_merging.concatenate([photons[k][1] for k in kept]), r)
            samples = max(1, min(round((end - begin) / (npix * self.light_paths_per_camera_path)),
                                 photon_merging.MAX_WALKS // npix))
            # Half B's walks keyed apart from half A's (and from any pass's), so that the halves
            # are independent.
            pixels, contributions = photon_merging.merge(
                pool, self.geometry, self.materials, self.camera.params(), self.pixel_filter,
                self.fresnel, self.limits, self.seed, pass_index + (half << 40), grid,
                npix * samples, samples, CHUNK)
            contributions *= ((end - begin) / max(stored, 1)) / (np.pi * r * r * samples)
            bad += wavefront.splat(pixels, contributions, film)
            if film_a is not None and len(halves) == 2 and half == 0:
                wavefront.splat(pixels, contributions, film_a)
        return bad


def describe_stages(stages: dict) -> tuple[str, str]:
    """('stage (why), ...' of the stages run, the same of those skipped) for a summary line."""
    run = ", ".join(f"{name} ({why})" for name, (runs, why) in stages.items() if runs)
    skipped = ", ".join(f"{name} ({why})" for name, (runs, why) in stages.items() if not runs)
    return run or "none", skipped or "none"


def render(scene: Scene, settings: RenderSettings | None = None, progress=None) -> RenderResult:
    """Render a scene with the settings (default: its own); see Renderer.render."""
    return Renderer(scene, settings).render(progress=progress)


def clear_glass(materials, kind, settings) -> np.ndarray:
    """Per material, whether its transmissions keep a camera path see-through (wavefront.go_on)
    under Film > Transparent > Transparent Glass: smooth glass and refraction, and rough ones
    (Principled included) of a roughness up to the threshold, untextured; empty when Transparent
    Glass is off (a program's transmissions count when singular, whatever this says)."""
    if not (settings.film_transparent and settings.film_transparent_glass):
        return np.zeros(0, bool)
    clear = np.isin(kind, (GLASS, REFRACTION))
    for m, mat in enumerate(materials):
        if kind[m] == LAYERED and mat["kind"] in ("glass", "refraction", "principled") \
                and "roughness" not in (mat.get("textures") or {}):
            clear[m] = (float(material_field(mat, "roughness"))
                        <= settings.film_transparent_roughness)
    return clear


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
    # A diffuse triangle and a mirror one under a lamp that rays can hit, and out of the
    # camera's view an emissive triangle facing them: the light tracer runs, and so do the
    # light vertices (a mesh light starts them). Between the first two, a half-transparent,
    # glowing node-graph material: the shader-program stages (most real files have one).
    triangles = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0],
                          [-1, -1, 0.5], [1, -1, 0.5], [0, 1, 0.5],
                          [2, -1, 1], [2, 1, 1], [3, 0, 1],
                          [-1, -1, 0.25], [1, -1, 0.25], [0, 1, 0.25]], np.float32)
    lamp = {"name": "lamp", "kind": "point", "position": [0.0, 0.0, 1.0],
            "intensity": [1.0, 1.0, 1.0], "radius": 0.1}
    scene = Scene(positions=triangles,
                  triangles=np.array([[0, 1, 2], [3, 4, 5], [6, 7, 8], [9, 10, 11]], np.int32),
                  material_ids=np.array([0, 1, 2, 3], np.int32),
                  object_ids=np.array([0, 1, 2, 3], np.int32),
                  materials=[{"name": "grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]},
                             {"name": "mirror", "kind": "mirror", "color": [1.0, 1.0, 1.0]},
                             {"name": "light", "kind": "emission", "color": [1.0, 1.0, 1.0],
                              "strength": 1.0},
                             _warm_up_program()],
                  lights=[lamp], camera=camera, world={"color": [0.1, 0.1, 0.1]},
                  render={"spp": 1, "max_depth": 2, "seed": 0, "fresnel": "exact"},
                  objects=[{"name": "triangle", "closed": False},
                           {"name": "mirror", "closed": False},
                           {"name": "light", "closed": False}, {"name": "veil", "closed": False}],
                  normals=np.array([[0, 0, 1]] * 6 + [[0, 0, -1]] * 3 + [[0, 0, 1]] * 3,
                                   np.float32))
    for sampler in SAMPLERS:
        Renderer(scene, scene.settings(threads=1, sampler=sampler)).render()
    # The stages a render with the denoising features runs are compiled apart (wavefront.py),
    # and Cycles' F12 denoises by default.
    Renderer(scene, scene.settings(threads=1, denoising_passes=True)).render()
    jit.mark_warm()
    return time.perf_counter() - start


def _warm_up_program() -> dict:
    """A shader program (shader/program.py) that runs every program stage: Mix Shader of a
    Diffuse and of a Transparent and an Emission, emission marked as varying."""
    c = closures
    #  registers: 0-2 colour, 3 fac, 4-6 white, 7-8 the two sides' weights
    code = [[c.MIX_CLOSURE, 7, 8, -1, 3, 0, 0, 0],
            [c.DIFFUSE, 7, 0, -1, 0, 0, 0, 0],
            [c.TRANSPARENT_BSDF, 8, 4, 0, 0, 0, 0, 0],
            [c.EMISSION, 8, 4, 3, 0, 0, 0, 0]]
    return {"name": "veil", "kind": "program",
            "program": {"registers": 9, "constants": [0.5, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0],
                        "code": code, "data": [], "emission_varies": True, "refracts": False}}


def kernels_compiled() -> bool:
    """Whether the kernels are compiled and cached on disk (else the first render compiles them,
    which takes a while: callers say so, then call warm_up)."""
    return jit.is_warm()
