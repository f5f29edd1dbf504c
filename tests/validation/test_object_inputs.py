"""The input nodes that read the object, the camera and mesh attributes (tracer/shader/
object_inputs.py, addon/export/shader/input_nodes.py) held against Cycles point by point:
Texture Coordinate's Normal, Camera, Window and Object of another object, Object Info, Attribute,
Color Attribute and Camera Data.

The scene: a smooth, bumpy 6 x 6 grid, rotated, translated and scaled unequally, with an object
colour and pass index, custom properties (on the object and its mesh), colour attributes on
corners (float) and points (bytes, the render default), a float attribute on faces, a vector
on points and a UV map; an empty for Texture
Coordinate Object; a perspective camera with shift and a 24 x 16 frame. Each graph drives the
Emission of the grid's material and Cycles renders it at 1 sample, no bounces: each pixel is
the graph's value at the point sample 0 hit, which a render of Geometry Position gives. Snell's
exporter compiles the same material, and its interpreter (program.run) evaluates it at those
points; the two agree to float32 precision (Cycles computes in float32).

The last test makes the grid a collection instance (an empty instancing its collection), where
the random id, the matrix and the Instancer properties come from the instance.

Each test's teeth are the same comparison with a deliberate error, which must fail; the numbers
measured are in the tests' docstrings.
"""
from __future__ import annotations

import math
import os
import tempfile

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402
from snell.addon.export import meshes as export_meshes  # noqa: E402
from snell.tracer import lobes  # noqa: E402
from snell.tracer.camera import Camera  # noqa: E402
from snell.tracer.image import read_exr  # noqa: E402
from snell.tracer.materials import material_tables  # noqa: E402
from snell.tracer.microfacet_tables import shipped_tables  # noqa: E402
from snell.tracer.shader import closures, program  # noqa: E402
from snell.tracer.shader import inputs as shader_inputs  # noqa: E402
from snell.tracer.shader import object_inputs as oi  # noqa: E402

WIDTH, HEIGHT = 24, 16
RTOL = ATOL = 2e-5          # float32 agreement, with room for Cycles' float32 inputs
OBJECT_COLOR = (0.2, 0.55, 0.9, 0.35)
PASS_INDEX, MATERIAL_PASS_INDEX = 7, 3
PROPERTIES = {"tint": [0.2, 0.45, 0.7, 0.3], "count": 3, "pair": [0.6, -0.4]}


def _grid(n=6, extent=1.6):
    """A smooth n x n grid of quads over [-extent, extent]^2, bumped in z."""
    xs = np.linspace(-extent, extent, n)
    verts = [(x, y, 0.25 * math.sin(1.7 * x) * math.cos(1.3 * y)) for y in xs for x in xs]
    faces = [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i)
             for j in range(n - 1) for i in range(n - 1)]
    mesh = bpy.data.meshes.new("Grid")
    mesh.from_pydata(verts, [], faces)
    mesh.shade_smooth()
    rng = np.random.default_rng(5)
    nc, nv, nf = len(mesh.loops), len(mesh.vertices), len(mesh.polygons)
    col = mesh.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
    col.data.foreach_set("color", rng.uniform(0.0, 1.0, nc * 4).astype(np.float32))
    byte = mesh.color_attributes.new("Bytes", "BYTE_COLOR", "POINT")
    byte.data.foreach_set("color", rng.uniform(0.0, 1.0, nv * 4).astype(np.float32))
    mesh.attributes.new("Weight", "FLOAT", "FACE").data.foreach_set(
        "value", rng.uniform(-1.0, 2.0, nf).astype(np.float32))
    mesh.attributes.new("Offset", "FLOAT_VECTOR", "POINT").data.foreach_set(
        "vector", rng.uniform(-1.0, 1.0, nv * 3).astype(np.float32))
    uv = mesh.uv_layers.new(name="UVMap")
    uv.uv.foreach_set("vector", rng.uniform(0.0, 1.0, nc * 2).astype(np.float32))
    # The active colour attribute is not the render one: an unnamed Color Attribute node
    # reads the render one (the default colour).
    mesh.color_attributes.active_color = col
    mesh.attributes.default_color_name = "Bytes"
    return mesh


