"""Two textured floors under an area lamp: a checker image on a Diffuse BSDF's Color (8-bit sRGB,
Linear) and roughness stripes on a metallic Principled BSDF (Non-Color, Closest).

Run: python scenes/textured_floors.py OUT.blend
The two PNGs are written beside OUT.blend. 64 x 32 pixels.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402
import common  # noqa: E402


def write_png(path, rgb8):
    """An 8-bit RGB PNG of an (h, w, 3) uint8 array."""
    import OpenImageIO as oiio
    path = str(path)
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, oiio.ImageSpec(rgb8.shape[1], rgb8.shape[0], 3, "uint8")):
        raise OSError(f"{path}: cannot write ({oiio.geterror()})")
    out.write_image(np.ascontiguousarray(rgb8))
    out.close()
    return path


def checker_png(path, n=8):
    """An n x n checker of two colours (8-bit sRGB values)."""
    rows, cols = np.indices((n, n))
    light, dark = np.array([230, 200, 120]), np.array([40, 70, 150])
    image = np.where(((rows + cols) % 2 == 0)[..., None], light, dark).astype(np.uint8)
    return write_png(path, image)


def stripes_png(path, n=8):
    """Vertical stripes of roughness 0.15 and 0.6 (grey 8-bit values, read as Non-Color)."""
    values = np.where(np.arange(n) % 2 == 0, round(0.15 * 255), round(0.6 * 255))
    image = np.repeat(np.tile(values, (n, 1))[..., None], 3, axis=2).astype(np.uint8)
    return write_png(path, image)


def image_material(name, shader, image_path, input_name, interpolation, colorspace, **values):
    """A material whose shader's input_name comes from an Image Texture of image_path."""
    mat = common.material(name, shader, (0.8, 0.8, 0.8), **values)
    tree = mat.node_tree
    node = next(n for n in tree.nodes if n.bl_idname.startswith("ShaderNodeBsdf"))
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(str(image_path))
    tex.image.colorspace_settings.name = colorspace
    tex.interpolation = interpolation
    tree.links.new(tex.outputs["Color"], node.inputs[input_name])
    return mat


def plane(name, location, size, mat):
    """A square plane of the given size, facing +Z, with mat."""
    bpy.ops.mesh.primitive_plane_add(size=size, location=location)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(mat)
    return obj


def build_floors(path, checker, stripes):
    """The scene with the given checker and stripes images, saved to path."""
    scene = common.reset()
    common.setup_render(scene, (64, 32))
    common.set_world(scene, (0.05, 0.05, 0.06))
    floor = image_material("Checker", "diffuse", checker, "Color", "Linear", "sRGB")
    metal = image_material("RoughStripes", "principled", stripes, "Roughness", "Closest",
                           "Non-Color", Metallic=1.0)
    plane("CheckerFloor", (-1.05, 0.0, 0.0), 2.0, floor)
    plane("MetalFloor", (1.05, 0.0, 0.0), 2.0, metal)
    common.area_lamp("Lamp", 300.0, 1.0, (0.3, 1.5, 2.0), (-0.6, 0.0, 0.0))
    common.camera(scene, (0.0, -3.2, 2.2), (0.0, 0.2, 0.0), lens=32.0)
    return common.save(path)


def build(path):
    """Build the scene (its images beside path) and save it to path."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    return build_floors(path, checker_png(os.path.join(folder, "checker.png")),
                        stripes_png(os.path.join(folder, "stripes.png")))


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "textured_floors.blend"))
