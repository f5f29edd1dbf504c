"""The Snell scene file: one versioned .npz written by the exporter and read by the tracer.

The format is documented in docs/scene-format.md. Every check here raises SceneError naming the
field at fault, so that a bad export never reaches the integrator.
"""
from __future__ import annotations

import copy
import hashlib
import json
import math
from dataclasses import dataclass, field

import numpy as np

from .atomic import atomic_path
from .checks import SceneError
from .checks import finite_number as _finite_number
from .checks import int_in as _int_in
from .checks import short as _short
from .settings import DEFAULT_RENDER, SCENE, RenderSettings, of_scope

FORMAT = "snell-scene"
VERSION = 4
# Version 2 added spot lamps and lamp radius, spread, angle and flags; version 3 the glossy and
# principled materials and the roughness of glass and refraction; version 4 orthographic cameras,
# images (stored in the file) and the world's environment map. Shader programs (the "program"
# material) and object texture coordinates came without a new version: they are additions that
# an older reader rejects by name ("unknown material kind 'program'").
READS_VERSIONS = (1, 2, 3, 4)
# The tracer's material and distribution codes are positions in these tuples: add at the end.
# "program": a shader node tree compiled to instructions (tracer/shader/program.py).
MATERIAL_KINDS = ("diffuse", "mirror", "glass", "refraction", "emission", "glossy", "principled",
                  "program")
DISTRIBUTIONS = ("ggx", "multi_ggx", "beckmann")
LIGHT_KINDS = ("area", "point", "spot", "sun")
LIGHT_FLAGS = ("visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission",
               "cast_shadow", "use_mis")
AREA_SHAPES = ("rectangle", "square", "disk", "ellipse")
SENSOR_FITS = ("AUTO", "HORIZONTAL", "VERTICAL")
CAMERA_TYPES = ("PERSP", "ORTHO")    # camera.type (version 4); absent: PERSP
INTERPOLATIONS = ("linear", "closest")
EXTENSIONS = ("repeat", "extend", "clip", "mirror")     # textures.REPEAT ... MIRROR
COLORSPACES = ("linear", "srgb")
# Then four world-space attributes for normal maps (tracer/shader/normals.py), and a mesh
# attribute or an object's property by name: its value, and its (Fac, Alpha, found)
# (tracer/shader/object_inputs.py).
TEXCOORD_KINDS = ("uv", "generated", "object", "tangent", "tangent_sign", "tangent_normal",
                  "normal_matrix", "attribute", "attribute_extra", "object_attribute",
                  "object_attribute_extra")
# The inputs an image texture may drive, by material kind (docs/scene-format.md).
TEXTURE_SLOTS = ("color", "roughness", "metallic")
TEXTURABLE = {"diffuse": ("color",), "mirror": ("color",), "glossy": ("color", "roughness"),
              "glass": ("color", "roughness"), "refraction": ("color", "roughness"),
              "principled": ("color", "roughness", "metallic")}
MAX_IMAGES = 4096

# Bounds on integers that size arrays or loops (and MAX_INT, settings.py): a file may hold any
# integer, and one past these would end the render with an overflow or an allocation failure
# instead of a named field.
MAX_RESOLUTION = 65536      # Blender's own limit per side
# Vertex coordinates stop here: Embree intersects in float32, whose squares overflow near 1.8e19.
MAX_COORDINATE = 1e18
MAX_BLADES = 1000

# The optional material fields of each kind and what a file without them means: Blender's node
# defaults (Glossy, Glass, Refraction and Principled BSDF), and for glass and refraction a smooth
# surface, so that files written before roughness read as before. Read them with material_field.
MATERIAL_DEFAULTS = {
    "glossy": {"roughness": 0.5, "distribution": "multi_ggx"},
    "glass": {"roughness": 0.0, "distribution": "multi_ggx"},
    "refraction": {"roughness": 0.0, "distribution": "beckmann"},
    "principled": {
        "metallic": 0.0, "roughness": 0.5, "ior": 1.5, "specular_ior_level": 0.5,
        "specular_tint": [1.0, 1.0, 1.0], "transmission": 0.0, "coat_weight": 0.0,
        "coat_roughness": 0.03, "coat_ior": 1.5, "coat_tint": [1.0, 1.0, 1.0],
        "emission_color": [1.0, 1.0, 1.0], "emission_strength": 0.0, "distribution": "multi_ggx"},
}
# (kind, field) whose default is another field of the same material.
DEFAULT_FROM_FIELD = {("glass", "transmission_color"): "color"}
# (least, greatest, least excluded) of the numeric fields above; colours are never negative.
MATERIAL_RANGES = {
    "roughness": (0.0, 1.0, False), "metallic": (0.0, 1.0, False),
    "transmission": (0.0, 1.0, False), "coat_roughness": (0.0, 1.0, False),
    "ior": (0.0, None, True), "specular_ior_level": (0.0, None, False),
    "coat_weight": (0.0, None, False), "coat_ior": (1.0, None, False),
    "emission_strength": (0.0, None, False),
}
# The distributions Blender offers on each node (Refraction BSDF: no multiscatter GGX;
# Principled BSDF: no Beckmann).
MATERIAL_DISTRIBUTIONS = {"glossy": DISTRIBUTIONS, "glass": DISTRIBUTIONS,
                          "refraction": ("ggx", "beckmann"), "principled": ("ggx", "multi_ggx")}

