"""The packaged extension: build the zips, install one into a throw-away user extension repository
through the bpy module, enable it as Blender does, render the default scene with F12's operator
and compare with `snell render`; import every module the zip ships; then disable, check Blender
is clean, and enable again."""
import json
import os
import subprocess
import sys
import textwrap
import zipfile

import numpy as np
import pytest

pytest.importorskip("bpy")
oiio = pytest.importorskip("OpenImageIO")

from support.paths import ROOT  # noqa: E402

# Runs in a fresh process whose Blender user resources are a temporary directory.
INSTALL_AND_RENDER = textwrap.dedent('''
    import importlib, importlib.machinery, json, os, sys
    zip_path, blend, exr, ext_root, shipped = sys.argv[1:6]

    class BundledWheelsOnly:
        """Import embreex, numba and llvmlite only from the extension's own site-packages (the
        wheels it bundles)."""
        def find_spec(self, name, path=None, target=None):
            if name not in ("embreex", "numba", "llvmlite"):
                return None
            local = [p for p in sys.path if p.startswith(ext_root)]
            spec = importlib.machinery.PathFinder.find_spec(name, local)
            if spec is None:
                raise ImportError(f"{name} is not in the extension's site-packages {local}")
            return spec
    sys.meta_path.insert(0, BundledWheelsOnly())

    import bpy, addon_utils
    out = {}
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                             enable_on_install=True)
    module = "bl_ext.user_default.snell"
    out["enabled"] = module in bpy.context.preferences.addons
    bpy.ops.wm.open_mainfile(filepath=blend)
    scene = bpy.context.scene
    scene.render.engine = "SNELL"
    scene.snell.seed = 7
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGB"
    scene.render.filepath = exr
    import time
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    out["first_render_s"] = time.perf_counter() - start
    import embreex, numba, llvmlite
    out["wheels"] = [embreex.__file__, numba.__file__, llvmlite.__file__]
    out["kernel_cache"] = sys.modules[module + ".tracer.jit"].cache_dir()
    out["kernels_compiled_s"] = sys.modules[module + ".addon.final"].last_render["kernels_compiled_s"]
    out["snell_module"] = sys.modules[module].__file__
    # Every module the zip ships imports inside Blender (the render above imports only some).
    out["import_failures"] = {}
    for name in json.loads(shipped):
        try:
            importlib.import_module(".".join([module] + ([name] if name else [])))
        except Exception as exc:
            out["import_failures"][name] = f"{type(exc).__name__}: {exc}"

    def traces():
        panels = sorted(n for n in dir(bpy.types)
                        if "SNELL" in (getattr(getattr(bpy.types, n), "COMPAT_ENGINES", None) or ()))
        names = sorted(n for n in dir(bpy.types) if "snell" in n.lower())
        return panels, names, hasattr(bpy.types.Scene, "snell")

    out["enabled_traces"] = traces()
    addon_utils.disable(module, default_set=True)
    out["disabled_traces"] = traces()
    try:
        scene.render.engine = "SNELL"
        out["engine_after_disable"] = True
    except TypeError:
        out["engine_after_disable"] = False
    addon_utils.enable(module, default_set=True)
    scene.render.engine = "SNELL"
    out["reenabled_traces"] = traces()
    out["engine_after_reenable"] = scene.render.engine
    print("RESULT " + json.dumps(out))
''')


def shipped_modules(zip_path) -> list:
    """The dotted names (below the extension's package; "" for its __init__) of the .py files in
    the zip."""
    names = []
    for n in zipfile.ZipFile(zip_path).namelist():
        if n.endswith(".py"):
            parts = n[:-3].split("/")
            names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return sorted(names)


def build(out, *options, timeout=600):
    proc = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "build_extension.py"),
                           "--output-dir", str(out), *options], capture_output=True, text=True,
                          timeout=timeout)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The zips without compiled kernels (compiling them takes minutes)."""
    return build(tmp_path_factory.mktemp("dist"), "--no-kernels")


@pytest.fixture(scope="module")
def built_with_kernels(tmp_path_factory):
    """The zips as released: this platform's carries the compiled kernels."""
    # A whole cold compile: about 3 minutes idle, over 10 on a loaded machine.
    return build(tmp_path_factory.mktemp("dist"), timeout=2400)


