"""Random Blender scenes from a grammar, for the .blend fuzzer (tests/blender/test_blend_fuzz.py).

Run with bpy in a subprocess (it resets bpy):

    python tests/support/blend_fuzz.py OUT_DIR SEED COUNT

writes fuzz_<SEED>_<i>.blend for i in 0 .. COUNT - 1 and fuzz_<SEED>.json: for each file what
the grammar chose (one line per choice) and the image size Blender would render. Scene i of a
seed is the same whatever COUNT is (its own random.Random(SEED * 100003 + i)).

The grammar: 1 to 5 objects (mesh primitives, curves with and without bevel, text, metaballs,
empties, collection and vertex instances, particle systems, Geometry Nodes modifiers and other
modifiers with odd values), a material on each (node graphs of supported and unsupported nodes,
links that Blender marks invalid, zero, negative, NaN and huge values), 0 to 3 lights, a world, a
camera (perspective, orthographic, panoramic, odd lenses and clipping, depth of field) and render
settings (odd resolutions and percentages, pixel filters, bounces, Snell's and Cycles' samples).
Images stay tiny (at most 24 pixels a side) so each render takes a second or two.
"""
from __future__ import annotations

import json
import math
import os
import random
import sys

import bpy

NAN, INF = float("nan"), float("inf")


class Grammar:
    """One scene's choices, drawn from its own random stream and written down as they are made."""

    def __init__(self, rng: random.Random):
        self.rng = rng
        self.log: list[str] = []

    def pick(self, what, options):
        choice = self.rng.choice(options)
        self.log.append(f"{what}: {choice!r}")
        return choice

    def chance(self, p):
        return self.rng.random() < p

    def odd_number(self, what, usual):
        """Usually a value in `usual` (low, high), sometimes 0, negative, NaN, Inf or huge."""
        r = self.rng.random()
        if r < 0.85:
            value = self.rng.uniform(*usual)
        else:
            value = self.rng.choice([0.0, -1.0, -usual[1], NAN, INF, -INF, 1e30, 1e-30, 1e6])
        self.log.append(f"{what}: {value!r}")
        return value


def _set(socket_owner, name, value):
    """Set an input's default value if the node has it (names vary between node versions)."""
    socket = socket_owner.inputs.get(name)
    if socket is None or not hasattr(socket, "default_value"):
        return
    current = socket.default_value
    try:
        if hasattr(current, "__len__") and not isinstance(value, (list, tuple)):
            socket.default_value = [value] * len(current)
        else:
            socket.default_value = value
    except (TypeError, ValueError):
        pass


# ---------------------------------------------------------------------------------------------
# Materials


def _image(g: Grammar, name):
    """A generated image of 1x1 to 8x4 pixels, some of them NaN, Inf, negative or huge; or one
    whose file is missing."""
    if g.chance(0.2):
        image = bpy.data.images.new(name, 4, 4)
        image.filepath = "//missing_texture.png"
        image.source = "FILE"
        g.log.append(f"{name}: a missing file")
        return image
    width, height = g.rng.choice([(1, 1), (2, 1), (8, 4)])
    image = bpy.data.images.new(name, width, height, float_buffer=g.chance(0.7))
    pixels = [g.rng.random() for _ in range(width * height * 4)]
    if g.chance(0.5):
        odd = g.pick(f"{name} pixel", [NAN, INF, -INF, -1.0, 1e30, 3e38])
        pixels[g.rng.randrange(len(pixels))] = odd
    image.pixels = pixels
    if g.chance(0.5):
        image.pack()
    return image

BSDFS = ["ShaderNodeBsdfPrincipled", "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfGlossy",
         "ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction", "ShaderNodeEmission",
         "ShaderNodeBsdfTransparent", "ShaderNodeBsdfTranslucent", "ShaderNodeHoldout",
         "ShaderNodeBsdfSheen", "ShaderNodeBsdfMetallic"]
UNSUPPORTED = ["ShaderNodeBsdfToon", "ShaderNodeBsdfHair", "ShaderNodeSubsurfaceScattering",
               "ShaderNodeBsdfHairPrincipled", "ShaderNodeBsdfRayPortal",
               "ShaderNodeAmbientOcclusion",
               "ShaderNodeBevel", "ShaderNodeWireframe", "ShaderNodeVolumePrincipled",
               "ShaderNodeVolumeScatter", "ShaderNodeLightFalloff", "ShaderNodeParticleInfo",
               "ShaderNodeHairInfo", "ShaderNodePointInfo", "ShaderNodeScript"]
