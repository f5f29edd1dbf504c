"""A room whose materials are node graphs, as users build them: the node-heavy scene that
`snell bench` holds against Cycles beside the default scenes (every material is a shader
program, none a fixed kind).

Run: python scenes/node_materials.py OUT.blend
In the Cornell box: a floor of worn tiles (Checker colours through a Noise-driven Mix, the
roughness a Map Range of the Noise), a brick back wall, a glass built as Mix(Fresnel,
Refraction, Glossy), a three-IOR dispersion group, a leaf cut out by a Noise and a Color
Ramp through the Principled BSDF's Alpha, and glass mixed with Transparent for shadow rays.
256x256, Standard view transform.
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402


def node_tree(name):
    """A new material with an empty node tree: (material, tree, its Material Output)."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    return mat, tree, tree.nodes.new("ShaderNodeOutputMaterial")


def node(tree, idname, **inputs):
    """A new node of the tree with these input values."""
    new = tree.nodes.new(idname)
    for key, value in inputs.items():
        new.inputs[key].default_value = value
    return new


def worn_tiles():
    """Checker tiles whose colour and roughness wear with a Noise texture."""
    mat, tree, out = node_tree("WornTiles")
    bsdf = node(tree, "ShaderNodeBsdfPrincipled")
    checker = node(tree, "ShaderNodeTexChecker", Scale=6.0, Color1=(0.8, 0.75, 0.65, 1.0),
                    Color2=(0.15, 0.12, 0.1, 1.0))
    noise = node(tree, "ShaderNodeTexNoise", Scale=4.0, Detail=3.0)
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MULTIPLY"
    mix.inputs["Factor"].default_value = 0.6
    tree.links.new(checker.outputs["Color"], mix.inputs["A"])
    tree.links.new(noise.outputs["Color"], mix.inputs["B"])
    rough = node(tree, "ShaderNodeMapRange", **{"To Min": 0.2, "To Max": 0.7})
    tree.links.new(noise.outputs["Fac"], rough.inputs["Value"])
    tree.links.new(mix.outputs["Result"], bsdf.inputs["Base Color"])
    tree.links.new(rough.outputs["Result"], bsdf.inputs["Roughness"])
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return mat


def brick_wall():
    """A Diffuse BSDF coloured by a Brick texture."""
    mat, tree, out = node_tree("BrickWall")
    bsdf = node(tree, "ShaderNodeBsdfDiffuse")
    brick = node(tree, "ShaderNodeTexBrick", Scale=3.0, Color1=(0.55, 0.2, 0.12, 1.0),
                  Color2=(0.4, 0.16, 0.1, 1.0), Mortar=(0.7, 0.7, 0.68, 1.0))
    tree.links.new(brick.outputs["Color"], bsdf.inputs["Color"])
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return mat


def fresnel_glass(ior=1.5, refraction_ior=None, name="FresnelGlass", transmission=None,
                  reflection=None):
    """Mix(Fresnel, Refraction, Glossy): the glass of a file issue 29 lists, both BSDFs smooth
    (the Fresnel node's IOR ior, the Refraction's refraction_ior, default the same; the
    Refraction's colour transmission, the Glossy's reflection, default the nodes' own: white
    and grey 0.8)."""
    mat, tree, out = node_tree(name)
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(node(tree, "ShaderNodeFresnel", IOR=ior).outputs[0], mix.inputs["Fac"])
    refraction = node(tree, "ShaderNodeBsdfRefraction", IOR=refraction_ior or ior, Roughness=0.0,
                      **({"Color": (*transmission, 1.0)} if transmission else {}))
    tree.links.new(refraction.outputs[0], mix.inputs[1])
    tree.links.new(node(tree, "ShaderNodeBsdfGlossy", Roughness=0.0,
                        **({"Color": (*reflection, 1.0)} if reflection else {})).outputs[0],
                   mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    return mat


def dispersion_glass():
    """A node group adding three tinted glasses of three IORs."""
    group = bpy.data.node_groups.new("Dispersion", "ShaderNodeTree")
    group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
    go = group.nodes.new("NodeGroupOutput")
    shaders = [node(group, "ShaderNodeBsdfGlass", Color=(r, g, b, 1.0), IOR=ior, Roughness=0.0)
               for r, g, b, ior in ((1, 0, 0, 1.51), (0, 1, 0, 1.53), (0, 0, 1, 1.55))]
    first, second = group.nodes.new("ShaderNodeAddShader"), group.nodes.new("ShaderNodeAddShader")
    group.links.new(shaders[0].outputs[0], first.inputs[0])
    group.links.new(shaders[1].outputs[0], first.inputs[1])
    group.links.new(first.outputs[0], second.inputs[0])
    group.links.new(shaders[2].outputs[0], second.inputs[1])
    group.links.new(second.outputs[0], go.inputs[0])
    mat, tree, out = node_tree("DispersionGlass")
    instance = tree.nodes.new("ShaderNodeGroup")
    instance.node_tree = group
    tree.links.new(instance.outputs[0], out.inputs["Surface"])
    return mat


def leaf():
    """A Principled BSDF cut out by a Noise through a constant Color Ramp into Alpha."""
    mat, tree, out = node_tree("Leaf")
    bsdf = node(tree, "ShaderNodeBsdfPrincipled", **{"Base Color": (0.2, 0.55, 0.1, 1.0),
                                                       "Roughness": 0.5})
    noise = node(tree, "ShaderNodeTexNoise", Scale=3.0, Detail=2.0)
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "CONSTANT"
    ramp.color_ramp.elements[1].position = 0.5
    tree.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    tree.links.new(ramp.outputs["Color"], bsdf.inputs["Alpha"])
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return mat


def shadow_glass(ior=1.45, clear=1.0):
    """Glass for camera and indirect rays, Transparent (of colour `clear`) for shadow rays."""
    mat, tree, out = node_tree("ShadowGlass")
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(tree.nodes.new("ShaderNodeLightPath").outputs["Is Shadow Ray"],
                   mix.inputs["Fac"])
    tree.links.new(node(tree, "ShaderNodeBsdfGlass", IOR=ior, Roughness=0.0).outputs[0],
                   mix.inputs[1])
    tree.links.new(node(tree, "ShaderNodeBsdfTransparent",
                        Color=(clear, clear, clear, 1.0)).outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    return mat


def build(path):
    """Build the scene and save it to path."""
    scene = common.reset()
    common.setup_render(scene, (256, 256))
    common.cornell_box()
    tiles, bricks = worn_tiles(), brick_wall()
    for name, mat in (("Floor", tiles), ("BackWall", bricks)):
        obj = bpy.data.objects[name]
        obj.data.materials.clear()
        obj.data.materials.append(mat)
    common.uv_sphere("FresnelSphere", (-0.5, 0.4, 0.35), 0.35, fresnel_glass(), 48, 24)
    common.uv_sphere("DispersionSphere", (0.45, -0.25, 0.3), 0.3, dispersion_glass(), 48, 24)
    common.uv_sphere("ShadowSphere", (0.35, 0.55, 0.25), 0.25, shadow_glass(), 48, 24)
    plane = common.quad("Leaf", [(-0.5, -0.4, 0.9), (0.2, -0.4, 0.9), (0.2, 0.3, 1.3),
                                 (-0.5, 0.3, 1.3)], leaf())
    plane.name = "Leaf"
    common.cornell_camera(scene)
    return common.save(path)


if __name__ == "__main__":
    build(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__),
                                                             "node_materials.blend"))
