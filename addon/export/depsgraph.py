"""The depsgraph walk: Exporter visits a depsgraph's rendered instances and assembles the Scene.

Each instance goes to its datablock's module (lights.py, meshes.py, materials.py and
textures.py); the camera, world and render settings are converted once. Each distinct evaluated
mesh is converted once, and at the end transformed for all its instances in one batch.
export_depsgraph is the entry point; export_blend and export_to_file open a .blend file first.
"""
from __future__ import annotations

import os

import numpy as np

from ...tracer import scene as scene_mod
from ...tracer.scene import Scene, SceneError
from .camera import convert_camera
from .contacts import refracting_contacts
from .custom_properties import instance_rgba, view_layer_rgba
from .light_groups import NOT_LISTED, LightGroups
from .lights import convert_light
from .materials import HOLDOUT_NAME, NO_MATERIAL, NO_SURFACE, convert_material, holdout_material
from .meshes import mesh_arrays, to_world
from .settings import convert_render
from .shader.input_nodes import attribute_requests, object_attribute_key, uses_object_data
from .shader.normal_nodes import uses_normal_maps
from .textures import ImageTextures, uses_image_textures
from .world import convert_world


def _hidden_from_render(obj):
    """A viewport depsgraph still holds objects hidden from render; a render one does not."""
    orig = obj.original
    if orig.hide_render:
        return True
    colls = orig.users_collection
    return bool(colls) and all(c.hide_render for c in colls)


