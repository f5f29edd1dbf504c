"""The exporter: scenes built with bpy in the test, exported through the evaluated depsgraph."""
import importlib
import math
import warnings as warnings_module

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402
from snell.addon.export import depsgraph, materials, meshes  # noqa: E402
from snell.tracer import scene as scene_mod  # noqa: E402
from snell.tracer.scene import SceneError  # noqa: E402
from support.shader_trees import mix_nodes, mix_shader_material  # noqa: E402

common = importlib.import_module("common")
graphs = importlib.import_module("node_materials")


@pytest.fixture
def bl():
    """An empty Blender scene with a camera."""
    scene = common.reset()
    common.camera(scene, (0.0, -10.0, 0.0), (0.0, 0.0, 0.0))
    return scene


def run():
    return export.export_depsgraph(bpy.context.evaluated_depsgraph_get())


def cube(name="Cube", mat=None, **kw):
    bpy.ops.mesh.primitive_cube_add(size=2.0, **kw)
    obj = bpy.context.active_object
    obj.name = name
    if mat is not None:
        obj.data.materials.append(mat)
    return obj


def geometric_normals(s):
    p = s.positions.astype(np.float64)[s.triangles]
    return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p.mean(axis=1)


def assert_outward(s, center):
    n, centroid = geometric_normals(s)
    assert np.all(np.sum(n * (centroid - center), axis=1) > 0)
    # Flat shading normals agree with the winding.
    vn = s.normals[s.triangles].mean(axis=1)
    assert np.all(np.sum(vn * n, axis=1) > 0)


# ---------------------------------------------------------------------------------------------
# Geometry


def test_curves_text_and_metaballs_export_their_mesh_once(bl):
    """Each reaches the depsgraph as itself and as its evaluated mesh instance: one copy only."""
    bpy.ops.object.text_add(location=(-3.0, 0.0, 0.0))
    bpy.ops.curve.primitive_bezier_circle_add(location=(0.0, 0.0, 0.0))
    bpy.context.active_object.data.bevel_depth = 0.1
    bpy.ops.object.metaball_add(location=(3.0, 0.0, 0.0))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    expected = 0
    for inst in depsgraph.object_instances:
        if inst.object.type == "MESH":
            inst.object.data.calc_loop_triangles()
            # Text has a few zero-area triangles; the exporter drops those.
            expected += sum(1 for t in inst.object.data.loop_triangles if t.area > 0)
    s, _ = run()
    assert expected > 0 and len(s.triangles) == expected
    assert len(s.objects) == 3


def test_cube_world_transform(bl):
    obj = cube(location=(1.0, 2.0, 3.0), rotation=(0.3, 0.5, 0.7))
    obj.scale = (1.0, 2.0, 0.5)
    s, warnings = run()
    assert s.triangles.shape == (12, 3)
    assert warnings == [f"object 'Cube', material '(none)': {materials.NO_MATERIAL}"]
    m = np.array(obj.matrix_world)
    local = np.array([v.co for v in obj.data.vertices])
    expected = local @ m[:3, :3].T + m[:3, 3]
    # Every world corner is exported (flat faces split vertices: 6 faces x 4 corners).
    assert len(s.positions) == 24
    d = np.linalg.norm(s.positions[:, None] - expected[None], axis=2).min(axis=1)
    assert d.max() < 1e-5
    assert_outward(s, m[:3, 3])
    # Normals: inverse transpose, unit length, and equal to the true face normals.
    n, _ = geometric_normals(s)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    assert np.allclose(np.linalg.norm(s.normals, axis=1), 1, atol=1e-5)
    assert np.allclose(s.normals[s.triangles[:, 0]], n, atol=1e-5)
    assert s.objects == [{"name": "Cube", "closed": True}]


def test_negative_scale_flips_winding(bl):
    obj = cube(location=(0.0, 0.0, 0.0))
    obj.scale = (-1.0, 1.5, 1.0)
    s, _ = run()
    assert_outward(s, np.zeros(3))


def test_linked_duplicates_each_with_its_own_matrix(bl):
    # One mesh, three objects (one mirrored) with another mesh in between: transformed together.
    a = cube("A", location=(-4.0, 0.0, 0.0))
    common.uv_sphere("Ball", (0.0, 0.0, 4.0), 1.0, common.material("M", "diffuse"), 8, 4)
    for name, x, scale in (("B", 0.0, (-1.0, 2.0, 1.0)), ("C", 4.0, (0.5, 0.5, 0.5))):
        dup = a.copy()
        dup.name, dup.location, dup.scale = name, (x, 0.0, 0.0), scale
        bl.collection.objects.link(dup)
    s, _ = run()
    assert sorted(o["name"] for o in s.objects) == ["A", "B", "Ball", "C"]
    for i, o in enumerate(s.objects):
        obj = bpy.data.objects[o["name"]]
        t = s.triangles[s.object_ids == i]
        n, centroid = geometric_normals(s)
        n, centroid = n[s.object_ids == i], centroid[s.object_ids == i]
        assert np.all(np.sum(n * (centroid - np.array(obj.location)), axis=1) > 0), o["name"]
        if o["name"] != "Ball":
            corners = s.positions[t].reshape(-1, 3) - np.array(obj.location)
            assert np.allclose(np.abs(corners).max(axis=0), np.abs(obj.scale), atol=1e-6)


def test_instancing_converts_each_mesh_once(bl, monkeypatch):
    calls = []
    original = depsgraph.mesh_arrays
    monkeypatch.setattr(depsgraph, "mesh_arrays", lambda obj, *a: calls.append(obj.name) or original(obj, *a))
    a = cube("A", location=(-3.0, 0.0, 0.0))
    b = a.copy()
    b.name = "B"
    b.location = (3.0, 0.0, 0.0)
    bl.collection.objects.link(b)
    # A collection instance of A as a third copy.
    coll = bpy.data.collections.new("Src")
    coll.objects.link(a)
    empty = bpy.data.objects.new("Inst", None)
    empty.instance_type = "COLLECTION"
    empty.instance_collection = coll
    empty.location = (0.0, 0.0, 5.0)
    bl.collection.objects.link(empty)
    s, _ = run()
    assert len(calls) == 1
    assert s.triangles.shape == (36, 3)
    assert sorted(o["name"] for o in s.objects) == ["A", "B", "Inst/A"]
    centers = sorted(tuple(np.round(s.positions[s.triangles[s.object_ids == i]].reshape(-1, 3)
                                    .mean(axis=0), 4)) for i in range(3))
    assert centers == [(-3.0, 0.0, 0.0), (-3.0, 0.0, 5.0), (3.0, 0.0, 0.0)]


def test_modifiers_are_applied(bl):
    obj = cube()
    obj.modifiers.new("Sub", "SUBSURF").levels = 1
    s, _ = run()
    assert s.triangles.shape == (48, 3)


def test_smooth_and_flat_normals(bl):
    mat = common.material("M", "diffuse")
    sphere = common.uv_sphere("Smooth", (5.0, 0.0, 0.0), 1.0, mat, segments=16, rings=8)
    s, _ = run()
    # Smooth: one vertex per mesh vertex, normals radial.
    assert len(s.positions) == len(sphere.data.vertices)
    radial = s.positions - np.array([5.0, 0.0, 0.0])
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    assert np.all(np.sum(s.normals * radial, axis=1) > 0.995)
    assert np.allclose(np.linalg.norm(s.normals, axis=1), 1, atol=1e-5)
    sphere.data.shade_flat()
    s, _ = run()
    n, _ = geometric_normals(s)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    for k in range(3):
        assert np.allclose(s.normals[s.triangles[:, k]], n, atol=1e-4)


def test_split_vertices_one_vertex_per_distinct_normal():
    # Reference: np.unique over (vertex, normal bits), the exporter's former rule.
    rng = np.random.default_rng(3)
    palette = np.array([[0, 0, 1], [0, 0, -1], [-0.0, 0, 1], [np.nan, 0, 0], [1, 0, 0]],
                       np.float32)
    verts = rng.integers(0, 50, 2000).astype(np.int32)
    normals = palette[rng.integers(0, len(palette), 2000)]
    # Vertex 60 carries 20 distinct normals: more than the rounds, so the sort finishes it.
    verts[:40] = 60
    normals[:40] = np.repeat(rng.normal(size=(20, 3)).astype(np.float32), 2, axis=0)
    slot = meshes._split_vertices(verts, normals, 70)
    keys = np.empty(len(verts), [("v", np.int32), ("n", np.uint32, 3)])
    keys["v"], keys["n"] = verts, normals.view(np.uint32)
    _, inverse = np.unique(keys.view(np.dtype((np.void, 16))), return_inverse=True)
    inverse = inverse.reshape(-1)
    # Same partition of the corners: slot and inverse determine each other.
    assert len(np.unique(slot)) == len(np.unique(inverse))
    assert len(np.unique(np.stack([slot, inverse]), axis=1).T) == len(np.unique(inverse))
    triangles, first = meshes._compact(slot, np.arange(2000).reshape(-1, 2))
    assert np.array_equal(triangles.ravel(), np.unique(slot, return_inverse=True)[1].reshape(-1))
    assert np.array_equal(slot[first], np.unique(slot))


@pytest.mark.parametrize("tris,closed", [
    ([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]], True),  # tetrahedron
    ([[0, 1, 2], [0, 2, 3], [0, 3, 1]], False),  # open
    ([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2], [1, 2, 4]], False),  # an edge of three
    ([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2], [1, 2, 3]], False),  # a face twice
    ([[0, 1, 2], [2, 1, 0]], True),  # two-sided triangle: every edge twice
    (np.zeros((0, 3), int), False),
])
def test_is_closed(tris, closed):
    assert meshes._is_closed(np.array(tris, np.int32).reshape(-1, 3), 5) is closed


