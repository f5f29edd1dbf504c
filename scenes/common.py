"""Helpers shared by the scene-building scripts: a fresh file, node materials, meshes, camera.

Units: metres, +Z up. The Cornell box spans x in [-1, 1], y in [-1, 1] (open at y = -1, back
wall at y = +1) and z in [0, 2], so it is 2 m wide like the seed's box.
"""
import math
import os

import bpy
import numpy as np
from mathutils import Vector

BOX_HALF = 1.0
BOX_HEIGHT = 2.0


def reset():
    """Start from an empty file (no objects, no world)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def setup_render(scene, resolution=(256, 256), samples=64, max_bounces=7):
    """Cycles settings that make a comparison with Snell fair (see cycles-conventions.md)."""
    scene.render.engine = "CYCLES"
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.max_bounces = max_bounces
    c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = max_bounces
    c.blur_glossy = 0.0
    c.sample_clamp_indirect = 0.0
    c.caustics_reflective = c.caustics_refractive = True
    c.use_denoising = False
    c.use_adaptive_sampling = False
    c.film_exposure = 1.0
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0


def set_world(scene, color, strength=1.0):
    """A uniform world through a Background node."""
    world = bpy.data.worlds.new("World")
    scene.world = world
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (*color, 1.0)
    bg.inputs["Strength"].default_value = strength
    return world


def new_scene(world_color, resolution=(256, 256)):
    """An empty file with setup_render's settings at resolution and a uniform world."""
    scene = reset()
    setup_render(scene, resolution)
    set_world(scene, world_color)
    return scene


def material(name, kind, color=(0.8, 0.8, 0.8), **values):
    """A node material with one shader into the output.

    kind: diffuse | glossy | glass | refraction | emission | principled; values set the named
    inputs (e.g. IOR=1.5, Strength=10, Roughness=0).
    """
    idname = {"diffuse": "ShaderNodeBsdfDiffuse", "glossy": "ShaderNodeBsdfGlossy",
              "glass": "ShaderNodeBsdfGlass", "refraction": "ShaderNodeBsdfRefraction",
              "emission": "ShaderNodeEmission", "principled": "ShaderNodeBsdfPrincipled"}[kind]
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    node = tree.nodes.new(idname)
    node.location = (-300, 0)
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    color_input = "Base Color" if kind == "principled" else "Color"
    node.inputs[color_input].default_value = (*color, 1.0)
    if kind in ("glossy", "glass", "refraction"):
        values.setdefault("Roughness", 0.0)  # the node default 0.5 is not a mirror
    for key, value in values.items():
        node.inputs[key].default_value = value
    return mat


def checker_material(name, color1, color2, scale, kind="diffuse", **values):
    """material() with a Checker Texture (its default, Generated, coordinates; scale) into the
    shader's colour: a node-tree material, which Snell renders as a shader program."""
    mat = material(name, kind, color1, **values)
    tree = mat.node_tree
    shader = next(n for n in tree.nodes if n.type != "OUTPUT_MATERIAL")
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.location = (-600, 0)
    checker.inputs["Color1"].default_value = (*color1, 1.0)
    checker.inputs["Color2"].default_value = (*color2, 1.0)
    checker.inputs["Scale"].default_value = scale
    tree.links.new(checker.outputs["Color"],
                   shader.inputs["Base Color" if kind == "principled" else "Color"])
    return mat


