"""The kernels' first compile, in a background process started when Snell becomes a scene's
render engine: Blender's interface never waits on it, the status bar and the terminal show how
long it has run and about how long is left, and the first F12 or viewport render waits only for
what is left (wait).

The process imports this copy of Snell and runs integrator.warm_up into the same kernel cache
(jit.SourcesLocator keys a cached kernel by its module's name: the same package name, the same
entries), then writes the warm marker that integrator.kernels_compiled reads. An extension built
with its kernels (tools/build_kernel_cache.py) has them from the first use, and starts none.
Not in background mode (`blender
--background`, `snell batch`): there the render compiles what it needs in its own process.
"""
from __future__ import annotations

import os
import subprocess
import sys
import threading
import time

import bpy
from bpy.app.handlers import persistent

from ..tracer import jit

# Seconds the first compile takes on the 2-core development machine: 185 s of CPU, in one
# thread, with the shader-program stages (docs/measurements.md, "Kernel cache: shipped
# compiled"; CPU seconds were within 2% of the idle wall time before), until this machine has
# timed one of its own.
DEFAULT_ESTIMATE_S = 185.0
_TIMING_FILE = "last-compile-seconds"
_LOG_FILE = "background-compile.log"     # the process's stderr (a pipe could fill and block it)

_process: subprocess.Popen | None = None
_started = 0.0
_finishing = threading.Lock()


# The process imports Snell under this process's package name (bl_ext.<repository>.snell inside
# Blender): Numba's cache index pickles the kernels' argument types with their modules' names,
# and an index written under another name cannot be read here. Found on sys.path (an install
# or a checkout) if it is this copy, else its parent packages are made as Blender makes them.
_IMPORT = """
import importlib, os, sys, types
name, root = {name!r}, {root!r}
try:
    found = os.path.dirname(os.path.abspath(importlib.import_module(name).__file__)) == root
except ImportError:
    found = False
if not found:
    for module in [m for m in sys.modules if m == name or m.startswith(name + ".")]:
        del sys.modules[module]
    parts = name.split(".")
    for i in range(1, len(parts)):
        package = types.ModuleType(".".join(parts[:i]))
        package.__path__ = [os.path.normpath(os.path.join(root, *[os.pardir] * (len(parts) - i)))]
        sys.modules[package.__name__] = package
    if len(parts) == 1:
        sys.path.insert(0, os.path.dirname(root))
"""


