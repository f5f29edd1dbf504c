"""Light vertices: one bounce of light from the lamps, connected to the camera path's vertices.

Light that a diffuse surface reflects right next to a lamp (a ceiling 1 cm above a mesh lamp
whose back face lights it) is hard for the path tracer: a camera path finds that small, bright
patch only when a BSDF sample happens to hit it. Bidirectional path tracing's strategy s = 2
finds it from the other end: each camera path gets one light vertex y1, the first diffuse hit of
a ray leaving a lamp, and every diffuse or layered vertex z of the camera path connects to y1
with a shadow ray (Veach's thesis, chapter 10; pbrt-v4's bdpt.cpp, ConnectBDPT with s = 2).

A path z, y1, y0 (y0 on the lamp) then has three strategies, weighted by the power heuristic
over their densities in one measure (here solid angle at y1 towards y0, all three divided by the
same density of reaching y1 from z):

    p0 = BSDF sampling at y1 finds the lamp:  cos_s(y1, w0) / pi
    p1 = next-event estimation at y1:         the light sampler's solid-angle density
    p2 = the light vertex:                    q(y0) cos_g(y1, w0) / p_A(z -> y1)

where q = (the lamp's pick probability / its area) x (emission sides / pi) is the light vertex's
density of y0 in area and of its direction per cosine (`light_vertex_density`, in
lights/dispatch.py with the other switches on a light's kind), and p_A(z -> y1)
= pdf_bsdf(z, w1) cos_g(y1, w1) / |y1 - z|^2 the density of the camera path's own step to y1.
The path tracer adds p2 to the weights of its two strategies (wavefront.emitters, materials);
the connection itself is weighted by p2^2 / (p0^2 + p1^2 + p2^2). Light vertices start on
emissive triangles (both faces, as they emit) and on area lamps with a spread and Cycles' MIS,
shadow and diffuse-visibility options; other lights leave the two strategies to themselves.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .geometry import hit_point, offset_origin
from .jit import jit, jit_inline
from .lights.codes import STARTS_LIGHT_VERTICES
from .lights.dispatch import emitter_density, light_vertex_density, light_vertex_ray, pick_light
from .material_kinds import DIFFUSE
from .media import start_sigma, transmittance
from .sampler import sample_pair
from .textures import surface_colors
from .vec import dot, mul, neg, row, store, sub

# Sampler dimensions of a camera path's light vertex (any numbers apart from the bounces' own).
PICK_DIMENSION, POINT_DIMENSION, DIRECTION_DIMENSION = 0x4C56_0000, 0x4C56_0001, 0x4C56_0002


class LightVertices(NamedTuple):
    """Each camera path's light vertex (row = the path's row in its chunk) and the rays that find
    them."""
    found: np.ndarray        # (n,) bool: the path has a light vertex
    point: np.ndarray        # (n, 3) y1, lifted off its surface towards the light's side
    normal: np.ndarray       # (n, 3) y1's geometric normal, facing the light's side
    weight: np.ndarray       # (n, 3) light arriving x f(y1) x the shading-normal factor, per
    #                          unit of the geometric term cos_g(y1, z) / |y1 - z|^2 a connection
    #                          multiplies it by
    density: np.ndarray      # (n,) q(y0) cos_g(y1, w0): p2 times the camera step's density
    others: np.ndarray       # (n,) p0^2 + p1^2
    lamp: np.ndarray         # (n,) int64: the mesh triangle y0 lies on, or -1 - its area lamp
    row: np.ndarray          # (n,) int64: the path row of emission ray j
    o32: np.ndarray          # (n, 3) float32 emission rays
    d32: np.ndarray          # (n, 3)
    tmax: np.ndarray         # (n,) float32


def new_light_vertices(n: int) -> LightVertices:
    """Uninitialised buffers for the light vertices of n camera paths."""
    return LightVertices(np.zeros(n, np.bool_), np.empty((n, 3)), np.empty((n, 3)),
                         np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n, np.int64),
                         np.empty(n, np.int64),
                         np.empty((n, 3), np.float32), np.empty((n, 3), np.float32),
                         np.empty(n, np.float32))


def starts_light_vertices(lights) -> bool:
    """Whether any light of these tables (lights.tables.Lights) starts light vertices."""
    area = (lights.area_flags & STARTS_LIGHT_VERTICES) == STARTS_LIGHT_VERTICES
    return bool(lights.tri_prim.shape[0] > 0 or np.any(area & (lights.area_spread_tan > 0.0)))


@jit_inline
def camera_step_density(pdf_bsdf, o, p, ng, w):
    """The density in area at p of a BSDF sample from o (solid-angle density pdf_bsdf) arriving
    along w at a surface of geometric normal ng."""
    to = sub(p, o)
    d2 = dot(to, to)
    return pdf_bsdf * abs(dot(w, ng)) / d2 if d2 > 0.0 else 0.0


@jit
def emit(lights, mesh, bits, stratified, n, keys, samples, lv):
    """Rays from the lamps for camera paths 0 .. n (keys, samples: their sampler keys and sample
    indices); returns how many there are (row j's path in lv.row)."""
    m = 0
    zero = (0.0, 0.0, 0.0)
    for i in range(n):
        lv.found[i] = False
        if lights.cdf.shape[0] == 0 or not lights.cdf[-1] > 0.0:
            continue
        u_pick, u_side = sample_pair(keys[i], samples[i], PICK_DIMENSION, bits, stratified)
        u0, u1 = sample_pair(keys[i], samples[i], POINT_DIMENSION, bits, stratified)
        v0, v1 = sample_pair(keys[i], samples[i], DIRECTION_DIMENSION, bits, stratified)
        kind, k, pmf = pick_light(lights, u_pick)
        q = light_vertex_density(lights, kind, k, pmf)
        if q == 0.0:
            continue
        y, normal, w, radiance, emitter = light_vertex_ray(lights, mesh, kind, k, u_side, u0, u1,
                                                           v0, v1)
        lv.lamp[i] = emitter
        # Radiance x cos / (point density x direction density) = radiance / q.
        beta = mul(radiance, 1.0 / q) if dot(w, normal) > 0.0 else zero
        if not (beta[0] > 0.0 or beta[1] > 0.0 or beta[2] > 0.0):
            continue
        store(lv.weight, i, beta)          # the emission weight until hits() completes it
        lv.density[i] = q                  # likewise
        lv.row[m] = i
        for a in range(3):
            lv.o32[m, a] = y[a]
            lv.d32[m, a] = w[a]
        lv.tmax[m] = 1e30
        m += 1
    return m


@jit
def hits(lights, mesh, mats, media, m, lv, prim, u, v):
    """Keep the emission rays' diffuse hits as light vertices, with their MIS densities; in a
    scene with media, the light is attenuated in the media around its lamp (media.py)."""
    for j in range(m):
        i = lv.row[j]
        tri = prim[j]
        if tri < 0 or mats.kind[mats.of_triangle[tri]] != DIFFUSE:
            continue
        d = (np.float64(lv.d32[j, 0]), np.float64(lv.d32[j, 1]), np.float64(lv.d32[j, 2]))
        origin = (np.float64(lv.o32[j, 0]), np.float64(lv.o32[j, 1]), np.float64(lv.o32[j, 2]))
        p, ng, ns, eps = hit_point(mesh, tri, np.float64(u[j]), np.float64(v[j]))
        w0 = neg(d)                                # towards the lamp
        side = 1.0 if dot(w0, ng) > 0.0 else -1.0
        ng_f, ns_f = mul(ng, side), mul(ns, side)
        cos_s, cos_g = dot(w0, ns_f), dot(w0, ng_f)
        if not (cos_s > 0.0 and cos_g > 0.0):
            continue                               # next-event estimation gets nothing here
        to = sub(origin, p)
        dist = math.sqrt(dot(to, to))
        p1 = emitter_density(lights, lv.lamp[i], p, w0, dist)
        albedo, _ = surface_colors(mats, mats.of_triangle[tri], tri, np.float64(u[j]),
                                   np.float64(v[j]))
        scale = cos_s / (cos_g * math.pi)         # f = albedo / pi, and Veach's 5.3 factor
        tr = (1.0, 1.0, 1.0)
        if media.on:
            lamp = lv.lamp[i]
            tr = transmittance(start_sigma(media, lamp < 0, -1 - lamp if lamp < 0 else lamp),
                               dist)
        for a in range(3):
            lv.weight[i, a] *= albedo[a] * scale * tr[a]
        p0 = cos_s / math.pi
        lv.others[i] = p0 * p0 + p1 * p1
        lv.density[i] *= cos_g
        store(lv.point, i, offset_origin(p, ng_f, eps, w0))
        store(lv.normal, i, ng_f)
        lv.found[i] = True


@jit_inline
def direction_to(lv, i, p):
    """(unit direction from p to path i's light vertex, squared distance)."""
    to = sub(row(lv.point, i), p)
    d2 = dot(to, to)
    return (mul(to, 1.0 / math.sqrt(d2)) if d2 > 0.0 else (0.0, 0.0, 1.0)), d2


@jit_inline
def connection(lv, i, w, d2, f_cos, pdf_bsdf):
    """The light a camera vertex gets from path i's light vertex along w at squared distance d2,
    MIS-weighted, per unit of the path's throughput (f_cos: the vertex's BSDF x cosine towards
    it, pdf_bsdf: its density of sampling w); zero where the vertex is behind y1."""
    cos_y = -dot(w, row(lv.normal, i))
    if not (cos_y > 0.0 and d2 > 0.0):
        return (0.0, 0.0, 0.0)
    g = cos_y / d2
    step = pdf_bsdf * g
    mis = 1.0
    if step > 0.0:     # (else no BSDF sample from the vertex reaches y1: the light vertex only)
        p2 = lv.density[i] / step
        mis = p2 * p2 / (p2 * p2 + lv.others[i])
    s = g * mis
    return (f_cos[0] * lv.weight[i, 0] * s, f_cos[1] * lv.weight[i, 1] * s,
            f_cos[2] * lv.weight[i, 2] * s)
