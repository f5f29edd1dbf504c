"""Blender meshes as local-space arrays (mesh_arrays, Mesh) and their instances' world-space
arrays (to_world).

Each distinct evaluated mesh is read once: its triangles, a vertex per distinct (vertex, normal)
pair, its material slots per triangle, whether it is closed, and with textures its UV maps and
Generated coordinates per corner (with normal maps also the UV maps' tangents, and with
Attribute or Color Attribute nodes the attributes they name). The depsgraph walk transforms it
for all its instances.

Arrays are read with foreach_get into preallocated arrays. Attributes (positions, corner
vertices, material indices) and the normal caches are copied by Blender in one block; the loop
triangles' corners have no such layout and are read item by item: 12-20 ms of the 40-50 ms
that exporting cornell_dragon's 128k triangles takes.
"""
from __future__ import annotations

import numpy as np

from ...tracer.scene import MAX_COORDINATE


def _read(collection, prop, count, dtype):
    """collection.foreach_get(prop) into a new flat array of count values."""
    out = np.empty(count, dtype)
    collection.foreach_get(prop, out)
    return out


def _attribute(mesh, name, count, dtype, prop="value"):
    """An attribute's values (prop: "value" or "vector"), or None if the mesh has no such one."""
    attr = mesh.attributes.get(name)
    return None if attr is None else _read(attr.data, prop, count, dtype)


def _mesh_texcoords(mesh, corner_verts, co):
    """{UV map name: (corners, 2) float32}, the active render UV map's name, and the Generated
    coordinates (corners, 3) of a bpy mesh (Cycles: (co - texspace location) / (2 texspace
    size) + 0.5)."""
    nc = len(corner_verts)
    uvs = {}
    for layer in mesh.uv_layers:
        uvs[layer.name] = _read(layer.uv, "vector", nc * 2, np.float32).reshape(nc, 2)
    active = next((layer.name for layer in mesh.uv_layers if layer.active_render), "")
    loc = np.array(mesh.texspace_location, np.float64)
    size = np.array(mesh.texspace_size, np.float64)
    half = np.divide(0.5, size, out=np.zeros(3), where=size != 0)
    orco = ((co.reshape(-1, 3)[corner_verts] - loc) * half + 0.5).astype(np.float32)
    return uvs, active, orco


# Attribute types Cycles reads (blender/mesh.cpp), by the foreach_get property that holds them.
ATTRIBUTE_PROPS = {"FLOAT": "value", "INT": "value", "INT8": "value", "BOOLEAN": "value",
                   "FLOAT2": "vector", "FLOAT_VECTOR": "vector", "FLOAT_COLOR": "color",
                   "BYTE_COLOR": "color"}
WIDTHS = {"value": 1, "vector": None, "color": 4}
# The array types foreach_get fills for the integer and boolean ones (Cycles reads them as
# floats).
VALUE_TYPES = {"INT": np.int32, "INT8": np.int32, "BOOLEAN": bool}


def _standard_attribute(mesh, name, uvs, active, orco):
    """(per-corner values (corners, k), width) of the Cycles standard attributes an Attribute
    node can name that Snell reads ("uv": the active render UV map, "generated": Generated
    coordinates), or None."""
    if name == "uv":
        uv = uvs.get(active)
        return None if uv is None else (uv.astype(np.float64), 2)
    if name == "generated":
        return orco.astype(np.float64), 3
    return None


