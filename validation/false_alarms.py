"""`snell false-alarms`: how often the validator calls a correct render inconsistent.

A null run renders one configuration twice with independent seeds, both correct, and keeps the
raw images: for Snell against Cycles, Snell's batch images and Cycles' per-seed images; for the
exact null, a second set of Cycles seeds in Snell's place. Runs are cached as .npz files, so the
verdict (or a candidate statistic) can be evaluated again over the same runs without rendering.
The failure rate of each test and of the whole verdict comes with its binomial 95% interval.
"""
from __future__ import annotations

import copy
import hashlib
import json
import math
import os
import subprocess
import sys
from dataclasses import asdict, dataclass, replace

import numpy as np

from . import cycles, metrics
from .compare import BATCHES, load_snell_scene, snell_render

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SNELL, EXACT = "snell", "cycles"     # what takes the tested image's place
TESTED = np.array("snell: independent sampler, batches, no light vertices; seeds per config; "
                  "both renderers with the scene's pixel filter")
SEED_BLOCKS = 2000   # Cycles seeds (base * 1000 + k, cycles.seeds_for) stay below 2^31


@dataclass(frozen=True)
class NullConfig:
    """One configuration: a scene builder in scenes/, its render settings and camera, and
    optionally a deliberate error in the tested render (a power run; no error: a null run)."""
    name: str
    scene: str                       # scenes/<scene>.py builds it
    spp: int
    scale: int = 25                  # resolution percentage
    cycles_seeds: int = 8
    max_depth: int | None = None     # None: the scene's
    camera: tuple = ()               # (key, value) camera overrides for both renderers
    mode: str = SNELL
    args: tuple = ()                 # extra arguments of the scene builder
    error: tuple = ()                # (kind, value): see apply_error

    def key(self) -> str:
        """A short hash of the settings both renderers share, naming the cache folder: a power
        run shares its reference renders with the null run of the same settings."""
        shared = {k: v for k, v in asdict(self).items() if k not in ("name", "error")}
        text = json.dumps(shared, sort_keys=True)
        return f"{self.scene}-{hashlib.sha1(text.encode()).hexdigest()[:10]}"

    def seed(self, run: int) -> int:
        """Run `run`'s seed: each configuration has its own block of 1000, so that runs of
        configurations of one scene (at other sample counts or depths) are independent too."""
        block = int(hashlib.sha1(self.key().encode()).hexdigest(), 16) % SEED_BLOCKS
        return block * 1000 + run

    def with_error(self, kind: str, value) -> "NullConfig":
        return replace(self, name=f"{self.name}:{kind}{value:+g}" if not isinstance(value, str)
                       else f"{self.name}:{kind}={value}", error=(kind, value))


def apply_error(scene, error):
    """The Snell scene with a deliberate error: ("ior", +d) on glass, ("roughness", x) scales
    rough glossy and glass, ("fresnel", model), ("max_depth", +d), ("focus", x),
    ("aperture", x), ("lamps", x) scales emission."""
    if not error:
        return scene
    kind, value = error
    if kind in ("ior", "roughness", "lamps"):
        out = copy.copy(scene)
        out.materials = [_changed(m, kind, value) for m in scene.materials]
        return out
    if kind == "fresnel":
        return scene.with_render(fresnel=value)
    if kind == "max_depth":
        return scene.with_render(max_depth=scene.render["max_depth"] + value)
    if kind == "focus":
        return scene.with_camera(dof={"focus_distance":
                                      scene.camera["dof"]["focus_distance"] * value})
    if kind == "aperture":
        return scene.with_camera(dof={"aperture_radius":
                                      scene.camera["dof"]["aperture_radius"] * value})
    raise ValueError(f"unknown error kind {kind!r}")


def _changed(material, kind, value):
    m = dict(material)
    if kind == "ior" and m["kind"] == "glass":
        m["ior"] = m["ior"] + value
    elif kind == "roughness" and m.get("roughness", 0.0) > 0.0:
        m["roughness"] = m["roughness"] * value
    elif kind == "lamps" and m["kind"] == "emission":
        m["strength"] = m["strength"] * value
    return m


