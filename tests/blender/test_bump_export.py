"""The Bump node and bump displacement compiled (addon/export/shader/normal_nodes.py,
closure_nodes.py, the Compiler's memo scopes), built with bpy in the test: the Height's nodes
compiled once per evaluation and shared with the rest of the tree at the hit, the moved copies
between OFFSET and RESTORE, a linked Filter Width warned, and a scene with bump renders without
NaN."""
import copy
import importlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402
from snell.tracer.integrator import Renderer  # noqa: E402
from snell.tracer.shader import bump, closures, procedural_textures  # noqa: E402

common = importlib.import_module("common")


@pytest.fixture
def scene():
    scene = common.reset()
    common.setup_render(scene, (16, 16))
    common.camera(scene, (0.0, -4.0, 0.5), (0.0, 0.0, 0.0))
    common.set_world(scene, (0.5, 0.5, 0.5))
    return scene


def _noise_bumped(name):
    """A Diffuse BSDF whose Color and Bump Height are the same Noise texture."""
    mat = common.material(name, "diffuse")
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname.startswith("ShaderNodeBsdf"))
    noise = tree.nodes.new("ShaderNodeTexNoise")
    node = tree.nodes.new("ShaderNodeBump")
    tree.links.new(noise.outputs["Fac"], node.inputs["Height"])
    tree.links.new(noise.outputs["Color"], bsdf.inputs["Color"])
    tree.links.new(node.outputs["Normal"], bsdf.inputs["Normal"])
    return mat, node


def _export():
    return export.export_depsgraph(bpy.context.evaluated_depsgraph_get())


def test_height_compiles_three_times_and_shares_the_hit_copy(scene):
    """Noise -> Bump Height and Noise -> Color: the noise at the hit is compiled once (the
    colour and the bump's first height read it) and twice more, each between OFFSET and
    RESTORE, as Cycles copies the Height's nodes; its texture coordinate too. (Deliberate
    error, measured: the moved copies compiled in the caller's memo scope give one Noise
    instruction, not three, and the bump reads the same height three times: fails.)"""
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    mat, _ = _noise_bumped("Noisy")
    plane.data.materials.append(mat)
    snell_scene, warnings = _export()
    assert warnings == []
    code = snell_scene.materials[0]["program"]["code"]
    ops = [row[0] for row in code]
    noises = [k for k, op in enumerate(ops) if op == procedural_textures.NOISE]
    offsets = [k for k, op in enumerate(ops) if op == bump.OFFSET]
    restores = [k for k, op in enumerate(ops) if op == bump.RESTORE]
    assert len(noises) == 3 and len(offsets) == 2 and len(restores) == 2
    assert noises[0] < offsets[0] < noises[1] < restores[0] < offsets[1] < noises[2] \
        < restores[1]
    assert [code[k][1] for k in offsets] == [bump.AXIS_X, bump.AXIS_Y]
    diffuse = next(row for row in code if row[0] == closures.DIFFUSE)
    bumped = next(row for row in code if row[0] == bump.BUMP)
    assert diffuse[3] == bumped[1]
    # The Diffuse's colour is written at the hit, before the moved copies.
    assert min(k for k, row in enumerate(code) if row[1] == diffuse[2]) < offsets[0]


def test_linked_filter_width_is_warned(scene):
    """Cycles reads the Filter Width's unlinked value when it builds the graph: a link there
    is warned, naming material, node and input."""
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    mat, node = _noise_bumped("Wide")
    value = mat.node_tree.nodes.new("ShaderNodeValue")
    mat.node_tree.links.new(value.outputs[0], node.inputs["Filter Width"])
    plane.data.materials.append(mat)
    _, warnings = _export()
    assert len(warnings) == 1
    assert "'Wide'" in warnings[0] and "'Bump'" in warnings[0] and "'Filter Width'" in \
        warnings[0]


def test_bumped_scene_renders_without_nan(scene):
    """A bumped plane and bump displacement on a sphere render finite, and the image differs
    without the sphere's SET_NORMAL (its bump displacement left out)."""
    bpy.ops.mesh.primitive_plane_add(size=2.0, rotation=(1.3, 0.0, 0.0))
    plane = bpy.context.active_object
    mat, node = _noise_bumped("Noisy")
    node.inputs["Distance"].default_value = 0.5
    plane.data.materials.append(mat)
    ball = common.uv_sphere("Ball", (0.8, -1.0, 0.3), 0.3, common.material("Shell", "glossy",
                                                                          Roughness=0.3), 16, 8)
    shell = ball.data.materials[0]
    disp = shell.node_tree.nodes.new("ShaderNodeDisplacement")
    noise = shell.node_tree.nodes.new("ShaderNodeTexNoise")
    shell.node_tree.links.new(noise.outputs["Fac"], disp.inputs["Height"])
    shell.node_tree.links.new(disp.outputs[0],
                              shell.node_tree.nodes["Material Output"].inputs["Displacement"])
    snell_scene, warnings = _export()
    assert warnings == []
    snell_scene = snell_scene.with_render(spp=4, max_depth=3)
    image = Renderer(snell_scene).render().mean()
    assert np.all(np.isfinite(image))
    flat = copy.copy(snell_scene)
    flat.materials = copy.deepcopy(snell_scene.materials)
    for m in flat.materials:
        if m["kind"] == "program":
            m["program"]["code"] = [row for row in m["program"]["code"]
                                    if row[0] != bump.SET_NORMAL]
    assert not np.allclose(Renderer(flat).render().mean(), image)


def test_height_through_a_node_group_compiles_three_times(scene):
    """A Noise inside a node group feeds the Bump's Height through the group's output: the
    group's nodes are flattened and compiled in each memo scope, three Noise instructions."""
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    group = bpy.data.node_groups.new("Heights", "ShaderNodeTree")
    group.interface.new_socket("Height", in_out="OUTPUT", socket_type="NodeSocketFloat")
    inner = group.nodes.new("ShaderNodeTexNoise")
    output = group.nodes.new("NodeGroupOutput")
    group.links.new(inner.outputs["Fac"], output.inputs[0])
    mat = common.material("Grouped", "diffuse")
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname.startswith("ShaderNodeBsdf"))
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    bumped = tree.nodes.new("ShaderNodeBump")
    tree.links.new(node.outputs[0], bumped.inputs["Height"])
    tree.links.new(bumped.outputs["Normal"], bsdf.inputs["Normal"])
    plane.data.materials.append(mat)
    snell_scene, warnings = _export()
    assert warnings == []
    ops = [row[0] for row in snell_scene.materials[0]["program"]["code"]]
    assert ops.count(procedural_textures.NOISE) == 3 and ops.count(bump.BUMP) == 1
