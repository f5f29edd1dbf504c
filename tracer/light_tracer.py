"""Caustics by light tracing: paths from the lamps through mirrors and glass to the first
diffuse surface, connected to the camera.

Snell renders with a hybrid of the path tracer and a light tracer that split path space between
them (LuxCoreRender's hybrid back/forward): the light tracer owns every path "lamp, one or more
specular vertices, one diffuse vertex, camera" (L S+ D E) and the path tracer skips exactly those
(wavefront.emitters, the `caustic` state of a path). A diffuse vertex is one on a surface light
paths end on (Materials.receives: a plain diffuse surface, or a Principled or node-tree one with
a Lambert lobe) where the camera path sampled a Lambert lobe; the light tracer's connection
there carries the Lambert lobes' share of the BSDF (receivers.py). Both count a path of k
bounces alike, so the hybrid renders the path tracer's image, with far less noise where glass
and mirrors focus light.

A light path starts on an emitter whose light camera paths find through mirrors and glass by
BSDF sampling (emissive triangles, and lamps with Cycles' MIS option: area lamps with a spread,
point and spot lamps with a radius, sun discs), or on a delta lamp (a point or spot lamp of
radius 0, a sun of angle 0), whose light through mirrors and glass no camera path can find: the
light tracer is the only technique that renders it, and the path tracer's light samples of it
at diffuse vertices (direct light, L D) stay the path tracer's. The light tracer owns every path
from a delta lamp whose first vertex is specular: such a path goes on past its first diffuse
vertex (receiver_bounce) and connects to the camera at each diffuse vertex (L S+ D (S|D)* D E),
since the path tracer renders none of them. On a Principled or node-tree surface it carries
the whole BSDF there, but for its singular lobes and its transmission, which it does not
follow (their light is lost), and a program's Light Path inputs are a camera ray's. It is
aimed at the specular objects: from a lamp, its direction is drawn in the cone that bounds one
of them, seen from the light point (a mixture over objects; the density of a direction sums
every cone that holds it);
from a sun or the world, the direction is the sun's or drawn from the world's distribution, and
the line crosses a disk across one of them (aimed_line). The world starts light paths where its
light is concentrated (an HDRI with a sun: lights.dispatch.WORLD_PEAK), and the path tracer then
leaves it the world-lit L S+ D E paths too (wavefront.emitters' world_caustics). Specular
bounces use the path tracer's own sample_specular, a refraction's weight times the adjoint's
(n_i / n_t)^2 (specular.light_refraction_scale: Cycles carries radiance across it unscaled;
the factors cancel through closed glass, not through an open pane). At the first diffuse
vertex (light_bounce's receiving_vertex; specular_vertex scatters) the path connects to a lens
point: the camera ray through that lens point that sees the
vertex gives the pixel, a shadow ray checks it, and the contribution is

    beta f (|ns . wi| / |ng . wi|) |ng . wo| s / (d^2 cos^3 theta)

(beta the light path's weight, f = albedo / pi on a plain diffuse surface, f |ns . wi| the
lobes' receivers.surface_response on others, wi towards the light, wo towards the lens, the
shading-normal factor of Veach's thesis section 5.3 that makes the adjoint agree with the path
tracer, s raster pixels per unit of image-plane area, d and theta the distance from the lens point
and the ray's angle to the optical axis). The image's pixel j gets the sum over light paths of
their contributions times the density pixel j's camera samples have where the path lands (1 in
the pixel itself for a 1-pixel box; pixel_filter.spread), divided by the number of light paths.
"""
from __future__ import annotations

import copy
import math
from typing import NamedTuple

import numpy as np

from . import specular
from .camera import camera_connection
from .geometry import facing, hit_point, offset_origin
from .jit import jit, jit_inline
from .light_groups import light_group
from .lights.codes import (AREA, EMISSIVE_TRIANGLE, POINT, SUN, VISIBLE_DIFFUSE, VISIBLE_GLOSSY,
                           VISIBLE_TRANSMISSION, WORLD, ZERO)
from .lights.dispatch import (delta_lamp, emission_anchor, emit_along, light_seen,
                              starts_light_paths)
from .lights.sun import sun_emission
from .lights.world import world_emission
from .material_kinds import DIFFUSE, GLASS, MIRROR, REFRACTION
from .path_limits import (DIFFUSE_BOUNCE, GLOSSY_BOUNCE, NO_BOUNCES, TRANSMISSION_BOUNCE,
                          add_bounce, drops, kind_count, within_limits)
from . import media as medium
from .photon_merging import record_photon
from .media import empty_stacks
from .mnee import (CAMERA_HIT_REFRACTIONS, FROM_RECEIVER, NO_CHAIN, RECEIVER, lamp_row,
                   mnee_after)
from .sampler import mix, random_pair
from .sampling import (orthonormal_basis, sample_cosine_hemisphere, sample_uniform_cone,
                       sample_uniform_disk, sample_uniform_sphere)
from .receivers import surface_response
from .textures import surface_colors
from .vec import add, dot, madd, mul, neg, row, store, sub, vmul