def mesh_object(name, verts, faces, mat=None, smooth=False, collection=None):
    """An object from numpy vertices (V, 3) and equal-sized polygons (F, k), built with foreach_set."""
    verts = np.asarray(verts, np.float32).reshape(-1, 3)
    faces = np.asarray(faces, np.int32)
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(verts))
    mesh.vertices.foreach_set("co", verts.ravel())
    mesh.loops.add(faces.size)
    mesh.loops.foreach_set("vertex_index", faces.ravel())
    mesh.polygons.add(len(faces))
    mesh.polygons.foreach_set("loop_start", np.arange(0, faces.size, faces.shape[1], dtype=np.int32))
    mesh.update(calc_edges=True)
    mesh.validate()
    if smooth:
        mesh.shade_smooth()
    if mat is not None:
        mesh.materials.append(mat)
    obj = bpy.data.objects.new(name, mesh)
    (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def canonical_polygons(obj):
    """Give obj a copy of its mesh with the polygons in one fixed order, so that a scene script
    builds the same file every time: Blender's primitive operators number the polygons of a UV
    sphere differently from one run to the next, which renumbers the triangles, reorders the BVH
    and the smooth-normal sums, and flips a few pixels of a render. Each polygon keeps its winding
    and its triangulation (a quad turns by two corners at most, keeping its diagonal)."""
    old = obj.data
    verts = [v.co[:] for v in old.vertices]
    faces = []
    for polygon in old.polygons:
        p = list(polygon.vertices)
        step = 2 if len(p) == 4 else 1
        start = min(range(0, len(p), step), key=lambda i: p[i])
        faces.append(p[start:] + p[:start])
    faces.sort(key=lambda p: sorted(p))
    mesh = bpy.data.meshes.new(old.name)
    mesh.from_pydata(verts, [], faces)
    mesh.update(calc_edges=True)
    obj.data = mesh
    bpy.data.meshes.remove(old)
    return obj


def place(name, data, location, rotation=None):
    """An object of data (a mesh, a light) at location (Euler rotation, if given), linked to the
    scene."""
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    if rotation is not None:
        obj.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(obj)
    return obj


def point_lamp(name, location, intensity, radius):
    """A point lamp of `intensity` W/sr (Blender's power 4 pi x that) and radius."""
    data = bpy.data.lights.new(name, "POINT")
    data.energy = 4.0 * math.pi * intensity
    data.shadow_soft_size = radius
    return place(name, data, location)


def sun(name, direction, irradiance, angle=0.0):
    """A sun lamp shining along `direction` (its travel direction) with `irradiance` W/m^2 and
    this angle (radians; 0: a direction)."""
    data = bpy.data.lights.new(name, "SUN")
    data.energy = irradiance
    data.angle = angle
    return place(name, data, (0.0, 0.0, 0.0),
                 Vector(direction).to_track_quat("-Z", "Y").to_euler())


def area_lamp(name, energy, size, location, rotation):
    """A square area lamp of energy watts and size metres."""
    data = bpy.data.lights.new(name, "AREA")
    data.energy = energy
    data.size = size
    return place(name, data, location, rotation)


def quad(name, corners, mat):
    """A one-polygon quad; corners counter-clockwise seen from the side the normal points to."""
    return mesh_object(name, corners, [[0, 1, 2, 3]], mat)


def floor(name, half, mat):
    """A square floor at z = 0 from -half to half in x and y, facing +Z."""
    return quad(name, [(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)],
                mat)


def uv_sphere(name, location, radius, mat, segments=64, rings=32):
    """A smooth UV sphere with outward normals."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=radius,
                                         location=location)
    obj = bpy.context.active_object
    canonical_polygons(obj)
    obj.name = obj.data.name = name
    obj.data.shade_smooth()
    obj.data.materials.append(mat)
    return obj


def cornell_box(light_strength=15.0, light_size=0.5):
    """The CS184 Cornell box: white floor/ceiling/back, red left, blue right, a ceiling emitter."""
    h, z = BOX_HALF, BOX_HEIGHT
    white = material("White", "diffuse", (0.725, 0.71, 0.68))
    red = material("Red", "diffuse", (0.63, 0.065, 0.05))
    blue = material("Blue", "diffuse", (0.1, 0.15, 0.6))
    # Every wall's normal faces into the box.
    quad("Floor", [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], white)
    quad("Ceiling", [(-h, -h, z), (-h, h, z), (h, h, z), (h, -h, z)], white)
    quad("BackWall", [(-h, h, 0), (h, h, 0), (h, h, z), (-h, h, z)], white)
    quad("LeftWall", [(-h, -h, 0), (-h, h, 0), (-h, h, z), (-h, -h, z)], red)
    quad("RightWall", [(h, -h, 0), (h, -h, z), (h, h, z), (h, h, 0)], blue)
    s, lz = light_size / 2, z - 0.01
    lamp = material("Light", "emission", (1.0, 1.0, 1.0), Strength=light_strength)
    light = quad("Light", [(-s, -s, lz), (-s, s, lz), (s, s, lz), (s, -s, lz)], lamp)
    light.visible_camera = True
    return light


def camera(scene, location, target, lens=35.0, sensor_width=36.0, name="Camera"):
    """A perspective camera at location looking at target, +Z up; becomes the scene camera."""
    data = bpy.data.cameras.new(name)
    data.lens = lens
    data.sensor_width = sensor_width
    data.sensor_fit = "AUTO"
    obj = bpy.data.objects.new(name, data)
    scene.collection.objects.link(obj)
    obj.location = location
    direction = Vector(target) - Vector(location)
    obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    scene.camera = obj
    return obj


def shadow_caustics(lamp, casters, receivers):
    """Cycles' shadow caustics (manifold next-event estimation) switched on as a user does: the
    lamp a caustics light, the glass objects casters, the diffuse ones receivers."""
    lamp.data.cycles.is_caustics_light = True
    for obj in casters:
        obj.cycles.is_caustics_caster = True
    for obj in receivers:
        obj.cycles.is_caustics_receiver = True


def aperture_fstop(lens_mm, radius_m):
    """The f-stop whose Cycles aperture radius lens / (2 fstop) equals radius_m."""
    return lens_mm * 1e-3 / (2.0 * radius_m)


def save(path):
    """Write the current file to path (directories created as needed)."""
    path = os.path.abspath(path)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=path, check_existing=False)
    return path


def cornell_camera(scene, target=(0.0, 0.0, 1.0), distance=3.4, height=1.0):
    """The camera looking into the box through its open front."""
    return camera(scene, (0.0, target[1] - distance, height), target, lens=35.0)


__all__ = [n for n in dir() if not n.startswith("_") and n not in ("bpy", "np", "os", "math")]
