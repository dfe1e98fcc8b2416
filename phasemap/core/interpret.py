"""The interpreter tier: a compiled function's own Python, run at once, with numba's numbers.

numba compiles a model's point function in seconds to minutes (the declared ladder's
``point``: about 10 s of CPU); a single :func:`phasemap.classify` needs a few hundred
microseconds of arithmetic.  :func:`interpreted` gives the plain-Python twin of a jitted
function, to run while the compiled one is built (:mod:`phasemap.core.tiers` chooses).

The twin is the function's own source, with three changes that make CPython compute
what numba's machine code computes, bit for bit:

* **IEEE arithmetic.**  Under ``error_model="numpy"`` numba divides by zero to
  ``inf``/``nan``, where Python raises: ``/``, ``//`` and ``%`` become calls that do
  what the compiled code does (a function compiled with numba's default ``"python"``
  error model raises ``ZeroDivisionError`` in both tiers).
* **Powers as numba takes them.**  ``x ** n`` with an integer ``n`` is numba's repeated
  squaring (``x ** 3`` is ``x * (x * x)``, not the C library's ``pow``); a float exponent is
  ``pow`` itself.
* **The C library's elementary functions, without exceptions.**  ``math.sqrt(-1.0)`` is
  ``nan`` in compiled code and an exception in Python; the twin's ``math`` and ``np`` give
  the compiled values (``np.sin`` of a number is the C library's ``sin``, as in numba).

Every other name keeps its value, and a jitted function the code calls is replaced by its
own twin (``~`` of a boolean is numba's logical not; ``a /= x`` on an array is in place).
A function the twin cannot reproduce (an intrinsic, ``objmode``, ``parallel=True``, an
elementary function without a C-library twin such as ``math.floor``, a plain Python
function from outside phasemap) raises :class:`Unsupported` when its twin is made, and
the caller compiles instead.

What the twin does not reproduce, and phasemap's compiled code does not do: integer
overflow (numba's 64-bit integers wrap, Python's grow), a variable that holds an integer
on one path and a float on another (numba unifies it to a float; the twin's ``**``, ``//``
and ``%`` take the value's own type), and ``int()`` of a NaN.  The tests compare both tiers
bit for bit on every model's rows and motions.

>>> import math
>>> from numba import njit
>>> from phasemap.core.interpret import interpreted
>>> @njit(error_model="numpy")
... def f(x, y):
...     return math.sqrt(x) / y ** 3
>>> math.isnan(interpreted(f)(-1.0, 2.0)), interpreted(f)(4.0, 0.0)   # as compiled
(True, inf)
"""

from __future__ import annotations

import ast
import builtins
import dis
import functools
import inspect
import linecache
import math
import textwrap
import threading
import types

import numpy as np

__all__ = ["Unsupported", "interpreted"]


class Unsupported(TypeError):
    """The function uses something the interpreter tier cannot reproduce exactly."""


# --------------------------------------------------------------------------- numbers

def _ieee(a, b, op, np_op):
    try:
        return op(a, b)
    except ZeroDivisionError:
        with np.errstate(all="ignore"):
            r = np_op(np.float64(a), np.float64(b))
        return float(r)


def _div(a, b):
    """``a / b`` as compiled under ``error_model="numpy"``: IEEE, never an exception."""
    try:
        return a / b
    except ZeroDivisionError:
        with np.errstate(all="ignore"):
            return float(np.true_divide(np.float64(a), np.float64(b)))


def _floordiv(a, b):
    if _integer(a) and _integer(b):
        return a // b if b != 0 else 0  # numba's integer division by zero under "numpy"
    return _ieee(a, b, lambda x, y: x // y, np.floor_divide)


def _mod(a, b):
    if _integer(a) and _integer(b):
        return a % b if b != 0 else 0
    return _ieee(a, b, lambda x, y: x % y, np.remainder)


def _integer(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_))


