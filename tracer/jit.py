"""How Snell's compiled code is compiled: Numba, without the GIL, cached on disk.

Every scalar physics function and every wavefront kernel is decorated with `jit`. Kernels release
the GIL, so chunks of paths run in parallel on the integrator's own thread pool (not Numba's
parallel=True threading layer, which would load its own TBB or OpenMP next to Blender's and
Embree's). error_model="numpy" makes x / 0 give inf or NaN, as numpy does, instead of raising:
the integrator counts non-finite samples and never writes them to an image. Compiled code never
allocates, so Numba's reference counting is off (_nrt=False): with it, every call that passes a
table of arrays to a function LLVM does not inline costs an atomic increment and decrement per
array, which made the materials stage 1.5x slower. A function compiled code calls is compiled
for those callers without the wrappers that let Python call it (Compiled): a dispatcher's
compile makes them for every signature, and unboxing a table of arrays from Python objects is
half a second's compile per function.

The machine code is cached on disk, under a directory named after a hash of the tracer's
sources, the Python version and the CPU compiled for (cache_key): Numba checks only the timestamp of
the file that defines a kernel, so an edit to a
function it calls in another file would otherwise leave a stale kernel in the cache. Inside that
directory a kernel's entry is found by its module's name (SourcesLocator), not by the path and
timestamp of its file as Numba's own locators do: the hash already says the sources are the
same, so a cache compiled in one checkout or installation serves another of the same sources,
and a cache compiled when the extension is built (tools/build_kernel_cache.py) is copied into
the user's cache on first use. That cache is compiled for the architecture's generic CPU, so
that one build serves every machine; Snell compiles for the generic CPU only when such a cache
exists (_choose_target), and otherwise for the machine's own. On the development machine the
generic kernels render the same image bit for bit, at 1.02-1.04x the CPU time (within the
noise; docs/measurements.md, "Kernel cache").
The cache lives under Snell's user cache directory unless set_cache_dir() picks another base
before the first kernel module is imported (inside Blender, the extension's user directory).
compile_seconds() says how long this process has spent compiling, so that a render leaves its
kernels' first compile out of its timings.
"""
from __future__ import annotations

import functools
import hashlib
import os
import shutil
import sys
import threading
import time
import types

import numba
from numba.core import caching as _caching
from numba.core import event

OPTIONS = {"nogil": True, "cache": True, "error_model": "numpy", "_nrt": False}
TRACER_DIR = os.path.dirname(os.path.abspath(__file__))


class Compiled:
    """A function compiled with Snell's options: called from Python, or from compiled code
    (where Numba types it as a dispatcher of its own that makes no Python entry point)."""

    def __init__(self, fn):
        functools.update_wrapper(self, fn)
        self.py_func = fn
        # Made on first use: most functions are only ever called from compiled code, kernels
        # only from Python, and each dispatcher costs the import time to set up its cache.
        self._inner = self._outer = None

    @property
    def _from_compiled(self):
        # Every compile of a dispatcher makes, besides the machine code compiled callers link
        # in, wrappers that unbox each argument from Python objects (for a table of 40 arrays,
        # half a second) and a C entry point. Compiled callers use neither, so their callees
        # are compiled without.
        if self._inner is None:
            with _MAKING:
                if self._inner is None:
                    self._inner = _njit(self.py_func, no_cpython_wrapper=True,
                                        no_cfunc_wrapper=True)
        return self._inner

    @property
    def _from_python(self):
        # Cached under a name of its own: Numba keys a cache entry by the function's name and
        # signature, not by these options, and would load the one without wrappers.
        if self._outer is None:
            with _MAKING:
                if self._outer is None:
                    self._outer = _njit(
                        _renamed(self.py_func, self.py_func.__qualname__ + "_py"))
        return self._outer

    @property
    def _numba_type_(self):
        # What numba.typeof says this object is, where compiled code refers to it.
        return self._from_compiled._numba_type_

    def __call__(self, *args):
        return self._from_python(*args)


_MAKING = threading.Lock()


def _renamed(fn, qualname):
    """A copy of fn under another qualified name."""
    copy = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__,
                              fn.__closure__)
    copy.__qualname__ = qualname
    copy.__kwdefaults__ = fn.__kwdefaults__
    copy.__module__ = fn.__module__
    copy.__doc__ = fn.__doc__
    return copy


