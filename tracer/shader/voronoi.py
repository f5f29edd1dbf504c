"""Cycles' Voronoi texture in 1-4 dimensions: F1, F2, Smooth F1, Distance to Edge and N-Sphere
Radius, with the Euclidean, Manhattan, Chebychev and Minkowski metrics, fractal octaves
(Detail, Roughness, Lacunarity) and Normalize.

Follows Blender 5.0's intern/cycles/kernel/svm/voronoi.h. Cycles writes every feature once per
dimension; here each is written once for a point of `dims` components (x, y, z, w: the unused
ones are zero and their loops run over the one cell 0), visiting the neighbouring cells in
Cycles' order (w outermost, x innermost) so that ties resolve alike. 1D reads its cell points
from hash_float_to_float of the cell's float coordinate, 2D-4D from the PCG hashes of the
integer cell (hash_int*_to_float*), as Cycles 5.0 does.
"""
from __future__ import annotations

import math

from ..jit import jit
from .hashes import hash_float_to_float, hash_float_to_float3, hash_int2_to_float2, \
    hash_int3_to_float3, hash_int4_to_float4

# NodeVoronoiFeature and NodeVoronoiDistanceMetric (kernel/svm/types.h), in Cycles' order
F1, F2, SMOOTH_F1, DISTANCE_TO_EDGE, N_SPHERE_RADIUS = range(5)
EUCLIDEAN, MANHATTAN, CHEBYCHEV, MINKOWSKI = range(4)

_FLT_MAX = 3.4028234663852886e38


@jit
def cell_point(dims, cx, cy, cz, cw):
    """The random point of an integer cell, each component in [0, 1] (unused ones 0)."""
    if dims == 1:
        return hash_float_to_float(float(cx)), 0.0, 0.0, 0.0
    if dims == 2:
        a, b = hash_int2_to_float2(cx, cy)
        return a, b, 0.0, 0.0
    if dims == 3:
        a, b, c = hash_int3_to_float3(cx, cy, cz)
        return a, b, c, 0.0
    return hash_int4_to_float4(cx, cy, cz, cw)


@jit
def cell_color(dims, cx, cy, cz, cw):
    """The random colour of an integer cell (hash_float_to_float3 in 1D, hash_int2_to_float3,
    hash_int3_to_float3, hash_int4_to_float3)."""
    if dims == 1:
        return hash_float_to_float3(float(cx))
    if dims == 2:
        return hash_int3_to_float3(cx, cy, 0)
    if dims == 3:
        return hash_int3_to_float3(cx, cy, cz)
    a, b, c, _ = hash_int4_to_float4(cx, cy, cz, cw)
    return a, b, c


@jit
def _reduce(dims, metric, exponent, dx, dy, dz, dw, bound):
    # the metric of the difference (dx, dy, dz, dw); bound skips the final root (Cycles'
    # voronoi_distance_bound), which orders points alike at less cost
    if dims == 1:
        return abs(dx)
    if metric == EUCLIDEAN:
        s = dx * dx + dy * dy + (dz * dz if dims >= 3 else 0.0) + (dw * dw if dims >= 4 else 0.0)
        return s if bound else math.sqrt(s)
    ax, ay, az, aw = abs(dx), abs(dy), abs(dz), abs(dw)
    if metric == MANHATTAN:
        return ax + ay + (az if dims >= 3 else 0.0) + (aw if dims >= 4 else 0.0)
    if metric == CHEBYCHEV:
        m = max(ax, ay)
        if dims >= 3:
            m = max(m, az)
        if dims >= 4:
            m = max(m, aw)
        return m
    if metric == MINKOWSKI:
        s = ax ** exponent + ay ** exponent
        if dims >= 3:
            s += az ** exponent
        if dims >= 4:
            s += aw ** exponent
        return s if bound else s ** (1.0 / exponent)
    return 0.0


@jit
def voronoi_distance(dims, metric, exponent, dx, dy, dz, dw):
    """The distance of a difference vector under a metric (Cycles' voronoi_distance)."""
    return _reduce(dims, metric, exponent, dx, dy, dz, dw, False)


@jit
def _span(dims, axis, r):
    # the neighbour offsets along an axis: -r..r if the axis is in use, else only 0
    return (-r, r + 1) if dims > axis else (0, 1)


