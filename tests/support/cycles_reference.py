"""A Cycles reference rendered once, and Snell renders compared against it (the validator's
statistics, snell.validation.compare), shared by the tests that hold scenes against Cycles.

Stored references (Mitsuba 3's test_renders.py pattern): `tools/make_cycles_references.py`
renders the references the tests use into tests/references/<key>.npz (the per-seed images, their
seeds and times). A Reference loads its file when one is there for the same key, and renders
Cycles otherwise. The key (reference_key) hashes what Cycles renders: Blender's version, the
exported scene (geometry, normals, texture coordinates, materials, lights, camera, world, image
pixels; not its Snell-only "render" settings), the .blend's Cycles-only settings that Snell does
not export (cycles_only_settings), and the Cycles settings (spp, max depth, seed, seeds, camera
overrides, validation.cycles.forced_settings).

SNELL_CYCLES_REFERENCES selects what a Reference does:
  read (default)  load the stored file; render Cycles when there is none
  require         load the stored file; fail the test when there is none (a check that a run
                  renders no Cycles reference: the files are committed for every default test)
  update          load the stored file; render and write it when there is none
  write           render Cycles and (re)write every file
  off             ignore the files; render Cycles
SNELL_CYCLES_REFERENCES_LOG=<file> appends each Reference's key to <file> (the tool's record of
the files in use).
"""
from __future__ import annotations

import hashlib
import json
import os

import numpy as np

from support.paths import TESTS

REFERENCES = os.path.join(TESTS, "references")

SPP = 256       # samples per pixel in both renderers: Cycles as 8 seeds of SPP / 8
SCALE = 25      # resolution percentage (64x64 of the reference scenes' 256x256)
SEED = 0
MODES = ("read", "require", "update", "write", "off")


class Reference:
    """A Cycles reference plus the exported Snell scene at the test resolution."""

    def __init__(self, blend, dof=None, framing=None, max_depth=None, spp=SPP, cycles_seeds=8):
        from snell.validation import compare, cycles
        self.blend, self.spp = blend, spp
        scene, self.warnings = compare.load_snell_scene(blend)
        dof, framing = dict(dof or {}), dict(framing or {})
        framing = {"resolution_percentage": SCALE, **framing}
        scene = scene.with_camera(**framing).with_render(
            spp=spp, seed=SEED, max_depth=max_depth)
        if dof:
            scene = scene.with_camera(dof={"use_dof": True, **dof})
        self.scene = scene
        settings = {"spp": spp, "max_depth": scene.render["max_depth"], "seed": SEED,
                    "camera": {**dof, **framing}, "n_seeds": cycles_seeds,
                    "film": list(cycles.scene_film(scene))}
        bounces = cycles.scene_bounces(scene)
        if bounces is not None:     # only then: the stored references' keys stay
            settings["bounces"] = list(bounces)
        caustics = cycles.scene_caustics(scene)
        if caustics is not None:    # likewise
            settings["caustics"] = list(caustics)
        self.key = reference_key(scene, settings, cycles_only_settings())
        self.path = os.path.join(REFERENCES, self.key + ".npz")
        mode = os.environ.get("SNELL_CYCLES_REFERENCES", "read")
        if mode not in MODES:
            raise ValueError(f"SNELL_CYCLES_REFERENCES={mode!r}: one of {', '.join(MODES)}")
        log = os.environ.get("SNELL_CYCLES_REFERENCES_LOG")
        if log:
            with open(log, "a") as f:
                f.write(self.key + "\n")
        self.normals = normal_moments(scene)
        self.cycles = (load_cycles(self.path, self.normals) if mode in ("read", "require", "update")
                       else None)
        self.stored = self.cycles is not None
        if self.cycles is None:
            if mode == "require":
                import pytest
                pytest.fail(f"no stored Cycles reference {os.path.relpath(self.path, TESTS)} for "
                            f"{os.path.basename(blend)} (SNELL_CYCLES_REFERENCES=require); "
                            "tools/make_cycles_references.py renders it", pytrace=False)
            self.cycles = compare.cycles_render(blend, **settings)
            if mode in ("write", "update"):
                save_cycles(self.path, self.cycles, self.normals)

    def compare(self, modify=lambda s: s, noise_threshold=0.0, spp=None, **snell):
        """The validator's report dict for Snell (modify: a deliberate change; snell: options of
        compare.snell_render) against Cycles."""
        from snell.validation import compare
        scene = modify(self.scene)
        result = compare.snell_render(scene, spp or self.spp, noise_threshold=noise_threshold,
                                      **snell)
        return compare.compare_renders(result, self.cycles, settings=compare.snell_settings(scene),
                                       scene=scene)


