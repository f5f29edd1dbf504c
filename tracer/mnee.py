"""Manifold next-event estimation (MNEE): light that reaches a rough surface through smooth
refracting surfaces, sampled at the surface as a light sample (Hanika et al. 2015; Cycles'
shadow caustics, kernel/integrator/mnee.h). The formulas are manifold.py's; this is the stage.

Where it runs is the file's: Cycles' shadow-caustics flags (an object's caustics caster and
receiver, a lamp's caustics light; docs/scene-format.md). At a vertex on a receiver (diffuse,
layered or a shader program's: RECEIVING_KINDS) the stage samples a caustics lamp and on it a
point y (point and spot lamps of radius > 0: uniform on the disk that faces the chain's last
vertex, as the path tracer's ray from that vertex finds it, so y turns with that vertex as the
walk moves it: face_last_vertex; area lamps of spread > 0: a point uniform on the lamp) or, for
a sun, a direction (uniform in its cone; a sun of angle 0: its one direction, and y stands for
that direction, manifold.py's fixed direction),
follows the segment x0 y collecting the smooth refracting triangles of casters it crosses (other
objects are passed, as in Cycles; at most manifold.MAX_CASTERS), walks that seed chain onto the
specular manifold by Newton's method (each step's points projected back onto their objects by a
ray from the vertex before them, halving the step where a projection misses or a vertex stops
refracting), where that walk fails walks again from a seed refracted by Snell's law at each
caster it meets (reseed), checks that each converged segment is free, and adds

    beta f(x0) |cos(x0)| prod(tint (1 - F)) L_e G / (pmf p_A(y))

((1 - F) at glass only: a refraction-only caster, Cycles' Refraction BSDF, carries its tint),
with f the receiver's BSDF from the viewer to the first vertex (albedo / pi on a diffuse one;
as in Cycles, every lobe of a layered or program one: receiver_response), G = dw0/dA(y)
(manifold.geometry_term), no clamp; for a sun dw0/dw(sun) over the cone's
solid-angle density (a sun of angle 0: its irradiance over density 1, as the light tracer's
sun_emission).

The split with the other techniques is exact, as the light tracer's is: the stage owns every
path "caustics lamp, one or more refractions at caster triangles, a receiver vertex whose
direction towards them is one a non-singular lobe samples above both its normals" (`reflected`;
the camera side anything), and the others skip exactly those. A camera path's `mnee` state
(wavefront.Paths.mnee, mnee_after) counts the caster refractions since its last receiver vertex;
wavefront.emitters gives it no light from a caustics lamp then, whether it crosses the lamp or
escapes into a sun's disc (Cycles skips caustic lamps after a caster too, but also after
reflections, which MNEE does not render). A light path's state (light_tracer.LightPaths.mnee)
counts the same from its lamp, and the light tracer neither stores a photon nor goes on at a
receiver after them, and connects to the camera only where the stage leaves it the camera ray's
own hit (below).

Where the camera ray itself hits the receiver, the light tracer's connection from the receiver
to the camera renders exactly the stage's paths (lamp, refractions at casters, receiver, camera;
any surface between blocks both the connection and the camera ray's depth 0), unbiased. Where
light passes two or more refracting surfaces (a glass, a tumbler's walls) it does better: a
light path lands where the glass focuses the light, where the stage's Jacobian is heavy-tailed
and its walks often fail (docs/measurements.md). Through one (a water surface), whose walks
seldom fail, the stage's chains are far smoother than light paths spread over the floor. So at
depth 0, towards a lamp the light tracer starts paths from and the path tracer leaves its
caustics to (Snell's caustics on, not the pure light-tracing test), on a plain diffuse receiver
(whose whole BSDF the connection carries) the stage's chains hold one refraction at most, and
the light tracer connects its paths through two or more; on a layered or program receiver (the
connection carries its Lambert lobe alone but from a delta lamp) the stage leaves it only a sun
of angle 0's light. Either way the split is exact: a path's refractions are counted alike by
both. Past depth 0 (a receiver seen through glass, or after a bounce) the light tracer cannot
reach the camera, and the stage keeps the light. A sun of angle 0 is the stage's where the file
flags it, as in Cycles (no camera path finds it, and the light tracer cannot render its paths
seen through glass); point lamps of radius 0 and area lamps of spread 0 stay the light tracer's
alone.

What MNEE itself leaves out is its bias: one solution per lamp sample (where waves fold the
light, several paths join x0 and y, and the walk finds the one nearest its seed), and none where
the seed segment misses the casters or neither walk converges. The second seed is Snell's:
Cycles and Hanika et al. walk from the straight one only, and where that segment crosses the
edge of a thick wall (a tube's, twice its outer surface) no path with those vertices exists, so
that walk can only fail; the refracted seed has the vertices a path through the wall has
(docs/measurements.md, the tumbler). A one-vertex chain's refracted seed is its straight one,
walked again from the gentle first step: where the water's index is high (2.0), the full first
step overshoots and 6% of the pool's walks failed, and this finds a third of their light.

Runs only where the flags name a receiver, a caster and a lamp, light sampling is on, and the
render has no absorbing media, light passes or light groups (its light is no one pass's).
"""
from __future__ import annotations

import math
import threading
from typing import NamedTuple

import numpy as np

from .direct_light import add_light
from .geometry import facing, hit_offset, hit_point, offset_origin
from .jit import jit, jit_inline
from .lights.area import area_lamp_emitted, area_lamp_point
from .lights.codes import AREA, POINT, SUN, VISIBLE_TRANSMISSION, seen_by
from .lights.dispatch import delta_lamp
from .lights.point import point_lamp_radiance, spot_attenuation
from .lights.sun import sample_sun
from .lobes import DIFFUSE_EVENT, REFLECT_EVENT, bsdf_eval
from .manifold import (MAX_CASTERS, SYSTEM_COLUMNS, C, facing_disk, fill_system,
                       geometry_term, normal_derivatives, refraction_weight, relative_ior,
                       solve_blocks, toward_next, transfer_determinant, unit_towards,
                       vertex_row)
from .material_kinds import DIFFUSE, GLASS, LAYERED, PROGRAM, REFRACTION
from .path_limits import DIFFUSE_BOUNCE, GLOSSY_BOUNCE, TRANSMISSION_BOUNCE, add_bounce, \
    clamp_light, clamp_limit, dropped_at, within_limits