LIGHT_DOMAIN = np.uint64(0x11C7_A0C5)   # keys light paths' random numbers apart from camera paths'
# A camera path's place in the split of path space with the light tracer (wavefront.Paths.caustic):
# NO_CAUSTIC, or FIRST_DIFFUSE (the camera's first hit was diffuse, or sampled a Lambert lobe of a
# surface that receives light paths: receivers.py) then CAUSTIC (and every vertex since
# specular): the light tracer's paths, whose emitters the path tracer then skips.
# With photon merging (photon_merging.py): SPECULAR_CAMERA (every vertex so far specular), then
# SDS_DIFFUSE (one diffuse vertex), then SDS_CAUSTIC (every vertex since specular): the merged
# paths, whose emitters the path tracer then skips too (caustic_after, left_to_light_paths).
NO_CAUSTIC, FIRST_DIFFUSE, CAUSTIC, SPECULAR_CAMERA, SDS_DIFFUSE, SDS_CAUSTIC = range(6)
# What the path tracer leaves to light paths (wavefront.emitters' `caustics`): nothing, the light
# tracer's paths, or those and the merged ones.
SPLIT_NONE, SPLIT_LIGHT, SPLIT_MERGE = range(3)


class Caustics(NamedTuple):
    """What the light tracer emits from and aims at (pure: the test mode below)."""
    emitter_kind: np.ndarray     # (E,) lights.AREA, POINT, SUN or EMISSIVE_TRIANGLE
    emitter_index: np.ndarray    # (E,) its row in its kind's tables
    emitter_pmf: np.ndarray      # (E,)
    emitter_cdf: np.ndarray      # (E,)
    emitter_delta: np.ndarray    # (E,) bool: a delta lamp (no ray finds it; see light_bounce)
    aim_center: np.ndarray       # (K, 3) bounding spheres of the specular objects
    aim_radius: np.ndarray       # (K,)
    scene_center: np.ndarray     # (3,) a sphere around all geometry (sun paths start outside)
    scene_radius: float
    # Pure light tracing, for tests of the camera connection: emission in every direction and a
    # connection at every diffuse vertex, diffuse bounces included (the light tracer's image is
    # then the whole image but for emitters seen directly or through specular vertices only).
    pure: bool


class LightPaths(NamedTuple):
    """The state of up to n light paths."""
    key: np.ndarray          # (n,) uint64: the path's random-number key
    o32: np.ndarray          # (n, 3) float32 ray origin
    d32: np.ndarray          # (n, 3) float32 unit direction (the light's travel direction)
    tmax: np.ndarray         # (n,) float32
    beta: np.ndarray         # (n, 3) radiance x measure / density carried
    bounces: np.ndarray      # (n,) int64 vertices so far (all specular unless pure or delta)
    lamp: np.ndarray         # (n,) int64 the emitter's row in Caustics (for its flags)
    medium: np.ndarray       # (n, media.MAX_MEDIA) int64 the media the ray is inside (media.py)
    kinds: np.ndarray        # (n,) int64 its diffuse, glossy and transmission scatterings
    #                          after the first vertex, packed (path_limits.py; see light_bounce)
    dropped: np.ndarray      # (n,) int64 1 when its last scattering is of a kind of caustics
    #                          switched off (path_limits): a diffuse vertex next ends it
    mnee: np.ndarray         # (n,) int64 from a lamp manifold next-event estimation samples:
    #                          mnee.FROM_RECEIVER + its refractions at casters so far, else
    #                          NO_CHAIN (mnee.py: at a receiver after them the path is MNEE's)


def new_light_paths(n: int) -> LightPaths:
    """Uninitialised buffers for n light paths."""
    return LightPaths(np.empty(n, np.uint64), np.empty((n, 3), np.float32),
                      np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty((n, 3)),
                      np.empty(n, np.int64), np.empty(n, np.int64), empty_stacks(n),
                      np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64))


def caustics_tables(scene, lights, geometry, materials, pure=False) -> Caustics | None:
    """The light tracer's tables for a scene (its materials.Materials), or None when it has
    nothing to do (no mirror or glass, no surface light paths end on, or no emitter that camera
    paths could reach through them)."""
    specular = np.isin(materials.kind, (MIRROR, GLASS, REFRACTION))
    tri_specular = specular[scene.material_ids] if len(scene.material_ids) else np.zeros(0, bool)
    if pure:                       # aim at the whole scene (used by suns and the world only)
        tri_specular = np.ones(len(scene.material_ids), bool)
        scene = copy.copy(scene)
        scene.object_ids = np.zeros(len(scene.material_ids), np.int32)
    if not tri_specular.any():
        return None
    if not np.any(materials.receives[scene.material_ids]):
        return None                # no surface for light paths to end on (receivers.py)
    centers, radii = [], []
    for obj in np.unique(scene.object_ids[tri_specular]):
        corners = geometry.corners[tri_specular & (scene.object_ids == obj)].reshape(-1, 3)
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        center = 0.5 * (lo + hi)
        centers.append(center)
        # A little wider than the corners: float32 geometry and the offsets of hit points.
        radii.append(np.linalg.norm(corners - center, axis=1).max() * (1 + 1e-6) + 1e-6)
    centers, radii = np.array(centers), np.array(radii)
    t = lights.tables
    kinds, indices, power, delta = [], [], [], []
    for k in np.flatnonzero(t.pmf > 0):
        kind, i = int(t.kind[k]), int(t.index[k])
        if starts_light_paths(t, kind, i, centers, radii, pure):
            kinds.append(kind)
            indices.append(i)
            power.append(t.pmf[k])
            delta.append(delta_lamp(t, kind, i))
    if not kinds:
        return None
    pmf = np.array(power) / np.sum(power)
    extent = geometry.corners.reshape(-1, 3)
    lo, hi = extent.min(axis=0), extent.max(axis=0)
    return Caustics(np.array(kinds, np.int64), np.array(indices, np.int64), pmf, np.cumsum(pmf),
                    np.array(delta, bool), np.ascontiguousarray(centers), radii, 0.5 * (lo + hi),
                    float(0.5 * np.linalg.norm(hi - lo)) + 1.0, bool(pure))