def test_material_slots_per_triangle(bl):
    red = common.material("Red", "diffuse", (1.0, 0.0, 0.0))
    green = common.material("Green", "diffuse", (0.0, 1.0, 0.0))
    obj = cube(mat=red)
    obj.data.materials.append(green)
    mi = np.array([0, 1, 0, 1, 1, 1], np.int32)
    obj.data.polygons.foreach_set("material_index", mi)
    obj.data.update()
    s, _ = run()
    names = [s.materials[i]["name"] for i in s.material_ids]
    # Triangles come in polygon order, two per quad.
    assert names == [["Red", "Green"][i] for i in np.repeat(mi, 2)]


def test_zero_area_triangles_dropped(bl):
    verts = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (2, 0, 0)]
    common.mesh_object("Sliver", verts, [[0, 1, 2], [0, 1, 3]], common.material("M", "diffuse"))
    s, warnings = run()
    assert s.triangles.shape == (1, 3)
    assert any("'Sliver'" in w and "1 zero-area" in w for w in warnings)
    # No pixel of either renderer sees a zero-area triangle: not a reason for "not comparable".
    assert not any(export.differs_from_cycles(w) for w in warnings if "'Sliver'" in w)


def test_nan_matrix_names_the_object(bl):
    obj = cube("Broken")
    obj.location = (float("nan"), 0.0, 0.0)
    with pytest.raises(SceneError, match="Broken"):
        run()


def test_hidden_from_render_skipped(bl):
    cube("Shown")
    cube("Hidden", location=(3.0, 0.0, 0.0)).hide_render = True
    coll = bpy.data.collections.new("Off")
    bl.collection.children.link(coll)
    coll.hide_render = True
    in_coll = cube("InHiddenCollection", location=(-3.0, 0.0, 0.0))
    bl.collection.objects.unlink(in_coll)
    coll.objects.link(in_coll)
    s, _ = run()
    assert [o["name"] for o in s.objects] == ["Shown"]
    # Instances of a hidden source collection still render.
    empty = bpy.data.objects.new("Inst", None)
    empty.instance_type, empty.instance_collection = "COLLECTION", coll
    bl.collection.objects.link(empty)
    s, _ = run()
    assert sorted(o["name"] for o in s.objects) == ["Inst/InHiddenCollection", "Shown"]


def test_export_blend_uses_render_visibility(tmp_path):
    common.reset()
    common.camera(bpy.context.scene, (0.0, -10.0, 0.0), (0.0, 0.0, 0.0))
    obj = cube("ViewportOff")
    obj.hide_viewport = True
    obj.modifiers.new("Sub", "SUBSURF").render_levels = 1
    obj.modifiers["Sub"].levels = 0
    path = common.save(str(tmp_path / "vis.blend"))
    s, _ = export.export_blend(path)
    assert s.triangles.shape == (48, 3)


def test_no_camera(bl):
    cube()
    bl.camera = None
    with pytest.raises(SceneError, match="has no camera"):
        run()


# ---------------------------------------------------------------------------------------------
# Materials


def exported_material(bl, mat, name="Obj"):
    obj = cube(name, mat=mat)
    s, warnings = run()
    bpy.data.objects.remove(obj)
    return s.materials[0], warnings


@pytest.mark.parametrize("kind,values,expected", [
    ("diffuse", {}, {"kind": "diffuse", "color": [0.2, 0.4, 0.6]}),
    ("glossy", {"Roughness": 0.0}, {"kind": "glossy", "color": [0.2, 0.4, 0.6], "roughness": 0.0,
                                    "distribution": "multi_ggx"}),
    ("glossy", {"Roughness": 0.3}, {"kind": "glossy", "color": [0.2, 0.4, 0.6], "roughness": 0.3,
                                    "distribution": "multi_ggx"}),
    ("glass", {"IOR": 1.33}, {"kind": "glass", "color": [0.2, 0.4, 0.6], "ior": 1.33,
                              "transmission_color": [0.2, 0.4, 0.6], "roughness": 0.0,
                              "distribution": "multi_ggx"}),
    ("glass", {"IOR": 1.5, "Roughness": 0.2}, {
        "kind": "glass", "color": [0.2, 0.4, 0.6], "ior": 1.5, "transmission_color": [0.2, 0.4, 0.6],
        "roughness": 0.2, "distribution": "multi_ggx"}),
    ("refraction", {"IOR": 1.2}, {"kind": "refraction", "color": [0.2, 0.4, 0.6], "ior": 1.2,
                                  "roughness": 0.0, "distribution": "beckmann"}),
    ("refraction", {"IOR": 1.2, "Roughness": 0.4}, {
        "kind": "refraction", "color": [0.2, 0.4, 0.6], "ior": 1.2, "roughness": 0.4,
        "distribution": "beckmann"}),
    ("emission", {"Strength": 7.0}, {"kind": "emission", "color": [0.2, 0.4, 0.6], "strength": 7.0}),
])
def test_material_mapping(bl, kind, values, expected):
    m, warnings = exported_material(bl, common.material("M", kind, (0.2, 0.4, 0.6), **values))
    assert warnings == []
    assert m.pop("name") == "M"
    assert set(m) == set(expected)
    for key in ("kind", "distribution"):
        assert m.pop(key, None) == expected.pop(key, None)
    for key, value in expected.items():
        assert np.allclose(m[key], value, atol=1e-6), key


