"""The HDRI world (#16) against Cycles: glass, mirror, diffuse and rough gold spheres under a sky
with a sun-like hot spot made in the test, seen through a Mapping node's Z rotation. Snell must
be `snell compare` consistent, and turning the map by 5 degrees in Snell alone must be caught."""
from __future__ import annotations

import copy
import importlib

import numpy as np
import pytest

from support import hdri
from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
ROTATION = 0.3          # the Mapping node's Z rotation, radians


def build_spheres(path, exr):
    """Smooth glass, a mirror, a diffuse and a rough Principled gold sphere in a row, floating in
    the HDRI world; the camera sees the sky and the ground around them."""
    scene = common.reset()
    common.setup_render(scene, (64, 32))
    hdri.set_hdri_world(scene, exr, rotation_z=ROTATION)
    specs = [("Glass", "glass", (1.0, 1.0, 1.0), {"IOR": 1.5}),
             ("Mirror", "glossy", (0.9, 0.9, 0.9), {}),
             ("Diffuse", "diffuse", (0.8, 0.5, 0.3), {}),
             ("Gold", "principled", (1.0, 0.766, 0.336), {"Metallic": 1.0, "Roughness": 0.3})]
    for (name, kind, color, inputs), x in zip(specs, (-1.65, -0.55, 0.55, 1.65)):
        common.uv_sphere(name, (x, 0.0, 0.0), 0.5, common.material(name, kind, color, **inputs))
    common.camera(scene, (0.0, -5.0, 0.6), (0.0, 0.0, 0.2), lens=35.0)
    return common.save(path)


@pytest.fixture(scope="module")
def spheres(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("hdri")
    exr = hdri.write_exr(tmp / "sky.exr", hdri.sky())
    return Reference(build_spheres(str(tmp / "spheres.blend"), exr), framing=FULL, spp=256)


def turned(degrees):
    """A deliberate error: the environment turned about Z by `degrees` more in Snell alone."""
    from snell.tracer.lights.world import rotation_matrix

    def modify(scene):
        scene = copy.copy(scene)
        scene.world = copy.deepcopy(scene.world)
        env = scene.world["environment"]
        env["matrix"] = (np.array(env["matrix"])
                         @ rotation_matrix((0.0, 0.0, np.radians(degrees)))).tolist()
        return scene
    return modify


def test_exporter_reads_the_world(spheres):
    """The world exports as an environment map with the Mapping node's rotation, no warning."""
    assert spheres.warnings == []
    env = spheres.scene.world["environment"]
    np.testing.assert_allclose(env["matrix"], [[np.cos(ROTATION), -np.sin(ROTATION), 0],
                                               [np.sin(ROTATION), np.cos(ROTATION), 0],
                                               [0, 0, 1]], atol=1e-7)
    assert env["interpolation"] == "linear" and env["strength"] == 1.0
    np.testing.assert_array_equal(spheres.scene.images[env["image"]]["pixels"], hdri.sky())


def test_hdri_spheres_match_cycles(spheres):
    """Consistent (measured at 256 spp: mean ratio 0.996 .. 1.000, |mean z| < 1)."""
    verdict, detail = _verdict(spheres.compare())
    assert verdict == "consistent", detail


def test_hdri_rotated_5_degrees_is_caught(spheres):
    """Power: the map turned by 5 degrees is inconsistent."""
    verdict, detail = _verdict(spheres.compare(turned(5.0)))
    assert verdict == "inconsistent", detail


def _export_world(tmp_path, setup):
    """Export a one-sphere scene whose world `setup(scene)` makes: (world dict, images, warnings)."""
    from snell.validation import compare
    scene = common.reset()
    common.setup_render(scene, (8, 8))
    setup(scene)
    common.uv_sphere("S", (0.0, 0.0, 0.0), 0.5, common.material("D", "diffuse"))
    common.camera(scene, (0.0, -5.0, 0.0), (0.0, 0.0, 0.0))
    exported, warnings = compare.load_snell_scene(common.save(str(tmp_path / "w.blend")))
    return exported.world, exported.images, warnings


def test_exporter_world_options_and_fallbacks(tmp_path):
    """Closest interpolation and a Strength export as such; a Background without a Mapping node
    gets the identity; an Environment Texture without an image warns, naming the world and the
    node, and renders Cycles' missing-image pink; the mirror-ball projection warns."""
    exr = hdri.write_exr(tmp_path / "sky.exr", hdri.sky(8, 16))
    world, images, warnings = _export_world(tmp_path, lambda s: hdri.set_hdri_world(
        s, exr, strength=2.5, interpolation="Closest", mapping=False))
    assert warnings == []
    env = world["environment"]
    assert env["interpolation"] == "closest" and env["strength"] == 2.5
    np.testing.assert_array_equal(env["matrix"], np.eye(3))
    assert images[0]["name"] == "sky.exr" and images[0]["pixels"].shape == (8, 16, 3)

    def no_image(scene):
        hdri.set_hdri_world(scene, exr, strength=2.0, mapping=False)
        scene.world.node_tree.nodes["Environment Texture"].image = None
    world, images, warnings = _export_world(tmp_path, no_image)
    assert world == {"color": [2.0, 0.0, 2.0]} and images == []
    assert any("world 'HDRI': node 'Environment Texture': no image" in w for w in warnings)

    def mirror_ball(scene):
        hdri.set_hdri_world(scene, exr, mapping=False)
        scene.world.node_tree.nodes["Environment Texture"].projection = "MIRROR_BALL"
    world, _, warnings = _export_world(tmp_path, mirror_ball)
    assert "environment" not in world
    assert any("mirror ball projection is not supported" in w for w in warnings)
