"""Per-model kernels from module-level templates, cached in memory and on disk.

A template is a plain Python function that reads the model's jitted functions
and its compile-time layout from *globals* (``POINT``, ``N_BRANCHES`` ...).
:func:`specialize` gives each model a copy of the template with its own
globals and compiles it once.  Closures would be simpler, but numba's on-disk
cache key pickles closure cells, and dispatchers pickle with a per-process
identity, so a closure kernel recompiles in every process; globals are not in
the key.  The copy is named after a hash of every source compiled into it,
because numba invalidates a cached function when its own file changes, not
when a function it calls does.
"""

from __future__ import annotations

import hashlib
import sys
import types

from numba import njit

from . import _codegen, _numerics as nx
from . import events
from .model import Model

_CACHE: dict[tuple[str, str], object] = {}


def specialize(template, model: Model, kind: str, parallel: bool = False, inline: bool = False,
               **constants):
    """The template compiled for ``model`` with ``constants`` as its globals.

    With ``inline`` the function is marked for LLVM to inline into its callers
    (``forceinline``): for small per-step helpers, whose calls would pass arrays
    as structs by value.  Unlike numba's IR inlining, the helper is compiled
    once, not once per call site.
    """
    digest = source_hash(model, sys.modules[template.__module__])
    key = (kind, model.name, digest)
    kernel = _CACHE.get(key)
    if kernel is None:
        scope = dict(template.__globals__)
        scope.update(constants)
        name = f"{kind}_{model.name}_{digest}"
        fn = types.FunctionType(template.__code__, scope, name)
        fn.__qualname__ = name  # one on-disk cache index per model and source
        fn.__doc__ = template.__doc__
        if inline:
            kernel = _CACHE[key] = njit(cache=True, forceinline=True, error_model="numpy")(fn)
        else:
            kernel = _CACHE[key] = njit(parallel=parallel, cache=True, error_model="numpy")(fn)
    return kernel


def source_hash(model: Model, *modules) -> str:
    """Hash of the model's module, the shared numerics and events, and ``modules``."""
    h = hashlib.sha256()
    for module in (sys.modules[model.candidates[0].func.py_func.__module__], nx, events,
                   _codegen, *modules):
        h.update(_codegen.file_digest(module.__file__))
    # the generated contract's module name hashes its text and what it imports:
    # a compiled kernel that calls it must not outlive it (declared models are
    # generated files whose names change with the declaration)
    h.update(model.contract.__name__.encode())
    return h.hexdigest()[:12]
