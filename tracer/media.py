"""Absorbing media inside objects: the per-path stack of the media a path is inside, and the
Beer-Lambert attenuation exp(-sigma_a t) along every segment it travels inside them.

A material with a Volume (scene file: its `absorption`, sigma_a per metre per channel) makes the
inside of every object it is on a medium. As Cycles keeps its volume stack
(intern/cycles/kernel/integrator/volume_stack.h, volume_stack_enter_exit): a path that passes
through a surface (a transmission) of such a material enters the medium when it hits the front
face (adds the entry (object, material) unless it is already there) and leaves it at the back
face (removes that entry); a stack holds at most MAX_MEDIA entries, and one more is ignored.
Overlapping media add their coefficients (volume_extinction_setup sums the extinction of every
volume closure). A shadow ray starts with its path's stack, updated the same way when it leaves
through the surface it starts on (shade_surface.h: is_transmission = dot(light, N) < 0).
Where a path starts inside a medium (a camera or a lamp inside an object), the stack is found
as Cycles' integrator_volume_stack_init finds the camera's (intersect_volume_stack.h): a ray
straight up (+Z) from the point, whose exits from objects it never entered are the media the
point is inside (stack_at, in numpy over the medium triangles, once per render).

Homogeneous absorption only: Cycles' transmittance of a homogeneous, absorbing medium over a
segment of length t is exp(-sigma_t t) exactly (shade_volume.h, volume_integrate_homogeneous).
An entry is encoded as object * (number of materials) + material; NONE ends a stack.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .jit import jit
from .lights.area import intersect_area_lamp
from .lights.point import intersect_point_lamp
from .vec import vmul

MAX_MEDIA = 8           # entries in a path's stack (Cycles: the scene's volume objects + 1)
NONE = -1               # no entry (the end of a stack)
ZERO = (0.0, 0.0, 0.0)


class Media(NamedTuple):
    """The scene's media, as the kernels read them."""
    on: bool                  # any material absorbs: every medium step runs only then
    sigma: np.ndarray         # (M, 3) absorption coefficient sigma_a of each material, per metre
    volume: np.ndarray        # (M,) bool: the material has a volume (enters and leaves stacks)
    n_materials: int
    object_of: np.ndarray     # (T,) int64 the object of each triangle
    camera: np.ndarray        # (MAX_MEDIA,) int64 the stack at the camera
    object_start: np.ndarray  # (O, MAX_MEDIA) stack at each emissive object (light paths)
    area_start: np.ndarray    # (A, MAX_MEDIA) stack at each area lamp's centre
    point_start: np.ndarray   # (P, MAX_MEDIA) stack at each point and spot lamp


def empty_stacks(n: int) -> np.ndarray:
    """n stacks with nothing in them."""
    return np.full((n, MAX_MEDIA), NONE, np.int64)


# -- the stack ----------------------------------------------------------------------------------

@jit
def entry_of(media, tri, mat):
    """The stack entry of the medium behind triangle tri of material mat: (object, material)."""
    return media.object_of[tri] * media.n_materials + mat


@jit
def enter(stacks, i, entry):
    """Stack i enters a medium: the entry is added unless it is there already or the stack is
    full (then ignored, as Cycles ignores it)."""
    for k in range(MAX_MEDIA):
        if stacks[i, k] == entry:
            return
        if stacks[i, k] == NONE:
            stacks[i, k] = entry
            return


@jit
def leave(stacks, i, entry):
    """Stack i leaves a medium: its entry is removed (the last entry takes its place)."""
    last = MAX_MEDIA - 1
    for k in range(MAX_MEDIA):
        if stacks[i, k] == NONE:
            last = k - 1
            break
    for k in range(last + 1):
        if stacks[i, k] == entry:
            stacks[i, k] = stacks[i, last]
            stacks[i, last] = NONE
            return


@jit
def pass_through(media, stacks, i, tri, mat, front):
    """Stack i passes through triangle tri of material mat (a transmission), hitting its front
    face (front: into the object) or its back face (out of it)."""
    if not media.volume[mat]:
        return
    entry = entry_of(media, tri, mat)
    if front:
        enter(stacks, i, entry)
    else:
        leave(stacks, i, entry)


@jit
def copy_stack(src, i, dst, j):
    """dst[j] = src[i]."""
    for k in range(MAX_MEDIA):
        dst[j, k] = src[i, k]


