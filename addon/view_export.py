"""The viewport's export: the exporter's walk over the depsgraph, with what an edit left alone kept.

`LiveExport.update(depsgraph, plan)` re-walks the depsgraph's instances (matrices, material
slots, lamps, world and settings are cheap to read) but takes each object's local-space mesh
arrays from a cache, extracting only the objects the plan names (view_updates.py) or has not
seen, and transforms to world space only the objects whose matrix or mesh changed. When no
object's mesh or matrix changed, the geometry arrays and their version stay the same, so the
render worker keeps its BVH (view_session.py). Meshes of generated instances (collection
instances, geometry nodes) are extracted on every walk: the cache is keyed by object name.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from .export import rendered_instances
from .export.depsgraph import Exporter
from .export.meshes import mesh_arrays, to_world


@dataclass
class Content:
    """Everything of the scene but the camera, and the version of its geometry arrays."""
    scene: object             # a tracer Scene whose camera is a placeholder
    geometry_version: int
    warnings: list

    def with_camera(self, camera: dict) -> object:
        """The scene with the viewport's camera (not yet validated)."""
        scene = copy.copy(self.scene)
        scene.camera = camera
        return scene


class _CachedExporter(Exporter):
    """The exporter with its meshes and world-space arrays taken from a LiveExport."""

    def __init__(self, depsgraph, live):
        super().__init__(depsgraph)
        self.live = live

    def mesh_of(self, inst):
        if inst.is_instance:
            return super().mesh_of(inst)
        name = inst.object.name_full
        self.live.seen.add(name)
        cached = self.live.meshes.get(name)
        # A mesh cached before any material had an image texture has no texture coordinates.
        if name not in self.live.meshes or (self.want_texcoords and cached is not None
                                            and cached.coords is None):
            self.live.meshes[name] = mesh_arrays(inst.object, self.want_texcoords,
                                                 self.want_tangents, self.want_attributes)
            self.live.extracted.append(name)
        return self.live.meshes[name]

    def geometry(self):
        return self.live.assemble(self)


PLACEHOLDER_CAMERA = {"matrix": np.eye(4).tolist(), "lens": 50.0, "sensor_width": 36.0,
                      "sensor_height": 24.0, "clip_start": 0.1, "clip_end": 100.0,
                      "resolution": [1, 1], "dof": {"use_dof": False, "focus_distance": 10.0,
                                                    "fstop": 2.8}}


class LiveExport:
    """The scene as the viewport last exported it, and the per-object arrays behind it."""

    def __init__(self):
        self.meshes = {}        # object name -> its local-space Mesh (None: no mesh)
        self.world = {}         # part name -> (Mesh, matrix bytes, positions, normals, triangles)
        self.parts_key = None   # the (name, Mesh, matrix bytes) of each part, in order
        self.arrays = None      # (positions, normals, triangles) of the last assembly
        self.geometry_version = 0
        self.content = None
        self.seen = set()
        self.extracted = []     # what the last update extracted and transformed (stats, tests)
        self.transformed = []

    def update(self, depsgraph, plan, source="(viewport)") -> Content | None:
        """The new Content after the edits in plan, or None if the scene content is unchanged."""
        if self.content is not None and not plan.content:
            return None
        for name in plan.geometry:
            self.meshes.pop(name, None)
        self.extracted, self.transformed, self.seen = [], [], set()
        ex = _CachedExporter(depsgraph, self)
        for inst in rendered_instances(depsgraph, ex):
            ex.add_instance(inst)
        scene = ex.scene(depsgraph.scene, PLACEHOLDER_CAMERA, source)
        for gone in set(self.meshes) - self.seen:        # deleted, hidden or renamed
            del self.meshes[gone]
        self.content = Content(scene, self.geometry_version, list(ex.warnings))
        return self.content

    def assemble(self, ex):
        """World positions, normals and triangles of the exporter's parts: each part's arrays
        from the cache unless its mesh or matrix changed; the same arrays as before if none did."""
        key, blocks = [], []
        for mesh, matrix, _, object_id in ex.parts:
            name = ex.objects[object_id]["name"]
            m = matrix.tobytes()
            cached = self.world.get(name)
            if cached is None or cached[0] is not mesh or cached[1] != m:
                p, n, t = to_world(mesh, matrix[None])
                cached = self.world[name] = (mesh, m, p[0], n[0], t[0])
                self.transformed.append(name)
            key.append((name, mesh, m))
            blocks.append(cached[2:])
        names = {k[0] for k in key}
        for gone in set(self.world) - names:
            del self.world[gone]
        if self.arrays is not None and self.parts_key is not None and len(key) == len(
                self.parts_key) and all(a[0] == b[0] and a[1] is b[1] and a[2] == b[2]
                                        for a, b in zip(key, self.parts_key)):
            return self.arrays
        self.parts_key = key
        self.geometry_version += 1
        n_verts = sum(len(b[0]) for b in blocks)
        n_tris = sum(len(b[2]) for b in blocks)
        positions = np.empty((n_verts, 3), np.float32)
        normals = np.empty((n_verts, 3), np.float32)
        triangles = np.empty((n_tris, 3), np.int32)
        v = t = 0
        for p, n, tris in blocks:
            positions[v:v + len(p)] = p
            normals[v:v + len(p)] = n
            triangles[t:t + len(tris)] = tris + v
            v, t = v + len(p), t + len(tris)
        self.arrays = positions, normals, triangles
        return self.arrays
