"""The Properties editor with Snell selected: every panel Cycles shows for render, output, lights,
cameras, objects and the world has a Snell counterpart, or is deliberately absent for a reason."""
import types

import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import registration, ui  # noqa: E402

CONTEXTS = ("render", "output", "object", "world", "data")

# Cycles' panel -> the panel that shows the same with Snell: one of Snell's, or a built-in one.
COUNTERPARTS = {
    "CYCLES_RENDER_PT_sampling": "RENDER_PT_snell_sampling",
    "CYCLES_RENDER_PT_sampling_render": "RENDER_PT_snell_sampling",
    "CYCLES_RENDER_PT_sampling_viewport": "RENDER_PT_snell_sampling_viewport",
    "CYCLES_RENDER_PT_sampling_viewport_denoise": "RENDER_PT_snell_sampling_viewport",
    "CYCLES_RENDER_PT_sampling_advanced": "RENDER_PT_snell_sampling",    # seed, animated seed
    "CYCLES_RENDER_PT_sampling_render_denoise": "RENDER_PT_snell_denoise",
    "CYCLES_RENDER_PT_light_paths": "RENDER_PT_snell_light_paths",
    "CYCLES_RENDER_PT_light_paths_max_bounces": "RENDER_PT_snell_light_paths",
    "CYCLES_RENDER_PT_light_paths_clamping": "RENDER_PT_snell_light_paths",
    # The caustics switches (Filter Glossy is listed there as not rendered).
    "CYCLES_RENDER_PT_light_paths_caustics": "RENDER_PT_snell_light_paths",
    "CYCLES_RENDER_PT_film": "RENDER_PT_snell_film",
    "CYCLES_RENDER_PT_film_pixel_filter": "RENDER_PT_snell_film",
    "CYCLES_RENDER_PT_film_transparency": "RENDER_PT_snell_film",
    "CYCLES_RENDER_PT_performance": "RENDER_PT_snell_performance",
    "CYCLES_RENDER_PT_performance_threads": "RENDER_PT_snell_performance",
    "CYCLES_CAMERA_PT_dof": "DATA_PT_camera_dof",
    "CYCLES_CAMERA_PT_dof_aperture": "DATA_PT_camera_dof_aperture",
    "CYCLES_LIGHT_PT_light": "DATA_PT_snell_light",
    "CYCLES_LIGHT_PT_beam_shape": "DATA_PT_snell_light_beam",
    "CYCLES_LIGHT_PT_settings": "DATA_PT_snell_light_settings",
    "CYCLES_OBJECT_PT_visibility": "OBJECT_PT_snell_visibility",
    "CYCLES_OBJECT_PT_visibility_ray_visibility": "OBJECT_PT_snell_visibility",
    "CYCLES_WORLD_PT_surface": "EEVEE_WORLD_PT_surface",
}