def jit(fn):
    """Compile fn with Snell's options (nogil, cached, numpy error model, no reference counting)."""
    return Compiled(fn)


def jit_inline(fn):
    """jit, inlined into every caller by Numba. For functions that take a table of arrays (the
    lights, the mesh, the camera): a call that LLVM does not inline copies every array's
    descriptor, and sample_light alone cost 70 ns more per call that way."""
    return _njit(fn, inline="always")


def _njit(fn, **options):
    """Numba's dispatcher of fn with Snell's options (and these), its disk cache written by
    KeyedCacheFile."""
    dispatcher = numba.njit(**OPTIONS, **options)(fn)
    cache = getattr(dispatcher, "_cache", None)
    if isinstance(getattr(cache, "_cache_file", None), _caching.IndexDataCacheFile):
        cache._cache_file = KeyedCacheFile(cache._cache_file)
    return dispatcher


class KeyedCacheFile(_caching.IndexDataCacheFile):
    """Numba's cache file of one function (an index of its compiled signatures, a data file
    each), saved so that processes compiling at once never give one signature another's code.

    Numba names a new signature's data file with the first number its index does not use,
    and writes the index before the data: two processes saving two signatures of a function
    at once (two renders compiling into a fresh cache; a loaded machine widens the window)
    both took file 1, and the index could name one signature's file holding the other's
    machine code (measured: a float64 kernel loaded for int32 arrays). Here the data file is
    named after the signature's key, so it is one signature's alone, and it is written before
    an index names it. Two indexes written at once can still lose an entry: that signature is
    compiled again."""

    def __init__(self, original: _caching.IndexDataCacheFile):
        self.__dict__.update(original.__dict__)

    def save(self, key, data):
        """Write key's data, then add it to the index."""
        name = self.data_name(key)
        self._save_data(name, data)
        overloads = self._load_index()
        overloads[key] = name
        self._save_index(overloads)

    def data_name(self, key) -> str:
        """The name of key's data file: the index's name and a hash of the key."""
        digest = hashlib.sha256(self._dump(key)).hexdigest()[:16]
        return f"{self._index_name[:-len('.nbi')]}.{digest}.nbc"


@functools.lru_cache(maxsize=None)
def sources_hash() -> str:
    """A short hash of every tracer source file (subpackages included) and the Numba version
    (workers of one render must have the same)."""
    # Read once per process: the cache key, the shipped cache and the farm's check all ask.
    digest = hashlib.sha256(numba.__version__.encode())
    for folder, dirs, files in os.walk(TRACER_DIR):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                digest.update(os.path.relpath(path, TRACER_DIR).encode())
                with open(path, "rb") as f:
                    digest.update(f.read())
    return digest.hexdigest()[:16]


class SourcesLocator(_caching._CacheLocator):
    """Finds the cache entry of a tracer function by its module's name under the sources-hash
    directory, wherever the tracer's files are and whatever their timestamps."""

    def __init__(self, py_func):
        # The module's full name keeps apart the imports of one tree under two names (Blender's
        # bl_ext.<repository>.snell and the command line's snell), whose compiled code differs.
        self._cache_path = os.path.join(numba.config.CACHE_DIR, py_func.__module__)
        self._lineno = py_func.__code__.co_firstlineno

    def get_cache_path(self):
        return self._cache_path

    def get_source_stamp(self):
        # The directory is the sources' hash: every entry in it is of these sources.
        return os.path.basename(numba.config.CACHE_DIR)

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        if not numba.config.CACHE_DIR or not _inside(py_file, TRACER_DIR):
            return None                 # not a tracer function: Numba's own locators
        self = cls(py_func)
        try:
            self.ensure_cache_path()
        except OSError:
            return None
        return self


def _inside(path: str, folder: str) -> bool:
    path = os.path.abspath(path)
    return os.path.commonpath([path, folder]) == folder


if SourcesLocator not in _caching.CacheImpl._locator_classes:
    _caching.CacheImpl._locator_classes.insert(0, SourcesLocator)


GENERIC_CPU = ("generic", "")     # Numba's CPU name and features for the architecture's baseline


def cache_key_for(target: tuple) -> str:
    """The name of the cache directory for these sources and this Python, compiling for target."""
    digest = hashlib.sha256(sources_hash().encode())
    digest.update(f"python {sys.version_info[0]}.{sys.version_info[1]}".encode())
    digest.update(repr(tuple(target)).encode())
    return digest.hexdigest()[:16]