from .sampler import mix, sample_pair
from .sampling import orthonormal_basis, sample_uniform_disk
from .receivers import hit_lobes
from .shader.inputs import ray_flags
from .specular import refract
from .textures import surface_colors
from .vec import dot, length, madd, mul, neg, row, store, sub, vmul

CASTER, RECEIVER = 1, 2          # MneeTables.tri_flags bits
# The material kinds of a receiver vertex: diffuse, layered (rough, Principled) and shader
# programs, whose BSDF the stage evaluates.
RECEIVING_KINDS = (DIFFUSE, LAYERED, PROGRAM)
# A path's state (Paths.mnee, LightPaths.mnee): NO_CHAIN, or FROM_RECEIVER + j after a receiver
# (camera side) or a caustics lamp (light side) and j refractions at casters since.
NO_CHAIN, FROM_RECEIVER = 0, 1
# The refractions a chain may hold at the camera ray's own hit on a plain diffuse receiver, towards
# a lamp the light tracer starts paths from: its connections render the paths through more.
CAMERA_HIT_REFRACTIONS = 1
# Chains.state
# REJECTED: the probe found no chain in the seed (a caster that does not refract, more casters
# than the chain may hold or than it probes); FAILED: no caster, or the walk failed.
PROBING, SOLVING, CONVERGED, FAILED, REJECTED = range(5)
MAX_PROBE_HITS = 10              # surfaces the seed segment may cross (Cycles' 10)
MAX_ITERATIONS = 64
# |constraint| (sine of the half vector's angle to the normal) of a solution. Not much below:
# Embree's float32 barycentrics stall the walk on the tumbler's curved walls near 2e-6 (the
# vertices then stop moving and the chain failed, 8 in 10 there); Cycles takes 1e-3.
TOLERANCE = 1e-4
MIN_STEP = 1e-4                  # the Newton step's scale below which the walk fails
MIN_PROGRESS = 1e-7              # metres a vertex must move per accepted step
# The first step's scale from a refracted seed (reseed): Cycles' first step for every walk.
# Measured on the tumbler (16x16, 2 x 512 spp): of 13403 walks seeded again, 3617 converged
# from a full first step, 4373 from this one. A one-vertex chain seeded again walks from the
# same vertex with it.
BENT_FIRST_STEP = 0.1
MNEE_DOMAIN = np.uint64(0x3A11_F0D5)   # keys the stage's random numbers apart


class MneeTables(NamedTuple):
    """Where the stage runs (empty arrays: nowhere)."""
    tri_flags: np.ndarray        # (T,) int64 CASTER | RECEIVER of each triangle's object
    tri_object: np.ndarray       # (T,) int64 each triangle's object
    lamp: np.ndarray             # (areas + points + suns,) bool: the lamps the stage samples
    #                              (lamp_row's order: area lamps, point and spot lamps, suns)
    pick_cdf: np.ndarray         # (M,) the cdf of picking the stage's lamp j
    pick_kind: np.ndarray        # (M,) its codes kind (AREA, POINT, SUN)
    pick_index: np.ndarray       # (M,) its row in that kind's light tables
    pick_traced: np.ndarray      # (M,) bool: the light tracer starts paths from it, and connects
    #                              them to the camera from a receiver the camera ray hits
    pick_delta: np.ndarray       # (M,) bool: a delta lamp (a sun of angle 0, of the stage's)


OFF = MneeTables(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, bool), np.zeros(0),
                 np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, bool),
                 np.zeros(0, bool))


def mnee_lamp(light: dict, tables, kind: int, k: int) -> bool:
    """Whether row k of the light tables of this kind (scene light `light`) is a lamp the stage
    samples: a caustics light that transmission rays see, and a point or spot lamp a disk of
    radius > 0, an area lamp of spread > 0, or a sun (of any angle)."""
    flags = {AREA: tables.area_flags, POINT: tables.point_flags, SUN: tables.sun_flags}[kind]
    if not (light.get("caustics_light", False) and seen_by(int(flags[k]), VISIBLE_TRANSMISSION)):
        return False
    if kind == POINT:
        return bool(tables.point_radius[k] > 0.0 and not tables.point_sphere[k])
    return kind == SUN or bool(tables.area_spread_tan[k] > 0.0)


def mnee_tables(scene, lights, material_kind, of_triangle,
                light_traced=frozenset()) -> tuple[MneeTables, str]:
    """(the stage's tables, OFF where it does not run; why or why not). light_traced: the
    (codes kind, row) of the lamps the light tracer starts paths from and the path tracer
    leaves their caustics to; their light at the camera ray's own hit the stage leaves to the
    light tracer's connection (MneeTables.pick_traced; seed_chains)."""
    objects = scene.objects
    flags = np.array([(CASTER if o.get("caustics_caster") else 0)
                      | (RECEIVER if o.get("caustics_receiver") else 0) for o in objects]
                     + [0], np.int64)
    oid = scene.object_ids.astype(np.int64) if len(scene.object_ids) else np.zeros(0, np.int64)
    tri_flags = flags[np.minimum(oid, len(objects))] if len(objects) else np.zeros(len(oid),
                                                                                  np.int64)
    materials = material_kind[of_triangle]
    receivers = np.any((tri_flags & RECEIVER != 0) & np.isin(materials, RECEIVING_KINDS))
    casters = np.any((tri_flags & CASTER != 0) & np.isin(materials, (GLASS, REFRACTION)))
    lamp, pmf, kinds, index, traced, delta, named = [], [], [], [], [], [], []
    for kind, names, pmfs in ((AREA, ("area",), lights.area_pmf),
                              (POINT, ("point", "spot"), lights.point_pmf),
                              (SUN, ("sun",), lights.sun_pmf)):
        of_kind = [light for light in scene.lights if light["kind"] in names]
        for k, light in enumerate(of_kind):
            lamp.append(mnee_lamp(light, lights, kind, k))
            if lamp[-1]:
                pmf.append(pmfs[k])
                kinds.append(kind)
                index.append(k)
                traced.append((kind, k) in light_traced)
                delta.append(delta_lamp(lights, kind, k))
                named.append(f"{light.get('name', '?')!r}" + (
                    "" if not traced[-1] else
                    " (a sun of angle 0: the light tracer's where the camera sees the receiver)"
                    if delta[-1] else
                    " (the light tracer's through two or more casters where the camera sees a "
                    "diffuse receiver)"))
    if not (receivers and casters and any(lamp)):
        return OFF, ("no shadow-caustics receiver, smooth glass caster and caustics light "
                     "(a point or spot lamp of radius > 0 with soft falloff on, an area lamp "
                     "of spread > 0 or a sun)")
    pmf = np.array(pmf)
    pmf = pmf / pmf.sum() if pmf.sum() > 0 else np.full(len(pmf), 1.0 / len(pmf))
    return (MneeTables(tri_flags, oid, np.array(lamp, bool), np.cumsum(pmf),
                       np.array(kinds, np.int64), np.array(index, np.int64),
                       np.array(traced, bool), np.array(delta, bool)),
            f"shadow caustics: {len(kinds)} caustics light(s): {', '.join(named)}")


