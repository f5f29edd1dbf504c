"""The render-settings schema (tracer/settings.py): defaults, ranges, the scene file's render
object, the command-line options and the docs table made from it."""
import os

import pytest

from snell import cli
from snell.tracer.scene import SceneError
from snell.tracer.settings import (BY_NAME, DEFAULT_RENDER, ESTIMATOR, RUN, SCENE, SETTINGS,
                                   VIEWPORT, RenderSettings, markdown_table, of_scope)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_the_defaults_are_the_scene_files_defaults():
    # The scene file's defaults before the schema: files written then render as they did
    # (time_limit 0: no limit; a 1-pixel box, the only filter before pixel filters).
    # (transparent_max_bounces: Cycles' default 8; files before it had no transparent surface)
    # (the limits of each kind and clamping: none, as before; both caustics switches on)
    assert DEFAULT_RENDER == {"spp": 64, "max_depth": 8, "transparent_max_bounces": 8,
                              "diffuse_bounces": 1024, "glossy_bounces": 1024,
                              "transmission_bounces": 1024, "caustics_reflective": True,
                              "caustics_refractive": True, "sample_clamp_direct": 0.0,
                              "sample_clamp_indirect": 0.0,
                              "seed": 0, "fresnel": "exact",
                              "caustics": True, "shadow_caustics": True,  # no file sets flags
                              "light_vertices": True, "noise_threshold": 0.01,
                              "min_spp": 0, "time_limit": 0.0,   # time_limit 0: no limit, as before
                              "pixel_filter": "box", "filter_width": 1.0,
                              "film_exposure": 1.0, "film_transparent": False,  # as before
                              "film_transparent_glass": False,
                              "film_transparent_roughness": 0.1,
                              # no denoising and no denoising passes, as before
                              "denoise": False, "denoising_input_passes": "albedo_normal",
                              "denoising_prefilter": "accurate", "denoising_quality": "high",
                              "denoising_passes": False}
    assert RenderSettings().to_render() == DEFAULT_RENDER
    assert all(getattr(RenderSettings(), s.name) == s.default for s in SETTINGS)


def bad_values(setting):
    """Values the setting must refuse: out of its range, of another type, not a choice."""
    if setting.type is bool:
        return [1, "true", None]
    if setting.type is str:
        return ["nonsense", 0, None]
    bad = ["1", None, True]
    bad.append(setting.least if setting.least_excluded else setting.least - 1)
    if setting.greatest is not None:
        bad.append(setting.greatest + 1)
    if setting.type is float:
        bad += [float("nan"), float("inf")]
    else:
        bad.append(float(setting.default) + 0.5)
    return bad


@pytest.mark.parametrize("setting", SETTINGS, ids=lambda s: s.name)
def test_every_setting_refuses_what_is_out_of_its_range_naming_itself(setting):
    for value in bad_values(setting):
        with pytest.raises(SceneError, match=f"^render.{setting.name}: "):
            RenderSettings().replace(**{setting.name: value})
    assert getattr(RenderSettings().replace(**{setting.name: setting.default}),
                   setting.name) == setting.default


def test_the_render_object_round_trips_and_old_files_load():
    settings = RenderSettings.from_render({"spp": 9, "fresnel": "schlick", "unknown": 1},
                                          threads=3)
    assert settings.to_render() == {**DEFAULT_RENDER, "spp": 9, "fresnel": "schlick"}
    assert settings.threads == 3 and settings.render_threads == 3
    assert RenderSettings.from_render({}) == RenderSettings()       # a file before them all
    assert RenderSettings().render_threads == 2
    with pytest.raises(SceneError, match="render: expected an object"):
        RenderSettings.from_render([])
    with pytest.raises(SceneError, match="render.sppp: not a render setting"):
        RenderSettings().replace(sppp=4)
    with pytest.raises(AttributeError):
        RenderSettings().spp = 3                                       # frozen


def test_every_setting_has_a_scope_a_doc_line_and_the_right_kind_of_range():
    for s in SETTINGS:
        assert s.scope in (SCENE, RUN, VIEWPORT, ESTIMATOR) and s.doc and "\n" not in s.doc
        assert (s.type is str) == bool(s.choices), s.name
        assert (s.type in (int, float)) == (s.least is not None), s.name


def parser_options(command):
    """{dest: argparse action} of a subcommand's options."""
    sub = next(a for a in cli.build_parser()._actions if a.dest == "command")
    return {a.dest: a for a in sub.choices[command]._actions}


@pytest.mark.parametrize("command", ["render", "batch"])
def test_the_command_line_options_are_the_schemas(command):
    options = parser_options(command)
    for s in of_scope(SCENE, RUN):
        action = options[s.name]
        assert action.option_strings == [s.option]
        assert action.help.startswith(s.doc[0].lower() + s.doc[1:])
        if s.type is bool:
            assert action.choices == ("on", "off")
        elif s.type is str:
            assert tuple(action.choices) == s.values
        else:
            assert action.type(str(s.least + (1 if s.least_excluded else 0))) is not None
    for s in of_scope(VIEWPORT, ESTIMATOR):
        assert s.name not in options


def test_command_line_values_become_settings():
    args = cli.build_parser().parse_args(
        ["render", "x.snell", "-o", "x.exr", "--caustics", "off", "--spp", "3", "--fresnel",
         "schlick", "--threads", "1"])
    assert cli.setting_overrides(args) == {"caustics": False, "spp": 3, "fresnel": "schlick",
                                           "threads": 1}


def test_the_docs_table_is_the_schemas():
    """docs/scene-format.md holds markdown_table()'s output: regenerate it when SETTINGS change."""
    with open(os.path.join(ROOT, "docs", "scene-format.md"), encoding="utf-8") as f:
        page = f.read()
    assert markdown_table() in page
    assert all(f"| `{name}` |" in markdown_table() for name in BY_NAME)