def emitter_names(scene, caustics: Caustics) -> list[str]:
    """The emitters light paths start on, in words: each lamp by name and kind (delta lamps
    named so), the emissive triangles' count, the world."""
    by_kind = {AREA: ("area",), POINT: ("point", "spot"), SUN: ("sun",)}
    names, triangles = [], 0
    for e, (kind, i) in enumerate(zip(caustics.emitter_kind, caustics.emitter_index)):
        if kind == EMISSIVE_TRIANGLE:
            triangles += 1
        elif kind in by_kind:
            light = [x for x in scene.lights if x["kind"] in by_kind[kind]][i]
            delta = ", delta" if caustics.emitter_delta[e] else ""
            names.append(f"{light.get('name', '?')!r} ({light['kind']}{delta})")
        else:
            names.append("the world")
    if triangles:
        names.insert(0, f"{triangles} emissive triangle{'s' if triangles != 1 else ''}")
    return names


def receiver_names(scene, materials) -> list[str]:
    """The surfaces other than plain diffuse ones that light paths end on (receivers.py), in
    words: each material by name and kind, as `snell info` lists them."""
    words = {"principled": "Principled", "program": "node tree"}
    used = np.unique(materials.of_triangle)
    return [f"{scene.materials[m].get('name', '?')!r} ({words[scene.materials[m]['kind']]})"
            for m in used if materials.receives[m] and scene.materials[m]["kind"] in words]


@jit_inline
def caustic_after(state, scattered, kind, depth):
    """A camera path's state (see NO_CAUSTIC above) after its vertex at wavefront depth `depth`
    on a surface of this kind, given `scattered`, the light tracer's state scatter.py made:
    photon merging's states follow specular and diffuse vertices from the camera."""
    if kind == MIRROR or kind == GLASS or kind == REFRACTION:
        if (depth == 0 and state == NO_CAUSTIC) or state == SPECULAR_CAMERA:
            return SPECULAR_CAMERA
        if state == SDS_DIFFUSE or state == SDS_CAUSTIC:
            return SDS_CAUSTIC
    elif kind == DIFFUSE and state == SPECULAR_CAMERA:
        return SDS_DIFFUSE
    return scattered


@jit_inline
def left_to_light_paths(split, state):
    """Whether the path tracer leaves the light a camera path in this state finds to light
    paths (split: SPLIT_NONE, SPLIT_LIGHT or SPLIT_MERGE)."""
    return ((split != SPLIT_NONE and state == CAUSTIC)
            or (split == SPLIT_MERGE and state == SDS_CAUSTIC))


# -- aiming -------------------------------------------------------------------------------------

@jit_inline
def aim_cone(caustics, k, y, margin):
    """The cone from y that holds sphere k widened by margin: (axis, 1 - cos of its half-angle;
    2 for the whole sphere of directions when y is inside)."""
    to = sub(row(caustics.aim_center, k), y)
    d2 = dot(to, to)
    r = caustics.aim_radius[k] + margin
    if d2 <= r * r:
        return (0.0, 0.0, 1.0), 2.0
    sin2 = r * r / d2
    return mul(to, 1.0 / math.sqrt(d2)), sin2 / (1.0 + math.sqrt(1.0 - sin2))


@jit_inline
def aimed_direction(caustics, y, margin, u_pick, u0, u1):
    """A direction from y towards the specular objects: a cone picked in proportion to its solid
    angle, then uniform in it. Returns (direction, density: the sum over every cone holding it
    of 1 / the sum of the cones' solid angles)."""
    total = 0.0
    for k in range(caustics.aim_radius.shape[0]):
        total += aim_cone(caustics, k, y, margin)[1]
    target = u_pick * total
    chosen = 0
    for k in range(caustics.aim_radius.shape[0]):
        omc = aim_cone(caustics, k, y, margin)[1]
        if target < omc or k == caustics.aim_radius.shape[0] - 1:
            chosen = k
            break
        target -= omc
    axis, omc = aim_cone(caustics, chosen, y, margin)
    w, _ = sample_uniform_cone(axis, omc, u0, u1)
    return w, aimed_density(caustics, y, margin, w, total)