class Exporter:
    """One export: the scene's materials, meshes, lights and images as instances are added."""

    def __init__(self, depsgraph):
        self.depsgraph = depsgraph
        self.warnings = []
        self._warned = set()
        self.materials = []
        self.material_ids = {}  # Blender material (or None) -> index
        self.coverage = []  # per material: its Coverage.as_dict(), with "name" and "kind"
        self.meshes = {}  # evaluated geometry pointer -> Mesh
        self.parts = []  # (Mesh, world matrix, material ids per triangle, object id)
        self.objects = []
        self.lights = []
        self.images = []  # the scene's images: {"name", "source", "pixels"}
        self.textures = ImageTextures(self.images)
        normal_maps, self.want_tangents = uses_normal_maps()
        self.want_attributes, self.want_properties = attribute_requests()
        self.properties = []  # per object: {texcoord name: RGBA} of want_properties
        self._layer_properties = {}
        self.want_texcoords = uses_image_textures() or normal_maps or bool(self.want_attributes)
        self.want_object_data = uses_object_data()
        self.object_data = []  # per object: object_data's fields, or None
        self._hidden = {}  # original object pointer -> hidden from render
        self.light_groups = LightGroups(getattr(depsgraph, "view_layer", None), self.warn)

    def warn(self, message):
        """Add a warning, unless it was given already."""
        if message not in self._warned:
            self._warned.add(message)
            self.warnings.append(message)

    def hidden_from_render(self, obj):
        """_hidden_from_render, once per object (all the instances of one instancer ask)."""
        key = obj.original.as_pointer()
        if key not in self._hidden:
            self._hidden[key] = _hidden_from_render(obj)
        return self._hidden[key]

    def material_id(self, mat, obj_name):
        """The scene's index of a Blender material (None: the default), converted on first use;
        its issues are warned for the object."""
        key = mat.original if mat is not None else None
        if key not in self.material_ids:
            converted, coverage = convert_material(mat, self.textures)
            nodes = converted.pop("_textures", None)
            if nodes:
                textures = {}
                for field, (node, groups) in nodes.items():
                    spec = self.textures.convert(node, coverage, groups)
                    if spec is not None:
                        textures[field] = spec
                        coverage.evaluate(node, f"image texture as the {field}")
                if textures:
                    converted["textures"] = textures
            self.material_ids[key] = (len(self.materials), coverage.issues)
            self.materials.append(converted)
            self.coverage.append({"name": converted["name"], "kind": converted["kind"],
                                  **coverage.as_dict()})
        index, issues = self.material_ids[key]
        mat_name = mat.name if mat is not None else "(none)"
        for issue in issues:
            self.warn(f"object {obj_name!r}, material {mat_name!r}: {issue}")
        return index

    def texcoords(self):
        """The scene's texture coordinate entries: each key's coordinates over every part."""
        out = []
        for kind, name in self.textures.texcoord_keys:
            parts = []
            for mesh, matrix, _, object_id in self.parts:
                if kind in ("object_attribute", "object_attribute_extra"):
                    parts.append(self.property_coords(kind, name, object_id,
                                                      len(mesh.triangles)))
                    continue
                coords = mesh.texcoord(kind, name, matrix)
                if _det3(matrix) < 0:        # to_world swaps two corners of mirrored parts
                    coords = coords[:, [0, 2, 1]]
                parts.append(coords)
            coords = np.concatenate(parts) if parts else np.zeros((0, 3, 3), np.float32)
            out.append({"kind": kind, "name": name,
                        "coords": np.ascontiguousarray(coords, np.float32)})
        return out

    def property_rgba(self, inst, kind, name):
        """An Attribute node's RGBA of type `kind` (OBJECT, INSTANCER, VIEW_LAYER) for an
        instance (the view layer's read once)."""
        if kind != "VIEW_LAYER":
            return instance_rgba(inst, name, kind == "INSTANCER")
        if name not in self._layer_properties:
            self._layer_properties[name] = view_layer_rgba(self.depsgraph, name)
        return self._layer_properties[name]

    def property_coords(self, kind, name, object_id, n_triangles):
        """(T, 3, 3) float32 texture coordinates of an object's property (texcoord name
        `name`: object_attribute_key's), the same at every corner: its RGB (object_attribute)
        or (Fac: their average, Alpha, 1) (object_attribute_extra), as Cycles reads an object
        attribute (a float4: kernel/svm/attribute.h); NaN or Inf read as 0 (a scene file
        holds finite coordinates)."""
        r, g, b, a = np.nan_to_num(self.properties[object_id].get(name, (0.0, 0.0, 0.0, 0.0)),
                                   nan=0.0, posinf=0.0, neginf=0.0).tolist()
        # The average in float32, as Cycles takes it.
        value = ((r, g, b) if kind == "object_attribute" else
                 (float(np.float32(np.float32(r) + np.float32(g) + np.float32(b)) *
                        np.float32(1.0 / 3.0)), a, 1.0))
        return np.broadcast_to(np.asarray(value, np.float32), (n_triangles, 3, 3))

    def add_instance(self, inst):
        """Record one depsgraph instance; the geometry is transformed later, per mesh (scene())."""
        obj = inst.object
        name = f"{inst.parent.name}/{obj.name}" if inst.is_instance and inst.parent else obj.name
        matrix = np.array(inst.matrix_world, np.float64)
        if not np.isfinite(matrix).all():
            raise SceneError(f"object {name!r}: world matrix contains NaN or Inf")
        if obj.type == "LIGHT":
            light = convert_light(obj, matrix, self.warn)
            if light is not None:
                light["name"] = name
                light.update(self.light_groups.entry(obj, f"light {name!r}"))
                self.lights.append(light)
            return
        if obj.type in NOT_RENDERED:
            # Cycles renders these as curves or spheres; Snell has triangles only (embreex
            # exposes no curve or point geometry).
            self.warn(f"object {name!r}: {NOT_RENDERED[obj.type]} not rendered (Snell renders "
                      "meshes only)")
            return
        # Curves, surfaces, metaballs and text reach the depsgraph twice: as themselves and as
        # the mesh instance their evaluation makes. Cycles renders the mesh; so does Snell.
        if obj.type != "MESH":
            return
        self.warn_hair(obj, name)
        mesh = self.mesh_of(inst)
        if mesh is None:
            return
        if mesh.dropped_nonfinite:
            self.warn(f"object {name!r}: dropped {mesh.dropped_nonfinite} triangle(s) with a "
                      "NaN or Inf vertex coordinate")
        if mesh.dropped_out_of_range:
            self.warn(f"object {name!r}: dropped {mesh.dropped_out_of_range} triangle(s) with a "
                      f"vertex coordinate beyond +-{scene_mod.MAX_COORDINATE:g} (out of range)")
        if mesh.dropped:
            self.warn(f"object {name!r}: dropped {mesh.dropped} {DROPPED_TRIANGLES}")
        for attribute in mesh.nonfinite_attributes:
            self.warn(f"object {name!r}: attribute {attribute!r} has NaN or Inf values: "
                      "read as 0 there")
        if len(mesh.triangles) == 0:
            return
        if abs(_det3(matrix)) < 1e-30:
            self.warn(f"object {name!r}: {ZERO_SCALE}")
            return
        slots = [s.material for s in obj.material_slots] or [None]
        mat_ids, used = mesh.material_ids(tuple(self.material_id(m, name) for m in slots))
        if self.held_out(obj):
            mat_ids, used = self.hold_out(name, mat_ids, used)
        object_id = len(self.objects)
        # The pass index for the Object Index pass (tracer/data_passes.py); 0 is left out, so
        # files without one export as before.
        self.objects.append({"name": name, "closed": mesh.closed,
                             **({"pass_index": int(obj.pass_index)} if obj.pass_index else {}),
                             **shadow_caustics(obj),
                             **self.light_groups.entry(obj, f"object {name!r}")})
        # Kept aside: the scene's objects carry them only if a program reads them
        # (scene_objects).
        self.object_data.append(object_data(inst, matrix) if self.want_object_data else None)
        self.properties.append({object_attribute_key(kind, prop): self.property_rgba(
            inst, kind, prop) for kind, prop in self.want_properties})
        for key, value in self.properties[-1].items():
            if not np.isfinite(value).all():
                self.warn(f"object {name!r}: property {key.partition(':')[2]!r} is NaN or "
                          "Inf: read as 0 there")
        if not mesh.closed:
            for i in used:
                mat = self.materials[i]
                if scene_mod.refracts(mat):
                    self.warn(f"object {name!r}: {mat['kind']} material {mat['name']!r} "
                              f"{OPEN_MESH}")
        self.parts.append((mesh, matrix, mat_ids, object_id))

    def held_out(self, obj) -> bool:
        """Whether the object is a holdout (Object > Visibility > Mask > Holdout, or a holdout
        collection of the view layer), as Cycles reads it."""
        orig = obj.original
        try:
            return bool(orig.holdout_get(view_layer=self.depsgraph.view_layer))
        except (AttributeError, TypeError, RuntimeError):
            return bool(getattr(orig, "is_holdout", False))

    def hold_out(self, name, mat_ids, used):
        """An object held out: every triangle gets one Holdout program (Cycles' object holdout
        replaces every closure with a holdout of weight 1). Returns (material ids, used)."""
        if HOLDOUT_KEY not in self.material_ids:
            self.material_ids[HOLDOUT_KEY] = (len(self.materials), [])
            self.materials.append(holdout_material())
            self.coverage.append({"name": HOLDOUT_NAME, "kind": "program", "evaluated": [],
                                  "replaced": []})
        index = self.material_ids[HOLDOUT_KEY][0]
        if any(scene_mod.refracts(self.materials[i]) for i in used):
            # Cycles keeps a held-out surface's transparency (surface_shader_apply_holdout).
            self.warn(f"object {name!r}: a holdout of a transparent or refracting material: "
                      "held out whole (Cycles lets its transparency through)")
        return np.full_like(mat_ids, index), [index]

    def warn_hair(self, obj, name):
        """Warn for the hair particle systems of a mesh object, which Cycles renders as curves."""
        for system in getattr(obj, "particle_systems", ()):
            settings = system.settings
            if settings.type == "HAIR" and settings.render_type == "PATH":
                self.warn(f"object {name!r}: hair particle system {system.name!r} not rendered "
                          "(Snell renders meshes only)")

    def warn_missing_libraries(self, data):
        """Warn for each linked library whose file is missing: its objects are not rendered."""
        for library in getattr(data, "libraries", ()):
            if getattr(library, "is_missing", False):
                lost = sorted(o.name for o in data.objects
                              if o.library == library and getattr(o, "is_missing", False))
                what = (f" ({len(lost)} object(s): {', '.join(lost[:3])}"
                        f"{', ...' if len(lost) > 3 else ''})" if lost else "")
                self.warn(f"library {library.filepath!r} is missing: what it links is not "
                          f"rendered{what}")

    def mesh_of(self, inst):
        """The local-space Mesh of an instance's evaluated object (None if it has no mesh)."""
        obj = inst.object
        # Objects sharing evaluated geometry (linked duplicates, instances) share one conversion;
        # with modifiers each object's evaluated data is its own.
        key = (obj.type == "MESH" and obj.data.as_pointer()) or ("object", obj.as_pointer())
        if key not in self.meshes:
            self.meshes[key] = mesh_arrays(obj, self.want_texcoords, self.want_tangents,
                                           self.want_attributes)
        return self.meshes[key]

    def geometry(self):
        """World positions, normals (float32) and triangles of all parts, in the parts' order."""
        n_verts = np.array([len(p[0].positions) for p in self.parts], np.int64)
        n_tris = np.array([len(p[0].triangles) for p in self.parts], np.int64)
        v_start = np.cumsum(n_verts) - n_verts
        t_start = np.cumsum(n_tris) - n_tris
        positions = np.empty((n_verts.sum(), 3), np.float32)
        normals = np.empty((n_verts.sum(), 3), np.float32)
        triangles = np.empty((n_tris.sum(), 3), np.int32)
        by_mesh = {}
        for i, part in enumerate(self.parts):
            by_mesh.setdefault(id(part[0]), []).append(i)
        # All instances of one mesh in one batch: one NumPy call each, not one per instance.
        for parts in by_mesh.values():
            mesh, parts = self.parts[parts[0]][0], np.array(parts)
            p, n, t = to_world(mesh, np.stack([self.parts[i][1] for i in parts]))
            far = ~(np.abs(p) <= scene_mod.MAX_COORDINATE).all(axis=(1, 2))
            if far.any():
                name = self.objects[self.parts[parts[int(np.argmax(far))]][3]]["name"]
                raise SceneError(f"object {name!r}: world-space vertex coordinates beyond "
                                 f"+-{scene_mod.MAX_COORDINATE:g} or not finite (its location, "
                                 "scale or parent's transform)")
            rows = _rows(v_start[parts], len(mesh.positions))
            positions[rows] = p.reshape(-1, 3)
            normals[rows] = n.reshape(-1, 3)
            t += v_start[parts, None, None].astype(np.int32)
            triangles[_rows(t_start[parts], len(mesh.triangles))] = t.reshape(-1, 3)
        return positions, normals, triangles

    def scene_objects(self):
        """The scene's objects, with their object_data where a program reads it (so that
        scenes whose programs do not, the stored Cycles references' among them, export as
        before)."""
        if not any(reads_object_data(mat) for mat in self.materials):
            return self.objects
        return [{**obj, **(data or {})} for obj, data in zip(self.objects, self.object_data)]

    def scene(self, bl_scene, camera, source):
        """The Scene of the instances added, with this camera and the scene's world and settings."""
        positions, normals, triangles = self.geometry()
        n_tris = [len(p[0].triangles) for p in self.parts]
        material_ids = (np.concatenate([p[2] for p in self.parts]) if self.parts
                        else np.zeros(0, np.int32))
        world = convert_world(bl_scene.world, self.warn, self.images)
        if bl_scene.world is not None:
            world.update(self.light_groups.entry(bl_scene.world,
                                                 f"world {bl_scene.world.name!r}"))
        return Scene(
            positions=positions, normals=normals, triangles=triangles,
            material_ids=material_ids.astype(np.int32),
            object_ids=np.repeat(np.array([p[3] for p in self.parts], np.int32), n_tris),
            materials=self.materials, lights=self.lights, camera=camera, world=world,
            render=convert_render(bl_scene, self.warn), objects=self.scene_objects(),
            source=source,
            images=self.images, texcoords=self.texcoords(), coverage=self.coverage,
            light_groups=self.light_groups.names)


