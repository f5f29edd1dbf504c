"""Convert a Blender depsgraph into a Snell Scene (docs/scene-format.md): the public entry points.

The exporter is being split into one module per datablock; until then depsgraph.py holds it all.
"""
from .depsgraph import (DROPPED_TRIANGLES, OPEN_MESH, SAME_IN_CYCLES, ZERO_SCALE, convert_camera,
                        convert_light, convert_material, convert_render, convert_world,
                        differs_from_cycles, export_blend, export_depsgraph, export_to_file,
                        rendered_instances)

__all__ = ["DROPPED_TRIANGLES", "OPEN_MESH", "SAME_IN_CYCLES", "ZERO_SCALE", "convert_camera",
           "convert_light", "convert_material", "convert_render", "convert_world",
           "differs_from_cycles", "export_blend", "export_depsgraph", "export_to_file",
           "rendered_instances"]
