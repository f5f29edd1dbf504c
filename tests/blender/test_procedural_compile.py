"""The procedural texture nodes compiled (addon/export/shader/procedural_textures.py) and run as
shader program rows (tracer/shader/procedural_textures.py's execute) against Cycles: each node
drives the probe plane's emission (support/node_probe.py) and its rows are run at the float32
points Cycles shaded. This holds the exporter's side (Blender's enum strings, sockets, parameter
blocks and settings ints) where tests/blender/test_procedural_textures.py holds the formulas.

Until the shader program core is on main, the rows are compiled by `RowCompiler` below, which
offers the contract's Compiler methods over the probe's one graph (the linked Vector is the
point, a W linked from Separate XYZ is its x, unlinked inputs are their values).

Teeth: a row whose settings int names the wrong enum must disagree (test_wrong_settings_caught:
Voronoi's metric Minkowski read as Manhattan differs by up to 0.21), and the comparison fails
when the compiler's enum tables are wrong (measured: "F2" mapped to F1 failed the two F2 cases,
off by 0.70 and 0.77; the rings direction "Y" mapped to Z failed the Y rings case, off by 0.96).
"""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.node_probe import probe  # noqa: E402

from snell.addon.export.shader import procedural_textures as compiled  # noqa: E402
from snell.tracer.shader import procedural_textures as family  # noqa: E402

SIZE = 16
LOCATION = (0.3, -0.2, 0.4)
ROTATION = (0.5, 0.7, 0.2)
# float32 rounding as measured by the formula tests (Noise's is the largest)
TOL = {"ShaderNodeTexNoise": 5e-4}
TOL_DEFAULT = 1e-4
EDGE = 2e-4


class RowCompiler:
    """The Compiler's methods (contract of issue 29) for one node of the probe graph: its
    registers, constants and rows, with the point in registers 0-2."""

    POINT = 0

    def __init__(self):
        self.regs = [0.0, 0.0, 0.0]
        self.rows = []
        self.warnings = []

    def alloc(self, kind):
        r = len(self.regs)
        self.regs += [0.0] * (1 if kind == "float" else 3)
        return r

    def constant(self, value):
        if isinstance(value, (int, float)):
            r = self.alloc("float")
            self.regs[r] = float(value)
        else:
            r = self.alloc("vector")
            self.regs[r:r + 3] = [float(v) for v in list(value)[:3]]
        return r

    def _socket(self, node, name):
        return next(s for s in node.inputs if s.identifier == name or s.name == name)

    def _link(self, node, name):
        socket = self._socket(node, name)
        # by names: node and socket names are unique in a tree
        return next((link for link in node.id_data.links if link.to_node.name == node.name
                     and link.to_socket.identifier == socket.identifier), None)

    def is_linked(self, node, name):
        return self._link(node, name) is not None

    def input(self, node, name, kind):
        socket = self._socket(node, name)
        link = self._link(node, name)
        if link is not None:
            source = link.from_node
            # the probe graph links the point (Mapping) or its x (Separate XYZ)
            assert source.bl_idname in ("ShaderNodeMapping", "ShaderNodeSeparateXYZ",
                                        "ShaderNodeVectorMath"), source.bl_idname
            return self.POINT
        value = socket.default_value
        if kind == "float":
            return self.constant(float(value))
        return self.constant(tuple(value)[:3])

    def value(self, node, name):
        return self._socket(node, name).default_value

    def texcoord(self, node, which):
        raise AssertionError("the probe graphs link every texture's Vector")

    def emit(self, opcode, *slots):
        assert len(slots) <= 7
        self.rows.append([opcode, *slots] + [0] * (7 - len(slots)))

    def data(self, values):
        raise AssertionError("the procedural textures store no data")

    def warn(self, node, what, instead, input=None):
        self.warnings.append((node.name, what, instead, input))

    def run(self, x, y, z):
        """The registers after the rows ran at the point (x, y, z)."""
        regs = np.array(self.regs, dtype=np.float64)
        regs[0:3] = (x, y, z)
        for row in self.rows:
            ins = np.array(row, dtype=np.int64)
            assert ins[0] in family.SPECS
            family.execute(ins, regs, np.zeros(1))
        return regs


def _coordinates(tree):
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.vector_type = "POINT"
    mapping.inputs["Location"].default_value = LOCATION
    mapping.inputs["Rotation"].default_value = ROTATION
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Object"],
                   mapping.inputs["Vector"])
    return mapping.outputs["Vector"]


