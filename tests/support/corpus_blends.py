"""Build the unusual .blend files of the robustness corpus (run with bpy: python corpus_blends.py DIR).

Each starts from Blender's startup file (the default cube, point light and camera) at a tiny
resolution and changes one thing; `startup.blend` is the startup file saved unchanged.
"""
from __future__ import annotations

import math
import os
import sys

import bpy


def factory(empty=False):
    bpy.ops.wm.read_factory_settings(use_empty=empty)
    return bpy.context.scene


def tiny(scene):
    scene.render.resolution_x, scene.render.resolution_y = 16, 12
    scene.render.resolution_percentage = 100


def save(directory, name):
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(directory, name))


def build(directory):
    factory()
    save(directory, "startup.blend")

    scene = factory()
    tiny(scene)
    # Snell's samples as the add-on stores them: enough for `snell batch` to render in passes
    # (Ctrl-C between them); the other commands are given --spp.
    from snell.addon import registration
    registration.ensure_registered()
    scene.snell.spp = 2048
    save(directory, "tiny.blend")

    scene = factory(empty=True)   # nothing but a camera
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    tiny(scene)
    save(directory, "empty_scene.blend")

    scene = factory()
    tiny(scene)
    bpy.data.objects.remove(bpy.data.objects["Camera"])
    save(directory, "no_camera.blend")

    for kind in ("ORTHO", "PANO"):
        scene = factory()
        tiny(scene)
        scene.camera.data.type = kind
        save(directory, f"camera_{kind.lower()}.blend")

    scene = factory()
    tiny(scene)
    mat = bpy.data.objects["Cube"].active_material
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    noise = nodes.new("ShaderNodeTexNoise")
    links.new(noise.outputs["Color"], nodes["Principled BSDF"].inputs["Base Color"])
    hair = nodes.new("ShaderNodeBsdfHairPrincipled")
    links.new(hair.outputs[0], nodes["Material Output"].inputs["Surface"])
    save(directory, "unsupported_nodes.blend")

    scene = factory()
    tiny(scene)
    bpy.data.objects["Cube"].location = (math.nan, 0.0, 0.0)
    save(directory, "nan_object.blend")

    scene = factory()
    tiny(scene)
    scene.camera.location = (math.nan, 0.0, 0.0)
    save(directory, "nan_camera.blend")

    scene = factory()
    tiny(scene)
    bpy.data.objects["Cube"].active_material.node_tree.nodes["Principled BSDF"].inputs[
        "Base Color"].default_value = (math.nan, 0.5, 0.5, 1.0)
    save(directory, "nan_material.blend")

    scene = factory()
    tiny(scene)
    bpy.data.lights["Light"].energy = math.inf
    save(directory, "inf_light.blend")

    scene = factory()
    tiny(scene)
    bpy.data.objects["Cube"].scale = (0.0, 0.0, 0.0)
    save(directory, "zero_scale.blend")

    scene = factory()
    tiny(scene)
    scene.camera = bpy.data.objects["Cube"]      # Blender allows any object as the camera
    save(directory, "camera_is_mesh.blend")

    for name, value in (("nan", math.nan), ("inf", math.inf), ("huge", 1e30)):
        scene = factory()
        tiny(scene)
        bpy.data.objects["Cube"].data.vertices[0].co = (value, 1.0, 1.0)
        save(directory, f"{name}_vertex.blend")

    scene = factory()
    tiny(scene)
    scene.camera.scale = (0.0, 1.0, 1.0)
    save(directory, "camera_zero_scale.blend")

    scene = factory()
    tiny(scene)
    scene.camera.data.clip_start, scene.camera.data.clip_end = 50.0, 1.0
    save(directory, "clip_reversed.blend")

    for name, color, strength in (("nan_strength", (0.05, 0.05, 0.05, 1.0), math.nan),
                                  ("huge", (1e38, 1e38, 1e38, 1.0), 10.0)):
        scene = factory()
        tiny(scene)
        background = scene.world.node_tree.nodes["Background"]
        background.inputs["Color"].default_value = color
        background.inputs["Strength"].default_value = strength
        save(directory, f"world_{name}.blend")

    # Objects Cycles renders and Snell drops (with a warning): hair particles, a point cloud
    # (what Geometry Nodes' points make), hair curves; and a linked library that went missing.
    scene = factory()
    tiny(scene)
    cube = bpy.data.objects["Cube"]
    cube.modifiers.new("Hair", "PARTICLE_SYSTEM")
    cube.particle_systems[0].settings.type = "HAIR"
    cube.particle_systems[0].settings.count = 10
    points = bpy.data.objects.new("Points", bpy.data.pointclouds.new("Points"))
    scene.collection.objects.link(points)
    curves = bpy.data.objects.new("Curves", bpy.data.hair_curves.new("Curves"))
    scene.collection.objects.link(curves)
    save(directory, "dropped_objects.blend")

    scene = factory()
    tiny(scene)
    bpy.data.objects["Cube"].name = "LinkedCube"
    library = os.path.join(directory, "library_gone.blend")
    save(directory, "library_gone.blend")
    scene = factory()
    tiny(scene)
    with bpy.data.libraries.load(library, link=True) as (source, target):
        target.objects = ["LinkedCube"]
    for obj in target.objects:
        scene.collection.objects.link(obj)
    save(directory, "missing_library.blend")
    os.remove(library)


if __name__ == "__main__":
    build(sys.argv[1])
