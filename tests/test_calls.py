"""A shared compiled driver calls a model's compiled function at its address
(phasemap.core.calls): the result, an exception it raises, and a call of the wrong types."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from numba import extending, types

from phasemap.core import calls
from phasemap.core.types import F1

SIG = types.float64(types.float64, F1)


@numba.njit(SIG, cache=True)
def _scaled_sum_or_raise(x, a):
    if x < 0.0:
        raise ValueError("x must not be negative")
    return x * a.sum()


@extending.intrinsic
def _call(typingctx, at, x, a):
    return calls.typer(SIG, at, (x, a))


@numba.njit(cache=True)
def _drive(at, xs, a):
    out = np.empty(xs.shape[0])
    for i in range(xs.shape[0]):
        out[i] = _call(at, xs[i], a) + 1.0
    return out


@numba.njit(cache=True)
def _drive_int(at, a):
    return _call(at, 1, a)


def test_a_function_called_at_its_address_returns_its_result():
    at = calls.address(_scaled_sum_or_raise, SIG.args)
    assert at == calls.address(_scaled_sum_or_raise, SIG.args) and at > 0
    a = np.array([1.0, 2.0, 0.5])
    assert np.array_equal(_drive(at, np.array([0.0, 2.0, 4.0]), a), [1.0, 8.0, 15.0])


def test_an_exception_of_the_called_function_reaches_the_caller():
    at = calls.address(_scaled_sum_or_raise, SIG.args)
    with pytest.raises(ValueError, match="x must not be negative"):
        _drive(at, np.array([1.0, -1.0]), np.ones(2))
    # and the driver goes on working after it
    assert _drive(at, np.array([3.0]), np.ones(2))[0] == 7.0


def test_arguments_of_other_types_do_not_type():
    at = calls.address(_scaled_sum_or_raise, SIG.args)
    with pytest.raises(numba.core.errors.TypingError):
        _drive_int(at, np.ones(2))


def test_every_shared_driver_takes_an_address():
    """The grid, fate and batch drivers and the tracer's entry points take the model's
    functions as addresses (intp), not as numba first-class functions."""
    from phasemap.bifurcation import _trace
    from phasemap.core import codegen
    from phasemap.motion import integrate

    drivers = [codegen.driver(), integrate._fate_driver(), integrate._batch_driver()]
    for d in drivers:
        (sig,) = d.nopython_signatures
        assert sig.args[0] == types.intp
        assert not any(isinstance(t, types.FunctionType) for t in sig.args)
    assert _trace.ADDRESSES == types.UniTuple(types.intp, 4)
