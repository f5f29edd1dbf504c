"""What the exporter made of one material's shader nodes (Coverage): the nodes and inputs Snell
evaluates, and each node, link or output it does not, with what it renders instead.

Every converter records here, and only here, whether a node or input is evaluated or replaced:
the exporter's warnings are the replaced entries (issues), and `snell info` lists both. A
replaced entry reads "node 'N': input 'I' <what Snell does not evaluate>: <what it renders
instead>", so that a warning always names the node, the input and the fallback.
"""
from __future__ import annotations

# The shader nodes Snell does not evaluate, by family, as a warning names them: what each is,
# so that "linked to 'Mix' (a shader mix)" says why it is dropped. An idname not here is named
# by its type alone.
NODE_FAMILIES = {
    "ShaderNodeMixShader": "a shader mix", "ShaderNodeAddShader": "a shader sum",
    "ShaderNodeGroup": "a node group", "NodeGroupInput": "a node group's input",
    "ShaderNodeNormalMap": "a normal map", "ShaderNodeBump": "a bump map",
    "ShaderNodeDisplacement": "a displacement", "ShaderNodeVectorDisplacement": "a displacement",
    "ShaderNodeVolumeAbsorption": "a volume", "ShaderNodeVolumeScatter": "a volume",
    "ShaderNodeVolumePrincipled": "a volume", "ShaderNodeVolumeCoefficients": "a volume",
    "ShaderNodeBsdfTransparent": "a transparent surface", "ShaderNodeHoldout": "a holdout",
    "ShaderNodeBsdfTranslucent": "a translucent surface",
    "ShaderNodeSubsurfaceScattering": "subsurface scattering",
    "ShaderNodeBsdfSheen": "a sheen surface", "ShaderNodeBsdfToon": "a toon surface",
    "ShaderNodeBsdfHair": "a hair surface", "ShaderNodeBsdfHairPrincipled": "a hair surface",
    "ShaderNodeBsdfRayPortal": "a ray portal", "ShaderNodeBsdfMetallic": "a metallic surface",
    "ShaderNodeTexNoise": "a procedural texture", "ShaderNodeTexChecker": "a procedural texture",
    "ShaderNodeTexBrick": "a procedural texture", "ShaderNodeTexWave": "a procedural texture",
    "ShaderNodeTexVoronoi": "a procedural texture", "ShaderNodeTexMagic": "a procedural texture",
    "ShaderNodeTexGradient": "a procedural texture",
    "ShaderNodeTexWhiteNoise": "a procedural texture",
    "ShaderNodeTexGabor": "a procedural texture", "ShaderNodeTexSky": "a procedural texture",
    "ShaderNodeTexImage": "an image texture", "ShaderNodeTexEnvironment": "an environment texture",
    "ShaderNodeLightPath": "a ray-type switch", "ShaderNodeFresnel": "a Fresnel factor",
    "ShaderNodeLayerWeight": "a Fresnel factor", "ShaderNodeNewGeometry": "a geometry input",
    "ShaderNodeMath": "a math node", "ShaderNodeVectorMath": "a math node",
    "ShaderNodeMix": "a mix of values", "ShaderNodeMixRGB": "a mix of values",
    "ShaderNodeValToRGB": "a colour ramp",
}


def node_text(node):
    """A node as a warning names it: its name, and its family when Snell knows it."""
    family = NODE_FAMILIES.get(node.bl_idname)
    return f"{node.name!r} ({family or node.bl_idname})"


class Coverage:
    """One material's (or the world's) coverage: evaluated and replaced entries, in order."""

    def __init__(self):
        self.evaluated = []    # "node 'Principled BSDF' as a principled surface", ...
        self.issues = []       # the replaced entries: each one warning

    def evaluate(self, node, how, input=None):
        """Record that Snell evaluates a node (on an input of another node, if given; once)."""
        on = f" on input {input!r}" if input else ""
        entry = f"node {node.name!r}{on}: {how}"
        if entry not in self.evaluated:
            self.evaluated.append(entry)

    def replace(self, node, what, instead, input=None):
        """Record a node, link or input Snell does not evaluate and what it renders instead."""
        where = f"node {node.name!r}: input {input!r} " if input else f"node {node.name!r}: "
        self.append(f"{where}{what}: {instead}")

    def append(self, issue):
        """Record a replaced entry already worded as a warning (once)."""
        if issue not in self.issues:
            self.issues.append(issue)

    def as_dict(self):
        """The coverage as `snell info` reads it."""
        return {"evaluated": list(self.evaluated), "replaced": list(self.issues)}
