"""Shader node trees the exporter and validation tests build with bpy."""


def mix_nodes(mat):
    """The material's Mix Shader and the nodes linked to its Fac and its two Shader inputs."""
    mix = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeMixShader")
    return (mix, *(mix.inputs[i].links[0].from_node for i in range(3)))


def mix_shader_material(name, fac, first, second):
    """A material whose Surface is a Mix Shader (Fac `fac`) of two new shader nodes, and
    (material, mix node, [first node, second node]). Each side is a node idname, (idname,
    {input or "distribution": value}), or None (left unlinked)."""
    import bpy
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = fac
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    sides = []
    for i, side in ((1, first), (2, second)):
        node = None
        if side is not None:
            idname, values = (side, {}) if isinstance(side, str) else side
            node = tree.nodes.new(idname)
            for key, value in values.items():
                if key == "distribution":
                    node.distribution = value
                else:
                    node.inputs[key].default_value = value
            tree.links.new(node.outputs[0], mix.inputs[i])
        sides.append(node)
    return mat, mix, sides
