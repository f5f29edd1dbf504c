"""Snell's Denoising Albedo and Denoising Normal passes (tracer/features.py) against Cycles' own
(View Layer > Passes > Data > Denoising Data), with the validator's statistics: both are Monte
Carlo estimates over the same paths' first rough surface.

The scene is the Cornell box (red and green walls) with three spheres: smooth glass, a glossy
sphere of roughness 0.2 (alpha 0.04: specular by Cycles' rule, whose threshold is alpha 0.075)
and a Principled plastic of roughness 0.5 (rough); the passes through the glass and the glossy
sphere show the walls. Power: a glass of roughness 0.3 (the passes stop at the glass instead of
going through it), a glossy sphere of roughness 0.28 (just past the threshold) and a red wall
5% too bright must each be inconsistent.
"""
from __future__ import annotations

import copy
import importlib

import pytest

from support.cycles_reference import PassesReference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
PASSES = ("Denoising Albedo", "Denoising Normal")


def build(path):
    """The Cornell box with a glass, a glossy and a plastic sphere, 96x64."""
    scene = common.reset()
    common.setup_render(scene)
    common.cornell_box()
    specs = [("Glass", "glass", (1.0, 1.0, 1.0), {"IOR": 1.5}),
             ("Glossy", "glossy", (0.95, 0.75, 0.55), {"Roughness": 0.2}),
             ("Plastic", "principled", (0.2, 0.4, 0.8), {"Roughness": 0.5})]
    for (name, kind, color, inputs), x in zip(specs, (-0.62, 0.0, 0.62)):
        common.uv_sphere(name, (x, 0.0, 0.28), 0.28, common.material(name, kind, color, **inputs))
    scene.render.resolution_x, scene.render.resolution_y = 96, 64
    common.camera(scene, (0.0, -2.4, 0.75), (0.0, 0.0, 0.45), lens=43.0)
    return common.save(path)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return PassesReference(build(str(tmp_path_factory.mktemp("passes") / "passes.blend")),
                           framing=FULL)


def _with_material(name, **fields):
    """A modify function: the Snell scene with one material's fields changed."""
    def modify(scene):
        other = copy.copy(scene)
        other.materials = [dict(m, **fields) if m["name"] == name else m for m in scene.materials]
        return other
    return modify


def _material(scene, name):
    (material,) = [m for m in scene.materials if m["name"] == name]
    return material


def test_the_passes_agree_with_cycles(reference):
    results = reference.compare()
    for name in PASSES:
        verdict, detail = _verdict(results[name])
        assert verdict == "consistent", (name, detail)


@pytest.mark.parametrize("change", ["glass rough", "glossy past the threshold", "red wall"])
def test_the_comparison_catches_deliberate_errors(reference, change):
    red = _material(reference.scene, "Red")
    modify = {"glass rough": _with_material("Glass", roughness=0.3),
              "glossy past the threshold": _with_material("Glossy", roughness=0.28),
              "red wall": _with_material("Red", color=[1.05 * c for c in red["color"]])}[change]
    results = reference.compare(modify)
    verdicts = {name: _verdict(results[name])[0] for name in PASSES}
    assert "inconsistent" in verdicts.values(), verdicts


def test_the_validator_never_sees_a_denoised_image(reference):
    """A file that denoises (Cycles' Denoise on, followed) is validated on its noisy estimate:
    compare renders neither the passes nor a denoised image, and its image is the render's own
    mean; no validator module calls the denoiser but the bench's denoised comparison
    (bench.py, whose page marks its denoised images as not tested). Teeth: an import of the
    denoiser added to compare.py fails it ({'bench.py', 'compare.py'}, measured)."""
    import ast
    import os

    import numpy as np

    from snell.validation import compare
    from support.paths import ROOT

    scene = reference.scene.with_render(denoise=True, denoising_passes=True)
    assert scene.settings().denoise
    result = compare.snell_render(scene, 16)
    assert not result.has_features
    plain = compare.snell_render(reference.scene, 16)
    assert np.array_equal(result.mean(), plain.mean())
    folder = os.path.join(ROOT, "validation")
    denoising = set()
    for name in sorted(os.listdir(folder)):
        if name.endswith(".py"):
            with open(os.path.join(folder, name)) as f:
                tree = ast.parse(f.read())
            imported = {f"{node.module or ''}.{alias.name}" for node in ast.walk(tree)
                        if isinstance(node, ast.ImportFrom) for alias in node.names}
            imported |= {f"{node.module or ''}" for node in ast.walk(tree)
                         if isinstance(node, ast.ImportFrom)}
            imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                         for alias in node.names}
            if any("denoise" in module for module in imported):
                denoising.add(name)
    assert denoising <= {"bench.py"}, denoising