VALUES = ["ShaderNodeTexNoise", "ShaderNodeTexVoronoi", "ShaderNodeTexChecker", "ShaderNodeTexWave",
          "ShaderNodeTexMagic", "ShaderNodeTexGradient", "ShaderNodeTexBrick", "ShaderNodeTexImage",
          "ShaderNodeTexEnvironment", "ShaderNodeTexSky", "ShaderNodeMath", "ShaderNodeVectorMath",
          "ShaderNodeMix", "ShaderNodeValToRGB", "ShaderNodeRGBCurve", "ShaderNodeMapRange",
          "ShaderNodeLayerWeight", "ShaderNodeFresnel", "ShaderNodeTexCoord", "ShaderNodeAttribute",
          "ShaderNodeBump", "ShaderNodeNormalMap", "ShaderNodeBlackbody", "ShaderNodeWavelength",
          "ShaderNodeLightPath", "ShaderNodeObjectInfo", "ShaderNodeValue", "ShaderNodeRGB",
          "ShaderNodeSeparateColor", "ShaderNodeCombineXYZ", "ShaderNodeHueSaturation",
          "ShaderNodeTexWhiteNoise", "ShaderNodeTexGabor", "ShaderNodeUVMap",
          "ShaderNodeVertexColor"]
SHADER_INPUTS = ("Base Color", "Color", "Roughness", "Metallic", "IOR", "Strength",
                 "Emission Strength", "Transmission Weight", "Alpha", "Coat Weight",
                 "Specular IOR Level", "Anisotropic", "Sheen Weight", "Subsurface Weight")


def material(g: Grammar, name: str):
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    for node in list(tree.nodes):
        tree.nodes.remove(node)
    if g.chance(0.05):
        g.log.append(f"{name}: no nodes")
        return mat
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    if g.chance(0.05):
        g.log.append(f"{name}: Material Output only")
        return mat
    shaders = []
    for _ in range(g.rng.randint(1, 3)):
        kind = g.pick(f"{name} shader", BSDFS if g.chance(0.8) else UNSUPPORTED)
        node = tree.nodes.new(kind)
        for socket in SHADER_INPUTS:
            if socket in node.inputs and g.chance(0.3):
                _set(node, socket, g.odd_number(f"{name} {kind} {socket}", (0.0, 1.0)))
        shaders.append(node)
    surface = shaders[0]
    if len(shaders) > 1:
        mix = tree.nodes.new(g.pick(f"{name} mix", ["ShaderNodeMixShader", "ShaderNodeAddShader"]))
        if mix.bl_idname == "ShaderNodeMixShader":
            _set(mix, "Fac", g.odd_number(f"{name} mix factor", (0.0, 1.0)))
        shader_inputs = [s for s in mix.inputs if s.type == "SHADER"]
        for socket, shader in zip(shader_inputs, shaders):
            if shader.outputs:
                tree.links.new(shader.outputs[0], socket)
        surface = mix
    for _ in range(g.rng.randint(0, 4)):
        kind = g.pick(f"{name} value node", VALUES)
        node = tree.nodes.new(kind)
        if kind in ("ShaderNodeTexImage", "ShaderNodeTexEnvironment") and g.chance(0.6):
            node.image = _image(g, f"{name}_image")
        for socket in node.inputs:
            if hasattr(socket, "default_value") and g.chance(0.2):
                _set(node, socket.name, g.odd_number(f"{name} {kind} {socket.name}", (0.0, 2.0)))
        targets = [s for n in [surface, *shaders] for s in n.inputs if not s.is_linked]
        if node.outputs and targets:
            source = g.rng.choice(list(node.outputs))
            target = g.rng.choice(targets)
            g.log.append(f"{name} link: {kind}.{source.name} -> "
                         f"{target.node.bl_idname}.{target.name}")
            tree.links.new(source, target)
    if surface.outputs:
        tree.links.new(surface.outputs[0], output.inputs["Surface"])
    if g.chance(0.1):   # a shader into a colour: Blender keeps the link and marks it invalid
        shader = tree.nodes.new("ShaderNodeBsdfDiffuse")
        colour = [s for s in surface.inputs if s.type == "RGBA"]
        if colour:
            tree.links.new(shader.outputs[0], colour[0])
            g.log.append(f"{name}: shader linked into a colour input")
    if g.chance(0.1):   # a loop: Blender keeps it too
        a, b = tree.nodes.new("ShaderNodeMath"), tree.nodes.new("ShaderNodeMath")
        tree.links.new(a.outputs[0], b.inputs[0])
        tree.links.new(b.outputs[0], a.inputs[0])
        targets = [s for s in surface.inputs if s.type in ("VALUE", "RGBA") and not s.is_linked]
        if targets:
            tree.links.new(b.outputs[0], targets[0])
        g.log.append(f"{name}: a loop of two Math nodes")
    if g.chance(0.1):
        tree.nodes.new("ShaderNodeOutputMaterial").is_active_output = True
        g.log.append(f"{name}: a second, empty Material Output made active")
    if g.chance(0.1):
        vol = tree.nodes.new(g.pick(f"{name} volume", ["ShaderNodeVolumeAbsorption",
                                                       "ShaderNodeVolumeScatter",
                                                       "ShaderNodeVolumePrincipled"]))
        _set(vol, "Density", g.odd_number(f"{name} volume density", (0.0, 5.0)))
        tree.links.new(vol.outputs[0], output.inputs["Volume"])
    if g.chance(0.1):
        disp = tree.nodes.new("ShaderNodeDisplacement")
        _set(disp, "Height", g.odd_number(f"{name} displacement height", (0.0, 1.0)))
        tree.links.new(disp.outputs[0], output.inputs["Displacement"])
    return mat


