"""Check the user's arguments once, at the public entry points, before any work.

Every public entry point (:func:`phasemap.classify`, :class:`phasemap.Scene`,
:meth:`phasemap.Scene.compute`, :func:`phasemap.simulate`,
:func:`phasemap.motion.phase.phase_curve`, the command line) takes Python and NumPy
scalars alike and refuses anything else with **one** exception that names the
argument, never an ``OverflowError``, a ``KeyError`` or a numba error from deep
inside.

What counts as a number
-----------------------
A *real scalar* is a Python ``int`` or ``float``, a NumPy integer or floating
scalar, a 0-d array of one of those, or any other :class:`numbers.Real`
(``fractions.Fraction``).  Refused, with a :class:`WrongType`:

* ``bool`` and ``numpy.bool_``: ``True`` is not a length or an angle, and
  taking it as 1.0 would hide a mistake;
* ``numpy.datetime64`` and ``numpy.timedelta64``: a date is not a state
  (NumPy would read ``datetime64('2020')`` as 50.0);
* strings, bytes, complex numbers, ``None`` and containers where one number is
  expected.

An integer too large for a double (``10**400``) is a ``ValueError`` that names
the argument and the limit, not an ``OverflowError``.

Errors
------
A wrong *type* raises :class:`WrongType`, which is a ``TypeError`` and
also a ``ValueError``: phasemap promises a ``ValueError`` for bad input, and
code that catches either keeps working.  A wrong *value* raises
``ValueError``.  Every message starts with where the argument went (usually the
model's name) and names the argument.  An unknown name comes with the closest
known ones (:func:`difflib.get_close_matches`).

Examples
--------
>>> import numpy as np
>>> from phasemap.core import args as _args
>>> _args.real("phi", np.float32(0.5), where="ladder")
0.5
>>> _args.count("max_steps", np.int64(1000))
1000
>>> _args.count("max_steps", 10**30)
Traceback (most recent call last):
...
ValueError: max_steps = 10**30 is too large: at most 9223372036854775807
>>> _args.parse_real("2*pi/3", "phi")
2.0943951023931953
>>> _args.check_name("layer", "n_solution", ["n_solutions", "stagnation"], where="ladder")
Traceback (most recent call last):
...
ValueError: ladder: unknown layer 'n_solution'; did you mean 'n_solutions'? (allowed: n_solutions, stagnation)
"""

from __future__ import annotations

import ast
import difflib
import math
import numbers
import operator
import os
import pathlib
import stat
from typing import Iterable, Mapping

import numpy as np

#: The largest count (a number of steps, events, stages or cells): the kernels' int64.
MAX_COUNT = int(np.iinfo(np.int64).max)
#: The longest arithmetic expression :func:`parse_real` reads.
MAX_EXPRESSION = 200


#: Types that NumPy or Python count as numbers but that are no state or parameter
#: (``numpy.timedelta64`` is even a NumPy integer).
_NOT_NUMBERS = (bool, np.bool_, np.datetime64, np.timedelta64)


class WrongType(TypeError, ValueError):
    """An argument of the wrong type.  A ``TypeError``, and also a ``ValueError`` so that
    ``except ValueError`` catches every kind of bad input, as phasemap documents."""


def _prefix(where: str) -> str:
    return f"{where}: " if where else ""