def reads_object_data(mat):
    """Whether a scene material's program reads its object's fields (object_data)."""
    from ...tracer.shader import object_inputs
    return mat["kind"] == "program" and any(
        row[0] in object_inputs.READS_OBJECT for row in mat["program"]["code"])


def object_data(inst, matrix):
    """The scene object fields shader programs read of a depsgraph instance (Object Info,
    Texture Coordinate Normal), as Blender's Cycles sync sets them (blender/object.cpp): its
    world matrix, colour and alpha, pass index, and random id (an instance's from the
    depsgraph, an object's the hash of its name)."""
    obj = inst.object
    if inst.is_instance:
        random_id = inst.random_id % 2 ** 32
    else:
        random_id = object_random_id(obj.name)
    return {"matrix": matrix.tolist(), "color": [float(x) for x in obj.color],
            "pass_index": int(obj.pass_index), "random_id": int(random_id)}


def shadow_caustics(obj) -> dict:
    """The object's Cycles shadow-caustics flags (caster, receiver: tracer/mnee.py), only those
    that are on (files without them read as before)."""
    cycles = getattr(getattr(obj, "original", obj), "cycles", None)
    return {key: True for key, prop in (("caustics_caster", "is_caustics_caster"),
                                        ("caustics_receiver", "is_caustics_receiver"))
            if getattr(cycles, prop, False)}


