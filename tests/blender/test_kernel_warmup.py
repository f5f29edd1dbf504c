"""The kernels' first compile in a background process (addon/kernel_warmup.py): started once
when Snell becomes the engine, timed for the next estimate, waited for by the first render, and
a failure said with its reason. A stand-in command (a short Python script) plays the compile,
except in the last test, which runs the real command against the warm cache."""
import subprocess
import sys

import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import final, kernel_warmup  # noqa: E402
from snell.tracer import jit  # noqa: E402


@pytest.fixture
def fake(monkeypatch, tmp_path):
    """A background compile played by a script that sleeps, then writes its marker (or fails),
    with the timings kept beside a cache in tmp_path."""
    marker = tmp_path / "compiled"
    state = {"exit": 0, "sleep": 0.6}
    monkeypatch.setattr(jit, "cache_dir", lambda: str(tmp_path / "cache" / "hash"))
    monkeypatch.setattr(kernel_warmup, "_in_background", lambda: False)
    monkeypatch.setattr(kernel_warmup, "_compiled", marker.exists)

    def command():
        code = (f"import sys, time; time.sleep({state['sleep']}); "
                f"sys.exit('no llvmlite here') if {state['exit']} else "
                f"open({str(marker)!r}, 'w').close()")
        return [sys.executable, "-c", code]

    monkeypatch.setattr(kernel_warmup, "_command", command)
    yield state
    if kernel_warmup._process is not None:
        kernel_warmup._process.wait()
        kernel_warmup.finish()


def test_a_background_compile_starts_once_and_the_render_waits_for_it(fake):
    assert kernel_warmup.start() and kernel_warmup.running()
    first = kernel_warmup._process
    assert kernel_warmup.start() and kernel_warmup._process is first     # not a second one
    assert "compiling kernels" in kernel_warmup.status() and "left" in kernel_warmup.status()
    seen = []
    assert kernel_warmup.wait(lambda status: seen.append(status), interval=0.05)
    assert seen and not kernel_warmup.running() and kernel_warmup.status() == ""
    # Its time is the next estimate; compiled kernels start nothing more.
    assert 0.5 < kernel_warmup.estimate() < 30.0
    assert not kernel_warmup.start()


def test_a_cancelled_render_stops_waiting_and_the_compile_goes_on(fake):
    fake["sleep"] = 2.0
    kernel_warmup.start()
    assert not kernel_warmup.wait(lambda status: False, interval=0.05)
    assert kernel_warmup.running()


def test_a_failed_compile_says_why_and_the_render_compiles_itself(fake, capsys):
    fake["exit"] = 1
    kernel_warmup.start()
    assert not kernel_warmup.wait(lambda status: True, interval=0.05)
    err = capsys.readouterr().err
    assert "background compile failed (no llvmlite here, exit status 1)" in err
    assert kernel_warmup.estimate() == kernel_warmup.DEFAULT_ESTIMATE_S


def test_nothing_starts_in_background_mode(fake, monkeypatch):
    monkeypatch.setattr(kernel_warmup, "_in_background", lambda: True)
    assert not kernel_warmup.start() and not kernel_warmup.running()


def test_choosing_snell_starts_the_compile(monkeypatch):
    calls = []
    monkeypatch.setattr(kernel_warmup, "start", lambda: calls.append(1) or False)
    from snell.addon import registration
    bpy.ops.wm.read_factory_settings(use_empty=True)
    registration.ensure_registered()
    bpy.context.scene.render.engine = "CYCLES"
    kernel_warmup._engine_chosen()
    assert calls == []
    bpy.context.scene.render.engine = "SNELL"
    kernel_warmup._engine_chosen()
    assert calls == [1]


def test_f12_cancelled_while_waiting_renders_nothing(fake, monkeypatch):
    """final._compile_kernels during a background compile: shows its status, and returns
    False once the render is cancelled, without compiling in the render's own process."""
    fake["sleep"] = 2.0

    class Engine:
        stats = []

        def update_stats(self, _a, text):
            self.stats.append(text)

    class Integrator:
        @staticmethod
        def kernels_compiled():
            return False

        @staticmethod
        def warm_up():
            pytest.fail("the render compiled while the background compile ran")

    monkeypatch.setattr(final, "_integrator", lambda: Integrator)
    stops = iter([False, True, True, True])
    monkeypatch.setattr(final, "_should_stop", lambda engine: next(stops))
    kernel_warmup.start()
    engine = Engine()
    assert final._compile_kernels(engine, {}) is False
    assert any("compiling kernels" in s for s in engine.stats)


def test_the_real_command_warms_this_copys_cache():
    """The command imports this copy of Snell under this process's package name and fills the
    cache this process reads: another process then loads every kernel from it. (Imported
    under the folder's name, `main`, it wrote cache indexes this name could not read:
    ModuleNotFoundError: No module named 'main' in every later render.)"""
    from snell.tracer import integrator
    integrator.warm_up()
    out = subprocess.run(kernel_warmup._command(), env=kernel_warmup._environment(),
                         capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    again = subprocess.run([sys.executable, "-c", "from snell.tracer import integrator; "
                            "print(integrator.warm_up())"], env=kernel_warmup._environment(),
                           capture_output=True, text=True, timeout=900)
    assert again.returncode == 0, again.stderr[-2000:]
    assert float(again.stdout.split()[-1]) < 60.0      # loaded, not compiled


def test_the_command_imports_an_extension_under_its_blender_name(tmp_path):
    """Inside Blender Snell is bl_ext.<repository>.snell, whose parents exist only there: the
    command makes them, so the process's kernels carry the name Blender's process uses."""
    name, root = kernel_warmup._package()
    repository = tmp_path / "extensions" / "user_default"
    repository.mkdir(parents=True)
    (repository / "snell").symlink_to(root)
    code = kernel_warmup._IMPORT.format(name="bl_ext.user_default.snell",
                                        root=str(repository / "snell"))
    code += 'print(importlib.import_module(name + ".tracer.jit").__file__, end="")'
    out = subprocess.run([sys.executable, "-c", code], env=kernel_warmup._environment(),
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout == str(repository / "snell" / "tracer" / "jit.py")