def build_scene():
    """The scene (see the module docstring) with an Emission material on the grid, whose
    Color input the tests link; returns its tree and Emission node."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = bpy.data.objects.new("Surface", _grid())
    obj.location = (0.3, -0.2, 0.1)
    obj.rotation_euler = (0.25, -0.15, 0.5)
    obj.scale = (1.3, 0.8, 1.1)
    obj.color = OBJECT_COLOR
    obj.pass_index = PASS_INDEX
    for key, value in PROPERTIES.items():
        obj[key] = value
    scene.view_layers[0]["shade"] = [0.3, 0.6]
    scene["shade"] = 5.0                # the view layer's comes first
    scene["level"] = 0.75
    obj.data["gloss"] = 0.25
    scene.collection.objects.link(obj)
    other = bpy.data.objects.new("Other", None)
    other.location = (-0.4, 0.7, 0.3)
    other.rotation_euler = (0.4, 0.1, -0.8)
    other.scale = (0.5, 1.5, 2.0)
    scene.collection.objects.link(other)

    mat = bpy.data.materials.new("Probe")
    mat.pass_index = MATERIAL_PASS_INDEX
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    obj.data.materials.append(mat)

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 30.0
    cam_data.shift_x, cam_data.shift_y = 0.08, -0.05
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = (0.5, -1.2, 3.2)
    cam.rotation_euler = (0.35, 0.05, 0.1)
    scene.collection.objects.link(cam)
    scene.camera = cam
    world = bpy.data.worlds.new("Black")
    if world.node_tree is not None:
        for node in world.node_tree.nodes:
            if node.bl_idname == "ShaderNodeBackground":
                node.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    world.color = (0.0, 0.0, 0.0)
    scene.world = world

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.max_bounces = 0
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 2
    scene.view_settings.view_transform = "Standard"
    img = scene.render.image_settings
    img.file_format = "OPEN_EXR"
    img.color_depth = "32"
    img.color_mode = "RGB"
    return tree, emission


def instance_grid():
    """Make the grid a collection instance: its collection is instanced by an empty, moved,
    turned and scaled, with custom properties of its own."""
    scene = bpy.context.scene
    grid = bpy.data.objects["Surface"]
    scene.collection.objects.unlink(grid)
    collection = bpy.data.collections.new("Source")
    collection.objects.link(grid)
    holder = bpy.data.objects.new("Holder", None)
    holder.instance_type = "COLLECTION"
    holder.instance_collection = collection
    holder.location = (0.2, 0.3, -0.2)
    holder.rotation_euler = (0.1, 0.2, -0.3)
    holder.scale = (0.9, 1.2, 1.0)
    holder["tint"] = [0.9, 0.1, 0.5, 0.6]
    scene.collection.objects.link(holder)


class Probe:
    """The scene, Cycles' renders of graphs on it, and Snell's values at the points Cycles
    hit."""

    def __init__(self, instanced=False):
        self.tree, self.emission = build_scene()
        if instanced:
            instance_grid()
        self.points = self.cycles(lambda t: self.node("ShaderNodeNewGeometry").outputs[
            "Position"])
        ones = self.cycles(lambda t: self.value(1.0))
        self.mask = ones[:, 0] > 0.5          # pixels that see the grid
        assert self.mask.mean() > 0.6

    def node(self, idname, **props):
        node = self.tree.nodes.new(idname)
        for key, value in props.items():
            setattr(node, key, value)
        return node

    def value(self, v):
        node = self.node("ShaderNodeValue")
        node.outputs[0].default_value = v
        return node.outputs[0]

    def combine(self, *sockets):
        comb = self.node("ShaderNodeCombineXYZ")
        for i, s in enumerate(sockets):
            self.tree.links.new(s, comb.inputs[i])
        return comb.outputs[0]

    def _link(self, build):
        for node in list(self.tree.nodes):
            if node.bl_idname not in ("ShaderNodeOutputMaterial", "ShaderNodeEmission"):
                self.tree.nodes.remove(node)
        self.tree.links.new(build(self.tree), self.emission.inputs["Color"])

    def cycles(self, build):
        """Cycles' (H * W, 3) emission with build(tree)'s socket on the Emission Color."""
        self._link(build)
        scene = bpy.context.scene
        with tempfile.TemporaryDirectory(prefix="snell-objinputs-") as tmp:
            scene.render.filepath = os.path.join(tmp, "probe.exr")
            bpy.ops.render.render(write_still=True)
            return read_exr(scene.render.filepath).astype(np.float64).reshape(-1, 3)

    def snell(self, build):
        """Snell's (H * W, 3) emission of the same graph at the points Cycles hit (0 off the
        grid)."""
        self._link(build)
        scene, warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
        assert not [w for w in warnings if "not evaluated" in w or "does not" in w], warnings
        return SnellPoints(scene).emission(self.points, self.mask)


class SnellPoints:
    """An exported scene's one material run by program.run at given points of its surface."""

    def __init__(self, scene):
        self.scene = scene
        self.camera = Camera(scene.camera)
        self.mats = material_tables(scene.materials, scene.material_ids, scene.images,
                                    scene.texcoords, scene.objects, scene.object_ids,
                                    self.camera)
        self.corners = scene.positions[scene.triangles].astype(np.float64)    # (T, 3, 3)
        self.normals = scene.normals[scene.triangles].astype(np.float64)
        self.regs = program.new_registers()
        self.scratch = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
        self.tables = shipped_tables()

    def _locate(self, p):
        """(triangle, b1, b2) of the triangle nearest p."""
        a, b, c = self.corners[:, 0], self.corners[:, 1], self.corners[:, 2]
        e1, e2, d = b - a, c - a, p - a
        d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
        r1, r2 = (d * e1).sum(1), (d * e2).sum(1)
        det = d11 * d22 - d12 * d12
        b1 = (d22 * r1 - d12 * r2) / det
        b2 = (d11 * r2 - d12 * r1) / det
        q = a + b1[:, None] * e1 + b2[:, None] * e2
        outside = np.maximum(0.0, -np.minimum(np.minimum(b1, b2), 1.0 - b1 - b2))
        t = int(np.argmin(np.linalg.norm(q - p, axis=1) + outside))
        return t, float(b1[t]), float(b2[t])

    def emission(self, points, mask):
        out = np.zeros_like(points)
        eye = self.camera.position
        for k in np.flatnonzero(mask):
            p = points[k]
            t, b1, b2 = self._locate(p)
            n = self.normals[t]
            ns = (1.0 - b1 - b2) * n[0] + b1 * n[1] + b2 * n[2]
            ns /= np.linalg.norm(ns)
            c = self.corners[t]
            ng = np.cross(c[1] - c[0], c[2] - c[0])
            ng /= np.linalg.norm(ng)
            view = eye - p
            distance = float(np.linalg.norm(view))
            view /= distance
            entering = float(ng @ view) > 0.0
            if not entering:
                ng, ns = -ng, -ns
            hit = (tuple(p), tuple(ng), tuple(ns), tuple(view), entering, t, b1, b2,
                   1 << shader_inputs.LP_CAMERA, 0, distance)
            program.run(self.mats, 0, self.regs, hit, self.scratch, self.tables, True)
            out[k] = program.total(self.regs, closures.TOTAL_EMISSION)
        return out