def _pow(a, b, ieee: bool = True):
    """``a ** b`` as numba computes it: an integer exponent by repeated squaring
    (numba's ``static_power_impl`` and ``int_power_impl``), a float one by ``pow``.

    Zero to a negative integer power raises ``ZeroDivisionError`` for a float (numba's
    inversion is compiled with Python's error model) and, for an integer, gives
    ``-2**63`` under ``error_model="numpy"``."""
    if _integer(b):
        b = int(b)
        if _integer(a):
            a = int(a)
            if b >= 0:
                return a ** b
            if a == 0:
                if ieee:
                    return -(1 << 63)
                raise ZeroDivisionError("0 cannot be raised to a negative power")
            return a ** -b if a in (1, -1) else 0
        a = float(a)
        if abs(b) > 0x10000:  # numba's cutoff: the C library's pow itself
            return _POW(a, float(b))
        invert, n, r = b < 0, abs(b), 1.0
        while n:
            if n & 1:
                r *= a
            n >>= 1
            a *= a
        return 1.0 / r if invert else r
    return _POW(float(a), float(b))


def _pow_constant(a, b):
    """``a ** c`` for a float literal ``c``: what LLVM makes of ``pow(a, c)`` for the
    constants it rewrites without fast-math (``x * x``, ``1 / x``, ``sqrt``), else
    :func:`_pow`."""
    if not _integer(a):
        a = float(a)
        if b == 2.0:
            return a * a
        if b == 1.0:
            return a
        if b == 0.0:
            return 1.0
        if b == -1.0:
            return _div(1.0, a)
        if b == 0.5:
            return math.inf if a == -math.inf else abs(_MATH["sqrt"](a))
    return _pow(a, b)


def _div_python(a, b):
    """``a / b`` under numba's default error model: a zero divisor raises, whatever the
    types (numpy's float64 would return inf)."""
    if b == 0:
        raise ZeroDivisionError("division by zero")
    return a / b


def _invert(a):
    """``~a``: numba's logical not of a boolean, the bitwise one of an integer."""
    if isinstance(a, (bool, np.bool_)):
        return not a
    return ~a


def _in_place(helper):
    """``t op= v`` with ``helper`` for op: in place where ``t`` is an array, as numba
    does (the caller's array changes), elementwise with numba's scalar arithmetic."""

    def f(t, v):
        if isinstance(t, np.ndarray):
            t[...] = _elementwise(helper, (t, v))
            return t
        return helper(t, v)

    return f


def _pow_python(a, b):
    return _pow(a, b, ieee=False)


def _safe(name: str, exact, fallback):
    """The C library's ``exact`` where it returns, ``fallback`` (numpy's IEEE value) where
    CPython raises instead of returning ``nan`` or ``inf``."""

    def f(*args):
        try:
            return exact(*args)
        except (ValueError, OverflowError):
            with np.errstate(all="ignore"):
                return float(fallback(*args))
        except TypeError:
            if any(isinstance(a, np.ndarray) for a in args):
                return _elementwise(f, args)
            raise

    f.__name__ = f.__qualname__ = name
    return f


def _elementwise(f, args):
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    out = np.empty(arrays[0].shape)
    for i in np.ndindex(out.shape):
        out[i] = f(*(float(a[i]) for a in arrays))
    return out


#: The elementary functions: ``math`` name -> (numpy's name, for the IEEE fallback).
_ELEMENTARY = {
    "sqrt": "sqrt", "sin": "sin", "cos": "cos", "tan": "tan", "asin": "arcsin",
    "acos": "arccos", "atan": "arctan", "atan2": "arctan2", "exp": "exp", "expm1": "expm1",
    "log": "log", "log1p": "log1p", "log10": "log10", "log2": "log2", "pow": "power",
    "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "asinh": "arcsinh", "acosh": "arccosh",
    "atanh": "arctanh", "hypot": "hypot", "fmod": "fmod",
}
#: ``math`` names that return what numba returns as they are.
_EXACT_MATH = {"fabs", "copysign", "isnan", "isinf", "isfinite", "pi", "e", "tau", "inf",
               "nan", "degrees", "radians"}
