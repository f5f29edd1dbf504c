"""What a render returns: per-pixel sums of samples, their squares and the light tracer's splats,
and the statistics a caller derives from them (the image, variances of its mean, counters)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import adaptive, light_groups, light_passes, wavefront
from .image import as_float32


class ExtraRows(NamedTuple):
    """What a chunk adds its paths' other passes to, as rows of the image's pixels (None: the
    render does not make that pass): the Denoising Albedo and Normal sums (pixels, 3), the sums
    and sums of squares of each sample's uncovered share, 1 - alpha (pixels,), and the counts
    of samples left out of each for a NaN or Inf (arrays of one)."""
    albedo: np.ndarray | None
    normal: np.ndarray | None
    feature_nans: np.ndarray | None
    transparent: np.ndarray | None
    transparent_sq: np.ndarray | None
    alpha_nans: np.ndarray | None
    light: np.ndarray | None = None          # the light passes' sums (2, pixels, COLUMNS)
    light_nans: np.ndarray | None = None
    # The light groups' sums (light_groups.py): the camera paths', (2, pixels, 3 x groups) by
    # half as the light passes', and the light tracer's splats, (pixels, 3 x groups).
    groups: np.ndarray | None = None
    group_light: np.ndarray | None = None
    group_nans: np.ndarray | None = None


class Window(NamedTuple):
    """Samples first .. end of a render; `index`, each window's own, keys its light paths."""
    index: int
    first: int
    end: int