def object_random_id(name):
    """Cycles' random id of an object that is not an instance: hash_uint2(hash_string(name),
    0) (util/hash.h), hash_string over the name's UTF-8 bytes, each from 0 to 255 (measured
    against Blender 5.0's Cycles: a name with non-ASCII letters hashes its bytes unsigned)."""
    from ...tracer.shader.hashes import hash_uint2
    h = 0
    for byte in name.encode("utf-8"):
        h = (h * 37 + byte) % 2 ** 32
    return int(hash_uint2(h, 0))


def _rows(starts, length):
    """Indices of the blocks of length rows at starts: a slice when they follow each other."""
    # Instances from one instancer come in a row: slice assignment is several times faster.
    if np.all(np.diff(starts) == length):
        return slice(starts[0], starts[0] + len(starts) * length)
    return (starts[:, None] + np.arange(length)).reshape(-1)


def _det3(m):
    """Determinant of the upper-left 3x3 block, in plain Python (np.linalg.det: 10 us a call)."""
    (a, b, c), (d, e, f), (g, h, i) = m[:3, :3].tolist()
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


# Object types Cycles renders and Snell drops, with a warning naming them.
NOT_RENDERED = {"CURVES": "hair curves", "POINTCLOUD": "point cloud"}
HOLDOUT_KEY = "holdout"     # material_ids' key of the object holdout's material

