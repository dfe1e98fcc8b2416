"""``njit`` that compiles one machine-code function per argument types, not per constant.

numba types a constant argument of a call between compiled functions as a literal
(``Literal[bool](True)``, ``Literal[int](4)``) and compiles the callee once per literal:
``_march(..., True, ...)`` and ``_march(..., False, ...)`` were two compilations of
the tracer's largest function, and ``_push`` with its six kinds of vertex six.  On the
README's rod, the bifurcation tracer's first ``boundaries`` compiled 16 of its functions
two to six times each: 88 s of CPU from empty caches, 77 s with this decorator.

The functions decorated here type every argument without its literal value
(:func:`numba.types.unliteral`): one compilation per argument types, as a call from
Python gets.  The constants still reach the machine code: LLVM propagates them where it
inlines a small function, and a large one branches on them at run time, which costs
nothing against its work.  Everything else is numba's ``njit``: the same options, the
same on-disk cache, a subclass of numba's dispatcher (so the interpreter tier, the
kernel cache and ``calls.address`` treat it as any other).

>>> from phasemap.core.jit import njit
>>> @njit(cache=False)
... def add(x, k):
...     return x + k
>>> @njit(cache=False)
... def twice():
...     return add(1.0, 1) + add(1.0, 2)
>>> twice(), add.signatures
(5.0, [(float64, int64)])
"""

from __future__ import annotations

from numba import types
from numba.core.registry import CPUDispatcher

__all__ = ["njit"]


class Dispatcher(CPUDispatcher):
    """numba's CPU dispatcher, typing a compiled caller's constant arguments by their
    types alone."""

    def get_call_template(self, args, kws):
        return super().get_call_template(tuple(types.unliteral(a) for a in args),
                                         {k: types.unliteral(v) for k, v in kws.items()})


def njit(*args, **options):
    """``numba.njit`` (the same options) with the :class:`Dispatcher` above; also usable
    bare, ``@njit``, and with a signature first, as numba's."""
    if args and callable(args[0]) and not isinstance(args[0], (str, types.Type)):
        return njit(**options)(args[0])
    sigs = args[0] if args else None
    cache = options.pop("cache", False)
    local_types = options.pop("locals", {})
    targetoptions = {**options, "nopython": True}

    def wrap(fn):
        disp = Dispatcher(py_func=fn, locals=local_types, targetoptions=targetoptions)
        if cache:
            disp.enable_caching()
        if sigs is not None:
            for sig in sigs if isinstance(sigs, (list, tuple)) else [sigs]:
                disp.compile(sig)
            disp.disable_compile()
        return disp

    return wrap
