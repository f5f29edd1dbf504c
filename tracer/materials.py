"""The per-material tables the kernels read, built from the scene file's material list.

Smooth materials keep their exact code paths (material_kinds: DIFFUSE, MIRROR, GLASS,
REFRACTION); a Glossy BSDF of roughness 0 is a mirror. Everything with a rough lobe, and every
Principled BSDF, is
LAYERED: its lobes are built per hit by lobes.setup_shader from the `shader` code and the
parameters here.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import lobes, microfacet
from .material_kinds import DIFFUSE, EMISSION, GLASS, LAYERED, MIRROR, PROGRAM, REFRACTION
from .scene import DISTRIBUTIONS, EXTENSIONS, TEXTURE_SLOTS, emits, material_field
from .shader import closures
from .shader.inputs import IMAGE
from .shader.object_inputs import camera_table, object_table
from .shader.program import Programs, program_tables


class Materials(NamedTuple):
    """Per-material tables."""
    kind: np.ndarray          # (M,) int64 kind codes (material_kinds.DIFFUSE, ..., LAYERED)
    color: np.ndarray         # (M, 3) colour (Principled: base colour)
    trans_color: np.ndarray   # (M, 3) refraction weight of glass
    ior: np.ndarray           # (M,)
    radiance: np.ndarray      # (M, 3) emission (colour x strength)
    of_triangle: np.ndarray   # (T,) int64 material of each triangle
    shader: np.ndarray        # (M,) int64 lobes.SHADER_* of LAYERED materials
    roughness: np.ndarray     # (M,)
    distribution: np.ndarray  # (M,) int64 lobes.DIST_* (scene.DISTRIBUTIONS order)
    principled: np.ndarray    # (M, lobes.P_FIELDS) Principled parameters
    # Image textures (textures.py): tex[m, slot] is the texture on scene.TEXTURE_SLOTS[slot]
    # (colour, roughness, metallic) of material m, or -1; textured[m] whether it has any.
    textured: np.ndarray      # (M,) bool
    tex: np.ndarray           # (M, 3) int64
    tex_image: np.ndarray     # (K,) int64 the image of each texture
    tex_coord: np.ndarray     # (K,) int64 its row of coords
    tex_closest: np.ndarray   # (K,) bool Closest (else Linear) interpolation
    tex_extension: np.ndarray  # (K,) int64 textures.REPEAT, EXTEND, CLIP, MIRROR
    tex_matrix: np.ndarray    # (K, 3, 3) the Mapping node: coordinate A x + b
    tex_offset: np.ndarray    # (K, 3)
    image_slot: np.ndarray    # (scene images,) int64 each scene image's index in the pool, or -1
    img_offset: np.ndarray    # (I,) int64 first row of each image in the pool
    img_width: np.ndarray     # (I,) int64
    img_height: np.ndarray    # (I,) int64
    img_srgb: np.ndarray      # (I,) bool decoded from sRGB after interpolation
    pool: np.ndarray          # (N, 3) float32 every textured image's texels, top row first
    coords: np.ndarray        # (C, T, 3, 3) float32 texture coordinates per triangle corner
    # (image textures: the rows they use; shader programs: the scene's texcoords, in order)
    programs: Programs        # the PROGRAM materials' shader programs (shader/program.py)
    # What programs read of the object and camera (shader/object_inputs.py).
    of_object: np.ndarray     # (T,) int64 object of each triangle
    objects: np.ndarray       # (O, object_inputs.OBJECT_FIELDS) each object's matrix, colour ...
    camera: np.ndarray        # (object_inputs.CAMERA_FIELDS,) world to camera and view plane
    receives: np.ndarray      # (M,) bool: light paths end on it (receives_light_paths)


NO_COLOR = (0.0, 0.0, 0.0)   # the colour fields of a program material, which has none
SHADERS = {"glossy": lobes.SHADER_GLOSSY, "glass": lobes.SHADER_GLASS,
           "refraction": lobes.SHADER_REFRACTION, "principled": lobes.SHADER_PRINCIPLED}
SMOOTH_KINDS = {"diffuse": DIFFUSE, "mirror": MIRROR, "glossy": MIRROR,
                "glass": GLASS, "refraction": REFRACTION, "emission": EMISSION}


def kind_code(mat: dict) -> int:
    """The integrator's kind of a scene material: its smooth code path, or LAYERED."""
    kind = mat["kind"]
    if kind == "program":
        return PROGRAM
    if kind == "principled":
        return LAYERED
    if kind in ("glossy", "glass", "refraction"):
        alpha = float(material_field(mat, "roughness")) ** 2
        # A roughness texture makes roughness a per-hit value: the layered code serves both.
        if not microfacet.is_almost_specular(alpha) or "roughness" in (mat.get("textures") or {}):
            return LAYERED
    return SMOOTH_KINDS[kind]


