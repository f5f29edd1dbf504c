"""jit.Compiled: a function called from compiled code is compiled without a Python entry point,
one called from Python with one, each cached under its own name."""
from collections import namedtuple

import numba
import numpy as np

from snell.tracer.jit import jit

Table = namedtuple("Table", ["a", "b"])
CALLEE = None          # the test's jit(_callee), made under a fresh cache directory


def _callee(table, k):
    """The callee's docstring."""
    return table.a[k] * 2.0 + table.b[k]


def _caller(table, n):
    total = 0.0
    for k in range(n):
        total += CALLEE(table, k)
    return total


def _compile_fresh(monkeypatch, tmp_path):
    # A fresh cache: nothing loads from an earlier run, so the callee compiles.
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    monkeypatch.setitem(globals(), "CALLEE", jit(_callee))
    return jit(_caller)


def test_compiled_callers_use_the_callee_without_a_python_entry_point(monkeypatch, tmp_path):
    """The caller compiles the callee's compiled-code dispatcher (no CPython or C wrapper) and
    leaves its Python one alone; calling the callee from Python then compiles that one. Typing
    the callee as its Python dispatcher (what plain numba.njit does) was caught: the Python
    dispatcher had 1 signature after the caller's compile and the other 0."""
    caller = _compile_fresh(monkeypatch, tmp_path)
    table = Table(np.arange(4.0), np.ones(4))
    assert caller(table, 4) == 16.0
    inner, outer = CALLEE._from_compiled, CALLEE._from_python
    assert len(inner.signatures) == 1 and len(outer.signatures) == 0
    assert inner.targetoptions["no_cpython_wrapper"] and inner.targetoptions["no_cfunc_wrapper"]
    assert CALLEE(table, 3) == 7.0
    assert len(outer.signatures) == 1 and "no_cpython_wrapper" not in outer.targetoptions


def test_the_two_dispatchers_cache_under_different_names(monkeypatch, tmp_path):
    """Numba keys a cache entry by the function's qualified name and signature only, so the
    dispatchers with and without the Python entry point must not share a name. Without
    _renamed both were '_callee', and this test failed; the first one's Python call then
    loaded the entry the caller's compile had cached, which has no wrapper, and crashed
    pytest."""
    _compile_fresh(monkeypatch, tmp_path)
    inner, outer = CALLEE._from_compiled, CALLEE._from_python
    assert inner.py_func.__qualname__ == "_callee"
    assert outer.py_func.__qualname__ == "_callee_py"
    assert CALLEE.__doc__ == "The callee's docstring." and CALLEE.__name__ == "_callee"