def _mesh_attributes(mesh, names, corner_verts, uvs=None, active="", orco=None):
    """{name: ((corners, 3) value, (corners, 3) (Fac, Alpha, 1))} float32 of the named
    attributes the mesh has ("": its default colour attribute, which Cycles renders for a Color
    Attribute node without a name), per corner as Cycles reads them (kernel/svm/attribute.h):
    a number f is (f, f, f) of Fac f, a 2D vector (x, y, 0) of Fac x, a 3D vector or a colour
    its first three of Fac their average; Alpha is a colour's alpha, else 1. Byte colours are
    decoded from sRGB per element (Blender's `color`), before interpolation, as Cycles decodes
    them. Cycles' standard names "uv", "generated" and "vertex_color" are the active render UV
    map, Generated coordinates and the default colours. Attributes on edges (which Cycles does
    not read) and of other types are left out: missing, as in Cycles."""
    nc = len(corner_verts)
    out = {}
    for name in names:
        standard = _standard_attribute(mesh, name, uvs or {}, active, orco)
        if standard is not None:
            raw, width = standard
            out[name] = _attribute_outputs(raw, width)
            continue
        # "vertex_color": Cycles' standard name of the default colours, as "".
        real = "" if name == "vertex_color" else name
        attr = mesh.attributes.get(real or mesh.attributes.default_color_name or "")
        prop = ATTRIBUTE_PROPS.get(getattr(attr, "data_type", None))
        if attr is None or prop is None or attr.domain not in ("POINT", "CORNER", "FACE"):
            continue
        n = len(attr.data)
        width = WIDTHS[prop] or (2 if attr.data_type == "FLOAT2" else 3)
        raw = _read(attr.data, prop, n * width, VALUE_TYPES.get(attr.data_type, np.float32))
        raw = raw.astype(np.float64).reshape(n, width)
        if attr.domain == "POINT":
            at = corner_verts
        elif attr.domain == "FACE":
            at = _corner_faces(mesh, nc)
        else:
            at = np.arange(nc)
        out[name] = _attribute_outputs(raw[at], width)
    return out


def _attribute_outputs(raw, width):
    """((n, 3) value, (n, 3) (Fac, Alpha, 1)) float32 of n values of `width` components, as
    _mesh_attributes describes."""
    n = len(raw)
    value = np.zeros((n, 3))
    extra = np.ones((n, 3))
    if width == 1:
        value[:] = raw
        extra[:, 0] = raw[:, 0]
    elif width == 2:
        value[:, :2] = raw
        extra[:, 0] = raw[:, 0]
    else:
        value[:] = raw[:, :3]
        extra[:, 0] = raw[:, :3].mean(axis=1)
        if width == 4:
            extra[:, 1] = raw[:, 3]
    return value.astype(np.float32), extra.astype(np.float32)


def _corner_faces(mesh, n_corners):
    """The face of each corner."""
    nf = len(mesh.polygons)
    start = _read(mesh.polygons, "loop_start", nf, np.int64)
    total = _read(mesh.polygons, "loop_total", nf, np.int64)
    faces = np.zeros(n_corners, np.int64)
    order = np.argsort(start, kind="stable")
    faces[np.concatenate([np.arange(start[f], start[f] + total[f]) for f in order])
          if nf else np.zeros(0, np.int64)] = np.repeat(order, total[order])
    return faces


def _tangent_frames(uvs, co, corner_verts, tri_corners, corner_n, smooth):
    """{UV map name: ((corners, 3) tangent, (corners,) bitangent sign)} in object space, as
    Cycles computes them (scene/mesh.cpp, mikk_compute_tangents): MikkTSpace over the mesh's
    triangles (not its quads: on Suzanne the two differ by up to 25 degrees), with the corner
    normals on smooth triangles. A mesh without UV maps gets Cycles' fallback under the name
    "": its positions mapped to a sphere (map_to_sphere)."""
    import bpy
    co = co.reshape(-1, 3)
    if not uvs:
        uvs = {"": map_to_sphere(co[corner_verts].astype(np.float64)).astype(np.float32)}
    nt, nc = len(tri_corners), len(corner_verts)
    tri = bpy.data.meshes.new("snell tangents")
    try:
        tri.vertices.add(len(co))
        tri.vertices.foreach_set("co", co.astype(np.float32).ravel())
        tri.loops.add(3 * nt)
        tri.loops.foreach_set("vertex_index", corner_verts[tri_corners].astype(np.int32).ravel())
        tri.polygons.add(nt)
        tri.polygons.foreach_set("loop_start", np.arange(0, 3 * nt, 3, dtype=np.int32))
        tri.update(calc_edges=True)
        tri.polygons.foreach_set("use_smooth", smooth)
        tri.normals_split_custom_set(corner_n[tri_corners].reshape(-1, 3))
        layer = tri.uv_layers.new(name="uv")
        frames = {}
        for name, uv in uvs.items():
            layer.uv.foreach_set("vector", uv[tri_corners].astype(np.float32).ravel())
            tri.calc_tangents(uvmap="uv")
            # MikkTSpace welds corners of equal position, normal and UV: a corner's triangles
            # agree on its tangent, which goes back to the mesh's corners.
            tangent = np.zeros((nc, 3), np.float32)
            sign = np.ones(nc, np.float32)
            tangent[tri_corners.ravel()] = _read(tri.loops, "tangent", 9 * nt,
                                                 np.float32).reshape(-1, 3)
            sign[tri_corners.ravel()] = _read(tri.loops, "bitangent_sign", 3 * nt, np.float32)
            frames[name] = tangent, sign
        return frames
    finally:
        bpy.data.meshes.remove(tri)