#: numpy names the code may use as they are (numpy's scalar and array results are numba's).
_EXACT_NUMPY = {"inf", "nan", "pi", "e", "isfinite", "isnan", "isinf", "abs", "absolute",
                "fabs", "sign", "copysign", "ones", "full", "empty_like",
                "zeros_like", "ones_like", "full_like", "float64", "int64", "intp", "bool_",
                "int32", "uint8", "array", "asarray", "arange", "minimum", "maximum",
                "fmin", "fmax", "floor", "ceil", "trunc", "rint", "signbit", "radians",
                "degrees", "newaxis", "nextafter", "spacing", "finfo", "int8", "flatnonzero"}
#: What x86-64 machine code gives for an integer conversion of NaN, an infinity or a float
#: beyond int64 (``cvttsd2si``'s "integer indefinite"): numba's ``math.floor`` of them.
_INDEFINITE = -(1 << 63)


def _floor(x):
    """numba's ``math.floor``: an int64, not Python's unbounded int or its exception."""
    try:
        r = math.floor(x)
    except (ValueError, OverflowError):
        return _INDEFINITE
    return r if -(1 << 63) <= r < (1 << 63) else _INDEFINITE


def _argsort(a, kind=None):
    """``np.argsort`` with a stable kind, whose order is unique (numba's quicksort and
    numpy's order equal keys each their own way)."""
    if kind not in ("mergesort", "stable"):
        raise Unsupported("np.argsort without kind='mergesort' or 'stable' orders equal "
                          "keys as numba does not")
    return np.argsort(a, kind=kind)


def _records(make):
    """numpy's ``make`` (``np.empty``, ``np.zeros``), giving a record array where the
    dtype has fields: numba reads and writes a record's fields as attributes
    (``a[i].u = 1.0``), which a record array's elements take and a plain array's do
    not."""

    def f(*args, **kwargs):
        out = make(*args, **kwargs)
        return out.view(np.recarray) if out.dtype.names else out

    f.__name__ = f.__qualname__ = make.__name__
    return f


def records(value):
    """``value`` as compiled code sees it: a structured array as a record array (its
    elements' fields read and written as attributes), anything else as it is."""
    if type(value) is np.ndarray and value.dtype.names:
        return value.view(np.recarray)
    return value


#: Functions whose twin is not the function itself, by module: what each namespace and the
#: identity table give (:data:`MATH`, :data:`NUMPY`, :func:`_identities`).
_SPECIAL_MATH = {"floor": _floor}
_SPECIAL_NUMPY = {"argsort": _argsort, "empty": _records(np.empty),
                  "zeros": _records(np.zeros)}


def plain(value):
    """A twin's result as compiled code returns it: record arrays as plain arrays."""
    if isinstance(value, np.recarray):
        return value.view(np.ndarray)
    if type(value) is tuple:
        return tuple(plain(v) for v in value)
    return value

_MATH = {name: _safe(name, getattr(math, name), getattr(np, np_name))
         for name, np_name in _ELEMENTARY.items()}
_POW = _MATH["pow"]   # the C library's pow, IEEE where CPython raises
_MATH["pow"] = lambda a, b: _pow(a, b)   # numba lowers math.pow as a ** b
# CPython's math.hypot is its own algorithm, not the C library's that numba calls
_MATH["hypot"] = lambda a, b: float(np.hypot(float(a), float(b)))
_NUMPY = {np_name: _safe(np_name, getattr(math, name), getattr(np, np_name))
          for name, np_name in _ELEMENTARY.items() if name not in ("pow", "fmod", "hypot")}


class _Namespace(types.SimpleNamespace):
    """A module's stand-in: the names the twin may use, and a clear error for the rest."""

    def __init__(self, label: str, names: dict):
        super().__init__(**names)
        self._label = label

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        raise Unsupported(f"{self._label}.{name} is not reproduced by the interpreter tier")


MATH = _Namespace("math", {**{n: getattr(math, n) for n in _EXACT_MATH}, **_MATH,
                            **_SPECIAL_MATH})
