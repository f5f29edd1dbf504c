"""Normal maps exported (addon/export/meshes.py, shader/normal_nodes.py), built with bpy in the
test: the tangent frame of a UV map as world-space texture coordinates, an n-gon mesh (MikkTSpace
runs over the triangles, as in Cycles), a mesh without UV maps through Cycles' sphere mapping,
the Bump node folded away, and the scene renders without NaN."""
import importlib
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402
from snell.tracer.integrator import Renderer  # noqa: E402
from snell.tracer.shader import bump as tracer_bump, normals  # noqa: E402

common = importlib.import_module("common")


def _normal_mapped(name, space="TANGENT"):
    mat = common.material(name, "diffuse")
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname.startswith("ShaderNodeBsdf"))
    node = tree.nodes.new("ShaderNodeNormalMap")
    node.space = space
    node.inputs["Color"].default_value = (0.8, 0.5, 0.9, 1.0)
    tree.links.new(node.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


@pytest.fixture
def scene():
    scene = common.reset()
    common.setup_render(scene, (16, 16))
    common.camera(scene, (0.0, -4.0, 0.5), (0.0, 0.0, 0.0))
    common.set_world(scene, (0.5, 0.5, 0.5))
    return scene


def _frame(snell_scene, kind):
    index = next(i for i, tc in enumerate(snell_scene.texcoords) if tc["kind"] == kind)
    return snell_scene.texcoords[index]["coords"].astype(np.float64)


def test_a_rotated_scaled_plane_exports_its_frame_in_world_space(scene):
    """A plane (UVs along its x and y, normal z) rotated 90 degrees about x and scaled (2, 1, 3):
    tangent M^-T x = (0.5, 0, 0) and normal M^-T z = (0, -1/3, 0) at every corner, sign 1 and
    G = det(M) (M M^T)^-1 = diag(1.5, 2/3, 6); no warning. (Deliberate error: the frame times M, as directions are
    transformed: tangent (2, 0, 0); caught.)"""
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    plane.data.materials.append(_normal_mapped("Mapped"))
    plane.rotation_euler = (math.pi / 2, 0.0, 0.0)
    plane.scale = (2.0, 1.0, 3.0)
    snell_scene, warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert warnings == []
    assert snell_scene.materials[0]["kind"] == "program"
    assert np.allclose(_frame(snell_scene, "tangent"), (0.5, 0.0, 0.0), atol=1e-6)
    signs = _frame(snell_scene, "tangent_sign")
    assert np.allclose(signs[:, :, 0], 1.0)
    assert np.allclose(signs[:, :, 1], (1.5, 2 / 3, 6.0), atol=1e-5)
    assert np.allclose(signs[:, :, 2], 0.0, atol=1e-5)
    assert np.allclose(_frame(snell_scene, "tangent_normal"), (0.0, -1 / 3, 0.0), atol=1e-6)
    code = snell_scene.materials[0]["program"]["code"]
    assert any(row[0] == normals.NORMAL_MAP_TANGENT for row in code)


def test_ngons_and_meshes_without_uvs_get_tangents_and_render(scene):
    """An n-gon disc (which Blender's MikkTSpace refuses as it is) and a UV-less sphere: unit
    tangents orthogonal to the normal, and a render without NaN; object and world spaces too."""
    bpy.ops.mesh.primitive_circle_add(vertices=8, fill_type="NGON", location=(-1.2, 0.0, 0.0),
                                      rotation=(math.pi / 2, 0.0, 0.0))
    bpy.context.active_object.data.materials.append(_normal_mapped("Disc"))
    ball = common.uv_sphere("Ball", (1.2, 0.0, 0.0), 0.8, _normal_mapped("Ball"), 16, 8)
    assert len(ball.data.uv_layers) == 0
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.0, 0.0, 1.2))
    bpy.context.active_object.data.materials.append(_normal_mapped("Object", "OBJECT"))
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.0, 0.0, -1.2))
    bpy.context.active_object.data.materials.append(_normal_mapped("World", "WORLD"))
    snell_scene, warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert warnings == []
    t = _frame(snell_scene, "tangent")
    n = _frame(snell_scene, "tangent_normal")
    mapped = np.linalg.norm(t, axis=2) > 0.0
    ids = snell_scene.material_ids
    names = [m["name"] for m in snell_scene.materials]
    for name in ("Disc", "Ball"):
        rows = ids == names.index(name)
        assert mapped[rows].all(), name
        assert np.allclose(np.linalg.norm(t[rows], axis=2), 1.0, atol=1e-5)
        assert np.abs(np.einsum("tci,tci->tc", t[rows], n[rows])).max() < 1e-4
    result = Renderer(snell_scene, snell_scene.settings().replace(spp=4, max_depth=4)).render()
    assert np.isfinite(result.mean()).all() and result.nan_count == 0


def test_bump_without_height_passes_the_normal_map_through(scene):
    """Normal Map -> Bump (Height unlinked) -> BSDF: Cycles folds the Bump away, so does the
    compiler (the BSDF reads the Normal Map's register); a Bump with a linked Height is
    evaluated (tracer/shader/bump.py), bending the Normal Map's normal, without a warning.
    (Deliberate error: the Bump node giving the shading normal even with its Normal linked: the
    Normal Map is left unread and warned; caught.)"""
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    mat = _normal_mapped("Bumped")
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname.startswith("ShaderNodeBsdf"))
    normal_map = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeNormalMap")
    bump = tree.nodes.new("ShaderNodeBump")
    tree.links.new(normal_map.outputs["Normal"], bump.inputs["Normal"])
    tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    plane.data.materials.append(mat)
    snell_scene, warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert warnings == []
    code = snell_scene.materials[0]["program"]["code"]
    mapped = next(row for row in code if row[0] == normals.NORMAL_MAP_TANGENT)
    assert code[-1][3] == mapped[1]            # the Diffuse BSDF's normal slot
    tree.links.new(tree.nodes.new("ShaderNodeTexNoise").outputs[0], bump.inputs["Height"])
    snell_scene, warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert warnings == []
    code = snell_scene.materials[0]["program"]["code"]
    mapped = next(row for row in code if row[0] == normals.NORMAL_MAP_TANGENT)
    bumped = next(row for row in code if row[0] == tracer_bump.BUMP)
    assert bumped[2] == mapped[1] and code[-1][3] == bumped[1]