@jit_inline
def aimed_line(caustics, w, u_pick, u_point):
    """A line of direction w through the specular objects, for light from infinitely far (suns,
    the world): a sphere picked in proportion to its area pi r^2, a point uniform on the disk
    across w through it, moved back along w to outside the scene's bounding sphere (pbrt-v4's
    infinite lights' SampleLe, with a disk per specular object instead of one across the scene).
    Returns (origin, density of the line per unit area across w: the sum over every disk it
    crosses of 1 / the disks' total area)."""
    total = 0.0
    for k in range(caustics.aim_radius.shape[0]):
        total += caustics.aim_radius[k] ** 2
    target = u_pick * total
    chosen = caustics.aim_radius.shape[0] - 1
    for k in range(caustics.aim_radius.shape[0]):
        if target < caustics.aim_radius[k] ** 2:
            chosen = k
            break
        target -= caustics.aim_radius[k] ** 2
    x, y2 = sample_uniform_disk(u_point[0], u_point[1])
    t_axis, s_axis = orthonormal_basis(w)
    r = caustics.aim_radius[chosen]
    q = add(row(caustics.aim_center, chosen), add(mul(t_axis, x * r), mul(s_axis, y2 * r)))
    area_density = 0.0
    for k in range(caustics.aim_radius.shape[0]):
        off = sub(q, row(caustics.aim_center, k))
        along = dot(off, w)
        miss2 = dot(off, off) - along * along
        if miss2 <= caustics.aim_radius[k] ** 2:
            area_density += 1.0 / (math.pi * total)
    far = dot(sub(q, caustics.scene_center), w) + caustics.scene_radius
    return madd(q, -far, w), area_density


@jit_inline
def emission_direction(caustics, y, margin, u_pick, u0, u1):
    """aimed_direction, or uniform over the sphere of directions for pure light tracing."""
    if caustics.pure:
        return sample_uniform_sphere(u0, u1), 1.0 / (4.0 * math.pi)
    return aimed_direction(caustics, y, margin, u_pick, u0, u1)


@jit_inline
def aimed_density(caustics, y, margin, w, total):
    """The density of aimed_direction at direction w (total: the sum of 1 - cos over cones)."""
    holding = 0
    for k in range(caustics.aim_radius.shape[0]):
        axis, omc = aim_cone(caustics, k, y, margin)
        if dot(axis, w) >= 1.0 - omc or omc >= 2.0:
            holding += 1
    return holding / (2.0 * math.pi * total)


# -- emission -----------------------------------------------------------------------------------

@jit_inline
def emit(caustics, lights, mesh, u_pick, u_point, u_dir, emitter):
    """A light path leaving emitter `emitter` of the caustics tables: (origin, direction,
    weight = emitted radiance x measure / density, excluding the emitter's pick). The direction
    is aimed at the specular objects from the light's anchor (lights.dispatch.emission_anchor);
    a point lamp's line is then drawn across it, where the path tracer's own test of the lamp
    is made at the line's first specular vertex (light_bounce). A sun's or the world's
    direction is its own (sun_emission, world_emission) and its line is aimed_line's: the
    weight is radiance / (direction density x area density across the direction), E / area
    density for a sun of angle 0. That is pbrt-v4's Le |cos| / (pdfDir pdfPos) of an infinite
    light's SampleLe with the disk perpendicular to the direction (|cos| = 1): the density in
    area x solid angle measure that the hybrid's split needs, since the path tracer's camera
    path finds the same light with weight 1 (after a specular vertex no light sample
    competes)."""
    kind, i = caustics.emitter_kind[emitter], caustics.emitter_index[emitter]
    if kind == SUN or kind == WORLD:
        if kind == SUN:
            w, radiance, dir_density = sun_emission(lights, i, u_dir[0], u_dir[1])
        else:
            w, radiance, dir_density = world_emission(lights, u_dir[0], u_dir[1])
        origin, area_density = aimed_line(caustics, w, u_pick, u_point)
        if not dir_density > 0.0:           # a map's pole: never drawn
            return origin, w, ZERO
        return origin, w, mul(radiance, 1.0 / (dir_density * area_density))
    y, margin = emission_anchor(lights, kind, i, u_point[0], u_point[1])
    if kind == AREA and lights.area_spread_tan[i] == 0.0:
        # A collimated (spread 0) area lamp emits along its normal only, radiance L pi delta(w -
        # n) (irradiance pi L at normal incidence): the direction is drawn with probability one
        # (density 1 stands for the delta) and the path carries pi L A, the lamp's power.
        w, density = row(lights.area_emit, i), 1.0
    else:
        w, density = emission_direction(caustics, y, margin, u_pick, u_dir[0], u_dir[1])
    # One call for both (emit_along is inlined: each call site is compiled anew).
    origin, weight = emit_along(lights, mesh, kind, i, y, w, density, u_point[0], u_point[1])
    return origin, w, weight


# -- the stages ---------------------------------------------------------------------------------