def _shipped(key: str) -> str:
    return os.path.join(TRACER_DIR, "data", "kernels", key)


def generic_target() -> tuple:
    """Numba's target for the generic CPU of this machine's architecture."""
    import llvmlite.binding as llvm
    return (llvm.get_process_triple(), *GENERIC_CPU)


def _choose_target() -> tuple:
    """The target Numba compiles for, (triple, CPU, features): the architecture's generic CPU
    when Snell ships a cache compiled for it (one build serves every machine), else this
    machine's CPU, or the one the user chose (NUMBA_CPU_NAME)."""
    from numba.core.registry import cpu_target
    generic = generic_target()
    chosen = numba.config.CPU_NAME is None and numba.config.CPU_FEATURES is None and \
        os.path.isdir(_shipped(cache_key_for(generic)))
    if chosen:
        numba.config.CPU_NAME, numba.config.CPU_FEATURES = GENERIC_CPU
    target = cpu_target.target_context.codegen().magic_tuple()
    if chosen and tuple(target) != generic:
        # Numba's code generator was made before this module (another add-on compiled first)
        # and stays on its CPU: the cache key says which.
        numba.config.CPU_NAME = numba.config.CPU_FEATURES = None
        target = cpu_target.target_context.codegen().magic_tuple()
    return tuple(target)


TARGET = _choose_target()


def cache_key() -> str:
    """The name of the cache directory for these sources, this Python and the CPU compiled for."""
    return cache_key_for(TARGET)


def default_cache_base() -> str:
    """Snell's user cache directory for compiled kernels ($XDG_CACHE_HOME/snell/kernels)."""
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(root, "snell", "kernels")


def set_cache_dir(base: str) -> str:
    """Cache compiled kernels under base (in a directory per source hash); call before any kernel
    module is imported. Returns the directory."""
    path = os.path.join(base, cache_key())
    numba.config.CACHE_DIR = path
    _seed_from_shipped(path)
    return path


def shipped_cache_dir() -> str:
    """Where a cache compiled before packaging is, for this key (it may not exist)."""
    return _shipped(cache_key())


def _seed_from_shipped(path: str) -> None:
    # A cache compiled when the extension was built is copied, once, into the user's cache
    # (the extension's own folder may be read-only), so that the first render compiles nothing.
    shipped = shipped_cache_dir()
    marker = os.path.basename(_warm_marker())
    if not os.path.isfile(os.path.join(shipped, marker)) or \
            os.path.isfile(os.path.join(path, marker)):
        return
    try:
        shutil.copytree(shipped, path, dirs_exist_ok=True)
    except OSError:
        pass            # a cache it cannot fill: the kernels are compiled as without one


def cache_dir() -> str:
    """Where compiled kernels are cached now."""
    return numba.config.CACHE_DIR


def _warm_marker() -> str:
    # Per package name, as the entries are (SourcesLocator).
    return os.path.join(cache_dir(), f"warm-{__name__.rsplit('.', 2)[0]}")


def is_warm() -> bool:
    """Whether every kernel is already compiled in the cache (integrator.warm_up has run)."""
    return os.path.isfile(_warm_marker())


def mark_warm() -> None:
    """Record that every kernel is compiled in the cache."""
    os.makedirs(cache_dir(), exist_ok=True)
    with open(_warm_marker(), "w") as f:
        f.write(numba.__version__ + "\n")


class _CompileClock(event.Listener):
    """Adds up the seconds Numba spends compiling (not loading from the cache): a compile
    nested in another (a callee's) is counted once, in its caller's."""

    def __init__(self):
        self.total = 0.0
        self._local = threading.local()
        self._lock = threading.Lock()

    def on_start(self, ev):
        stack = self._local.__dict__.setdefault("starts", [])
        stack.append(time.perf_counter())

    def on_end(self, ev):
        stack = self._local.starts
        start = stack.pop()
        if not stack:
            with self._lock:
                self.total += time.perf_counter() - start


_CLOCK = _CompileClock()
event.register("numba:compile", _CLOCK)


def compile_seconds() -> float:
    """Seconds spent compiling kernels in this process so far (renders subtract theirs from
    their timings)."""
    return _CLOCK.total


# SNELL_KERNEL_CACHE moves the cache (tests point it at a fresh directory to time compiles).
set_cache_dir(os.environ.get("SNELL_KERNEL_CACHE") or default_cache_base())