@jit_inline
def receiving_kind(kind):
    """Whether a receiver's hit on a material of this kind is a receiver vertex
    (RECEIVING_KINDS)."""
    return kind in RECEIVING_KINDS


@jit_inline
def reflected(w, ng_f, ns_f, pdf):
    """Whether a receiver's direction w (sampled with BSDF density pdf; 0: by a singular lobe)
    is one the stage renders: a non-singular one above both normals (facing the viewer)."""
    return pdf > 0.0 and dot(w, ng_f) > 0.0 and dot(w, ns_f) > 0.0


@jit_inline
def mnee_after(tri_flags, state, tri, kind, ray_kind, from_receiver):
    """A path's state (NO_CHAIN, FROM_RECEIVER + j) after scattering at triangle tri (material
    kind `kind`) into a ray of ray_kind: a receiver starts a chain where its sample is one the
    stage renders (from_receiver: `reflected`), a refraction at a caster extends it (up to
    MAX_CASTERS), anything else ends it."""
    if tri_flags.shape[0] == 0:
        return NO_CHAIN
    flags = tri_flags[tri]
    if receiving_kind(kind) and flags & RECEIVER and from_receiver:
        return FROM_RECEIVER
    if ((kind == GLASS or kind == REFRACTION) and flags & CASTER
            and ray_kind == VISIBLE_TRANSMISSION
            and FROM_RECEIVER <= state < FROM_RECEIVER + MAX_CASTERS):
        return state + 1
    return NO_CHAIN


@jit_inline
def left_to_mnee(lamp_flags, state, lamp):
    """Whether a path in this state leaves the light of lamp `lamp` (lamp_row's; -1: none) to
    the stage."""
    return state > FROM_RECEIVER and lamp >= 0 and lamp_flags.shape[0] > 0 and lamp_flags[lamp]


@jit_inline
def escape_left_to_mnee(lights, lamp_flags, state, k):
    """Whether a path in this state that escaped leaves light k of lights.dispatch's
    lights_at_escape (the world first where it gives light, then the suns) to the stage."""
    sun = k - 1 if lights.has_world else k
    return sun >= 0 and left_to_mnee(lamp_flags, state, lamp_row(lights, SUN, sun))


@jit_inline
def lamp_row(lights, kind, i):
    """Row of MneeTables.lamp of light i of this codes kind (lights.dispatch.lamps_to_cross's
    index for area, point and spot lamps, the suns after them; -1 for other kinds)."""
    n_area, n_point = lights.area_area.shape[0], lights.point_radius.shape[0]
    if kind == AREA:
        return i
    if kind == POINT:
        return n_area + i
    if kind == SUN:
        return n_area + n_point + i
    return -1


# -- the chains --------------------------------------------------------------------------------

class Chains(NamedTuple):
    """Up to n chains: their receiver vertex, lamp sample, refracting vertices and rays."""
    path: np.ndarray         # (n,) the camera path's radiance row
    x0: np.ndarray           # (n, 3) the receiver vertex
    ng0: np.ndarray          # (n, 3) its geometric normal, facing the camera side
    ns0: np.ndarray          # (n, 3) its shading normal, likewise
    eps0: np.ndarray         # (n,) its offset (geometry.hit_offset)
    weight: np.ndarray       # (n, 3) throughput
    tri0: np.ndarray         # (n,) the receiver's triangle; for its colours and the lobes of a
    #                          LAYERED or PROGRAM one (receivers.hit_lobes' inputs):
    uv0: np.ndarray          # (n, 2) its barycentrics
    view0: np.ndarray        # (n, 3) the direction to the viewer
    entering0: np.ndarray    # (n,) 1: the ray met the front face
    ray0: np.ndarray         # (n, 3) the ray's Light Path flags, caustics dropped, bounce
    length0: np.ndarray      # (n,) and its length
    limit: np.ndarray        # (n,) the clamp of its light
    lamp: np.ndarray         # (n,) the lamp's row in its kind's tables
    lamp_kind: np.ndarray    # (n,) its codes kind
    fixed: np.ndarray        # (n,) 1: y is a direction (a sun's), 0: a point
    y: np.ndarray            # (n, 3) the lamp point (or direction)
    centre: np.ndarray       # (n, 3) a point lamp's centre, and y's offset from it on the disk
    offset: np.ndarray       # (n, 3) that faces x0 (facing_disk turns it to face xk)
    y_ab: np.ndarray         # (n, 2, 3) the lamp's unit tangents at y
    pdf: np.ndarray          # (n,) pick x area density of y (solid-angle density for a sun)
    state: np.ndarray        # (n,) PROBING ... FAILED
    bent: np.ndarray         # (n,) 1: the seed refracts at each caster (reseed), 0: straight
    k: np.ndarray            # (n,) refracting vertices
    room_diffuse: np.ndarray # (n,) how many refracting vertices the bounce limits allow after
    room_glossy: np.ndarray  # (n,) the receiver's diffuse and its glossy reflection (chain_room)
    prim: np.ndarray         # (n, MAX_CASTERS) their triangles
    pos: np.ndarray          # (n, MAX_CASTERS, 3)
    n: np.ndarray            # (n, MAX_CASTERS, 3) shading normals
    dn_da: np.ndarray        # (n, MAX_CASTERS, 3) and their derivatives
    dn_db: np.ndarray
    ta: np.ndarray           # (n, MAX_CASTERS, 3) the triangles' unit tangents
    tb: np.ndarray
    ng: np.ndarray           # (n, MAX_CASTERS, 3) geometric normals (outward)
    ior: np.ndarray          # (n, MAX_CASTERS)
    tint: np.ndarray         # (n, MAX_CASTERS, 3) transmission colours
    glass: np.ndarray        # (n, MAX_CASTERS) 1: glass (Fresnel), 0: refraction only
    step: np.ndarray         # (n,) the Newton step's scale
    resolve: np.ndarray      # (n,) 1: solve again before the next step
    delta: np.ndarray        # (n, 2 MAX_CASTERS) the last Newton step
    transfer: np.ndarray     # (n,) |det dx1/dy| at convergence
    ray_o: np.ndarray        # (n, 3) a probing chain's next ray
    ray_d: np.ndarray
    ray_t: np.ndarray        # (n,)
    first_ray: np.ndarray    # (n,) its first ray in the ray buffers
    new_prim: np.ndarray     # (n, MAX_CASTERS) projections' triangles and barycentrics
    new_u: np.ndarray
    new_v: np.ndarray
    o32: np.ndarray          # (n MAX_CASTERS, 3) float32 rays for Embree
    d32: np.ndarray
    tmax: np.ndarray
    owner: np.ndarray        # (n MAX_CASTERS,) the chain of each ray
    scratch: np.ndarray      # (2 MAX_CASTERS, SYSTEM_COLUMNS) the linear system