NUMPY = _Namespace("numpy", {**{n: getattr(np, n) for n in _EXACT_NUMPY}, **_NUMPY,
                             **_SPECIAL_NUMPY})


# --------------------------------------------------------------------------- source

_CALLS = {ast.Pow: "_pm_pow"}
_IEEE_CALLS = {ast.Div: "_pm_div", ast.FloorDiv: "_pm_floordiv", ast.Mod: "_pm_mod"}
_PYTHON_CALLS = {ast.Div: "_pm_div_python"}


def _helpers(ieee: bool) -> dict:
    """The names the rewritten code calls, for a function under the numpy error model
    (``ieee``) or numba's default (division by zero raises)."""
    plain = {"_pm_div": _div, "_pm_floordiv": _floordiv, "_pm_mod": _mod,
             "_pm_pow": _pow if ieee else _pow_python, "_pm_div_python": _div_python}
    return {**plain, **{"_pm_i" + k[4:]: _in_place(f) for k, f in plain.items()},
            "_pm_pow_constant": _pow_constant, "_pm_invert": _invert}


def _rewrite(tree, ieee: bool) -> None:
    """In place: ``/``, ``//``, ``%`` (under the numpy error model) and ``**`` become calls
    of the IEEE helpers, ``~`` numba's, and decorators go.  One pass over the tree (a
    model's point function has tens of thousands of nodes)."""
    calls = {**_CALLS, **(_IEEE_CALLS if ieee else _PYTHON_CALLS)}
    attributes = set()
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.FunctionDef):
            node.decorator_list = []
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            attributes.add((node.value.id, node.attr))
        for field in node._fields:
            value = getattr(node, field, None)
            if isinstance(value, list):
                for i, child in enumerate(value):
                    if isinstance(child, ast.AST):
                        value[i] = _call(child, calls)
                        stack.append(value[i])
            elif isinstance(value, ast.AST):
                new = _call(value, calls)
                if new is not value:
                    setattr(node, field, new)
                stack.append(new)
    return attributes


def _call(node, calls):
    """``node`` as a helper call if it is an operation the helpers take."""
    if isinstance(node, ast.BinOp):
        name = calls.get(type(node.op))
        if name == "_pm_pow" and _float_literal(node.right) is not None:
            name = "_pm_pow_constant"  # (LLVM rewrites pow by some constants)
        if name is not None:
            return _located(ast.Call(_located(ast.Name(name, ast.Load()), node),
                                     [node.left, node.right], []), node)
    elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Invert):
        return _located(ast.Call(_located(ast.Name("_pm_invert", ast.Load()), node),
                                 [node.operand], []), node)
    elif isinstance(node, ast.AugAssign):
        name = calls.get(type(node.op))
        if name is not None:  # in place for an array, as numba does
            load = _located(ast.parse(ast.unparse(node.target), mode="eval").body, node)
            for sub in ast.walk(load):
                _located(sub, node)
            value = _located(ast.Call(_located(ast.Name("_pm_i" + name[4:], ast.Load()),
                                               node), [load, node.value], []), node)
            return _located(ast.Assign([node.target], value), node)
    return node