def map_to_sphere(p):
    """(N, 2) Cycles' map_to_sphere of (N, 3) positions (util/math_float3.h): u the longitude
    0.5 - atan2(x, y) / 2 pi, v 1 - acos(z / |p|) / pi; 0 at the origin."""
    length = np.linalg.norm(p, axis=1)
    u = np.where((p[:, 0] == 0.0) & (p[:, 1] == 0.0), 0.0,
                 0.5 - np.arctan2(p[:, 0], p[:, 1]) / (2.0 * np.pi))
    v = 1.0 - np.arccos(np.clip(p[:, 2] / np.where(length > 0.0, length, 1.0), -1.0, 1.0)) / np.pi
    inside = length > 0.0
    return np.stack([np.where(inside, u, 0.0), np.where(inside, v, 0.0)], axis=1)


def mesh_arrays(obj, texcoords=False, tangents=False, attributes=()):
    """Local-space geometry of an evaluated object, ready for instancing (see Mesh); with
    texcoords, also its UV maps and Generated coordinates per corner, with tangents its UV
    maps' tangents (for normal maps) and the named attributes (_mesh_attributes)."""
    mesh = obj.to_mesh()
    try:
        if mesh is None:
            return None
        mesh.calc_loop_triangles()
        nv, nc, nf = len(mesh.vertices), len(mesh.loops), len(mesh.polygons)
        nt = len(mesh.loop_triangles)
        # Through the public, slower collections if an attribute is missing: a mesh without
        # vertices has no "position", and ".corner_vert" is Blender's internal name.
        co = _attribute(mesh, "position", nv * 3, np.float32, "vector")
        if co is None:
            co = _read(mesh.vertices, "co", nv * 3, np.float32)
        corner_verts = _attribute(mesh, ".corner_vert", nc, np.int32)
        if corner_verts is None:
            corner_verts = _read(mesh.loops, "vertex_index", nc, np.int32)
        # Read as intp (no slower: it goes item by item anyway), the type NumPy indexes with.
        tri_corners = _read(mesh.loop_triangles, "loops", nt * 3, np.intp).reshape(nt, 3)
        tri_faces = _read(mesh.loop_triangle_polygons, "value", nt, np.int32)
        face_mat = _attribute(mesh, "material_index", nf, np.int32)
        # Smooth faces: Blender's corner normals (vertex, sharp-edge split or custom normals).
        corner_n = _read(mesh.corner_normals, "vector", nc * 3, np.float32).reshape(nc, 3)
        sharp = _attribute(mesh, "sharp_face", nf, bool)
        coords = None
        if texcoords:
            uvs, active, orco = _mesh_texcoords(mesh, corner_verts, co)
            smooth = np.ones(nt, bool) if sharp is None else ~sharp[tri_faces]
            frames = (_tangent_frames(uvs, co, corner_verts, tri_corners, corner_n, smooth)
                      if tangents and nt else {})
            coords = (uvs, active, orco, frames,
                      _mesh_attributes(mesh, attributes, corner_verts, uvs, active, orco))
        if sharp is not None and sharp.any():
            face_n = _read(mesh.polygons, "normal", nf * 3, np.float32).reshape(nf, 3)
            corner_verts, tri_corners, corner_n, coords = _flat_normals(
                sharp[tri_faces], face_n[tri_faces], co, corner_verts, tri_corners, corner_n,
                coords)
    finally:
        obj.to_mesh_clear()
    mat_index = face_mat[tri_faces] if face_mat is not None else np.zeros(nt, np.int32)
    return Mesh(co.reshape(nv, 3).astype(np.float64), corner_verts, tri_corners, mat_index,
                 corner_n, coords)