def receives_light_paths(mat: dict) -> bool:
    """Whether light paths end on this material (receivers.py): it may have a Lambert lobe (a
    Diffuse BSDF, a Principled BSDF, a program with either closure)."""
    if mat["kind"] == "program":
        return any(ins[0] in (closures.DIFFUSE, closures.PRINCIPLED)
                   for ins in mat["program"]["code"])
    return mat["kind"] in ("diffuse", "principled")


def principled_row(mat: dict) -> np.ndarray:
    """A Principled material's parameters as a row of Materials.principled."""
    row = np.zeros(lobes.P_FIELDS)
    if mat["kind"] != "principled":
        return row
    for column, key in ((lobes.P_METALLIC, "metallic"), (lobes.P_ROUGHNESS, "roughness"),
                        (lobes.P_IOR, "ior"), (lobes.P_SPECULAR_LEVEL, "specular_ior_level"),
                        (lobes.P_TRANSMISSION, "transmission"), (lobes.P_COAT, "coat_weight"),
                        (lobes.P_COAT_ROUGHNESS, "coat_roughness"), (lobes.P_COAT_IOR, "coat_ior")):
        row[column] = float(material_field(mat, key))
    row[lobes.P_SPECULAR_TINT:lobes.P_SPECULAR_TINT + 3] = material_field(mat, "specular_tint")
    row[lobes.P_COAT_TINT:lobes.P_COAT_TINT + 3] = material_field(mat, "coat_tint")
    return row


def emission(mat: dict) -> np.ndarray:
    """Emitted radiance (colour x strength) of a material, 0 for those that do not emit."""
    if not emits(mat):
        return np.zeros(3)
    if mat["kind"] == "program":
        # A program's constant emission; one that varies is no light to sample (its hits
        # evaluate it, with no other strategy to weigh against).
        if mat["program"].get("emission_varies"):
            return np.zeros(3)
        return np.asarray(mat["emission"], np.float64)
    if mat["kind"] == "emission":
        return np.asarray(mat["color"], np.float64) * float(mat.get("strength", 0.0))
    # A Principled BSDF's: Cycles dims it by the coat's reflectance and tint, view-dependent,
    # which is not modelled.
    return (np.asarray(material_field(mat, "emission_color"), np.float64)
            * float(material_field(mat, "emission_strength")))


