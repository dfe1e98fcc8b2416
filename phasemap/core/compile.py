"""Per-model kernels from module-level templates, cached in memory and on disk.

A template is a plain Python function that reads the model's jitted functions
and its compile-time layout from *globals* (``POINT``, ``N_BRANCHES`` ...).
:func:`specialize` gives each model a copy of the template with its own
globals and compiles it once; :func:`contract_constants` is the set of globals
every engine (the integrator, the phase-curve tracer) starts from.  Closures
would be simpler, but numba's on-disk cache key pickles closure cells, and
dispatchers pickle with a per-process identity, so a closure kernel recompiles
in every process; globals are not in the key.  The copy is named after a hash
of every source compiled into it, because numba invalidates a cached function
when its own file changes, not when a function it calls does: a template's
module lists the other modules its kernels call in ``SOURCES``.
"""

from __future__ import annotations

import hashlib
import sys
import types

import numpy as np
from numba import njit

from phasemap.core.memo import Memo
from phasemap.core import codegen as _codegen
from phasemap.core import numerics as nx
from phasemap.core import events
from phasemap.core.model import Model

#: (kind, model name, source hash) -> the template compiled for that model
_CACHE = Memo("compile.specialized")
#: an engine's key -> what it built for the model under that key (the latest model)
_BUILT = Memo("compile.built", replace=True)


def specialize(template, model: Model, kind: str, parallel: bool = False, inline: bool = False,
               counts: bool = True, **constants):
    """The template compiled for ``model`` with ``constants`` as its globals.

    With ``inline`` the function is marked for LLVM to inline into its callers
    (``forceinline``): for small per-step helpers, whose calls would pass arrays
    as structs by value.  Unlike numba's IR inlining, the helper is compiled
    once, not once per call site.  ``inline="ir"`` inlines it into numba's IR of
    its (one) caller instead: it is never compiled on its own, where a called
    function's code is optimised and generated once in its own library and again
    in each caller's.

    ``counts=False`` compiles it without numba's reference counts (``_nrt=False``), for a
    helper that allocates no array and returns none (numba refuses an allocation there):
    the counts of its array arguments, raised and lowered around its calls, are atomic
    operations that cost more than a small helper's arithmetic (the integrator's step
    pieces: a wheel fate cell 37-39 -> 33-34 us, the same bits).
    """
    module = sys.modules[template.__module__]
    digest = source_hash(model, module, *getattr(module, "SOURCES", ()))
    key = (kind, model.name, digest)

    def make():
        scope = dict(template.__globals__)
        scope.update(constants)
        name = f"{kind}_{model.name}_{digest}"
        fn = types.FunctionType(template.__code__, scope, name)
        fn.__qualname__ = name  # one on-disk cache index per model and source
        fn.__doc__ = template.__doc__
        if inline == "ir":
            return njit(cache=True, inline="always", error_model="numpy")(fn)
        lean = {} if counts else {"_nrt": False}
        if inline:
            return njit(cache=True, forceinline=True, error_model="numpy", **lean)(fn)
        return njit(parallel=parallel, cache=True, error_model="numpy", **lean)(fn)

    return _CACHE.get((), key, make)


def remember(key, model: Model, build):
    """``build()`` for ``model``, once per process under ``key`` (a new model object of
    the same name, such as a reloaded declaration, is built anew).  The engines keep
    their compiled kernels here, so that a call after the first looks them up."""
    return _BUILT.get((model,), key, build)


def source_hash(model: Model, *modules) -> str:
    """Hash of the model's module, the shared numerics and events, this module and
    ``modules`` (the engines look their kernels up once per process, see
    :func:`remember`, so a call after the first does not hash)."""
    h = hashlib.sha256()
    for module in (sys.modules[model.candidates[0].func.py_func.__module__], nx, events,
                   _codegen, sys.modules[__name__], *modules):
        h.update(_codegen.file_digest(module.__file__))
    # the generated contract's module name hashes its text and what it imports:
    # a compiled kernel that calls it must not outlive it (declared models are
    # generated files whose names change with the declaration)
    h.update(model.contract.__name__.encode())
    return h.hexdigest()[:12]