# ---------------------------------------------------------------------------------------------
# Objects

PRIMITIVES = ["cube", "uv_sphere", "ico_sphere", "cylinder", "cone", "torus", "plane", "grid",
              "monkey", "circle"]


def _primitive(g: Grammar, kind):
    ops = bpy.ops.mesh
    if kind == "cube":
        ops.primitive_cube_add()
    elif kind == "uv_sphere":
        ops.primitive_uv_sphere_add(segments=g.rng.randint(3, 16), ring_count=g.rng.randint(3, 8))
    elif kind == "ico_sphere":
        ops.primitive_ico_sphere_add(subdivisions=g.rng.randint(1, 3))
    elif kind == "cylinder":
        ops.primitive_cylinder_add(vertices=g.rng.randint(3, 16))
    elif kind == "cone":
        ops.primitive_cone_add(vertices=g.rng.randint(3, 16), radius2=g.rng.choice([0.0, 0.5]))
    elif kind == "torus":
        ops.primitive_torus_add(major_segments=8, minor_segments=4)
    elif kind == "plane":
        ops.primitive_plane_add()
    elif kind == "grid":
        ops.primitive_grid_add(x_subdivisions=g.rng.randint(1, 6),
                               y_subdivisions=g.rng.randint(1, 6))
    elif kind == "monkey":
        ops.primitive_monkey_add()
    else:
        ops.primitive_circle_add(fill_type=g.rng.choice(["NOTHING", "NGON", "TRIFAN"]))
    return bpy.context.object


def _curve(g: Grammar):
    kind = g.pick("curve", ["bezier", "nurbs_path", "bezier_circle", "nurbs_circle"])
    {"bezier": bpy.ops.curve.primitive_bezier_curve_add,
     "nurbs_path": bpy.ops.curve.primitive_nurbs_path_add,
     "bezier_circle": bpy.ops.curve.primitive_bezier_circle_add,
     "nurbs_circle": bpy.ops.curve.primitive_nurbs_circle_add}[kind]()
    obj = bpy.context.object
    curve = obj.data
    if g.chance(0.6):
        depth = g.odd_number("bevel depth", (0.0, 0.3)) if g.chance(0.8) else 0.1
        curve.bevel_depth = max(0.0, depth)
        curve.bevel_resolution = g.rng.randint(0, 4)
    if g.chance(0.3):
        curve.extrude = abs(g.odd_number("extrude", (0.0, 0.5)))
    if g.chance(0.3):
        curve.dimensions = "2D"
        curve.fill_mode = g.pick("fill", ["NONE", "BACK", "FRONT", "BOTH"])
    if g.chance(0.2):
        curve.bevel_mode = "OBJECT"
        g.log.append("bevel mode OBJECT without an object")
    return obj


