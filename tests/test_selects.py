"""Generated code's conditionals as ``_select`` calls (phasemap.core.selects): which are
rewritten, and that the rewritten module computes what the conditionals did, compiled and
interpreted."""

from __future__ import annotations

import ast
import importlib.util
import math
import sys

import numpy as np
import pytest
from numba import njit

from phasemap.core.interpret import interpreted
from phasemap.core.selects import DEEPEST, selects

SOURCE = '''"""A module as the code printer writes them."""
import math
import sys
import numpy as np
NAN = np.nan


def f(x, y, r):
    s = r[0] if x > 0.0 else 0
    z = r[1] if s else (y / x if x != 0.0 else NAN)
    w = math.sqrt(x) if x >= 0.0 else -1.0
    k = r[2] if y > 0 else 7
    q = (2 if y > 1.0 else 1) if x < 0.0 else 0
    return s + z + w + k + q
'''


def _calls(text):
    return [n for n in ast.walk(ast.parse(text)) if isinstance(n, ast.Call)
            and getattr(n.func, "id", "") == "_select"]


def test_harmless_arms_become_select_calls_and_the_others_stay():
    out = selects(SOURCE)
    tree = ast.parse(out)
    assert ast.get_docstring(tree) == "A module as the code printer writes them."
    assert "from phasemap.core.selects import select as _select" in out
    # s, z (both), k and q (both) are rewritten; w keeps its conditional: math.sqrt is a
    # call, evaluated only where x >= 0
    assert len(_calls(out)) == 6
    assert "math.sqrt(x) if x >= 0.0 else -1.0" in out
    assert selects("def g(x):\n    return x if x else 0\n") != "def g(x):\n    return x if x else 0\n"
    nothing = "def h(x):\n    return abs(x) if x else 0\n"
    assert selects(nothing) == nothing          # no rewrite: the same text, no import


@pytest.mark.parametrize("index", ["-1", "i", "0.0"])
def test_a_subscript_that_could_fail_is_not_evaluated_eagerly(index):
    text = f"def h(r, i):\n    return r[{index}] if i > 0 else 0.0\n"
    assert not _calls(selects(text))


def _module(text, path):
    path.write_text(text)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_rewritten_function_computes_the_same_compiled_and_interpreted(tmp_path):
    before = _module(SOURCE, tmp_path / "selects_before.py")
    after = _module(selects(SOURCE), tmp_path / "selects_after.py")
    want = njit(error_model="numpy")(before.f)
    got = njit(error_model="numpy")(after.f)
    twin = interpreted(got)
    r = np.array([1.5, -2.0, 0.25])
    for x in (-2.0, -0.0, 0.0, 0.5, math.inf, math.nan):
        for y in (-1.0, 0.0, 2.0):
            a, b, c = want(x, y, r), got(x, y, r), twin(x, y, r)
            assert (a == b == c) or (math.isnan(a) and math.isnan(b) and math.isnan(c)), \
                (x, y, a, b, c)


def test_an_expression_too_deep_for_pythons_ast_leaves_the_module_as_written():
    deep = "def f(x):\n    return (x" + " + x" * 20000 + ") if x else 0.0\n"
    assert selects(deep) == deep


def _chain(levels: int) -> str:
    """A module whose syntax tree is about ``levels`` deep, with one harmless conditional."""
    return "def f(a, b, c):\n    return " + "a + " * (levels - 5) + "(b if c else a)\n"


def _from_depth(frames: int, text: str) -> str:
    return _from_depth(frames - 1, text) if frames else selects(text)


@pytest.mark.parametrize("levels", [DEEPEST - 10, DEEPEST + 10])
def test_the_rewrite_of_a_module_does_not_depend_on_the_callers_stack(levels):
    # the file's text decides the names of the files generated from it (a contract hashes
    # its declared module's file): a caller deep in a stack (pytest's, a dask worker's)
    # must get the text a shallow caller gets, up to DEEPEST and beyond it
    text = _chain(levels)
    shallow = selects(text)
    assert _from_depth(sys.getrecursionlimit() - 100, text) == shallow
    assert bool(_calls(shallow)) == (levels <= DEEPEST)


def test_an_error_in_the_rewrite_reaches_the_caller():
    with pytest.raises(SyntaxError):
        selects("def f(:\n")
