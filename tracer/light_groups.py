"""Cycles' light groups: each group's pass holds the light its lamps, emissive objects and world
add to the image.

Blender's View Layer lists the light groups; a lamp or an emissive object joins one by its
Object > Shading > Light Group, the world by World > Settings > Light Group. Cycles
(kernel/film/light_passes.h: film_write_emission_or_background_pass and film_write_direct_light)
adds every piece of light a camera path adds to Combined also to the pass of its light's group
(LIGHTGROUP_NONE: to none), after clamping, as Combined gets it; the passes are named
"Combined_<group>" (blender/sync.cpp). So the image is the sum of the group passes plus the light
of the lights in no group.

A path's radiance row carries its groups' shares: when a render makes the light groups, the
row has 3 more columns per group after Combined's three (the chunk buffer is that wide), and
the stages add each contribution through add_grouped, the group of the light that gave it:
the lamp a ray crosses, the emissive triangle's object, the world or sun it escapes to, the
light a light sample picked (carried by its shadow ray), the lamp that started a light vertex.
With no group columns (the render makes no groups) add_grouped is add_light. The light tracer's
splats go to the group of the light their path left (Renderer.trace_light_chunk).

Like the light passes' rows (light_passes.py), the paths' group columns are added to the
pixels' sums of the half of the sample indices they are in (light_passes.film_rows), and read as
the image is (RenderResult.light_group_images).
"""
from __future__ import annotations

import numpy as np

from .jit import jit, jit_inline
from .lights.codes import AREA, EMISSIVE_TRIANGLE, POINT, SUN
from .vec import finite_row

NONE = -1              # a light in no group (Cycles' LIGHTGROUP_NONE)
PASS_PREFIX = "Combined_"    # Blender's pass of group NAME is "Combined_NAME"


def pass_name(group: str) -> str:
    """Blender's and Cycles' name of a light group's pass."""
    return PASS_PREFIX + group


def wanted(scene, settings) -> list:
    """The names of the light groups a render makes: the scene's, when its settings ask."""
    return list(scene.light_groups) if settings.light_groups else []


def columns(groups: int) -> int:
    """The width of a path's radiance row: Combined's three, then three per group."""
    return 3 + 3 * groups


@jit
def add_grouped(radiance, path, group, contribution):
    """radiance[path] += contribution, and to its group's columns where the row has them."""
    for k in range(3):
        radiance[path, k] += contribution[k]
    if group >= 0 and radiance.shape[1] > 3:
        for k in range(3):
            radiance[path, 3 + 3 * group + k] += contribution[k]


@jit
def add_to_group(radiance, path, group, contribution):
    """Add contribution to group's columns of radiance[path] only (light Cycles' film writes to
    the group but not to Combined: the world behind a transparent film)."""
    if group >= 0 and radiance.shape[1] > 3:
        for k in range(3):
            radiance[path, 3 + 3 * group + k] += contribution[k]


@jit_inline
def light_group(lights, kind, i):
    """The group of light i of this kind (a lights.codes kind; for emissive triangles the row of
    the light triangle), NONE for none."""
    if kind == EMISSIVE_TRIANGLE:
        return lights.prim_group[lights.tri_prim[i]]
    if kind == AREA:
        return lights.area_group[i]
    if kind == POINT:
        return lights.point_group[i]
    if kind == SUN:
        return lights.sun_group[i]
    return lights.world_group


@jit_inline
def lamp_group(lights, lamp):
    """The group of lamp `lamp` of lights.dispatch.lamps_to_cross (area lamps, then point and
    spot lamps)."""
    n_area = lights.area_group.shape[0]
    return lights.area_group[lamp] if lamp < n_area else lights.point_group[lamp - n_area]


@jit_inline
def escape_group(lights, k):
    """The group of light k of lights.dispatch.lights_at_escape (the world, then the suns)."""
    if lights.has_world:
        if k == 0:
            return lights.world_group
        k -= 1
    return lights.sun_group[k]


@jit_inline
def emitter_group(lights, emitter):
    """The group of a light vertex's emitter (light_vertices.py: a mesh triangle, or -1 - an
    area lamp)."""
    return lights.prim_group[emitter] if emitter >= 0 else lights.area_group[-1 - emitter]


@jit
def splat_groups(pixels, contributions, groups, total):
    """Add each finite splat (the light tracer's) to its pixel's row of its group's columns in
    total (pixels, 3 x groups); splats in no group add nothing. Returns how many were not
    finite."""
    bad = 0
    for j in range(pixels.shape[0]):
        if not finite_row(contributions, j):
            bad += 1
            continue
        g = groups[j]
        if g < 0:
            continue
        for k in range(3):
            total[pixels[j], 3 * g + k] += contributions[j, k]
    return bad


def group_tables(scene, n_triangles: int) -> dict:
    """The light tables' group columns (lights.tables.Lights) of a scene: each area, point and
    spot lamp's and sun's group (in the order of the scene's lights of each kind), the world's,
    and each mesh triangle's (its object's), NONE where the scene names none."""
    def of(entries):
        return np.array([entry.get("light_group", NONE) for entry in entries], np.int64)
    lights = scene.lights
    objects = np.append(of(scene.objects), NONE)      # a file without objects: ids 0
    ids = np.asarray(scene.object_ids, np.int64)
    prim = objects[np.minimum(ids, len(objects) - 1)] if len(ids) else np.zeros(0, np.int64)
    if len(prim) != n_triangles:
        prim = np.full(n_triangles, NONE, np.int64)
    return dict(area_group=of([x for x in lights if x["kind"] == "area"]),
                point_group=of([x for x in lights if x["kind"] in ("point", "spot")]),
                sun_group=of([x for x in lights if x["kind"] == "sun"]),
                world_group=int(scene.world.get("light_group", NONE)),
                prim_group=np.ascontiguousarray(prim))


def read_groups(mean: np.ndarray, light: np.ndarray | None, names, exposure: float) -> dict:
    """{pass name: float64 (H, W, 3)} of the groups' pixel means (H, W, 3 x groups) plus the
    light tracer's (the same shape, per light path; None without it), times the film's
    exposure as the image."""
    out = {}
    for g, name in enumerate(names):
        values = mean[..., 3 * g:3 * g + 3]
        if light is not None:
            values = values + light[..., 3 * g:3 * g + 3]
        out[pass_name(name)] = values * exposure
    return out