def _text(g: Grammar):
    bpy.ops.object.text_add()
    obj = bpy.context.object
    obj.data.body = g.pick("text", ["Snell", "", " ", "a\nb", "\u00e9\u4e2d\u00df", "." * 40])
    obj.data.extrude = abs(g.odd_number("text extrude", (0.0, 0.2))) if g.chance(0.5) else 0.0
    obj.data.bevel_depth = abs(g.odd_number("text bevel", (0.0, 0.05))) if g.chance(0.3) else 0.0
    return obj


def _metaball(g: Grammar):
    bpy.ops.object.metaball_add(type=g.pick("metaball", ["BALL", "CAPSULE", "PLANE", "ELLIPSOID",
                                                         "CUBE"]))
    obj = bpy.context.object
    obj.data.resolution = g.rng.choice([0.2, 0.4, 1.0])
    obj.data.render_resolution = obj.data.resolution
    if g.chance(0.3):
        obj.data.elements[0].radius = g.odd_number("metaball radius", (0.1, 2.0))
    return obj


def _geometry_nodes(g: Grammar, obj):
    group = bpy.data.node_groups.new("fuzz_nodes", "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = group.nodes, group.links
    gin, gout = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    kind = g.pick("geometry nodes", ["subdivide and move", "points", "instances",
                                     "realized instances",
                                     "curve to mesh", "curve with radius", "empty", "pass-through",
                                     "huge offset", "delete all", "volume cube"])
    geometry = gin.outputs[0]
    if kind == "subdivide and move":
        sub = nodes.new("GeometryNodeSubdivideMesh")
        sub.inputs["Level"].default_value = g.rng.randint(0, 2)
        move = nodes.new("GeometryNodeSetPosition")
        noise = nodes.new("ShaderNodeTexNoise")
        links.new(geometry, sub.inputs[0])
        links.new(sub.outputs[0], move.inputs["Geometry"])
        links.new(noise.outputs["Color"], move.inputs["Offset"])
        geometry = move.outputs[0]
    elif kind == "points":
        pts = nodes.new("GeometryNodeMeshToPoints")
        links.new(geometry, pts.inputs[0])
        geometry = pts.outputs[0]
    elif kind in ("instances", "realized instances"):
        inst = nodes.new("GeometryNodeInstanceOnPoints")
        ico = nodes.new("GeometryNodeMeshIcoSphere")
        ico.inputs["Radius"].default_value = 0.2
        links.new(geometry, inst.inputs["Points"])
        links.new(ico.outputs[0], inst.inputs["Instance"])
        geometry = inst.outputs[0]
        if kind == "realized instances":
            real = nodes.new("GeometryNodeRealizeInstances")
            links.new(geometry, real.inputs[0])
            geometry = real.outputs[0]
    elif kind in ("curve to mesh", "curve with radius"):
        spiral = nodes.new("GeometryNodeCurveSpiral")
        geometry = spiral.outputs[0]
        if kind == "curve to mesh":
            c2m = nodes.new("GeometryNodeCurveToMesh")
            circle = nodes.new("GeometryNodeCurvePrimitiveCircle")
            circle.inputs["Radius"].default_value = 0.05
            links.new(geometry, c2m.inputs["Curve"])
            links.new(circle.outputs[0], c2m.inputs["Profile Curve"])
            geometry = c2m.outputs[0]
        else:
            radius = nodes.new("GeometryNodeSetCurveRadius")
            links.new(geometry, radius.inputs["Curve"])
            geometry = radius.outputs[0]
    elif kind == "empty":
        geometry = None
    elif kind == "huge offset":
        move = nodes.new("GeometryNodeSetPosition")
        links.new(geometry, move.inputs["Geometry"])
        move.inputs["Offset"].default_value = (g.rng.choice([1e20, NAN, INF, 1e8]), 0.0, 0.0)
        geometry = move.outputs[0]
    elif kind == "delete all":
        delete = nodes.new("GeometryNodeDeleteGeometry")
        links.new(geometry, delete.inputs["Geometry"])
        geometry = delete.outputs[0]
    elif kind == "volume cube":
        vol = nodes.new("GeometryNodeVolumeCube")
        geometry = vol.outputs[0]
    if geometry is not None:
        links.new(geometry, gout.inputs[0])
    mod = obj.modifiers.new("GeometryNodes", "NODES")
    mod.node_group = group


MODIFIERS = ["SUBSURF", "ARRAY", "SOLIDIFY", "BEVEL", "DISPLACE", "MIRROR", "DECIMATE",
             "WIREFRAME", "TRIANGULATE", "WELD", "SCREW", "BOOLEAN", "EDGE_SPLIT", "SMOOTH",
             "CAST", "SIMPLE_DEFORM", "BUILD", "MASK", "NODES"]


def _modifier(g: Grammar, obj, others):
    kind = g.pick("modifier", MODIFIERS)
    if kind == "NODES":
        _geometry_nodes(g, obj)
        return
    mod = obj.modifiers.new(kind.lower(), kind)
    if kind == "SUBSURF":
        mod.levels = mod.render_levels = g.rng.randint(0, 2)
    elif kind == "ARRAY":
        mod.count = g.rng.randint(1, 4)
        mod.relative_offset_displace = (g.odd_number("array offset", (0.0, 2.0)), 0.0, 0.0)
    elif kind == "SOLIDIFY":
        mod.thickness = g.odd_number("solidify thickness", (-0.2, 0.2))
    elif kind == "BEVEL":
        mod.width = abs(g.odd_number("bevel width", (0.0, 0.3)))
        mod.segments = g.rng.randint(1, 3)
    elif kind == "DISPLACE":
        mod.strength = g.odd_number("displace strength", (-1.0, 1.0))
    elif kind == "DECIMATE":
        mod.ratio = g.rng.choice([0.0, 0.1, 0.5, 1.0])
    elif kind == "WIREFRAME":
        mod.thickness = g.odd_number("wireframe thickness", (0.0, 0.1))
    elif kind == "WELD":
        mod.merge_threshold = g.rng.choice([0.0, 0.1, 10.0, 1e6])
    elif kind == "SCREW":
        mod.steps = mod.render_steps = g.rng.randint(2, 8)
        mod.angle = g.odd_number("screw angle", (0.0, 6.3))
    elif kind == "BOOLEAN" and others:
        mod.object = g.rng.choice(others)
        mod.operation = g.pick("boolean", ["DIFFERENCE", "UNION", "INTERSECT"])
    elif kind == "CAST":
        mod.factor = g.odd_number("cast factor", (-1.0, 1.0))
    elif kind == "SIMPLE_DEFORM":
        mod.angle = g.odd_number("deform angle", (0.0, 3.0))
    elif kind == "BUILD":
        mod.frame_start, mod.frame_duration = 1, 2
    elif kind == "MASK":
        mod.vertex_group = "missing group"


def _particles(g: Grammar, emitter, others):
    mod = emitter.modifiers.new("particles", "PARTICLE_SYSTEM")
    settings = mod.particle_system.settings
    settings.type = g.pick("particles", ["EMITTER", "HAIR"])
    settings.count = g.rng.choice([0, 1, 10, 50])
    settings.frame_start = settings.frame_end = 1
    settings.render_type = g.pick("particle render", ["OBJECT", "COLLECTION", "PATH", "NONE"])
    if settings.render_type == "OBJECT" and others:
        settings.instance_object = g.rng.choice(others)
    elif settings.render_type == "COLLECTION":
        settings.instance_collection = bpy.data.collections.new("empty_collection")
    settings.particle_size = abs(g.odd_number("particle size", (0.01, 0.3)))


def _transform(g: Grammar, obj):
    obj.location = [g.rng.uniform(-2, 2) for _ in range(3)]
    obj.rotation_euler = [g.rng.uniform(-3.2, 3.2) for _ in range(3)]
    if g.chance(0.2):
        obj.scale = [g.pick("scale", [0.0, -1.0, 1e-6, 1e6, 0.5, 2.0]) for _ in range(3)]
    else:
        obj.scale = [g.rng.uniform(0.3, 1.2)] * 3


def objects(g: Grammar):
    made = []
    for i in range(g.rng.randint(1, 5)):
        kind = g.pick(f"object {i}", ["mesh", "mesh", "mesh", "curve", "text", "metaball", "empty",
                                      "collection instance", "vertex instances"])
        if kind == "mesh":
            obj = _primitive(g, g.pick("primitive", PRIMITIVES))
            if g.chance(0.5):
                bpy.ops.object.shade_smooth()
            if g.chance(0.1):
                obj.data.vertices[0].co = (g.rng.choice([NAN, INF, 1e30]), 0.0, 0.0)
                g.log.append("a vertex moved to a non-finite or huge position")
            if g.chance(0.05):
                mesh = bpy.data.meshes.new("loose")
                mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1)], [])
                obj.data = mesh
                g.log.append("a mesh of loose vertices and an edge, no faces")
            if g.chance(0.05) and len(obj.data.polygons):
                obj.data.polygons[0].material_index = 7
                g.log.append("a face's material index beyond the slots")
        elif kind == "curve":
            obj = _curve(g)
        elif kind == "text":
            obj = _text(g)
        elif kind == "metaball":
            obj = _metaball(g)
        elif kind == "empty":
            bpy.ops.object.empty_add(type=g.pick("empty", ["PLAIN_AXES", "IMAGE", "SPHERE"]))
            obj = bpy.context.object
        elif kind == "collection instance":
            collection = bpy.data.collections.new(f"fuzz_collection_{i}")
            if made and g.chance(0.7):
                collection.objects.link(g.rng.choice(made))
            bpy.ops.object.collection_instance_add(collection=collection.name)
            obj = bpy.context.object
        else:
            obj = _primitive(g, "plane")
            bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.2)
            child = bpy.context.object
            child.parent = obj
            obj.instance_type = "VERTS"
            made.append(child)
        _transform(g, obj)
        if obj.type in ("MESH", "CURVE", "FONT", "META"):
            if g.chance(0.85):
                obj.data.materials.append(material(g, f"material_{i}"))
                if g.chance(0.1):
                    obj.material_slots[0].link = "OBJECT"
                    obj.material_slots[0].material = material(g, f"object_material_{i}")
                    g.log.append("a slot linked to the object")
            if g.chance(0.1):
                obj.data.materials.append(None)
                g.log.append("an empty material slot")
        if obj.type == "MESH":
            for _ in range(g.rng.randint(0, 2)):
                _modifier(g, obj, [o for o in made if o.type == "MESH"])
            if g.chance(0.15):
                _particles(g, obj, made)
        elif obj.type in ("CURVE", "FONT") and g.chance(0.2):
            _geometry_nodes(g, obj)
        if g.chance(0.05):
            obj.hide_render = True
            g.log.append("hidden from render")
        made.append(obj)
    return made