@jit
def carry(media, stacks, i, out, j, tri, mat, front, transmitted):
    """The next ray's stack (row j of out) after path i's vertex on triangle tri: its own,
    entered or left where the vertex transmitted through the surface."""
    copy_stack(stacks, i, out, j)
    if transmitted:
        pass_through(media, out, j, tri, mat, front)


# -- coefficients and attenuation ---------------------------------------------------------------

@jit
def sigma_of(media, stacks, i):
    """The absorption coefficient inside stack i's media (overlapping media add)."""
    s0, s1, s2 = 0.0, 0.0, 0.0
    n = media.n_materials
    for k in range(MAX_MEDIA):
        entry = stacks[i, k]
        if entry == NONE:
            break
        mat = entry % n
        s0 += media.sigma[mat, 0]
        s1 += media.sigma[mat, 1]
        s2 += media.sigma[mat, 2]
    return (s0, s1, s2)


@jit
def sigma_through(media, stacks, i, tri, mat, front):
    """sigma_of the stack a ray gets that leaves path i's vertex through the surface (a shadow
    ray to a light behind it): stack i entered or left at triangle tri of material mat."""
    s0, s1, s2 = 0.0, 0.0, 0.0
    n = media.n_materials
    entry = entry_of(media, tri, mat) if media.volume[mat] else NONE
    found = False
    count = 0
    for k in range(MAX_MEDIA):
        e = stacks[i, k]
        if e == NONE:
            break
        count += 1
        if e == entry:
            found = True
            if not front:
                continue          # leaving this medium: it no longer counts
        m = e % n
        s0 += media.sigma[m, 0]
        s1 += media.sigma[m, 1]
        s2 += media.sigma[m, 2]
    if entry != NONE and front and not found and count < MAX_MEDIA:
        s0 += media.sigma[mat, 0]
        s1 += media.sigma[mat, 1]
        s2 += media.sigma[mat, 2]
    return (s0, s1, s2)


@jit
def transmittance(sigma, t):
    """Beer-Lambert: exp(-sigma t) per channel; 1 where sigma is 0 (also for t infinite)."""
    return (math.exp(-sigma[0] * t) if sigma[0] > 0.0 else 1.0,
            math.exp(-sigma[1] * t) if sigma[1] > 0.0 else 1.0,
            math.exp(-sigma[2] * t) if sigma[2] > 0.0 else 1.0)


@jit
def absorbs(sigma):
    """Whether a coefficient attenuates at all."""
    return sigma[0] > 0.0 or sigma[1] > 0.0 or sigma[2] > 0.0


@jit
def through(beta, sigma, t):
    """beta after a segment of length t in a medium of coefficient sigma."""
    return vmul(beta, transmittance(sigma, t)) if absorbs(sigma) else beta


@jit
def lamp_distance(lights, lamp, o, d):
    """How far along o + t d the ray crosses lamp `lamp` (lights.dispatch.lamps_to_cross's
    numbering: area lamps, then point and spot lamps)."""
    n_area = lights.area_area.shape[0]
    if lamp < n_area:
        return intersect_area_lamp(lights, lamp, o, d)
    return intersect_point_lamp(lights, lamp - n_area, o, d)


@jit
def attenuate_shadows(media, stacks, i, tri, mat, front, ns_f, shadows, first, end):
    """Attenuate the shadow rays first .. end that path i's vertex on triangle tri queued, each
    over its length in the media it crosses: the path's, entered or left through this surface
    when the ray goes below the shading normal (ns_f, facing the incoming ray), as Cycles'
    shadow ray copies the path's stack."""
    if first == end:
        return
    inside = sigma_of(media, stacks, i)
    below = sigma_through(media, stacks, i, tri, mat, front)
    for j in range(first, end):
        d = (np.float64(shadows.d32[j, 0]), np.float64(shadows.d32[j, 1]),
             np.float64(shadows.d32[j, 2]))
        sigma = below if d[0] * ns_f[0] + d[1] * ns_f[1] + d[2] * ns_f[2] < 0.0 else inside
        if not absorbs(sigma):
            continue
        tr = transmittance(sigma, np.float64(shadows.tmax[j]))
        for k in range(3):
            shadows.contrib[j, k] *= tr[k]
            shadows.without[j, k] *= tr[k]


