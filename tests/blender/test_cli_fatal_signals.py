"""`snell compare` on a fatal signal: the Python stacks of all threads on stderr and in the
report's directory (faults.py; issue 31, item 9); with stdout closed it still works; Ctrl-C
while Blender starts ends the command (exit 130), not the process (SIGSEGV), and while Blender
opens the file it is not lost in a load handler."""
import os
import resource
import signal
import subprocess
import sys

import pytest

from snell.faults import FAULT_FILE, header
from support.paths import SUPPORT

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals and file descriptors")


def no_core():
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def compare_argv(blend, report):
    return ["compare", str(blend), "--report", str(report), "--spp", "16", "--cycles-seeds",
            "2", "--quiet"]


def test_an_abort_in_compare_leaves_the_stacks_in_the_report(blender_scenes, tmp_path):
    report = tmp_path / "report"
    proc = subprocess.run([sys.executable, os.path.join(SUPPORT, "fault_hook.py"),
                           *compare_argv(blender_scenes / "cornell.blend", report)],
                          capture_output=True, text=True, timeout=600, preexec_fn=no_core)
    assert proc.returncode == -signal.SIGABRT, proc.stderr
    assert header("compare") in proc.stderr
    saved = (report / FAULT_FILE).read_text()
    assert saved.splitlines()[0] == header("compare")
    for text in ("Fatal Python error: Aborted", "in trace_chunk", "in cmd_compare"):
        assert text in saved and text in proc.stderr
    assert not (report / "report.html").exists()


def test_compare_with_stdout_closed(blender_scenes, tmp_path):
    # Before: sys.stdout is None and the console silencer's flush raised AttributeError.
    report = tmp_path / "report"
    proc = subprocess.run([sys.executable, "-m", "snell.cli",
                           *compare_argv(blender_scenes / "cornell.blend", report)],
                          stdout=None, stderr=subprocess.PIPE, text=True, timeout=600,
                          preexec_fn=lambda: os.close(1))
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert (report / "report.html").is_file()
    assert not (report / FAULT_FILE).exists()


# Ctrl-C while Blender starts: the script sends itself SIGINT when Blender's start-up imports
# _bpy_types (inside the first `import bpy`, and only there), then runs `snell info FILE.blend`
# as `snell` does.
CTRL_C_IN_BLENDER_START = """
import importlib.abc, os, signal, sys
class Trip(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "_bpy_types":
            sys.stderr.write("sending SIGINT\\n")
            os.kill(os.getpid(), signal.SIGINT)
        return None
sys.meta_path.insert(0, Trip())
from snell.cli import main
sys.exit(main(["info", sys.argv[1]]))
"""


def test_ctrl_c_while_blender_starts_exits_130(blender_scenes):
    """Before: SIGSEGV (exit -11) in Blender's BPy_init_modules, every time."""
    proc = subprocess.run([sys.executable, "-c", CTRL_C_IN_BLENDER_START,
                           str(blender_scenes / "cornell.blend")], capture_output=True, text=True,
                          timeout=300, preexec_fn=lambda: (no_core(), signal.signal(
                              signal.SIGINT, signal.SIG_DFL)))
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr.strip().splitlines() == ["sending SIGINT", "snell: interrupted"]
    assert "Traceback" not in proc.stderr and "Fatal Python error" not in proc.stderr


# Ctrl-C inside a handler Blender runs while it opens the file (as Cycles' version_update is):
# a persistent load_pre handler sends SIGINT, then `snell info FILE.blend` runs.
CTRL_C_IN_LOAD_HANDLER = """
import os, signal, sys
import bpy
@bpy.app.handlers.persistent
def interrupt(*args):
    sys.stderr.write("sending SIGINT\\n")
    os.kill(os.getpid(), signal.SIGINT)
bpy.app.handlers.load_pre.append(interrupt)
from snell.cli import main
sys.exit(main(["info", sys.argv[1]]))
"""


def test_ctrl_c_while_blender_opens_the_file_stops_the_command(blender_scenes):
    """Before: Blender printed the handler's KeyboardInterrupt traceback, dropped the handler's
    work and went on, and the command ended with exit 0."""
    proc = subprocess.run([sys.executable, "-c", CTRL_C_IN_LOAD_HANDLER,
                           str(blender_scenes / "cornell.blend")], capture_output=True, text=True,
                          timeout=300, preexec_fn=lambda: signal.signal(signal.SIGINT,
                                                                        signal.SIG_DFL))
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr.strip().splitlines() == ["sending SIGINT", "snell: interrupted"]


# Ctrl-C inside the Python a Cycles render runs: a persistent render_pre handler sends SIGINT
# (compare's Cycles renders are the only bpy.ops.render.render calls), then `snell compare`.
CTRL_C_IN_CYCLES_RENDER = """
import os, signal, sys
import bpy
@bpy.app.handlers.persistent
def interrupt(*args):
    os.kill(os.getpid(), signal.SIGINT)
bpy.app.handlers.render_pre.append(interrupt)
from snell.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_ctrl_c_in_a_cycles_render_stops_compare(blender_scenes, tmp_path):
    """Before: Blender printed the KeyboardInterrupt, the render went on and compare wrote its
    report and ended with exit 0."""
    report = tmp_path / "report"
    proc = subprocess.run([sys.executable, "-c", CTRL_C_IN_CYCLES_RENDER,
                           *compare_argv(blender_scenes / "cornell.blend", report)],
                          capture_output=True, text=True, timeout=600,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr.strip().splitlines() == ["snell: interrupted"]
    assert not report.exists()
