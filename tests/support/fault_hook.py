"""Run `snell` with a deliberate os.abort() in one of the render's worker threads.

    python fault_hook.py snell-arguments...

The first chunk a Snell worker thread traces calls os.abort() instead: SIGABRT from a thread
that is not the main one, as the issue 31 aborts were (a library's thread, not Python's main
loop). The command runs through snell.cli.main as `snell` does, so what its fault handler
writes is what a user would see.
"""
from __future__ import annotations

import os
import sys
import threading


def install():
    from snell.tracer import integrator

    def trace_chunk(self, *args, **kwargs):
        if threading.current_thread() is not threading.main_thread():
            os.abort()
        raise SystemExit("fault_hook: a chunk traced on the main thread")
    integrator.Renderer.trace_chunk = trace_chunk


if __name__ == "__main__":
    install()
    from snell.cli import main
    sys.exit(main(sys.argv[1:]))