def _build(idname, props, inputs, output, w_from_x, store, mapped=True):
    def build(tree):
        coords = (_coordinates(tree) if mapped
                  else tree.nodes.new("ShaderNodeTexCoord").outputs["Object"])
        node = tree.nodes.new(idname)
        for name, value in props.items():
            setattr(node, name, value)
        for name, value in inputs.items():
            next(s for s in node.inputs if s.identifier == name).default_value = value
        if w_from_x:
            sep = tree.nodes.new("ShaderNodeSeparateXYZ")
            tree.links.new(coords, sep.inputs[0])
            tree.links.new(sep.outputs["X"], next(s for s in node.inputs if s.identifier == "W"))
        vector = next(s for s in node.inputs if s.identifier == "Vector")
        if vector.enabled:
            tree.links.new(coords, vector)
        store["node"] = node
        return next(s for s in node.outputs if s.identifier == output)

    def compile_node(material):
        # once the output is linked to the emission (the compiler asks which outputs are used),
        # and while the node exists (the probe resets bpy afterwards)
        node = store.pop("node")
        c = RowCompiler()
        outputs = compiled.COMPILERS[idname](c, node)
        kinds = {s.identifier: s.type for s in node.outputs}
        store.update(compiler=c, register=outputs[output], kind=kinds[output])
    return build, compile_node


CASES = [
    ("ShaderNodeTexNoise", dict(noise_dimensions="3D", noise_type="FBM", normalize=True),
     dict(Scale=3.0, Detail=2.5, Roughness=0.6, Distortion=0.3), "Color", False),
    ("ShaderNodeTexNoise", dict(noise_dimensions="4D", noise_type="HYBRID_MULTIFRACTAL"),
     dict(Scale=2.0, Detail=1.5, Offset=0.8, Gain=1.4), "Fac", True),
    ("ShaderNodeTexNoise", dict(noise_dimensions="1D", noise_type="RIDGED_MULTIFRACTAL"),
     dict(Scale=4.0, Detail=2.0, Offset=1.0, Gain=2.0), "Color", True),
    ("ShaderNodeTexVoronoi", dict(voronoi_dimensions="3D", feature="F2", distance="MANHATTAN",
                                  normalize=True),
     dict(Scale=3.0, Detail=1.5, Roughness=0.6), "Color", False),
    ("ShaderNodeTexVoronoi", dict(voronoi_dimensions="2D", feature="SMOOTH_F1",
                                  distance="MINKOWSKI"),
     dict(Scale=3.0, Exponent=1.5, Smoothness=0.6, Randomness=0.8), "Distance", False),
    ("ShaderNodeTexVoronoi", dict(voronoi_dimensions="4D", feature="F2"),
     dict(Scale=2.0), "Position", True),
    ("ShaderNodeTexVoronoi", dict(voronoi_dimensions="1D", feature="F1"),
     dict(Scale=3.0), "W", True),
    ("ShaderNodeTexVoronoi", dict(voronoi_dimensions="3D", feature="DISTANCE_TO_EDGE"),
     dict(Scale=3.0, Detail=1.0), "Distance", False),
    ("ShaderNodeTexVoronoi", dict(voronoi_dimensions="2D", feature="N_SPHERE_RADIUS"),
     dict(Scale=3.0), "Radius", False),
    ("ShaderNodeTexChecker", {}, dict(Scale=3.0, Color1=(0.9, 0.4, 0.1, 1.0)), "Color", False),
    ("ShaderNodeTexBrick", dict(offset=0.3, offset_frequency=3, squash=0.6, squash_frequency=2),
     {"Scale": 2.5, "Mortar Size": 0.05, "Mortar Smooth": 0.4, "Bias": 0.2,
      "Color2": (0.1, 0.5, 0.2, 1.0)}, "Color", False),
    ("ShaderNodeTexBrick", {}, dict(Scale=3.0), "Fac", False),
    ("ShaderNodeTexGradient", dict(gradient_type="EASING"), {}, "Color", False),
    ("ShaderNodeTexWave", dict(wave_type="RINGS", rings_direction="Y", wave_profile="TRI"),
     dict(Scale=1.3, Distortion=3.0, Detail=2.0), "Color", False),
    ("ShaderNodeTexWave", dict(wave_type="BANDS", bands_direction="DIAGONAL",
                               wave_profile="SIN"),
     {"Scale": 1.5, "Phase Offset": 0.4}, "Fac", False),
    ("ShaderNodeTexMagic", dict(turbulence_depth=4), dict(Scale=1.5, Distortion=2.0), "Fac",
     False),
    ("ShaderNodeTexGabor", dict(gabor_type="3D"),
     {"Scale": 2.0, "Anisotropy": 0.5, "Orientation 3D": (0.3, 0.5, 0.8)}, "Intensity", False),
    ("ShaderNodeTexGabor", dict(gabor_type="2D"), {"Scale": 3.0, "Orientation 2D": 0.3}, "Value",
     False),
]


@pytest.fixture(scope="module")
def points():
    """The float32 points Cycles shades, read back from the probe."""
    image, _ = probe(_coordinates, size=SIZE)
    return image


@pytest.fixture(scope="module")
def renders():
    """Per case: (Cycles' image, the compiled node)."""
    out = []
    for idname, props, inputs, output, w_from_x in CASES:
        store = {}
        build, compile_node = _build(idname, props, inputs, output, w_from_x, store)
        image, _ = probe(build, size=SIZE, material_setup=compile_node)
        out.append((image, store))
    return out