DOF = (("aperture_radius", 0.23), ("focus_distance", 3.3))
GLASS = (("lens", 140.0), ("shift_x", 0.565), ("shift_y", -0.69))
LENS = (("aperture_radius", 0.5), ("focus_distance", 3.0))
CONFIGS = [
    NullConfig("spheres-64", "cornell_spheres", 64),
    NullConfig("spheres-256", "cornell_spheres", 256),
    NullConfig("spheres-128px-64", "cornell_spheres", 64, scale=50),
    NullConfig("spheres-1024", "cornell_spheres", 1024, cycles_seeds=16),
    *[NullConfig(f"depth-{d}", "cornell_spheres", 32, max_depth=d) for d in (1, 2, 3, 4, 5, 100)],
    *[NullConfig(f"depth-{d}-256", "cornell_spheres", 256, cycles_seeds=16, max_depth=d)
      for d in (1, 2, 3, 4)],
    NullConfig("dof-dragon", "cornell_dragon", 128, scale=19, camera=DOF),
    *[NullConfig(f"dof-dragon-{n}", "cornell_dragon", n, scale=19, camera=DOF,
                 cycles_seeds=8 if n < 1024 else 16) for n in (64, 256, 1024)],
    NullConfig("caustic-floor", "caustic_floor", 256),
    NullConfig("small-lamp", "light_room", 256),
    NullConfig("rough", "cornell_rough", 256),
    NullConfig("rough-64", "cornell_rough", 64),
    NullConfig("rough-1024", "cornell_rough", 1024, cycles_seeds=16),
    NullConfig("textured", "textured_floors", 256, scale=100),
    NullConfig("startup", "startup", 64, scale=100, max_depth=9),
    NullConfig("startup-160-256", "startup", 256, scale=250, max_depth=9),
    NullConfig("glass", "cornell_spheres", 512, max_depth=4, camera=GLASS),
    NullConfig("lens", "lens", 1024, scale=50, max_depth=1, camera=LENS, args=(6, 3, 0.5, 0.4)),
    NullConfig("exact-spheres-64", "cornell_spheres", 64, mode=EXACT),
    NullConfig("exact-startup", "startup", 64, scale=100, max_depth=9, mode=EXACT),
    NullConfig("exact-caustic-floor", "caustic_floor", 256, mode=EXACT),
]
BY_NAME = {c.name: c for c in CONFIGS}
# The deliberate errors of tests/validation/test_compare.py.
TEETH = [
    *[BY_NAME["glass"].with_error(*e) for e in
      (("fresnel", "schlick"), ("ior", 0.05), ("max_depth", 1), ("max_depth", -1))],
    *[BY_NAME["lens"].with_error(*e) for e in (("focus", 1.05), ("aperture", 1.1))],
]
# Errors of growing size at 64, 256 and 1024 spp: the smallest one caught in 9 runs of 10.
CURVES = [
    *[BY_NAME[f"spheres-{n}"].with_error("ior", d) for n in (64, 256, 1024)
      for d in (0.01, 0.02, 0.05, 0.1)],
    *[BY_NAME[f"rough{n}"].with_error("roughness", x) for n in ("-64", "", "-1024")
      for x in (1.05, 1.1, 1.2)],
    *[BY_NAME[f"dof-dragon-{n}"].with_error("focus", x) for n in (64, 256, 1024)
      for x in (1.02, 1.05, 1.1)],
]
POWER = TEETH + CURVES
BY_NAME.update({c.name: c for c in POWER})


def build_scene(name: str, folder: str, args=()) -> str:
    """The .blend of scenes/<name>.py (with args) in folder, built once in a subprocess (it
    resets bpy)."""
    tag = "-".join([name, *map(str, args)])
    path = os.path.join(folder, tag, f"{name}.blend")
    if not os.path.exists(path):
        os.makedirs(os.path.dirname(path), exist_ok=True)
        proc = subprocess.run([sys.executable, os.path.join(ROOT, "scenes", f"{name}.py"), path,
                               *map(str, args)], capture_output=True, text=True)
        if proc.returncode != 0 or not os.path.exists(path):
            raise RuntimeError(f"scenes/{name}.py failed: {proc.stderr[-500:]}")
    return path


