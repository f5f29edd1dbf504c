"""F12 fills the light passes the View Layer asks for (#33): Blender registers them for the
compositor, the render writes them into its result (read back from the multilayer EXR F12
saves), with the values the tracer makes for the scene."""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import registration  # noqa: E402
from support.render_passes import (FLOOR, f12_against_tracer, lamp_over_floor,  # noqa: E402
                                   registered_passes)

SWITCHES = ("use_pass_emit", "use_pass_environment", "use_pass_diffuse_direct",
            "use_pass_diffuse_color", "use_pass_glossy_indirect")
NAMES = ("Emission", "Environment", "Diffuse Direct", "Diffuse Color", "Glossy Indirect")


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


def build(tmp_path):
    """A diffuse floor under a point lamp and a blue world, Snell the engine, five of
    the light passes switched on, F12 saving a multilayer EXR."""
    scene = lamp_over_floor(tmp_path / "f12.exr")
    for switch in SWITCHES:
        setattr(scene.view_layers[0], switch, True)
    return scene


def test_the_light_passes_are_registered_for_the_compositor(tmp_path):
    registered = registered_passes(build(tmp_path))
    for name in NAMES:
        assert (name, 3, "RGB", "COLOR") in registered, registered
    assert not any(name == "Glossy Color" for name, *_ in registered)


def test_f12_writes_the_light_passes(tmp_path):
    """The passes in F12's EXR are the tracer's for the exported scene. Deliberate error: the
    rows written top first (no flip to Blender's bottom-first rows) fails it, 180 of 576
    values off by up to 0.5."""
    build(tmp_path)
    written, _ = f12_against_tracer(tmp_path / "f12.exr", NAMES, "light_pass_images",
                                    light_passes=True)
    color = written["Diffuse Color"]
    # Pixels the floor covers have its colour exactly (edge pixels a share of it).
    inside = np.all(np.isclose(color, FLOOR, atol=1e-6), axis=-1)
    assert inside.sum() > 20 and np.all(color <= np.array(FLOOR) + 1e-6)
    assert written["Environment"].max() > 0.1 and written["Diffuse Direct"].max() > 0.1
