"""What a viewport edit changes: `depsgraph.updates` sorted into the least the viewport redoes.

Blender lists every datablock an edit touched with three flags (geometry, transform, shading).
Measured in Blender 5.0 (tests/blender/test_viewport.py captures them with a depsgraph_update_post
handler): moving an object lists the object with `transform`; editing its mesh lists the object
and the mesh with `geometry`; an edit of a material's node lists the material and, with
`shading`, each object and mesh using it; a camera's f-stop lists the camera object with
`geometry`; a scene-level change (visibility, world) lists the scene and every object with
`shading`. The rules below go by the datablock's type first, so that a flag means what it
means for that type. No bpy here: `snapshot` reads the updates into plain values.
"""
from __future__ import annotations

from dataclasses import dataclass, field

# Object types whose evaluated data is a mesh the exporter reads (curves, text and the like
# reach the depsgraph as meshes too).
GEOMETRY_OBJECTS = {"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD",
                    "VOLUME", "GREASEPENCIL"}
# Data that objects own: their objects are listed with the same flags, so these add nothing.
OBJECT_DATA = {"Mesh", "Curve", "TextCurve", "SurfaceCurve", "MetaBall", "Curves", "PointCloud",
               "Volume", "GreasePencil", "Armature", "Lattice"}
MATERIAL_DATA = {"Material", "Image", "Texture", "ImageTexture"}


@dataclass(frozen=True)
class Update:
    """One entry of depsgraph.updates as plain values."""
    id_type: str              # the datablock's class name: "Object", "Mesh", "Material", ...
    name: str
    object_type: str = ""     # for objects: MESH, LIGHT, CAMERA, EMPTY, ...
    geometry: bool = False
    transform: bool = False
    shading: bool = False


def snapshot(depsgraph) -> list[Update]:
    """depsgraph.updates as Update values (read on the main thread, during view_update)."""
    out = []
    for u in depsgraph.updates:
        block = u.id
        out.append(Update(type(block).__name__, block.name, getattr(block, "type", "")
                          if type(block).__name__ == "Object" else "",
                          bool(u.is_updated_geometry), bool(u.is_updated_transform),
                          bool(u.is_updated_shading)))
    return out


@dataclass
class Plan:
    """What to redo after an edit."""
    geometry: set = field(default_factory=set)     # objects to extract again
    transform: set = field(default_factory=set)    # objects whose matrix to apply again
    materials: bool = False
    lights: bool = False
    world: bool = False
    camera: bool = False
    settings: bool = False     # the scene: render settings, visibility, objects added or removed

    def restart(self) -> str:
        """The largest step the plan takes, for the stats and the tests: "nothing", "camera",
        "tables" (materials, lamps, world, settings: the BVH stays), "transform" (matrices
        applied again, BVH rebuilt) or "geometry" (objects extracted again, BVH rebuilt)."""
        if self.geometry:
            return "geometry"
        if self.transform:
            return "transform"
        if self.materials or self.lights or self.world or self.settings:
            return "tables"
        return "camera" if self.camera else "nothing"

    def merge(self, other: "Plan") -> "Plan":
        """Both plans' work (edits that arrive before the viewport takes them)."""
        return Plan(self.geometry | other.geometry, self.transform | other.transform,
                    self.materials or other.materials, self.lights or other.lights,
                    self.world or other.world, self.camera or other.camera,
                    self.settings or other.settings)

    @property
    def content(self) -> bool:
        """Whether the scene content (anything but the camera) changed."""
        return self.restart() not in ("nothing", "camera")


def classify(updates) -> Plan:
    """The plan for a list of Update values."""
    plan = Plan()
    for u in updates:
        if u.id_type == "Object":
            if u.object_type in GEOMETRY_OBJECTS:
                if u.geometry:
                    plan.geometry.add(u.name)
                if u.transform:
                    plan.transform.add(u.name)
                if u.shading and not u.geometry:
                    plan.materials = True   # its material's node changed (or the scene's)
            elif u.object_type == "LIGHT":
                plan.lights = True
            elif u.object_type == "CAMERA":
                plan.camera = True
            elif u.geometry or u.transform:
                # Empties and the rest: an instancer, a parent or a focus object moved.
                plan.transform.add(u.name)
                plan.camera = True
        elif u.id_type in OBJECT_DATA:
            continue
        elif u.id_type.endswith("Light"):       # PointLight, SunLight, SpotLight, AreaLight
            plan.lights = True
        elif u.id_type == "Camera":
            plan.camera = True
        elif u.id_type == "World":
            plan.world = True
        elif u.id_type in ("Scene", "Collection", "ViewLayer"):
            plan.settings = True
        elif u.id_type in MATERIAL_DATA or u.id_type.endswith("NodeTree"):
            # A node tree comes with the material, lamp or world that uses it; a node group's
            # edit lists the group alone.
            plan.materials = True
        else:
            # Anything else: the tables are cheap to rebuild, and the BVH stays.
            plan.materials = plan.lights = plan.world = True
    return plan


def full() -> Plan:
    """The plan of a first export: everything."""
    return Plan(materials=True, lights=True, world=True, camera=True, settings=True)
