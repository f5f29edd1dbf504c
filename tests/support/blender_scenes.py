"""Build the small .blend files the engine tests use. Run in a subprocess (it resets bpy):

    python tests/support/blender_scenes.py OUT_DIR [SIZE]

cornell.blend: the default scene (scenes/cornell_spheres.py) at SIZE x SIZE, Snell 8 spp, seed 5,
max depth 6 (Snell's own settings: Follow Cycles' Settings off).
animated.blend: the same with the camera moving over frames 1-3.
unsupported.blend: the left wall with a Toon BSDF (not supported: grey diffuse fallback).
nocamera.blend: no camera object. empty.blend: a camera and nothing else.
pano.blend: a panoramic camera (the exporter refuses it).
"""
import os
import sys

import bpy

# Run as a script: scenes/ (in the repository, three folders up) is not on the path yet.
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scenes"))
import cornell_spheres  # noqa: E402

import snell  # noqa: E402


def save(out, name):
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, name), check_existing=False)


def main(out, size):
    snell.register()
    cornell_spheres.build(os.path.join(out, "cornell.blend"))
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.snell.spp, scene.snell.seed, scene.snell.max_depth = 8, 5, 6
    # The engine tests set Snell's own settings: they render at them, not at the file's Cycles
    # settings (tests/blender/test_engine.py has its own tests of following Cycles').
    scene.snell.use_cycles_settings = False
    scene.cycles.samples = 8
    save(out, "cornell.blend")

    cam = scene.camera
    for frame, dx in ((1, -0.3), (2, 0.0), (3, 0.3)):
        cam.location.x = dx
        cam.keyframe_insert("location", frame=frame)
    scene.frame_start, scene.frame_end = 1, 3
    save(out, "animated.blend")
    bpy.ops.wm.open_mainfile(filepath=os.path.join(out, "cornell.blend"))

    wall = bpy.data.objects["LeftWall"]
    mat = bpy.data.materials.new("ToonWall")
    tree = mat.node_tree
    tree.nodes.clear()
    toon = tree.nodes.new("ShaderNodeBsdfToon")
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(toon.outputs[0], output.inputs["Surface"])
    wall.data.materials[0] = mat
    save(out, "unsupported.blend")
    bpy.ops.wm.open_mainfile(filepath=os.path.join(out, "cornell.blend"))

    bpy.context.scene.camera.data.type = "PANO"
    save(out, "pano.blend")
    bpy.ops.wm.open_mainfile(filepath=os.path.join(out, "cornell.blend"))

    bpy.data.objects.remove(bpy.context.scene.camera)
    save(out, "nocamera.blend")
    bpy.ops.wm.open_mainfile(filepath=os.path.join(out, "cornell.blend"))

    for obj in list(bpy.data.objects):
        if obj.type != "CAMERA":
            bpy.data.objects.remove(obj)
    bpy.context.scene.world = None
    save(out, "empty.blend")


if __name__ == "__main__":
    main(os.path.abspath(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 32)
