"""numba's typing of scalar calls, memoised (phasemap/core/fasttyping.py): the same
signatures as numba's own resolution, and only for plain scalar arguments."""

from __future__ import annotations

import math
import operator

import numba
import numpy as np
import pytest
from numba.core import types
from numba.core.registry import cpu_target
from numba.core.types import functions

import phasemap  # noqa: F401  (installs the memo)
from phasemap.core import fasttyping


def _resolve(fn, args):
    context = cpu_target.typing_context
    context.refresh()
    fnty = context.resolve_value_type(fn)
    return fnty, context, fnty.get_call_type(context, args, {})


def test_importing_phasemap_installs_it_once():
    assert fasttyping.installed()
    patched = functions.BaseFunction.get_call_type
    fasttyping.install()
    assert functions.BaseFunction.get_call_type is patched
    assert hasattr(patched, "__wrapped__")


@pytest.mark.parametrize("fn, args", [
    (operator.mul, (types.float64, types.float64)),
    (operator.add, (types.int64, types.float64)),
    (operator.truediv, (types.int64, types.int64)),
    (operator.pow, (types.float64, types.int64)),
    (operator.lt, (types.float64, types.float64)),
    (operator.and_, (types.boolean, types.boolean)),
    (abs, (types.float64,)),
    (math.sin, (types.float64,)),
    (math.atan2, (types.float64, types.float64)),
    (max, (types.float64, types.float64)),
])
def test_the_memoised_signature_is_numbas_own(fn, args):
    fnty, context, sig = _resolve(fn, args)
    own = functions.BaseFunction.get_call_type.__wrapped__(fnty, context, args, {})
    assert sig == own and sig.return_type == own.return_type
    again = fnty.get_call_type(context, args, {})
    assert again is sig                                    # the second time: the memo
    assert fnty.get_impl_key(sig) == fnty.get_impl_key(own)   # what lowering reads


def test_arrays_literals_and_keywords_go_through_numba_unchanged():
    """Only plain scalars are memoised: an array, a literal or a keyword argument is
    resolved by numba every time, and the memo never holds it."""
    arr = types.Array(types.float64, 1, "C")
    for args in [(arr, types.float64), (types.IntegerLiteral(3), types.float64),
                 (types.UniTuple(types.float64, 2), types.UniTuple(types.float64, 2))]:
        fnty, context, sig = _resolve(operator.add if isinstance(args[0], types.BaseTuple)
                                      else operator.mul, args)
        assert sig is not None
        assert all(key[2] != args for key in fasttyping._MEMO)
    fnty, context, sig = _resolve(operator.mul, (types.float64, types.float64))
    assert any(key[2] == (types.float64, types.float64) for key in fasttyping._MEMO)


def test_a_compiled_function_gives_the_same_numbers():
    @numba.njit(cache=False)
    def f(x, y, k):
        return abs(x) * math.sin(y) + x ** k - max(x, y) / (1.0 + k) + (x < y)

    rng = np.random.default_rng(7)
    for x, y in rng.normal(size=(20, 2)):
        assert f(x, y, 3) == f.py_func(x, y, 3)