def contract_constants(model: Model) -> dict:
    """The compile-time globals every engine's templates start from.

    The generated contract (``POINT``, the inlined ``BRANCH_ROW``, ``DERIVE``,
    ``DOMAIN`` and ``REST_SPEED``), the branch layout (``STICK``, ``N_BRANCHES``,
    ``N_FIELDS``, ``DIRECTIONS``, the row columns of the ``REACTIONS``) and,
    for a model that moves, the integrated state: ``N_DOF`` coordinates,
    ``Y_SLOT`` (the input slot of each integrated variable, positions then
    velocities; -1 for a position that is not an input), ``ACC_COL`` (the row
    column of each coordinate's acceleration), ``VEL_Y`` (the index of the
    relative velocity in the integrated state), ``STICK_IS_REST``, the bounds
    ``LOWER``, ``UPPER`` of the integrated variables, and per branch the finite bound
    it exists only on, ``BOUND_ROW`` (``2 i + side`` for variable ``i``; -1: none).
    """
    contract = model.contract
    consts = dict(
        POINT=contract.point, BRANCH_ROW=contract.branch_row_inline,
        DERIVE=contract.derive_inline, DOMAIN=contract.domain_inline,
        REST_SPEED=contract.rest_speed_inline,
        STICK=model.stick_branch, N_BRANCHES=len(model.branches), N_FIELDS=model.n_fields,
        DIRECTIONS=np.array(model.directions, dtype=np.float64),
        REACTIONS=np.arange(model.first_reaction, model.n_fields, dtype=np.int64),
    )
    dyn = model.dynamics
    if dyn is None:
        return consts
    slot = {n: i for i, n in enumerate(model.inputs)}
    variables = {**model.variables, **{p.name: p for p in dyn.positions}}
    positions = [c[0] for c in dyn.coordinates]
    velocities = [c[1] for c in dyn.coordinates]
    acc_names = [a.name for a in model.accelerations]
    consts.update(
        N_DOF=len(dyn.coordinates),
        Y_SLOT=np.array([slot.get(n, -1) for n in positions + velocities], dtype=np.int64),
        ACC_COL=np.array([nx.FIRST_ACC + acc_names.index(c[2]) for c in dyn.coordinates],
                         dtype=np.int64),
        VEL_Y=len(positions) + velocities.index(model.velocity),
        STICK_IS_REST=dyn.stick_is_rest,
        LOWER=np.array([variables[n].lower for n in positions + velocities]),
        UPPER=np.array([variables[n].upper for n in positions + velocities]),
    )
    consts["BOUND_ROW"] = bound_rows(model, positions + velocities, consts["LOWER"],
                                      consts["UPPER"])
    return consts


def bound_rows(model: Model, names: list, lower, upper) -> np.ndarray:
    """Per branch, ``2 i + side`` where it exists only on the finite bound ``side`` (0
    lower, 1 upper) of the integrated variable ``names[i]``, else -1 (see
    :attr:`phasemap.core.model.Candidate.bound`; a bound that depends on parameters is infinite
    in ``lower``, ``upper`` and not marked)."""
    rows = np.full(len(model.candidates), -1, dtype=np.int64)
    for k, b in enumerate(model.candidates):
        if b.bound is not None and b.bound[0] in names:
            i = names.index(b.bound[0])
            if np.isfinite((lower, upper)[b.bound[1]][i]):
                rows[k] = 2 * i + b.bound[1]
    return rows


@njit(cache=True)
def grow(a, n):
    """``a`` (2-D) with at least ``n`` rows, keeping its content (doubling, so that
    appending one row at a time costs amortised O(1))."""
    if n <= a.shape[0]:
        return a
    b = np.empty((max(n, 2 * a.shape[0]), a.shape[1]))
    b[:a.shape[0]] = a
    return b