def bsdf(mat):
    """The one shader node of a material built by common.material."""
    return next(n for n in mat.node_tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial")


def enum_items(node, prop):
    return {item.identifier for item in node.bl_rna.properties[prop].enum_items}


def unlinked_value(sock):
    """A socket's own value: its number, or its colour's RGB."""
    value = sock.default_value
    return list(value)[:3] if sock.type == "RGBA" else value


@pytest.mark.parametrize("kind, blender, snell", [
    ("glossy", "GGX", "ggx"), ("glossy", "MULTI_GGX", "multi_ggx"),
    ("glossy", "BECKMANN", "beckmann"),
    ("glass", "GGX", "ggx"), ("glass", "MULTI_GGX", "multi_ggx"), ("glass", "BECKMANN", "beckmann"),
    ("refraction", "GGX", "ggx"), ("refraction", "BECKMANN", "beckmann"),
    ("principled", "GGX", "ggx"), ("principled", "MULTI_GGX", "multi_ggx"),
])
def test_distributions(bl, kind, blender, snell):
    mat = common.material("M", kind, (0.5, 0.5, 0.5), Roughness=0.3)
    bsdf(mat).distribution = blender
    m, warnings = exported_material(bl, mat)
    assert warnings == [] and m["distribution"] == snell


def test_every_distribution_blender_offers_is_mapped(bl):
    """Blender's enum identifiers on each node: all mapped, Ashikhmin-Shirley with a warning."""
    offered = {kind: enum_items(bsdf(common.material(kind, kind)), "distribution")
               for kind in ("glossy", "glass", "refraction", "principled")}
    assert offered == {"glossy": {"GGX", "MULTI_GGX", "BECKMANN", "ASHIKHMIN_SHIRLEY"},
                       "glass": {"GGX", "MULTI_GGX", "BECKMANN"},
                       "refraction": {"GGX", "BECKMANN"}, "principled": {"GGX", "MULTI_GGX"}}
    for kind, identifiers in offered.items():
        assert {materials.BLENDER_DISTRIBUTIONS[i] for i in identifiers - {"ASHIKHMIN_SHIRLEY"}} \
            == set(scene_mod.MATERIAL_DISTRIBUTIONS[kind])
    mat = common.material("Brushed", "glossy", (0.5, 0.5, 0.5), Roughness=0.3)
    bsdf(mat).distribution = "ASHIKHMIN_SHIRLEY"
    m, warnings = exported_material(bl, mat, "Pot")
    assert m["kind"] == "glossy" and m["distribution"] == "ggx"
    assert warnings == ["object 'Pot', material 'Brushed': node 'Glossy BSDF': distribution "
                        "ASHIKHMIN_SHIRLEY is not supported, rendered as GGX"]


@pytest.mark.parametrize("kind", ["glossy", "glass", "refraction", "principled"])
def test_scene_file_defaults_are_blenders(kind):
    """MATERIAL_DEFAULTS holds the installed Blender's node defaults (glass and refraction: the
    smooth surface a version 2 file means, which is also the nodes' default)."""
    tree = bpy.data.materials.new("Defaults").node_tree
    node = tree.nodes.new({"glossy": "ShaderNodeBsdfGlossy", "glass": "ShaderNodeBsdfGlass",
                           "refraction": "ShaderNodeBsdfRefraction",
                           "principled": "ShaderNodeBsdfPrincipled"}[kind])
    inputs = materials.PRINCIPLED_INPUTS if kind == "principled" else {"roughness": "Roughness"}
    for field, default in scene_mod.MATERIAL_DEFAULTS[kind].items():
        if field == "distribution":
            assert materials.BLENDER_DISTRIBUTIONS[node.distribution] == default
        else:
            value = node.inputs[inputs[field]].default_value
            assert np.allclose(value[:3] if isinstance(default, list) else value, default, atol=1e-6), field


def test_blenders_default_material_is_principled_with_its_defaults(bl):
    """A new material as Blender makes it (a Principled BSDF at its defaults), as Cycles renders it."""
    mat = bpy.data.materials.new("Default")
    with warnings_module.catch_warnings():
        warnings_module.simplefilter("ignore", DeprecationWarning)   # use_nodes goes in Blender 6
        mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    m, warnings = exported_material(bl, mat)
    assert warnings == []
    assert m["kind"] == "principled"
    for field, socket in materials.PRINCIPLED_INPUTS.items():
        assert np.allclose(m[field], unlinked_value(node.inputs[socket])), field
    assert m["distribution"] == materials.BLENDER_DISTRIBUTIONS[node.distribution]


PRINCIPLED_VALUES = {   # a principled material with every input away from its default
    "Metallic": 0.25, "Roughness": 0.3, "IOR": 1.6, "Specular IOR Level": 0.7,
    "Specular Tint": (0.9, 0.8, 0.7, 1.0), "Transmission Weight": 0.4, "Coat Weight": 0.2,
    "Coat Roughness": 0.1, "Coat IOR": 1.7, "Coat Tint": (0.6, 0.7, 0.8, 1.0),
    "Emission Color": (1.0, 0.5, 0.25, 1.0), "Emission Strength": 3.0}


def test_principled_fields_come_from_their_inputs(bl):
    mat = common.material("P", "principled", (0.2, 0.3, 0.4), **PRINCIPLED_VALUES)
    bsdf(mat).distribution = "GGX"
    m, warnings = exported_material(bl, mat)
    assert warnings == []
    assert m.pop("name") == "P" and m.pop("kind") == "principled" and m.pop("distribution") == "ggx"
    assert np.allclose(m.pop("color"), [0.2, 0.3, 0.4])
    assert set(m) == set(materials.PRINCIPLED_INPUTS) - {"color"}
    for field, value in m.items():
        given = PRINCIPLED_VALUES[materials.PRINCIPLED_INPUTS[field]]
        assert np.allclose(value, given[:3] if isinstance(given, tuple) else given), field


@pytest.mark.parametrize("socket, value, field, expected", [
    ("Roughness", 1.5, "roughness", 1.0), ("Metallic", -0.5, "metallic", 0.0),
    ("Transmission Weight", 2.0, "transmission", 1.0), ("Coat Roughness", 3.0, "coat_roughness", 1.0),
    ("IOR", -1.0, "ior", 1e-5), ("Coat IOR", 0.5, "coat_ior", 1.0),
    ("Specular IOR Level", -1.0, "specular_ior_level", 0.0), ("Coat Weight", -1.0, "coat_weight", 0.0),
    ("Emission Strength", -2.0, "emission_strength", 0.0),
])
def test_principled_inputs_are_clamped_as_cycles_clamps_them(bl, socket, value, field, expected):
    """Python can set inputs beyond the sliders' ranges; Cycles clamps them, and so does the
    exporter, so that the scene file's ranges hold."""
    m, warnings = exported_material(bl, common.material("P", "principled", **{socket: value}))
    assert warnings == [] and m[field] == pytest.approx(expected)


SMOOTH_GLASS = {"Transmission Weight": 1.0, "Roughness": 0.0, "IOR": 1.45}


def test_principled_smooth_glass_is_glass(bl):
    """Full transmission, smooth, white, nothing on top: Cycles' exact smooth glass, the kind the
    validator has always held it as."""
    m, warnings = exported_material(bl, common.material("PGlass", "principled", (1.0, 1.0, 1.0),
                                                        **SMOOTH_GLASS))
    assert warnings == []
    assert m == {"name": "PGlass", "kind": "glass", "color": [1.0, 1.0, 1.0],
                 "transmission_color": [1.0, 1.0, 1.0], "ior": pytest.approx(1.45)}


@pytest.mark.parametrize("base, roughness, tint", [
    ((0.8, 0.8, 0.8), 0.0, [0.8 ** 0.5] * 3),                 # the node's default base colour
    ((0.25, 0.64, 0.04), 0.0, [0.5, 0.8, 0.2]),
    ((2.0, 0.25, -1.0), 0.0, [1.0, 0.5, 0.0]),                # clamped to [0, 1] first
    ((0.25, 0.64, 0.04), 0.003, [0.5, 0.8, 0.2]),             # Cycles' perfect dielectric
])
@pytest.mark.parametrize("level", [0.5, 0.2])      # the level weighs a layer of no weight here
def test_principled_tinted_smooth_glass_is_glass_tinted_in_transmission(bl, base, roughness, tint,
                                                                       level):
    """A base colour tints Cycles' Principled glass in transmission only, by its square root:
    glass with that transmission colour, a caster for the light tracer."""
    m, warnings = exported_material(bl, common.material(
        "Tinted", "principled", base,
        **{**SMOOTH_GLASS, "Roughness": roughness, "Specular IOR Level": level}))
    assert warnings == [] and m["kind"] == "glass", m
    assert m["color"] == [1.0, 1.0, 1.0] and m["ior"] == pytest.approx(1.45)
    assert m["transmission_color"] == pytest.approx(tint, abs=1e-6)


@pytest.mark.parametrize("change", [
    {"Transmission Weight": 0.99}, {"Metallic": 0.01}, {"Coat Weight": 0.01}, {"Roughness": 0.05},
    {"Specular Tint": (1.0, 1.0, 0.9, 1.0)}, {"Emission Strength": 1.0},
])
def test_principled_glass_with_anything_more_is_principled(bl, change):
    m, _ = exported_material(bl, common.material("P", "principled", (0.9, 1.0, 1.0),
                                                 **{**SMOOTH_GLASS, **change}))
    assert m["kind"] == "principled"


@pytest.mark.parametrize("kind, socket, value, rendered", [
    ("principled", "Sheen Weight", 0.5, "sheen is ignored"),
    ("principled", "Subsurface Weight", 0.5, "subsurface scattering is rendered as the diffuse base"),
    ("principled", "Thin Film Thickness", 300.0, "thin film interference is ignored"),
    ("principled", "Anisotropic", 0.5, "rendered isotropic"),
    ("principled", "Diffuse Roughness", 0.5, "Oren-Nayar diffuse is rendered as Lambert"),
    ("glossy", "Anisotropy", -0.3, "rendered isotropic"),
    ("glass", "Thin Film Thickness", 300.0, "thin film interference is ignored"),
    ("diffuse", "Roughness", 0.5, "Oren-Nayar diffuse is rendered as Lambert"),
])
def test_inputs_snell_does_not_render_warn_naming_material_node_and_input(bl, kind, socket, value,
                                                                         rendered):
    mat = common.material("Odd", kind, (0.5, 0.5, 0.5), **{socket: value})
    m, warnings = exported_material(bl, mat, "OddObj")
    node = bsdf(mat).name
    assert warnings == [f"object 'OddObj', material 'Odd': node {node!r}: input {socket!r} is "
                        f"{value:g}: {rendered}"]
    # At the input's neutral value nothing is said.
    bsdf(mat).inputs[socket].default_value = 0.0
    assert exported_material(bl, mat)[1] == []


def test_principled_alpha_makes_a_program(bl):
    """Alpha below 1 is a transparent share of the surface, which a program renders."""
    from snell.tracer.shader import closures
    mat = common.material("Leafy", "principled", (0.5, 0.5, 0.5), Alpha=0.5)
    m, warnings = exported_material(bl, mat, "LeafObj")
    assert warnings == [] and m["kind"] == "program"
    assert [row[0] for row in m["program"]["code"]] == [closures.PRINCIPLED]


def link(mat, socket, idname="ShaderNodeTexNoise"):
    """Feed the shader's input from a new node (a texture by default)."""
    source = mat.node_tree.nodes.new(idname)
    mat.node_tree.links.new(source.outputs[0], bsdf(mat).inputs[socket])
    return source


@pytest.mark.parametrize("kind, socket, field, shown", [
    ("principled", "Metallic", "metallic", "0.75"),
    ("principled", "Base Color", "color", "(0.2, 0.4, 0.6)"),
    ("principled", "Coat Tint", "coat_tint", "(1, 1, 1)"),
    ("glossy", "Roughness", "roughness", "0.75"),
    ("glass", "IOR", "ior", "1.5"),
])
def test_a_linked_input_uses_its_unlinked_value(bl, kind, socket, field, shown):
    values = {"Metallic": 0.75} if kind == "principled" else {"Roughness": 0.75}
    mat = common.material("Tex", kind, (0.2, 0.4, 0.6), **values)
    # A node no program evaluates either (a Noise Texture is compiled into a program now):
    # the fixed kind stays, with its input's unlinked value.
    wire = link(mat, socket, "ShaderNodeWireframe")
    m, warnings = exported_material(bl, mat, "TexObj")
    assert np.allclose(m[field], unlinked_value(bsdf(mat).inputs[socket]))
    assert warnings == [f"object 'TexObj', material 'Tex': node {bsdf(mat).name!r}: input "
                        f"{socket!r} is linked to {wire.name!r} (ShaderNodeWireframe), which "
                        f"Snell cannot evaluate: "
                        f"using its unlinked value {shown}"]
    bsdf(mat).inputs[socket].links[0].is_muted = True   # a muted link passes nothing: no warning
    assert exported_material(bl, mat)[1] == []


def constant_node(mat, socket, value):
    """Feed the shader's input from a new Value node (a number) or RGB node (a colour)."""
    idname = "ShaderNodeRGB" if isinstance(value, tuple) else "ShaderNodeValue"
    node = link(mat, socket, idname)
    node.outputs[0].default_value = value
    return node


def test_value_and_rgb_nodes_are_their_constants(bl):
    """A Value or RGB node linked to an input is its constant, as Cycles folds it: a Glass
    BSDF whose Color is an RGB node, IOR a Value node and Roughness an RGB node (its
    luminance) stays glass, without a warning, where it used to be a shader program."""
    mat = common.material("Constants", "glass", (1.0, 1.0, 1.0), IOR=9.0, Roughness=0.9)
    constant_node(mat, "Color", (0.2, 0.5, 0.9, 1.0))
    constant_node(mat, "IOR", 1.33)
    constant_node(mat, "Roughness", (0.1, 0.1, 0.1, 1.0))
    m, warnings = exported_material(bl, mat)
    assert warnings == [] and m["kind"] == "glass"
    assert m["color"] == pytest.approx([0.2, 0.5, 0.9])
    assert m["ior"] == pytest.approx(1.33) and m["roughness"] == pytest.approx(0.1, rel=1e-5)


def test_a_nan_value_node_names_the_node_it_comes_from(bl):
    mat = common.material("NanIor", "glass", IOR=1.5)
    constant_node(mat, "IOR", float("nan")).name = "IOR Value"
    with pytest.raises(SceneError) as caught:
        exported_material(bl, mat)
    assert str(caught.value).endswith(f"material 'NanIor': node {bsdf(mat).name!r}: input 'IOR' "
                                      "is nan from node 'IOR Value' (not a number)")


@pytest.mark.parametrize("kind", ["principled", "glossy", "glass", "refraction", "diffuse"])
def test_a_bump_with_a_height_on_a_normal_is_a_program(bl, kind):
    """A Bump node of linked Height on a BSDF's Normal: the material is a program that
    evaluates it (tracer/shader/bump.py), without a warning."""
    from snell.tracer.shader import bump
    mat = common.material("Bumpy", kind, (0.5, 0.5, 0.5))
    source = link(mat, "Normal", "ShaderNodeBump")
    noise = mat.node_tree.nodes.new("ShaderNodeTexNoise")
    mat.node_tree.links.new(noise.outputs[0], source.inputs["Height"])
    m, warnings = exported_material(bl, mat, "BumpyObj")
    assert warnings == [] and m["kind"] == "program"
    assert any(row[0] == bump.BUMP for row in m["program"]["code"])


@pytest.mark.parametrize("kind, socket, rendered", [
    ("principled", "Coat Normal", "shaded with the mesh's normals"),
    ("principled", "Tangent", "rendered isotropic"),
    ("glossy", "Tangent", "rendered isotropic"),
])
def test_linked_normals_and_tangents_are_ignored_with_a_warning(bl, kind, socket, rendered):
    mat = common.material("Bumpy", kind, (0.5, 0.5, 0.5))
    source = link(mat, socket, "ShaderNodeBump" if "Normal" in socket else "ShaderNodeTangent")
    if "Normal" in socket:
        # A Bump with a height (without one it folds away, as in Cycles, and renders exactly).
        noise = mat.node_tree.nodes.new("ShaderNodeTexNoise")
        mat.node_tree.links.new(noise.outputs[0], source.inputs["Height"])
    _, warnings = exported_material(bl, mat, "BumpyObj")
    shown = "'Bump' (a bump map)" if "Normal" in socket else "'Tangent' (ShaderNodeTangent)"
    assert warnings == [f"object 'BumpyObj', material 'Bumpy': node {bsdf(mat).name!r}: input "
                        f"{socket!r} is linked to {shown}, which Snell ignores: {rendered}"]


def test_mixes_of_other_kinds_become_programs_and_unknown_shaders_warn(bl):
    """Mix(0.5, Diffuse, Glass) and Mix(Fresnel, Refraction, Glossy) (the glass of issue 29's
    files) are programs, without a warning; a Toon BSDF in one is grey 0.8 diffuse, warned
    naming object, material and node."""
    from snell.tracer.shader import closures, inputs
    mat, _, _ = mix_shader_material("Mixed", 0.5, "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfGlass")
    m, warnings = exported_material(bl, mat, "MixObj")
    assert warnings == [] and m["kind"] == "program"
    assert [row[0] for row in m["program"]["code"]] == [closures.DIFFUSE, closures.GLASS]
    mat, mix, _ = mix_shader_material("FresnelGlass", 0.5, "ShaderNodeBsdfRefraction",
                                      "ShaderNodeBsdfGlossy")
    fresnel = mat.node_tree.nodes.new("ShaderNodeFresnel")
    mat.node_tree.links.new(fresnel.outputs[0], mix.inputs["Fac"])
    m, warnings = exported_material(bl, mat, "Ico")
    assert warnings == [] and m["kind"] == "program"
    assert [row[0] for row in m["program"]["code"]] == [
        inputs.FRESNEL, closures.MIX_CLOSURE, closures.REFRACTION, closures.GLOSSY]
    mat, _, _ = mix_shader_material("Toon", 0.5, "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfToon")
    m, warnings = exported_material(bl, mat, "ToonObj")
    assert m["kind"] == "program"
    assert warnings == ["object 'ToonObj', material 'Toon': node 'Toon BSDF': is 'Toon BSDF' (a "
                        "toon surface), which Snell does not render: rendered as grey 0.8 "
                        "diffuse"]
    # A replaced material renders differently from Cycles: "not comparable".
    assert all(export.differs_from_cycles(w) for w in warnings)


def test_constant_mix_shaders_fold_where_exact(bl):
    """Fac 0 or 1 picks a side (clamped as Cycles clamps it); two diffuse surfaces mix their
    colours; an unlinked side is no closure (black); emissions mix colour x strength."""
    mat, _, (a, b) = mix_shader_material("Pick", 1.7, "ShaderNodeBsdfGlass", "ShaderNodeBsdfGlossy")
    b.distribution = "GGX"
    m, warnings = exported_material(bl, mat)
    assert warnings == [] and m["kind"] == "glossy" and m["distribution"] == "ggx"
    mat, _, (a, b) = mix_shader_material("Blend", 0.25, "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfDiffuse")
    a.inputs["Color"].default_value = (1.0, 0.0, 0.0, 1.0)
    b.inputs["Color"].default_value = (0.0, 0.0, 1.0, 1.0)
    m, warnings = exported_material(bl, mat)
    assert warnings == [] and m["kind"] == "diffuse"
    assert m["color"] == pytest.approx([0.75, 0.0, 0.25])
    mat, _, (a, _) = mix_shader_material("Half", 0.5, "ShaderNodeBsdfDiffuse", None)
    a.inputs["Color"].default_value = (0.6, 0.6, 0.6, 1.0)
    m, _ = exported_material(bl, mat)
    assert m["kind"] == "diffuse" and m["color"] == pytest.approx([0.3, 0.3, 0.3])
    mat, _, (a, b) = mix_shader_material("Glow", 0.5, "ShaderNodeEmission", "ShaderNodeEmission")
    a.inputs["Strength"].default_value = 4.0
    m, _ = exported_material(bl, mat)
    assert m["kind"] == "emission" and m["strength"] == 1.0
    assert m["color"] == pytest.approx([2.5, 2.5, 2.5])


def fresnel_glass(name, ior=1.45, fresnel_ior=None, roughness=0.0, group=False):
    """The node glass of older files (scenes/node_materials.fresnel_glass: Mix(Fresnel,
    Refraction, Glossy)), its refraction (0.4, 0.7, 0.9) of IOR ior, its reflection (0.9, 0.8,
    0.7) of this roughness; group: the Fresnel node inside a node group whose IOR input is left
    at its value. Returns (material, mix, the node on its Fac)."""
    mat = graphs.fresnel_glass(ior if fresnel_ior is None else fresnel_ior, refraction_ior=ior,
                               name=name, transmission=(0.4, 0.7, 0.9),
                               reflection=(0.9, 0.8, 0.7))
    tree = mat.node_tree
    mix, fresnel, _, glossy = mix_nodes(mat)
    glossy.inputs["Roughness"].default_value = roughness
    if not group:
        return mat, mix, fresnel
    inner = bpy.data.node_groups.new("FresnelFac", "ShaderNodeTree")
    inner.interface.new_socket("IOR", in_out="INPUT", socket_type="NodeSocketFloat")
    inner.interface.new_socket("Fac", in_out="OUTPUT", socket_type="NodeSocketFloat")
    grouped = inner.nodes.new("ShaderNodeFresnel")
    inner.links.new(inner.nodes.new("NodeGroupInput").outputs["IOR"], grouped.inputs["IOR"])
    inner.links.new(grouped.outputs[0], inner.nodes.new("NodeGroupOutput").inputs["Fac"])
    source = tree.nodes.new("ShaderNodeGroup")
    source.node_tree = inner
    source.inputs["IOR"].default_value = fresnel.inputs["IOR"].default_value
    tree.nodes.remove(fresnel)
    tree.links.new(source.outputs[0], mix.inputs["Fac"])
    return mat, mix, source


@pytest.mark.parametrize("group", [False, True])
def test_node_glass_of_a_fresnel_mix_is_glass(bl, group):
    """Mix(Fresnel of IOR n, smooth Refraction of IOR n, smooth Glossy) is Cycles' glass of
    index n: the reflection tinted by the Glossy colour, the transmission by the Refraction's
    (its Fresnel node inside a group too)."""
    mat, _, _ = fresnel_glass("NodeGlass", group=group)
    m, warnings = exported_material(bl, mat)
    assert warnings == []
    assert m == {"name": "NodeGlass", "kind": "glass", "color": pytest.approx([0.9, 0.8, 0.7]),
                 "transmission_color": pytest.approx([0.4, 0.7, 0.9]),
                 "ior": pytest.approx(1.45)}


@pytest.mark.parametrize("change", ["fresnel ior", "rough glossy", "swapped", "fresnel normal"])
def test_fresnel_mixes_that_are_not_glass_stay_programs(bl, change):
    """The Fresnel node's IOR not the refraction's, a rough Glossy, the sides swapped (F of
    the refraction), a bumped Fresnel normal: not glass, programs as before."""
    from snell.tracer.shader import closures, inputs
    mat, mix, fresnel = fresnel_glass(
        "NotGlass", fresnel_ior=1.5 if change == "fresnel ior" else None,
        roughness=0.2 if change == "rough glossy" else 0.0)
    tree = mat.node_tree
    if change == "swapped":
        first, second = (link.from_socket for link in (mix.inputs[1].links[0],
                                                       mix.inputs[2].links[0]))
        tree.links.new(second, mix.inputs[1])
        tree.links.new(first, mix.inputs[2])
    if change == "fresnel normal":
        tree.links.new(tree.nodes.new("ShaderNodeBump").outputs[0], fresnel.inputs["Normal"])
    m, warnings = exported_material(bl, mat)
    assert warnings == [] and m["kind"] == "program"
    assert inputs.FRESNEL in [row[0] for row in m["program"]["code"]]
    assert closures.REFRACTION in [row[0] for row in m["program"]["code"]]


@pytest.mark.parametrize("first, second", [
    ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfGlossy"),
    ("ShaderNodeBsdfPrincipled", "ShaderNodeBsdfPrincipled"),
    ("ShaderNodeBsdfRefraction", "ShaderNodeBsdfRefraction"),
])
def test_mixes_that_are_not_one_material_are_programs(bl, first, second):
    """Multiscatter GGX (the Glossy BSDF's default) and the Principled BSDF are not linear in
    their colour, two Refraction BSDFs of two IORs not one: a mix of two is a program of both,
    weighted 0.5 each."""
    mat, _, (a, b) = mix_shader_material("Two", 0.5, first, second)
    a.inputs[0].default_value = (0.2, 0.3, 0.4, 1.0)
    if "Refraction" in second:
        b.inputs["IOR"].default_value = 1.33
    m, warnings = exported_material(bl, mat)
    assert warnings == [] and m["kind"] == "program"
    program = m["program"]
    weights = [row[1] for row in program["code"]]
    assert len(weights) == 2 and [program["constants"][w] for w in weights] == [0.5, 0.5]


def test_no_material_is_cycles_default_surface(bl):
    """An object without a material, and an empty slot, render as Cycles' default surface: a
    Principled BSDF of base colour 0.8 (Cycles' images of it and of a new material are equal),
    with a note that does not make the validator say "not comparable"."""
    m, warnings = exported_material(bl, None, "Bare")
    assert m == {**scene_mod.MATERIAL_DEFAULTS["principled"], "name": "(default surface)",
                 "kind": "principled", "color": [0.8, 0.8, 0.8]}
    assert warnings == [f"object 'Bare', material '(none)': {materials.NO_MATERIAL}"]
    assert not any(export.differs_from_cycles(w) for w in warnings)
    # Equal to what a new material (Blender's default Principled BSDF) exports as.
    new, _ = materials.convert_material(bpy.data.materials.new("New"))
    assert set(new) == set(m)
    for key, value in m.items():
        if key != "name":
            assert new[key] == (value if isinstance(value, str) else pytest.approx(value)), key


@pytest.mark.parametrize("how", ["unlinked", "no output", "muted bsdf"])
def test_a_material_without_surface_renders_black_as_in_cycles(bl, how):
    """Cycles renders a material whose output has no Surface (or no output at all, or a muted
    BSDF, which passes no shader) black: so does Snell, with a note."""
    mat = common.material("Empty", "principled")
    tree = mat.node_tree
    if how == "unlinked":
        tree.links.remove(tree.links[0])
    elif how == "no output":
        tree.nodes.remove(tree.nodes["Material Output"])
    else:
        bsdf(mat).mute = True
    m, warnings = exported_material(bl, mat, "Dark")
    assert m == {"name": "Empty", "kind": "diffuse", "color": [0.0, 0.0, 0.0]}
    (warning,) = warnings
    assert warning.startswith("object 'Dark', material 'Empty': ")
    assert warning.endswith(materials.NO_SURFACE) and not export.differs_from_cycles(warning)


def _glass_with(bl, output_input, idname):
    """A glass material whose Material Output's `output_input` is fed by a new `idname` node."""
    mat = common.material("Coffee", "glass", (1.0, 1.0, 1.0), IOR=1.33)
    node = mat.node_tree.nodes.new(idname)
    mat.node_tree.links.new(node.outputs[0],
                            mat.node_tree.nodes["Material Output"].inputs[output_input])
    return mat


@pytest.mark.parametrize("output_input, idname, shown, rendered", [
    ("Displacement", "ShaderNodeDisplacement", "'Displacement' (a displacement)",
     "rendered without displacement or bump (the mesh's normals)"),
])
def test_material_output_displacement_warns(bl, output_input, idname, shown, rendered):
    """A true displacement (method Displacement Only): one warning names the output, the input,
    the node and what renders instead; the surface still converts. (A Volume converts:
    tests/blender/test_export_volumes.py; bump displacement: the next test.)"""
    mat = _glass_with(bl, output_input, idname)
    mat.displacement_method = "DISPLACEMENT"
    m, warnings = exported_material(bl, mat, "Cup")
    assert m["kind"] == "glass" and m["ior"] == pytest.approx(1.33)
    assert warnings == [f"object 'Cup', material 'Coffee': node 'Material Output': input "
                        f"{output_input!r} is linked to {shown}, which Snell does not render: "
                        f"{rendered}"]
    assert export.differs_from_cycles(warnings[0])


@pytest.mark.parametrize("method, warned", [("BUMP", False), ("BOTH", True)])
def test_bump_displacement_is_a_program(bl, method, warned):
    """Displacement method Bump Only (Cycles' default), or Displacement and Bump: the
    material is a program that bumps its normal first (SET_NORMAL before the closures); the
    true displacement of the second is warned: rendered with bump only."""
    from snell.tracer.shader import bump
    mat = _glass_with(bl, "Displacement", "ShaderNodeDisplacement")
    mat.displacement_method = method
    m, warnings = exported_material(bl, mat, "Cup")
    assert m["kind"] == "program"
    ops = [row[0] for row in m["program"]["code"]]
    assert ops.count(bump.SET_NORMAL) == 1 and ops.count(bump.DISPLACEMENT) == 3
    if warned:
        assert warnings == ["object 'Cup', material 'Coffee': node 'Material Output': input "
                            "'Displacement' is displaced as well as bumped (displacement method "
                            "Displacement and Bump), and Snell does not displace meshes: "
                            "rendered with bump only"]
    else:
        assert warnings == []


def test_world_volume_warns(bl):
    world = common.set_world(bl, (0.1, 0.1, 0.1))
    fog = world.node_tree.nodes.new("ShaderNodeVolumeScatter")
    world.node_tree.links.new(fog.outputs[0], world.node_tree.nodes["World Output"].inputs["Volume"])
    s, warnings = run()
    assert s.world["color"] == pytest.approx([0.1, 0.1, 0.1])
    assert warnings == ["world 'World': node 'World Output': input 'Volume' is linked to "
                        "'Volume Scatter' (a volume), which Snell does not render: rendered "
                        "without it (clear air)"]


def test_node_group_on_the_surface_and_on_an_input_warn(bl):
    group = bpy.data.node_groups.new("Dispersion", "ShaderNodeTree")
    group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
    group.interface.new_socket("Value", in_out="OUTPUT", socket_type="NodeSocketFloat")
    mat = bpy.data.materials.new("Grouped")
    tree = mat.node_tree
    surface = tree.nodes.new("ShaderNodeGroup")
    surface.node_tree = group
    tree.links.new(surface.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    m, warnings = exported_material(bl, mat, "G")
    # A group with no Group Output gives no closure: black, as in Cycles.
    assert m["kind"] == "program" and m["program"]["code"] == []
    assert warnings == ["object 'G', material 'Grouped': node 'Group': is a node group with no "
                        "Group Output: no closure (black), as in Cycles"]
    tree.links.new(tree.nodes["Principled BSDF"].outputs[0],
                   tree.nodes["Material Output"].inputs["Surface"])
    tree.links.new(surface.outputs[1], tree.nodes["Principled BSDF"].inputs["Roughness"])
    m, warnings = exported_material(bl, mat, "G")
    assert m["kind"] == "principled" and m["roughness"] == pytest.approx(0.5)
    assert warnings == ["object 'G', material 'Grouped': node 'Principled BSDF': input "
                        "'Roughness' is linked to 'Group' (a node group), which Snell cannot "
                        "evaluate: using its unlinked value 0.5"]


def diffuse_group(name="Paint"):
    """A node group of a Diffuse BSDF (white inside) whose Color is the group's input, through
    a nested group that passes the colour on: flattening must read the outer group node's
    input."""
    inner = bpy.data.node_groups.new(name + "Inner", "ShaderNodeTree")
    inner.interface.new_socket("Color", in_out="INPUT", socket_type="NodeSocketColor")
    inner.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
    gi, go = inner.nodes.new("NodeGroupInput"), inner.nodes.new("NodeGroupOutput")
    inner.links.new(gi.outputs[0], go.inputs[0])
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    group.interface.new_socket("Color", in_out="INPUT", socket_type="NodeSocketColor")
    group.interface.new_socket("BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    gi, go = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    nested = group.nodes.new("ShaderNodeGroup")
    nested.node_tree = inner
    diffuse = group.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    group.links.new(gi.outputs[0], nested.inputs[0])
    group.links.new(nested.outputs[0], diffuse.inputs["Color"])
    group.links.new(diffuse.outputs[0], go.inputs[0])
    return group


def test_node_groups_are_flattened(bl):
    """A group on Surface (with a nested group inside) renders as the BSDF inside it, its
    inputs read from the group node, as Cycles flattens groups; a group input left
    unlinked inside takes the group node's value."""
    mat = bpy.data.materials.new("Grouped")
    tree = mat.node_tree
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = diffuse_group()
    node.inputs["Color"].default_value = (0.2, 0.5, 0.7, 1.0)
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    m, warnings = exported_material(bl, mat, "G")
    assert warnings == []
    assert m["kind"] == "diffuse" and m["color"] == pytest.approx([0.2, 0.5, 0.7])
    wire = tree.nodes.new("ShaderNodeWireframe")
    tree.links.new(wire.outputs["Fac"], node.inputs["Color"])
    m, warnings = exported_material(bl, mat, "G")
    # The link outside the group is named, and the value used is the group node's.
    assert warnings == ["object 'G', material 'Grouped': node 'Diffuse BSDF': input 'Color' is "
                        "linked to 'Wireframe' (ShaderNodeWireframe), which Snell cannot "
                        "evaluate: using its unlinked value (0.2, 0.5, 0.7)"]


def test_linked_principled_alpha_and_normal_map_make_a_program(bl):
    """A checker Alpha and a Normal Map are evaluated: a shader program, without warnings."""
    from snell.tracer.shader import closures, normals, procedural_textures
    mat = common.material("Leaf", "principled", (0.2, 0.5, 0.1))
    link(mat, "Alpha", "ShaderNodeTexChecker")
    link(mat, "Normal", "ShaderNodeNormalMap")
    m, warnings = exported_material(bl, mat, "Leaf")
    assert m["kind"] == "program" and warnings == []
    ops = {row[0] for row in m["program"]["code"]}
    assert closures.PRINCIPLED in ops
    assert ops & set(procedural_textures.SPECS) and ops & set(normals.SPECS)


def test_a_linked_input_snell_never_reads_warns(bl):
    """An input no converter reads (a Principled BSDF's Subsurface Radius) is not dropped
    unsaid when linked."""
    mat = common.material("Skin", "principled")
    rgb = link(mat, "Subsurface Radius", "ShaderNodeRGB")
    _, warnings = exported_material(bl, mat, "Skin")
    assert warnings == [f"object 'Skin', material 'Skin': node 'Principled BSDF': input "
                        f"'Subsurface Radius' is linked to {rgb.name!r} (ShaderNodeRGB), which "
                        f"Snell does not evaluate: ignored"]


def test_reroutes_and_muted_nodes_are_followed(bl, tmp_path):
    """An Image Texture reaches Base Color through a reroute and a muted Gamma node (a muted
    node passes its internal link, as Blender and Cycles do); a muted texture passes nothing,
    so its input's own value is used without a warning."""
    import numpy as np_
    image = bpy.data.images.new("Tex", 4, 4)
    image.pixels[:] = np_.full(64, 0.5)
    mat = common.material("Routed", "principled", (0.3, 0.3, 0.3))
    tree = mat.node_tree
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    gamma = tree.nodes.new("ShaderNodeGamma")
    gamma.mute = True
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(tex.outputs["Color"], gamma.inputs["Color"])
    tree.links.new(gamma.outputs["Color"], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], bsdf(mat).inputs["Base Color"])
    noise = link(mat, "Roughness")
    noise.mute = True
    bpy.ops.mesh.primitive_plane_add()
    bpy.context.active_object.data.materials.append(mat)
    s, warnings = run()
    (m,) = s.materials
    assert warnings == [] and "color" in m["textures"]
    assert m["roughness"] == pytest.approx(0.5)
    gamma.mute = False
    s, warnings = run()
    # An unmuted Gamma is a value node a program evaluates.
    assert warnings == [] and s.materials[0]["kind"] == "program"


def test_glass_on_open_mesh_warns(bl):
    glass = common.material("Pane", "glass", (1.0, 1.0, 1.0), IOR=1.5)
    common.quad("Window", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], glass)
    cube("Closed", mat=glass, location=(5.0, 0.0, 0.0))
    s, warnings = run()
    assert {o["name"]: o["closed"] for o in s.objects} == {"Window": False, "Closed": True}
    assert [w for w in warnings if "not closed" in w] == [
        "object 'Window': glass material 'Pane' on a mesh that is not closed "
        "(its edges are not all shared by two triangles)"]
    # Cycles refracts at the same open surface: the validator does not lower its verdict.
    assert not any(export.differs_from_cycles(w) for w in warnings if "not closed" in w)


def test_transmissive_principled_on_open_mesh_warns(bl):
    clear = common.material("Clear", "principled", **{"Transmission Weight": 0.5})
    opaque = common.material("Opaque", "principled")
    common.quad("Window", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], clear)
    common.quad("Card", [(0, 0, 2), (1, 0, 2), (1, 1, 2), (0, 1, 2)], opaque)
    _, warnings = run()
    assert [w for w in warnings if "not closed" in w] == [
        "object 'Window': principled material 'Clear' on a mesh that is not closed "
        "(its edges are not all shared by two triangles)"]