DEFAULT_DOF = {"use_dof": False, "focus_distance": 10.0, "fstop": 2.8, "blades": 0,
               "rotation": 0.0, "ratio": 1.0}


@dataclass
class Scene:
    """Geometry arrays plus the parsed header (materials, lights, camera, world, render)."""
    positions: np.ndarray
    triangles: np.ndarray
    material_ids: np.ndarray
    object_ids: np.ndarray
    materials: list
    lights: list
    camera: dict
    world: dict = field(default_factory=lambda: {"color": [0.0, 0.0, 0.0]})
    render: dict = field(default_factory=lambda: dict(DEFAULT_RENDER))
    objects: list = field(default_factory=list)
    normals: np.ndarray | None = None
    source: str = ""
    # Images the world and materials use: {"name", "source" (where the exporter read it),
    # "colorspace" (linear, or srgb: decoded after interpolation, as Cycles does), "pixels":
    # float32 (H, W, C), top row first}; the file stores the pixels.
    images: list = field(default_factory=list)
    # Texture coordinates the materials' textures read: {"kind": uv, generated or object (the
    # object-space position), "name": the UV
    # map ("" the active one), "coords": float32 (T, 3, 3), per triangle corner}.
    texcoords: list = field(default_factory=list)
    # What the exporter made of each material's shader nodes, in the materials' order:
    # {"name", "kind", "evaluated": [...], "replaced": [...]} (addon/export/coverage.py), for
    # `snell info`. Empty for a scene read from a file: the file does not keep it.
    coverage: list = field(default_factory=list)
    # The view layer's light groups, by name (Cycles' light groups: tracer/light_groups.py);
    # lights, objects and the world join one by its index ("light_group").
    light_groups: list = field(default_factory=list)

    def header(self) -> dict:
        """The JSON header as written to the file."""
        images = [{"name": im["name"], "source": im.get("source", ""),
                   "colorspace": im.get("colorspace", "linear"),
                   "shape": list(im["pixels"].shape), "sha256": image_hash(im["pixels"])}
                  for im in self.images]
        texcoords = [{"kind": tc["kind"], "name": tc.get("name", "")} for tc in self.texcoords]
        # Written only when there are light groups: files without them read as before.
        groups = {"light_groups": self.light_groups} if self.light_groups else {}
        return {"format": FORMAT, "version": VERSION, "source": self.source,
                "objects": self.objects, "materials": self.materials, "lights": self.lights,
                "world": self.world, "camera": self.camera, "render": self.render,
                "images": images, "texcoords": texcoords, **groups}

    def with_render(self, **overrides) -> "Scene":
        """A copy sharing the arrays, with saved render settings overridden (None: ignored)."""
        saved = {s.name for s in of_scope(SCENE)}
        for key in overrides:
            if key not in saved:
                raise SceneError(f"render.{key}: not a setting the scene file saves")
        other = copy.copy(self)
        other.render = {**self.render, **{k: v for k, v in overrides.items() if v is not None}}
        _check_render(other.render)
        return other

    def settings(self, **overrides) -> RenderSettings:
        """The scene's render settings with any settings overridden, checked (a render's)."""
        return RenderSettings.from_render(self.render, **overrides)

    def with_camera(self, **overrides) -> "Scene":
        """A copy sharing the arrays, with camera fields (or dof fields via dof={...})
        overridden."""
        other = copy.copy(self)
        other.camera = copy.deepcopy(self.camera)
        dof = overrides.pop("dof", None)
        other.camera.update(overrides)
        if dof:
            other.camera["dof"].update(dof)
        _check_camera(other.camera)
        return other

    def features(self) -> dict:
        """Which costly features the scene needs: glass, mirrors, rough surfaces, depth of field,
        world light, an environment map, emissive meshes, image textures."""
        used = (set(int(m) for m in np.unique(self.material_ids)) if len(self.material_ids)
                else set())
        mats = [self.materials[i] for i in sorted(used)]
        return {
            "glass": any(refracts(m) for m in mats),
            "mirrors": any(is_mirror(m) for m in mats),
            "rough": any(is_rough(m) for m in mats),
            "depth_of_field": aperture_radius(self.camera) > 0.0,
            "world": has_world_light(self.world),
            "environment": self.world.get("environment") is not None,
            "emissive_meshes": any(emits(m) for m in mats),
            "textures": any(m.get("textures") for m in mats),
        }


def image_hash(pixels: np.ndarray) -> str:
    """SHA-256 of an image's pixel bytes (C order), as the header records it."""
    return hashlib.sha256(np.ascontiguousarray(pixels).data).hexdigest()


def has_world_light(world: dict) -> bool:
    """Whether the world gives light: an environment map of strength above 0, or a colour."""
    env = world.get("environment")
    if env is not None:
        return env["strength"] > 0
    return any(c > 0 for c in world["color"])


def material_field(mat: dict, key: str):
    """A material's field, or the default its kind gives it when the file leaves it out."""
    if key in mat:
        return mat[key]
    if (mat["kind"], key) in DEFAULT_FROM_FIELD:
        return mat[DEFAULT_FROM_FIELD[mat["kind"], key]]
    defaults = MATERIAL_DEFAULTS.get(mat["kind"], {})
    if key not in defaults:
        raise KeyError(f"material kind {mat['kind']!r} has no field {key!r}")
    return defaults[key]