@jit_inline
def set_light_path(paths, j, key, origin, direction, beta, bounces, lamp):
    """Light path j leaves origin along direction with weight beta."""
    paths.key[j] = key
    for k in range(3):
        paths.o32[j, k] = origin[k]
        paths.d32[j, k] = direction[k]
    paths.tmax[j] = 1e30
    store(paths.beta, j, beta)
    paths.bounces[j] = bounces
    paths.lamp[j] = lamp
    paths.kinds[j] = NO_BOUNCES
    paths.dropped[j] = 0
    paths.mnee[j] = NO_CHAIN


@jit_inline
def count_scattering(paths, i, out, j, kind, limits):
    """Give light path j of `out`, scattered from path i of `paths` by an event of this kind
    (path_limits), i's counts and this event's, unless at i's first vertex: in the camera
    path's order that vertex's event is the last, towards the light, which no limit stops.
    Returns whether the counts are within the limits."""
    kinds = paths.kinds[i]
    out.kinds[j] = add_bounce(kinds, kind) if paths.bounces[i] > 0 else kinds
    return within_limits(out.kinds[j], limits)


@jit
def light_path_key(base, index):
    """Light path `index`'s key in a pass keyed by `base`: the index's low 32 bits, and its high
    bits where it has any (a pass of 2^32 light paths and more, a batch of a big render), so
    that paths 2^32 apart do not share their random numbers."""
    key = mix(base, np.uint64(index))
    high = np.uint64(index) >> np.uint64(32)
    if high != np.uint64(0):
        key = mix(key, high)
    return key


@jit
def emit_light_paths(caustics, lights, mesh, media, seed, pass_index, start, n, paths,
                     mnee_lamps):
    """Light paths start .. start + n of a pass leave their emitters (zero weight: left out),
    inside the media around them (media.py) in a scene with media; those from the lamps
    manifold next-event estimation samples (mnee_lamps, mnee.lamp_row's index; empty: none)
    start a chain (LightPaths.mnee)."""
    # Chained hashes: a single mix of seed ^ pass would give (seed 0, pass 1) the keys of
    # (seed 1, pass 0).
    base = mix(mix(mix(np.uint64(0), np.uint64(seed)), LIGHT_DOMAIN), np.uint64(pass_index))
    kept = 0
    for j in range(n):
        key = light_path_key(base, start + j)
        u_pick, u_aim = random_pair(key, 0, 0)
        u_point = random_pair(key, 0, 1)
        u_dir = random_pair(key, 0, 2)
        cdf = caustics.emitter_cdf
        e = min(np.searchsorted(cdf, u_pick * cdf[-1], side="right"), cdf.shape[0] - 1)
        origin, w, beta = emit(caustics, lights, mesh, u_aim, u_point, u_dir, e)
        beta = mul(beta, 1.0 / caustics.emitter_pmf[e])
        if not (beta[0] > 0.0 or beta[1] > 0.0 or beta[2] > 0.0):
            continue
        set_light_path(paths, kept, key, origin, w, beta, 0, e)
        if mnee_lamps.shape[0] > 0:
            lamp = lamp_row(lights, caustics.emitter_kind[e], caustics.emitter_index[e])
            if lamp >= 0 and mnee_lamps[lamp]:
                paths.mnee[kept] = FROM_RECEIVER
        if media.on:
            start_stack(caustics, lights, media, e, paths.medium, kept)
        kept += 1
    return kept


@jit
def start_stack(caustics, lights, media, e, stacks, j):
    """Light path j's stack where emitter e of the caustics tables starts it: its lamp's, its
    emissive triangle's object's, none for suns and the world (outside everything)."""
    kind, i = caustics.emitter_kind[e], caustics.emitter_index[e]
    for k in range(medium.MAX_MEDIA):
        stacks[j, k] = medium.NONE
    if kind == AREA:
        medium.copy_stack(media.area_start, i, stacks, j)
    elif kind == POINT:
        medium.copy_stack(media.point_start, i, stacks, j)
    elif kind == EMISSIVE_TRIANGLE:
        medium.copy_stack(media.object_start, media.object_of[lights.tri_prim[i]], stacks, j)


@jit
def lamp_sees(caustics, lights, e, w, s1, kind):
    """Whether the path tracer's ray from the first specular vertex s1 back along the light path
    (a ray of kind `kind`) would find emitter e of the caustics tables (dispatch.light_seen)."""
    # Not inlined: light_bounce asks at two places, once per light path, so one compiled copy
    # costs nothing measurable where two inlined copies cost their compile twice.
    return light_seen(lights, caustics.emitter_kind[e], caustics.emitter_index[e], s1, w, kind)