# Shown by Cycles, not by Snell, and why.
ABSENT = {
    "CYCLES_RENDER_PT_sampling_advanced_sample_subset": "Snell renders all its samples",
    "CYCLES_RENDER_PT_sampling_lights": "light tree and threshold: Snell samples lights its own "
                                        "way (snell info lists them as not rendered)",
    "CYCLES_RENDER_PT_sampling_path_guiding": "no path guiding",
    "CYCLES_RENDER_PT_sampling_path_guiding_debug": "no path guiding",
    "CYCLES_RENDER_PT_light_paths_fast_gi": "no fast GI approximation",
    "CYCLES_RENDER_PT_performance_acceleration_structure": "Embree's BVH, no options",
    "CYCLES_RENDER_PT_performance_compositor": "the compositor's own device settings",
    "CYCLES_RENDER_PT_performance_compositor_denoise_settings": "no denoising",
    "CYCLES_RENDER_PT_performance_final_render": "no tiles or persistent data",
    "CYCLES_RENDER_PT_performance_memory": "no tiles",
    "CYCLES_RENDER_PT_performance_viewport": "no viewport resolution options",
    "CYCLES_RENDER_PT_motion_blur": "no motion blur",
    "CYCLES_RENDER_PT_motion_blur_curve": "no motion blur",
    "CYCLES_RENDER_PT_bake": "no baking",
    "CYCLES_RENDER_PT_bake_influence": "no baking",
    "CYCLES_RENDER_PT_bake_output": "no baking",
    "CYCLES_RENDER_PT_bake_output_margin": "no baking",
    "CYCLES_RENDER_PT_bake_selected_to_active": "no baking",
    "CYCLES_RENDER_PT_curves": "no hair curves",
    "CYCLES_RENDER_PT_curves_viewport_display": "no hair curves",
    "CYCLES_RENDER_PT_volumes": "no volumes",
    "CYCLES_RENDER_PT_subdivision": "no adaptive subdivision",
    "CYCLES_RENDER_PT_debug": "Cycles' debug options",
    "CYCLES_RENDER_PT_simplify": "Simplify not checked with Snell's export yet",
    "CYCLES_RENDER_PT_simplify_culling": "no culling",
    "CYCLES_RENDER_PT_simplify_render": "Simplify not checked with Snell's export yet",
    "CYCLES_RENDER_PT_simplify_viewport": "Simplify not checked with Snell's export yet",
    "RENDER_PT_simplify_render": "Simplify not checked with Snell's export yet",
    "RENDER_PT_simplify_viewport": "Simplify not checked with Snell's export yet",
    "RENDER_PT_simplify_greasepencil": "no Grease Pencil",
    "CYCLES_VIEW3D_PT_simplify_greasepencil": "no Grease Pencil",
    "RENDER_PT_gpencil": "no Grease Pencil",
    "RENDER_PT_grease_pencil_render": "no Grease Pencil",
    "RENDER_PT_grease_pencil_viewport": "no Grease Pencil",
    "RENDER_PT_freestyle": "no Freestyle",
    "CYCLES_CAMERA_PT_lens_custom_parameters": "no custom (scripted) cameras",
    "CYCLES_PT_post_processing": "compositing and sequencer are not checked with Snell yet",
    "RENDER_PT_output_views": "no multi-view (stereo) rendering",
    "RENDER_PT_stereoscopy": "no multi-view (stereo) rendering",
    "DATA_PT_camera_stereoscopy": "no multi-view (stereo) rendering",
    "CYCLES_LIGHT_PT_nodes": "light nodes are read (Emission colour x strength) but not all: "
                             "the node panel would offer what Snell ignores",
    "CYCLES_LIGHT_PT_preview": "material previews render with Cycles",
    "CYCLES_OBJECT_PT_motion_blur": "no motion blur",
    "CYCLES_OBJECT_PT_visibility_culling": "no culling",
    "CYCLES_OBJECT_PT_lightgroup": "no light groups",
    "CYCLES_OBJECT_PT_shading_caustics": "Snell's light tracer renders every caustic; the "
                                         "shadow-caustics (MNEE) flags are not needed",
    "CYCLES_OBJECT_PT_shading_gi_approximation": "no fast GI approximation",
    "OBJECT_PT_shading": "shadow terminator offsets, caustics and light groups: not rendered",
    "OBJECT_PT_shadow_terminator": "no shadow terminator offsets",
    "CYCLES_WORLD_PT_mist": "no mist pass",
    "CYCLES_WORLD_PT_preview": "material previews render with Cycles",
    "CYCLES_WORLD_PT_ray_visibility": "the world is seen by every ray",
    "CYCLES_WORLD_PT_settings": "Snell samples the world its own way; no world volumes",
    "CYCLES_WORLD_PT_settings_light_group": "no light groups",
    "CYCLES_WORLD_PT_settings_surface": "Snell samples the world its own way",
    "CYCLES_WORLD_PT_settings_volume": "no volumes",
    "CYCLES_WORLD_PT_volume": "no volumes",
}

# Data panels of other kinds of data (meshes, curves, speakers, ...): edited with any engine,
# outside what this test covers (the camera's and the light's are covered).
DATA_KINDS = ("CAMERA", "camera", "LIGHT", "light")


def cycles_panels() -> set:
    """The Properties panels Cycles shows in CONTEXTS (lights' and cameras' for "data")."""
    out = set()
    for name in dir(bpy.types):
        cls = getattr(bpy.types, name)
        if not (isinstance(cls, type) and issubclass(cls, bpy.types.Panel)):
            continue
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if getattr(cls, "bl_space_type", "") != "PROPERTIES" or not isinstance(engines, set) \
                or "CYCLES" not in engines or getattr(cls, "bl_context", "") not in CONTEXTS:
            continue
        if cls.bl_context == "data" and (not any(kind in name for kind in DATA_KINDS)
                                         or "lightprobe" in name):   # EEVEE's
            continue
        out.add(name)
    return out


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


def shown_with_snell(name) -> bool:
    cls = getattr(bpy.types, name, None)
    return cls is not None and "SNELL" in getattr(cls, "COMPAT_ENGINES", ())