# A flat triangle whose normal is this close to its face's (1 - cos; 1e-8: 1.4e-4 radians) is
# shaded with the face's normal: float rounding alone makes the halves of a planar quad differ.
PLANAR = 1e-8


def _flat_normals(flat, face_n, co, corner_verts, tri_corners, corner_n, coords):
    """The normals of flat triangles (flat: per triangle; face_n: its face's normal), as Cycles
    shades them: with each triangle's geometric normal, which on a non-planar quad (Suzanne's)
    is not the face's (measured: the face's normal made flat-shaded Suzannes under suns 0.5%
    darker than Cycles). The halves of a quad share corners: those of a non-planar face get
    corners of their own; planar faces keep theirs, with the face's normal. Returns
    corner_verts, tri_corners, corner_n and coords (texcoords per corner), extended."""
    flat = np.nonzero(flat)[0]
    p = co.reshape(-1, 3)[corner_verts[tri_corners[flat]]].astype(np.float64)   # (F, 3, 3)
    # A triangle with an Inf corner gets a NaN normal here (inf - inf), silently: it is dropped
    # with its own warning (depsgraph), and NaN is neither planar nor kept below.
    with np.errstate(invalid="ignore", over="ignore"):
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    face = face_n[flat]
    with np.errstate(invalid="ignore"):
        planar = np.einsum("ij,ij->i", n, face) >= 1.0 - PLANAR
    corner_n[tri_corners[flat[planar]].ravel()] = np.repeat(face[planar], 3, axis=0)
    own = ~planar & (np.linalg.norm(n, axis=1) > 0.0)        # degenerate ones are dropped
    bent = flat[own]
    if bent.size == 0:
        return corner_verts, tri_corners, corner_n, coords
    old = tri_corners[bent].ravel()
    tri_corners = tri_corners.copy()
    tri_corners[bent] = (len(corner_verts) + np.arange(old.size)).reshape(-1, 3)
    corner_verts = np.concatenate([corner_verts, corner_verts[old]])
    corner_n = np.concatenate([corner_n, np.repeat(n[own].astype(np.float32), 3, axis=0)])
    if coords is not None:
        uvs, active, orco, frames, attrs = coords
        coords = ({name: np.concatenate([uv, uv[old]]) for name, uv in uvs.items()}, active,
                  np.concatenate([orco, orco[old]]),
                  {name: (np.concatenate([t, t[old]]), np.concatenate([s, s[old]]))
                   for name, (t, s) in frames.items()},
                  {name: (np.concatenate([v, v[old]]), np.concatenate([e, e[old]]))
                   for name, (v, e) in attrs.items()})
    return corner_verts, tri_corners, corner_n, coords


