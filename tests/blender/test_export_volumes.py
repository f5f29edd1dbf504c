"""The exporter's Volume output (addon/export/volumes.py): each volume node's absorption as
Cycles computes it (svm/closure.h), Add and constant Mix Shaders of volumes, and a warning naming
material, node and input for what Snell does not render (scattering, emission, linked inputs,
other nodes, a world Volume)."""
import importlib

import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402
from snell.addon.export import materials  # noqa: E402

common = importlib.import_module("common")


@pytest.fixture
def bl():
    """An empty Blender scene with a camera."""
    scene = common.reset()
    common.camera(scene, (0.0, -10.0, 0.0), (0.0, 0.0, 0.0))
    return scene


def _export(mat):
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    obj = bpy.context.active_object
    obj.data.materials.append(mat)
    s, warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    bpy.data.objects.remove(obj)
    bpy.data.materials.remove(mat)
    return s.materials[0], warnings


def _glass_with_volume(idname, **inputs):
    """A glass material whose Volume is a new `idname` node with these inputs; (mat, node)."""
    mat = common.material("Cup", "glass", (1.0, 1.0, 1.0), IOR=1.33)
    tree = mat.node_tree
    node = tree.nodes.new(idname)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Volume"])
    return mat, node


def test_volume_absorption_is_one_minus_colour_times_density(bl):
    """svm_node_closure_volume: weight = 1 - Color, times Density. (Color x Density, the
    scattering formula, would give 0.4, 0.6, 0.8.)"""
    mat, _ = _glass_with_volume("ShaderNodeVolumeAbsorption", Color=(0.2, 0.3, 0.4, 1.0),
                                Density=2.0)
    m, warnings = _export(mat)
    assert warnings == []
    assert m["kind"] == "glass" and m["absorption"] == pytest.approx([1.6, 1.4, 1.2], rel=1e-6)


def test_principled_volume_absorption_and_its_scattering_warned(bl):
    """Absorption max(1 - C, 0) max(1 - sqrt(A), 0) x Density; its scattering C x Density is
    warned, not rendered."""
    mat, _ = _glass_with_volume("ShaderNodeVolumePrincipled", Color=(0.0, 0.0, 0.0, 1.0),
                                Density=3.0, **{"Absorption Color": (0.25, 0.49, 1.0, 1.0)})
    m, warnings = _export(mat)
    assert warnings == []
    assert m["absorption"] == pytest.approx([1.5, 0.9, 0.0], rel=1e-6)
    mat, _ = _glass_with_volume("ShaderNodeVolumePrincipled", Color=(0.5, 0.5, 0.5, 1.0),
                                Density=2.0, **{"Absorption Color": (0.0, 0.0, 0.0, 1.0)})
    m, warnings = _export(mat)
    assert m["absorption"] == pytest.approx([1.0, 1.0, 1.0], rel=1e-6)
    assert warnings == ["object 'Cube', material 'Cup': node 'Principled Volume': scatters light "
                        "(Color x Density 1, 1, 1): rendered without its scattering "
                        "(homogeneous scattering is not rendered yet)"]
    assert export.differs_from_cycles(warnings[0])


def test_volume_scatter_and_volume_emission_warn(bl):
    """Volume Scatter's extinction is all scattering: no absorption, one warning."""
    mat, _ = _glass_with_volume("ShaderNodeVolumeScatter")
    m, warnings = _export(mat)
    assert "absorption" not in m
    assert warnings == ["object 'Cube', material 'Cup': node 'Volume Scatter': scatters light: "
                        "rendered without its scattering (homogeneous scattering is not "
                        "rendered yet)"]
    mat, _ = _glass_with_volume("ShaderNodeEmission")
    m, warnings = _export(mat)
    assert "absorption" not in m
    assert warnings == ["object 'Cube', material 'Cup': node 'Emission': (ShaderNodeEmission) on "
                        "the Volume output is not a volume Snell renders: rendered without it "
                        "(the object's inside is clear)"]


def test_linked_density_warns_and_uses_its_value(bl):
    mat, node = _glass_with_volume("ShaderNodeVolumeAbsorption", Color=(0.5, 0.5, 0.5, 1.0),
                                   Density=4.0)
    noise = mat.node_tree.nodes.new("ShaderNodeTexNoise")
    mat.node_tree.links.new(noise.outputs[0], node.inputs["Density"])
    m, warnings = _export(mat)
    assert m["absorption"] == pytest.approx([2.0, 2.0, 2.0], rel=1e-6)
    assert warnings == ["object 'Cube', material 'Cup': node 'Volume Absorption': input "
                        "'Density' is linked to 'Noise Texture' (a procedural texture), which "
                        "Snell cannot evaluate: using its unlinked value 4"]


def test_add_and_mix_of_volumes(bl):
    """Add Shader sums; a Mix Shader of factor 0.25 weights its sides 0.75 and 0.25 (the mix
    weight multiplies the density)."""
    mat = common.material("Cup", "glass", (1.0, 1.0, 1.0), IOR=1.33)
    tree = mat.node_tree
    a = tree.nodes.new("ShaderNodeVolumeAbsorption")
    a.inputs["Color"].default_value = (0.0, 0.5, 1.0, 1.0)
    b = tree.nodes.new("ShaderNodeVolumeAbsorption")
    b.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    b.inputs["Density"].default_value = 2.0
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.25
    tree.links.new(a.outputs[0], mix.inputs[1])
    tree.links.new(b.outputs[0], mix.inputs[2])
    add = tree.nodes.new("ShaderNodeAddShader")
    c = tree.nodes.new("ShaderNodeVolumeAbsorption")
    c.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)
    tree.links.new(mix.outputs[0], add.inputs[0])
    tree.links.new(c.outputs[0], add.inputs[1])
    tree.links.new(add.outputs[0], tree.nodes["Material Output"].inputs["Volume"])
    m, warnings = _export(mat)
    assert warnings == []
    expected = [0.75 * (1 - x) + 0.25 * 2.0 * 0.5 + 0.1 for x in (0.0, 0.5, 1.0)]
    assert m["absorption"] == pytest.approx(expected, rel=1e-6)


def test_volume_without_surface_is_a_clear_boundary(bl):
    """A Volume alone: Cycles' boundary lets rays through; Snell renders an IOR-1 refraction
    around the absorption, and says that lamps' direct light does not pass it."""
    mat = bpy.data.materials.new("Smoke")
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new("ShaderNodeVolumeAbsorption")
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Volume"])
    m, warnings = _export(mat)
    assert m["kind"] == "refraction" and m["ior"] == 1.0
    assert m["absorption"] == pytest.approx([0.2, 0.2, 0.2], rel=1e-6)
    assert warnings == [f"object 'Cube', material 'Smoke': node 'Material Output': input "
                        f"'Surface' is not connected (a volume alone): {materials.VOLUME_ONLY}"]


def test_world_volume_scatter_warns(bl):
    world = common.set_world(bl, (0.1, 0.1, 0.1))
    fog = world.node_tree.nodes.new("ShaderNodeVolumeScatter")
    world.node_tree.links.new(fog.outputs[0], world.node_tree.nodes["World Output"].inputs["Volume"])
    _, warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert warnings == ["world 'World': node 'World Output': input 'Volume' is linked to "
                        "'Volume Scatter' (a volume), which Snell does not render: rendered "
                        "without it (clear air)"]