@jit
def voronoi_f1(dims, metric, exponent, randomness, x, y, z, w):
    """(distance, colour, position (4D)) of the nearest cell point (Cycles' voronoi_f1)."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    cx, cy, cz, cw = int(fx), int(fy), int(fz), int(fw)
    lx, ly, lz, lw = x - fx, y - fy, z - fz, w - fw
    best = _FLT_MAX
    tx, ty, tz, tw = 0, 0, 0, 0
    px, py, pz, pw = 0.0, 0.0, 0.0, 0.0
    ua, ub = _span(dims, 3, 1)
    ka, kb = _span(dims, 2, 1)
    ja, jb = _span(dims, 1, 1)
    for u in range(ua, ub):
        for k in range(ka, kb):
            for j in range(ja, jb):
                for i in range(-1, 2):
                    hx, hy, hz, hw = cell_point(dims, cx + i, cy + j, cz + k, cw + u)
                    qx, qy = i + hx * randomness, j + hy * randomness
                    qz, qw = k + hz * randomness, u + hw * randomness
                    d = _reduce(dims, metric, exponent, qx - lx, qy - ly, qz - lz, qw - lw, True)
                    if d < best:
                        tx, ty, tz, tw = i, j, k, u
                        best = d
                        px, py, pz, pw = qx, qy, qz, qw
    distance = voronoi_distance(dims, metric, exponent, px - lx, py - ly, pz - lz, pw - lw)
    color = cell_color(dims, cx + tx, cy + ty, cz + tz, cw + tw)
    return distance, color, (px + fx, py + fy, pz + fz, pw + fw)


@jit
def _smoothstep01(x):
    # smoothstep(0, 1, x)
    if x < 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return (3.0 - 2.0 * x) * (x * x)


@jit
def voronoi_smooth_f1(dims, metric, exponent, randomness, smoothness, x, y, z, w):
    """(distance, colour, position (4D)) blended over the 5^dims nearest cells (Cycles'
    voronoi_smooth_f1)."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    cx, cy, cz, cw = int(fx), int(fy), int(fz), int(fw)
    lx, ly, lz, lw = x - fx, y - fy, z - fz, w - fw
    sd = 0.0
    sr, sg, sb = 0.0, 0.0, 0.0
    sx, sy, sz, sw = 0.0, 0.0, 0.0, 0.0
    h = -1.0
    ua, ub = _span(dims, 3, 2)
    ka, kb = _span(dims, 2, 2)
    ja, jb = _span(dims, 1, 2)
    for u in range(ua, ub):
        for k in range(ka, kb):
            for j in range(ja, jb):
                for i in range(-2, 3):
                    hx, hy, hz, hw = cell_point(dims, cx + i, cy + j, cz + k, cw + u)
                    qx, qy = i + hx * randomness, j + hy * randomness
                    qz, qw = k + hz * randomness, u + hw * randomness
                    d = voronoi_distance(dims, metric, exponent, qx - lx, qy - ly, qz - lz,
                                         qw - lw)
                    if h == -1.0:
                        h = 1.0
                    else:
                        h = _smoothstep01(0.5 + 0.5 * (sd - d) / smoothness)
                    correction = smoothness * h * (1.0 - h)
                    sd = sd + h * (d - sd) - correction
                    correction /= 1.0 + 3.0 * smoothness
                    r, g, b = cell_color(dims, cx + i, cy + j, cz + k, cw + u)
                    sr = sr + h * (r - sr) - correction
                    sg = sg + h * (g - sg) - correction
                    sb = sb + h * (b - sb) - correction
                    # the position has only the components in use (a float2 in 2D)
                    sx = sx + h * (qx - sx) - correction
                    sy = sy + h * (qy - sy) - correction if dims >= 2 else 0.0
                    sz = sz + h * (qz - sz) - correction if dims >= 3 else 0.0
                    sw = sw + h * (qw - sw) - correction if dims >= 4 else 0.0
    return sd, (sr, sg, sb), (fx + sx, fy + sy, fz + sz, fw + sw)