def _float_literal(node):
    """The value of a float literal (or its negation), else None."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        value = _float_literal(node.operand)
        return None if value is None else -value
    if isinstance(node, ast.Constant) and type(node.value) is float:
        return node.value
    return None


def _located(new, old):
    new.lineno, new.col_offset = old.lineno, old.col_offset
    new.end_lineno, new.end_col_offset = old.end_lineno, old.end_col_offset
    return new


def _dispatcher(obj) -> bool:
    from numba.core.dispatcher import Dispatcher

    return isinstance(obj, Dispatcher)


_LOCK = threading.RLock()
_TWINS: dict = {}
_MAKING: set = set()


def interpreted(dispatcher):
    """The plain-Python twin of the jitted ``dispatcher``: the same values, uncompiled.

    Raises :class:`Unsupported` where the twin could differ from the compiled function.
    Twins are made once per process and function.
    """
    if not _dispatcher(dispatcher):
        raise Unsupported(f"{dispatcher!r} is not a numba-jitted function")
    with _LOCK:
        return _made(id(dispatcher), dispatcher, lambda: _twin(dispatcher))


def _made(key, owner, make):
    """The twin under ``key`` (made once; ``owner`` held with it).  A function that calls
    itself back through another (mutual recursion) is refused, not made forever."""
    twin = _TWINS.get(key)
    if twin is None:
        if key in _MAKING:
            raise Unsupported(f"{getattr(owner, '__qualname__', owner)!s} is mutually "
                              "recursive")
        _MAKING.add(key)
        try:
            twin = _TWINS[key] = (owner, make())
        finally:
            _MAKING.discard(key)
    return twin[1]


def _twin(dispatcher):
    return _twin_of(dispatcher.py_func, getattr(dispatcher, "targetoptions", {}))


def _python_twin(function, error_model: str):
    """The twin of one of phasemap's plain Python functions that jitted code calls (one
    with a numba ``overload``, such as the stages of a Runge-Kutta step, whose Python is
    its reference), under the error model of its caller."""
    with _LOCK:
        return _made((id(function), error_model), function,
                     lambda: _twin_of(function, {"error_model": error_model}))


def _twin_of(py, options):
    if options.get("parallel") or options.get("forceobj") or options.get("fastmath"):
        raise Unsupported(f"{py.__qualname__} is compiled with options the interpreter "
                          "tier does not reproduce")
    if py.__closure__:
        raise Unsupported(f"{py.__qualname__} is a closure")
    try:
        filename = inspect.getsourcefile(py) or "<phasemap-interpreted>"
        source = _source(py, filename)
    except (OSError, TypeError) as err:
        raise Unsupported(f"the source of {py.__qualname__} is not available") from err
    # padded so that the twin's line numbers are the file's (tracebacks point there)
    tree = ast.parse("\n" * (py.__code__.co_firstlineno - 1) + source)
    if len(tree.body) != 1 or not isinstance(tree.body[0], ast.FunctionDef):
        raise Unsupported(f"{py.__qualname__} is not a plain function definition")
    ieee = options.get("error_model", "python") == "numpy"
    attributes = _rewrite(tree, ieee)
    code = compile(tree, filename, "exec")
    namespace = {"__builtins__": builtins, "__name__": py.__module__, **_helpers(ieee)}
    own = tree.body[0].name
    for name in _names(code):
        if name not in namespace and name != own and name in py.__globals__:
            try:
                namespace[name] = _global(py.__qualname__, name, py.__globals__[name],
                                      options.get("error_model", "python"))
            except Unsupported:
                if _looks_up(code, name):  # not only an attribute's name (np.sqrt)
                    raise
    # math.floor, np.linalg, a module's name the twin cannot take: refused now, not in
    # the middle of a call
    for name, attr in attributes:
        if isinstance(namespace.get(name), (_Namespace, _Module)):
            getattr(namespace[name], attr)
    exec(code, namespace)  # noqa: S102 - the function's own source
    twin = namespace[tree.body[0].name]
    namespace[tree.body[0].name] = twin  # recursion calls the twin
    twin.__qualname__ = py.__qualname__
    twin.__doc__ = py.__doc__
    return twin


def _source(py, filename: str) -> str:
    """The source of the function ``py``, dedented, from its first decorator to its end:
    ``inspect.getsource``'s text.  A module-level function's lines are read from one parse
    of its file, shared by every function of it (``getsource`` tokenizes from the
    function on, for each: a quarter of a second for a large generated module's twins)."""
    first = py.__code__.co_firstlineno
    lines = linecache.getlines(filename, py.__globals__)
    end = _ends(filename, len(lines), hash(tuple(lines))).get(first) if lines else None
    if end is None:
        return textwrap.dedent(inspect.getsource(py))
    return textwrap.dedent("".join(lines[first - 1:end]))


@functools.lru_cache(maxsize=32)
def _ends(filename: str, n: int, key: int) -> dict[int, int]:
    """Per module-level function of the file (read through linecache; ``n`` and ``key``:
    its lines' count and hash, so that a changed file is parsed again), its first line
    (its first decorator's) -> its last line."""
    lines = linecache.getlines(filename)
    try:
        tree = ast.parse("".join(lines))
    except (SyntaxError, ValueError):
        return {}
    return {min([node.lineno] + [d.lineno for d in node.decorator_list]): node.end_lineno
            for node in tree.body if isinstance(node, ast.FunctionDef)}


def _looks_up(code, name: str) -> bool:
    """Whether ``code`` (or code nested in it) loads the global ``name``."""
    if any(i.opname == "LOAD_GLOBAL" and i.argval == name for i in dis.get_instructions(code)):
        return True
    return any(_looks_up(c, name) for c in code.co_consts if isinstance(c, types.CodeType))


def _names(code) -> set[str]:
    """The names ``code`` and the code nested in it look up (attribute names included)."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _names(const)
    return names


def _global(owner: str, name: str, value, error_model: str = "numpy"):
    """The twin's value of a global name of the function ``owner``."""
    if _dispatcher(value):
        return interpreted(value)
    if value is math:
        return MATH
    if value is np:
        return NUMPY
    if isinstance(value, types.ModuleType):
        if value.__name__.split(".")[0] in ("phasemap",) or value.__name__.startswith(
                "phasemap_kernel_"):
            return _Module(owner, value, error_model)
        raise Unsupported(f"{owner} uses the module {value.__name__}, which the interpreter "
                          "tier does not reproduce")
    twin = _BY_IDENTITY.get(id(value))
    if twin is not None:
        return twin
    if isinstance(value, type) or not callable(value):
        return value  # a number, an array, a tuple, a class (a named tuple's)
    if isinstance(value, types.FunctionType) and value.__module__.split(".")[0] == "phasemap":
        return _python_twin(value, error_model)
    raise Unsupported(f"{owner} calls {name} ({value!r}), which the interpreter tier does "
                      "not reproduce (only jitted code and the C library's functions)")


class _Module:
    """One of phasemap's modules as a twin sees it: each name taken as :func:`_global` takes
    a global (jitted functions as their twins), when first used."""

    def __init__(self, owner: str, module, error_model: str):
        self._owner, self._module, self._errors = owner, module, error_model

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        value = _global(self._owner, f"{self._module.__name__}.{name}",
                        getattr(self._module, name), self._errors)
        setattr(self, name, value)
        return value


def _identities() -> dict:
    """Functions a twin may call, by identity: the C library's through the safe versions,
    the exact ones as they are, numba's ``prange`` as ``range``."""
    import numba

    table = {id(getattr(math, n)): getattr(MATH, n) for n in _ELEMENTARY}
    table.update({id(getattr(np, n)): f for n, f in _NUMPY.items()})
    for n in _EXACT_MATH:
        value = getattr(math, n)
        if callable(value):
            table[id(value)] = value
    for n in _EXACT_NUMPY:
        value = getattr(np, n, None)
        if callable(value) and not isinstance(value, type):
            table[id(value)] = value
    table[id(numba.prange)] = range
    table.update({id(getattr(math, n)): f for n, f in _SPECIAL_MATH.items()})
    table.update({id(getattr(np, n)): f for n, f in _SPECIAL_NUMPY.items()})
    return table


_BY_IDENTITY = _identities()
#: the objects of :data:`_BY_IDENTITY`'s registered keys, held so that an id is never reused
_REGISTERED: list = []


def register(compiled, twin) -> None:
    """Let twins call ``twin`` where the compiled code calls ``compiled``: an intrinsic
    (which has no Python of its own), with a Python function that does what its machine
    code does (:func:`phasemap.core.tiers.at_address`: the function at an address)."""
    with _LOCK:
        _REGISTERED.append(compiled)
        _BY_IDENTITY[id(compiled)] = twin
