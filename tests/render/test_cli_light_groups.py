"""`snell render --passes Combined_<group>`: the light groups' passes as EXR layers named as
Blender names them, an unknown group a clear error, a cluster a warning."""
from __future__ import annotations

import numpy as np
import pytest

from snell import cli
from snell.tracer import image
from snell.tracer.integrator import Renderer
from snell.tracer.scene import save, validate
from support.builders import camera, make_scene, quad


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    """A diffuse floor under a point lamp in "key" and a lamp in no group, a world in "sky"."""
    floor = (*quad((0.0, 0.0, -1.0), 2.0, 2.0), 0)
    lamps = [{"name": "key", "kind": "point", "position": [0.5, 0.0, 1.0],
              "intensity": [20.0, 20.0, 20.0], "radius": 0.1},
             {"name": "loose", "kind": "point", "position": [-0.5, 0.0, 1.0],
              "intensity": [10.0, 10.0, 10.0], "radius": 0.1}]
    scene = make_scene([floor], [{"name": "Floor", "kind": "diffuse", "color": [0.8, 0.5, 0.3]}],
                       camera(resolution=(8, 6), lens=30.0), world=(0.2, 0.3, 0.5),
                       lights=lamps, spp=4)
    scene.light_groups = ["key", "sky"]
    scene.lights[0]["light_group"] = 0
    scene.world["light_group"] = 1
    path = tmp_path_factory.mktemp("cli_groups") / "groups.snell"
    save(validate(scene), str(path))
    return path, scene


def test_the_groups_are_exr_layers(scene_file, tmp_path):
    """Each asked group's pass is a layer "Combined_<group>" with the tracer's values (the
    prefix in any case, the group's name as it is); the image is unchanged. Deliberate error:
    the layers written from the other group's pass fails it (144 of 144 values off, up to
    160: the key lamp seen directly)."""
    path, scene = scene_file
    out = tmp_path / "a.exr"
    assert cli.main(["render", str(path), "-o", str(out), "--quiet",
                     "--passes", "combined_key,Combined_sky"]) == 0
    expected = Renderer(scene, scene.settings(light_groups=True)).render()
    groups = expected.light_group_images()
    for name in ("Combined_key", "Combined_sky"):
        written = np.stack([image.read_channel(out, f"{name}.{c}") for c in "RGB"], -1)
        np.testing.assert_array_equal(written, groups[name])
        assert written.max() > 0.0
    assert np.array_equal(image.read_exr(out), expected.mean())


def test_an_unknown_group_is_an_error_naming_it(scene_file, tmp_path, capsys):
    path, _ = scene_file
    code = cli.main(["render", str(path), "-o", str(tmp_path / "a.exr"), "--quiet",
                     "--passes", "Combined_fill"])
    assert code == 1 and not (tmp_path / "a.exr").exists()
    err = capsys.readouterr().err
    assert "no light group 'fill' in the scene (its light groups: 'key', 'sky')" in err, err


def test_a_name_blender_does_not_have_is_a_usage_error(scene_file, tmp_path, capsys):
    path, _ = scene_file
    with pytest.raises(SystemExit) as exit_:
        cli.main(["render", str(path), "-o", str(tmp_path / "a.exr"), "--passes", "Combined"])
    assert exit_.value.code == 2
    assert "no pass 'Combined'" in capsys.readouterr().err
