"""phasemap.core.jit: one compilation per argument types, whatever constants a compiled
caller passes."""

from __future__ import annotations

import numpy as np
import pytest
from numba import types
from numba.core.dispatcher import Dispatcher

from phasemap.bifurcation import _trace
from phasemap.core import jit


def test_a_compiled_callers_constants_share_one_compilation():
    @jit.njit(cache=False, error_model="numpy")
    def scaled(x, k, flag):
        return x * k if flag else -x

    @jit.njit(cache=False)
    def caller(x):
        return scaled(x, 2, True) + scaled(x, 3, False) + scaled(x, np.int64(4), x > 0)

    assert caller(1.5) == 1.5 * 2 - 1.5 + 1.5 * 4
    assert [tuple(map(str, s)) for s in scaled.signatures] == [("float64", "int64", "bool")]
    assert isinstance(scaled, Dispatcher)      # numba's own, for the tiers and the caches
    assert scaled.targetoptions["error_model"] == "numpy"


def test_the_decorator_takes_numbas_forms():
    @jit.njit
    def bare(x):
        return x + 1

    @jit.njit("float64(float64)", cache=False)
    def typed(x):
        return x * 2

    assert bare(1) == 2 and typed(2.0) == 4.0
    with pytest.raises(TypeError):       # compiled for its signature only
        typed(np.zeros(2))

    @jit.njit(locals={"y": types.float64})
    def local(x):
        y = x
        return y

    assert local(3) == 3.0 and isinstance(local(3), float)


def test_every_function_of_the_tracer_is_compiled_once_per_argument_types():
    """The tracer's functions are the ones literal constants compiled many times (its
    first boundaries 88 s of CPU, 77 s without): each is this decorator's."""
    jitted = [v for v in vars(_trace).values() if isinstance(v, Dispatcher)]
    assert len(jitted) > 50
    assert all(isinstance(f, jit.Dispatcher) for f in jitted), \
        [f.py_func.__name__ for f in jitted if not isinstance(f, jit.Dispatcher)]
