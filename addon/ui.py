"""Snell's panel in the Render Properties, and Blender's own panels that mean the same for Snell."""
import bpy

from .export.cycles_settings import FOLLOWED

ENGINE = "SNELL"

# Built-in (bl_ui) panels whose settings Snell reads with the same meaning: camera lens and depth
# of field, material and world surface node trees, output format, frame range, output path,
# metadata, encoding, dimensions and colour management, and the custom-property and animation
# panels, which hold data, not render settings. Each has a COMPAT_ENGINES set of its own.
#
# Cycles' own panels (cycles.ui) are never given SNELL: they all share CyclesButtonsPanel's one
# COMPAT_ENGINES set, so adding SNELL to one shows every Cycles panel (tests/blender/
# test_panels.py). Where Snell renders what a Cycles panel shows (the lamp's fields, the
# objects' ray visibility) it has a panel of its own below.
COMPAT_PANELS = (
    "DATA_PT_context_camera", "DATA_PT_lens", "DATA_PT_camera", "DATA_PT_camera_dof",
    "DATA_PT_camera_dof_aperture", "DATA_PT_camera_safe_areas",
    "DATA_PT_camera_safe_areas_center_cut", "DATA_PT_camera_display",
    "DATA_PT_camera_display_composition_guides", "DATA_PT_camera_background_image",
    "DATA_PT_camera_animation", "DATA_PT_custom_props_camera",
    "DATA_PT_context_light", "DATA_PT_light_animation", "DATA_PT_custom_props_light",
    "EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface",
    "WORLD_PT_context_world", "EEVEE_WORLD_PT_surface", "WORLD_PT_animation",
    "WORLD_PT_custom_props",
    "OBJECT_PT_custom_props",
    "RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_time_stretching",
    "RENDER_PT_output", "RENDER_PT_output_color_management", "RENDER_PT_output_pixel_density",
    "RENDER_PT_encoding", "RENDER_PT_encoding_video", "RENDER_PT_encoding_audio",
    "RENDER_PT_stamp", "RENDER_PT_stamp_note", "RENDER_PT_stamp_burn",
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


def _cycles(context):
    """The scene's Cycles settings when Snell follows them (Follow Cycles' Settings on), else
    None."""
    props, cycles = context.scene.snell, getattr(context.scene, "cycles", None)
    return cycles if props.use_cycles_settings and hasattr(cycles, "samples") else None


def _draw_sampling(panel, owner, use, threshold, samples, least, time_limit):
    """The Sampling panel's adaptive sampling rows, of Snell's or of Cycles' properties."""
    # Cycles' layout: the checkbox and the value on one row under a "Noise Threshold" heading,
    # the value greyed out when off; the samples then are a maximum, with a minimum.
    col = panel.column(heading="Noise Threshold", align=True)
    row = col.row(align=True)
    row.prop(owner, use, text="")
    sub = row.row()
    sub.active = getattr(owner, use)
    sub.prop(owner, threshold, text="")
    col = panel.column(align=True)
    if getattr(owner, use):
        col.prop(owner, samples, text="Max Samples")
        col.prop(owner, least, text="Min Samples")
        if getattr(owner, least) == 0 and getattr(owner, threshold) > 0:
            # The automatic minimum at Cycles' 0.01 is 64: at 64 samples or fewer the
            # threshold changes nothing (`snell info` says so too).
            from ..tracer.adaptive import auto_min_spp, first_check
            least_spp = first_check(auto_min_spp(getattr(owner, threshold)))
            if least_spp >= getattr(owner, samples):
                col.label(text=f"Automatic minimum {least_spp}: no adaptive saving",
                          icon="INFO")
    else:
        col.prop(owner, samples, text="Samples")
    col.prop(owner, time_limit)


class RENDER_PT_snell_sampling(SnellPanel, bpy.types.Panel):
    bl_label = "Sampling"

    def draw(self, context):
        props, cycles = context.scene.snell, _cycles(context)
        self.column().prop(props, "use_cycles_settings")
        if cycles is not None:
            # The file's Cycles settings themselves: editing them here is editing Cycles'.
            _draw_sampling(self, cycles, "use_adaptive_sampling", "adaptive_threshold", "samples",
                                "adaptive_min_samples", "time_limit")
            row = self.column().row(align=True)
            row.prop(cycles, "seed")
            row.prop(cycles, "use_animated_seed", text="", icon="TIME")
            self.layout.label(text="Not rendered by Snell: light tree, path guiding",
                              icon="INFO")
            return
        _draw_sampling(self, props, "use_adaptive_sampling", "noise_threshold", "spp", "min_spp",
                            "time_limit")
        self.column().prop(props, "seed")

class RENDER_PT_snell_overrides(SnellPanel, bpy.types.Panel):
    """Per setting, Snell's own value over the file's Cycles one, while Snell follows the rest."""
    bl_label = "Snell Overrides"
    bl_parent_id = "RENDER_PT_snell_sampling"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return super().poll(context) and _cycles(context) is not None

    def draw(self, context):
        props = context.scene.snell
        col = self.column()
        for followed in FOLLOWED:
            key = followed.name.upper()
            row = col.row(heading=followed.label.rsplit(" > ", 1)[-1])
            row.prop_enum(props, "overrides", key, text="", icon="DECORATE_OVERRIDE")
            sub = row.row()
            sub.active = key in props.overrides
            sub.prop(props, followed.name, text="")


# The viewport's denoise switch, passes, prefilter, quality and start sample: Cycles' properties
# and Snell's own.
VIEWPORT_DENOISE_CYCLES = ("use_preview_denoising", "preview_denoising_input_passes",
                           "preview_denoising_prefilter", "preview_denoising_quality",
                           "preview_denoising_start_sample")
VIEWPORT_DENOISE_SNELL = ("viewport_denoise", "viewport_denoising_input_passes",
                          "viewport_denoising_prefilter", "viewport_denoising_quality",
                          "viewport_denoise_start_sample")


class RENDER_PT_snell_sampling_viewport(SnellPanel, bpy.types.Panel):
    bl_label = "Viewport"
    bl_parent_id = "RENDER_PT_snell_sampling"

    def draw(self, context):
        # Cycles' Sampling > Viewport: the samples the viewport's Rendered mode refines to
        # (the file's Cycles value when Snell follows it, as the Render panel does).
        cycles, props = _cycles(context), context.scene.snell
        col = self.column(align=True)
        if cycles is not None:
            col.prop(cycles, "preview_samples", text="Max Samples")
        else:
            col.prop(props, "viewport_spp", text="Max Samples")
        col.prop(props, "viewport_time_limit", text="Time Limit")
        # Cycles' Viewport > Denoise, with Open Image Denoise on the CPU whatever its denoiser.
        owner, names = ((cycles, VIEWPORT_DENOISE_CYCLES) if cycles is not None else
                        (props, VIEWPORT_DENOISE_SNELL))
        self.column(heading="Denoise").prop(owner, names[0], text="")
        sub = self.column()
        sub.active = getattr(owner, names[0])
        for name, label in zip(names[1:], ("Passes", "Prefilter", "Quality", "Start Sample")):
            sub.prop(owner, name, text=label)


class RENDER_PT_snell_denoise(SnellPanel, bpy.types.Panel):
    bl_label = "Denoise"
    bl_parent_id = "RENDER_PT_snell_sampling"

    def draw_header(self, context):
        cycles = _cycles(context)
        owner, prop = (cycles, "use_denoising") if cycles is not None else \
            (context.scene.snell, "denoise")
        self.layout.prop(owner, prop, text="")

    def draw(self, context):
        cycles = _cycles(context)
        col = self.column()
        if cycles is not None:
            # Cycles' own properties: Snell denoises with Open Image Denoise whatever the
            # denoiser (snell info lists another as not rendered).
            col.active = cycles.use_denoising
            col.prop(cycles, "denoiser", text="Denoiser")
            col.prop(cycles, "denoising_input_passes", text="Passes")
            col.prop(cycles, "denoising_prefilter", text="Prefilter")
            col.prop(cycles, "denoising_quality", text="Quality")
            return
        props = context.scene.snell
        col.active = props.denoise
        col.prop(props, "denoising_input_passes", text="Passes")
        col.prop(props, "denoising_prefilter", text="Prefilter")
        col.prop(props, "denoising_quality", text="Quality")
        col.prop(props, "denoising_passes")


class RENDER_PT_snell_light_paths(SnellPanel, bpy.types.Panel):
    bl_label = "Light Paths"

    def draw(self, context):
        props, cycles = context.scene.snell, _cycles(context)
        col = self.column()
        if cycles is not None:
            # Cycles' own properties, which Snell renders (cycles_settings.FOLLOWED).
            col.prop(cycles, "max_bounces", text="Max Bounces")
            for prop, text in (("diffuse_bounces", "Diffuse"), ("glossy_bounces", "Glossy"),
                               ("transmission_bounces", "Transmission"),
                               ("transparent_max_bounces", "Transparent")):
                col.prop(cycles, prop, text=text)
            col.label(text=f"Snell: Max Depth {cycles.max_bounces + 1}")
            col.prop(cycles, "sample_clamp_direct", text="Clamp Direct")
            col.prop(cycles, "sample_clamp_indirect", text="Clamp Indirect")
            col.prop(cycles, "caustics_reflective", text="Reflective Caustics")
            col.prop(cycles, "caustics_refractive", text="Refractive Caustics")
            col.label(text="Filter Glossy is not rendered")
        else:
            col.prop(props, "max_depth")
            col.label(text=f"Cycles: Max Bounces {props.max_depth - 1}" if props.max_depth > 0
                      else "No Cycles equivalent (emitters only)")
            for name in ("diffuse_bounces", "glossy_bounces", "transmission_bounces",
                         "transparent_max_bounces", "sample_clamp_direct",
                         "sample_clamp_indirect", "caustics_reflective", "caustics_refractive"):
                col.prop(props, name)
        # What Snell adds: its own whether or not it follows Cycles.
        col.prop(props, "fresnel")
        col.prop(props, "caustics")
        col.prop(props, "light_vertices")


class RENDER_PT_snell_performance(SnellPanel, bpy.types.Panel):
    bl_label = "Performance"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        props = context.scene.snell
        self.column().prop(props, "threads")
        # F12 on a Dask cluster (addon/final.py): the threads are then the workers'.
        col = self.column()
        col.prop(props, "render_on")
        if props.render_on == "DASK_SCHEDULER":
            col.prop(props, "cluster_address")
        elif props.render_on == "LOCAL_WORKERS":
            col.prop(props, "cluster_workers")


class RENDER_PT_snell_film(SnellPanel, bpy.types.Panel):
    bl_label = "Film"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        # The pixel filter, exposure and transparency: Blender's and Cycles' own properties when
        # Snell follows them (editing them here is editing theirs), else Snell's.
        col = self.column()
        rd, following = context.scene.render, _cycles(context)
        if following is not None:
            col.prop(following, "pixel_filter_type", text="Pixel Filter")
            col.prop(following, "filter_width", text="Width")
            col.prop(following, "film_exposure", text="Exposure")
            col.prop(rd, "film_transparent", text="Transparent")
            glass = col.column()
            glass.active = rd.film_transparent
            glass.prop(following, "film_transparent_glass", text="Transparent Glass")
            glass.prop(following, "film_transparent_roughness", text="Roughness Threshold")
        else:
            props = context.scene.snell
            col.prop(props, "pixel_filter")
            col.prop(props, "filter_width", text="Width")
            col.prop(props, "film_exposure", text="Exposure")
            col.prop(props, "film_transparent", text="Transparent")
            glass = col.column()
            glass.active = props.film_transparent
            glass.prop(props, "film_transparent_glass")
            glass.prop(props, "film_transparent_roughness")


class SnellDataPanel(SnellPanel):
    bl_context = "data"


class DATA_PT_snell_light(SnellDataPanel, bpy.types.Panel):
    """Every lamp field Snell renders (addon/export/lights.py), laid out as Cycles' Light panel."""
    bl_label = "Light"

    @classmethod
    def poll(cls, context):
        return context.light is not None and super().poll(context)

    def draw(self, context):
        light, layout = context.light, self.layout
        layout.row().prop(light, "type", expand=True)
        col = self.column()
        row = col.column(align=True, heading="Temperature").row(align=True)
        row.prop(light, "use_temperature", text="")
        sub = row.row()
        sub.active = light.use_temperature
        sub.prop(light, "temperature", text="")
        col.prop(light, "color", text="Tint" if light.use_temperature else "Color")
        col = self.column()
        col.prop(light, "energy")
        col.prop(light, "exposure")
        col.prop(light, "normalize")
        col = self.column()
        if light.type in {"POINT", "SPOT"}:
            col.prop(light, "shadow_soft_size", text="Radius")
            col.prop(light, "use_soft_falloff")
        elif light.type == "SUN":
            col.prop(light, "angle")
        elif light.type == "AREA":
            col.prop(light, "shape")
            sub = col.column(align=True)
            if light.shape in {"RECTANGLE", "ELLIPSE"}:
                sub.prop(light, "size", text="Size X")
                sub.prop(light, "size_y", text="Y")
            else:
                sub.prop(light, "size")


class DATA_PT_snell_light_beam(SnellDataPanel, bpy.types.Panel):
    bl_label = "Beam Shape"
    bl_parent_id = "DATA_PT_snell_light"

    @classmethod
    def poll(cls, context):
        return context.light is not None and context.light.type in {"SPOT", "AREA"} \
            and super().poll(context)

    def draw(self, context):
        light, col = context.light, self.column()
        if light.type == "SPOT":
            col.prop(light, "spot_size", text="Angle")
            col.prop(light, "spot_blend", text="Blend", slider=True)
            col.prop(light, "show_cone")
        else:
            col.prop(light, "spread")


class DATA_PT_snell_light_settings(SnellDataPanel, bpy.types.Panel):
    """Cycles' light Settings, but only what Snell renders: Cast Shadow and Multiple Importance
    (not the per-light max bounces, portals or the shadow-caustics flag)."""
    bl_label = "Settings"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.light is not None and super().poll(context)

    def draw(self, context):
        light, col = context.light, self.column(align=True)
        col.prop(light, "use_shadow", text="Cast Shadow")
        cycles = getattr(light, "cycles", None)
        if cycles is not None:
            col.prop(cycles, "use_multiple_importance_sampling", text="Multiple Importance")


class OBJECT_PT_snell_visibility(SnellPanel, bpy.types.Panel):
    """Show In Renders for every object; ray visibility for lamps, which Snell honours (not for
    meshes, which every ray sees)."""
    bl_label = "Visibility"
    bl_context = "object"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.object is not None and super().poll(context)

    def draw(self, context):
        ob, col = context.object, self.column(heading="Show In")
        col.prop(ob, "hide_viewport", text="Viewports", invert_checkbox=True, toggle=False)
        col.prop(ob, "hide_render", text="Renders", invert_checkbox=True, toggle=False)
        col = self.column(heading="Ray Visibility")
        if ob.type == "LIGHT":
            col.prop(ob, "visible_camera", text="Camera")
            col.prop(ob, "visible_diffuse", text="Diffuse")
            col.prop(ob, "visible_glossy", text="Glossy")
            col.prop(ob, "visible_transmission", text="Transmission")
        else:
            col.label(text="Not rendered for meshes: every ray sees them")


classes = (RENDER_PT_snell_sampling, RENDER_PT_snell_overrides, RENDER_PT_snell_sampling_viewport,
           RENDER_PT_snell_denoise, RENDER_PT_snell_light_paths,
           RENDER_PT_snell_film, RENDER_PT_snell_performance, DATA_PT_snell_light,
           DATA_PT_snell_light_beam, DATA_PT_snell_light_settings, OBJECT_PT_snell_visibility)


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
