"""How a shared compiled driver calls a model's compiled function: at its address.

The drivers that serve every model are compiled once and cached on disk:
- the grid evaluator's parallel driver (:func:`phasemap.core.codegen.driver`);
- the integrator's fate and batch drivers (:mod:`phasemap.motion.integrate`);
- the bifurcation tracer's entry points (:mod:`phasemap.bifurcation._trace`).

What is particular to a model reaches them as the address of its compiled code, an
``intp`` argument (:func:`address`). The driver calls it with an intrinsic written for
the function's signature (:func:`typer`), in numba's own calling convention, and an
exception the function raises propagates as from any compiled call.

numba's first-class functions (``types.FunctionType``) did this job before, for the grid,
fate and batch drivers. They cost three things:
- the dispatcher typed them again at every call (0.1 to 0.3 ms);
- each call was lowered with a second path that asks Python for the address where it is
  missing, a few hundred instructions;
- that path kept LLVM from inlining the small helpers around the call, and each helper
  then counted references to its array arguments with atomic instructions.

A model's own kernels are made another way: the integrator and the phase tracer compile
their templates per model with the model's functions as globals
(:func:`phasemap.core.compile.specialize`). There the model's code is compiled into the
kernel and inlined into its loop; it is not called at all.

Keep the dispatcher of a function whose address a driver holds: its machine code lives
as long as the dispatcher does.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils

from phasemap.core.memo import Memo

#: (a compiled function; argument types) -> the address of its machine code; the entry
#: holds the function, so that the code stays loaded while its address is known
_ADDRESSES = Memo("calls.addresses")


def address(dispatcher, args) -> int:
    """The address of the machine code of ``dispatcher``'s overload for the argument
    types ``args`` (compiled or loaded from the cache first where it is missing), as
    :func:`call` calls it; found once per process (a look-up after)."""
    args = tuple(args)
    return _ADDRESSES.get((dispatcher,), args, lambda: _address(dispatcher, args))


def _address(dispatcher, args: tuple) -> int:
    if args not in dispatcher.overloads:
        dispatcher.compile(args)
    cres = dispatcher.overloads[args]
    return cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)


def call(context, builder, at, fsig, args):
    """In an intrinsic's code: call the function of signature ``fsig`` at the address
    ``at`` (an LLVM ``intp``) with ``args``, propagating its exception status; its
    result (a new reference, as every compiled call returns)."""
    fnty = context.call_conv.get_function_type(fsig.return_type, fsig.args).as_pointer()
    fn = builder.inttoptr(at, fnty)
    status, res = context.call_conv.call_function(builder, fn, fsig.return_type, fsig.args,
                                                  args)
    with cgutils.if_unlikely(builder, status.is_error):
        context.call_conv.return_status_propagate(builder, status)
    return res


def typer(fsig, at, args, index: int | None = None, table=None):
    """The signature and code of an intrinsic that calls a function of signature
    ``fsig`` with the argument types ``args``; None (no match) where they are not
    ``fsig``'s.

    The address ``at`` is an ``intp``, or with ``index`` element ``index`` of a tuple of
    addresses of the type ``table`` (a model's set of functions, passed as one
    argument).
    """
    args = tuple(types.unliteral(a) for a in args)
    if args != tuple(fsig.args):
        return None
    if index is None:
        if types.unliteral(at) != types.intp:
            return None
    elif at != table:
        return None

    def codegen(context, builder, sig, llargs):
        ptr = llargs[0] if index is None else builder.extract_value(llargs[0], index)
        res = call(context, builder, ptr, fsig, llargs[1:])
        if fsig.return_type == types.none:
            return context.get_dummy_value()
        return res

    return fsig.return_type(types.intp if index is None else table, *args), codegen