class RecordingLayout:
    """Stands in for a panel's layout: records the properties drawn (each one its owner has)
    and the enum items drawn as toggles; every other layout call returns the layout."""
    use_property_split = use_property_decorate = active = False

    def __init__(self):
        self.props, self.enums = [], []

    def __getattr__(self, name):
        return lambda *a, **k: self

    def prop(self, owner, name, **kwargs):
        assert hasattr(owner, name), name
        self.props.append(name)

    def prop_enum(self, owner, name, value, **kwargs):
        self.enums.append(value)


def draw(panel, context) -> RecordingLayout:
    """Draw a panel class into a RecordingLayout."""
    layout = RecordingLayout()
    panel.draw(types.SimpleNamespace(layout=layout, column=lambda **o: layout), context)
    return layout


def test_every_cycles_panel_has_a_counterpart_or_a_reason():
    panels = cycles_panels()
    assert len(panels) > 60 and "CYCLES_LIGHT_PT_light" in panels
    unaccounted = sorted(p for p in panels if p not in COUNTERPARTS and p not in ABSENT
                         and not shown_with_snell(p))
    assert unaccounted == [], "a Cycles panel with neither a Snell counterpart nor a reason"
    for cycles, snell in COUNTERPARTS.items():
        assert shown_with_snell(snell), f"{cycles}: {snell} is not shown with Snell"
    # The lists name panels that exist (a renamed panel is not silently "accounted for").
    assert set(COUNTERPARTS) <= panels and set(ABSENT) <= panels


def test_cycles_own_panels_are_never_given_snell():
    """They share CyclesButtonsPanel's one COMPAT_ENGINES set: SNELL in it shows them all."""
    assert "SNELL" not in bpy.types.CYCLES_RENDER_PT_film.COMPAT_ENGINES
    assert not any(p.startswith("CYCLES_") for p in ui.COMPAT_PANELS)


def test_the_light_panel_draws_every_field_snell_renders():
    """DATA_PT_snell_light and its Beam Shape draw power, colour, radius, shape, size, spread,
    spot size and blend and sun angle: every lamp field the exporter reads."""
    drawn = []

    for kind, extra in (("POINT", {}), ("SPOT", {}), ("SUN", {}), ("AREA", {"shape": "RECTANGLE"})):
        light = bpy.data.lights.new(kind, kind)
        for key, value in extra.items():
            setattr(light, key, value)
        context = type("Context", (), {"light": light, "engine": "SNELL"})()
        for panel in (ui.DATA_PT_snell_light, ui.DATA_PT_snell_light_beam):
            if panel.poll(context):
                drawn += draw(panel, context).props
    for field in ("type", "color", "energy", "exposure", "normalize", "use_temperature",
                  "temperature", "shadow_soft_size", "use_soft_falloff", "angle", "shape",
                  "size", "size_y", "spot_size", "spot_blend", "spread"):
        assert field in drawn, field


def test_the_overrides_panel_offers_every_followed_setting():
    """Snell Overrides (under Sampling, while Snell follows Cycles): a toggle and Snell's own
    value for every Cycles setting Snell follows, each a property Snell has."""
    from snell.addon.export.cycles_settings import FOLLOWED
    registration.ensure_registered()
    scene = bpy.context.scene
    scene.snell.use_cycles_settings = True       # the panel shows while Snell follows Cycles
    context = types.SimpleNamespace(scene=scene, engine="SNELL")
    assert ui.RENDER_PT_snell_overrides.poll(context)
    layout = draw(ui.RENDER_PT_snell_overrides, context)
    assert layout.enums == [f.name.upper() for f in FOLLOWED]
    assert layout.props == [f.name for f in FOLLOWED]


@pytest.mark.parametrize("follow", [True, False])
def test_the_viewport_panel_draws_its_denoise_settings(follow):
    """Sampling > Viewport: the samples, and Denoise with its passes, prefilter, quality and
    start sample, from Cycles' properties while Snell follows them, else from Snell's."""
    registration.ensure_registered()
    scene = bpy.context.scene
    scene.snell.use_cycles_settings = follow
    drawn = draw(ui.RENDER_PT_snell_sampling_viewport,
                 types.SimpleNamespace(scene=scene, engine="SNELL")).props
    scene.snell.use_cycles_settings = True
    names = ui.VIEWPORT_DENOISE_CYCLES if follow else ui.VIEWPORT_DENOISE_SNELL
    assert drawn[-5:] == list(names)