@pytest.fixture(scope="module")
def probe():
    return Probe()


def _agree(a, b, mask):
    """Whether two (N, 3) images agree to float32 precision on the mask (and the largest
    difference, for messages)."""
    diff = np.abs(a[mask] - b[mask])
    worst = float((diff - RTOL * np.abs(b[mask])).max())
    return bool(worst <= ATOL), float(diff.max())


def _assert_agree(snell, cycles, mask, what):
    ok, worst = _agree(snell, cycles, mask)
    assert ok, f"{what}: Snell and Cycles differ by up to {worst:.3g}"


def _assert_caught(wrong, cycles, mask, what):
    ok, worst = _agree(wrong, cycles, mask)
    assert not ok, f"{what} was not caught (largest difference {worst:.3g})"


def _texcoord(probe, output, target=None):
    def build(tree):
        node = probe.node("ShaderNodeTexCoord")
        node.object = target
        return node.outputs[output]
    return build


def test_texture_coordinate_outputs_match_cycles(probe, monkeypatch):
    """Texture Coordinate's Normal (the smooth shading normal in the grid's space, under an
    unequal scale), Camera, Window (a shifted perspective camera, 24 x 16) and Object of
    another object (an empty) match Cycles to float32 precision (measured: largest
    differences 1.2e-7, 3.6e-7, 2.2e-7, 4.7e-7). Teeth, each caught (largest differences):
    the Window's y flipped (0.94), the Camera's z negated, Blender's camera space with -z
    ahead (7.2), the Normal brought to object space by M^-1 rather than M^T (0.17), and Object
    ignoring the other object, the grid's own space (4.8)."""
    other = bpy.data.objects["Other"]
    for output in ("Normal", "Camera", "Window"):
        build = _texcoord(probe, output)
        _assert_agree(probe.snell(build), probe.cycles(build), probe.mask, output)
    build = _texcoord(probe, "Object", other)
    cycles_object = probe.cycles(build)
    _assert_agree(probe.snell(build), cycles_object, probe.mask, "Object of another object")
    _assert_caught(probe.snell(_texcoord(probe, "Object")), cycles_object, probe.mask,
                   "Object ignoring the other object")

    window = probe.cycles(_texcoord(probe, "Window"))
    flipped = probe.snell(_texcoord(probe, "Window")) * [1, -1, 1] + [0, 1, 0]
    _assert_caught(flipped, window, probe.mask, "the Window's y flipped")
    camera = probe.cycles(_texcoord(probe, "Camera"))
    _assert_caught(probe.snell(_texcoord(probe, "Camera")) * [1, 1, -1], camera, probe.mask,
                   "the Camera's z negated")

    from snell.tracer import materials as tracer_materials

    def inverse_rows(objects):
        table = oi.object_table(objects)
        for row in table:
            m = np.vstack([row[:12].reshape(3, 4), [0, 0, 0, 1]])
            row[:12] = np.linalg.inv(m).T[:3].ravel()
        return table
    normal = probe.cycles(_texcoord(probe, "Normal"))
    monkeypatch.setattr(tracer_materials, "object_table", inverse_rows)
    _assert_caught(probe.snell(_texcoord(probe, "Normal")), normal, probe.mask,
                   "the Normal by M^-1")


