"""The Snell render engine as Blender sees it. Thin: the F12 work is in final.py, the
viewport's in viewport.py."""
import bpy

from ..tracer.scene import SceneError
from . import final, viewport


class SnellRenderEngine(bpy.types.RenderEngine):
    bl_idname = "SNELL"
    bl_label = "Snell"
    bl_use_preview = False          # no material preview renders
    bl_use_postprocess = True       # compositing and sequencer work as with any engine
    bl_use_eevee_viewport = True    # Material Preview in the viewport uses EEVEE

    def render(self, depsgraph):
        final.render(self, depsgraph)

    def view_update(self, context, depsgraph):
        """The scene changed while the viewport renders: re-export what changed, restart."""
        viewport.controller(self).update(self, depsgraph)

    def view_draw(self, context, depsgraph):
        """Draw the viewport's newest image; follow navigation (it calls no view_update)."""
        viewport.controller(self).draw(self, context, depsgraph, viewport.DRAWING)

    def __del__(self):
        # Blender frees the engine when the viewport closes or leaves Rendered mode, or the
        # engine changes: stop and join the worker. (A final render has no viewport.)
        try:
            viewport.release(self)
        except Exception:  # at interpreter exit the modules may be gone; the worker is a daemon
            pass

    def update_render_passes(self, scene=None, renderlayer=None):
        """The passes a render fills, for the compositor's Render Layers node."""
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        self.register_pass(scene, renderlayer, final.SAMPLE_COUNT_PASS, 1, "X", "VALUE")
        if scene is None:
            return
        from .export import blender_settings
        try:
            settings = blender_settings(scene)
        except SceneError:   # a broken setting is reported by the render, not here
            return
        for name, channels, ids in final.denoising_passes(settings):
            self.register_pass(scene, renderlayer, name, channels, ids,
                               "VECTOR" if ids == "XYZ" else "COLOR")
        groups = final.light_groups_of(renderlayer)
        for name, channels, ids in final.light_passes_of(renderlayer) + groups:
            self.register_pass(scene, renderlayer, name, channels, ids, "COLOR")
        for name, channels, ids in final.data_passes_of(renderlayer):
            self.register_pass(scene, renderlayer, name, channels, ids,
                               "VALUE" if channels == 1 else "VECTOR")
