"""Run `snell` with a pause at one stage, so that a test can send Ctrl-C (SIGINT) right there.

    python interrupt_hook.py STAGE MARKER snell-arguments...

At STAGE (export, build, render, cycles, write) the child creates the file MARKER and sleeps; the
test waits for MARKER, sends SIGINT and checks the exit status and that nothing partial is left.
Only the pause is added: the command runs through snell.cli.main as `snell` does.

- export: after Blender opened the .blend, before the depsgraph is converted;
- build: before the Embree BVH is built;
- render: after the first of several passes, with samples still to render;
- cycles: before a Cycles render (compare, study);
- write: inside an atomic write, with the temporary file or directory already written and not
  yet renamed into place.
"""
from __future__ import annotations

import functools
import os
import sys
import time


def _pause(marker):
    with open(marker, "w") as f:
        f.write(str(os.getpid()))
    for _ in range(2400):
        time.sleep(0.05)  # SIGINT raises KeyboardInterrupt here ...
        final = sys.modules.get("snell.addon.final")
        stop = getattr(final, "stop_requested", None)
        if stop is not None and stop.is_set():
            return        # ... or, inside `snell batch`'s render, asks the engine to stop
    raise SystemExit("interrupt_hook: no SIGINT arrived")


def _before(owner, name, marker):
    original = getattr(owner, name)

    @functools.wraps(original)
    def wrapper(*args, **kwargs):
        _pause(marker)
        return original(*args, **kwargs)
    setattr(owner, name, wrapper)


def install(stage, marker):
    if stage == "export":
        from snell.addon import export
        from snell.addon.export import depsgraph
        _before(depsgraph, "export_depsgraph", marker)           # what export_blend calls
        export.export_depsgraph = depsgraph.export_depsgraph     # what the engine imports
    elif stage == "build":
        from snell.tracer import integrator
        _before(integrator, "Geometry", marker)
    elif stage == "cycles":
        from snell.validation import cycles
        _before(cycles, "_render_one", marker)
    elif stage == "render":
        from snell.tracer import integrator
        original = integrator.Renderer.render

        def render(self, progress=None, stop=None):
            def paused(result, done, total):
                if done < total:
                    _pause(marker)
                return progress(result, done, total) if progress else True
            return original(self, progress=paused, stop=stop)
        integrator.Renderer.render = render
    elif stage == "write":
        for name in ("replace", "rename"):
            original = getattr(os, name)

            def moved(src, dst, *args, _original=original, **kwargs):
                # Only the atomic writers' temporaries (".NAME.XXXX.tmp..."), not Blender's.
                if os.path.basename(os.fspath(src)).startswith(".") and ".tmp" in os.fspath(src):
                    _pause(marker)
                return _original(src, dst, *args, **kwargs)
            setattr(os, name, moved)
    else:
        raise SystemExit(f"interrupt_hook: unknown stage {stage!r}")


if __name__ == "__main__":
    install(sys.argv[1], sys.argv[2])
    from snell.cli import main
    sys.exit(main(sys.argv[3:]))