@dataclass
class WindowSums:
    """What one window of a render adds to its image: the camera samples' sums and sums of
    squares and the light tracer's splats, rows of (pixels, 3) of the whole image (pixel =
    y * width + x), with the light paths traced, the NaN or Inf samples left out and the
    event counters (wavefront.STATS); with light groups, the light tracer's splats of each
    group, (pixels, 3 x groups). Camera sums None: already added to the render's."""
    window: Window
    sum: np.ndarray | None
    sum_sq: np.ndarray | None
    light_sum: np.ndarray | None
    light_paths: int = 0
    nan_count: int = 0
    counters: np.ndarray | None = None
    group_light: np.ndarray | None = None


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
    light_budget: object = None      # the light-budget pilot's choice (light_budget.Budget)
    light_in_image: bool = False     # the hybrid: the light tracer's splats are part of the image
    batches: int = 0
    nan_count: int = 0
    time_s: float = 0.0              # rendering, without compile_s
    compile_s: float = 0.0           # compiling kernels the render met first (passes.drive)
    build_s: float = 0.0
    embree_time_s: float = 0.0
    rays: int = 0
    threads: int = 1
    workers: int = 0                 # Dask worker processes that traced it (farm/); 0: this one
    cancelled: bool = False
    time_limited: bool = False      # stopped by the settings' time_limit (a whole image)
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
    # The Denoising Albedo and Normal passes' sums (features.py; None: not rendered), world-space
    # normals; the camera's world-to-camera rotation (Cycles' camera space: x right, y up, z into
    # the scene); the samples whose features held a NaN or Inf (left out, as the image's).
    albedo_sum: np.ndarray | None = None
    normal_sum: np.ndarray | None = None
    world_to_camera: np.ndarray | None = None
    feature_nans: np.ndarray | None = None
    # The film's alpha (Film > Transparent, or a Holdout; None: opaque): per-pixel sums of each
    # sample's uncovered share and of its squares, and the samples whose share was NaN or Inf.
    transparent_sum: np.ndarray | None = None
    transparent_sq: np.ndarray | None = None
    alpha_nans: np.ndarray | None = None
    film_transparent: bool = False   # Film > Transparent: the world is not in the image
    exposure: float = 1.0            # Film > Exposure: mean() scales the radiance by it
    # The light passes' per-pixel sums (light_passes.py; None: not rendered), (2, H x W,
    # COLUMNS): those of each half of the sample indices (adaptive.half_of), which an adaptive
    # render's image weighs as its halves; and the samples whose pass row held a NaN or Inf.
    light_pass_sum: np.ndarray | None = None
    light_pass_nans: np.ndarray | None = None
    # The light groups (light_groups.py; no names: not rendered): their names, the camera
    # samples' sums by half as the light passes', (2, H x W, 3 x groups), the light tracer's
    # splats' (H x W, 3 x groups) and the samples whose group columns held a NaN or Inf.
    light_group_names: list = field(default_factory=list)
    light_group_sum: np.ndarray | None = None
    light_group_light: np.ndarray | None = None
    light_group_nans: np.ndarray | None = None

    def start_features(self, camera_rotation: np.ndarray):
        """Keep the denoising passes' sums; camera_rotation: the camera's columns (Blender's:
        x right, y up, looking down -z) in world space."""
        self.albedo_sum = np.zeros_like(self.sum)
        self.normal_sum = np.zeros_like(self.sum)
        self.world_to_camera = (np.asarray(camera_rotation, np.float64)
                                * np.array([1.0, 1.0, -1.0])).T
        self.feature_nans = np.zeros(1, np.int64)

    def start_alpha(self, film_transparent: bool):
        """Keep the alpha's sums (film_transparent: Film > Transparent is on)."""
        self.transparent_sum = np.zeros((self.height, self.width))
        self.transparent_sq = np.zeros((self.height, self.width))
        self.alpha_nans = np.zeros(1, np.int64)
        self.film_transparent = film_transparent

    def start_light_passes(self):
        """Keep the light passes' sums."""
        self.light_pass_sum = np.zeros((2, self.height * self.width, light_passes.COLUMNS))
        self.light_pass_nans = np.zeros(1, np.int64)

    def start_light_groups(self, names):
        """Keep the sums of the light groups of these names."""
        self.light_group_names = list(names)
        width = 3 * len(self.light_group_names)
        self.light_group_sum = np.zeros((2, self.height * self.width, width))
        self.light_group_light = np.zeros((self.height * self.width, width))
        self.light_group_nans = np.zeros(1, np.int64)

    def extra_rows(self) -> ExtraRows | None:
        """The rows the stages add the denoising features, the alpha, the light passes and the
        light groups to (Renderer.trace_chunk), or None when the render makes none of them."""
        if self.albedo_sum is None and self.transparent_sum is None \
                and self.light_pass_sum is None and self.light_group_sum is None:
            return None
        features = self.albedo_sum is not None
        alpha = self.transparent_sum is not None
        light = self.light_pass_sum is not None
        return ExtraRows(self.albedo_sum.reshape(-1, 3) if features else None,
                         self.normal_sum.reshape(-1, 3) if features else None,
                         self.feature_nans,
                         self.transparent_sum.reshape(-1) if alpha else None,
                         self.transparent_sq.reshape(-1) if alpha else None,
                         self.alpha_nans,
                         self.light_pass_sum if light else None,
                         self.light_pass_nans, self.light_group_sum, self.light_group_light,
                         self.light_group_nans)

    @property
    def has_light_passes(self) -> bool:
        """Whether the render made the light passes."""
        return self.light_pass_sum is not None

    @property
    def light_pass_nan_count(self) -> int:
        """Samples whose light-pass row held a NaN or Inf (left out of the passes)."""
        return 0 if self.light_pass_nans is None else int(self.light_pass_nans[0])

    def light_pass_images(self) -> dict:
        """The light passes as Blender names them, float32 (H, W, 3) each, read as Cycles reads
        them (light_passes.read_passes): Direct and Indirect divided by their Color pass, the
        light tracer's splats in Diffuse Indirect (their Lambert surface's indirect light). Each
        pixel's mean is the image's: with adaptive sampling the mean of its halves' means
        (adaptive.Halves.mean), so that the passes add up to the image exactly."""
        if self.light_pass_sum is None:
            raise ValueError("the render has no light passes (settings: light_passes)")
        mean = self._mean_of_halves(self.light_pass_sum)
        splats = self.light_image() if self.light_in_image and self.light_paths else None
        passes = light_passes.read_passes(mean.reshape(self.height, self.width, -1), splats,
                                          self.exposure)
        return {name: as_float32(values) for name, values in passes.items()}

    @property
    def has_light_groups(self) -> bool:
        """Whether the render made the light groups' passes."""
        return self.light_group_sum is not None

    def light_group_images(self) -> dict:
        """The light groups' passes as Blender names them ("Combined_<group>"), float32
        (H, W, 3) each: each pixel's mean as the image's (with adaptive sampling the mean of its
        halves' means), plus the light tracer's splats of the group's lights per light path,
        times the film's exposure. The image is their sum plus the light in no group."""
        if self.light_group_sum is None:
            raise ValueError("the render has no light groups (settings: light_groups)")
        mean = self._mean_of_halves(self.light_group_sum)
        light = None
        if self.light_in_image and self.light_paths:
            light = self.light_group_light / self.light_paths
            light = light.reshape(self.height, self.width, -1)
        passes = light_groups.read_groups(mean.reshape(self.height, self.width, -1), light,
                                          self.light_group_names, self.exposure)
        return {name: as_float32(values) for name, values in passes.items()}

    def _mean_of_halves(self, sums: np.ndarray) -> np.ndarray:
        """Each pixel's mean of per-half sums (2, pixels, C) as the image's: the sum over its
        samples, or with adaptive sampling the mean of its halves' means."""
        if self.halves is None:
            count = np.maximum(self.samples().reshape(-1, 1).astype(np.float64), 1.0)
            return sums.sum(axis=0) / count
        count = self.halves.count[..., None].astype(np.float64)
        weights = (count > 0).astype(np.float64)
        return (sums / np.maximum(count, 1.0) * weights).sum(axis=0) \
            / np.maximum(weights.sum(axis=0), 1.0)

    @property
    def has_alpha(self) -> bool:
        """Whether the render made an alpha channel (Film > Transparent, or a Holdout)."""
        return self.transparent_sum is not None

    @property
    def alpha_nan_count(self) -> int:
        """Samples whose uncovered share was NaN or Inf (left out of the alpha)."""
        return 0 if self.alpha_nans is None else int(self.alpha_nans[0])

    def alpha(self) -> np.ndarray:
        """The alpha channel, float32 (H, W): 1 less each pixel's mean uncovered share, in
        [0, 1] as Cycles' film reads it; 1 everywhere when the render made no alpha."""
        if self.transparent_sum is None:
            return np.ones((self.height, self.width), np.float32)
        count = np.maximum(self.samples().astype(np.float64), 1.0)
        return np.clip(1.0 - self.transparent_sum / count, 0.0, 1.0).astype(np.float32)

    def exr_channels(self) -> dict:
        """The channels an EXR of this render carries after R, G, B (`snell render` and `snell
        batch` alike): A where the render made an alpha, then each pixel's samples."""
        alpha = {"A": self.alpha()} if self.has_alpha else {}
        return {**alpha, "samples": self.samples()}

    def alpha_variance_and_dof(self):
        """Per-pixel variance of the alpha's mean from its samples (n - 1 degrees of freedom,
        the smallest pixel's), (H, W) and a number."""
        n = self.samples().astype(np.float64)
        spread = np.maximum(self.transparent_sq - self.transparent_sum ** 2 / np.maximum(n, 1), 0)
        variance = np.where(n >= 2, spread / np.maximum(n - 1, 1) / np.maximum(n, 1), np.inf)
        return variance, max(int(n.min()) - 1, 1)

    @property
    def has_features(self) -> bool:
        """Whether the render made the Denoising Albedo and Normal passes."""
        return self.albedo_sum is not None

    @property
    def feature_nan_count(self) -> int:
        """Samples whose denoising features were NaN or Inf (left out of the passes)."""
        return 0 if self.feature_nans is None else int(self.feature_nans[0])

    def denoising_albedo(self) -> np.ndarray:
        """The Denoising Albedo pass: each pixel's mean feature albedo, float32 (H, W, 3)."""
        return self._feature_mean(self.albedo_sum)

    def denoising_normal(self) -> np.ndarray:
        """The Denoising Normal pass in Cycles' camera space, each pixel's mean, float32
        (H, W, 3) (not normalised: a pixel's mean of unit normals, as Cycles)."""
        return self._feature_mean(self.normal_sum @ self.world_to_camera.T)

    def _feature_mean(self, total) -> np.ndarray:
        if total is None:
            raise ValueError("the render has no denoising passes (settings: denoising_passes)")
        count = self.samples().astype(np.float64)[..., None]
        return as_float32(total / np.maximum(count, 1.0))

    def add(self, sums: WindowSums):
        """Add a window of every pixel's samples (Renderer.render_window) to the sums: windows
        added in the order of their samples make the fixed-sample render's sums bit for bit."""
        if sums.sum is not None:
            self.sum.reshape(-1, 3)[:] += sums.sum
            self.sum_sq.reshape(-1, 3)[:] += sums.sum_sq
        if sums.light_sum is not None:
            if self.light_sum is None:
                self.light_sum = np.zeros_like(self.sum)
            self.light_sum.reshape(-1, 3)[:] += sums.light_sum
        if sums.group_light is not None:
            self.light_group_light += sums.group_light
        self.light_paths += sums.light_paths
        self.spp += sums.window.end - sums.window.first
        self.nan_count += sums.nan_count
        self.stats = {name: self.stats.get(name, 0) + count
                      for name, count in zip(wavefront.STATS, sums.counters.tolist())}

    def mean(self) -> np.ndarray:
        """The image: per-pixel mean radiance (each pixel's sum over its own sample count) times
        the film's exposure, float32 (H, W, 3), linear."""
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
            if self.exposure != 1.0:
                part *= self.exposure
            image[band] = as_float32(part)
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

        With K >= 2 batches (the setting batches=K), from the spread of the K passes'
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


def _variance_of_mean(total, total_sq, k):
    """The variance of the mean of k independent values (samples, or batch images) per pixel,
    from their sum and sum of squares."""
    return np.maximum((total_sq - total * total / k) / (k - 1), 0.0) / k