def _object_info(probe, *outputs):
    def build(tree):
        node = probe.node("ShaderNodeObjectInfo")
        sockets = [node.outputs[o] for o in outputs]
        return sockets[0] if len(sockets) == 1 else probe.combine(*sockets)
    return build


def test_object_info_matches_cycles(probe):
    """Object Info's Location, Color, Alpha, Object Index (pass index 7), Material Index (the
    material's pass index 3) and Random (Cycles' hash of the object's name) match Cycles
    exactly (measured: difference 0). Teeth: the random id hashed with seed 1 instead of 0
    (0.774 instead of Cycles' 0.105), caught."""
    for outputs in (("Location",), ("Color",), ("Alpha", "Object Index", "Random"),
                    ("Material Index",)):
        build = _object_info(probe, *outputs)
        _assert_agree(probe.snell(build), probe.cycles(build), probe.mask, " ".join(outputs))
    build = _object_info(probe, "Alpha", "Object Index", "Random")
    cycles = probe.cycles(build)
    assert np.allclose(cycles[probe.mask][:, :2], [OBJECT_COLOR[3], PASS_INDEX])

    from snell.tracer.shader.hashes import hash_uint2
    h = 0
    for byte in b"Surface":
        h = h * 37 + byte
    wrong = probe.snell(build)
    wrong[:, 2] = oi.random_number(int(hash_uint2(h % 2 ** 32, 1)))
    _assert_caught(wrong, cycles, probe.mask, "the random id hashed with seed 1")


def _attribute(probe, *outputs):
    """outputs: (node idname, name, output) each (an Attribute node's name may be "TYPE:name",
    its attribute_type)."""
    def build(tree):
        sockets = []
        for idname, name, output in outputs:
            if idname == "ShaderNodeAttribute":
                kind, _, name = name.rpartition(":")
                node = probe.node(idname, attribute_name=name, attribute_type=kind or "GEOMETRY")
            else:
                node = probe.node(idname, layer_name=name)
            sockets.append(node.outputs[output])
        return sockets[0] if len(sockets) == 1 else probe.combine(*sockets)
    return build


