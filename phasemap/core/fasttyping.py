"""numba types each scalar operation of a function once per process, not once per use.

numba's type inference resolves every call in a function (``a * b``, ``math.sin(x)``,
``abs(u)``) through :meth:`numba.core.types.functions.BaseFunction.get_call_type`,
which tries the templates registered for the operation one by one (for ``*``: numbers,
arrays through their ufunc, lists, tuples, strings, timedeltas, ...) every time it meets
it.  phasemap's generated kernels are long straight-line arithmetic: the drawer's
condition gradients are 33 573 such calls, and resolving them was a quarter of their
compile (46 s of CPU of -O1 compile; 33 s with this).

:func:`install` memoises the answer for the calls whose arguments are plain scalars
(numba's ``Float``, ``Integer`` and ``Boolean`` types, without literal values) and no
keywords: the operation's type, the typing context and the argument types decide the
signature, and numba records the template's implementation key on the first answer
(``_impl_keys``), which lowering reads.  Every other call (arrays, tuples, literals,
keywords, a call that fails to type) goes through numba unchanged.  The machine code is
the same: only how fast numba finds the signature changes.

>>> install(); install()   # once per process, however often it is called
>>> import numba
>>> numba.njit(lambda x, y: x * y + abs(x))(2.0, 3.0)
8.0
"""

from __future__ import annotations

import threading

__all__ = ["install", "installed"]

_STATE = {"installed": False}
#: (id of the operation's type, id of the typing context, argument types) -> (the
#: operation's type, the context, the signature): the objects are held, so that an id
#: is never another object's
_MEMO: dict = {}
_LOCK = threading.Lock()


def installed() -> bool:
    """Whether :func:`install` has patched numba in this process."""
    return _STATE["installed"]


def install() -> None:
    """Memoise numba's typing of scalar calls (once per process; a numba whose
    ``BaseFunction.get_call_type`` is missing is left as it is)."""
    with _LOCK:
        if _STATE["installed"]:
            return
        from numba.core import types
        from numba.core.types import functions

        original = getattr(functions.BaseFunction, "get_call_type", None)
        if original is None:
            return
        scalars = (types.Float, types.Integer, types.Boolean)

        def get_call_type(self, context, args, kws):
            if kws or not all(type(a) in scalars for a in args):
                return original(self, context, args, kws)
            key = (id(self), id(context), args)
            seen = _MEMO.get(key)
            if seen is not None and seen[0] is self and seen[1] is context:
                return seen[2]
            sig = original(self, context, args, kws)
            if sig is not None:
                _MEMO[key] = (self, context, sig)
            return sig

        get_call_type.__wrapped__ = original
        get_call_type.__doc__ = original.__doc__
        functions.BaseFunction.get_call_type = get_call_type
        _STATE["installed"] = True