def test_build_makes_one_zip_per_platform_with_its_wheels(built):
    zips = sorted(p.name for p in built.glob("*.zip"))
    assert zips == ["snell-0.1.0-linux_x64.zip", "snell-0.1.0-macos_arm64.zip",
                    "snell-0.1.0-macos_x64.zip", "snell-0.1.0-windows_x64.zip"]
    tags = {"linux_x64": "manylinux", "windows_x64": "win_amd64", "macos_arm64": "_arm64",
            "macos_x64": "_x86_64"}
    for name in zips:
        names = zipfile.ZipFile(built / name).namelist()
        wheels = [n for n in names if n.endswith(".whl")]
        platform = name[len("snell-0.1.0-"):-4]
        assert all(tags[platform] in w for w in wheels), wheels
        if platform.startswith("macos"):
            assert all("macosx" in w for w in wheels), wheels
        # Embree and the kernels' compiler, for Blender's Python 3.11 and 3.13.
        assert sorted((os.path.basename(w).split("-")[0], w.split("-")[-3]) for w in wheels) == [
            (package, py) for package in ("embreex", "llvmlite", "numba") for py in ("cp311", "cp313")]
        assert "__init__.py" in names and "addon/engine.py" in names and "tracer/integrator.py" in names
        assert "tracer/data/microfacet_tables.npz" in names
        assert not [n for n in names if n.startswith("tracer/data/kernels/")]   # --no-kernels
        assert not [n for n in names if n.startswith(("tests/", "scenes/", "docs/", "tools/", ".venv/",
                                                      ".git", "dist/"))
                    or "__pycache__" in n or n.endswith(".blend")]
        assert not [n for n in names if "numpy" in n.lower()]
        # The extension is addon/, tracer/, farm/ (F12 on a Dask cluster), errors.py and
        # __init__.py: not the command line nor what only it runs (the validator, snell stress,
        # their pages), which Blender cannot import.
        assert not [n for n in names if n.startswith(("validation/", "stress/", "pages/", "compare/"))
                    or n == "cli.py"]
        assert {m for m in shipped_modules(built / name) if "." not in m} == {
            "", "addon", "errors", "farm", "tracer"}
        # Everything in addon/ ships.
        addon = sorted(os.path.relpath(os.path.join(d, f), ROOT).replace(os.sep, "/")
                       for d, _, files in os.walk(os.path.join(ROOT, "addon")) if "__pycache__" not in d
                       for f in files if f.endswith(".py"))
        assert sorted(n for n in names if n.startswith("addon/") and n.endswith(".py")) == addon


# Slow: building the zips compiles every kernel (3 minutes idle).
@pytest.mark.slow
def test_installed_extension_renders_like_snell_render(built_with_kernels, tmp_path,
                                                       blender_scenes):
    """Installed from the released zip into a fresh Blender user directory, the first F12
    compiles nothing: the zip's kernels are copied into the extension's user directory. (Built
    --no-kernels, the same render compiled for 3 minutes: kernels_compiled_s 180 s.)"""
    from snell.tracer import jit
    blends = blender_scenes
    blend = blends / "cornell.blend"
    resources = tmp_path / "blender_user"
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(resources))
    ext_root = str(resources / "extensions")
    zip_path = built_with_kernels / "snell-0.1.0-linux_x64.zip"
    key = jit.cache_key_for(jit.generic_target())
    assert f"tracer/data/kernels/{key}/warm-bl_ext.user_default.snell" in \
        zipfile.ZipFile(zip_path).namelist()
    shipped = shipped_modules(zip_path)
    proc = subprocess.run([sys.executable, "-c", INSTALL_AND_RENDER, str(zip_path),
                           str(blend), str(tmp_path / "engine.exr"), ext_root, json.dumps(shipped)],
                          capture_output=True, text=True, timeout=600, env=env, cwd=tmp_path)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = json.loads(lines[-1][len("RESULT "):])
    assert out["enabled"]
    assert out["snell_module"].startswith(ext_root)
    assert "addon.batch" in shipped and "tracer.integrator" in shipped and "errors" in shipped
    assert out["import_failures"] == {}
    assert all(path.startswith(ext_root) for path in out["wheels"])   # the bundled wheels
    # The kernel cache is in the extension's user directory, filled from the zip before the
    # first render, which found every kernel compiled.
    assert out["kernel_cache"].startswith(str(resources / "extensions" / ".user"))
    assert os.path.basename(out["kernel_cache"]) == key
    assert out["kernels_compiled_s"] is None, out
    print(f"first F12 after installing: {out['first_render_s']:.1f} s")
    panels, names, has_prop = out["enabled_traces"]
    assert "DATA_PT_lens" in panels and names and has_prop
    assert out["disabled_traces"] == [[], [], False]
    assert out["engine_after_disable"] is False
    assert out["reenabled_traces"] == out["enabled_traces"]
    assert out["engine_after_reenable"] == "SNELL"

    ref = tmp_path / "ref.exr"
    proc = subprocess.run([sys.executable, "-m", "snell.cli", "render", str(blend), "-o", str(ref),
                           "--seed", "7", "--quiet"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    engine_img = oiio.ImageBuf(str(tmp_path / "engine.exr")).get_pixels(oiio.FLOAT)[:, :, :3]
    ref_img = oiio.ImageBuf(str(ref)).get_pixels(oiio.FLOAT)[:, :, :3]
    assert engine_img.shape == ref_img.shape == (32, 32, 3)
    np.testing.assert_allclose(engine_img, ref_img, rtol=1e-6, atol=1e-7)
    assert engine_img.mean() > 0.01