class NullRuns:
    """Renders and caches the runs of one configuration."""

    def __init__(self, config: NullConfig, cache: str, threads: int = 2):
        self.config, self.threads = config, threads
        self.folder = os.path.join(cache, config.key())
        os.makedirs(self.folder, exist_ok=True)
        self.blend = build_scene(config.scene, os.path.join(cache, "scenes"), config.args)
        self._scene = None

    def path(self, run: int, error=()) -> str:
        slug = "" if not error else "-" + "".join(map(str, error))
        return os.path.join(self.folder, f"run{run:04d}{slug}.npz")

    def scene(self):
        """The exported Snell scene at the configuration's settings (seed set per run)."""
        if self._scene is None:
            c = self.config
            scene, _ = load_snell_scene(self.blend)
            camera = dict(c.camera)
            dof = {k: camera.pop(k) for k in ("aperture_radius", "focus_distance") if k in camera}
            scene = scene.with_camera(resolution_percentage=c.scale, **camera).with_render(
                spp=c.spp, max_depth=c.max_depth)
            if dof:
                scene = scene.with_camera(dof={"use_dof": True, **dof})
            self._scene = scene
        return self._scene

    def _cycles(self, base_seed: int, count: int | None = None):
        """The reference's images: count (default the configuration's K) seeds from
        seeds_for(count, base_seed), spp / count samples each."""
        c, scene = self.config, self.scene()
        count = count or c.cycles_seeds
        return np.stack(cycles.render_seeds(
            self.blend, spp=max(1, c.spp // count), max_depth=scene.render["max_depth"],
            seeds=cycles.seeds_for(count, base_seed), threads=self.threads,
            camera={**dict(c.camera), "resolution_percentage": c.scale},
            film=cycles.scene_film(scene),
            bounces=cycles.scene_bounces(scene)).images).astype(np.float32)

    def _snell(self, run: int, error=()):
        """Snell's batch images and light tracer share, rendered as `snell compare` does."""
        scene = apply_error(self.scene().with_render(seed=self.config.seed(run)), error)
        result = snell_render(scene, self.config.spp, threads=self.threads)
        light = np.stack(result.light_batch_images) if result.light_batch_images else None
        return np.stack(result.batch_images), light

    def render(self, run: int) -> str:
        """Render run `run` (run < 500; seeds from config.seed) unless cached; returns its .npz
        path: the reference's images, and the tested ones (with the configuration's error, if
        any)."""
        base = self.path(run)
        if not os.path.exists(base) or _stale(base):
            seed = self.config.seed(run)
            data = {"b": self._cycles(seed), "tested": TESTED}
            if self.config.mode == EXACT:
                # In Snell's place as Snell is: as many images as its batches.
                data["a"] = self._cycles(seed + 500, BATCHES)
            else:
                data["a"], light = self._snell(run)
                if light is not None:
                    data["light"] = light
            _save(base, data)
        if not self.config.error:
            return base
        path = self.path(run, self.config.error)
        if not os.path.exists(path) or _stale(path):
            a, light = self._snell(run, self.config.error)
            _save(path, {"a": a, "tested": TESTED,
                         **({"light": light} if light is not None else {})})
        return path


def _stale(path):
    with np.load(path) as cached:
        return "tested" not in cached.files or cached["tested"] != TESTED


def _save(path, arrays):
    tmp = path + ".tmp.npz"
    np.savez(tmp, **arrays)
    os.replace(tmp, path)


def run_paths(config: NullConfig, cache: str):
    """The cached runs of a configuration that the current validator made, in run order."""
    import glob
    folder = os.path.join(cache, config.key())
    slug = "" if not config.error else "-" + "".join(map(str, config.error))
    paths = sorted(glob.glob(os.path.join(folder, f"run????{slug}.npz")))
    return [p for p in paths if not _stale(p) and (not config.error or not _stale(_base(p)))]


def _base(path):
    """The null run's file beside a power run's (its reference images)."""
    return path[:path.rindex("run") + len("run0000")] + ".npz"


def load_run(path: str):
    """(tested images (n, H, W, 3), reference images (K, H, W, 3), the tested images' light
    tracer share (n, H, W, 3) or None) of a cached run, float64."""
    with np.load(path) as data:
        a = data["a"].astype(np.float64)
        light = data["light"].astype(np.float64) if "light" in data else None
    with np.load(_base(path)) as data:
        b = data["b"].astype(np.float64)
    return a, b, light


def clopper_pearson(k: int, n: int, level: float = 0.95):
    """The exact binomial interval (low, high) for k successes in n trials."""
    from scipy import stats
    lo = 0.0 if k == 0 else float(stats.beta.ppf((1 - level) / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1 - (1 - level) / 2, k + 1, n - k))
    return lo, hi


def failure_rates(results):
    """{test or "verdict": (failures, runs, rate, low, high)} over a list of statistics dicts."""
    names = sorted({t for r in results for t in r["tests"]})
    out = {}
    for name in names + ["verdict"]:
        if name == "verdict":
            fails = sum(r["verdict"] != metrics.CONSISTENT for r in results)
            n = len(results)
        else:
            runs = [r for r in results if name in r["tests"]]
            fails, n = sum(not r["tests"][name] for r in runs), len(runs)
        lo, hi = clopper_pearson(fails, n) if n else (math.nan, math.nan)
        out[name] = (fails, n, fails / n if n else math.nan, lo, hi)
    return out


def estimates(a, b, light=None):
    """(tested, reference) metrics.Estimates of a run's images (see load_run)."""
    return metrics.Estimate.from_images(a, light), metrics.Estimate.from_images(b)


def evaluate(configs, cache: str, runs: int, threads: int = 2, progress=None, render=True):
    """{config name: [statistics dict per run]} over runs 0..runs-1 of each configuration,
    rendering the runs not cached yet (unless render is False: then only the cached ones)."""
    out = {}
    for config in configs:
        if render:
            source = NullRuns(config, cache, threads)
            for run in range(runs):
                source.render(run)
                if progress is not None:
                    progress(config.name, run + 1, runs)
        results = []
        for path in run_paths(config, cache)[:runs]:
            a, b, light = load_run(path)
            results.append(metrics.compare_estimates(*estimates(a, b, light), error_metrics=False))
        out[config.name] = results
    return out


def summary(results_by_config):
    """(rows per configuration, overall failure rates): each row is the configuration's name,
    its runs and each test's failures, the whole verdict's last."""
    rows, everything = [], []
    for name, results in results_by_config.items():
        if not results:
            continue
        rates = failure_rates(results)
        rows.append({"config": name, "runs": len(results),
                     **{test: rate[0] for test, rate in rates.items()}})
        if ":" not in name:             # power runs are not null runs
            everything += results
    return rows, failure_rates(everything) if everything else {}