# ---------------------------------------------------------------------------------------------
# Lights, camera, world


def add_light(bl, name, kind, **props):
    data = bpy.data.lights.new(name, kind)
    for key, value in props.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(name, data)
    bl.collection.objects.link(obj)
    return obj


def test_lights(bl):
    rect = add_light(bl, "Rect", "AREA", shape="RECTANGLE", size=1.0, size_y=0.5, energy=100.0,
                     color=(1.0, 0.5, 0.25), exposure=1.0)
    rect.scale = (2.0, 3.0, 1.0)
    rect.location = (0.0, 0.0, 2.0)
    rect.rotation_euler = (0.4, 0.0, 0.0)
    rect.visible_camera = True
    add_light(bl, "Disk", "AREA", shape="DISK", size=2.0, energy=10.0)
    add_light(bl, "Raw", "AREA", shape="SQUARE", size=2.0, energy=10.0, normalize=False)
    warm = add_light(bl, "Warm", "AREA", shape="SQUARE", size=1.0, energy=10.0,
                     use_temperature=True, temperature=3000.0)
    point = add_light(bl, "Point", "POINT", energy=4 * math.pi * 3, shadow_soft_size=0.0)
    point.location = (1.0, 2.0, 3.0)
    bulb = add_light(bl, "Bulb", "POINT", energy=1.0, shadow_soft_size=0.2)
    bulb.visible_glossy = False
    bulb.data.use_soft_falloff = False
    add_light(bl, "RawBulb", "POINT", energy=2.0, shadow_soft_size=0.5, normalize=False)
    sun = add_light(bl, "Sun", "SUN", energy=3.0, angle=math.radians(10))
    sun.rotation_euler = (0.0, math.pi / 2, 0.0)
    add_light(bl, "RawSun", "SUN", energy=3.0, angle=math.radians(10), normalize=False)
    spot = add_light(bl, "Spot", "SPOT", energy=1.0, spot_size=math.radians(60), spot_blend=0.5,
                     use_shadow=False)
    spot.scale = (2.0, 1.0, 1.0)
    spread = add_light(bl, "Spread", "AREA", shape="SQUARE", size=1.0, energy=1.0,
                       spread=math.radians(45))
    spread.data.cycles.use_multiple_importance_sampling = False
    s, warnings = run()
    lights = {l["name"]: l for l in s.lights}
    assert set(lights) == {"Rect", "Disk", "Raw", "Warm", "Point", "Bulb", "RawBulb", "Sun",
                           "RawSun", "Spot", "Spread"}
    assert not warnings, warnings

    r = lights["Rect"]
    assert r["shape"] == "rectangle" and r["size"] == pytest.approx([2.0, 1.5])
    assert np.allclose(r["radiance"], np.array([1.0, 0.5, 0.25]) * 100 * 2 / (math.pi * 3.0))
    assert r["visible_camera"] is True and r["spread"] == pytest.approx(math.pi)
    m = np.array(r["matrix"])
    assert np.allclose(np.linalg.norm(m[:3, :3], axis=0), 1)  # scale lives in size only
    assert np.allclose(m[:3, 3], [0, 0, 2]) and np.allclose(m[:3, 2], [0, -math.sin(0.4), math.cos(0.4)])
    d = lights["Disk"]
    assert d["shape"] == "disk" and d["size"] == pytest.approx([2.0, 2.0])
    assert np.allclose(d["radiance"], 10 / (math.pi * math.pi / 4 * 4))
    assert lights["Disk"]["visible_camera"] is False          # Blender 5's default for lights
    assert np.allclose(lights["Raw"]["radiance"], 10 / math.pi)  # normalize off: P / pi
    tc = np.array(bpy.data.lights["Warm"].temperature_color[:3])
    assert np.allclose(lights["Warm"]["radiance"], tc * 10 / math.pi)
    p = lights["Point"]
    assert p["kind"] == "point" and p["position"] == pytest.approx([1, 2, 3])
    assert np.allclose(p["intensity"], 3.0) and p["radius"] == 0.0
    b = lights["Bulb"]                      # I = P / (4 pi) whatever the radius
    assert b["radius"] == pytest.approx(0.2) and np.allclose(b["intensity"], 1 / (4 * math.pi))
    assert b["soft_falloff"] is False and b["visible_glossy"] is False and b["visible_diffuse"]
    rb = lights["RawBulb"]                  # unnormalised: radiance P / pi, so I = P r^2
    assert rb["soft_falloff"] is True and np.allclose(rb["intensity"], 2.0 * 0.25)
    sun = lights["Sun"]
    assert np.allclose(sun["direction"], [-1, 0, 0], atol=1e-6)
    assert np.allclose(sun["irradiance"], 3.0) and sun["angle"] == pytest.approx(math.radians(10))
    # Unnormalised, the disc's radiance is the strength: irradiance pi sin^2(5 deg) x 3.
    assert np.allclose(lights["RawSun"]["irradiance"], 3.0 * math.pi * math.sin(math.radians(5)) ** 2)
    sp = lights["Spot"]
    assert sp["kind"] == "spot" and sp["spot_size"] == pytest.approx(math.radians(60))
    assert sp["spot_blend"] == pytest.approx(0.5) and sp["cast_shadow"] is False
    assert np.allclose(np.linalg.norm(np.array(sp["matrix"])[:3, :3], axis=0), [2, 1, 1])
    assert lights["Spread"]["spread"] == pytest.approx(math.radians(45))
    assert lights["Spread"]["use_mis"] is False and lights["Rect"]["use_mis"] is True