class PassesReference:
    """Cycles' Denoising Albedo and Denoising Normal passes of a .blend (8 seeds), stored as a
    Reference's images are (one file per pass), and Snell's passes compared against them: both
    are Monte Carlo estimates, so the validator's statistics apply unchanged."""

    def __init__(self, blend, framing=None, max_depth=None, spp=SPP, cycles_seeds=8):
        from snell.validation import compare, cycles
        self.blend, self.spp, self.n_seeds = blend, spp, cycles_seeds
        scene, self.warnings = compare.load_snell_scene(blend)
        framing = {"resolution_percentage": SCALE, **dict(framing or {})}
        self.scene = scene.with_camera(**framing).with_render(spp=spp, seed=SEED,
                                                              max_depth=max_depth)
        max_depth = self.scene.render["max_depth"]
        settings = {"spp": spp, "max_depth": max_depth, "seed": SEED, "camera": framing,
                    "n_seeds": cycles_seeds, "passes": list(cycles.DENOISING_PASSES)}
        base = reference_key(self.scene, settings, cycles_only_settings())
        self.keys = {name: hashlib.sha256(f"{base} {name}".encode()).hexdigest()[:20]
                     for name in cycles.DENOISING_PASSES}
        mode = os.environ.get("SNELL_CYCLES_REFERENCES", "read")
        log = os.environ.get("SNELL_CYCLES_REFERENCES_LOG")
        if log:
            with open(log, "a") as f:
                f.write("".join(key + "\n" for key in self.keys.values()))
        normals = normal_moments(self.scene)
        paths = {name: os.path.join(REFERENCES, key + ".npz") for name, key in self.keys.items()}
        self.cycles = {}
        if mode in ("read", "require", "update"):
            for name, path in paths.items():
                self.cycles[name] = load_cycles(path, normals)
        self.stored = all(v is not None for v in self.cycles.values()) and bool(self.cycles)
        if not self.stored:
            if mode == "require":
                import pytest
                pytest.fail(f"no stored Cycles denoising passes for {os.path.basename(blend)} "
                            "(SNELL_CYCLES_REFERENCES=require); tools/make_cycles_references.py "
                            "renders them", pytrace=False)
            per_seed = max(1, -(-spp // cycles_seeds))
            self.cycles = cycles.render_denoising_passes(
                blend, spp=per_seed, max_depth=max_depth,
                seeds=cycles.seeds_for(cycles_seeds, SEED), camera=framing)
            if mode in ("write", "update"):
                for name, path in paths.items():
                    save_cycles(path, self.cycles[name], normals)

    def snell_images(self, modify=lambda s: s) -> dict:
        """{pass name: (seeds, H, W, 3)} of Snell's passes: as many independent renders as
        Cycles' seeds, each of the same samples per pixel as one of Cycles'."""
        from snell.tracer.integrator import Renderer
        from snell.validation import cycles
        scene = modify(self.scene)
        per_seed = max(1, -(-self.spp // self.n_seeds))
        images = {name: [] for name in cycles.DENOISING_PASSES}
        for k in range(self.n_seeds):
            settings = scene.settings(threads=2, sampler="independent", spp=per_seed,
                                      seed=1000 + k, noise_threshold=0.0, time_limit=0.0,
                                      caustics=False, light_vertices=False,
                                      denoising_passes=True)
            result = Renderer(scene, settings).render()
            images["Denoising Albedo"].append(result.denoising_albedo())
            images["Denoising Normal"].append(result.denoising_normal())
        return {name: np.stack(stack).astype(np.float64) for name, stack in images.items()}

    def compare(self, modify=lambda s: s) -> dict:
        """{pass name: the validator's statistics} of Snell's passes against Cycles'."""
        from snell.validation import metrics
        out = {}
        for name, images in self.snell_images(modify).items():
            a = metrics.Estimate.from_images(images)
            b = metrics.Estimate.from_images(np.stack(self.cycles[name].images))
            out[name] = metrics.compare_estimates(a, b, error_metrics=False)
        return out


def without_light_tracer(result):
    """A deliberate error: a Snell render's light-traced part taken out of its batches, while
    its path tracer still skips those paths (the caustic then rendered by nothing)."""
    result.batch_images = [b - l for b, l in zip(result.batch_images, result.light_batch_images)]
    result.light_batch_images = [np.zeros_like(l) for l in result.light_batch_images]
    return result


def verdict(result):
    """(verdict, the numbers an assertion message should show)."""
    detail = {k: result[k] for k in ("tests", "z_pass_fraction", "tiles_failed", "mean_z",
                                     "mean_ratio", "sharpness_z")}
    return result["verdict"], detail


def assert_image_and_alpha_consistent(report):
    """Assert a report's image and alpha channel are both consistent; returns the alpha's."""
    v, detail = verdict(report)
    assert v == "consistent", (detail, report.get("alpha_channel"))
    alpha = report["alpha_channel"]
    assert alpha["verdict"] == "consistent", alpha
    return alpha


def blender_version():
    import bpy
    return list(bpy.app.version)


def reference_key(scene, settings, cycles_only=None):
    """A hash of what Cycles renders: the Blender version, the Snell scene as exported (arrays and
    header, without the paths the .blend and its images were written to, and without the
    Snell-only "render" settings: the Cycles settings carry spp, max depth and seed), the .blend's
    Cycles-only settings (cycles_only_settings) and the Cycles settings, with the settings
    validation.cycles forces on every render."""
    from snell.validation import cycles
    header = scene.header()
    header.pop("source", None)
    header.pop("render", None)
    for image in header["images"]:
        image.pop("source", None)
    per_seed = max(1, -(-settings["spp"] // settings["n_seeds"]))
    film, bounces = settings.get("film"), settings.get("bounces")
    caustics = settings.get("caustics")
    forced = [(k, v) for k, v, _ in cycles.forced_settings(settings["max_depth"], per_seed, 0,
                                                           film=film and tuple(film),
                                                           bounces=bounces and tuple(bounces),
                                                           caustics=caustics and
                                                           tuple(caustics))
              if k not in ("cycles.seed", "render.threads")]
    h = hashlib.sha256(json.dumps([blender_version(), header, settings, forced, cycles_only],
                                  sort_keys=True, default=str).encode())
    h.update(geometry_digest(scene).encode())
    return h.hexdigest()[:20]


def geometry_digest(scene):
    """A hash of the exported geometry that is the same for the same .blend built twice: Blender
    numbers the triangles differently from one build of a scene script to the next and its
    smooth normals differ in the last bit, so the triangles are hashed as a sorted set (corners
    rotated to a canonical first corner, keeping the winding that one-sided lamps and backfaces
    depend on), with their material and object, whether each corner is smooth-shaded (its normal
    more than 0.3 degrees from the face's) and their texture coordinates to 1e-5."""
    corners = scene.positions[scene.triangles].astype(np.float32)            # (T, 3, 3)
    t = len(corners)
    flat = corners.reshape(-1, 3)
    rank = np.empty(len(flat), np.int64)
    rank[np.lexsort(flat.T[::-1])] = np.arange(len(flat))
    first = rank.reshape(t, 3).argmin(axis=1)
    roll = (first[:, None] + np.arange(3)[None, :]) % 3                        # (T, 3)
    rows = np.arange(t)[:, None]
    columns = [corners[rows, roll].reshape(t, 9).astype(np.float64),
               scene.material_ids[:, None].astype(np.float64),
               scene.object_ids[:, None].astype(np.float64)]
    if scene.normals is not None and len(scene.normals):
        g = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]).astype(np.float64)
        g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-30)
        n = scene.normals[scene.triangles].astype(np.float64)[rows, roll]
        n /= np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-30)
        columns.append((np.einsum("tk,tck->tc", g, n) < 1 - 1.5e-5).astype(np.float64))
    for tc in scene.texcoords:
        columns.append(np.round(np.asarray(tc["coords"], np.float64)[rows, roll].reshape(t, 9), 5))
    table = np.ascontiguousarray(np.concatenate(columns, axis=1)) if t else np.zeros((0, 11))
    table = table[np.lexsort(table.T[::-1])] if t else table
    return hashlib.sha256(table.tobytes()).hexdigest()


def normal_moments(scene):
    """{object index: [corners, sum of corner normals (3), sum of normal x position (9)]}: what
    the key cannot hold of the smooth normals (their last bits differ from one build to the next),
    checked within NORMAL_TOLERANCE when a stored reference is loaded."""
    if scene.normals is None or not len(scene.normals):
        return {}
    n = scene.normals[scene.triangles].astype(np.float64).reshape(-1, 3)
    p = scene.positions[scene.triangles].astype(np.float64).reshape(-1, 3)
    ids = np.repeat(scene.object_ids, 3)
    out = {}
    for i in np.unique(ids):
        sel = ids == i
        out[str(int(i))] = [int(sel.sum()), *n[sel].sum(axis=0).tolist(),
                            *np.einsum("ci,cj->ij", n[sel], p[sel]).ravel().tolist()]
    return out


NORMAL_TOLERANCE = 1e-5   # per corner and metre: Blender's builds differ by about 1e-7


def moments_match(stored, current):
    if stored is None:
        return True
    if set(stored) != set(current):
        return False
    for k, a in current.items():
        b = stored[k]
        scale = a[0] * NORMAL_TOLERANCE * (1.0 + max(abs(x) for x in a[4:]) / max(a[0], 1))
        if a[0] != b[0] or max(abs(x - y) for x, y in zip(a[1:], b[1:])) > scale:
            return False
    return True


# The Cycles-only settings of the open .blend that Snell's exporter does not read (so they are not
# in the exported scene) but that change what Cycles renders: the `cycles` settings of the scene,
# materials (emission sampling), worlds and lights, and objects' ray visibility.
OBJECT_VISIBILITY = ("visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission",
                     "visible_volume_scatter", "visible_shadow", "is_shadow_catcher", "is_holdout",
                     "hide_render")
OBJECT_CAUSTICS = ("is_caustics_caster", "is_caustics_receiver")


def cycles_only_settings():
    """{datablock: {setting: value}} of the .blend bpy has open (the one just exported)."""
    import bpy
    out = {}
    scene = bpy.context.scene
    out["scene"] = _rna_values(getattr(scene, "cycles", None))
    for kind in ("materials", "worlds", "lights"):
        for block in getattr(bpy.data, kind):
            out[f"{kind}/{block.name}"] = _rna_values(getattr(block, "cycles", None))
    for ob in scene.objects:
        out[f"objects/{ob.name}"] = {k: getattr(ob, k) for k in OBJECT_VISIBILITY if hasattr(ob, k)}
        # Shadow caustics' caster and receiver flags, only where set (older keys stay valid).
        flags = {k: True for k in OBJECT_CAUSTICS if getattr(getattr(ob, "cycles", None), k, False)}
        if flags:
            out[f"objects/{ob.name}"].update(flags)
    return out


def _rna_values(struct):
    """The plain values (numbers, booleans, strings, enums and their arrays) of a property group."""
    if struct is None:
        return None
    values = {}
    for prop in struct.bl_rna.properties:
        if prop.identifier == "rna_type" or prop.type in ("POINTER", "COLLECTION"):
            continue
        value = getattr(struct, prop.identifier, None)
        if prop.type == "ENUM" and prop.is_enum_flag:
            value = sorted(value)
        elif hasattr(value, "__len__") and not isinstance(value, str):
            value = list(value)
        if isinstance(value, float):
            value = float(np.float32(value))
        values[prop.identifier] = value
    return values


# The per-seed images are stored as float16 (half the size of float32) where float16's rounding
# (2^-11 relative) is far below the across-seed noise the statistics use: a pixel whose seeds'
# standard deviation is at least PRECISE_NOISE times its rounding keeps its variance to a few %
# and its mean to a twentieth of its standard error (measured on the 29 stored references: 2.9 %
# and 0.045 at most; the median variance change 0.17 % at most). The other pixels (those every
# seed rendered alike, a lamp or the world seen directly, which the validator holds to Snell's
# exactly, and those of little noise) are stored as float32, as are images float16 cannot hold.
HALF_MAX = 60000.0
PRECISE_NOISE = 30.0


def float16_rounding(stack):
    """Half of float16's spacing at each pixel's largest value (normal and subnormal range)."""
    return np.maximum(np.abs(stack).max(axis=0) * 2.0 ** -11, 2.0 ** -25)


def save_cycles(path, cyc, normals=None):
    """Write a CyclesResult (normals: the scene's normal_moments, checked when it is loaded)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    meta = {"blender": blender_version(), "spp": cyc.spp, "seeds": list(cyc.seeds),
            "time_s": cyc.time_s, "settings": [list(s) for s in cyc.settings],
            "normals": normals}
    stack = np.stack(cyc.images).astype(np.float32)
    arrays = {"meta": np.array(json.dumps(meta, default=str))}
    if np.all(np.isfinite(stack)) and np.abs(stack).max(initial=0.0) < HALF_MAX:
        noise = stack.astype(np.float64).std(axis=0, ddof=1)
        precise = np.flatnonzero(noise < PRECISE_NOISE * float16_rounding(stack)).astype(np.int32)
        arrays.update(images=stack.astype(np.float16), precise=precise,
                      precise_values=stack.reshape(len(stack), -1)[:, precise])
    else:
        arrays.update(images=stack)
    if cyc.alpha_images:          # a transparent film's alpha, per seed
        arrays.update(alpha=np.stack(cyc.alpha_images).astype(np.float32))
    tmp = path + ".tmp.npz"
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)


def load_cycles(path, normals=None):
    """The stored CyclesResult, or None (no file, another Blender version, or normals, given as
    normal_moments, other than the stored scene's)."""
    from snell.validation.cycles import CyclesResult
    if not os.path.exists(path):
        return None
    with np.load(path) as data:
        meta = json.loads(str(data["meta"]))
        if meta["blender"] != blender_version():
            return None
        if normals is not None and not moments_match(meta.get("normals"), normals):
            return None
        stack = data["images"].astype(np.float32)
        if "precise" in data.files:
            stack.reshape(len(stack), -1)[:, data["precise"]] = data["precise_values"]
        stack = stack.astype(np.float64)
        alphas = list(data["alpha"].astype(np.float64)) if "alpha" in data.files else []
    # As cycles.render_seeds makes them: the mean and the variance of the mean over the seeds.
    return CyclesResult(stack.mean(axis=0), stack.var(axis=0, ddof=1) / len(stack), meta["spp"],
                        meta["seeds"], meta["time_s"], [tuple(s) for s in meta["settings"]],
                        list(stack), alphas)