# Notes whose cause Cycles renders the same way: a zero-area triangle covers no pixel in either
# renderer, a zero-scale object none, glass on an open mesh refracts at the same surfaces, and a
# missing material or surface is Cycles' default surface or black in both.
DROPPED_TRIANGLES = "zero-area triangle(s)"
ZERO_SCALE = "singular world matrix (zero scale), skipped"
OPEN_MESH = "on a mesh that is not closed (its edges are not all shared by two triangles)"
SAME_IN_CYCLES = (DROPPED_TRIANGLES, ZERO_SCALE, OPEN_MESH, NO_MATERIAL, NO_SURFACE, NOT_LISTED)


def differs_from_cycles(warning: str) -> bool:
    """Whether an exporter warning means Snell renders something Cycles renders differently
    (the validator's "not comparable"); the notes in SAME_IN_CYCLES do not."""
    return not any(warning.endswith(note) for note in SAME_IN_CYCLES)


def export_depsgraph(depsgraph, *, source=""):
    """Convert an evaluated depsgraph into (Scene, warnings)."""
    bl_scene = depsgraph.scene
    camera = convert_camera(bl_scene, depsgraph)
    ex = Exporter(depsgraph)
    import bpy
    ex.warn_missing_libraries(bpy.data)
    for inst in rendered_instances(depsgraph, ex):
        ex.add_instance(inst)
    scene = ex.scene(bl_scene, camera, source)
    scene_mod.validate(scene)
    warn_contacts(scene, ex.warn)
    return scene, ex.warnings