def new_chains(n: int) -> Chains:
    """Buffers for n chains."""
    v, m = MAX_CASTERS, MAX_CASTERS * n
    f = lambda *shape: np.zeros(shape)                    # noqa: E731
    i = lambda *shape: np.zeros(shape, np.int64)          # noqa: E731
    f32 = lambda *shape: np.zeros(shape, np.float32)      # noqa: E731
    return Chains(
        path=i(n), x0=f(n, 3), ng0=f(n, 3), ns0=f(n, 3), eps0=f(n), weight=f(n, 3), tri0=i(n),
        uv0=f(n, 2), view0=f(n, 3), entering0=i(n), ray0=i(n, 3),
        length0=f(n), limit=f(n), lamp=i(n), lamp_kind=i(n), fixed=i(n), y=f(n, 3),
        centre=f(n, 3), offset=f(n, 3),
        y_ab=f(n, 2, 3), pdf=f(n), state=i(n), bent=i(n), k=i(n), room_diffuse=i(n),
        room_glossy=i(n), prim=i(n, v), pos=f(n, v, 3), n=f(n, v, 3), dn_da=f(n, v, 3),
        dn_db=f(n, v, 3), ta=f(n, v, 3), tb=f(n, v, 3), ng=f(n, v, 3), ior=f(n, v),
        tint=f(n, v, 3), glass=i(n, v), step=f(n), resolve=i(n), delta=f(n, 2 * v), transfer=f(n),
        ray_o=f(n, 3), ray_d=f(n, 3), ray_t=f(n), first_ray=i(n), new_prim=i(n, v),
        new_u=f(n, v), new_v=f(n, v), o32=f32(m, 3), d32=f32(m, 3), tmax=f32(m), owner=i(m),
        scratch=f(2 * v, SYSTEM_COLUMNS))


_local = threading.local()


def chains_for(n: int) -> Chains:
    """This thread's chain buffers, for at least n chains."""
    chains = getattr(_local, "chains", None)
    if chains is None or chains.path.shape[0] < n:
        chains = _local.chains = new_chains(n)
    return chains


@jit_inline
def set_vertex(chains, c, i, mesh, mats, tri, b1, b2):
    """Vertex i of chain c on triangle tri at barycentrics (b1, b2): its point, normals and
    their derivatives, tangents, index and tint."""
    p, ng, ns, _ = hit_point(mesh, tri, b1, b2)
    a, b = orthonormal_basis(ng)
    n, dn_da, dn_db = ns, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    if mesh.corner_normals.shape[0] > 0:
        n, dn_da, dn_db = normal_derivatives(mesh.corners[tri], mesh.corner_normals[tri], b1,
                                             b2, a, b)
    mat = mats.of_triangle[tri]
    _, tint = surface_colors(mats, mat, tri, b1, b2)
    chains.prim[c, i] = tri
    for k in range(3):
        chains.pos[c, i, k] = p[k]
        chains.n[c, i, k] = n[k]
        chains.dn_da[c, i, k] = dn_da[k]
        chains.dn_db[c, i, k] = dn_db[k]
        chains.ta[c, i, k] = a[k]
        chains.tb[c, i, k] = b[k]
        chains.ng[c, i, k] = ng[k]
        chains.tint[c, i, k] = tint[k]
    chains.ior[c, i] = mats.ior[mat]
    chains.glass[c, i] = mats.kind[mat] == GLASS


@jit_inline
def segment_origin(mesh, chains, c, i, toward):
    """Where chain c's ray from vertex i - 1 (the receiver for i = 0) towards `toward` starts:
    the vertex lifted off its surface to the side the ray leaves to."""
    if i == 0:
        return offset_origin(row(chains.x0, c), row(chains.ng0, c), chains.eps0[c],
                             sub(toward, row(chains.x0, c)))
    p = vertex_row(chains.pos[c], i - 1)
    return offset_origin(p, vertex_row(chains.ng[c], i - 1),
                         hit_offset(mesh, chains.prim[c, i - 1], p), sub(toward, p))


@jit_inline
def queue_ray(chains, m, c, origin, target, reach):
    """Ray m of the buffers, chain c's: from origin towards target, reach times as long as
    the distance."""
    w, distance = unit_towards(origin, target)
    queue_along(chains, m, c, origin, w, reach * distance)


@jit_inline
def queue_along(chains, m, c, origin, w, tmax):
    """Ray m of the buffers, chain c's: from origin along the unit direction w up to tmax."""
    for q in range(3):
        chains.o32[m, q] = origin[q]
        chains.d32[m, q] = w[q]
    chains.tmax[m] = tmax
    chains.owner[m] = c


@jit_inline
def pick_lamp(cdf, u):
    """The stage's lamp whose cdf interval holds u."""
    for k in range(cdf.shape[0]):
        if u < cdf[k]:
            return k
    return cdf.shape[0] - 1