def test_light_node_tree_emission_scales_the_light(bl):
    """Cycles multiplies a lamp by its Emission node's Color x Strength when it uses nodes; any
    other node is reported by name and ignored."""
    lamp = add_light(bl, "Lamp", "POINT", energy=4 * math.pi, color=(0.5, 1.0, 1.0))
    lamp.data.use_nodes = True
    emission = next(n for n in lamp.data.node_tree.nodes if n.bl_idname == "ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    emission.inputs["Strength"].default_value = 2.0
    other = add_light(bl, "Other", "POINT", energy=4 * math.pi)
    other.data.use_nodes = True
    tree = other.data.node_tree
    tree.nodes.clear()
    node = tree.nodes.new("ShaderNodeBsdfDiffuse")
    output = tree.nodes.new("ShaderNodeOutputLight")
    tree.links.new(node.outputs[0], output.inputs["Surface"])
    s, warnings = run()
    lights = {l["name"]: l for l in s.lights}
    assert np.allclose(lights["Lamp"]["intensity"], [1.0, 1.0, 0.5])
    assert np.allclose(lights["Other"]["intensity"], 1.0)
    assert any("'Other'" in w and "ShaderNodeBsdfDiffuse" in w for w in warnings), warnings


def test_camera(bl):
    cam = bl.camera
    cam.scale = (2.0, 2.0, 2.0)
    data = cam.data
    data.lens, data.sensor_width, data.sensor_height, data.sensor_fit = 42.0, 30.0, 20.0, "VERTICAL"
    data.shift_x, data.shift_y, data.clip_start, data.clip_end = 0.1, -0.2, 0.5, 50.0
    data.dof.use_dof = True
    data.dof.aperture_fstop, data.dof.aperture_blades = 4.0, 6
    data.dof.aperture_rotation, data.dof.aperture_ratio = 0.3, 1.5
    target = bpy.data.objects.new("Target", None)
    target.location = (2.0, -4.0, 1.0)  # 6 m in front along the view axis (+Y), off-axis
    bl.collection.objects.link(target)
    data.dof.focus_object = target
    r = bl.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = 320, 200, 50
    r.pixel_aspect_x, r.pixel_aspect_y = 1.0, 2.0
    s, _ = run()
    c = s.camera
    m = np.array(c["matrix"])
    assert np.allclose(np.linalg.norm(m[:3, :3], axis=0), 1)
    assert np.allclose(m[:3, 3], [0, -10, 0]) and np.allclose(-m[:3, 2], [0, 1, 0], atol=1e-6)
    assert (c["lens"], c["sensor_width"], c["sensor_height"], c["sensor_fit"]) == (42.0, 30.0, 20.0, "VERTICAL")
    assert c["shift_x"] == pytest.approx(0.1) and c["shift_y"] == pytest.approx(-0.2)
    assert c["clip_start"] == pytest.approx(0.5) and c["clip_end"] == pytest.approx(50.0)
    assert c["resolution"] == [320, 200] and c["resolution_percentage"] == 50
    assert c["pixel_aspect"] == [1.0, 2.0]
    dof = c["dof"]
    assert dof["use_dof"] is True and dof["focus_distance"] == pytest.approx(6.0, abs=1e-5)
    assert dof["fstop"] == 4.0 and dof["blades"] == 6
    assert dof["rotation"] == pytest.approx(0.3) and dof["ratio"] == pytest.approx(1.5)
    assert scene_mod.aperture_radius(c) == pytest.approx(0.042 / 8)


def test_orthographic_camera_exported_and_panoramic_rejected(bl):
    bl.camera.data.type = "ORTHO"
    bl.camera.data.ortho_scale = 3.5
    s, _ = run()
    assert s.camera["type"] == "ORTHO" and s.camera["ortho_scale"] == pytest.approx(3.5)
    bl.camera.data.type = "PANO"
    with pytest.raises(SceneError, match="perspective and orthographic.*PANO"):
        run()


def test_world(bl):
    s, _ = run()
    assert s.world == {"color": [0.0, 0.0, 0.0]}
    common.set_world(bl, (0.5, 0.25, 1.0), 2.0)
    s, _ = run()
    assert np.allclose(s.world["color"], [1.0, 0.5, 2.0])


def test_render_settings_default(bl):
    """A new file follows Cycles' defaults: 4096 samples, noise threshold 0.01, max bounces 12
    (max depth 13), Blackman-Harris 1.5 px, denoised (OIDN, albedo and normal, accurate
    prefilter, high quality); Snell's own settings at theirs; each value's source saved with it."""
    s, warnings = run()
    saved = {k: s.render[k] for k in scene_mod.DEFAULT_RENDER}
    assert saved == {**scene_mod.DEFAULT_RENDER, "spp": 4096, "max_depth": 13,
                     "diffuse_bounces": 4, "glossy_bounces": 4, "transmission_bounces": 12,
                     "sample_clamp_indirect": 10.0,
                     "pixel_filter": "blackman_harris", "filter_width": 1.5, "denoise": True}
    assert s.render["sources"] == {
        **dict.fromkeys(["spp", "noise_threshold", "min_spp", "time_limit", "seed", "max_depth",
                         "transparent_max_bounces", "diffuse_bounces", "glossy_bounces",
                         "transmission_bounces", "caustics_reflective", "caustics_refractive",
                         "sample_clamp_direct", "sample_clamp_indirect",
                         "pixel_filter", "filter_width",
                         "film_exposure", "film_transparent", "film_transparent_glass",
                         "film_transparent_roughness", "denoise",
                         "denoising_input_passes",
                         "denoising_prefilter", "denoising_quality", "denoising_passes"],
                        "file's Cycles setting"),
        **dict.fromkeys(["fresnel", "caustics", "shadow_caustics", "light_vertices"],
                        "default")}
    labels = {e["label"]: e for e in s.render["cycles_not_rendered"]}
    assert "Light Paths > Diffuse bounces" not in labels        # rendered
    # Cycles' default indirect clamp, which Snell's light tracer does not apply: no warning.
    caustics = labels["Light Paths > Clamping > Indirect Light (caustics)"]
    assert (caustics["value"], caustics["status"]) == ("10", "differs")
    assert not any(e["warn"] for e in labels.values())      # Cycles' defaults
    assert not any("Cycles'" in w for w in warnings)


def test_the_files_cycles_settings_are_followed(bl):
    """Samples, noise threshold, min samples, time limit, seed (animated too), max bounces (of
    each kind too), clamping and the pixel filter from Cycles' panels, Film > Transparent from
    Blender's; the Cycles settings Snell does not render, when set to something Snell renders
    differently, are warnings."""
    c = bl.cycles
    c.samples, c.adaptive_threshold, c.adaptive_min_samples, c.time_limit = 300, 0.03, 40, 12.5
    c.seed, c.max_bounces = 17, 3
    c.pixel_filter_type, c.filter_width = "GAUSSIAN", 2.25
    c.sample_clamp_indirect, c.diffuse_bounces = 0.0, 2
    c.glossy_bounces, c.transmission_bounces, c.sample_clamp_direct = 1, 5, 2.5
    bl.render.film_transparent = True
    s, warnings = run()
    assert {k: s.render[k] for k in ("diffuse_bounces", "glossy_bounces", "transmission_bounces",
                                     "sample_clamp_direct", "sample_clamp_indirect")} == {
        "diffuse_bounces": 2, "glossy_bounces": 1, "transmission_bounces": 5,
        "sample_clamp_direct": 2.5, "sample_clamp_indirect": 0.0}
    assert {k: s.render[k] for k in ("spp", "noise_threshold", "min_spp", "time_limit", "seed",
                                     "max_depth")} == {"spp": 300, "noise_threshold": 0.03,
                                                       "min_spp": 40, "time_limit": 12.5,
                                                       "seed": 17, "max_depth": 4}
    assert (s.render["pixel_filter"], s.render["filter_width"]) == ("gaussian", 2.25)
    assert not any("Pixel Filter" in w for w in warnings)
    assert not any("bounces" in w for w in warnings), warnings
    assert s.render["film_transparent"] is True
    c.film_exposure = 0.75
    assert run()[0].render["film_exposure"] == 0.75
    assert not any("Film > Transparent" in w for w in warnings), warnings
    c.film_transparent_glass, c.film_transparent_roughness = True, 0.25
    s, glass_warnings = run()
    assert (s.render["film_transparent_glass"], s.render["film_transparent_roughness"]) == \
        (True, 0.25)
    assert not any("Transparent Glass" in w for w in glass_warnings), glass_warnings
    c.film_transparent_glass = False
    assert not any("Clamping" in w for w in warnings)       # followed; caustics: 0 unclamped
    c.caustics_reflective = False          # followed (tracer/path_limits.py), not warned
    s, caustics_warnings = run()
    assert (s.render["caustics_reflective"], s.render["caustics_refractive"]) == (False, True)
    assert not any("Caustics" in w for w in caustics_warnings), caustics_warnings
    c.caustics_reflective = True
    c.sample_clamp_indirect = 3.0
    assert any("Clamping > Indirect Light (caustics) 3" in w for w in run()[1])
    c.sample_clamp_indirect = 0.0
    c.use_adaptive_sampling = False
    assert run()[0].render["noise_threshold"] == 0.0
    c.use_adaptive_sampling, c.adaptive_threshold = True, 0.0    # Cycles' automatic threshold
    assert run()[0].render["noise_threshold"] == pytest.approx(1 / 300)
    c.use_denoising, c.denoising_input_passes = False, "RGB_ALBEDO"
    c.denoising_prefilter, c.denoising_quality = "FAST", "BALANCED"
    bl.view_layers[0].cycles.denoising_store_passes = True
    render = run()[0].render
    assert {k: render[k] for k in ("denoise", "denoising_input_passes", "denoising_prefilter",
                                   "denoising_quality", "denoising_passes")} == {
        "denoise": False, "denoising_input_passes": "albedo", "denoising_prefilter": "fast",
        "denoising_quality": "balanced", "denoising_passes": True}
    if "OPTIX" in {item.identifier for item in c.bl_rna.properties["denoiser"].enum_items}:
        c.use_denoising, c.denoiser = True, "OPTIX"
        assert any("Denoiser" in w and "Open Image Denoise" in w for w in run()[1])
    c.use_animated_seed = True
    seeds = set()
    for frame in (1, 2, 3):
        bl.frame_set(frame)
        seeds.add(run()[0].render["seed"])
    assert len(seeds) == 3


def test_the_viewport_refines_to_cycles_viewport_samples(bl):
    """Sampling > Viewport > Max Samples (0: until stopped, in both) is the viewport's target,
    unless Follow Cycles' Settings is off."""
    from snell.addon import registration
    from snell.addon.export import blender_settings
    registration.ensure_registered()
    bl.snell.viewport_spp = 20
    for samples in (37, 0):
        bl.cycles.preview_samples = samples
        assert blender_settings(bl).viewport_spp == samples
    bl.snell.use_cycles_settings = False
    assert blender_settings(bl).viewport_spp == 20


def test_snells_own_settings_override_cycles_only_when_asked(bl):
    from snell.addon import registration
    registration.ensure_registered()
    bl.cycles.samples, bl.cycles.max_bounces = 300, 3
    bl.snell.spp, bl.snell.max_depth, bl.snell.fresnel = 20, 2, "SCHLICK"
    bl.snell.pixel_filter, bl.snell.filter_width = "GAUSSIAN", 2.0
    s, _ = run()
    assert (s.render["spp"], s.render["max_depth"], s.render["fresnel"]) == (300, 4, "schlick")
    assert (s.render["pixel_filter"], s.render["filter_width"]) == ("blackman_harris", 1.5)
    assert s.render["sources"]["fresnel"] == "Snell setting"
    bl.snell.use_cycles_settings = False
    s, _ = run()
    assert (s.render["spp"], s.render["max_depth"]) == (20, 2)
    assert (s.render["pixel_filter"], s.render["filter_width"]) == ("gaussian", 2.0)
    assert s.render["sources"]["spp"] == s.render["sources"]["max_depth"] == "Snell override"


def test_one_setting_overridden_while_following_the_rest(bl, tmp_path):
    """The Sampling panel's Snell Overrides: Snell's own samples over Cycles', every other
    setting still the file's Cycles one; saved in the file and read back, and `snell info`'s
    sources say which is which."""
    from snell.addon import registration
    registration.ensure_registered()
    bl.cycles.samples, bl.cycles.max_bounces = 300, 3
    bl.snell.spp, bl.snell.max_depth = 20, 2
    bl.snell.overrides = {"SPP"}
    s, _ = run()
    assert (s.render["spp"], s.render["max_depth"]) == (20, 4)
    assert s.render["sources"]["spp"] == "Snell override"
    assert s.render["sources"]["max_depth"] == "file's Cycles setting"
    path = str(tmp_path / "override.blend")
    common.save(path)
    bl.snell.overrides = set()
    assert run()[0].render["spp"] == 300
    s, _ = export.export_blend(path)          # opens the saved file (bl is gone)
    assert (s.render["spp"], s.render["max_depth"]) == (20, 4)


@pytest.mark.parametrize("use_adaptive, threshold", [(True, 0.05), (False, 0.0)])
def test_sampling_panel_settings_reach_the_scene_file(bl, tmp_path, use_adaptive, threshold):
    """Noise Threshold (checkbox and value) and Min Samples, through a saved file; unchecked the
    threshold is exported as 0 (off)."""
    from snell.addon import registration
    registration.ensure_registered()
    props = bl.snell
    props.use_cycles_settings = False       # Snell's own Sampling panel
    props.spp, props.use_adaptive_sampling, props.noise_threshold, props.min_spp = \
        512, use_adaptive, 0.05, 24
    path = str(tmp_path / "adaptive.blend")
    common.save(path)
    s, _ = export.export_blend(path)
    assert (s.render["spp"], s.render["noise_threshold"], s.render["min_spp"]) == \
        (512, threshold, 24)


def test_sampling_settings_stored_without_the_addon():
    """A file read without the add-on registered: its ID properties hold only what was set
    (booleans as integers); what is missing keeps Cycles' defaults."""
    class Stored(dict):
        """Stands in for a bpy Scene: scene.get("snell") and no scene.snell."""
    stored = Stored(snell={"noise_threshold": 0.0020000000949949026, "min_spp": 8})
    render = export.convert_render(stored)
    assert (render["noise_threshold"], render["min_spp"]) == (0.002, 8)
    stored["snell"]["use_adaptive_sampling"] = 0
    assert export.convert_render(stored)["noise_threshold"] == 0.0
    assert export.convert_render(Stored(snell={}))["noise_threshold"] == 0.01
    # Overrides are saved as a bit mask in FOLLOWED's order (spp first, then noise_threshold).
    from snell.addon.export.settings import overridden
    assert overridden(Stored(snell={"overrides": 0b11})) == {"spp", "noise_threshold"}
    assert overridden(Stored(snell={})) == set()


# ---------------------------------------------------------------------------------------------
# Files and scene scripts


def test_round_trip(bl, tmp_path):
    common.uv_sphere("Ball", (0, 0, 0), 1.0, common.material("G", "glass", IOR=1.5), 16, 8)
    add_light(bl, "Lamp", "AREA", size=1.0, energy=5.0)
    path = str(tmp_path / "cube.blend")
    common.save(path)
    out = str(tmp_path / "cube.snell")
    assert export.export_to_file(path, out) == []
    s, _ = export.export_blend(path)
    back = scene_mod.load(out)
    for key in ("positions", "triangles", "material_ids", "object_ids", "normals"):
        assert np.array_equal(getattr(back, key), getattr(s, key)), key
    assert back.header() == s.header()
    assert back.source == "cube.blend"


@pytest.mark.parametrize("name", ["cornell_spheres", "cornell_dragon", "furnace", "slab", "lens"])
def test_scene_scripts_build_and_export(name, tmp_path):
    module = importlib.import_module(name)
    path = module.build(str(tmp_path / f"{name}.blend"))
    s, warnings = export.export_blend(path)
    assert warnings == []
    kinds = {m["kind"] for m in s.materials}
    if name == "cornell_spheres":
        assert {"glossy", "glass", "emission", "diffuse"} <= kinds
        mirror = next(m for m in s.materials if m["kind"] == "glossy")
        assert mirror["roughness"] == 0.0 and scene_mod.is_mirror(mirror)
        assert s.camera["resolution"] == [256, 256] and not s.camera["dof"]["use_dof"]
        assert all(o["closed"] for o in s.objects if "Sphere" in o["name"])
    if name == "cornell_dragon":
        dragon = [i for i, o in enumerate(s.objects) if o["name"] == "Dragon"][0]
        assert np.sum(s.object_ids == dragon) >= 100_000
        assert s.objects[dragon]["closed"]
        assert scene_mod.aperture_radius(s.camera) == pytest.approx(0.1, rel=1e-5)
        centre = s.positions[s.triangles[s.object_ids == dragon]].reshape(-1, 3).mean(axis=0)
        assert np.linalg.norm(np.array(s.camera["matrix"])[:3, 3] - centre) == pytest.approx(3.3, abs=0.1)
    if name == "furnace":
        assert s.world["color"] == [1.0, 1.0, 1.0] and kinds == {"glass"}
    if name == "slab":
        assert [o["closed"] for o in s.objects] == [False, True]
    if name == "lens":
        assert s.camera["dof"]["use_dof"]


def test_blenders_startup_scene_exports_its_lamp_without_warnings():
    """The default cube, camera and point light (radius 0.1, soft falloff) as Blender starts."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    s, warnings = run()
    assert not warnings, warnings
    (lamp,) = s.lights
    assert lamp["kind"] == "point" and lamp["radius"] == pytest.approx(0.1)
    assert lamp["soft_falloff"] is True and np.allclose(lamp["intensity"], 1000 / (4 * math.pi))
    assert len(s.triangles) == 12


def test_info_names_where_each_setting_came_from(bl, tmp_path):
    """`snell info` of a file with its own Cycles settings: the values, their sources, and the
    Cycles settings Snell does not render (a warning where the file set one Snell renders
    differently)."""
    from snell import cli
    cube()
    add_light(bl, "Lamp", "POINT", energy=10.0)
    bl.cycles.samples, bl.cycles.max_bounces, bl.cycles.seed = 96, 6, 9
    bl.cycles.sample_clamp_direct, bl.cycles.sample_clamp_indirect = 5.0, 4.0
    path = str(tmp_path / "info.blend")
    common.save(path)
    lines = cli.describe(cli.load_scene(path))
    text = "\n".join(lines)
    assert ("render     96 spp, max depth 7, seed 9, fresnel exact, pixel filter blackman-harris "
            "1.5 px") in text, text
    assert ("paths      bounces diffuse 4, glossy 4, transmission 12, transparent 8; "
            "clamp direct 5, indirect 4; caustics reflective on, refractive on") in text, text
    sources = next(line for line in lines if line.startswith("sources"))
    assert sources == ("sources    file's Cycles setting: spp, max_depth, "
                       "transparent_max_bounces, diffuse_bounces, glossy_bounces, "
                       "transmission_bounces, caustics_reflective, caustics_refractive, "
                       "sample_clamp_direct, sample_clamp_indirect, seed, noise_threshold, "
                       "min_spp, time_limit, pixel_filter, filter_width, film_exposure, "
                       "film_transparent, film_transparent_glass, film_transparent_roughness, "
                       "denoise, "
                       "denoising_input_passes, denoising_prefilter, denoising_quality, "
                       "denoising_passes; default: fresnel, "
                       "caustics, shadow_caustics, light_vertices"), sources
    cycles = [line for line in lines if line.startswith("cycles")]
    # Rendered as Cycles, but not on the light tracer's caustics: a warning.
    assert ("cycles     warning: Light Paths > Clamping > Indirect Light (caustics) 4: "
            "not rendered") in "\n".join(cycles), cycles
    assert not any(name in line for line in cycles
                   for name in ("Direct Light", "Diffuse bounces", "Glossy bounces",
                                "Transmission bounces")), cycles
    assert "cycles     not rendered, the same image with other noise: Light Tree on" in text
    assert sum("warning" in line for line in cycles) == 1