class Mesh:
    """One evaluated mesh in local space: deduplicated (vertex, normal) pairs and triangles."""

    def __init__(self, co, corner_verts, tri_corners, mat_index, corner_n, coords=None):
        """co: (V, 3) positions; corner_verts, corner_n: per corner; the rest per triangle;
        coords: (UV maps, active name, Generated, tangent frames, attributes), or None (then no
        texture coordinates at all: texcoord gives zeros)."""
        tris = corner_verts[tri_corners]
        # Vertices at NaN, Inf or beyond MAX_COORDINATE drop their triangles, counted apart
        # from the zero-area ones (Embree skips such triangles too, and Cycles renders none).
        in_range = (np.abs(co) <= MAX_COORDINATE).all(axis=1)          # False for NaN
        self.dropped_nonfinite = self.dropped_out_of_range = 0
        if not in_range.all():
            finite = np.isfinite(co).all(axis=1)
            nonfinite = ~finite[tris].all(axis=1)
            self.dropped_nonfinite = int(np.count_nonzero(nonfinite))
            self.dropped_out_of_range = int(np.count_nonzero(~in_range[tris].all(axis=1)
                                                             & ~nonfinite))
            co = np.where(in_range[:, None], co, 0.0)     # no Inf - Inf in the tests below
            valid = in_range[tris].all(axis=1)
            keep = valid & _nondegenerate(co, tris)
            self.dropped = int(np.count_nonzero(valid & ~keep))
            corner_n = _finite_normals(corner_n, co, tris[keep], tri_corners[keep])
        else:
            keep = _nondegenerate(co, tris)
            self.dropped = int(len(keep) - np.count_nonzero(keep))
        if not keep.all():
            tri_corners, tris, mat_index = tri_corners[keep], tris[keep], mat_index[keep]
        self.tri_corners, self.coords = tri_corners, coords
        # NaN or Inf in an attribute would make the scene file invalid: read as 0, named
        # here for the exporter's warning.
        self.nonfinite_attributes = []
        for name, arrays in (coords[4] if coords is not None else {}).items():
            if not all(np.isfinite(a).all() for a in arrays):
                self.nonfinite_attributes.append(name)
                for a in arrays:
                    np.nan_to_num(a, copy=False, nan=0.0, posinf=0.0, neginf=0.0)
        # Object coordinates per triangle corner: the local positions (affine over a
        # triangle, so interpolating them is exact).
        self.local_corners = co[tris].astype(np.float32) if coords is not None else None
        self.mat_index = mat_index
        self.closed = _is_closed(tris, len(co))
        slot = _split_vertices(corner_verts, corner_n, len(co))
        self.triangles, first = _compact(slot, tri_corners)
        self.positions = co[corner_verts[first]]
        self.normals = corner_n[first].astype(np.float64)
        self._by_slots = {}

    def texcoord(self, kind, name, matrix=None):
        """(T, 3, 3) float32 texture coordinates per triangle corner: a UV map (name "" the
        active render one; a missing map gives 0, as in Cycles), Generated, Object, a named
        attribute's value or its (Fac, Alpha, found) (0 where the mesh lacks it); or, in
        world space for an instance of world matrix `matrix`, a UV map's normal-map frame
        (tangent_frame) or the object's normal matrix (normal_matrix)."""
        out = np.zeros((len(self.tri_corners), 3, 3), np.float32)
        if self.coords is None:
            return out
        uvs, active, orco, frames, attrs = self.coords
        if kind in ("attribute", "attribute_extra"):
            found = attrs.get(name)
            if found is not None:
                out[:] = found[kind == "attribute_extra"][self.tri_corners]
        elif kind in ("tangent", "tangent_sign", "tangent_normal"):
            frame = frames.get(name or active)
            if frame is not None:
                out[:] = self.tangent_frame(frame, matrix)[kind]
        elif kind == "normal_matrix":
            # Column x, y or z of the normal matrix M^-T: row x, y or z of M^-1.
            out[:] = np.linalg.inv(matrix[:3, :3])["xyz".index(name)]
        elif kind == "generated":
            out[:] = orco[self.tri_corners]
        elif kind == "object":
            out[:] = self.local_corners
        else:
            uv = uvs.get(name or active)
            if uv is not None:
                out[:, :, :2] = uv[self.tri_corners]
        return out

    def tangent_frame(self, frame, matrix):
        """{"tangent", "tangent_sign", "tangent_normal": (T, 3, 3)}: each corner's tangent t
        and normal n (the corner's shading normal), object-space vectors times the normal
        matrix A = M^-T of world matrix `matrix`; and per corner k its bitangent sign, then
        entry k of the diagonal and of (xy, xz, yz) of G = det(M) (M M^T)^-1, with which
        A (n x t) = G (A n x A t) (tracer/shader/normals.py)."""
        tangent, sign = frame
        m = np.asarray(matrix, np.float64)[:3, :3]
        inv = np.linalg.inv(m)                                  # row vectors: v M^-1 = A v
        t = tangent[self.tri_corners].astype(np.float64)        # (T, 3, 3)
        n = self.normals[self.triangles]
        g = np.linalg.det(m) * np.linalg.inv(m @ m.T)
        diagonal, off = np.diag(g), np.array([g[0, 1], g[0, 2], g[1, 2]])
        if np.linalg.det(m) < 0:
            # depsgraph.texcoords swaps corners 1 and 2 of a mirrored part: swap G's entries
            # first, so that they end where the kernel reads them.
            diagonal, off = diagonal[[0, 2, 1]], off[[0, 2, 1]]
        rows = np.empty((len(t), 3, 3))
        rows[:, :, 0] = sign[self.tri_corners]
        rows[:, :, 1] = diagonal
        rows[:, :, 2] = off
        return {"tangent": t @ inv, "tangent_sign": rows, "tangent_normal": n @ inv}

    def material_ids(self, slot_ids):
        """(scene material id of each triangle, the distinct ids) for an object's slots' ids."""
        # Cached: the thousands of instances of one mesh mostly share their slots.
        if slot_ids not in self._by_slots:
            ids = np.array(slot_ids, np.int32)[np.clip(self.mat_index, 0, len(slot_ids) - 1)]
            self._by_slots[slot_ids] = ids, np.unique(ids).tolist()
        return self._by_slots[slot_ids]