@jit
def seed_chains(tables, lights, mesh, mats, depth, bits, strat, limits, clamp, n_active, active,
                paths, prim, u, v, chains):
    """A chain per kept hit (rows `active`) on a receiver (RECEIVING_KINDS): a caustics lamp
    picked, a point y on it (a sun's direction) sampled (sample_lamp; the sampler's pairs,
    stratified if strat), and the seed ray towards it. At the camera ray's own hit (depth 0),
    towards a lamp the light tracer starts paths from (MneeTables.pick_traced), whose
    connection renders that light: no chain to a sun of angle 0, and on a plain diffuse
    receiver a chain of one refraction at most. Returns the count."""
    n = 0
    cdf = tables.pick_cdf
    for j in range(n_active):
        i = active[j]
        tri = prim[i]
        mat = mats.of_triangle[tri]
        surface_kind = mats.kind[mat]
        if not (receiving_kind(surface_kind) and tables.tri_flags[tri] & RECEIVER):
            continue
        # Room for the receiver's reflection and at least one refraction.
        bounce = paths.bounce[i]
        room_diffuse = room_after(bounce, add_bounce(paths.kinds[i], DIFFUSE_BOUNCE), limits)
        room_glossy = 0 if surface_kind == DIFFUSE else \
            room_after(bounce, add_bounce(paths.kinds[i], GLOSSY_BOUNCE), limits)
        if max(room_diffuse, room_glossy) == 0:
            continue
        b1, b2 = np.float64(u[i]), np.float64(v[i])
        p, ng, ns, eps = hit_point(mesh, tri, b1, b2)
        d = row(paths.d, i)
        ng_f, ns_f, entering = facing(d, ng, ns)
        key = mix(paths.key[i], MNEE_DOMAIN)
        # The stage's own pairs (its key apart from the path's), stratified over the pixel's
        # samples as direct light's are: the lamp point is most of a chain's variance.
        u_pick, _ = sample_pair(key, paths.sample[i], 2 * depth, bits, strat)
        u0, u1 = sample_pair(key, paths.sample[i], 2 * depth + 1, bits, strat)
        j = pick_lamp(cdf, u_pick)
        pmf = cdf[j] - (cdf[j - 1] if j > 0 else 0.0)
        kind, lamp = tables.pick_kind[j], tables.pick_index[j]
        if depth == 0 and tables.pick_traced[j]:
            # The light tracer's connection from the camera ray's hit renders a delta sun's
            # light, and a lamp's through two or more casters onto a plain diffuse receiver.
            if tables.pick_delta[j]:
                continue
            if surface_kind == DIFFUSE:
                room_diffuse = min(room_diffuse, CAMERA_HIT_REFRACTIONS)
        y, ta, tb, density = sample_lamp(lights, kind, lamp, p, u0, u1)
        if not density > 0.0:
            continue
        chains.path[n] = paths.path[i]
        store(chains.x0, n, p)
        store(chains.ng0, n, ng_f)
        store(chains.ns0, n, ns_f)
        chains.eps0[n] = eps
        store(chains.weight, n, row(paths.beta, i))
        chains.tri0[n] = tri
        chains.uv0[n, 0], chains.uv0[n, 1] = b1, b2
        store(chains.view0, n, neg(d))
        chains.entering0[n] = entering
        ray_kind = paths.ray_kind[i]
        chains.ray0[n, 0] = ray_flags(ray_kind, paths.pdf_prev[i])
        chains.ray0[n, 1] = dropped_at(limits, ray_kind)
        chains.ray0[n, 2] = bounce
        chains.length0[n] = length(sub(p, row(paths.o, i)))
        chains.limit[n] = clamp_limit(clamp, bounce == 0)
        chains.lamp[n] = lamp
        chains.lamp_kind[n] = kind
        chains.fixed[n] = kind == SUN
        store(chains.y, n, y)
        if kind == POINT:
            c = row(lights.point_pos, lamp)
            store(chains.centre, n, c)
            store(chains.offset, n, sub(y, c))
        store(chains.y_ab[n], 0, ta)
        store(chains.y_ab[n], 1, tb)
        chains.pdf[n] = pmf * density
        chains.room_diffuse[n] = room_diffuse
        chains.room_glossy[n] = room_glossy
        start_probe(chains, n, 0)
        n += 1
    return n


@jit_inline
def sample_lamp(lights, kind, lamp, p, u0, u1):
    """A point y on lamp `lamp` of this codes kind for the receiver vertex p, or a sun's
    direction: (y, the lamp's unit tangents at y, y's density: per area, per solid angle for a
    sun, 1 for a sun of angle 0; 0: no sample)."""
    if kind == SUN:
        w, _, density = sample_sun(lights, lamp, u0, u1)
        ta, tb = orthonormal_basis(w)
        return w, ta, tb, density if density > 0.0 else 1.0
    if kind == AREA:
        y = area_lamp_point(lights, lamp, u0, u1)
        return (y, row(lights.area_ex, lamp), row(lights.area_ey, lamp),
                1.0 / lights.area_area[lamp])
    # A point lamp's disk faces the receiver vertex (the walk turns it: face_last_vertex).
    c = row(lights.point_pos, lamp)
    r = lights.point_radius[lamp]
    toward, _ = unit_towards(c, p)
    ta, tb = orthonormal_basis(toward)
    dx, dy = sample_uniform_disk(u0, u1)
    return madd(madd(c, dx * r, ta), dy * r, tb), ta, tb, 1.0 / (math.pi * r * r)


@jit_inline
def towards_lamp(chains, c, p):
    """(unit direction from p towards chain c's lamp, distance: infinite for a sun's)."""
    if chains.fixed[c]:
        return row(chains.y, c), math.inf
    return unit_towards(p, row(chains.y, c))


@jit_inline
def start_probe(chains, c, bent):
    """Set chain c probing from its receiver vertex towards its lamp point, its seed straight
    (bent 0) or refracted at each caster (bent 1)."""
    chains.state[c] = PROBING
    chains.k[c] = 0
    chains.bent[c] = bent
    x0 = row(chains.x0, c)
    w, _ = towards_lamp(chains, c, x0)
    origin = offset_origin(x0, row(chains.ng0, c), chains.eps0[c], w)
    store(chains.ray_o, c, origin)
    store(chains.ray_d, c, w)
    _, distance = towards_lamp(chains, c, origin)
    chains.ray_t[c] = distance


@jit
def reseed(chains, n):
    """Set each chain whose walk from a straight seed failed, or whose straight seed of two or
    more vertices the probe rejected, probing again with a refracted seed (of one vertex it is
    the straight seed, walked again from a gentle first step); returns how many."""
    m = 0
    for c in range(n):
        if chains.bent[c] == 0 and ((chains.state[c] == FAILED and chains.k[c] > 0)
                                    or (chains.state[c] == REJECTED and chains.k[c] > 1)):
            start_probe(chains, c, 1)
            m += 1
    return m


@jit_inline
def room_after(bounce, kinds, limits):
    """How many refractions at casters (up to MAX_CASTERS) the bounce limits allow a path
    after a receiver vertex at bounce `bounce`, kinds its packed counts with the receiver's
    reflection (joined as photon merging's gather joins a photon:
    photon_merging.joined_within_limits)."""
    room = 0
    while (room < MAX_CASTERS and bounce + 2 + room <= limits[0]
           and within_limits(add_times(kinds, TRANSMISSION_BOUNCE, room), limits)):
        room += 1
    return room