ATTR, COLOR_ATTR = "ShaderNodeAttribute", "ShaderNodeVertexColor"
ATTRIBUTE_GRAPHS = (
    ((ATTR, "Col", "Color"),),
    ((ATTR, "Col", "Fac"), (ATTR, "Col", "Alpha"), (ATTR, "Weight", "Fac")),
    ((ATTR, "Offset", "Vector"),),
    ((ATTR, "UVMap", "Color"),),
    ((ATTR, "UVMap", "Fac"), (ATTR, "Offset", "Fac"), (ATTR, "Bytes", "Alpha")),
    ((ATTR, "Missing", "Fac"), (ATTR, "Missing", "Alpha"), (COLOR_ATTR, "Missing", "Alpha")),
    ((COLOR_ATTR, "", "Color"),),
    ((COLOR_ATTR, "", "Alpha"), (COLOR_ATTR, "Col", "Alpha"), (ATTR, "Weight", "Alpha")),
    ((COLOR_ATTR, "Col", "Color"),),
    ((ATTR, "Weight", "Color"),),
    ((ATTR, "generated", "Color"),),
    ((ATTR, "uv", "Color"),),
    ((ATTR, "generated", "Fac"), (ATTR, "uv", "Fac"), (ATTR, "vertex_color", "Alpha")),
    ((ATTR, "", "Color"),),
    ((ATTR, "", "Fac"), (ATTR, "", "Alpha"), (ATTR, "", "Vector")),
)


@pytest.mark.parametrize("outputs", ATTRIBUTE_GRAPHS,
                         ids=["-".join(f"{n or 'default'}.{o}" for _, n, o in g)
                              for g in ATTRIBUTE_GRAPHS])
def test_attributes_match_cycles(probe, outputs):
    """Attribute (type Geometry) and Color Attribute outputs match Cycles to float32
    precision: a float colour on corners, a byte colour on points (the render default, read by
    an unnamed Color Attribute node), a float on faces, a vector on points, a UV map; a
    missing attribute gives Fac 0 and Alpha 1 (Attribute) or Alpha 0 (Color Attribute);
    Cycles' standard names generated, uv and vertex_color; an Attribute node without a name
    reads nothing (measured: largest differences 0 to 5.8e-7 over the graphs)."""
    build = _attribute(probe, *outputs)
    _assert_agree(probe.snell(build), probe.cycles(build), probe.mask, str(outputs))


PROPERTY_GRAPHS = (
    ((ATTR, "OBJECT:tint", "Color"),),
    ((ATTR, "OBJECT:tint", "Fac"), (ATTR, "OBJECT:tint", "Alpha"), (ATTR, "OBJECT:count", "Fac")),
    ((ATTR, "OBJECT:location", "Vector"),),
    ((ATTR, "OBJECT:pair", "Color"),),
    ((ATTR, "OBJECT:gloss", "Fac"), (ATTR, "OBJECT:missing", "Alpha"),
     (ATTR, "INSTANCER:tint", "Alpha")),
    ((ATTR, "OBJECT:pass_index", "Fac"), (ATTR, "OBJECT:pair", "Alpha"),
     (ATTR, "INSTANCER:count", "Alpha")),
    ((ATTR, "VIEW_LAYER:shade", "Color"),),
    ((ATTR, "VIEW_LAYER:level", "Fac"), (ATTR, "VIEW_LAYER:shade", "Alpha"),
     (ATTR, "VIEW_LAYER:missing", "Alpha")),
)


@pytest.mark.parametrize("outputs", PROPERTY_GRAPHS,
                         ids=["-".join(f"{n}.{o}" for _, n, o in g) for g in PROPERTY_GRAPHS])
def test_object_properties_match_cycles(probe, outputs):
    """Attribute nodes of type Object and Instancer (the grid is no instance: its own) read
    its custom properties (a float array of four, of two, an integer), its mesh's (a float)
    and RNA paths (location, pass_index), and of type View Layer the view layer's property
    before the scene's, as Cycles does (measured: equal to float32)."""
    build = _attribute(probe, *outputs)
    _assert_agree(probe.snell(build), probe.cycles(build), probe.mask, str(outputs))