# ---------------------------------------------------------------------------------------------
# Lights, world, camera, settings


def lights(g: Grammar):
    for i in range(g.rng.randint(0, 3)):
        kind = g.pick(f"light {i}", ["POINT", "SPOT", "AREA", "SUN"])
        data = bpy.data.lights.new(f"light_{i}", kind)
        data.energy = g.odd_number("light energy", (10.0, 1000.0) if kind != "SUN" else (0.5, 5.0))
        if g.chance(0.2):
            data.color = [g.odd_number("light colour", (0.0, 1.0)) for _ in range(3)]
        if kind in ("POINT", "SPOT"):
            data.shadow_soft_size = abs(g.odd_number("light radius", (0.0, 1.0)))
        if kind == "SPOT":
            data.spot_size = g.rng.choice([0.01, 0.5, 1.5, math.pi])
            data.spot_blend = g.rng.choice([0.0, 0.5, 1.0])
        if kind == "AREA":
            data.shape = g.pick("area shape", ["SQUARE", "RECTANGLE", "DISK", "ELLIPSE"])
            data.size = g.odd_number("area size", (0.1, 2.0))
            data.size_y = g.odd_number("area size y", (0.1, 2.0))
        if kind == "SUN":
            data.angle = g.rng.choice([0.0, 0.01, 0.5, math.pi])
        obj = bpy.data.objects.new(f"light_{i}", data)
        bpy.context.scene.collection.objects.link(obj)
        obj.location = [g.rng.uniform(-4, 4) for _ in range(2)] + [g.rng.uniform(1, 5)]
        if g.chance(0.1):
            obj.scale = (0.0, 1.0, 1.0)
            g.log.append("light scale 0")


