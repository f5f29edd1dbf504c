"""An HDRI made in code (a sky with a sun-like hot spot), written as an EXR, and the Blender world
that shows it: Texture Coordinate (Generated) -> Mapping -> Environment Texture -> Background.
Used by scenes/hdri_caustic.py and by the tests (tests/support/hdri.py)."""
from __future__ import annotations

import math

import numpy as np


def sky(h=64, w=128, sun_theta=0.6, sun_phi=0.8, sun_peak=400.0, sun_sigma=0.05):
    """float32 (h, w, 3), top row first: a sky from a blue zenith to a white horizon with
    brightness bands in azimuth (so that turning the map about Z changes what a camera sees), a
    dark striped ground and a Gaussian hot spot at polar angle sun_theta, azimuth sun_phi."""
    theta = (np.arange(h) + 0.5) / h * np.pi
    phi = np.pi - 2 * np.pi * (np.arange(w) + 0.5) / w      # Cycles' equirectangular u
    t, p = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    z = d[..., 2:3]
    bands = 1.0 + 0.5 * np.cos(3.0 * p)[..., None]
    sky_rgb = (np.array([0.9, 0.95, 1.0]) * (1 - z) + np.array([0.2, 0.35, 0.8]) * z) * bands
    ground = np.array([0.15, 0.12, 0.1]) * (1.0 + 0.8 * (np.sin(8.0 * p) > 0))[..., None]
    image = np.where(z > 0, sky_rgb, ground)
    sun = np.array([math.sin(sun_theta) * math.cos(sun_phi),
                    math.sin(sun_theta) * math.sin(sun_phi), math.cos(sun_theta)])
    angle = np.arccos(np.clip(d @ sun, -1, 1))
    image = image + (sun_peak * np.exp(-0.5 * (angle / sun_sigma) ** 2))[..., None] \
        * np.array([1.0, 0.9, 0.7])
    return image.astype(np.float32)


def write_image(path, image, pixel_type):
    """Write an (h, w, 3) image of pixel_type ("float", "uint8") to path (format by extension)."""
    import OpenImageIO as oiio
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(image.shape[1], image.shape[0], 3, pixel_type))
    assert out.write_image(np.ascontiguousarray(image))
    out.close()
    return str(path)


def write_exr(path, image):
    """Write a float32 (h, w, 3) image as an OpenEXR file."""
    return write_image(path, image, "float")


def set_hdri_world(scene, image_path, rotation_z=0.0, strength=1.0, interpolation="Linear",
                   mapping=True):
    """A world of the Environment Texture image_path (rotated about Z by a Mapping node)."""
    import bpy
    world = bpy.data.worlds.new("HDRI")
    scene.world = world
    tree = world.node_tree
    background = tree.nodes.get("Background")
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(image_path))
    env.interpolation = interpolation
    if mapping:
        coords = tree.nodes.new("ShaderNodeTexCoord")
        node = tree.nodes.new("ShaderNodeMapping")
        node.inputs["Rotation"].default_value[2] = rotation_z
        tree.links.new(coords.outputs["Generated"], node.inputs["Vector"])
        tree.links.new(node.outputs["Vector"], env.inputs["Vector"])
    tree.links.new(env.outputs["Color"], background.inputs["Color"])
    background.inputs["Strength"].default_value = strength
    return world
