"""Caustics seen through glass: photon merging for the paths lamp, one or more specular vertices,
a diffuse vertex, one or more specular vertices, camera (L S+ D S+ E).

Neither the path tracer nor the light tracer samples these paths well (the pool floor's caustic
seen through the water's surface, a caustic inside a tumbler seen through its wall): a camera
path reaches the diffuse vertex through glass and must then find a small lamp through glass by
BSDF sampling, and a light path that reaches the diffuse vertex through glass can connect to
the camera only through glass, which no shadow ray passes. Photon merging joins the two halves
at the diffuse vertex (progressive photon mapping, in the probabilistic form of Knaus and
Zwicker 2011, "Progressive photon mapping: a probabilistic approach", ACM TOG 30(3), and the
merging of Georgiev et al. 2012, "Light transport simulation with vertex connection and
merging"):

- photons are the light tracer's own paths (light_tracer.light_bounce) stored at their first
  diffuse vertex after one or more specular ones, with their weight beta (flux: radiance x
  measure / density), the direction they arrived from and their bounce counts;
- camera walks leave the camera through the pixel filter's and the lens's samples as the path
  tracer's camera paths do, follow mirrors and glass with the path tracer's own sample_specular,
  and at their first diffuse vertex, reached through one or more specular ones, gather every
  photon within radius r of it:

      L(x, wo) ~ sum_p f(x) beta_p (|ns . wi_p| / |ng . wi_p|) / (pi r^2 N)

  f = albedo / pi (Lambert), wi_p towards where photon p came from, N the light paths traced,
  the shading-normal factor the light tracer's (Veach's thesis section 5.3).

Pass i merges with radius r_i, r_i^2 = r_1^2 prod_{k=1}^{i-1} (k + alpha) / (k + 1) (Knaus and
Zwicker's radius reduction, alpha = 2/3: the exponent that balances the bias, O(r^2), against the
variance, O(1 / (N r^2)), so that the error of the average of the passes' estimates falls as
i^(-1/3), its mean square error as i^(-2/3)). Each pass's estimate is added to the light
tracer's film weighted by its light paths, so the light image, light sum / light paths, is the
average of the passes' estimates: consistent, the bias vanishing as the passes accumulate.

The split stays exact: the path tracer skips light found by a camera path in the SDS_CAUSTIC
state (light_tracer.caustic_after: every vertex specular, then one diffuse vertex, then every
vertex specular), the emitters the light tracer starts on, as it does for the light tracer's
own L S+ D E paths, and the merge counts the same paths within the same bounce limits (the
camera walk's counts, the diffuse vertex's and the photon's). A merged estimate is biased and
its pixels are correlated (one photon lights every pixel whose gather finds it), so merging is
off by default and `snell compare` validates the unbiased image. Light from a delta lamp (a
point lamp of radius 0, a sun of angle 0) along these paths is rendered by merging alone: no
camera path finds such a lamp, so without merging it is missing, as the light tracer's own
L S+ D E paths from delta lamps are without the light tracer. With adaptive sampling the
light tracer's two halves merge apart (Renderer.merge_pass), so that its error estimate sees the
merged noise.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import specular
from .camera import camera_ray
from .geometry import facing, hit_point, offset_origin
from .jit import jit, jit_inline
from .material_kinds import DIFFUSE, GLASS, MIRROR, REFRACTION
from .path_limits import (DIFFUSE_BOUNCE, GLOSSY_BOUNCE, NO_BOUNCES, TRANSMISSION_BOUNCE,
                          add_bounce, within_limits)
from .pixel_filter import position as filter_position
from .sampler import mix, random_pair
from .textures import surface_colors
from .vec import dot, neg, row, store

MERGE_DOMAIN = np.uint64(0x5D5_3E26)   # keys camera walks' random numbers apart from others'
ALPHA = 2.0 / 3.0                      # Knaus and Zwicker's alpha (the radius schedule)
# The automatic first radius: this many pixel footprints at the specular objects' far side (on
# the pool at 16x16, 1 gave a relative RMSE of 0.50 / 0.27 / 0.14 after 4 / 16 / 64 passes, 2
# gave 0.53 / 0.32 / 0.20, 0.5 gave 0.53 / 0.27 / 0.13: docs/measurements.md).
RADIUS_PIXELS = 1.0
# A pass (each of adaptive sampling's halves) keeps the photons of at most this many light paths
# (its first chunks'; a batch of a big render traces far more), about 0.4 GB of photons, and
# traces at most this many camera walks.
MAX_PHOTON_PATHS = 1 << 22
MAX_WALKS = 1 << 22


class Photons(NamedTuple):
    """Photons: light paths at their first diffuse vertex after one or more specular ones."""
    p: np.ndarray            # (n, 3) the vertex
    wi: np.ndarray           # (n, 3) unit direction towards where the light came from
    ng: np.ndarray           # (n, 3) the surface's geometric normal there
    beta: np.ndarray         # (n, 3) the light path's weight arriving (not yet reflected)
    bounces: np.ndarray      # (n,) int64 its specular vertices
    kinds: np.ndarray        # (n,) int64 its glossy and transmission scatterings but the
    #                          first, packed (light_tracer.LightPaths.kinds)


def new_photons(n: int) -> Photons:
    """Buffers for n photons (0: no photons are recorded)."""
    return Photons(np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)),
                   np.empty(n, np.int64), np.empty(n, np.int64))


def concatenate(parts: list[Photons]) -> Photons:
    """The photons of several chunks, in order."""
    if not parts:
        return new_photons(0)
    return Photons(*(np.ascontiguousarray(np.concatenate(field)) for field in zip(*parts)))


@jit_inline
def record_photon(photons, n, p, ng, d, beta, bounces, kinds, i):
    """Store a photon as row n (light arriving along d, weight beta, `bounces` specular vertices,
    row i of `kinds` its counts); returns the new count (the same if the buffer is full)."""
    if n >= photons.bounces.shape[0]:
        return n
    store(photons.p, n, p)
    store(photons.wi, n, neg(d))
    store(photons.ng, n, ng)
    store(photons.beta, n, beta)
    photons.bounces[n] = bounces
    photons.kinds[n] = kinds[i]
    return n + 1


def radius(r1: float, i: int, alpha: float = ALPHA) -> float:
    """Pass i's (from 1) merging radius: r_i^2 = r_1^2 prod_{k=1}^{i-1} (k + alpha) / (k + 1)
    (Knaus and Zwicker 2011's radius reduction), as a ratio of gamma functions."""
    if i < 1:
        raise ValueError(f"radius: pass {i}: passes count from 1")
    log_ratio = (math.lgamma(i + alpha) - math.lgamma(1.0 + alpha)
                 - math.lgamma(i + 1.0) + math.lgamma(2.0))
    return r1 * math.exp(0.5 * log_ratio)


def first_radius(camera, centers: np.ndarray, radii: np.ndarray) -> float:
    """The automatic first radius: RADIUS_PIXELS pixel footprints at the far side of the
    specular objects' bounding spheres (the caustic lies on or behind them)."""
    far = max(float(np.linalg.norm(c - camera.position)) + r for c, r in zip(centers, radii))
    footprint = far * 2.0 * camera.half_x / camera.width
    return RADIUS_PIXELS * footprint


# -- the grid -----------------------------------------------------------------------------------

class PhotonGrid(NamedTuple):
    """Photons sorted into a hash grid of cells of side 2 r."""
    photons: Photons
    start: np.ndarray        # (T + 1,) int64 the first photon of each hash bucket
    cell: float              # the cells' side
    radius: float
    mask: np.uint64          # T - 1 (T a power of two)


@jit_inline
def bucket(ix, iy, iz, mask):
    """The hash bucket of cell (ix, iy, iz) (Teschner et al. 2003's primes)."""
    h = (np.uint64(ix & 0xFFFFFFFF) * np.uint64(73856093)) \
        ^ (np.uint64(iy & 0xFFFFFFFF) * np.uint64(19349663)) \
        ^ (np.uint64(iz & 0xFFFFFFFF) * np.uint64(83492791))
    return np.int64(h & mask)


@jit
def _buckets(p, cell, mask, out):
    """Each photon's bucket."""
    for j in range(p.shape[0]):
        out[j] = bucket(np.int64(math.floor(p[j, 0] / cell)), np.int64(math.floor(p[j, 1] / cell)),
                        np.int64(math.floor(p[j, 2] / cell)), mask)


def build_grid(photons: Photons, r: float) -> PhotonGrid:
    """The photons in a hash grid for gathers of radius r."""
    n = photons.bounces.shape[0]
    size = 1 << max(4, int(2 * max(n, 1) - 1).bit_length())
    mask = np.uint64(size - 1)
    cell = 2.0 * r
    keys = np.empty(n, np.int64)
    _buckets(photons.p, cell, mask, keys)
    order = np.argsort(keys, kind="stable")
    sorted_photons = Photons(*(np.ascontiguousarray(field[order]) for field in photons))
    start = np.zeros(size + 1, np.int64)
    start[1:] = np.cumsum(np.bincount(keys, minlength=size))
    return PhotonGrid(sorted_photons, start, cell, float(r), mask)


@jit_inline
def cell_of(grid, x):
    """The grid cell holding point x."""
    return (np.int64(math.floor(x[0] / grid.cell)), np.int64(math.floor(x[1] / grid.cell)),
            np.int64(math.floor(x[2] / grid.cell)))


@jit_inline
def gather(grid, x, ng_f, ns_f, camera_bounces, camera_kinds, limits):
    """The sum over photons within grid.radius of x of beta (|ns . wi| / |ng . wi|), for a camera
    vertex x on a diffuse surface (normals facing the camera side) reached through
    camera_bounces specular vertices (camera_kinds their counts), counting only the photons
    whose joined path a camera path could take within the bounce limits (path_limits.py):
    every scattering but the last (the photon's first, towards the light) counted, the diffuse
    one at x included, and as many bounces in all as max depth allows."""
    r = grid.radius
    r2 = r * r
    total = (0.0, 0.0, 0.0)
    ph = grid.photons
    # Cells of side 2 r: the ball around x meets at most two along each axis.
    lo = cell_of(grid, (x[0] - r, x[1] - r, x[2] - r))
    hi = cell_of(grid, (x[0] + r, x[1] + r, x[2] + r))
    for ix in range(lo[0], hi[0] + 1):
        for iy in range(lo[1], hi[1] + 1):
            for iz in range(lo[2], hi[2] + 1):
                b = bucket(ix, iy, iz, grid.mask)
                for j in range(grid.start[b], grid.start[b + 1]):
                    q = row(ph.p, j)
                    off = (q[0] - x[0], q[1] - x[1], q[2] - x[2])
                    if dot(off, off) > r2:
                        continue
                    # Cells that share a bucket: count each photon from its own cell only.
                    c = cell_of(grid, q)
                    if c[0] != ix or c[1] != iy or c[2] != iz:
                        continue
                    wi = row(ph.wi, j)
                    cos_g, cos_s = dot(wi, ng_f), dot(wi, ns_f)
                    # The path tracer's diffuse sample at x: around the shading normal, nothing
                    # below the geometric surface.
                    if not (cos_g > 0.0 and cos_s > 0.0):
                        continue
                    # Only photons on a surface facing the same way, within 60 degrees (not the
                    # far side of a thin wall nor a crease's other face; the test's bias goes
                    # with r on a smooth surface).
                    ng_p = row(ph.ng, j)
                    lit_side = 1.0 if dot(ng_p, wi) > 0.0 else -1.0
                    if lit_side * dot(ng_p, ng_f) < 0.5:
                        continue
                    if not joined_within_limits(camera_bounces, camera_kinds, ph.bounces[j],
                                                ph.kinds, j, limits):
                        continue
                    s = cos_s / cos_g
                    total = (total[0] + ph.beta[j, 0] * s, total[1] + ph.beta[j, 1] * s,
                             total[2] + ph.beta[j, 2] * s)
    return total


@jit_inline
def joined_within_limits(camera_bounces, camera_kinds, light_bounces, light_kinds, j, limits):
    """Whether the path a camera walk (camera_bounces specular vertices, camera_kinds their
    counts) and photon j (light_bounces vertices, row j of light_kinds the counts of all but its
    first) make through one diffuse vertex is one the path tracer counts: camera_bounces + 1 +
    light_bounces bounces at most max depth, and each kind's count, the diffuse vertex's
    included, within its limit (path_limits.bounce_limits)."""
    # Packed counts add field by field (no field comes near its 16 bits).
    return (camera_bounces + 1 + light_bounces <= limits[0]
            and within_limits(add_bounce(camera_kinds + light_kinds[j], DIFFUSE_BOUNCE), limits))


# -- camera walks -------------------------------------------------------------------------------

class Walks(NamedTuple):
    """The state of up to n camera walks (camera rays through mirrors and glass)."""
    pixel: np.ndarray        # (n,) int64
    key: np.ndarray          # (n,) uint64
    o32: np.ndarray          # (n, 3) float32
    d32: np.ndarray          # (n, 3) float32
    tmax: np.ndarray         # (n,) float32
    beta: np.ndarray         # (n, 3) throughput
    bounces: np.ndarray      # (n,) int64 specular vertices so far
    kinds: np.ndarray        # (n,) int64 their scatterings by kind, packed (path_limits.py)


def new_walks(n: int) -> Walks:
    """Buffers for n camera walks."""
    return Walks(np.empty(n, np.int64), np.empty(n, np.uint64), np.empty((n, 3), np.float32),
                 np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty((n, 3)),
                 np.empty(n, np.int64), np.zeros(n, np.int64))


@jit_inline
def set_walk(walks, j, pixel, key, o, d, far, beta, bounces):
    """Walk j leaves o along d (at most far) with throughput beta."""
    walks.pixel[j] = pixel
    walks.key[j] = key
    for k in range(3):
        walks.o32[j, k] = o[k]
        walks.d32[j, k] = d[k]
    walks.tmax[j] = far
    store(walks.beta, j, beta)
    walks.bounces[j] = bounces


@jit
def start_walks(cam, filt, seed, pass_index, start, n, samples, walks):
    """Camera walks start .. start + n of a pass of `samples` per pixel (walk g samples pixel
    g // samples): a camera ray through the pixel filter's and the lens's samples, as the path
    tracer's generate makes them."""
    base = mix(mix(mix(np.uint64(0), np.uint64(seed)), MERGE_DOMAIN), np.uint64(pass_index))
    for j in range(n):
        g = start + j
        key = mix(base, np.uint64(g))
        u0, u1 = random_pair(key, 0, 0)
        l0, l1 = random_pair(key, 0, 1)
        o, d, far = camera_ray(cam, g // samples, filter_position(filt, u0),
                               filter_position(filt, u1), l0, l1)
        set_walk(walks, j, g // samples, key, o, d, far, (1.0, 1.0, 1.0), 0)
        walks.kinds[j] = NO_BOUNCES


@jit
def walk_bounce(mesh, mats, fresnel_model, limits, grid, m, walks, prim, u, v, out, pixels,
                contrib):
    """Walks m: at a mirror or glass, scatter as the path tracer does (specular.sample_specular,
    into `out`); at the first diffuse vertex after one or more specular ones, gather (`pixels`
    and `contrib` get the pixel and throughput x albedo / pi x the gather's sum); any other hit
    or a miss ends the walk. Returns (walks in out, gathers)."""
    has_normals = mesh.corner_normals.shape[0] > 0
    n_out = 0
    n_gather = 0
    for i in range(m):
        tri = prim[i]
        if tri < 0:
            continue
        mat = mats.of_triangle[tri]
        kind = mats.kind[mat]
        d = (np.float64(walks.d32[i, 0]), np.float64(walks.d32[i, 1]),
             np.float64(walks.d32[i, 2]))
        p, ng, ns, eps = hit_point(mesh, tri, np.float64(u[i]), np.float64(v[i]))
        ng_f, ns_f, entering = facing(d, ng, ns)
        bounces = walks.bounces[i]
        color, trans_color = surface_colors(mats, mat, tri, np.float64(u[i]), np.float64(v[i]))
        beta = row(walks.beta, i)
        if kind == DIFFUSE:
            if bounces == 0:
                continue          # seen directly: the path tracer's and the light tracer's
            total = gather(grid, p, ng_f, ns_f, bounces, walks.kinds[i], limits)
            if total[0] > 0.0 or total[1] > 0.0 or total[2] > 0.0:
                pixels[n_gather] = walks.pixel[i]
                for k in range(3):
                    contrib[n_gather, k] = beta[k] * color[k] / math.pi * total[k]
                n_gather += 1
            continue
        if not (kind == MIRROR or kind == GLASS or kind == REFRACTION):
            continue              # rough, Principled, node-tree or emitting: not merged
        if bounces + 3 > limits[0]:
            continue              # no room for this vertex, a diffuse one and a specular one
        u_choice, _ = random_pair(walks.key[i], 1 + bounces, 0)
        new_d, weight, event, valid, _ = specular.sample_at_hit(
            kind, d, ng_f, ns_f, entering, has_normals, color, trans_color, mats.ior[mat],
            fresnel_model, u_choice)
        if not valid or event == specular.TIR_ABSORBED:
            continue
        beta = (beta[0] * weight[0], beta[1] * weight[1], beta[2] * weight[2])
        if not (beta[0] > 0.0 or beta[1] > 0.0 or beta[2] > 0.0):
            continue
        set_walk(out, n_out, walks.pixel[i], walks.key[i], offset_origin(p, ng, eps, new_d),
                 new_d, 1e30, beta, bounces + 1)
        out.kinds[n_out] = add_bounce(walks.kinds[i], TRANSMISSION_BOUNCE
                                      if event == specular.TRANSMITTED else GLOSSY_BOUNCE)
        if not within_limits(out.kinds[n_out], limits):
            continue              # the path tracer's camera path ends at its next surface
        n_out += 1
    return n_out, n_gather


def merge(pool, geometry, mats, cam, filt, fresnel_model, limits, seed, pass_index,
          grid: PhotonGrid, total: int, samples: int, chunk: int):
    """A pass's camera walks 0 .. total (`samples` per pixel), in jobs of `chunk` on the pool,
    gathering the grid's photons: (pixels, contributions, in job order: the sums do not depend
    on the threads), each contribution throughput x albedo / pi x the gather's sum (the caller
    divides by pi r^2 and the samples)."""
    jobs = [(a, min(chunk, total - a)) for a in range(0, total, chunk)]
    parts = list(pool.map(lambda job: _walk_chunk(geometry, mats, cam, filt, fresnel_model,
                                                  limits, seed, pass_index, grid, samples,
                                                  *job), jobs))
    if not parts:
        return np.zeros(0, np.int64), np.zeros((0, 3))
    return (np.concatenate([p for p, _ in parts]),
            np.concatenate([c for _, c in parts]))


def _walk_chunk(geometry, mats, cam, filt, fresnel_model, limits, seed, pass_index, grid,
                samples, start, n):
    """Camera walks start .. start + n: (pixels, contributions) of their gathers."""
    walks, out = new_walks(n), new_walks(n)
    pixels, contrib = np.empty(n, np.int64), np.empty((n, 3))
    found_pixels, found = [], []
    start_walks(cam, filt, seed, pass_index, start, n, samples, walks)
    m = n
    for _ in range(int(limits[0])):
        if m == 0:
            break
        prim, u, v, _ = geometry.intersect(walks.o32[:m], walks.d32[:m], walks.tmax[:m])
        m, n_gather = walk_bounce(geometry.mesh, mats, fresnel_model, limits, grid, m, walks,
                                  prim, u, v, out, pixels, contrib)
        if n_gather:
            found_pixels.append(pixels[:n_gather].copy())
            found.append(contrib[:n_gather].copy())
        walks, out = out, walks
    if not found:
        return np.zeros(0, np.int64), np.zeros((0, 3))
    return np.concatenate(found_pixels), np.concatenate(found)