# NumPy temporaries of 1 MB and more come back from the allocator bpy brings (tbbmalloc) as
# fresh pages, and on the 2-core development machine a page fault costs more than the arithmetic
# on the page: per-triangle work goes in chunks that stay below that size (_nondegenerate on
# cornell_dragon's 128k triangles: 20 ms whole, 5 ms in chunks).
CHUNK = 16384


def _nondegenerate(co, tris):
    """Which triangles (vertex indices into co) have an area that is not negligible."""
    # Each coordinate as a (corner, triangle) array: NumPy is several times faster on such
    # contiguous rows than on (n, 3) columns.
    rows = [np.ascontiguousarray(c) for c in co.T]
    keep = np.empty(len(tris), bool)
    for s in range(0, len(tris), CHUNK):
        corners = np.ascontiguousarray(tris[s:s + CHUNK].T)
        x, y, z = (r[corners] for r in rows)
        u = [c[1] - c[0] for c in (x, y, z)]
        v = [c[2] - c[0] for c in (x, y, z)]
        w = [c[2] - c[1] for c in (x, y, z)]
        cross_sq = sum((u[i] * v[j] - u[j] * v[i]) ** 2 for i, j in ((1, 2), (2, 0), (0, 1)))
        longest_sq = np.maximum(np.maximum(_dot(u, u), _dot(w, w)), _dot(v, v))
        # Relative test, so that a tiny but well-shaped triangle is kept.
        keep[s:s + CHUNK] = np.sqrt(cross_sq) > 1e-12 * longest_sq
    return keep


def _finite_normals(corner_n, co, tris, tri_corners):
    """corner_n, with the NaN or Inf normals of these triangles' corners (a smooth vertex next
    to a NaN one) replaced by the triangle's own normal."""
    bad = ~np.isfinite(corner_n).all(axis=1)
    if not bad.any():
        return corner_n
    corner_n = corner_n.copy()
    hit = bad[tri_corners].any(axis=1)
    p = co[tris[hit]]
    g = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300)
    for k in range(3):
        corners = tri_corners[hit, k]
        fix = bad[corners]
        corner_n[corners[fix]] = g[fix]
    return corner_n