@jit_inline
def chain_room(chains, c):
    """How many refracting vertices the bounce limits allow chain c: the most after either
    kind of reflection at its receiver."""
    return max(chains.room_diffuse[c], chains.room_glossy[c])


@jit_inline
def add_times(kinds, kind, times):
    """Packed counts with `times` more bounces of this kind."""
    for _ in range(times):
        kinds = add_bounce(kinds, kind)
    return kinds


@jit
def probe_rays(chains, n):
    """Queue the next seed-segment ray of each probing chain; returns the count."""
    m = 0
    for c in range(n):
        if chains.state[c] != PROBING:
            continue
        for k in range(3):
            chains.o32[m, k] = chains.ray_o[c, k]
            chains.d32[m, k] = chains.ray_d[c, k]
        chains.tmax[m] = chains.ray_t[c]
        chains.owner[m] = c
        m += 1
    return m


@jit
def probe_hits(tables, mesh, mats, chains, m, prim, u, v, t):
    """Record the caster triangles the seed rays met (a non-refracting caster, or more than
    the chain may hold, fails the chain; other objects are passed) and move each ray past its
    hit (refracted at a caster where the seed is bent); a ray that meets nothing more ends
    the probe."""
    for j in range(m):
        c = chains.owner[j]
        tri = prim[j]
        if tri < 0:
            end_probe(chains, c)
            continue
        b1, b2 = np.float64(u[j]), np.float64(v[j])
        d = row(chains.ray_d, c)
        if tables.tri_flags[tri] & CASTER:
            kind = mats.kind[mats.of_triangle[tri]]
            if not (kind == GLASS or kind == REFRACTION) or chains.k[c] >= chain_room(chains, c):
                chains.state[c] = REJECTED
                continue
            i = chains.k[c]
            set_vertex(chains, c, i, mesh, mats, tri, b1, b2)
            chains.k[c] += 1
            if chains.bent[c]:
                d = seed_direction(d, vertex_row(chains.n[c], i), vertex_row(chains.ng[c], i),
                                   chains.ior[c, i])
                store(chains.ray_d, c, d)
        p, ng, _, eps = hit_point(mesh, tri, b1, b2)
        origin = offset_origin(p, ng, eps, d)
        store(chains.ray_o, c, origin)
        to_lamp, distance = towards_lamp(chains, c, origin)
        chains.ray_t[c] = distance
        if dot(to_lamp, d) <= 0.0:
            end_probe(chains, c)


@jit_inline
def end_probe(chains, c):
    """Chain c's seed is complete: it walks if it holds a vertex, from a full step for a
    straight seed, a gentle one for a refracted seed (further from its solution, as Cycles
    starts every walk: its linearisation holds only near the seed)."""
    chains.state[c] = SOLVING if chains.k[c] > 0 else FAILED
    chains.step[c] = BENT_FIRST_STEP if chains.bent[c] else 1.0
    chains.resolve[c] = 1


@jit_inline
def seed_direction(d, n, ng, ior):
    """The seed chain's direction on from a caster vertex its ray d met (shading normal n,
    geometric normal ng, index ior): d refracted by Snell's law, or d itself where the light
    would be totally reflected."""
    wi = neg(d)
    n_wi = n if dot(wi, ng) > 0.0 else neg(n)
    cos_i = dot(wi, n_wi)
    eta = relative_ior(wi, ng, ior)
    g = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta)
    if cos_i <= 0.0 or g <= 0.0:
        return d
    return refract(d, n_wi, eta, cos_i, math.sqrt(g))


@jit
def newton_rays(mesh, chains, n):
    """For each solving chain: solve its linear system where its vertices moved (converged
    chains keep their transfer determinant and stop), then queue the projections of its
    vertices moved by the step onto their objects: rays from the vertex before each (as it
    is) through the moved point. Returns the rays queued."""
    m = 0
    system = chains.scratch
    for c in range(n):
        if chains.state[c] != SOLVING:
            continue
        k = chains.k[c]
        if chains.resolve[c]:
            y_motion = face_last_vertex(chains, c, k)
            worst = fill_system(system, k, row(chains.x0, c), row(chains.y, c), (
                row(chains.y_ab[c], 0), row(chains.y_ab[c], 1)), chains.fixed[c] != 0,
                chains.pos[c], chains.n[c], chains.dn_da[c], chains.dn_db[c], chains.ta[c],
                chains.tb[c], chains.ng[c], chains.ior[c], y_motion)
            if solve_blocks(system, k) == 0.0:
                chains.state[c] = FAILED
                continue
            if worst < TOLERANCE:
                chains.state[c] = CONVERGED
                chains.transfer[c] = transfer_determinant(system)
                continue
            for r in range(2 * k):
                chains.delta[c, r] = system[r, C]
        chains.first_ray[c] = m
        x0 = row(chains.x0, c)
        for i in range(k):
            p = vertex_row(chains.pos[c], i)
            step = chains.step[c]
            move = madd(mul(vertex_row(chains.ta[c], i), chains.delta[c, 2 * i]),
                        chains.delta[c, 2 * i + 1], vertex_row(chains.tb[c], i))
            moved = madd(p, -step, move)
            # A first step that would pass below the receiver goes the other way (Cycles).
            if i == 0 and dot(row(chains.ng0, c), sub(moved, x0)) <= 0.0:
                moved = madd(p, step, move)
            queue_ray(chains, m, c, segment_origin(mesh, chains, c, i, moved), moved, 2.0)
            m += 1
    return m


@jit_inline
def face_last_vertex(chains, c, k):
    """Turn a point lamp's disk to face chain c's last vertex xk, as the path tracer's ray from
    xk sees it (lights/point.py), moving y with it (facing_disk); returns how y moves along
    xk's tangents (zero for the other lamps, whose points stay)."""
    zero = (0.0, 0.0, 0.0)
    if chains.lamp_kind[c] != POINT:
        return zero, zero
    centre = row(chains.centre, c)
    facing_x0, _ = unit_towards(centre, row(chains.x0, c))
    y, normal, along_a, along_b = facing_disk(
        centre, row(chains.offset, c), facing_x0, vertex_row(chains.pos[c], k - 1),
        vertex_row(chains.ta[c], k - 1), vertex_row(chains.tb[c], k - 1))
    store(chains.y, c, y)
    ta, tb = orthonormal_basis(normal)
    store(chains.y_ab[c], 0, ta)
    store(chains.y_ab[c], 1, tb)
    return along_a, along_b