def _texture_tables(mats, images, texcoords, n_triangles) -> dict:
    """The texture fields of Materials: only the images textures and programs use go into the
    pool; programs read every texcoord by its scene index, so with programs all are kept."""
    tex = np.full((len(mats), 3), -1, np.int64)
    specs = []
    program_images = set()
    for m, mat in enumerate(mats):
        for slot, spec in (mat.get("textures") or {}).items():
            tex[m, TEXTURE_SLOTS.index(slot)] = len(specs)
            specs.append(spec)
        if mat["kind"] == "program":
            program_images.update(ins[4] for ins in mat["program"]["code"] if ins[0] == IMAGE)
    used = sorted({s["image"] for s in specs} | program_images)
    index = {image: k for k, image in enumerate(used)}
    rgb = [np.broadcast_to(images[i]["pixels"], images[i]["pixels"].shape[:2] + (3,))
           for i in used]
    sizes = [p.shape[0] * p.shape[1] for p in rgb]
    pool = np.empty((sum(sizes), 3), np.float32)
    offsets = np.cumsum([0] + sizes)[:-1].astype(np.int64)
    for p, start, size in zip(rgb, offsets, sizes):
        pool[start:start + size] = p.reshape(-1, 3)
    used_coords = sorted({s["texcoord"] for s in specs})
    if any(mat["kind"] == "program" for mat in mats):
        used_coords = list(range(len(texcoords)))
    coord_index = {c: k for k, c in enumerate(used_coords)}
    coords = (np.stack([texcoords[c]["coords"] for c in used_coords]) if used_coords
              else np.zeros((0, n_triangles, 3, 3), np.float32))
    return dict(
        textured=(tex >= 0).any(axis=1), tex=tex,
        tex_image=np.array([index[s["image"]] for s in specs], np.int64),
        tex_coord=np.array([coord_index[s["texcoord"]] for s in specs], np.int64),
        tex_closest=np.array([s["interpolation"] == "closest" for s in specs], bool),
        tex_extension=np.array([EXTENSIONS.index(s["extension"]) for s in specs], np.int64),
        tex_matrix=np.array([s["matrix"] for s in specs], np.float64).reshape(-1, 3, 3),
        tex_offset=np.array([s["offset"] for s in specs], np.float64).reshape(-1, 3),
        image_slot=np.array([index.get(i, -1) for i in range(len(images))], np.int64),
        img_offset=offsets,
        img_width=np.array([p.shape[1] for p in rgb], np.int64),
        img_height=np.array([p.shape[0] for p in rgb], np.int64),
        img_srgb=np.array([images[i].get("colorspace") == "srgb" for i in used], bool),
        pool=pool, coords=np.ascontiguousarray(coords))


def material_tables(mats: list, material_ids: np.ndarray, images=(), texcoords=(),
                    objects=(), object_ids=None, camera=None) -> Materials:
    """The kernels' tables for a scene's materials and its triangles' material indices (and its
    images and texture coordinates, which textures read; its objects, their triangles' object
    indices and its camera (a tracer.camera.Camera), which programs read)."""
    def rows(fn, dtype=np.float64, shape=()):
        return np.array([fn(m) for m in mats], dtype).reshape((len(mats),) + shape)

    roughness = rows(lambda m: material_field(m, "roughness") if m["kind"] in SHADERS else 0.0)
    return Materials(
        kind=rows(kind_code, np.int64),
        color=rows(lambda m: m.get("color", NO_COLOR), shape=(3,)),
        trans_color=rows(lambda m: m.get("transmission_color", m.get("color", NO_COLOR)),
                         shape=(3,)),
        ior=rows(lambda m: m.get("ior", 1.0)),
        radiance=np.ascontiguousarray(rows(emission, shape=(3,))),
        of_triangle=material_ids.astype(np.int64),
        shader=rows(lambda m: SHADERS.get(m["kind"], 0), np.int64),
        roughness=roughness,
        distribution=rows(lambda m: DISTRIBUTIONS.index(material_field(m, "distribution"))
                          if m["kind"] in SHADERS else 0, np.int64),
        principled=rows(principled_row, shape=(lobes.P_FIELDS,)),
        programs=program_tables([m["program"] if m["kind"] == "program" else None
                                 for m in mats]),
        of_object=(np.zeros(len(material_ids), np.int64) if object_ids is None
                   else np.asarray(object_ids, np.int64)),
        objects=object_table(list(objects)), camera=camera_table(camera),
        receives=rows(receives_light_paths, bool),
        **_texture_tables(mats, list(images), list(texcoords), len(material_ids)))