def warn_contacts(scene, warn):
    """Warn for each refracting object with faces lying on another object's (contacts.py)."""
    if not scene.objects or not scene.materials:
        return
    refracting = np.array([scene_mod.refracts(m) for m in scene.materials])[scene.material_ids]
    for glass, other in refracting_contacts(scene.positions, scene.triangles, scene.object_ids,
                                            refracting):
        warn(f"object {scene.objects[glass]['name']!r}: refracting faces lie on object "
             f"{scene.objects[other]['name']!r}'s faces (in one plane): Cycles and Snell "
             "resolve coincident faces differently; lift it by 0.1 mm")


def rendered_instances(depsgraph, ex):
    """The depsgraph's instances a render shows (a viewport depsgraph also holds hidden ones)."""
    check_hidden = depsgraph.mode != "RENDER"
    for inst in depsgraph.object_instances:
        obj = inst.object
        if check_hidden:
            # An instanced collection renders even when the source collection is hidden.
            if inst.is_instance:
                hidden = obj.original.hide_render or (
                    inst.parent is not None and ex.hidden_from_render(inst.parent))
            else:
                hidden = ex.hidden_from_render(obj)
            if hidden:
                continue
        if not inst.is_instance and obj.is_instancer and not obj.show_instancer_for_render:
            continue
        yield inst


def _prefer_render_settings():
    """Make the viewport depsgraph evaluate what a render would: render visibility and levels."""
    import bpy
    # Only un-hide: things hidden from render stay evaluated (a focus empty, an instance source)
    # and are skipped by export_depsgraph.
    for coll in bpy.data.collections:
        if not coll.hide_render:
            coll.hide_viewport = False
    for obj in bpy.data.objects:
        if not obj.hide_render:
            obj.hide_viewport = False
        for mod in obj.modifiers:
            mod.show_viewport = mod.show_render
            if hasattr(mod, "render_levels") and hasattr(mod, "levels"):
                mod.levels = mod.render_levels


def export_blend(path):
    """Open a .blend file and export its active scene: (Scene, warnings)."""
    import bpy

    from ..blendfile import open_blend
    from ..properties import ensure_readable
    ensure_readable()  # scene.snell: the render settings the add-on saved in the file
    open_blend(path)
    # Blender offers only the viewport depsgraph outside a render; the file was just opened
    # and is never saved, so switching it to render visibility and levels is harmless.
    _prefer_render_settings()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    try:
        scene, warnings = export_depsgraph(depsgraph, source=os.path.basename(path))
    except SceneError as exc:  # name the file too: the message names the object or field
        raise SceneError(f"{path}: {exc}") from None
    if bpy.context.scene.render.use_border:
        # F12 and `snell batch` render the region (addon/final.py); a scene file holds the
        # whole frame.
        warnings.append("Output > Format > Render Region is on and not applied here: the "
                        "whole frame is rendered (F12 and `snell batch` render the region)")
    return scene, warnings


def export_to_file(blend_path, out_path):
    """Export a .blend file to a .snell scene file; returns the warnings."""
    scene, warnings = export_blend(blend_path)
    scene_mod.save(scene, out_path)
    return warnings
