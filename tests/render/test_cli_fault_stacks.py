"""A fatal signal in a render thread ends `snell render` with the Python stacks of all threads
under a line naming the command (faults.py; issue 31, item 9); a closed standard stream is
opened on /dev/null; Ctrl-C while the command starts is exit 130, not a traceback."""
import os
import resource
import signal
import subprocess
import sys

import pytest

from snell.faults import header
from snell.tracer.scene import save
from support.builders import tiny_scene
from support.paths import SUPPORT

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals and file descriptors")


def no_core():
    # The aborts are on purpose: no core file in the test's directory.
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def run_hooked(*args, cwd):
    """snell ARGS through tests/support/fault_hook.py (os.abort() in a render thread)."""
    return subprocess.run([sys.executable, os.path.join(SUPPORT, "fault_hook.py"),
                           *map(str, args)], capture_output=True, text=True, timeout=600,
                          cwd=cwd, preexec_fn=no_core)


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "tiny.snell"
    save(tiny_scene(), str(path))
    return path


def test_an_abort_in_a_render_thread_prints_every_threads_stack(tmp_path, scene_file):
    out = tmp_path / "out.exr"
    proc = run_hooked("render", scene_file, "-o", out, "--threads", "2", cwd=tmp_path)
    assert proc.returncode == -signal.SIGABRT, proc.stderr
    lines = proc.stderr.splitlines()
    assert header("render") in lines, proc.stderr
    stacks = "\n".join(lines[lines.index(header("render")):])
    assert "Fatal Python error: Aborted" in stacks
    assert "in trace_chunk" in stacks        # the worker that aborted
    assert "in cmd_render" in stacks         # the main thread, waiting for it
    assert stacks.count("Thread 0x") + stacks.count("Current thread 0x") >= 2
    assert not out.exists()


def test_a_render_that_ends_well_writes_no_stacks(tmp_path, scene_file):
    proc = subprocess.run([sys.executable, "-m", "snell.cli", "render", str(scene_file), "-o",
                           str(tmp_path / "out.exr"), "--spp", "4"], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "Fatal Python error" not in proc.stderr and "crashed" not in proc.stderr


def test_closed_standard_descriptors_are_opened_on_dev_null():
    """A closed descriptor 1 would be the next file opened (an image being written) and take
    Blender's console lines; main() opens /dev/null there first."""
    check = ("import os, sys; from snell import cli; cli._open_standard_descriptors(); "
             "f = os.open(os.devnull, os.O_RDONLY); "
             "sys.stderr.write(f'{f} {os.readlink(\"/proc/self/fd/1\")}')")
    proc = subprocess.run([sys.executable, "-c", check], stderr=subprocess.PIPE, text=True,
                          timeout=120, preexec_fn=lambda: os.close(1))
    assert proc.returncode == 0, proc.stderr
    fd, target = proc.stderr.split()
    assert int(fd) > 2 and target == os.devnull


# Sends itself Ctrl-C while cli.py imports the validator's commands (its last import), then
# runs `snell` as `python -m snell.cli` does.
CTRL_C_AT_IMPORT = """
import importlib.abc, os, runpy, signal, sys
class Trip(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "snell.validation.commands":
            os.kill(os.getpid(), signal.SIGINT)
        return None
sys.meta_path.insert(0, Trip())
sys.argv = ["snell", "info", sys.argv[1]]
runpy.run_module("snell.cli", run_name="__main__")
"""


def test_ctrl_c_while_the_command_starts_exits_130_without_a_traceback(scene_file):
    proc = subprocess.run([sys.executable, "-c", CTRL_C_AT_IMPORT, str(scene_file)],
                          capture_output=True, text=True, timeout=120,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr == "snell: interrupted\n"