@jit
def voronoi_f2(dims, metric, exponent, randomness, x, y, z, w):
    """(distance, colour, position (4D)) of the second-nearest cell point (Cycles'
    voronoi_f2)."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    cx, cy, cz, cw = int(fx), int(fy), int(fz), int(fw)
    lx, ly, lz, lw = x - fx, y - fy, z - fz, w - fw
    d1 = _FLT_MAX
    d2 = _FLT_MAX
    o1x, o1y, o1z, o1w = 0, 0, 0, 0
    o2x, o2y, o2z, o2w = 0, 0, 0, 0
    p1x, p1y, p1z, p1w = 0.0, 0.0, 0.0, 0.0
    p2x, p2y, p2z, p2w = 0.0, 0.0, 0.0, 0.0
    ua, ub = _span(dims, 3, 1)
    ka, kb = _span(dims, 2, 1)
    ja, jb = _span(dims, 1, 1)
    for u in range(ua, ub):
        for k in range(ka, kb):
            for j in range(ja, jb):
                for i in range(-1, 2):
                    hx, hy, hz, hw = cell_point(dims, cx + i, cy + j, cz + k, cw + u)
                    qx, qy = i + hx * randomness, j + hy * randomness
                    qz, qw = k + hz * randomness, u + hw * randomness
                    d = voronoi_distance(dims, metric, exponent, qx - lx, qy - ly, qz - lz,
                                         qw - lw)
                    if d < d1:
                        d2 = d1
                        d1 = d
                        o2x, o2y, o2z, o2w = o1x, o1y, o1z, o1w
                        o1x, o1y, o1z, o1w = i, j, k, u
                        p2x, p2y, p2z, p2w = p1x, p1y, p1z, p1w
                        p1x, p1y, p1z, p1w = qx, qy, qz, qw
                    elif d < d2:
                        d2 = d
                        o2x, o2y, o2z, o2w = i, j, k, u
                        p2x, p2y, p2z, p2w = qx, qy, qz, qw
    color = cell_color(dims, cx + o2x, cy + o2y, cz + o2z, cw + o2w)
    return d2, color, (p2x + fx, p2y + fy, p2z + fz, p2w + fw)


@jit
def voronoi_distance_to_edge(dims, randomness, x, y, z, w):
    """Distance to the nearest edge between cells (Cycles' voronoi_distance_to_edge)."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    cx, cy, cz, cw = int(fx), int(fy), int(fz), int(fw)
    lx, ly, lz, lw = x - fx, y - fy, z - fz, w - fw
    if dims == 1:
        mid = hash_float_to_float(fx) * randomness
        left = -1.0 + hash_float_to_float(fx - 1.0) * randomness
        right = 1.0 + hash_float_to_float(fx + 1.0) * randomness
        return min(abs((mid + left) / 2.0 - lx), abs((mid + right) / 2.0 - lx))
    ua, ub = _span(dims, 3, 1)
    ka, kb = _span(dims, 2, 1)
    best = _FLT_MAX
    vx, vy, vz, vw = 0.0, 0.0, 0.0, 0.0
    for u in range(ua, ub):
        for k in range(ka, kb):
            for j in range(-1, 2):
                for i in range(-1, 2):
                    hx, hy, hz, hw = cell_point(dims, cx + i, cy + j, cz + k, cw + u)
                    qx, qy = i + hx * randomness - lx, j + hy * randomness - ly
                    qz, qw = k + hz * randomness - lz, u + hw * randomness - lw
                    d = qx * qx + qy * qy + qz * qz + qw * qw
                    if d < best:
                        best = d
                        vx, vy, vz, vw = qx, qy, qz, qw
    best = _FLT_MAX
    for u in range(ua, ub):
        for k in range(ka, kb):
            for j in range(-1, 2):
                for i in range(-1, 2):
                    hx, hy, hz, hw = cell_point(dims, cx + i, cy + j, cz + k, cw + u)
                    qx, qy = i + hx * randomness - lx, j + hy * randomness - ly
                    qz, qw = k + hz * randomness - lz, u + hw * randomness - lw
                    ex, ey, ez, ew = qx - vx, qy - vy, qz - vz, qw - vw
                    e2 = ex * ex + ey * ey + ez * ez + ew * ew
                    if e2 > 0.0001:
                        n = math.sqrt(e2)
                        d = ((vx + qx) / 2.0 * ex + (vy + qy) / 2.0 * ey + (vz + qz) / 2.0 * ez
                             + (vw + qw) / 2.0 * ew) / n
                        best = min(best, d)
    return best


@jit
def voronoi_n_sphere_radius(dims, randomness, x, y, z, w):
    """Half the distance from the nearest cell point to its own nearest neighbour (Cycles'
    voronoi_n_sphere_radius)."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    cx, cy, cz, cw = int(fx), int(fy), int(fz), int(fw)
    lx, ly, lz, lw = x - fx, y - fy, z - fz, w - fw
    ua, ub = _span(dims, 3, 1)
    ka, kb = _span(dims, 2, 1)
    ja, jb = _span(dims, 1, 1)
    best = _FLT_MAX
    px, py, pz, pw = 0.0, 0.0, 0.0, 0.0
    ox, oy, oz, ow = 0, 0, 0, 0
    for u in range(ua, ub):
        for k in range(ka, kb):
            for j in range(ja, jb):
                for i in range(-1, 2):
                    hx, hy, hz, hw = cell_point(dims, cx + i, cy + j, cz + k, cw + u)
                    qx, qy = i + hx * randomness, j + hy * randomness
                    qz, qw = k + hz * randomness, u + hw * randomness
                    d = ((qx - lx) ** 2 + (qy - ly) ** 2 + (qz - lz) ** 2 + (qw - lw) ** 2)
                    if d < best:
                        best = d
                        px, py, pz, pw = qx, qy, qz, qw
                        ox, oy, oz, ow = i, j, k, u
    best = _FLT_MAX
    nx, ny, nz, nw = 0.0, 0.0, 0.0, 0.0
    for u in range(ua, ub):
        for k in range(ka, kb):
            for j in range(ja, jb):
                for i in range(-1, 2):
                    if i == 0 and j == 0 and k == 0 and u == 0:
                        continue
                    ii, jj, kk, uu = i + ox, j + oy, k + oz, u + ow
                    hx, hy, hz, hw = cell_point(dims, cx + ii, cy + jj, cz + kk, cw + uu)
                    qx, qy = ii + hx * randomness, jj + hy * randomness
                    qz, qw = kk + hz * randomness, uu + hw * randomness
                    d = (px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2 + (pw - qw) ** 2
                    if d < best:
                        best = d
                        nx, ny, nz, nw = qx, qy, qz, qw
    return math.sqrt((nx - px) ** 2 + (ny - py) ** 2 + (nz - pz) ** 2 + (nw - pw) ** 2) / 2.0


@jit
def _octave(dims, feature, metric, exponent, randomness, smoothness, x, y, z, w):
    if feature == F2:
        return voronoi_f2(dims, metric, exponent, randomness, x, y, z, w)
    if feature == SMOOTH_F1 and smoothness != 0.0:
        return voronoi_smooth_f1(dims, metric, exponent, randomness, smoothness, x, y, z, w)
    return voronoi_f1(dims, metric, exponent, randomness, x, y, z, w)


@jit
def _lerp(a, b, t):
    return a + t * (b - a)


@jit
def fractal_voronoi_x_fx(dims, feature, metric, exponent, randomness, smoothness, detail,
                         roughness, lacunarity, normalize, max_distance, scale, x, y, z, w):
    """(distance, colour, position (4D)) summed over octaves (Cycles' fractal_voronoi_x_fx)."""
    amplitude = 1.0
    max_amplitude = 0.0
    octave_scale = 1.0
    distance = 0.0
    cr, cg, cb = 0.0, 0.0, 0.0
    px, py, pz, pw = 0.0, 0.0, 0.0, 0.0
    zero_input = detail == 0.0 or roughness == 0.0
    for i in range(int(math.ceil(detail)) + 1):
        s = octave_scale
        d, (r, g, b), (qx, qy, qz, qw) = _octave(dims, feature, metric, exponent, randomness,
                                                 smoothness, x * s, y * s, z * s, w * s)
        if zero_input:
            max_amplitude = 1.0
            distance, cr, cg, cb = d, r, g, b
            px, py, pz, pw = qx, qy, qz, qw
            break
        if i <= detail:
            max_amplitude += amplitude
            distance += d * amplitude
            cr, cg, cb = cr + r * amplitude, cg + g * amplitude, cb + b * amplitude
            px, py = _lerp(px, qx / s, amplitude), _lerp(py, qy / s, amplitude)
            pz, pw = _lerp(pz, qz / s, amplitude), _lerp(pw, qw / s, amplitude)
            octave_scale *= lacunarity
            amplitude *= roughness
        else:
            rmd = detail - math.floor(detail)
            if rmd != 0.0:
                max_amplitude = _lerp(max_amplitude, max_amplitude + amplitude, rmd)
                distance = _lerp(distance, distance + d * amplitude, rmd)
                cr = _lerp(cr, cr + r * amplitude, rmd)
                cg = _lerp(cg, cg + g * amplitude, rmd)
                cb = _lerp(cb, cb + b * amplitude, rmd)
                px = _lerp(px, _lerp(px, qx / s, amplitude), rmd)
                py = _lerp(py, _lerp(py, qy / s, amplitude), rmd)
                pz = _lerp(pz, _lerp(pz, qz / s, amplitude), rmd)
                pw = _lerp(pw, _lerp(pw, qw / s, amplitude), rmd)
    if normalize:
        distance /= max_amplitude * max_distance
        cr, cg, cb = cr / max_amplitude, cg / max_amplitude, cb / max_amplitude
    if scale != 0.0:
        px, py, pz, pw = px / scale, py / scale, pz / scale, pw / scale
    else:
        px, py, pz, pw = 0.0, 0.0, 0.0, 0.0
    return distance, (cr, cg, cb), (px, py, pz, pw)


@jit
def fractal_voronoi_distance_to_edge(dims, randomness, detail, roughness, lacunarity, normalize,
                                     max_distance, x, y, z, w):
    """Distance to edge over octaves (Cycles' fractal_voronoi_distance_to_edge)."""
    amplitude = 1.0
    max_amplitude = max_distance
    octave_scale = 1.0
    distance = 8.0
    zero_input = detail == 0.0 or roughness == 0.0
    for i in range(int(math.ceil(detail)) + 1):
        s = octave_scale
        d = voronoi_distance_to_edge(dims, randomness, x * s, y * s, z * s, w * s)
        if zero_input:
            distance = d
            break
        if i <= detail:
            max_amplitude = _lerp(max_amplitude, max_distance / s, amplitude)
            distance = _lerp(distance, min(distance, d / s), amplitude)
            octave_scale *= lacunarity
            amplitude *= roughness
        else:
            rmd = detail - math.floor(detail)
            if rmd != 0.0:
                lerp_amplitude = _lerp(max_amplitude, max_distance / s, amplitude)
                max_amplitude = _lerp(max_amplitude, lerp_amplitude, rmd)
                lerp_distance = _lerp(distance, min(distance, d / s), amplitude)
                distance = _lerp(distance, min(distance, lerp_distance), rmd)
    if normalize:
        distance /= max_amplitude
    return distance


@jit
def voronoi_texture(dims, feature, metric, x, y, z, w, scale, detail, roughness, lacunarity,
                    smoothness, exponent, randomness, normalize):
    """The Voronoi Texture node: (Distance, Color, Position, W, Radius) at vector (x, y, z) and
    W (Cycles' svm_node_tex_voronoi); the outputs a feature does not set are zero."""
    detail = min(max(detail, 0.0), 15.0)
    roughness = min(max(roughness, 0.0), 1.0)
    randomness = min(max(randomness, 0.0), 1.0)
    smoothness = min(max(smoothness / 2.0, 0.0), 0.5)
    x, y, z, w = x * scale, y * scale, z * scale, w * scale
    if dims == 1:
        # the 1D node reads W only
        x, y, z, w = w, 0.0, 0.0, 0.0
    elif dims == 2:
        z, w = 0.0, 0.0
    elif dims == 3:
        w = 0.0
    zero3 = (0.0, 0.0, 0.0)
    if feature == DISTANCE_TO_EDGE:
        max_distance = 0.5 + 0.5 * randomness
        d = fractal_voronoi_distance_to_edge(dims, randomness, detail, roughness, lacunarity,
                                             normalize, max_distance, x, y, z, w)
        return d, zero3, zero3, 0.0, 0.0
    if feature == N_SPHERE_RADIUS:
        return 0.0, zero3, zero3, 0.0, voronoi_n_sphere_radius(dims, randomness, x, y, z, w)
    c = 0.5 + 0.5 * randomness
    if dims == 1:
        max_distance = c
    else:
        max_distance = voronoi_distance(dims, metric, exponent, c, c, c, c)
    if feature == F2:
        max_distance *= 2.0
    d, color, (px, py, pz, pw) = fractal_voronoi_x_fx(
        dims, feature, metric, exponent, randomness, smoothness, detail, roughness, lacunarity,
        normalize, max_distance, scale, x, y, z, w)
    if dims == 1:
        # a 1D position is (0, 0, 0, coordinate): the W output
        return d, color, zero3, px, 0.0
    return d, color, (px, py, pz), pw, 0.0