@jit
def newton_accept(tables, mesh, mats, chains, n, prim, u, v):
    """Take each stepping chain's projected vertices if every projection found its own object
    and every vertex still refracts (its neighbours on opposite sides of its shading normal),
    doubling the step up to 1; else halve the step (a chain whose step falls below MIN_STEP,
    or whose vertices stop moving, fails)."""
    for c in range(n):
        if chains.state[c] != SOLVING:
            continue
        k = chains.k[c]
        j0 = chains.first_ray[c]
        ok = True
        for i in range(k):
            tri = prim[j0 + i]
            if tri < 0 or tables.tri_object[tri] != tables.tri_object[chains.prim[c, i]]:
                ok = False
                break
            chains.new_prim[c, i] = tri
            chains.new_u[c, i] = np.float64(u[j0 + i])
            chains.new_v[c, i] = np.float64(v[j0 + i])
        if ok:
            ok = still_refracts(mesh, chains, c, k)
        if not ok:
            chains.step[c] *= 0.5
            chains.resolve[c] = 0
            if chains.step[c] < MIN_STEP:
                chains.state[c] = FAILED
            continue
        moved = 0.0
        for i in range(k):
            before = vertex_row(chains.pos[c], i)
            set_vertex(chains, c, i, mesh, mats, chains.new_prim[c, i], chains.new_u[c, i],
                       chains.new_v[c, i])
            shift = sub(vertex_row(chains.pos[c], i), before)
            moved = max(moved, length(shift))
        if moved < MIN_PROGRESS:
            chains.state[c] = FAILED     # stuck (at a mesh's edge): no nearer solution
            continue
        chains.step[c] = min(1.0, 2.0 * chains.step[c])
        chains.resolve[c] = 1


@jit_inline
def still_refracts(mesh, chains, c, k):
    """Whether each projected vertex of chain c has its neighbours on opposite sides of its
    shading normal."""
    for i in range(k):
        tri = chains.new_prim[c, i]
        p, _, n, _ = hit_point(mesh, tri, chains.new_u[c, i], chains.new_v[c, i])
        prev = row(chains.x0, c)
        if i > 0:
            prev, _, _, _ = hit_point(mesh, chains.new_prim[c, i - 1], chains.new_u[c, i - 1],
                                      chains.new_v[c, i - 1])
        wo, _ = towards_lamp(chains, c, p)
        if i < k - 1:
            nxt, _, _, _ = hit_point(mesh, chains.new_prim[c, i + 1], chains.new_u[c, i + 1],
                                     chains.new_v[c, i + 1])
            wo = sub(nxt, p)
        if dot(n, sub(prev, p)) * dot(n, wo) >= 0.0:
            return False
    return True


@jit
def visibility_rays(mesh, chains, n):
    """For each converged chain, the rays along its segments x0 x1 .. x(k-1) xk (each must
    meet the next vertex first; owner and first_ray say whose); returns the count."""
    m = 0
    for c in range(n):
        if chains.state[c] != CONVERGED:
            continue
        chains.first_ray[c] = m
        for i in range(chains.k[c]):
            p = vertex_row(chains.pos[c], i)
            queue_ray(chains, m, c, segment_origin(mesh, chains, c, i, p), p, 1.5)
            m += 1
    return m


@jit
def check_segments(tables, mesh, chains, n, prim, t):
    """Fail each converged chain one of whose segment rays met something before its vertex,
    or met its vertex's object elsewhere."""
    for c in range(n):
        if chains.state[c] != CONVERGED:
            continue
        j0 = chains.first_ray[c]
        for i in range(chains.k[c]):
            tri = prim[j0 + i]
            p = vertex_row(chains.pos[c], i)
            _, distance = unit_towards(segment_origin(mesh, chains, c, i, p), p)
            if (tri < 0 or tables.tri_object[tri] != tables.tri_object[chains.prim[c, i]]
                    or abs(np.float64(t[j0 + i]) - distance) > 1e-4 * (1.0 + distance)):
                chains.state[c] = FAILED
                break


@jit
def light_rays(mesh, chains, n):
    """For each converged chain, the shadow ray from its last vertex to its lamp point (rows
    in the ray buffers, owner says whose); returns the count."""
    m = 0
    for c in range(n):
        if chains.state[c] != CONVERGED:
            continue
        k = chains.k[c]
        p = vertex_row(chains.pos[c], k - 1)
        tri = chains.prim[c, k - 1]
        w, _ = towards_lamp(chains, c, p)
        origin = offset_origin(p, vertex_row(chains.ng[c], k - 1), hit_offset(mesh, tri, p), w)
        w, distance = towards_lamp(chains, c, origin)
        queue_along(chains, m, c, origin, w, distance)
        m += 1
    return m


@jit
def deliver(lights, mats, tables, has_normals, fresnel_model, chains, m, blocked, radiance,
            without, scratch):
    """Add each unblocked converged chain's light (the module docstring's estimate) to its
    path's radiance (and to `without` where it has rows: light vertices do not compete).
    tables: the albedo tables, scratch: (lobes, program registers, Principled parameters), for
    the lobes of layered and program receivers (receivers.hit_lobes)."""
    for j in range(m):
        if blocked[j] == 0:
            continue
        c = chains.owner[j]
        response = receiver_response(mats, tables, has_normals, chains, c, scratch)
        if not (response[0] > 0.0 or response[1] > 0.0 or response[2] > 0.0):
            continue
        light = chain_light(lights, fresnel_model, chains, c, response)
        if not (light[0] > 0.0 or light[1] > 0.0 or light[2] > 0.0):
            continue
        light = clamp_light(light, chains.limit[c])
        add_light(radiance, chains.path[c], light)
        if without.shape[0] > 0:
            add_light(without, chains.path[c], light)