def emits(mat: dict) -> bool:
    """Whether a material emits light: emission, principled with a visible emission, or a
    program with an emission (constant or not)."""
    if mat["kind"] == "program":
        return (any(c > 0 for c in mat.get("emission", ()))
                or bool(mat["program"].get("emission_varies")))
    if mat["kind"] != "principled":
        return mat["kind"] == "emission"
    return (material_field(mat, "emission_strength") > 0
            and any(c > 0 for c in material_field(mat, "emission_color")))


def refracts(mat: dict) -> bool:
    """Whether light passes through a material: glass, refraction, principled transmission, a
    program with a refracting or transparent closure."""
    if mat["kind"] == "program":
        return bool(mat["program"].get("refracts"))
    if mat["kind"] == "principled":
        return material_field(mat, "transmission") > 0
    return mat["kind"] in ("glass", "refraction")


def is_mirror(mat: dict) -> bool:
    """Whether a material is a perfect mirror: mirror, or glossy of roughness 0."""
    return mat["kind"] == "mirror" or (mat["kind"] == "glossy"
                                       and material_field(mat, "roughness") == 0)


def is_rough(mat: dict) -> bool:
    """Whether a material is rough: glossy, principled, glass or refraction of roughness > 0."""
    # Glossy counts at roughness 0 too, though the tracer renders that as a mirror
    # (materials.kind_code, which also treats Cycles' near-zero roughness as smooth).
    if mat["kind"] in ("glass", "refraction"):
        return material_field(mat, "roughness") > 0
    return mat["kind"] in ("glossy", "principled", "program")


def aperture_radius(camera: dict) -> float:
    """Lens radius in metres: Cycles' lens / (2 f-stop) (orthographic: 1 / (2 f-stop)), 0 when
    depth of field is off."""
    dof = camera["dof"]
    if not dof.get("use_dof", False):
        return 0.0
    if dof.get("aperture_radius") is not None:
        return float(dof["aperture_radius"])
    lens = 1.0 if camera.get("type") == "ORTHO" else camera["lens"] * 1e-3
    return lens / (2.0 * max(float(dof["fstop"]), 1e-5))


# ---------------------------------------------------------------------------------------------
# Validation


