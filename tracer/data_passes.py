"""The data passes a compositor reads: Depth, Position, Normal and Object Index, as Blender 5
names their layers (View Layer > Passes > Data: Z, Position, Normal, Object Index).

Cycles writes Depth, Position and the index from each pixel's first sample only
(kernel/film/data_passes.h: overwritten at sample 0) and averages Normal over the samples. Snell
traces one camera ray per pixel, through the pixel's centre and the lens centre, and takes all
four from its first hit: where a pixel sees one surface that is Cycles' value (Normal to the
curvature across a pixel); on an edge each renderer shows one side. A ray that escapes has
Depth 1e10 (Cycles' film reads an unwritten depth so), Position, Normal and index 0. Transparent
surfaces are not looked through (Cycles looks past those under its alpha threshold).
"""
from __future__ import annotations

import numpy as np

# Pass -> its channels, as Blender names them in a multilayer EXR ("<pass>.<channel>").
CHANNELS = {"Depth": "Z", "Position": "XYZ", "Normal": "XYZ", "Object Index": "X"}
BACKGROUND_DEPTH = 1e10


def data_passes(renderer, names) -> dict:
    """{pass name: float32 (H, W, channels), row 0 at the top} of the passes named (CHANNELS'
    keys) for a Renderer's scene and camera."""
    unknown = [name for name in names if name not in CHANNELS]
    if unknown:
        raise ValueError(f"data passes: no pass {unknown[0]!r} (one of {', '.join(CHANNELS)})")
    camera, scene = renderer.camera, renderer.scene
    w, h = camera.width, camera.height
    pixels = np.arange(w * h, dtype=np.int64)
    centre = np.full((2, w * h), 0.5)
    o, d, far = camera.generate(pixels, centre, centre)
    prim, u, v, _ = renderer.geometry.intersect(np.ascontiguousarray(o.T, np.float32),
                                                np.ascontiguousarray(d.T, np.float32),
                                                far.astype(np.float32))
    n = w * h
    values = {"Depth": np.full((n, 1), BACKGROUND_DEPTH), "Position": np.zeros((n, 3)),
              "Normal": np.zeros((n, 3)), "Object Index": np.zeros((n, 1))}
    hit = np.flatnonzero(prim >= 0)
    if len(hit):
        tri = scene.triangles[prim[hit]]
        b1, b2 = u[hit].astype(np.float64), v[hit].astype(np.float64)
        bary = np.stack([1.0 - b1 - b2, b1, b2], axis=1)[:, :, None]
        corners = scene.positions[tri].astype(np.float64)          # (hits, 3 corners, 3)
        position = (bary * corners).sum(axis=1)
        face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        normal = face if scene.normals is None else (bary * scene.normals[tri]).sum(axis=1)
        normal = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
        # Facing the viewer, as Cycles' shading normal on a back face.
        normal *= np.where((face * d.T[hit]).sum(axis=1) > 0.0, -1.0, 1.0)[:, None]
        local = (position - camera.position) @ camera.rotation   # Blender's camera: -z ahead
        index = np.array([obj.get("pass_index", 0) for obj in scene.objects] or [0], float)
        values["Depth"][hit, 0] = -local[:, 2]
        values["Position"][hit] = position
        values["Normal"][hit] = normal
        values["Object Index"][hit, 0] = index[scene.object_ids[prim[hit]]]
    return {name: values[name].reshape(h, w, -1).astype(np.float32) for name in names}
