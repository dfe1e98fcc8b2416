"""What a declared model needs when it runs, without sympy: its domain check on whole
arrays, and the list of sources its generated kernels are derived by (part of the
kernel cache's key).  :mod:`phasemap.declare.build` (deriving a model) and
:mod:`phasemap.declare.loader` (loading it from the kernel cache) share it.
"""

from __future__ import annotations

import inspect
import pathlib
import types

import numpy as np

from phasemap.core import args as _args
from phasemap.core import numerics as nx

_DECLARE = pathlib.Path(__file__).resolve().parent
#: The modules of phasemap.declare that do not shape a generated module: the
#: admissibility conditions (the bifurcation tracer's), the loader (hashed by
#: :func:`phasemap.declare.loader.key_of` itself) and the full-coordinate numbers of
#: the motion through contact changes.
_NOT_SOURCES = ("admissibility.py", "loader.py", "full.py")


def declare_sources() -> list[pathlib.Path]:
    """The sources a declared model's generated module and its manifest are derived by:
    :mod:`phasemap.declare` (but :data:`_NOT_SOURCES`, which the generated text does not
    use) and the shared numerics."""
    declare = sorted(_DECLARE.glob("*.py"))
    return [f for f in declare if f.name not in _NOT_SOURCES] + [pathlib.Path(nx.__file__)]


def checks(name: str, check, inside, text: str):
    """A declared model's Python-level domain check: the declaration's own ``check``, and
    the generated ``inside`` (a state in the domain beyond its variables' bounds), evaluated
    on whole arrays (:func:`on_arrays`)."""
    if inside is None:
        return check
    names = list(inspect.signature(inside.py_func).parameters)
    arrays = on_arrays(inside.py_func)

    def both(values):
        if check is not None:
            check(values)
        vals = {}
        for n in names:
            src = n[4:] if n.startswith(("sin_", "cos_")) else n
            x = np.asarray(values[src], float)
            vals[n] = np.sin(x) if n.startswith("sin_") else (np.cos(x) if n.startswith("cos_")
                                                              else x)
        args = [vals[n] for n in names]
        try:
            with np.errstate(all="ignore"):
                ok = arrays(*args)
        except (TypeError, ValueError, AttributeError):  # a builtin that takes one number
            ok = np.vectorize(inside.py_func, otypes=[bool])(*args)
        if not np.all(ok):
            raise ValueError(f"{name}: outside the domain: {text}{_at(names, values)}")

    return both


def _at(names: list[str], values) -> str:
    """``", at l = 1, h = 0.8, theta = 0.1"``: the values the domain condition read (its
    parameters, ``sin_x``/``cos_x`` read as ``x``), where every one is a single number."""
    read = list(dict.fromkeys(n[4:] if n.startswith(("sin_", "cos_")) else n for n in names))
    if not all(np.ndim(values[n]) == 0 for n in read):
        return ""
    return ", at " + ", ".join(f"{n} = {_args.bound(float(values[n]))}" for n in read)


class _ArrayMath:
    """``math`` as the generated code calls it, with NumPy's functions, which take arrays
    (``math.asin`` is ``np.arcsin``); a name NumPy lacks raises AttributeError."""

    _RENAMED = {"asin": "arcsin", "acos": "arccos", "atan": "arctan", "atan2": "arctan2",
                "asinh": "arcsinh", "acosh": "arccosh", "atanh": "arctanh", "pow": "power"}

    def __getattr__(self, name):
        return getattr(np, self._RENAMED.get(name, name))


def on_arrays(func):
    """``func`` (a generated scalar function: arithmetic, ``abs``, ``&`` and ``math``) as one
    that takes NumPy arrays elementwise: the same code with ``math`` read as NumPy.

    Elementwise it computes what ``func`` computes on each number, in one pass over the
    arrays instead of one Python call per value (``np.vectorize``: about 1 us each).  The
    arithmetic is IEEE in both; the elementary functions are NumPy's, not libm's: on the
    project's machines they agreed with ``math``'s bit for bit (sin, cos, tan, sqrt, exp,
    log, the inverse functions and atan2, 2e6 random values each), but a NumPy build that
    dispatches them to other vector code may differ by an ulp, which matters only for a
    value exactly on a domain check's edge.  A division by zero gives inf, as in the compiled
    function (``error_model="numpy"``), where Python would raise.  Code that takes one
    number only (``max``, ``if``) raises TypeError or ValueError on arrays.

    >>> import math
    >>> def f(x, y):
    ...     return (math.sqrt(x) >= 1.0) & (abs(y) < 2.0)
    >>> on_arrays(f)(np.array([0.5, 4.0, 9.0]), np.array([1.0, 1.0, 3.0]))
    array([False,  True, False])
    """
    return types.FunctionType(func.__code__, {**func.__globals__, "math": _ArrayMath()},
                              func.__name__, func.__defaults__, func.__closure__)
