"""jit.compile_seconds: the seconds Numba spent compiling, a nested compile counted once."""
import time

import numba
import numpy as np

from snell.tracer import jit


def test_a_compile_is_counted_once_with_the_callees_it_compiles():
    """A new function calling another new one: the clock rises by no more than the first call
    took, and by more than nothing. Counting the callee's compile a second time was caught:
    a rise of 1.21 s for a first call of 0.93 s."""
    @numba.njit
    def callee(x):
        total = 0.0
        for k in range(x.shape[0]):
            total += np.sin(x[k]) * np.cos(x[k] * 0.5) + np.sqrt(abs(x[k]))
        return total

    @numba.njit
    def caller(x):
        return callee(x) + callee(x[::2])

    before = jit.compile_seconds()
    start = time.perf_counter()
    caller(np.linspace(0.0, 1.0, 8))
    took = time.perf_counter() - start
    rise = jit.compile_seconds() - before
    assert 0.0 < rise <= took
    again = jit.compile_seconds()
    caller(np.linspace(0.0, 1.0, 8))
    assert jit.compile_seconds() == again      # compiled once: no more time counted
