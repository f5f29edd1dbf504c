"""Convert a Blender depsgraph into a Snell Scene (docs/scene-format.md): one module per datablock.

Everything goes through the evaluated depsgraph, so modifiers, instances and world matrices are
the ones Cycles sees. Whatever Snell cannot render exactly is rendered with a stated fallback and
reported in the returned warnings.

- depsgraph.py: the walk. Exporter visits the rendered instances, hands each to its datablock's
  module and assembles the Scene; export_depsgraph, export_blend and export_to_file.
- materials.py: a material's shader nodes (convert_material: the active output's Surface, and a
  missing material as Cycles' default surface); mixes.py: a Mix Shader of a constant factor
  folded into one material where that is exact; bsdfs.py: the BSDF nodes Snell evaluates, one
  converter each in CONVERTERS; coverage.py: what a conversion evaluated and what it replaced
  with what (Coverage: the warnings, and `snell info`'s material lines); nodes.py: the
  node-tree readers every conversion shares (follow, through reroutes and muted nodes;
  active_output; Inputs).
- textures.py: Image Texture nodes (ImageTextures) and Mapping nodes (mapping_of); images.py
  reads an image's pixels for them and for the world.
- meshes.py: an evaluated mesh's arrays (mesh_arrays, Mesh) and its instances in world space
  (to_world).
- lights.py: lamp objects and their light nodes (convert_light).
- camera.py: the scene's camera (convert_camera).
- world.py: the world's Background and Environment Texture (convert_world).
- settings.py: the render settings (blender_settings, setting_sources, convert_render,
  blender_threads); cycles_settings.py: the file's Cycles settings Snell follows (FOLLOWED)
  and those it does not render (NOT_RENDERED).

A new shader node: a converter in bsdfs.py's CONVERTERS if it is a BSDF, in textures.py if
a material input reads it (a new material kind or field needs the scene format first:
tracer/scene.py). A new datablock: a module of its own whose convert_<datablock> takes the
Blender data and a warn callback and returns the scene file's entry, as lights.py does, called
from Exporter in depsgraph.py. The walk imports the datablock modules, never the reverse
(tests/unit/test_layering.py).
"""
from .camera import convert_camera
from .depsgraph import (DROPPED_TRIANGLES, OPEN_MESH, SAME_IN_CYCLES, ZERO_SCALE,
                        differs_from_cycles, export_blend, export_depsgraph, export_to_file,
                        rendered_instances)
from .lights import convert_light
from .materials import convert_material
from .settings import blender_settings, blender_threads, convert_render
from .world import convert_world

__all__ = ["DROPPED_TRIANGLES", "OPEN_MESH", "SAME_IN_CYCLES", "ZERO_SCALE", "blender_settings",
           "blender_threads", "convert_camera",
           "convert_light", "convert_material", "convert_render", "convert_world",
           "differs_from_cycles", "export_blend", "export_depsgraph", "export_to_file",
           "rendered_instances"]