def describe(value) -> str:
    """``value`` for a message: short, with its type where the repr does not show it
    (and never an error, not even for an integer of thousands of digits)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**20:
        # the digits without str(), which refuses integers of more than 4300 digits
        digits = int((abs(value).bit_length() - 1) * math.log10(2)) + 1
        digits += abs(value) >= 10**digits
        exact = abs(value) == 10 ** (digits - 1)
        return f"{'-' if value < 0 else ''}10**{digits - 1}" if exact else \
            f"an integer of {digits} digits"
    try:
        text = repr(value)
    except ValueError:  # it holds an integer of more digits than str() converts
        return f"a {type(value).__name__} holding an integer of thousands of digits"
    if len(text) > 60:
        text = text[:57] + "..."
    kind = type(value).__name__
    return text if kind in ("int", "float") else f"{text} ({kind})"


#: Python and NumPy real scalar types, accepted without further checks (not bool).
PLAIN = frozenset({float, int, np.float64, np.float32, np.int64, np.int32})


def _is_real_type(value) -> bool:
    """Whether ``value`` is a real scalar of an accepted type (its size not yet checked)."""
    if type(value) in PLAIN:  # the common case, without the slow ABC check below
        return True
    if isinstance(value, np.ndarray):
        return value.ndim == 0 and value.dtype.kind in "iuf"
    return isinstance(value, numbers.Real) and not isinstance(value, _NOT_NUMBERS)


def real(name: str, value, where: str = "") -> float:
    """``value`` as a Python float, if it is one real scalar.

    Parameters
    ----------
    name:
        the argument's name, for the message.
    value:
        a Python or NumPy integer or float, a 0-d array of one, or another
        :class:`numbers.Real`.
    where:
        what the argument belongs to (a model's name), the message's prefix.

    Returns
    -------
    float
        the value; NaN and infinities pass (check them with :func:`finite`).

    Raises
    ------
    WrongType
        for a bool, a date, a string, a complex number, ``None`` or a container.
    ValueError
        for an integer beyond the range of a double.

    Examples
    --------
    >>> import numpy as np
    >>> real("t_end", np.array(3))
    3.0
    >>> real("phi", True, where="ladder")
    Traceback (most recent call last):
    ...
    phasemap.core.args.WrongType: ladder: phi must be a real number, got True (bool)
    """
    if not _is_real_type(value):
        what = ("one real number, not a sequence"
                if not isinstance(value, (str, bytes, Mapping)) and _has_dimensions(value)
                else "a real number")
        raise WrongType(f"{_prefix(where)}{name} must be {what}, "
                                f"got {describe(value)}")
    try:
        return float(value)
    except OverflowError:
        raise ValueError(f"{_prefix(where)}{name} = {describe(value)} is too large to be "
                         f"represented: |{name}| must be below {np.finfo(float).max:.4g}"
                         ) from None


def finite(name: str, value, where: str = "", *, lower: float = -math.inf,
           upper: float = math.inf, lower_open: bool = False, allow_inf: bool = False) -> float:
    """:func:`real`, then finite (unless ``allow_inf``) and within ``[lower, upper]``.

    ``lower_open`` excludes ``lower`` itself (``lower=0, lower_open=True``: positive).

    >>> finite("rtol", 1e-6, lower=0, lower_open=True)
    1e-06
    >>> finite("atol", -1, where="ladder", lower=0, lower_open=True)
    Traceback (most recent call last):
    ...
    ValueError: ladder: atol must be a positive number, got -1
    """
    x = real(name, value, where)
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        raise ValueError(f"{_prefix(where)}{name} must be finite, got {x!r}")
    if x < lower or (lower_open and x == lower):
        what = ("a positive number" if lower == 0 and lower_open
                else f"{'>' if lower_open else '>='} {bound(lower)}")
        raise ValueError(f"{_prefix(where)}{name} must be {what}, got {describe(value)}")
    if x > upper:
        raise ValueError(f"{_prefix(where)}{name} must be <= {bound(upper)}, "
                         f"got {describe(value)}")
    return x


def finite_range(name: str, value, where: str = "", ends: tuple[str, str] = ("lo", "hi")
                 ) -> tuple[float, float]:
    """A range ``(lo, hi)`` of two finite numbers with lo < hi, or ValueError naming ``name``.

    ``ends`` are the words the messages call the two ends by.

    >>> finite_range("axis f", (0, 3))
    (0.0, 3.0)
    >>> finite_range("phi_range", (1, 0), "ladder", ("low", "high"))
    Traceback (most recent call last):
    ...
    ValueError: ladder: phi_range must be finite with low < high, got (1, 0) (tuple)
    """
    lo_word, hi_word = ends
    try:
        if isinstance(value, (str, bytes)):
            raise TypeError
        lo, hi = (real(name, t, where) for t in value)
    except (TypeError, ValueError):
        raise ValueError(f"{_prefix(where)}{name} must be two numbers ({lo_word}, {hi_word}), "
                         f"got {describe(value)}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"{_prefix(where)}{name} must be finite with {lo_word} < {hi_word}, "
                         f"got {describe(value)}")
    return lo, hi


def bound(x: float) -> str:
    """A bound written exactly: ``1.5707963267948966``, not ``1.5708``; ``0``, not ``0.0``.

    >>> bound(1.0), bound(float("inf")), bound(3.141592653589793 / 2)
    ('1', 'inf', '1.5707963267948966')
    """
    short = f"{x:g}"
    return short if float(short) == x else repr(float(x))


def count(name: str, value, where: str = "", *, least: int = 1,
          most: int = MAX_COUNT) -> int:
    """``value`` as a Python int in ``[least, most]``.

    A Python or NumPy integer (or a 0-d integer array); a float only when it is a
    whole number (``1e6``).  ``bool`` is refused.

    >>> count("max_events", 1e3)
    1000
    >>> count("max_events", 2.5, where="ladder")
    Traceback (most recent call last):
    ...
    ValueError: ladder: max_events must be a whole number, got 2.5
    """
    if isinstance(value, (int, np.integer)) and not isinstance(value, _NOT_NUMBERS):
        n = int(value)
    elif isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iu":
        n = int(value)
    else:
        x = real(name, value, where)
        if not (math.isfinite(x) and x == int(x)):
            raise ValueError(f"{_prefix(where)}{name} must be a whole number, "
                             f"got {describe(value)}")
        n = int(x)
    if n < least:
        raise ValueError(f"{_prefix(where)}{name} must be an integer >= {least}, got {n}")
    if n > most:
        raise ValueError(f"{_prefix(where)}{name} = {describe(n)} is too large: at most "
                         f"{most}")
    return n


def reals(name: str, values, where: str = "") -> np.ndarray:
    """``values`` (a sequence or array of real numbers) as a float array.

    Every element must be a real number as :func:`real` defines; a bool,
    date, string, complex or object array is refused.  NaN and infinities pass
    (the model's domain check refuses them with its own message).

    >>> reals("phi", [0, 1.5, np.float32(2)])
    array([0. , 1.5, 2. ])
    >>> reals("phi", np.array(["2020"], dtype="datetime64[Y]"), where="ladder")
    Traceback (most recent call last):
    ...
    phasemap.core.args.WrongType: ladder: phi must hold real numbers, got datetime64[Y] values
    """
    if isinstance(values, (str, bytes, Mapping)) or values is None:
        raise WrongType(f"{_prefix(where)}{name} must be a sequence of real numbers, "
                                f"got {describe(values)}")
    try:
        a = np.asarray(values)
    except (TypeError, ValueError):  # ragged nesting
        raise WrongType(f"{_prefix(where)}{name} must be a sequence of real numbers, "
                                f"got {describe(values)}") from None
    if a.dtype.kind in "iuf":
        return a.astype(float)
    if a.dtype.kind == "O":  # Python ints beyond int64, or mixed objects: one by one
        out = np.empty(a.shape)
        for index, x in np.ndenumerate(a):
            out[index] = real(f"{name}[{', '.join(map(str, index))}]", x, where)
        return out
    raise WrongType(f"{_prefix(where)}{name} must hold real numbers, got {a.dtype} "
                            "values")


def scalar_or_array(name: str, value, where: str = "") -> float | np.ndarray:
    """:func:`real` for a scalar, :func:`reals` for anything with dimensions."""
    if isinstance(value, (list, tuple, np.ndarray)) and _has_dimensions(value):
        return reals(name, value, where)
    return real(name, value, where)


def path(name: str, value, where: str = "") -> pathlib.Path:
    """``value`` (a ``str`` or an ``os.PathLike``, ``~`` expanded) as a Path.

    >>> path("path", 3.5, "open_atlas")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    phasemap.core.args.WrongType: open_atlas: path must be a file name ..., got 3.5
    """
    if isinstance(value, str) and not value:
        raise ValueError(f"{_prefix(where)}{name} is empty: give a file name")
    if not isinstance(value, (str, os.PathLike)):
        raise WrongType(f"{_prefix(where)}{name} must be a file name (a str or os.PathLike), "
                        f"got {describe(value)}")
    try:
        text = os.fspath(value)
    except TypeError as err:  # a PathLike whose __fspath__ returns something else
        raise WrongType(f"{_prefix(where)}{name}: {err}") from None
    if not isinstance(text, str):
        raise WrongType(f"{_prefix(where)}{name} must be a file name (a str or os.PathLike), "
                        f"got {describe(value)}")
    if "\0" in text:
        raise ValueError(f"{_prefix(where)}{name} {text!r} contains a null character")
    return pathlib.Path(os.path.expanduser(text))


def existing_file(name: str, value, where: str = "") -> pathlib.Path:
    """:func:`path`, which must name an existing regular file: else ValueError, in one
    line that starts with the path (missing, a folder, a device, a name too long)."""
    found = path(name, value, where)
    try:
        mode = found.stat().st_mode
    except FileNotFoundError:
        raise ValueError(f"{found}: no such file") from None
    except OSError as err:
        raise ValueError(f"{found}: {err.strerror or err}") from None
    if stat.S_ISDIR(mode):
        raise ValueError(f"{found}: a folder, not a file")
    if not stat.S_ISREG(mode):
        raise ValueError(f"{found}: not a regular file")
    return found


def mapping(name: str, value, where: str = "", *, none: bool = True) -> dict:
    """``value`` (a mapping with string keys; None when ``none``) as a dict."""
    if value is None and none:
        return {}
    if not isinstance(value, Mapping):
        raise WrongType(f"{_prefix(where)}{name} must be a mapping of names to values "
                        f"(a dict), got {describe(value)}")
    for key in value:
        if not isinstance(key, str):
            raise WrongType(f"{_prefix(where)}{name}: a name must be a string, got "
                            f"{describe(key)}")
    return dict(value)


def suggest(name: str, known: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest of ``known`` to ``name``, or ``""``."""
    if not isinstance(name, str):
        return ""
    close = difflib.get_close_matches(name, list(known), n=3, cutoff=0.6)
    if not close:
        return ""
    return "; did you mean " + " or ".join(repr(c) for c in close) + "?"


def unknown(kind: str, name, known: Iterable[str], where: str = "", listing: str = "") -> str:
    """The message for an unknown ``kind`` (variable, layer, model ...) called ``name``:
    the closest known names, then ``listing`` (by default ``allowed: a, b, c``; for a
    long list, say where to find it).

    >>> unknown("variable", "ph", ["phi", "omega"], where="ladder")
    "ladder: unknown variable 'ph'; did you mean 'phi'? (allowed: phi, omega)"
    """
    known = list(known)
    listing = listing or f"allowed: {', '.join(known)}"
    hint = suggest(name, known)
    shown = repr(name) if isinstance(name, str) else describe(name)
    return (f"{_prefix(where)}unknown {kind} {shown}{hint} ({listing})" if hint
            else f"{_prefix(where)}unknown {kind} {shown}; {listing}")


def check_name(kind: str, name, known: Iterable[str], where: str = "",
               listing: str = "") -> str:
    """``name`` if it is one of ``known``; else a ValueError from :func:`unknown` (an
    :class:`WrongType` for a name that is not a string)."""
    known = list(known)
    if not isinstance(name, str):
        raise WrongType(f"{_prefix(where)}a {kind} name must be a string, "
                                f"got {describe(name)}")
    if name not in known:
        raise ValueError(unknown(kind, name, known, where, listing))
    return name


def values(given: Mapping[str, object], known: Iterable[str], where: str = "",
           kind: str = "variable") -> dict[str, object]:
    """Check the names of ``given`` against ``known`` and each value with
    :func:`scalar_or_array`; return the coerced values."""
    known = list(known)
    for name in given:
        check_name(kind, name, known, where)
    return {name: scalar_or_array(name, value, where) for name, value in given.items()}


def scalars(given: Mapping[str, object], known: Iterable[str], where: str = "",
            hint: str = "") -> dict[str, float]:
    """Check the names of ``given`` against ``known`` and make each value a float with
    :func:`real`; a sequence is refused as ``"<name> must be a scalar"`` and ``hint``
    (say what takes arrays).

    >>> scalars({"phi": [0.1, 0.2]}, ["phi"], "ladder", "; use a Scene for arrays")
    Traceback (most recent call last):
    ...
    ValueError: ladder: phi must be a scalar; use a Scene for arrays
    """
    known = list(known)
    for name in given:
        check_name("variable", name, known, where)
    out = {}
    for name, value in given.items():
        if not isinstance(value, (str, bytes)) and _has_dimensions(value):
            raise ValueError(f"{_prefix(where)}{name} must be a scalar{hint}")
        out[name] = real(name, value, where)
    return out


def _has_dimensions(value) -> bool:
    if type(value) in PLAIN:
        return False
    try:
        return np.ndim(value) > 0
    except (TypeError, ValueError):  # ragged nesting: a sequence all the same
        return True


def layers(given, known: Iterable[str], where: str = "", listing: str = "") -> list[str]:
    """The layer names asked for, in order, without repeats.

    A single string is one layer (``layers="n_solutions"``); otherwise a
    sequence of strings.  Each must be one of ``known``.

    >>> layers("n_solutions", ["n_solutions", "stagnation"])
    ['n_solutions']
    """
    if isinstance(given, str):
        given = [given]
    if isinstance(given, (bytes, Mapping)) or not isinstance(given, Iterable) or (
            isinstance(given, np.ndarray) and given.ndim == 0):
        raise WrongType(f"{_prefix(where)}layers must be a layer name or a list of "
                                f"them, got {describe(given)}")
    names = list(given)
    for name in names:
        if not isinstance(name, str):
            raise WrongType(f"{_prefix(where)}layers must be layer names (strings), "
                                    f"got {describe(name)}")
    names = list(dict.fromkeys(names))
    known = list(known)
    for name in names:
        check_name("layer", name, known, where, listing)
    if not names:
        raise ValueError(f"{_prefix(where)}layers is empty: a scene needs at least one layer")
    return names


def chunks(given, axes: Mapping[str, int], where: str = ""):
    """Dask chunks of a scene, checked: ``None``, ``"auto"``, one int for every axis,
    or ``{axis: int}``.  Returns ``None``, ``"auto"`` or ``{axis: int}`` with every
    axis, each size clipped to its axis.

    >>> chunks(64, {"phi": 100, "f": 10})
    {'phi': 64, 'f': 10}
    >>> chunks("a", {"phi": 100})
    Traceback (most recent call last):
    ...
    phasemap.core.args.WrongType: chunks must be an int, a mapping {axis: int}, 'auto' or None, got 'a' (str)
    """
    if given is None or (isinstance(given, str) and given == "auto"):
        return given
    if isinstance(given, Mapping):
        sizes = {}
        for name, size in given.items():
            check_name("chunks axis", name, axes, where,
                       f"not an axis of this scene; its axes: {', '.join(axes)}")
            sizes[name] = count(f"chunks[{name!r}]", size, where)
    elif isinstance(given, (str, bytes)) or not (
            isinstance(given, (numbers.Real, np.ndarray)) and np.ndim(given) == 0):
        raise WrongType(f"{_prefix(where)}chunks must be an int, a mapping "
                                f"{{axis: int}}, 'auto' or None, got {describe(given)}")
    else:
        size = count("chunks", given, where)
        sizes = {name: size for name in axes}
    return {name: min(sizes.get(name, n), n) for name, n in axes.items()}


_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
              ast.Div: operator.truediv}
_UNARY = {ast.UAdd: operator.pos, ast.USub: operator.neg}
_CONSTANTS = {"pi": math.pi}


def parse_real(text: str, name: str, where: str = "") -> float:
    """A number written as text: a decimal (``1.5708``, ``-3e-2``) or arithmetic on
    numbers and ``pi`` with ``+ - * /`` and parentheses (``pi/2``, ``2*pi/3``,
    ``-(pi - 0.1)``).

    The text is parsed, never evaluated as code: only those operations are
    read, anything else is refused.

    >>> parse_real("-pi", "phi"), parse_real("(1 + 2) * 0.5", "f")
    (-3.141592653589793, 1.5)
    >>> parse_real("__import__('os')", "phi")
    Traceback (most recent call last):
    ...
    ValueError: phi: "__import__('os')" is not a number (write a decimal, or arithmetic with pi, + - * / and parentheses, such as pi/2)
    """
    text = str(text).strip()
    try:
        return float(text)  # nan and inf too: the domain check says what is wrong
    except ValueError:
        pass
    bad = ValueError(f"{_prefix(where)}{name}: {text!r} is not a number (write a decimal, or "
                     "arithmetic with pi, + - * / and parentheses, such as pi/2)")
    if not text or len(text) > MAX_EXPRESSION:
        raise bad
    try:
        tree = ast.parse(text, mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        raise bad from None

    def value(node) -> float:
        if isinstance(node, ast.Expression):
            return value(node.body)
        if isinstance(node, ast.Constant) and _is_real_type(node.value):
            return real(name, node.value, where)
        if isinstance(node, ast.Name) and node.id in _CONSTANTS:
            return _CONSTANTS[node.id]
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](value(node.operand))
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            left, right = value(node.left), value(node.right)
            if isinstance(node.op, ast.Div) and right == 0:
                raise ValueError(f"{_prefix(where)}{name}: {text!r} divides by zero")
            return _OPERATORS[type(node.op)](left, right)
        raise bad

    try:
        return value(tree)
    except RecursionError:
        raise bad from None
