"""Snell's render settings, stored on every scene as `scene.snell`.

The viewport (addon/viewport.py) reads viewport_spp and viewport_time_limit.
addon/export/settings.py reads spp, max_depth, seed, fresnel, caustics, light_vertices and the
adaptive sampling settings from here into the scene file; threads is used by the render engine
only.
"""
import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty


class SnellRenderSettings(bpy.types.PropertyGroup):
    spp: IntProperty(
        name="Samples", default=64, min=1, soft_max=4096,
        description="Samples per pixel of a final render; with a noise threshold, the most any "
                    "pixel takes")
    viewport_spp: IntProperty(
        name="Viewport Samples", default=1024, min=0, soft_max=4096,
        description="Samples per pixel the viewport's Rendered mode refines to; 0 refines until "
                    "the view changes or the viewport closes")
    viewport_time_limit: FloatProperty(
        name="Viewport Time Limit", default=0.0, min=0.0, soft_max=600.0, subtype="TIME_ABSOLUTE",
        unit="TIME_ABSOLUTE",
        description="Stop refining the viewport after this many seconds; 0 has no limit")
    # Adaptive sampling as Cycles' Sampling panel has it: names, defaults and ranges.
    use_adaptive_sampling: BoolProperty(
        name="Noise Threshold", default=True,
        description="Stop sampling each pixel once its noise is below the threshold (adaptive "
                    "sampling, as Cycles')")
    noise_threshold: FloatProperty(
        name="Noise Threshold", default=0.01, min=0.0, max=1.0, soft_min=0.001, step=0.1,
        precision=4,
        description="Noise level at which a pixel stops sampling: lower is less noise and more "
                    "samples (Cycles' default 0.01)")
    min_spp: IntProperty(
        name="Min Samples", default=0, min=0, max=4096,
        description="Samples every pixel takes before it may stop (rounded up to a multiple of "
                    "16, at least 32); 0 chooses from the noise threshold as Cycles does (64 at "
                    "0.01)")
    max_depth: IntProperty(
        name="Max Depth", default=8, min=0, soft_max=64,
        description="Emission plus up to this many bounces (the seed project's max_ray_depth). "
                    "Cycles equivalent: max_bounces = Max Depth - 1 (with the diffuse, glossy and "
                    "transmission limits set to the same value); 0 shows only emitters seen directly")
    seed: IntProperty(
        name="Seed", default=0, min=0,
        description="Random seed: the same seed and sample count give the same image, whatever "
                    "the thread count")
    threads: IntProperty(
        name="Threads", default=0, min=0, soft_max=256,
        description="Render threads; 0 uses Blender's own setting (Performance > Threads)")
    fresnel: EnumProperty(
        name="Fresnel", default="EXACT",
        items=[("EXACT", "Exact", "The exact unpolarised dielectric Fresnel equations, as Cycles"),
               ("SCHLICK", "Schlick", "Schlick's approximation, as the seed project (not Cycles)")],
        description="Fresnel model for glass")
    caustics: BoolProperty(
        name="Caustics", default=True,
        description="Trace light paths from the lamps through mirrors and glass to the surfaces "
                    "they light (the same image as the path tracer alone, with far less noise in "
                    "caustics); runs only in scenes with mirrors or glass and a lamp that rays "
                    "can hit")
    light_vertices: BoolProperty(
        name="Light Vertices", default=True,
        description="Connect every diffuse vertex of a camera path to a point that light from a "
                    "lamp reaches first (the same image, with far less noise where surfaces next "
                    "to lamps light the scene); runs only with mesh lights or area lamps. "
                    "Adaptive renders measure in their first samples whether the connections "
                    "save more samples than their rays cost, and keep them only if they do")


def register():
    bpy.types.Scene.snell = bpy.props.PointerProperty(type=SnellRenderSettings, name="Snell")


def unregister():
    del bpy.types.Scene.snell


_standalone = False


def ensure_readable():
    """Make scene.snell readable without the add-on (the `snell` command exporting a .blend).

    Blender 5 keeps add-on properties out of reach until their type is registered; only the
    property group is registered here, and registration.register() takes it over.
    """
    global _standalone
    if hasattr(bpy.types.Scene, "snell"):
        return
    bpy.utils.register_class(SnellRenderSettings)
    register()
    _standalone = True


def drop_standalone():
    """Undo ensure_readable() before the full registration."""
    global _standalone
    if _standalone:
        unregister()
        bpy.utils.unregister_class(SnellRenderSettings)
        _standalone = False
