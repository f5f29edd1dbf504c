"""Node trees compiled to shader programs (addon/export/shader/), built with bpy in the test:
which materials become programs, and bad trees (a node loop, a group without an output, a
missing image, nodes Snell does not know) each with a warning naming material, node and input
and a defined fallback, and a render without NaN."""
import importlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402
from snell.tracer.integrator import Renderer  # noqa: E402
from snell.tracer.shader import closures, inputs  # noqa: E402

common = importlib.import_module("common")


@pytest.fixture
def bl():
    scene = common.reset()
    common.setup_render(scene, (16, 16))
    common.camera(scene, (0.0, -4.0, 0.0), (0.0, 0.0, 0.0))
    common.set_world(scene, (0.5, 0.5, 0.5))
    return scene


def _sphere(mat):
    return common.uv_sphere("Ball", (0.0, 0.0, 0.0), 1.0, mat, 16, 8)


def _mix(name, fac_node=None, fac_output=0):
    """Mix(Fac, Diffuse, Glossy), Fac linked to fac_node's output if given."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.25
    tree.links.new(tree.nodes.new("ShaderNodeBsdfDiffuse").outputs[0], mix.inputs[1])
    tree.links.new(tree.nodes.new("ShaderNodeBsdfGlossy").outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    if fac_node is not None:
        node = tree.nodes.new(fac_node)
        tree.links.new(node.outputs[fac_output], mix.inputs["Fac"])
    return mat, tree, mix


def _export():
    return export.export_depsgraph(bpy.context.evaluated_depsgraph_get())


def _render_is_finite(scene):
    result = Renderer(scene, scene.settings().replace(spp=4, max_depth=4)).render()
    image = result.mean()
    assert np.isfinite(image).all() and result.nan_count == 0
    return image


def test_a_fresnel_mix_becomes_a_program_without_warnings(bl):
    _sphere(_mix("FresnelMix", "ShaderNodeFresnel")[0])
    scene, warnings = _export()
    assert warnings == []
    (mat,) = scene.materials
    assert mat["kind"] == "program"
    ops = [row[0] for row in mat["program"]["code"]]
    assert ops == [inputs.FRESNEL, closures.MIX_CLOSURE, closures.DIFFUSE, closures.GLOSSY]
    _render_is_finite(scene)


def test_a_constant_mix_stays_one_material(bl):
    """A mix the fixed kinds render exactly (the same BSDF, colours mixed) is no program."""
    mat, tree, mix = _mix("Folded")
    tree.nodes.remove(tree.nodes["Glossy BSDF"])
    tree.links.new(tree.nodes.new("ShaderNodeBsdfDiffuse").outputs[0], mix.inputs[2])
    _sphere(mat)
    scene, warnings = _export()
    assert warnings == [] and scene.materials[0]["kind"] == "diffuse"


def test_a_node_snell_does_not_know_warns_and_uses_the_unlinked_value(bl):
    """A Wireframe factor: warned naming material, node and input; Fac 0.25 used."""
    _sphere(_mix("Wired", "ShaderNodeWireframe")[0])
    scene, warnings = _export()
    (warning,) = warnings
    assert "material 'Wired'" in warning and "'Wireframe'" in warning and "'Factor'" in warning
    program = scene.materials[0]["program"]
    mix_row = next(r for r in program["code"] if r[0] == closures.MIX_CLOSURE) \
        if any(r[0] == closures.MIX_CLOSURE for r in program["code"]) else None
    # The factor folded to its unlinked 0.25: the sides get constant weights 0.75 and 0.25.
    assert mix_row is None
    assert sorted(program["constants"]).count(0.25) == 1
    _render_is_finite(scene)


def test_a_shader_snell_does_not_know_renders_grey_diffuse_with_a_warning(bl):
    mat, tree, mix = _mix("Toon", "ShaderNodeFresnel")
    tree.links.new(tree.nodes.new("ShaderNodeBsdfToon").outputs[0], mix.inputs[2])
    _sphere(mat)
    scene, warnings = _export()
    (warning,) = warnings
    assert "'Toon BSDF'" in warning and "grey 0.8 diffuse" in warning
    assert [r[0] for r in scene.materials[0]["program"]["code"]].count(closures.DIFFUSE) == 2
    _render_is_finite(scene)


def test_a_node_loop_warns_and_renders(bl):
    """Fresnel IOR <- Layer Weight Fresnel, Layer Weight Blend <- Fresnel: Blender marks a link
    of the loop invalid, and Cycles reads that input unlinked; so does Snell, saying so."""
    mat, tree, mix = _mix("Loop", "ShaderNodeFresnel")
    fresnel = tree.nodes["Fresnel"]
    weight = tree.nodes.new("ShaderNodeLayerWeight")
    tree.links.new(weight.outputs["Fresnel"], fresnel.inputs["IOR"])
    tree.links.new(fresnel.outputs[0], weight.inputs["Blend"])
    _sphere(mat)
    scene, warnings = _export()
    assert any("loop" in w and "material 'Loop'" in w for w in warnings), warnings
    _render_is_finite(scene)


def test_a_group_without_an_output_is_no_closure(bl):
    """A group node whose tree has no Group Output on the Surface: nothing, as in Cycles (the
    sphere black against the grey world), with a warning."""
    group = bpy.data.node_groups.new("Empty", "ShaderNodeTree")
    group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
    mat, tree, mix = _mix("Grouped", "ShaderNodeFresnel")
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    tree.links.new(node.outputs[0], mix.inputs[1])
    _sphere(mat)
    scene, warnings = _export()
    assert any("'Group'" in w and "no Group Output" in w for w in warnings), warnings
    assert [r[0] for r in scene.materials[0]["program"]["code"]].count(closures.DIFFUSE) == 0
    _render_is_finite(scene)


def test_a_missing_image_is_magenta_with_a_warning(bl, tmp_path):
    """Cycles renders an image it cannot read magenta; so does a program."""
    mat, tree, mix = _mix("Missing", "ShaderNodeFresnel")
    tex = tree.nodes.new("ShaderNodeTexImage")
    image = bpy.data.images.new("gone.png", 4, 4)
    image.source = "FILE"
    image.filepath = str(tmp_path / "gone.png")      # a file that is not there
    tex.image = image
    tree.links.new(tex.outputs["Color"], tree.nodes["Diffuse BSDF"].inputs["Color"])
    _sphere(mat)
    scene, warnings = _export()
    assert any("gone.png" in w and "magenta" in w for w in warnings), warnings
    program = scene.materials[0]["program"]
    assert [1.0, 0.0, 1.0] == program["constants"][:3] or any(
        program["constants"][k:k + 3] == [1.0, 0.0, 1.0] for k in range(len(program["constants"])))
    _render_is_finite(scene)
