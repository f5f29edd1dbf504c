"""What a distributed render's tasks are keyed by: the content of its scene and settings, the
frame, the window and the seed, so that a retried or duplicated task is the same task."""
from __future__ import annotations

import dataclasses
import hashlib
import json

import numpy as np

from ..tracer.scene import Scene

# Settings that change how a render runs but not a pixel of it: left out of the key.
NOT_IN_IMAGE = ("threads",)


def scene_hash(scene: Scene) -> str:
    """sha256 of the scene's content: its header (images by their own sha256) and its arrays.
    Not of a saved file's bytes: np.savez stamps its members with the time."""
    digest = hashlib.sha256(json.dumps(scene.header(), sort_keys=True,
                                       allow_nan=False).encode("utf-8"))
    arrays = [scene.positions, scene.triangles, scene.material_ids, scene.object_ids,
              scene.normals] + [tc["coords"] for tc in scene.texcoords]
    for array in arrays:
        if array is None:
            digest.update(b"none")
            continue
        array = np.ascontiguousarray(array)
        digest.update(f"{array.dtype.str}{array.shape}".encode())
        digest.update(array.data)
    return digest.hexdigest()


def render_key(scene: Scene, settings) -> str:
    """sha256 of a render's content: the scene and every setting that changes its pixels."""
    wanted = {k: v for k, v in dataclasses.asdict(settings).items() if k not in NOT_IN_IMAGE}
    text = scene_hash(scene) + json.dumps(wanted, sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def window_key(render: str, frame: int, window: int, seed: int) -> str:
    """The Dask key of one window's task."""
    return f"snell-window-{render[:20]}-frame{frame}-window{window}-seed{seed}"


def pass_key(render: str, frame: int, kind: str, first: int, row: int, seed: int) -> str:
    """The Dask key of one task of a pass (adaptive sampling, batches): its kind ("camera", or
    "light" and the pass), its first sample or light path, and its first pixel row."""
    return f"snell-pass-{render[:20]}-frame{frame}-{kind}-first{first}-row{row}-seed{seed}"


def scene_key(render: str) -> str:
    """The Dask key of a render's scattered scene."""
    return f"snell-scene-{render[:20]}"