def world(g: Grammar):
    scene = bpy.context.scene
    kind = g.pick("world", ["none", "colour", "strength", "environment", "sky", "unsupported",
                            "no nodes"])
    if kind == "none":
        scene.world = None
        return
    w = scene.world or bpy.data.worlds.new("World")
    scene.world = w
    tree = w.node_tree
    background = tree.nodes.get("Background")
    if kind == "no nodes":
        for node in list(tree.nodes):
            tree.nodes.remove(node)
        return
    if background is None:
        return
    if kind == "colour":
        rgb = [g.odd_number("world colour", (0.0, 1.0)) for _ in range(3)]
        background.inputs["Color"].default_value = rgb + [1.0]
    elif kind == "strength":
        background.inputs["Strength"].default_value = g.odd_number("world strength", (0.0, 2.0))
    elif kind in ("environment", "sky", "unsupported"):
        node = tree.nodes.new({"environment": "ShaderNodeTexEnvironment", "sky": "ShaderNodeTexSky",
                               "unsupported": "ShaderNodeTexNoise"}[kind])
        if kind == "environment" and g.chance(0.7):
            node.image = _image(g, "sky")
        tree.links.new(node.outputs[0], background.inputs["Color"])


def camera(g: Grammar):
    scene = bpy.context.scene
    cam = scene.camera
    data = cam.data
    data.type = g.pick("camera", ["PERSP"] * 12 + ["ORTHO"] * 3 + ["PANO"])
    if data.type == "PERSP" and g.chance(0.3):
        data.lens = g.rng.choice([1.0, 10.0, 50.0, 5000.0])
    if data.type == "ORTHO":
        data.ortho_scale = g.rng.choice([0.001, 1.0, 7.0, 1e4])
    if g.chance(0.2):
        data.clip_start = g.rng.choice([1e-6, 0.1, 50.0])
        data.clip_end = g.rng.choice([0.2, 100.0, 1e6])
        g.log.append(f"clip {data.clip_start} .. {data.clip_end}")
    if g.chance(0.2):
        data.dof.use_dof = True
        data.dof.aperture_fstop = g.rng.choice([0.1, 2.8, 128.0])
        data.dof.focus_distance = g.rng.choice([0.0, 1.0, 10.0, 1e4])
        data.dof.aperture_blades = g.rng.choice([0, 3, 16])
        g.log.append("depth of field")
    if g.chance(0.2):
        data.shift_x, data.shift_y = g.rng.uniform(-2, 2), g.rng.uniform(-2, 2)
        g.log.append("lens shift")
    if g.chance(0.1):
        cam.scale = (g.rng.choice([-1.0, 1e-3, 100.0]), 1.0, 1.0)
        g.log.append(f"camera scale {cam.scale[0]}")
    if g.chance(0.05):
        data.sensor_fit = g.pick("sensor fit", ["HORIZONTAL", "VERTICAL"])