def _dot(a, b):
    """Row-wise dot product of two vectors given as lists of coordinate rows."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _is_closed(tris, n_verts):
    """Every edge is shared by exactly two triangles."""
    if len(tris) == 0:
        return False
    # An edge as one integer, low * n_verts + high: sorting integers is far faster than
    # np.unique over rows.
    keys = np.empty((3, len(tris)), np.int64)
    for k in range(3):
        for s in range(0, len(tris), CHUNK):
            a, b = tris[s:s + CHUNK, k], tris[s:s + CHUNK, (k + 1) % 3]
            out = keys[k, s:s + CHUNK]
            np.minimum(a, b, out=out)
            out *= n_verts
            out += np.maximum(a, b)
    keys = keys.reshape(-1)
    # The stable sort (timsort) profits from the runs in a mesh's edge order: 5 ms, not 22 ms,
    # for the 384k edges of cornell_dragon.
    keys.sort(kind="stable")
    # Every key exactly twice: pairs (0, 1), (2, 3), ... equal and no pair equal to the next.
    return bool(np.array_equal(keys[0::2], keys[1::2]) and not np.any(keys[1:-1:2] == keys[2::2]))


def _split_vertices(verts, normals, n_verts, max_rounds=8):
    """Slot of each corner: one per distinct (vertex, normal), numbered round * n_verts + vertex.

    Most vertices carry one normal on all their corners and the others a few. Each round takes
    the normal of one corner per vertex still without a slot and gives that round's slot to
    that vertex's corners with exactly this normal; the others wait for the next round. Round
    0's slot is the vertex itself. (np.unique over all (vertex, normal) keys took 85 ms on
    cornell_dragon's 384k triangle corners; this takes 4 ms on its 256k mesh corners.)
    """
    keys = normals.view(np.dtype((np.void, 12))).ravel()  # exact bits: -0.0 and 0.0 differ
    seen = np.empty(n_verts, keys.dtype)
    seen[verts] = keys  # one corner per vertex wins
    slot = verts.astype(np.int64)
    left = np.flatnonzero(keys != seen[verts])
    for rnd in range(1, max_rounds):
        if len(left) == 0:
            return slot
        v, k = verts[left], keys[left]
        seen[v] = k
        same = k == seen[v]
        slot[left[same]] = rnd * n_verts + v[same]
        left = left[~same]
    if len(left):
        # A vertex with many normals (a flat cone's tip) would take a round each: sort the rest.
        pairs = np.empty(len(left), [("v", np.int64), ("n", keys.dtype)])
        pairs["v"], pairs["n"] = verts[left], keys[left]
        _, inverse = np.unique(pairs.view(np.dtype((np.void, 20))), return_inverse=True)
        slot[left] = max_rounds * n_verts + inverse.reshape(-1)
    return slot


def _compact(slot, tri_corners):
    """(triangles, one corner of each vertex): the slots triangles use, renumbered in order."""
    tri_slots = slot[tri_corners]
    used = np.zeros(int(slot.max(initial=-1)) + 1, bool)
    used[tri_slots] = True
    corner = np.empty(len(used), np.int64)
    corner[tri_slots] = tri_corners  # all corners of a slot have the same vertex and normal
    renumber = (np.cumsum(used) - 1).astype(np.int32)
    return renumber[tri_slots], corner[used]

def to_world(mesh, matrices):
    """Positions, unit normals (k, V, 3) and triangles (k, T, 3) of a mesh's k instances."""
    m3 = matrices[:, :3, :3]
    positions = mesh.positions @ m3.transpose(0, 2, 1) + matrices[:, None, :3, 3]
    normals = mesh.normals @ np.linalg.inv(m3)  # (M^-T n) for row vectors
    normals /= np.maximum(np.linalg.norm(normals, axis=2, keepdims=True), 1e-300)
    # A mirroring matrix turns the winding over: swap two corners to turn it back.
    flip = (np.linalg.det(m3) < 0)[:, None, None]
    triangles = np.where(flip, mesh.triangles[:, [0, 2, 1]], mesh.triangles)
    return positions, normals, triangles