@jit
def attenuate_path(media, stacks, i, beta, t):
    """Path i's throughput after its segment of length t."""
    return through(beta, sigma_of(media, stacks, i), t)


@jit
def start_sigma(media, kind_is_area, index):
    """sigma_a where a light vertex's ray starts: area lamp `index`, or emissive triangle
    `index` (its object's stack)."""
    if kind_is_area:
        return sigma_of(media, media.area_start, index)
    return sigma_of(media, media.object_start, media.object_of[index])


# -- tables -------------------------------------------------------------------------------------

def stack_at(point, corners, tri_object, tri_material, n_materials, volume) -> np.ndarray:
    """The stack (MAX_MEDIA entries) at a point, as Cycles' integrator_volume_stack_init finds
    the camera's: along the ray straight up from it (+Z), in the order of its hits on the
    medium triangles, the exit from an object it never entered (a back face) adds
    (object, material) unless the object is in the stack already; an entry (a front face)
    means the ray is outside that object. corners: (T, 3, 3) float64 of the triangles of
    materials with a volume, tri_object and tri_material theirs."""
    stack = np.full(MAX_MEDIA, NONE, np.int64)
    if len(corners) == 0:
        return stack
    p = np.asarray(point, np.float64)
    up = np.array([0.0, 0.0, 1.0])
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    e1, e2 = b - a, c - a
    pv = np.cross(up, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = p - a
    u = np.einsum("ij,ij->i", tv, pv) * inv
    qv = np.cross(tv, e1)
    v = (qv @ up) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    normal_z = np.cross(e1, e2)[:, 2]
    enclosed, count = set(), 0
    for k in np.flatnonzero(hit)[np.argsort(t[hit])]:
        obj, mat = int(tri_object[k]), int(tri_material[k])
        if not volume[mat]:
            continue
        if normal_z[k] > 0.0:          # the ray leaves through a back face: an exit
            entry = obj * n_materials + mat
            inside = {int(e) // n_materials for e in stack[:count]}
            if obj not in enclosed and obj not in inside and count < MAX_MEDIA:
                stack[count] = entry
                count += 1
        else:
            enclosed.add(obj)
    return stack


def media_tables(scene, lights) -> Media:
    """The kernels' media tables for a scene and its light tables (lights.tables.Lights):
    each material's sigma_a, and the stacks at the camera, the lamps and the emissive
    objects (for paths that start there)."""
    n_mat = len(scene.materials)
    sigma = np.zeros((max(n_mat, 1), 3))
    volume = np.zeros(max(n_mat, 1), bool)
    for m, mat in enumerate(scene.materials):
        if mat.get("absorption") is not None:
            sigma[m] = mat["absorption"]
            volume[m] = True
    on = bool(np.any(sigma > 0.0))
    object_of = np.asarray(scene.object_ids, np.int64)
    n_objects = int(object_of.max()) + 1 if len(object_of) else 0
    n_area, n_point = lights.area_area.shape[0], lights.point_pos.shape[0]
    camera = np.full(MAX_MEDIA, NONE, np.int64)
    object_start = empty_stacks(n_objects if on else 0)
    area_start, point_start = empty_stacks(n_area if on else 0), empty_stacks(n_point if on else 0)
    if on:
        mids = np.asarray(scene.material_ids, np.int64)
        chosen = volume[mids]
        corners = scene.positions[scene.triangles[chosen]].astype(np.float64)
        args = (corners, object_of[chosen], mids[chosen], n_mat, volume)
        camera = stack_at(np.asarray(scene.camera["matrix"], np.float64)[:3, 3], *args)
        for i in range(n_area):
            area_start[i] = stack_at(lights.area_center[i], *args)
        for i in range(n_point):
            point_start[i] = stack_at(lights.point_pos[i], *args)
        emissive = np.unique(object_of[lights.tri_prim]) if len(lights.tri_prim) else []
        for obj in emissive:
            tri = int(lights.tri_prim[np.flatnonzero(object_of[lights.tri_prim] == obj)[0]])
            centroid = scene.positions[scene.triangles[tri]].astype(np.float64).mean(axis=0)
            object_start[obj] = stack_at(centroid, *args)
    return Media(on, sigma, volume, max(n_mat, 1), object_of, camera, object_start, area_start,
                 point_start)


def camera_in_medium(media: Media) -> bool:
    """Whether the camera is inside a medium."""
    return bool(media.on and media.camera[0] != NONE)