def _values(store, pts, rows=None):
    """The compiled output at every point, as an image (a float splatted)."""
    c, r, kind = store["compiler"], store["register"], store["kind"]
    if rows is not None:
        c = _with_rows(c, rows)
    out = np.zeros(pts.shape[:2] + (3,))
    for i in range(pts.shape[0]):
        for j in range(pts.shape[1]):
            regs = c.run(*(float(t) for t in pts[i, j]))
            out[i, j] = regs[r] if kind == "VALUE" else regs[r:r + 3]
    return out


def _with_rows(c, rows):
    other = RowCompiler()
    other.regs, other.rows = c.regs, rows
    return other


def _near_edges(store, pts):
    base = _values(store, pts)
    near = np.zeros(pts.shape[:2], dtype=bool)
    for axis in range(3):
        for sign in (-1.0, 1.0):
            moved = pts.copy()
            moved[..., axis] += sign * EDGE
            near |= np.abs(_values(store, moved) - base).max(axis=2) > 0.05
    return near


@pytest.mark.parametrize("case", range(len(CASES)))
def test_compiled_node_matches_cycles(renders, points, case):
    """The node's compiled rows give Cycles' output at every point (away from cell edges), with
    no warning."""
    image, store = renders[case]
    assert store["compiler"].warnings == []
    near = _near_edges(store, points)
    assert near.mean() < 0.2
    err = np.abs(_values(store, points) - image).max(axis=2)[~near].max()
    assert err < TOL.get(CASES[case][0], TOL_DEFAULT), err


def test_wrong_settings_caught(renders, points):
    """The Voronoi row with its metric digit changed (Minkowski read as Manhattan) disagrees
    with Cycles."""
    image, store = renders[4]
    rows = [list(r) for r in store["compiler"].rows]
    row = next(r for r in rows if r[0] == family.VORONOI)
    dims, feature, metric, normalize = (family.setting(row[7], i, 4) for i in range(4))
    assert metric == compiled.METRICS["MINKOWSKI"]
    row[7] = family.settings(dims, feature, compiled.METRICS["MANHATTAN"], normalize)
    err = np.abs(_values(store, points, rows) - image).max()
    assert err > 0.05, err


def test_unknown_enum_warns():
    """An enum value the compiler does not know becomes its default, with a warning naming the
    property."""
    class Node:
        name = "Noise"
        noise_dimensions = "5D"
    c = RowCompiler()
    assert compiled._enum(c, Node(), "noise_dimensions", compiled.DIMENSIONS, 3) == 3
    assert c.warnings and "noise_dimensions" in c.warnings[0][1]


class _Recorder(RowCompiler):
    """A RowCompiler that records which texture coordinates were asked for."""

    def __init__(self):
        super().__init__()
        self.asked = []

    def texcoord(self, node, which, name=""):
        self.asked.append(which)
        return self.constant((0.0, 0.0, 0.0))


def _lone_node(idname):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tree = bpy.data.materials.new("Lone").node_tree
    return tree.nodes.new(idname)


@pytest.mark.parametrize("idname", sorted(compiled.COMPILERS))
def test_unlinked_vector_reads_generated(idname):
    """A texture with an unlinked Vector reads Generated coordinates (Cycles'
    LINK_TEXTURE_GENERATED), except White Noise, whose Cycles node has no default link and
    reads the socket's value (White Noise compiled with the textures' Generated default:
    caught)."""
    node = _lone_node(idname)
    c = _Recorder()
    compiled.COMPILERS[idname](c, node)
    if idname == "ShaderNodeTexWhiteNoise":
        assert c.asked == []
    else:
        assert c.asked == ["generated"]
    assert c.warnings == []


def test_texture_mapping_warns():
    """A node's texture_mapping moved from Python (not applied) is named in a warning."""
    node = _lone_node("ShaderNodeTexChecker")
    node.texture_mapping.translation = (0.5, 0.0, 0.0)
    c = _Recorder()
    compiled.COMPILERS["ShaderNodeTexChecker"](c, node)
    assert len(c.warnings) == 1 and "texture mapping" in c.warnings[0][1]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_the_cores_compiler_accepts_the_rows(case):
    """Through the core's exporter (addon/export/materials.convert_material with the scene's
    texture resources), each case's probe material becomes a program with no issue, and the
    scene loader's check (program.check_program) accepts its rows."""
    from support.node_probe import probe_scene

    from snell.addon.export.materials import convert_material
    from snell.addon.export.textures import ImageTextures
    from snell.tracer.shader.program import check_program

    idname, props, inputs, output, w_from_x = CASES[case]
    # Object coordinates straight in, W unlinked (Mapping and Separate XYZ are another
    # family's)
    build, _ = _build(idname, props, inputs, output, False, {}, mapped=False)
    probe_scene(build, size=SIZE)
    resources = ImageTextures([])
    mat, coverage = convert_material(bpy.data.materials["Probe"], resources)
    assert mat["kind"] == "program" and coverage.issues == [], coverage.issues
    check_program(mat["program"], 0, len(resources.texcoord_keys))
    assert any(row[0] >= 300 for row in mat["program"]["code"])
