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


if __name__ == "__main__":
    build(sys.argv[1])
