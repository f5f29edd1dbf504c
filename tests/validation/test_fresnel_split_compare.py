"""The Fresnel split (tracer/wavefront.split_fresnel) against Cycles: wavy water over a white
floor (scenes/pool.py's, without its shadow caustics) under a square area lamp that the camera
sees mirrored in the waves (glints), 30x30. Cycles picks reflection or refraction at the water
by F alone; Snell counts the light the reflection meets at F whichever way its path goes, an
estimator of the same image with the glints' noise taken out.

`compare` renders without the split (compare.snell_render): at its sample counts Cycles'
batches meet some glints' pixels not at all, and there the split's correct image failed (the
pool at 256 spp: 6 of 900 pixels, z up to 20). Held here against Cycles at 32 times the
samples, where every glint is met in every batch. (The pool itself is no scene for this: at
8192 spp its round lamp's light through the water shows the bias of Cycles' shadow caustics,
docs/validation.md.)"""
from __future__ import annotations

import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

pool_script = importlib.import_module("pool")
common = pool_script.common

SPP = 8192                                    # 8 Cycles seeds x 1024
FRAMING = {"resolution_percentage": 12}       # 256 x 12% = 30 pixels a side
LAMP_SIZE, LAMP_POWER = 1.5, 300.0            # W: radiance P / (pi A) = 42


def build_glints(path):
    """The pool's floor, water and camera under a large square area lamp (no shadow-caustics
    flags: the path tracer finds the lamp through the water, the lamp being large)."""
    from sds_geometry import POOL_HALF, water_surface
    scene = common.new_scene((0.0, 0.0, 0.0))
    common.floor("Floor", POOL_HALF, common.material("Floor", "diffuse", (0.8, 0.8, 0.8)))
    water = common.material("Water", "glass", (1.0, 1.0, 1.0), IOR=1.33, Roughness=0.0)
    positions, triangles, _ = water_surface()
    common.mesh_object("Water", positions, triangles, water, smooth=True)
    common.area_lamp("Area", LAMP_POWER, LAMP_SIZE, pool_script.LAMP_POSITION, None)
    common.camera(scene, pool_script.CAMERA, pool_script.TARGET, lens=50.0)
    return common.save(path)


@pytest.fixture(scope="module")
def glints_reference(tmp_path_factory):
    """Cycles and the exported scene."""
    return Reference(build_glints(str(tmp_path_factory.mktemp("split") / "glints.blend")),
                     framing=FRAMING, spp=SPP)


def test_split_is_consistent_with_cycles_and_a_doubled_mirror_is_caught(glints_reference,
                                                                        monkeypatch):
    """Snell with the split (8 Cycles seeds x 1024 spp, stored; Snell 8192 spp): consistent;
    the mirror rays' light counted twice (the glints' share of paths that refracted, about
    twice their light) is not."""
    from snell.tracer.integrator import Renderer
    assert Renderer(glints_reference.scene).stages()["Fresnel split"][0]
    verdict, detail = _verdict(glints_reference.compare(fresnel_split=True))
    assert verdict == "consistent", detail
    split_light = Renderer._split_light

    def twice(self, *args):
        split_light(self, *args)
        split_light(self, *args)
    monkeypatch.setattr(Renderer, "_split_light", twice)
    verdict, detail = _verdict(glints_reference.compare(fresnel_split=True))
    assert verdict != "consistent", detail
