"""Snell's panel in the Render Properties, and Blender's own panels that mean the same for Snell."""
import bpy

ENGINE = "SNELL"

# Built-in (bl_ui) panels whose settings Snell reads with the same meaning: camera lens and depth
# of field, lights, material and world surface node trees, output format, frame range, output path,
# dimensions and colour management. Cycles' own panels (cycles.ui) are left alone: they draw
# scene.cycles settings that Snell ignores.
COMPAT_PANELS = (
    "DATA_PT_context_camera", "DATA_PT_lens", "DATA_PT_camera", "DATA_PT_camera_dof",
    "DATA_PT_camera_dof_aperture", "DATA_PT_camera_safe_areas", "DATA_PT_camera_display",
    "DATA_PT_context_light", "DATA_PT_light", "DATA_PT_spot",
    "EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface",
    "WORLD_PT_context_world", "EEVEE_WORLD_PT_surface",
    "RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_output", "RENDER_PT_output_color_management",
    "RENDER_PT_color_management", "RENDER_PT_color_management_curves",
    "RENDER_PT_color_management_white_balance", "RENDER_PT_color_management_working_space",
    "RENDER_PT_color_management_advanced",
)

_added = []  # the panels we added ENGINE to (and so must remove it from)


class SnellPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def column(self, **options):
        """A property column laid out like Cycles' render panels (options: heading, align)."""
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        return layout.column(**options)


class RENDER_PT_snell_sampling(SnellPanel, bpy.types.Panel):
    bl_label = "Sampling"

    def draw(self, context):
        props = context.scene.snell
        # Cycles' layout: the checkbox and the value on one row under a "Noise Threshold" heading,
        # the value greyed out when off; the samples then are a maximum, with a minimum.
        col = self.column(heading="Noise Threshold", align=True)
        row = col.row(align=True)
        row.prop(props, "use_adaptive_sampling", text="")
        sub = row.row()
        sub.active = props.use_adaptive_sampling
        sub.prop(props, "noise_threshold", text="")
        col = self.column(align=True)
        if props.use_adaptive_sampling:
            col.prop(props, "spp", text="Max Samples")
            col.prop(props, "min_spp", text="Min Samples")
        else:
            col.prop(props, "spp", text="Samples")
        self.column().prop(props, "seed")


class RENDER_PT_snell_sampling_viewport(SnellPanel, bpy.types.Panel):
    bl_label = "Viewport"
    bl_parent_id = "RENDER_PT_snell_sampling"

    def draw(self, context):
        # Cycles' Sampling > Viewport: the samples the viewport's Rendered mode refines to.
        col = self.column(align=True)
        col.prop(context.scene.snell, "viewport_spp", text="Max Samples")
        col.prop(context.scene.snell, "viewport_time_limit", text="Time Limit")


class RENDER_PT_snell_light_paths(SnellPanel, bpy.types.Panel):
    bl_label = "Light Paths"

    def draw(self, context):
        props = context.scene.snell
        col = self.column()
        col.prop(props, "max_depth")
        col.label(text=f"Cycles: Max Bounces {props.max_depth - 1}" if props.max_depth > 0
                  else "No Cycles equivalent (emitters only)")
        col.prop(props, "fresnel")
        col.prop(props, "caustics")
        col.prop(props, "light_vertices")


class RENDER_PT_snell_performance(SnellPanel, bpy.types.Panel):
    bl_label = "Performance"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        self.column().prop(context.scene.snell, "threads")


classes = (RENDER_PT_snell_sampling, RENDER_PT_snell_sampling_viewport, RENDER_PT_snell_light_paths,
           RENDER_PT_snell_performance)


def add_compat_engine():
    for name in COMPAT_PANELS:
        panel = getattr(bpy.types, name, None)
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if isinstance(engines, set) and ENGINE not in engines:
            engines.add(ENGINE)
            _added.append(panel)


def remove_compat_engine():
    while _added:
        _added.pop().COMPAT_ENGINES.discard(ENGINE)