def _finite_vec(value, name, n=3, positive=False):
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an integer beyond float64
        raise SceneError(f"{name}: expected {n} numbers, got {_short(value)}") from None
    if arr.shape != (n,):
        raise SceneError(f"{name}: expected {n} numbers, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise SceneError(f"{name}: contains NaN or Inf ({_short(value)})")
    if positive and np.any(arr < 0):
        raise SceneError(f"{name}: must not be negative ({_short(value)})")
    return arr


def exact_unit_scale(m: np.ndarray) -> np.ndarray:
    """m divided by the power of two at or above its largest magnitude (exact: the same
    directions), so that squares and products of its entries neither overflow nor underflow."""
    big = float(np.abs(m).max(initial=0.0))
    return np.ldexp(m, -int(np.frexp(big)[1])) if big > 0.0 else m


def _matrix(value, name, size=4):
    """A finite size x size matrix, or a SceneError naming the field."""
    try:
        m = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise SceneError(f"{name}: expected a {size}x{size} matrix") from None
    if m.shape != (size, size):
        raise SceneError(f"{name}: expected a {size}x{size} matrix, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise SceneError(f"{name}: contains NaN or Inf")
    return m


def _check_array(arrays, key, dtype, ncols):
    if key not in arrays:
        raise SceneError(f"{key}: missing array")
    arr = arrays[key]
    if not isinstance(arr, np.ndarray):
        raise SceneError(f"{key}: expected an array, got {type(arr).__name__}")
    if arr.dtype != dtype:
        raise SceneError(f"{key}: expected dtype {_dtype_name(dtype)}, "
                         f"got {_dtype_name(arr.dtype)}")
    want_ndim = 1 if ncols is None else 2
    if arr.ndim != want_ndim or (ncols is not None and arr.shape[1] != ncols):
        want = "(n,)" if ncols is None else f"(n, {ncols})"
        raise SceneError(f"{key}: expected shape {want}, got {arr.shape}")
    return arr


def _dtype_name(dtype) -> str:
    """A dtype's name, with its byte order where it is not the machine's ("big-endian float32")."""
    dtype = np.dtype(dtype)
    order = {">": "big-endian ", "<": "little-endian "}.get(dtype.byteorder, "")
    native = "<" if np.little_endian else ">"
    return (order if dtype.byteorder != native else "") + dtype.name


def _entry_kind(section, i, entry, kinds):
    """The name to report an entry of a header list by, and its checked kind."""
    where = f"{section}[{i}]" + (f" ({_short(entry.get('name'), 40)})"
                                 if isinstance(entry, dict) else "")
    if not isinstance(entry, dict):
        raise SceneError(f"{where}: expected an object")
    kind = entry.get("kind")
    if kind not in kinds:
        what = section[:-1]
        raise SceneError(f"{where}.kind: unknown {what} kind {_short(kind)} "
                         f"(known: {', '.join(kinds)})")
    return where, kind


def _check_textures(where, kind, textures, images, texcoords):
    if not isinstance(textures, dict):
        raise SceneError(f"{where}.textures: expected an object, got {_short(textures)}")
    for slot, tex in textures.items():
        name = f"{where}.textures.{slot}"
        if slot not in TEXTURABLE.get(kind, ()):
            raise SceneError(f"{name}: a {kind} material has no texture input {slot!r} "
                             f"(it has: {', '.join(TEXTURABLE.get(kind, ())) or 'none'})")
        if not isinstance(tex, dict):
            raise SceneError(f"{name}: expected an object, got {_short(tex)}")
        _int_in(tex.get("image"), f"{name}.image", 0, len(images) - 1, "an image index")
        _int_in(tex.get("texcoord"), f"{name}.texcoord", 0, len(texcoords) - 1,
                "a texcoord index")
        for key, choices in (("interpolation", INTERPOLATIONS), ("extension", EXTENSIONS)):
            if tex.get(key) not in choices:
                raise SceneError(f"{name}.{key}: expected one of {', '.join(choices)}, "
                                 f"got {_short(tex.get(key))}")
        _matrix3(tex.get("matrix"), f"{name}.matrix", singular_ok=True)
        _finite_vec(tex.get("offset"), f"{name}.offset")


def _matrix3(value, name, singular_ok=False):
    m = _matrix(value, name, 3)
    if not singular_ok and not abs(np.linalg.det(m)) > 1e-12:
        raise SceneError(f"{name}: singular (a zero scale in the mapping)")
    return m


def _check_material(i, mat, images=(), texcoords=()):
    where, kind = _entry_kind("materials", i, mat, MATERIAL_KINDS)
    if mat.get("absorption") is not None:
        # The Volume output's absorption coefficient sigma_a per metre (tracer/media.py).
        _finite_vec(mat["absorption"], f"{where}.absorption", positive=True)
    if kind == "program":
        # Here, not at the top: the program's SPECS live beside its compiled code, which a
        # reader of scenes without programs need not import (Numba).
        from .shader.program import ProgramError, check_program
        try:
            check_program(mat.get("program"), len(images), len(texcoords))
        except ProgramError as exc:
            raise SceneError(f"{where}.program: {exc}") from None
        if "emission" in mat:
            _finite_vec(mat["emission"], f"{where}.emission", positive=True)
        return
    if mat.get("textures") is not None:
        _check_textures(where, kind, mat["textures"], images, texcoords)
    _finite_vec(mat.get("color"), f"{where}.color", positive=True)
    if kind in ("glass", "refraction"):
        _finite_number(mat.get("ior"), f"{where}.ior", 0.0, exclusive=True)
    if kind == "glass" and "transmission_color" in mat:
        _finite_vec(mat["transmission_color"], f"{where}.transmission_color", positive=True)
    if kind == "emission":
        _finite_number(mat.get("strength"), f"{where}.strength", 0.0)
    for key, default in MATERIAL_DEFAULTS.get(kind, {}).items():
        if key in mat:
            _check_material_field(f"{where}.{key}", kind, key, mat[key], default)


def _check_material_field(name, kind, key, value, default):
    """One optional material field, of the type of its default: a name, a colour or a number."""
    if isinstance(default, str):
        choices = MATERIAL_DISTRIBUTIONS[kind]
        if not isinstance(value, str) or value not in choices:
            raise SceneError(f"{name}: expected one of {', '.join(choices)}, got {_short(value)}")
    elif isinstance(default, list):
        _finite_vec(value, name, positive=True)
    else:
        least, greatest, exclusive = MATERIAL_RANGES[key]
        value = _finite_number(value, name, least, exclusive)
        if greatest is not None and value > greatest:
            raise SceneError(f"{name}: must be at most {greatest:g}, got {value!r}")


def _check_flag(light, key, where):
    if key in light and not isinstance(light[key], bool):
        raise SceneError(f"{where}.{key}: expected true or false, got {_short(light[key])}")


def _check_angle(light, key, where, maximum=math.pi, default=None):
    value = light.get(key, default)
    if value is None:
        raise SceneError(f"{where}.{key}: missing")
    value = _finite_number(value, f"{where}.{key}", 0.0)
    if value > maximum * (1.0 + 1e-6):     # Blender's float32 pi is 8.7e-8 above pi
        raise SceneError(f"{where}.{key}: must be at most {maximum:g} radians, got {value!r}")


def _check_light(i, light):
    where, kind = _entry_kind("lights", i, light, LIGHT_KINDS)
    for key in LIGHT_FLAGS + ("caustics_light",):
        _check_flag(light, key, where)
    if kind == "area":
        if light.get("shape") not in AREA_SHAPES:
            raise SceneError(f"{where}.shape: unknown area shape {_short(light.get('shape'))} "
                             f"(known: {', '.join(AREA_SHAPES)})")
        m = _matrix(light.get("matrix"), f"{where}.matrix")
        size = _finite_vec(light.get("size"), f"{where}.size", n=2)
        if np.any(size < 0):
            raise SceneError(f"{where}.size: must not be negative ({size.tolist()})")
        if np.any(size == 0):
            raise SceneError(f"{where}: zero-area emitter (size {size.tolist()})")
        if abs(np.linalg.det(m[:3, :3])) < 1e-300:
            raise SceneError(f"{where}.matrix: singular (zero scale)")
        _finite_vec(light.get("radiance"), f"{where}.radiance", positive=True)
        _check_angle(light, "spread", where, default=math.pi)
    elif kind in ("point", "spot"):
        _finite_vec(light.get("position"), f"{where}.position")
        _finite_vec(light.get("intensity"), f"{where}.intensity", positive=True)
        _finite_number(light.get("radius", 0.0), f"{where}.radius", 0.0)
        _check_flag(light, "soft_falloff", where)
        if kind == "spot":
            m = _matrix(light.get("matrix"), f"{where}.matrix")
            if abs(np.linalg.det(m[:3, :3])) < 1e-300:
                raise SceneError(f"{where}.matrix: singular (zero scale)")
            _check_angle(light, "spot_size", where)
            blend = _finite_number(light.get("spot_blend"), f"{where}.spot_blend", 0.0)
            if blend > 1.0:
                raise SceneError(f"{where}.spot_blend: must be at most 1, got {blend!r}")
    else:
        d = _finite_vec(light.get("direction"), f"{where}.direction")
        if np.linalg.norm(d) == 0:
            raise SceneError(f"{where}.direction: zero vector")
        _finite_vec(light.get("irradiance"), f"{where}.irradiance", positive=True)
        _check_angle(light, "angle", where, default=0.0)


def _check_camera(cam):
    if not isinstance(cam, dict):
        raise SceneError("camera: missing (the scene has no camera)")
    m3 = exact_unit_scale(_matrix(cam.get("matrix"), "camera.matrix")[:3, :3])
    lengths = np.linalg.norm(m3, axis=0)
    # The camera keeps only the rotation of its matrix: columns of no length, or parallel ones
    # (a zero scale in some axis), leave it no direction to look in.
    if not np.all(lengths > 1e-12) or not abs(np.linalg.det(m3 / lengths)) > 1e-12:
        raise SceneError("camera.matrix: singular (a zero scale in some axis): the camera has "
                         "no view direction")
    if cam.get("type", "PERSP") not in CAMERA_TYPES:
        raise SceneError(f"camera.type: unknown value {_short(cam.get('type'))}")
    ortho = cam.get("type", "PERSP") == "ORTHO"
    for key in ("lens", "sensor_width", "sensor_height", "clip_start", "clip_end"):
        # An orthographic camera's near clip may lie behind it (the viewport's does).
        _finite_number(cam.get(key), f"camera.{key}", None if ortho and key == "clip_start"
                       else 0.0, exclusive=True)
    if ortho:
        _finite_number(cam.get("ortho_scale"), "camera.ortho_scale", 0.0, exclusive=True)
    if not cam["clip_end"] > cam["clip_start"]:
        raise SceneError(f"camera.clip_end: must be greater than camera.clip_start "
                         f"({cam['clip_end']!r} <= {cam['clip_start']!r}): nothing would be "
                         "in view")
    for key in ("shift_x", "shift_y"):
        _finite_number(cam.get(key, 0.0), f"camera.{key}")
    if cam.get("sensor_fit", "AUTO") not in SENSOR_FITS:
        raise SceneError(f"camera.sensor_fit: unknown value {_short(cam.get('sensor_fit'))}")
    res = cam.get("resolution")
    if (not isinstance(res, (list, tuple)) or len(res) != 2
            or not all(isinstance(r, int) and not isinstance(r, bool) and 0 < r <= MAX_RESOLUTION
                       for r in res)):
        raise SceneError(f"camera.resolution: expected two integers from 1 to {MAX_RESOLUTION}, "
                         f"got {_short(res)}")
    pct = cam.get("resolution_percentage", 100)
    _int_in(pct, "camera.resolution_percentage", 1, 32767, "a percentage")
    size = [r * pct // 100 for r in res]
    if max(size) > MAX_RESOLUTION:
        # The image's own arrays (and pixel indices, 32-bit in the sampler's keys) stop here.
        raise SceneError(f"camera.resolution_percentage: {pct}% of {res[0]}x{res[1]} is "
                         f"{size[0]}x{size[1]} pixels, more than {MAX_RESOLUTION} a side")
    aspect = _finite_vec(cam.get("pixel_aspect", [1.0, 1.0]), "camera.pixel_aspect", n=2)
    if np.any(aspect <= 0):
        raise SceneError("camera.pixel_aspect: must be positive")
    dof = cam.get("dof")
    if not isinstance(dof, dict):
        raise SceneError("camera.dof: expected an object")
    _finite_number(dof.get("focus_distance"), "camera.dof.focus_distance", 0.0)
    _finite_number(dof.get("fstop"), "camera.dof.fstop", 0.0, exclusive=True)
    _finite_number(dof.get("rotation", 0.0), "camera.dof.rotation")
    _finite_number(dof.get("ratio", 1.0), "camera.dof.ratio", 0.0, exclusive=True)
    _int_in(dof.get("blades", 0), "camera.dof.blades", 0, MAX_BLADES)
    if dof.get("aperture_radius") is not None:
        _finite_number(dof["aperture_radius"], "camera.dof.aperture_radius", 0.0)


def _check_render(render):
    # The schema's checks; keys it does not know are left to an older or newer Snell.
    RenderSettings.from_render(render)


def _check_objects(objects):
    if not isinstance(objects, list):
        raise SceneError(f"objects: expected a list, got {_short(objects)}")
    for i, obj in enumerate(objects):
        if not isinstance(obj, dict):
            raise SceneError(f"objects[{i}]: expected an object, got {_short(obj)}")
        if "closed" in obj and not isinstance(obj["closed"], bool):
            raise SceneError(f"objects[{i}].closed: expected true or false, "
                             f"got {_short(obj['closed'])}")
        # What shader programs read of the object (Object Info, Texture Coordinate Normal);
        # each optional: a file written before them reads Blender's defaults.
        if "matrix" in obj:
            _matrix(obj["matrix"], f"objects[{i}].matrix")
        if "color" in obj:
            _finite_vec(obj["color"], f"objects[{i}].color", n=4)
        if "pass_index" in obj:
            _int_in(obj["pass_index"], f"objects[{i}].pass_index", 0, 2 ** 31 - 1)
        if "random_id" in obj:
            _int_in(obj["random_id"], f"objects[{i}].random_id", 0, 2 ** 32 - 1,
                    "a 32-bit unsigned integer")
        # Cycles' shadow caustics (tracer/mnee.py); absent: false.
        for key in ("caustics_caster", "caustics_receiver"):
            _check_flag(obj, key, f"objects[{i}]")


def _image_entries(images):
    """(index, entry, name for errors) of a list of image entries, each an object with a name."""
    if not isinstance(images, list):
        raise SceneError(f"images: expected a list, got {_short(images)}")
    if len(images) > MAX_IMAGES:
        raise SceneError(f"images: {len(images)} images (at most {MAX_IMAGES})")
    for i, im in enumerate(images):
        if not isinstance(im, dict) or not isinstance(im.get("name"), str):
            raise SceneError(f"images[{i}]: expected an object with a name")
        yield i, im, f"images[{i}] ({_short(im['name'], 40)})"


def _check_images(images):
    for _, im, where in _image_entries(images):
        px = im.get("pixels")
        if not isinstance(px, np.ndarray):
            raise SceneError(f"{where}: missing pixels")
        if px.dtype != np.float32:
            raise SceneError(f"{where}: expected dtype float32, got {_dtype_name(px.dtype)}")
        if px.ndim != 3 or px.shape[2] not in (1, 3) or px.shape[0] < 1 or px.shape[1] < 1:
            raise SceneError(f"{where}: expected shape (height, width, 1 or 3), got {px.shape}")
        if px.shape[0] > MAX_RESOLUTION or px.shape[1] > MAX_RESOLUTION:
            raise SceneError(f"{where}: larger than {MAX_RESOLUTION} pixels a side ({px.shape})")
        if not np.isfinite(px).all():
            raise SceneError(f"{where}: contains NaN or Inf")
        if im.get("colorspace", "linear") not in COLORSPACES:
            raise SceneError(f"{where}.colorspace: expected one of {', '.join(COLORSPACES)}, "
                             f"got {_short(im.get('colorspace'))}")


def _check_texcoords(texcoords, n_triangles):
    if not isinstance(texcoords, list):
        raise SceneError(f"texcoords: expected a list, got {_short(texcoords)}")
    for i, tc in enumerate(texcoords):
        where = f"texcoords[{i}]"
        if not isinstance(tc, dict) or tc.get("kind") not in TEXCOORD_KINDS:
            raise SceneError(f"{where}.kind: expected one of {', '.join(TEXCOORD_KINDS)}")
        if not isinstance(tc.get("name", ""), str):
            raise SceneError(f"{where}.name: expected a string")
        coords = tc.get("coords")
        if not isinstance(coords, np.ndarray) or coords.dtype != np.float32 \
                or coords.shape != (n_triangles, 3, 3):
            raise SceneError(f"{where}: expected float32 coordinates of shape "
                             f"({n_triangles}, 3, 3), got "
                             f"{getattr(coords, 'dtype', None)} {getattr(coords, 'shape', None)}")
        if not np.isfinite(coords).all():
            raise SceneError(f"{where}: contains NaN or Inf")


def _check_environment(env, images):
    where = "world.environment"
    if not isinstance(env, dict):
        raise SceneError(f"{where}: expected an object, got {_short(env)}")
    _int_in(env.get("image"), f"{where}.image", 0, len(images) - 1, "an image index")
    if images[env["image"]]["pixels"].shape[2] != 3:
        raise SceneError(f"{where}.image: expected an RGB image (3 channels)")
    _finite_number(env.get("strength"), f"{where}.strength", 0.0)
    _matrix3(env.get("matrix"), f"{where}.matrix")
    _finite_vec(env.get("offset"), f"{where}.offset")
    if env.get("interpolation") not in INTERPOLATIONS:
        raise SceneError(f"{where}.interpolation: expected one of {', '.join(INTERPOLATIONS)}, "
                         f"got {_short(env.get('interpolation'))}")


def _of_object(scene, triangles, vertex) -> str:
    """' (object NAME)' of a triangle that uses the vertex, where the scene names it, else ''."""
    try:
        uses = np.flatnonzero((triangles == vertex).any(axis=1))
        name = scene.objects[int(scene.object_ids[uses[0]])]["name"]
    except Exception:  # noqa: BLE001  (the arrays are not checked yet: name what can be named)
        return ""
    return f" (object {_short(name, 60)})" if isinstance(name, str) else ""


def validate(scene: Scene) -> Scene:
    """Check every array and header field; raise SceneError naming the first one at fault."""
    arrays = {"positions": scene.positions, "triangles": scene.triangles,
              "material_ids": scene.material_ids, "object_ids": scene.object_ids}
    pos = _check_array(arrays, "positions", np.float32, 3)
    tri = _check_array(arrays, "triangles", np.int32, 3)
    mid = _check_array(arrays, "material_ids", np.int32, None)
    oid = _check_array(arrays, "object_ids", np.int32, None)
    if not np.all(np.isfinite(pos)):
        bad = int(np.argmax(~np.isfinite(pos).all(axis=1)))
        raise SceneError(f"positions: vertex {bad}{_of_object(scene, tri, bad)} is NaN or Inf")
    if len(pos) and not np.abs(pos).max() <= MAX_COORDINATE:
        bad = int(np.argmax((np.abs(pos) > MAX_COORDINATE).any(axis=1)))
        raise SceneError(f"positions: vertex {bad}{_of_object(scene, tri, bad)} is out of range "
                         f"(a coordinate beyond +-{MAX_COORDINATE:g})")
    for key, arr in (("material_ids", mid), ("object_ids", oid)):
        if len(arr) != len(tri):
            raise SceneError(f"{key}: {len(arr)} entries for {len(tri)} triangles")
    if len(tri) and (tri.min() < 0 or tri.max() >= len(pos)):
        raise SceneError(f"triangles: vertex index out of range [0, {len(pos)})")
    _check_objects(scene.objects)
    if not isinstance(scene.source, str):
        raise SceneError(f"source: expected a string, got {_short(scene.source)}")
    if not isinstance(scene.materials, list):
        raise SceneError("materials: expected a list")
    _check_images(scene.images)
    _check_texcoords(scene.texcoords, len(tri))
    for i, mat in enumerate(scene.materials):
        _check_material(i, mat, scene.images, scene.texcoords)
    if len(mid) and (mid.min() < 0 or mid.max() >= len(scene.materials)):
        raise SceneError(f"material_ids: index out of range [0, {len(scene.materials)})")
    if len(oid) and (oid.min() < 0 or oid.max() >= max(len(scene.objects), 1)):
        raise SceneError(f"object_ids: index out of range [0, {len(scene.objects)})")
    if scene.normals is not None:
        nrm = _check_array({"normals": scene.normals}, "normals", np.float32, 3)
        if len(nrm) != len(pos):
            raise SceneError(f"normals: {len(nrm)} normals for {len(pos)} vertices")
        if not np.all(np.isfinite(nrm)):
            bad = int(np.argmax(~np.isfinite(nrm).all(axis=1)))
            raise SceneError(f"normals: vertex {bad}{_of_object(scene, tri, bad)} is NaN or Inf")
    if not isinstance(scene.lights, list):
        raise SceneError("lights: expected a list")
    for i, light in enumerate(scene.lights):
        _check_light(i, light)
    if not isinstance(scene.world, dict):
        raise SceneError(f"world: expected an object, got {_short(scene.world)}")
    _finite_vec(scene.world.get("color"), "world.color", positive=True)
    if scene.world.get("environment") is not None:
        _check_environment(scene.world["environment"], scene.images)
    _check_camera(scene.camera)
    _check_render(scene.render)
    _check_emitter_areas(scene)
    _check_light_groups(scene)
    return scene


def _check_light_groups(scene):
    """light_groups: distinct names; each light's, object's and the world's light_group an
    index into it."""
    groups = scene.light_groups
    if not isinstance(groups, list) or not all(isinstance(g, str) for g in groups):
        raise SceneError(f"light_groups: expected a list of names, got {_short(groups)}")
    if len(set(groups)) != len(groups):
        raise SceneError(f"light_groups: names must be distinct, got {_short(groups)}")
    entries = ([(f"lights[{i}]", x) for i, x in enumerate(scene.lights)]
               + [(f"objects[{i}]", x) for i, x in enumerate(scene.objects)]
               + [("world", scene.world)])
    for where, entry in entries:
        if "light_group" in entry:
            if not groups:
                raise SceneError(f"{where}.light_group: the scene lists no light_groups")
            _int_in(entry["light_group"], f"{where}.light_group", 0, len(groups) - 1,
                    "an index into light_groups")


def triangle_areas(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area of every triangle, in float64."""
    p = positions.astype(np.float64)[triangles]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def _check_emitter_areas(scene):
    emissive = [i for i, m in enumerate(scene.materials) if emits(m)]
    if not emissive or not len(scene.triangles):
        return
    for i in emissive:
        sel = scene.material_ids == i
        if sel.any() and triangle_areas(scene.positions, scene.triangles[sel]).sum() <= 0:
            raise SceneError(f"materials[{i}] ({_short(scene.materials[i].get('name'), 40)}): "
                             "zero-area emitter (all its triangles are degenerate)")


# ---------------------------------------------------------------------------------------------
# Reading and writing


def save(scene: Scene, path: str) -> None:
    """Validate and write the scene atomically (a failed write leaves no partial file)."""
    validate(scene)
    header = json.dumps(scene.header(), allow_nan=False).encode("utf-8")
    arrays = {"header": np.frombuffer(header, dtype=np.uint8), "positions": scene.positions,
              "triangles": scene.triangles, "material_ids": scene.material_ids,
              "object_ids": scene.object_ids}
    if scene.normals is not None:
        arrays["normals"] = scene.normals
    for i, im in enumerate(scene.images):
        arrays[f"image_{i}"] = im["pixels"]
    for i, tc in enumerate(scene.texcoords):
        arrays[f"texcoord_{i}"] = tc["coords"]
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)


def _read_members(path: str) -> dict:
    """{member name: array} of the .npz file, or SceneError naming the file or the member."""
    try:
        with open(path, "rb") as f:
            magic = f.read(4)
    except OSError:
        magic = b"PK\x03\x04"  # np.load below reports it
    if magic != b"PK\x03\x04":  # np.load would take any other bytes for a pickle and say so
        what = "an empty file" if not magic else "not an .npz archive"
        raise SceneError(f"{path}: not a Snell scene file ({what})")
    try:
        npz = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise SceneError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise SceneError(f"{path}: is a directory, not a Snell scene file") from None
    except PermissionError:
        raise SceneError(f"{path}: cannot read (permission denied)") from None
    except Exception as exc:  # noqa: BLE001
        # The bytes are the user's: a damaged archive fails in zipfile, zlib, struct or numpy's
        # header parser with whatever exception they raise, and every one means the same thing.
        raise SceneError(f"{path}: not a Snell scene file ({type(exc).__name__}: {exc})") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):  # pragma: no cover (the magic says zip)
        raise SceneError(f"{path}: not a Snell scene file (not an .npz archive)")
    arrays = {}
    with npz:
        for key in npz.files:
            try:
                arrays[key] = npz[key]
            except Exception as exc:  # noqa: BLE001  (as above, for one member)
                raise SceneError(f"{key}: cannot read the array "
                                 f"({type(exc).__name__}: {exc})") from None
    return arrays


def _read_images(entries, arrays) -> list:
    """The header's image entries with their pixels, each checked against its recorded hash."""
    images = []
    for i, entry, where in _image_entries(entries):
        key = f"image_{i}"
        if key not in arrays:
            raise SceneError(f"{where}: missing array {key}")
        pixels = arrays[key]
        if not isinstance(entry.get("sha256"), str):
            raise SceneError(f"{where}.sha256: expected a string")
        shape = entry.get("shape")
        if shape is not None and (not isinstance(shape, list)
                                  or list(pixels.shape) != shape):
            raise SceneError(f"{where}.shape: the header says {_short(shape)}, its array "
                             f"{key} has shape {list(pixels.shape)} (a damaged file)")
        if pixels.dtype == np.float32 and image_hash(pixels) != entry["sha256"]:
            raise SceneError(f"{where}: pixels do not match their sha256 (a damaged file)")
        images.append({"name": entry["name"], "source": str(entry.get("source", "")),
                       "colorspace": entry.get("colorspace", "linear"), "pixels": pixels})
    return images


def _read_texcoords(entries, arrays) -> list:
    """The header's texture coordinate entries with their arrays."""
    if not isinstance(entries, list):
        raise SceneError(f"texcoords: expected a list, got {_short(entries)}")
    out = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, dict):
            raise SceneError(f"texcoords[{i}]: expected an object")
        if f"texcoord_{i}" not in arrays:
            raise SceneError(f"texcoords[{i}]: missing array texcoord_{i}")
        out.append({**entry, "coords": arrays[f"texcoord_{i}"]})
    return out


def load(path: str) -> Scene:
    """Read and validate a scene file."""
    arrays = _read_members(path)
    if "header" not in arrays:
        raise SceneError(f"{path}: not a Snell scene file (no header)")
    try:
        header = json.loads(arrays["header"].tobytes().decode("utf-8"))
    except (UnicodeDecodeError, ValueError,
            RecursionError) as exc:  # ValueError: JSONDecodeError, huge ints
        raise SceneError(f"header: not valid JSON ({_short(str(exc), 100)})") from None
    if not isinstance(header, dict):
        raise SceneError(f"header: expected a JSON object, got {_short(header)}")
    if header.get("format") != FORMAT:
        raise SceneError(f"header.format: expected {FORMAT!r}, got {_short(header.get('format'))}")
    version = header.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version not in READS_VERSIONS:
        raise SceneError(f"header.version: unknown version {_short(header.get('version'))} "
                         f"(this Snell reads {', '.join(map(str, READS_VERSIONS))})")
    for key in ("positions", "triangles", "material_ids", "object_ids"):
        if key not in arrays:
            raise SceneError(f"{key}: missing array")
    render = header.get("render")
    if render is not None and not isinstance(render, dict):
        raise SceneError(f"render: expected an object, got {_short(render)}")
    objects = header.get("objects")
    images = _read_images(header.get("images", []), arrays)
    texcoords = _read_texcoords(header.get("texcoords", []), arrays)
    scene = Scene(
        positions=arrays["positions"], triangles=arrays["triangles"],
        material_ids=arrays["material_ids"], object_ids=arrays["object_ids"],
        normals=arrays.get("normals"),
        materials=header.get("materials"), lights=header.get("lights"),
        camera=header.get("camera"), world=header.get("world"),
        render={**DEFAULT_RENDER, **(render or {})},
        objects=[] if objects is None else objects, source=header.get("source", ""),
        images=images, texcoords=texcoords, light_groups=header.get("light_groups", []))
    if isinstance(scene.camera, dict) and isinstance(scene.camera.get("dof"), dict):
        scene.camera["dof"] = {**DEFAULT_DOF, **scene.camera["dof"]}
    validate(scene)
    # A file without "objects" (written before them) has object ids 0; one that lists its
    # objects must list every object its triangles name.
    oid = scene.object_ids
    if objects is not None and len(oid) and int(oid.max()) >= len(scene.objects):
        raise SceneError(f"object_ids: index {int(oid.max())} out of range "
                         f"[0, {len(scene.objects)}) (objects lists {len(scene.objects)})")
    return scene