@jit
def light_bounce(caustics, lights, mesh, mats, media, cam, margin, fresnel_model, limits, m,
                 paths, prim, u, v, out, connections, raster, photons, tables, scratch,
                 mnee_flags):
    """Scatter light paths at specular hits (into `out`); at the first vertex on a surface
    light paths end on (Materials.receives: diffuse, Principled and node-tree surfaces with a
    Lambert lobe; receivers.py) after one or more specular ones, queue the connection to the
    camera (its nearest image pixel, and in `raster` its raster point for the pixel filter;
    margin: how far past the image the filter reaches). In a scene with media, the light is
    attenuated along its segments and the connection in the media they cross, and the stack of
    media goes with each path (media.py). limits (path_limits.bounce_limits) bound the camera
    path each connection makes: its bounces, and each kind's count of scatterings but the last
    (the first vertex's, towards the light), so that the light tracer owns exactly the paths
    the path tracer would have ended. When `photons` has rows (photon merging), a path's first
    plain diffuse vertex after one or more specular ones is also stored there as a photon
    (photon_merging.py). limits[5]: the caustics switched off: a path whose specular scattering
    into a receiving vertex is of such a kind ends there, as the camera path's lobe there is
    dropped. tables: the albedo tables, scratch: (lobes, program registers,
    Principled parameters) for the hits' lobes (receivers.surface_response).
    A path that reaches a shadow-caustics receiver (mnee_flags, the triangles' mnee.py flags;
    empty: none) after refractions at casters only, from a lamp manifold next-event
    estimation samples, is that stage's: neither stored nor continued, and connected to the
    camera only from a delta sun, or through two or more casters onto a plain diffuse receiver
    (mnee.py: the stage leaves it those of the camera ray's own hits).
    Returns (paths in out, connections queued, photons stored)."""
    n_out, n_conn, n_photons = 0, 0, 0
    for i in range(m):
        tri = prim[i]
        if tri < 0:
            continue
        mat = mats.of_triangle[tri]
        kind = mats.kind[mat]
        specular_kind = kind == MIRROR or kind == GLASS or kind == REFRACTION
        if not (specular_kind or mats.receives[mat]):
            continue      # emitters, rough glossy and glass: the path tracer's
        d = (np.float64(paths.d32[i, 0]), np.float64(paths.d32[i, 1]), np.float64(paths.d32[i, 2]))
        b1, b2 = np.float64(u[i]), np.float64(v[i])
        p, ng, ns, eps = hit_point(mesh, tri, b1, b2)
        sigma = medium.ZERO
        if media.on:
            sigma = medium.sigma_of(media, paths.medium, i)
            origin = (np.float64(paths.o32[i, 0]), np.float64(paths.o32[i, 1]),
                      np.float64(paths.o32[i, 2]))
            segment = sub(p, origin)
            store(paths.beta, i, medium.through(row(paths.beta, i), sigma,
                                                math.sqrt(dot(segment, segment))))
        color, trans_color = surface_colors(mats, mat, tri, b1, b2)
        surface = (mat, tri, b1, b2)
        if specular_kind:
            n_out = specular_vertex(caustics, lights, mats, media, fresnel_model, limits, paths,
                                    i, out, n_out, (p, ng, ns, eps), d, kind, surface,
                                    (color, trans_color), mesh.corner_normals.shape[0] > 0,
                                    mnee_flags)
        else:
            n_out, n_conn, n_photons = receiving_vertex(
                caustics, lights, mesh, mats, media, cam, margin, limits, paths, i, out,
                connections, raster, photons, (n_out, n_conn, n_photons), (p, ng, ns, eps), d,
                kind, surface, (color, trans_color), sigma, tables, scratch, mnee_flags)
    return n_out, n_conn, n_photons