def settings(g: Grammar):
    scene = bpy.context.scene
    r = scene.render
    r.resolution_x = g.rng.choice([1, 2, 3, 7, 16, 24])
    r.resolution_y = g.rng.choice([1, 2, 5, 12, 24])
    r.resolution_percentage = g.rng.choice([1, 50, 100, 100, 100])
    if g.chance(0.1):
        r.pixel_aspect_x = g.rng.choice([1.0, 3.0, 200.0])
    if g.chance(0.1):
        r.use_border = True
        r.border_min_x, r.border_max_x = sorted(g.rng.uniform(0, 1) for _ in range(2))
        r.border_min_y, r.border_max_y = sorted(g.rng.uniform(0, 1) for _ in range(2))
        r.use_crop_to_border = g.chance(0.5)
        g.log.append(f"render border, crop {r.use_crop_to_border}")
    if g.chance(0.2):
        r.film_transparent = True
        g.log.append("transparent film")
    cycles = scene.cycles
    if g.chance(0.3):
        cycles.pixel_filter_type = g.pick("filter", ["BOX", "GAUSSIAN", "BLACKMAN_HARRIS"])
        cycles.filter_width = g.rng.choice([0.01, 1.5, 10.0])
    if g.chance(0.3):
        cycles.max_bounces = g.rng.choice([0, 1, 1024])
        cycles.transparent_max_bounces = g.rng.choice([0, 1, 1024])
    if g.chance(0.2):
        cycles.use_adaptive_sampling = True
        cycles.adaptive_threshold = g.rng.choice([0.0, 0.001, 1.0])
        cycles.adaptive_min_samples = g.rng.choice([0, 1, 4096])
    if g.chance(0.1):
        cycles.seed = g.rng.choice([0, 2 ** 31 - 1])
    if g.chance(0.1):
        cycles.use_denoising = True
    if g.chance(0.05):
        scene.frame_current = g.rng.choice([-100, 0, 100000])
        g.log.append(f"frame {scene.frame_current}")
    if g.chance(0.1):
        scene.unit_settings.scale_length = g.rng.choice([1e-5, 1e5])
        g.log.append(f"unit scale {scene.unit_settings.scale_length}")
    if g.chance(0.3):
        view = scene.view_settings
        view.view_transform = g.pick("view transform", ["Standard", "Filmic", "AgX", "Raw",
                                                        "Khronos PBR Neutral", "False Color"])
        view.exposure = g.pick("exposure", [-32.0, 0.0, 3.0, 32.0])
        view.gamma = g.pick("gamma", [0.0, 0.01, 1.0, 5.0])
        if g.chance(0.3):
            look = g.pick("look", ["Punchy", "Base Contrast", "High Contrast", "Very Low Contrast"])
            try:        # each view transform has its own looks
                view.look = look
            except TypeError:
                g.log.append(f"look {look!r} not offered by this view transform")
    width = max(1, r.resolution_x * r.resolution_percentage // 100)
    height = max(1, r.resolution_y * r.resolution_percentage // 100)
    return width, height


SNELL_SETTINGS = {
    "max_depth": [0, 1, 64], "transparent_max_bounces": [0, 1000], "seed": [0, 2 ** 31 - 1],
    "fresnel": ["exact", "schlick"], "caustics": [False, True], "light_vertices": [False, True],
    "noise_threshold": [0.0, 0.001, 1.0], "min_spp": [0, 1, 100000],
    "pixel_filter": ["box", "gaussian", "blackman_harris"], "filter_width": [0.01, 1.5, 10.0],
    "denoise": [False, True], "denoising_input_passes": ["color", "albedo", "albedo_normal"],
    "denoising_passes": [False, True], "batches": [0, 1, 3],
    "sampler": ["stratified", "independent"],
    "next_event": [False, True], "env_sampling": [False, True], "pure_light_tracing": [False, True],
    "light_paths_per_camera_path": [0.0, 1e-6, 1.0, 16.0], "light_vertex_pilot": [False, True],
}


def snell_settings(g: Grammar):
    """Snell's own settings (Follow Cycles' Settings off) with odd values, some of the time."""
    if not g.chance(0.4):
        return
    from snell.addon import registration
    registration.ensure_registered()
    props = bpy.context.scene.snell
    props.use_cycles_settings = False
    for name in g.rng.sample(sorted(SNELL_SETTINGS), 5):
        value = g.pick(f"snell {name}", SNELL_SETTINGS[name])
        setattr(props, name, value.upper() if isinstance(value, str) else value)


def build_scene(seed: int, index: int) -> dict:
    """Build scene `index` of `seed` in the current bpy session; what was chosen and the size."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    for obj in list(bpy.data.objects):
        if obj.type != "CAMERA":
            bpy.data.objects.remove(obj)
    g = Grammar(random.Random(seed * 100003 + index))
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cam = scene.camera
    cam.location, cam.rotation_euler = (0.0, -8.0, 1.5), (math.radians(85), 0.0, 0.0)
    made = objects(g)
    lights(g)
    world(g)
    camera(g)
    width, height = settings(g)
    snell_settings(g)
    return {"choices": g.log, "size": [width, height],
            "objects": [o.name for o in made]}


def main(out: str, seed: int, count: int) -> None:
    record = {}
    for index in range(count):
        name = f"fuzz_{seed}_{index}.blend"
        try:
            record[name] = build_scene(seed, index)
        except Exception as exc:     # the grammar's own bug: said, so the test can fail on it
            record[name] = {"build_error": f"{type(exc).__name__}: {exc}"}
            continue
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, name), check_existing=False)
    with open(os.path.join(out, f"fuzz_{seed}.json"), "w") as f:
        json.dump(record, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]))
