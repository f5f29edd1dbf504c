"""The instructions of a shader program that read the object, the camera or a mesh attribute at
the hit: Texture Coordinate's Normal, Camera, Window and Object (of another object), Object
Info, Attribute and Color Attribute, Camera Data; and the per-object and camera tables they
read (Materials.objects, .of_object and .camera).

Cycles is the model: kernel/svm/tex_coord.h (svm_node_tex_coord), geometry.h
(svm_node_object_info), attribute.h (svm_node_attr), vertex_color.h, camera.h
(svm_node_camera), kernel/geom/object.h (object_inverse_normal_transform, object_location ...),
kernel/camera/camera.h (camera_world_to_ndc), scene/object.cpp (the random number) and
scene/camera.cpp (worldtocamera, worldtondc).
"""
from __future__ import annotations

import numpy as np

from ..jit import jit
from ..vec import length, normalize
from .inputs import interpolate, store3

# Opcodes 40-99: the second part of the input nodes' range 20-99 (inputs.py has 20-39).
(TEXCO_NORMAL, TEXCO_CAMERA, TEXCO_WINDOW, TEXCO_OBJECT_OF, OBJECT_VECTOR, OBJECT_VALUE,
 ATTRIBUTE, CAMERA_DATA) = range(40, 48)
FIRST, LAST = 40, 99

# The instructions that read Materials.objects (the scene objects' optional fields).
READS_OBJECT = (TEXCO_NORMAL, OBJECT_VECTOR, OBJECT_VALUE)
# Object Info outputs: OBJECT_VECTOR's literal, then OBJECT_VALUE's.
OI_LOCATION, OI_COLOR = range(2)
OI_ALPHA, OI_INDEX, OI_RANDOM = range(3)

# A row of Materials.objects: the object-to-world matrix's rows (3 x 4), colour, alpha, pass
# index, random number.
OBJ_MATRIX, OBJ_COLOR, OBJ_ALPHA, OBJ_PASS_INDEX, OBJ_RANDOM = 0, 12, 15, 16, 17
OBJECT_FIELDS = 18
# Materials.camera: world to camera (3 x 4 rows, Cycles' camera space: +z in front of the
# camera, +y up), whether orthographic, the view plane's left and bottom and its width and
# height (on the plane z = 1 in camera space, or in scene units when orthographic).
CAM_MATRIX, CAM_ORTHO, CAM_LEFT, CAM_BOTTOM, CAM_WIDTH, CAM_HEIGHT = 0, 12, 13, 14, 15, 16
CAMERA_FIELDS = 17

SPECS = {
    TEXCO_NORMAL: ("Texture Coordinate Normal: the shading normal in object space", "v------"),
    TEXCO_CAMERA: ("Texture Coordinate Camera: the point in camera space", "v------"),
    TEXCO_WINDOW: ("Texture Coordinate Window: the point's screen coordinates", "v------"),
    TEXCO_OBJECT_OF: ("Texture Coordinate Object of another object: the point times the "
                      "world-to-object matrix at data d (12 values)", "vdi----", {3: 13}),
    OBJECT_VECTOR: ("Object Info: Location or Color (OI_*)", "vi-----", {2: 2}),
    OBJECT_VALUE: ("Object Info: Alpha, Object Index or Random (OI_*)", "fi-----", {2: 3}),
    ATTRIBUTE: ("Attribute or Color Attribute: colour v, Fac f, Alpha f from texcoords i "
                "(value) and i (Fac, Alpha, found), Alpha i where not found",
                "vffiii-", {4: "texcoords", 5: "texcoords", 6: 2}),
    CAMERA_DATA: ("Camera Data: View Vector v, View Z Depth f, View Distance f", "vff----"),
}


def random_number(random_id: int) -> float:
    """Cycles' per-object random number of a 32-bit random id (scene/object.cpp: float32
    (random_id) * (1 / 0xFFFFFFFF), whose float32 factor is 2^-32)."""
    return float(np.float32(random_id % 2 ** 32) * np.float32(1.0 / 4294967295.0))


def object_table(objects: list) -> np.ndarray:
    """(O, OBJECT_FIELDS) float64: each scene object's row (an object without the optional
    fields: identity matrix, colour (1, 1, 1), alpha 1, pass index 0, random id 0, Blender's
    defaults)."""
    out = np.zeros((max(len(objects), 1), OBJECT_FIELDS))
    out[:, OBJ_MATRIX:OBJ_MATRIX + 12] = np.eye(4)[:3].ravel()
    out[:, OBJ_COLOR:OBJ_ALPHA + 1] = 1.0
    for i, obj in enumerate(objects):
        if "matrix" in obj:
            out[i, OBJ_MATRIX:OBJ_MATRIX + 12] = np.asarray(obj["matrix"], np.float64)[:3].ravel()
        if "color" in obj:
            out[i, OBJ_COLOR:OBJ_ALPHA + 1] = obj["color"]
        out[i, OBJ_PASS_INDEX] = obj.get("pass_index", 0)
        out[i, OBJ_RANDOM] = random_number(obj.get("random_id", 0))
    return out