@jit_inline
def receiving_vertex(caustics, lights, mesh, mats, media, cam, margin, limits, paths, i, out,
                     connections, raster, photons, counts, vertex, d, kind, surface, colors,
                     sigma, tables, scratch, mnee_flags):
    """Light path i at a vertex on a surface light paths end on (vertex: point, geometric and
    shading normals, offset; d the light's direction): a photon stored (photon merging, plain
    diffuse surfaces), a delta lamp's path continued, the connection to the camera queued.
    counts: (paths in out, connections, photons) before; returns them after."""
    n_out, n_conn, n_photons = counts
    if paths.dropped[i] != 0:
        return counts             # the camera path's diffuse ray here drops that lobe there
    # Manifold next-event estimation's path, but for its connection to the camera from a delta
    # sun, or through two or more casters onto a plain diffuse receiver (mnee.seed_chains
    # leaves the camera ray's own hit that light).
    mnee_path = paths.mnee[i] > FROM_RECEIVER and mnee_flags[surface[1]] & RECEIVER != 0
    if mnee_path and not (caustics.emitter_delta[paths.lamp[i]]
                          or (kind == DIFFUSE
                              and paths.mnee[i] > FROM_RECEIVER + CAMERA_HIT_REFRACTIONS)):
        return counts
    max_depth = limits[0]
    bounces = paths.bounces[i]
    key = paths.key[i]
    p, ng = vertex[0], vertex[1]
    beta = row(paths.beta, i)
    # A photon: every vertex so far specular, and room for one more after this one.
    if (kind == DIFFUSE and photons.bounces.shape[0] > 0 and bounces > 0 and not caustics.pure
            and not mnee_path and kind_count(paths.kinds[i], DIFFUSE_BOUNCE) == 0
            and bounces + 2 <= max_depth):
        n_photons = record_photon(photons, n_photons, p, ng, d, beta, bounces, paths.kinds, i)
    # This vertex is bounce `bounces + 1` of the camera path that ends here.
    if (bounces == 0 and not caustics.pure) or bounces + 1 > max_depth:
        return n_out, n_conn, n_photons      # no specular vertex: the path tracer's; too long
    if bounces == 0 and not lamp_sees(caustics, lights, paths.lamp[i], d, p, VISIBLE_DIFFUSE):
        return n_out, n_conn, n_photons
    # The camera path's diffuse reflection here comes before its last unless this is the
    # first vertex.
    if bounces > 0 and kind_count(paths.kinds[i], DIFFUSE_BOUNCE) + 1 > limits[2]:
        return n_out, n_conn, n_photons
    lens0, lens1 = random_pair(key, 1 + bounces, 3)
    # A delta lamp's path goes on from here: no camera path renders light that left a delta
    # lamp towards a specular vertex, diffusely reflected or not (the path tracer reaches a
    # delta lamp only by light samples at diffuse and layered vertices), so the light tracer
    # renders every such path, connecting at each vertex that receives light paths, with the
    # whole BSDF there (receivers.py).
    whole = caustics.pure or caustics.emitter_delta[paths.lamp[i]]
    surf = (mats, tables, mesh.corner_normals.shape[0] > 0, kind, surface, colors, whole,
            scratch)
    if whole and not mnee_path and bounces + 2 <= max_depth:
        kept = receiver_bounce(paths, i, out, n_out, vertex, d, surf,
                               random_pair(key, 1 + bounces, 4))
        if kept > n_out and count_scattering(paths, i, out, n_out, DIFFUSE_BOUNCE, limits):
            if media.on:
                medium.copy_stack(paths.medium, i, out.medium, n_out)
            n_out = kept
    queued = connect_to_camera(cam, margin, (lens0, lens1), connections, raster, n_conn,
                               vertex, d, beta, sigma, surf)
    if queued > n_conn:       # its light's group, for the light group passes
        e = paths.lamp[i]
        connections.group[n_conn] = light_group(lights, caustics.emitter_kind[e],
                                                caustics.emitter_index[e])
    return n_out, queued, n_photons


@jit_inline
def specular_vertex(caustics, lights, mats, media, fresnel_model, limits, paths, i, out, n_out,
                    vertex, d, kind, surface, colors, has_normals, mnee_flags):
    """Light path i at a smooth mirror or glass vertex: its specular scattering into row n_out
    of `out`; returns the new count."""
    bounces = paths.bounces[i]
    if bounces + 1 >= limits[0]:
        return n_out              # a further diffuse vertex would exceed the depth
    p, ng, ns, eps = vertex
    mat, tri = surface[0], surface[1]
    ng_f, ns_f, entering = facing(d, ng, ns)
    key = paths.key[i]
    u_choice, _ = random_pair(key, 1 + bounces, 5)
    new_d, weight, event, valid, _ = specular.sample_at_hit(
        kind, d, ng_f, ns_f, entering, has_normals, colors[0], colors[1], mats.ior[mat],
        fresnel_model, u_choice)
    if not valid or event == specular.TIR_ABSORBED:
        return n_out
    if event == specular.TRANSMITTED:
        # The adjoint of the path tracer's refraction (an open pane's single refraction was
        # under- or over-counted by ior^2 without it).
        weight = mul(weight, specular.light_refraction_scale(mats.ior[mat], entering))
    if bounces == 0:
        ray_kind = VISIBLE_TRANSMISSION if event == specular.TRANSMITTED else VISIBLE_GLOSSY
        if not lamp_sees(caustics, lights, paths.lamp[i], d, p, ray_kind):
            return n_out
    beta = vmul(row(paths.beta, i), weight)
    if not (beta[0] > 0.0 or beta[1] > 0.0 or beta[2] > 0.0):
        return n_out
    set_light_path(out, n_out, key, offset_origin(p, ng, eps, new_d), new_d, beta, bounces + 1,
                   paths.lamp[i])
    if paths.mnee[i] != NO_CHAIN:
        out.mnee[n_out] = mnee_after(mnee_flags, paths.mnee[i], tri, kind,
                                     VISIBLE_TRANSMISSION if event == specular.TRANSMITTED
                                     else VISIBLE_GLOSSY, False)
    if not count_scattering(paths, i, out, n_out,
                            TRANSMISSION_BOUNCE if event == specular.TRANSMITTED
                            else GLOSSY_BOUNCE, limits):
        return n_out              # past a limit: no connection from here on would count
    out.dropped[n_out] = drops(limits[5], event == specular.TRANSMITTED)
    if media.on:
        medium.carry(media, paths.medium, i, out.medium, n_out, tri, mat, entering,
                     event == specular.TRANSMITTED)
    return n_out + 1


