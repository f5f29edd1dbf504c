"""The kernel cache is found by the tracer's sources, not by where its files are: a cache
compiled by one copy of the tracer serves another copy of the same sources with other paths and
timestamps (as a cache compiled before packaging would serve an installation)."""
import os
import shutil
import subprocess
import sys

from snell.tracer import jit

TREE = os.path.dirname(jit.TRACER_DIR)

# Compiles (or loads) one small kernel and prints the seconds spent compiling it.
PROBE = """
import sys
from snell.tracer import fresnel, jit
fresnel.fresnel_dielectric(0.5, 1.5)
if "--mark" in sys.argv:
    jit.mark_warm()
print(jit.compile_seconds(), jit.cache_dir())
"""


def _copy_tracer(root):
    """A package `snell` under root holding a copy of the tracer, every file newly written."""
    package = os.path.join(root, "snell")
    shutil.copytree(jit.TRACER_DIR, os.path.join(package, "tracer"),
                    ignore=shutil.ignore_patterns("__pycache__", "data"))
    open(os.path.join(package, "__init__.py"), "w").close()
    return root


def _probe(root, cache, *args, cpu=None):
    env = dict(os.environ, PYTHONPATH=root, SNELL_KERNEL_CACHE=cache)
    env.pop("NUMBA_CPU_NAME", None)
    env.pop("NUMBA_CPU_FEATURES", None)
    if cpu:
        env["NUMBA_CPU_NAME"] = cpu
    out = subprocess.run([sys.executable, "-c", PROBE, *args], env=env, cwd=root,
                         capture_output=True, text=True, check=True).stdout.split()
    return float(out[0]), out[1]


def test_a_second_copy_of_the_sources_loads_the_first_copys_kernels(tmp_path):
    """Compiled in copy A, loaded in copy B (another path, later timestamps): B compiles
    nothing. With Numba's own locator (path and timestamp) B compiled the kernel again (0.20 s)."""
    cache = str(tmp_path / "cache")
    first, dir_a = _probe(_copy_tracer(str(tmp_path / "a")), cache)
    second, dir_b = _probe(_copy_tracer(str(tmp_path / "b")), cache)
    assert first > 0.0 and dir_a == dir_b
    assert second == 0.0


def test_other_sources_get_another_cache(tmp_path):
    """An edit to any tracer file is another sources hash, so another cache directory: a stale
    kernel is never loaded."""
    cache = str(tmp_path / "cache")
    _, dir_a = _probe(_copy_tracer(str(tmp_path / "a")), cache)
    root = _copy_tracer(str(tmp_path / "b"))
    with open(os.path.join(root, "snell", "tracer", "vec.py"), "a") as f:
        f.write("\n# edited\n")
    compiled, dir_b = _probe(root, cache)
    assert dir_b != dir_a and compiled > 0.0


def test_a_cache_shipped_in_the_tracer_seeds_an_empty_user_cache(tmp_path):
    """A cache compiled into a copy's tracer/data/kernels (as build_extension puts it in the
    zip) is copied into an empty user cache on first use: the first call compiles nothing.
    Without the copy (_seed_from_shipped returning at once) it compiled: 0.89 s."""
    root = _copy_tracer(str(tmp_path / "a"))
    shipped = os.path.join(root, "snell", "tracer", "data", "kernels")
    _, built = _probe(root, shipped, "--mark", cpu="generic")     # as build_kernel_cache does
    user = str(tmp_path / "user")
    compiled, used = _probe(root, user)         # the generic CPU, chosen for the shipped cache
    assert os.path.basename(used) == os.path.basename(built)
    assert used.startswith(user) and compiled == 0.0
    assert os.path.isfile(os.path.join(used, "warm-snell"))


def test_without_a_shipped_cache_kernels_are_compiled_for_this_cpu():
    """The generic CPU only where it saves a compile: a checkout compiles for its machine."""
    assert not os.path.isdir(jit.shipped_cache_dir())
    assert jit.TARGET[1:] != jit.GENERIC_CPU and jit.TARGET[1] and jit.TARGET[2]