def test_attribute_domains_have_teeth(probe, monkeypatch):
    """Teeth of the attribute comparisons: the face attribute read with each corner's vertex
    as its face, the wrong domain (measured: largest difference 2.7), the active colour
    attribute taken for the default (render) one (0.81), and an object property that is not
    found read as (0, 0, 0, 1) rather than Blender's zeros (1.0) are caught."""
    build = _attribute(probe, (ATTR, "Weight", "Color"))
    cycles = probe.cycles(build)
    monkeypatch.setattr(export_meshes, "_corner_faces",
                        lambda mesh, n: np.arange(n) % len(mesh.polygons))
    _assert_caught(probe.snell(build), cycles, probe.mask, "the face attribute by corner")
    monkeypatch.undo()
    default = probe.cycles(_attribute(probe, (COLOR_ATTR, "", "Color")))
    _assert_caught(probe.snell(_attribute(probe, (COLOR_ATTR, "Col", "Color"))), default,
                   probe.mask, "the active colour attribute for the default")
    from snell.addon.export import custom_properties
    build = _attribute(probe, (ATTR, "OBJECT:missing", "Alpha"))
    cycles = probe.cycles(build)
    monkeypatch.setattr(custom_properties, "NOT_FOUND", (0.0, 0.0, 0.0, 1.0))
    _assert_caught(probe.snell(build), cycles, probe.mask, "a missing property of alpha 1")


def test_camera_data_matches_cycles(probe):
    """Camera Data's View Vector, View Z Depth and View Distance match Cycles to float32
    precision (measured: largest differences 8.5e-8 and 4.4e-7). Teeth: the Z depth's sign
    flipped, Blender's camera space (7.2), caught."""
    def vector(tree):
        return probe.node("ShaderNodeCameraData").outputs["View Vector"]

    def depths(tree):
        node = probe.node("ShaderNodeCameraData")
        return probe.combine(node.outputs["View Z Depth"], node.outputs["View Distance"])
    _assert_agree(probe.snell(vector), probe.cycles(vector), probe.mask, "View Vector")
    cycles = probe.cycles(depths)
    snell = probe.snell(depths)
    _assert_agree(snell, cycles, probe.mask, "View Z Depth and Distance")
    _assert_caught(snell * [-1, 1, 1], cycles, probe.mask, "the Z depth negated")


def test_random_of_a_non_ascii_name_matches_cycles(probe):
    """Random of an object named with non-ASCII letters: Cycles hashes its UTF-8 bytes as
    unsigned numbers (measured: equal, 0.3673). Teeth: the bytes from 128 taken as signed C
    chars (0.8712), caught."""
    obj = bpy.data.objects["Surface"]
    obj.name = "Würfel Ω"
    try:
        build = _object_info(probe, "Random")
        cycles = probe.cycles(build)
        _assert_agree(probe.snell(build), cycles, probe.mask, "Random")
        from snell.tracer.shader.hashes import hash_uint2
        h = 0
        for byte in obj.name.encode():
            h = (h * 37 + (byte if byte < 128 else byte - 256)) % 2 ** 32
        signed = np.full_like(cycles, oi.random_number(int(hash_uint2(h, 0))))
        _assert_caught(signed, cycles, probe.mask, "signed bytes")
    finally:
        obj.name = "Surface"


@pytest.fixture(scope="module")
def instanced():
    """The grid as a collection instance (built after the tests of `probe`: it resets bpy)."""
    return Probe(instanced=True)


INSTANCE_GRAPHS = (
    ((ATTR, "INSTANCER:tint", "Color"),),
    ((ATTR, "INSTANCER:tint", "Alpha"), (ATTR, "OBJECT:tint", "Alpha"),
     (ATTR, "INSTANCER:count", "Fac")),
)


def test_instance_matches_cycles(instanced):
    """On a collection instance (an empty instancing the grid's collection, moved, turned and
    scaled): Object Info Random (the depsgraph instance's random id), Location, Texture
    Coordinate Normal and Object (the instance's matrix), and Attribute nodes of type
    Instancer (the instancer's custom property first, then the object's) and Object (the
    object's own) match Cycles (measured: largest differences 0 to 4.4e-7). Teeth: Random from
    the hash of the object's name, as for an object that is not an instance, caught."""
    graphs = [_object_info(instanced, "Random", "Alpha", "Object Index"),
              _object_info(instanced, "Location"), _texcoord(instanced, "Normal"),
              _texcoord(instanced, "Object")]
    graphs += [_attribute(instanced, *g) for g in INSTANCE_GRAPHS]
    for k, build in enumerate(graphs):
        _assert_agree(instanced.snell(build), instanced.cycles(build), instanced.mask,
                      f"graph {k}")
    from snell.addon.export.depsgraph import object_random_id
    cycles = instanced.cycles(graphs[0])
    wrong = instanced.snell(graphs[0])
    wrong[:, 0] = oi.random_number(object_random_id("Surface"))
    _assert_caught(wrong, cycles, instanced.mask, "Random of the object's name")
