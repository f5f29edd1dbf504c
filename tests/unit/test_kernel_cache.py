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


def _cache_file(folder):
    """One process's view of a function's cache file in folder (as Snell's kernels have)."""
    from numba.core import caching
    return jit.KeyedCacheFile(caching.IndexDataCacheFile(
        cache_path=str(folder), filename_base="kernel-10.py311", source_stamp="sources"))


def _save_inside(first, step, second, key, data):
    """Run second.save(key, data), as another process would, in the middle of first's `step`
    (its _save_index or _save_data), and with the index as it was before first saved."""
    stale = second._load_index()
    second._load_index = lambda: dict(stale)
    original = getattr(first, step)

    def interleaved(*args):
        second.save(key, data)
        return original(*args)
    setattr(first, step, interleaved)


def test_two_processes_saving_two_signatures_at_once_keep_their_own_code(tmp_path):
    """Two renders compiling one kernel for two signatures into a fresh cache: whatever the
    interleaving, a signature loads its own machine code or none (compiled again), never the
    other's. Numba's own save numbered both data files 1 and wrote the index first: with the
    second process's save inside the first's data write, the index named file 1 for float64
    and file 1 held the int32 code (a kernel loaded for the wrong argument types)."""
    for n, step in enumerate(("_save_data", "_save_index")):
        folder = tmp_path / str(n)
        folder.mkdir()
        a, b = _cache_file(folder), _cache_file(folder)
        _save_inside(a, step, b, "float64", "code for float64")
        a.save("int32", "code for int32")
        fresh = _cache_file(folder)
        for key in ("float64", "int32"):
            assert fresh.load(key) in (None, f"code for {key}"), (step, key)
        assert fresh.load("float64") == "code for float64" or fresh.load("int32") == \
            "code for int32"