def _package() -> tuple[str, str]:
    """This copy of Snell: (its package name, its directory)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return __package__.rsplit(".", 1)[0], root


def warm_up_command(name: str, root: str) -> list[str]:
    """The command that compiles every kernel of the Snell in root imported as the package name
    (this Python; the cache is SNELL_KERNEL_CACHE's)."""
    code = _IMPORT.format(name=name, root=root)
    code += 'importlib.import_module(name + ".tracer.integrator").warm_up()\n'
    return [sys.executable, "-c", code]


def _command() -> list[str]:
    return warm_up_command(*_package())


def _environment() -> dict:
    env = dict(os.environ)
    # Blender's own paths (its modules, the extension's wheels: numba, llvmlite, embreex) and
    # the cache this process uses (jit.cache_dir is <base>/<sources hash>).
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["SNELL_KERNEL_CACHE"] = _cache_base()
    return env


def _cache_base() -> str:
    return os.path.dirname(jit.cache_dir())


def _beside_cache(name: str) -> str:
    return os.path.join(_cache_base(), name)


def estimate() -> float:
    """Seconds the whole compile is expected to take (the last one timed here, else the
    default)."""
    try:
        with open(_beside_cache(_TIMING_FILE)) as f:
            return max(1.0, float(f.read()))
    except (OSError, ValueError):
        return DEFAULT_ESTIMATE_S


def running() -> bool:
    """Whether a background compile is under way."""
    return _process is not None and _process.poll() is None


def start() -> bool:
    """Start compiling in the background unless the kernels are compiled, compiling already,
    or Blender runs in background mode; returns whether a compile is under way."""
    global _process, _started
    if running():
        return True
    if _in_background() or _compiled():
        return False
    _started = time.perf_counter()
    os.makedirs(_cache_base(), exist_ok=True)
    with open(_beside_cache(_LOG_FILE), "wb") as log:
        _process = subprocess.Popen(_command(), env=_environment(), stdin=subprocess.DEVNULL,
                                    stdout=subprocess.DEVNULL, stderr=log)
    print(f"Snell: compiling kernels in the background (first run only, about "
          f"{_minutes(estimate())})", file=sys.stderr, flush=True)
    return True


def status() -> str:
    """What the status bar says while the compile runs ('' when none does)."""
    if not running():
        return ""
    took = time.perf_counter() - _started
    left = estimate() - took
    tail = f"about {_minutes(left)} left" if left > 0 else "taking longer than usual"
    return f"Snell: compiling kernels (first run only): {_minutes(took)} so far, {tail}"


def finish() -> str | None:
    """After the process ended: record its time, say how it went (None: no compile ended)."""
    global _process
    with _finishing:       # the status timer and a render's wait may both get here
        if _process is None or _process.poll() is None:
            return None
        process, _process = _process, None
    took = time.perf_counter() - _started
    if process.returncode == 0 and _compiled():
        try:
            with open(_beside_cache(_TIMING_FILE), "w") as f:
                f.write(f"{took:.1f}\n")
        except OSError:
            pass
        message = f"Snell: kernels compiled in {_minutes(took)}"
    else:
        try:
            with open(_beside_cache(_LOG_FILE), errors="replace") as f:
                lines = f.read().strip().splitlines()
        except OSError:
            lines = []
        message = (f"Snell: the background compile failed ({lines[-1] if lines else 'no message'}"
                   f", exit status {process.returncode}); the first render compiles the kernels "
                   f"itself")
    print(message, file=sys.stderr, flush=True)
    return message


def wait(poll, interval: float = 0.5) -> bool:
    """Wait for a background compile to end, calling poll(status()) every interval seconds (it
    returns False to stop waiting: the render was cancelled). Returns whether the kernels are
    compiled now."""
    while running():
        if poll(status()) is False:
            return False
        time.sleep(interval)
    finish()
    return _compiled()


def _in_background() -> bool:
    return bpy.app.background


def _compiled() -> bool:
    # Imported here: the integrator loads Embree and the kernels, which registering Snell
    # must not need.
    from ..tracer import integrator
    return integrator.kernels_compiled()


def _minutes(seconds: float) -> str:
    seconds = max(0, int(round(seconds)))
    if seconds < 60:
        return f"{seconds} s"
    return f"{seconds // 60} min {seconds % 60:02d} s"


# -- when to start: Snell chosen as the engine, a file opened with it ---------------------------

ENGINE = "SNELL"          # engine.SnellRenderEngine.bl_idname
_OWNER = object()         # the message-bus subscription's owner


def _engine_chosen(*_args):
    scene = getattr(bpy.context, "scene", None)
    if scene is not None and scene.render.engine == ENGINE and start():
        if not bpy.app.timers.is_registered(_show_status):
            bpy.app.timers.register(_show_status, first_interval=1.0)


def _show_status():
    """Timer: the status bar's line while the compile runs, then its outcome once."""
    text = status()
    if text:
        _status_bar(text)
        return 1.0
    outcome = finish()        # None once the render's wait took it, or on the next tick
    _status_bar(outcome)
    return 5.0 if outcome else None


def _status_bar(text):
    for window in bpy.context.window_manager.windows:
        window.workspace.status_text_set_internal(text)


def _subscribe():
    bpy.msgbus.subscribe_rna(key=(bpy.types.RenderSettings, "engine"), owner=_OWNER, args=(),
                             notify=_engine_chosen)


@persistent
def _on_load(_file):
    # Opening a file drops every message-bus subscription.
    _subscribe()
    _engine_chosen()


def register():
    """Start a background compile whenever Snell becomes the engine (now, once Blender's
    context is ready, if it already is)."""
    _subscribe()
    bpy.app.handlers.load_post.append(_on_load)
    # register() runs in a restricted context: look at the scene once Blender is ready.
    bpy.app.timers.register(_engine_chosen, first_interval=0.5)


def unregister():
    """Undo register (a compile under way goes on: the cache keeps what it writes)."""
    bpy.msgbus.clear_by_owner(_OWNER)
    if _on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_on_load)
    for timer in (_engine_chosen, _show_status):
        if bpy.app.timers.is_registered(timer):
            bpy.app.timers.unregister(timer)