@jit_inline
def connect_to_camera(cam, margin, lens, connections, raster, n_conn, vertex, d, beta, sigma,
                      surf):
    """Queue the connection of a light vertex (point, geometric and shading normals, offset;
    light arriving along d with throughput beta) on a receiving surface (surf: see
    receiver_bounce) to a point on the lens (lens: its random pair) as connection n_conn, with
    its pixel and raster point (margin: how far past the image the pixel filter reaches),
    attenuated in the medium sigma; returns the new count (the same when the point is off the
    image or the geometry rules it out)."""
    p, ng, ns, eps = vertex
    pixel, rx, ry, o_cam, d_cam, lens_dist, cos_theta, s = camera_connection(
        cam, p, lens[0], lens[1], margin)
    if pixel < 0:
        return n_conn
    wo = neg(d_cam)                        # towards the lens
    wi = neg(d)                            # towards where the light came from
    # Normals facing the camera, as the camera path that sees p has them.
    face = 1.0 if dot(wo, ng) > 0.0 else -1.0
    ngc, nsc = mul(ng, face), mul(ns, face)
    cos_gi, cos_si, cos_go = dot(wi, ngc), dot(wi, nsc), dot(wo, ngc)
    if not (cos_gi > 0.0 and cos_go > 0.0):
        return n_conn             # a BSDF sample from p could not have produced wi
    origin = offset_origin(p, ngc, eps, wo)
    segment = sub(o_cam, origin)
    length = math.sqrt(dot(segment, segment))
    mats, tables, has_normals, kind, surface, colors, whole, scratch = surf
    if kind == DIFFUSE:
        if not cos_si > 0.0:
            return n_conn
        light = vmul(beta, colors[0])
        f = (cos_si / cos_gi) * cos_go * s / (math.pi * lens_dist * lens_dist * cos_theta ** 3)
    else:
        # The camera path that sees p: a camera ray from o_cam, meeting p's face towards it.
        light = vmul(beta, surface_response(mats, tables, has_normals, kind, surface, colors,
                                            (p, ngc, nsc, face > 0.0, length), wo, wi, whole,
                                            scratch))
        f = cos_go * s / (cos_gi * lens_dist * lens_dist * cos_theta ** 3)
        if not (light[0] > 0.0 or light[1] > 0.0 or light[2] > 0.0):
            return n_conn
    for k in range(3):
        connections.contrib[n_conn, k] = light[k] * f
    if medium.absorbs(sigma):
        tr = medium.transmittance(sigma, length)
        for k in range(3):
            connections.contrib[n_conn, k] *= tr[k]
    connections.path[n_conn] = pixel
    raster[n_conn, 0] = rx
    raster[n_conn, 1] = ry
    for k in range(3):
        connections.o32[n_conn, k] = origin[k]
        connections.d32[n_conn, k] = segment[k] / length
    connections.tmax[n_conn] = length
    return n_conn + 1


@jit_inline
def receiver_bounce(paths, i, out, n_out, vertex, d, surf, u):
    """Pure light tracing, or a delta lamp's path: continue light path i from its vertex on a
    receiving surface (vertex: point, geometric and shading normals, offset; d the light's
    direction) in a cosine-weighted direction, with the adjoint's shading-normal factor; surf:
    (materials, albedo tables, whether the mesh has normals, kind, surface, colours, whole,
    lobe scratch) for receivers.surface_response. Returns the new count in `out`."""
    p, ng, ns, eps = vertex
    wi = neg(d)                                   # towards where the light came from
    side = 1.0 if dot(wi, ng) > 0.0 else -1.0
    ng_f, ns_f = mul(ng, side), mul(ns, side)
    cos_si, cos_gi = dot(wi, ns_f), dot(wi, ng_f)
    mats, tables, has_normals, kind, surface, colors, whole, scratch = surf
    if kind == DIFFUSE and not cos_si > 0.0:
        return n_out
    # Around the geometric normal: the camera path that meets this vertex from wo counts it for
    # every wo above the geometric surface, also below the shading normal's horizon.
    wo, pdf = sample_cosine_hemisphere(ng_f, u[0], u[1])
    if not pdf > 0.0:
        return n_out
    if kind == DIFFUSE:
        # f |ng . wo| (|ns . wi| / |ng . wi|) / pdf with f = albedo / pi and pdf = |ng . wo| / pi.
        scale = cos_si / cos_gi
        albedo = colors[0]
        beta = (paths.beta[i, 0] * albedo[0] * scale, paths.beta[i, 1] * albedo[1] * scale,
                paths.beta[i, 2] * albedo[2] * scale)
    else:
        # The same with the surface's f |ns . wi| seen from wo (the camera path's next vertex
        # is where wo goes; its Light Path inputs are taken as a camera ray's).
        response = surface_response(mats, tables, has_normals, kind, surface, colors,
                                    (p, ng_f, ns_f, side > 0.0, 0.0), wo, wi, True, scratch)
        beta = vmul(row(paths.beta, i), mul(response, math.pi / cos_gi))
        if not (beta[0] > 0.0 or beta[1] > 0.0 or beta[2] > 0.0):
            return n_out
    set_light_path(out, n_out, paths.key[i], offset_origin(p, ng_f, eps, wo), wo, beta,
                   paths.bounces[i] + 1, paths.lamp[i])
    return n_out + 1
