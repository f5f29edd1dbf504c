"""Cycles' value of a shader node graph at known points: the graph drives the Emission of a
plane seen straight on by an orthographic camera, rendered with one sample per pixel (Cycles'
sample 0 goes through the pixel's centre) and no bounces, so each pixel is the graph's value at
that pixel centre's point. Tests of the tracer's node formulas evaluate them at `points` and
compare.

    image, points = probe(lambda tree: checker_output_socket, size=32, extent=2.0)

The plane is z = 0 over [-extent, extent]^2 with the identity transform, so Object and world
coordinates are the points; its UV map is (x, y) mapped from [-extent, extent] to [0, 1].
"""
from __future__ import annotations

import os
import tempfile

import numpy as np


def _plane(bpy, extent):
    mesh = bpy.data.meshes.new("ProbePlane")
    e = float(extent)
    mesh.from_pydata([(-e, -e, 0.0), (e, -e, 0.0), (e, e, 0.0), (-e, e, 0.0)], [],
                     [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    for loop, corner in zip(uv.data, ((0, 0), (1, 0), (1, 1), (0, 1))):
        loop.uv = corner
    obj = bpy.data.objects.new("ProbePlane", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def pixel_points(size, extent):
    """(size, size, 3) points on the plane at the pixel centres, row 0 at the top."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c * extent, -c * extent)
    return np.stack([x, y, np.zeros_like(x)], axis=-1)


def probe_scene(build, size=32, extent=1.0, material_setup=None):
    """Build probe's scene in bpy (reset to an empty file first), without rendering it: for a
    test that also exports it to Snell (save it with bpy.ops.wm.save_as_mainfile)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = _plane(bpy, extent)
    mat = bpy.data.materials.new("Probe")
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    tree.links.new(build(tree), emission.inputs["Color"])
    if material_setup is not None:
        material_setup(mat)
    obj.data.materials.append(mat)

    cam_data = bpy.data.cameras.new("ProbeCamera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = 2.0 * extent
    cam = bpy.data.objects.new("ProbeCamera", cam_data)
    cam.location = (0.0, 0.0, 1.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    world = bpy.data.worlds.new("Black")
    world.color = (0.0, 0.0, 0.0)
    if world.node_tree is not None:      # Blender 5 gives a new world a Background node
        for node in world.node_tree.nodes:
            if node.bl_idname == "ShaderNodeBackground":
                node.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.world = world

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.max_bounces = 0
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 2
    scene.view_settings.view_transform = "Standard"
    img = scene.render.image_settings
    img.file_format = "OPEN_EXR"
    img.color_depth = "32"
    img.color_mode = "RGB"
    return scene


def probe(build, size=32, extent=1.0, material_setup=None):
    """(Cycles' image (size, size, 3) float64, the points it shows (size, size, 3)).

    build(tree) adds nodes to the plane material's tree and returns the output socket (colour,
    vector or float; Blender converts it as a link into a colour input does) whose value
    becomes the Emission colour. material_setup(material), if given, runs after the tree is
    built (for material settings). Runs in this process: bpy is reset to an empty file."""
    import bpy

    from snell.tracer.image import read_exr

    scene = probe_scene(build, size, extent, material_setup)
    with tempfile.TemporaryDirectory(prefix="snell-probe-") as tmp:
        scene.render.filepath = os.path.join(tmp, "probe.exr")
        bpy.ops.render.render(write_still=True)
        image = read_exr(scene.render.filepath).astype(np.float64)
    return image, pixel_points(size, extent)