def camera_table(camera=None) -> np.ndarray:
    """(CAMERA_FIELDS,) float64 of a tracer.camera.Camera, as Cycles' worldtocamera (camera
    space with +z ahead: Blender's camera matrix, unscaled, times diag(1, 1, -1)) and the view
    plane worldtondc maps to [0, 1] (None: the identity and a unit view plane, for tables
    built without a camera)."""
    out = np.zeros(CAMERA_FIELDS)
    if camera is None:
        out[CAM_MATRIX:CAM_MATRIX + 12] = np.eye(4)[:3].ravel()
        out[CAM_WIDTH] = out[CAM_HEIGHT] = 1.0
        return out
    to_camera = np.diag([1.0, 1.0, -1.0]) @ camera.rotation.T
    out[CAM_MATRIX:CAM_MATRIX + 12] = np.hstack(
        [to_camera, -(to_camera @ camera.position)[:, None]]).ravel()
    out[CAM_ORTHO] = float(camera.ortho)
    out[CAM_LEFT] = camera.shift_x - camera.half_x
    out[CAM_BOTTOM] = camera.shift_y - camera.half_y
    out[CAM_WIDTH], out[CAM_HEIGHT] = 2.0 * camera.half_x, 2.0 * camera.half_y
    return out


@jit
def affine(m, at, p):
    """The 3 x 4 matrix in m[at:at + 12] (rows) times the point p."""
    return (m[at] * p[0] + m[at + 1] * p[1] + m[at + 2] * p[2] + m[at + 3],
            m[at + 4] * p[0] + m[at + 5] * p[1] + m[at + 6] * p[2] + m[at + 7],
            m[at + 8] * p[0] + m[at + 9] * p[1] + m[at + 10] * p[2] + m[at + 11])


@jit
def object_normal(obj, n):
    """A world-space normal in object space (object_inverse_normal_transform): the
    object-to-world matrix M's transpose times n, normalised (M^-T maps normals the other way)."""
    return normalize((obj[0] * n[0] + obj[4] * n[1] + obj[8] * n[2],
                      obj[1] * n[0] + obj[5] * n[1] + obj[9] * n[2],
                      obj[2] * n[0] + obj[6] * n[1] + obj[10] * n[2]))


@jit
def window(cam, p):
    """The Window coordinate of world point p (camera_world_to_ndc, z set to 0): its
    projection onto the view plane, (0, 0) at the bottom left of the frame, (1, 1) at the top
    right."""
    c = affine(cam, CAM_MATRIX, p)
    x, y = c[0], c[1]
    if cam[CAM_ORTHO] == 0.0:
        # transform_perspective: a point in the camera's plane (z = 0) maps to 0.
        if c[2] == 0.0:
            return (0.0, 0.0, 0.0)
        x, y = x / c[2], y / c[2]
    return ((x - cam[CAM_LEFT]) / cam[CAM_WIDTH], (y - cam[CAM_BOTTOM]) / cam[CAM_HEIGHT], 0.0)


@jit
def attribute(value, extra, missing_alpha):
    """(colour, Fac, Alpha) of an Attribute or Color Attribute node from its interpolated
    texture coordinates: value the Color (and Vector) output, extra (Fac, Alpha, found); an
    attribute the object lacks gives colour and Fac 0 and the node's missing_alpha."""
    alpha = extra[1] if extra[2] > 0.0 else missing_alpha
    return value, extra[0], alpha


@jit
def execute(ins, regs, hit, mats):
    """Run one instruction that reads the object, the camera or an attribute."""
    op = ins[0]
    p = hit[0]
    obj = mats.objects[mats.of_object[hit[5]]]
    if op == TEXCO_NORMAL:
        store3(regs, ins[1], object_normal(obj, hit[2]))
    elif op == TEXCO_CAMERA:
        store3(regs, ins[1], affine(mats.camera, CAM_MATRIX, p))
    elif op == TEXCO_WINDOW:
        store3(regs, ins[1], window(mats.camera, p))
    elif op == TEXCO_OBJECT_OF:
        # Twelve values, or (a file's bad count) none read.
        store3(regs, ins[1], affine(mats.programs.data, ins[2], p) if ins[3] == 12
               else (0.0, 0.0, 0.0))
    elif op == OBJECT_VECTOR:
        if ins[2] == OI_LOCATION:
            store3(regs, ins[1], (obj[3], obj[7], obj[11]))
        else:
            store3(regs, ins[1], (obj[OBJ_COLOR], obj[OBJ_COLOR + 1], obj[OBJ_COLOR + 2]))
    elif op == OBJECT_VALUE:
        which = ins[2]
        regs[ins[1]] = (obj[OBJ_ALPHA] if which == OI_ALPHA else
                        obj[OBJ_PASS_INDEX] if which == OI_INDEX else obj[OBJ_RANDOM])
    elif op == ATTRIBUTE:
        value = interpolate(mats.coords[ins[4]], hit[5], hit[6], hit[7])
        extra = interpolate(mats.coords[ins[5]], hit[5], hit[6], hit[7])
        color, fac, alpha = attribute(value, extra, float(ins[6]))
        store3(regs, ins[1], color)
        regs[ins[2]] = fac
        regs[ins[3]] = alpha
    elif op == CAMERA_DATA:
        c = affine(mats.camera, CAM_MATRIX, p)
        store3(regs, ins[1], normalize(c))
        regs[ins[2]] = c[2]
        regs[ins[3]] = length(c)