@jit_inline
def receiver_response(mats, tables, has_normals, chains, c, scratch):
    """Chain c's throughput at its receiver times the receiver's f |cos| towards the chain's
    first vertex (a DIFFUSE receiver's albedo / pi; a layered or program receiver's lobes of
    each kind whose bounce limits leave room for the chain's refractions), 0 where the
    direction is not one `reflected` takes (as the path tracer's samples the stage stands
    for)."""
    x0 = row(chains.x0, c)
    w0, _ = unit_towards(x0, vertex_row(chains.pos[c], 0))
    ng0, ns0 = row(chains.ng0, c), row(chains.ns0, c)
    if not reflected(w0, ng0, ns0, 1.0):
        return (0.0, 0.0, 0.0)
    tri = chains.tri0[c]
    mat = mats.of_triangle[tri]
    kind = mats.kind[mat]
    b1, b2 = chains.uv0[c, 0], chains.uv0[c, 1]
    colors = surface_colors(mats, mat, tri, b1, b2)
    if kind == DIFFUSE:
        return mul(vmul(row(chains.weight, c), colors[0]), dot(w0, ns0) / math.pi)
    k = chains.k[c]
    events = (1 << DIFFUSE_EVENT if k <= chains.room_diffuse[c] else 0) \
        | (1 << REFLECT_EVENT if k <= chains.room_glossy[c] else 0)
    view = row(chains.view0, c)
    count = hit_lobes(mats, tables, has_normals, kind, (mat, tri, b1, b2), colors,
                      (x0, ng0, ns0, chains.entering0[c] != 0), view,
                      (chains.ray0[c, 0], chains.ray0[c, 1], chains.ray0[c, 2],
                       chains.length0[c]), scratch)
    f, _ = bsdf_eval(scratch[0], count, view, w0, events)
    return vmul(row(chains.weight, c), f)


@jit_inline
def chain_light(lights, fresnel_model, chains, c, response):
    """The light chain c carries to its receiver's path (before the clamp), `response` the
    receiver's (receiver_response)."""
    k = chains.k[c]
    x0 = row(chains.x0, c)
    x1 = vertex_row(chains.pos[c], 0)
    light = response
    for i in range(k):
        p = vertex_row(chains.pos[c], i)
        prev = x0 if i == 0 else vertex_row(chains.pos[c], i - 1)
        wi, _ = unit_towards(p, prev)
        if i == k - 1:
            wo, _ = towards_lamp(chains, c, p)
        else:
            wo, _ = unit_towards(p, vertex_row(chains.pos[c], i + 1))
        light = vmul(light, refraction_weight(fresnel_model, wi, wo, vertex_row(chains.n[c], i),
                                              vertex_row(chains.ng[c], i), chains.ior[c, i],
                                              vertex_row(chains.tint[c], i),
                                              chains.glass[c, i] != 0))
    last, _ = towards_lamp(chains, c, vertex_row(chains.pos[c], k - 1))
    emitted = lamp_radiance(lights, chains, c, last)
    g = geometry_term(x0, x1, vertex_row(chains.ng[c], 0), chains.transfer[c])
    return mul(vmul(light, emitted), g / chains.pdf[c])


@jit_inline
def lamp_radiance(lights, chains, c, wo):
    """The radiance chain c's lamp sends its last vertex, wo the direction from that vertex to
    the lamp (a sun of angle 0: its irradiance, sample_lamp's density being 1)."""
    lamp, kind = chains.lamp[c], chains.lamp_kind[c]
    if kind == SUN:
        if lights.sun_one_minus_cos[lamp] == 0.0:
            return row(lights.sun_irradiance, lamp)
        return row(lights.sun_radiance, lamp)
    if kind == AREA:
        return area_lamp_emitted(lights, lamp, neg(wo))
    return mul(point_lamp_radiance(lights, lamp), spot_attenuation(lights, lamp, neg(wo)))


def probe(geometry, tables: MneeTables, mats, chains: Chains, n: int) -> None:
    """Collect the probing chains' seed vertices (probe_hits), ray by ray."""
    for _ in range(MAX_PROBE_HITS):
        m = probe_rays(chains, n)
        if m == 0:
            break
        hit, hu, hv, ht = geometry.intersect(chains.o32[:m], chains.d32[:m], chains.tmax[:m])
        probe_hits(tables, geometry.mesh, mats, chains, m, hit, hu, hv, ht)
    chains.state[:n][chains.state[:n] == PROBING] = REJECTED   # more surfaces than probed


def walk(geometry, tables: MneeTables, mats, chains: Chains, n: int) -> None:
    """Walk the solving chains onto the manifold (newton_rays, newton_accept); those still
    walking after MAX_ITERATIONS fail."""
    for _ in range(MAX_ITERATIONS):
        m = newton_rays(geometry.mesh, chains, n)
        if m == 0:
            break
        hit, hu, hv, _ = geometry.intersect(chains.o32[:m], chains.d32[:m], chains.tmax[:m])
        newton_accept(tables, geometry.mesh, mats, chains, n, hit, hu, hv)
    chains.state[:n][chains.state[:n] == SOLVING] = FAILED


def solve(geometry, tables: MneeTables, mats, chains: Chains, n: int) -> None:
    """Walk each of the n seeded chains onto the manifold from its straight seed, and each
    whose walk failed again from a refracted seed (reseed): CONVERGED, FAILED or REJECTED."""
    probe(geometry, tables, mats, chains, n)
    walk(geometry, tables, mats, chains, n)
    if reseed(chains, n):
        probe(geometry, tables, mats, chains, n)
        walk(geometry, tables, mats, chains, n)


def stage(geometry, tables: MneeTables, lights, mats, albedo_tables, fresnel_model: int,
          depth: int, bits: int, strat: bool, limits, clamp, n_active: int, active, paths, prim,
          u, v, radiance, without, scratch) -> int:
    """Manifold next-event estimation at the kept hits (rows `active` of paths, hits prim, u,
    v) of one bounce, its light added to `radiance` (and `without`); bits and strat the
    sampler's (seed_chains), albedo_tables and scratch as deliver's tables and scratch. Returns
    the chains that delivered light."""
    chains = chains_for(n_active)
    mesh = geometry.mesh
    n = seed_chains(tables, lights, mesh, mats, depth, bits, strat, limits, clamp, n_active,
                    active, paths, prim, u, v, chains)
    if n == 0:
        return 0
    solve(geometry, tables, mats, chains, n)
    m = visibility_rays(mesh, chains, n)
    if m == 0:
        return 0
    hit, _, _, ht = geometry.intersect(chains.o32[:m], chains.d32[:m], chains.tmax[:m])
    check_segments(tables, mesh, chains, n, hit, ht)
    m = light_rays(mesh, chains, n)
    if m == 0:
        return 0
    blocked = geometry.occluded(chains.o32[:m], chains.d32[:m], chains.tmax[:m])
    deliver(lights, mats, albedo_tables, mesh.corner_normals.shape[0] > 0, fresnel_model,
            chains, m, blocked, radiance, without, scratch)
    return int(np.count_nonzero(blocked[:m]))
