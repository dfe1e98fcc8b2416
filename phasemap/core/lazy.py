"""xarray, imported where phasemap first makes or reads a Dataset, not by ``import phasemap``.

xarray (with pandas) is about half of what ``import phasemap`` cost: 0.6-0.8 s of CPU
on the machines of BENCHMARKS.md, paid by every process, also one that only classifies
a state or writes no Dataset.  Each phasemap module that uses it reads it through
:data:`xarray`, a stand-in whose first attribute imports the real module::

    from phasemap.core.lazy import xarray as xr
    ...
    xr.Dataset(...)        # imports xarray here, once, then reads its Dataset

:func:`when_imported` runs a function as soon as a module is imported, by whoever
imports it: the ``ds.phasemap`` accessor is registered on xarray's Dataset the moment
xarray is imported, by phasemap or by the user's ``import xarray``, so
``xr.open_dataset(path).phasemap`` works after ``import phasemap`` as before.

xarray's first Variable imported ``dask.array`` (0.9 s of CPU, as long as xarray's own
import) to ask whether a NumPy array is a dask array; :func:`dask_checked_lazily`, which
runs as xarray is imported, lets it ask that without importing dask, which a process
that never makes a dask array then never does.

>>> import sys, phasemap
>>> from phasemap.core.lazy import xarray as xr
>>> xr.Dataset().phasemap.__class__.__name__        # imported, accessor registered
'PhasemapAccessor'
"""

from __future__ import annotations

import importlib
import importlib.abc
import sys
import threading
from collections.abc import Callable

__all__ = ["xarray", "when_imported", "dask_checked_lazily"]


class _Module:
    """A stand-in for the module ``name``: any attribute imports it and reads its own,
    which the stand-in then keeps (a second read is an ordinary attribute's)."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr: str):
        value = getattr(importlib.import_module(self._name), attr)
        setattr(self, attr, value)
        return value

    def __repr__(self) -> str:
        return f"<module {self._name!r}, imported on first use>"


#: xarray, imported on its first attribute
xarray = _Module("xarray")

_LOCK = threading.Lock()
_WAITING: dict[str, list[Callable]] = {}


def when_imported(name: str, then: Callable[[object], None]) -> None:
    """Call ``then(module)`` once the top-level module ``name`` has been imported: now if
    it is already, else right after its import ends, whoever imports it."""
    with _LOCK:
        if name not in sys.modules:
            if not _WAITING:
                sys.meta_path.insert(0, _Finder())
            _WAITING.setdefault(name, []).append(then)
            return
    then(sys.modules[name])


def _ran(name: str, module) -> None:
    with _LOCK:
        waiting = _WAITING.pop(name, [])
        if not _WAITING:       # nothing else awaited: the hook leaves the import system
            sys.meta_path[:] = [f for f in sys.meta_path if not isinstance(f, _Finder)]
    for then in waiting:
        then(module)


class _Finder(importlib.abc.MetaPathFinder):
    """Finds a waited-for module with the finders after it, and wraps its loader so that
    the functions waiting for it run when its code has run."""

    def find_spec(self, fullname, path, target=None):
        if fullname not in _WAITING:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None:
                break
        else:
            return None
        if spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        spec.loader = _Loader(spec.loader)
        return spec


class _Loader(importlib.abc.Loader):
    def __init__(self, loader):
        self._loader = loader

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module):
        # the module's own code sees its real loader, as without the hook
        module.__loader__ = module.__spec__.loader = self._loader
        self._loader.exec_module(module)
        _ran(module.__name__, module)

    def __getattr__(self, attr):   # (get_resource_reader, is_package, get_code, ...)
        return getattr(self._loader, attr)


def dask_checked_lazily(xr=None) -> bool:
    """Let xarray test whether an array is a dask array without importing ``dask.array``.

    xarray records each duck-array library in a cache
    (``xarray.namedarray.pycompat._cached_duck_array_modules``) whose entry for dask
    imports ``dask.array`` when first read, and every Variable reads it
    (``isinstance(data, array_type("dask"))``): the first Dataset of a process cost
    0.9 s of CPU more than it does without dask installed.  No object is a dask array
    unless ``dask.array`` has been imported, so the entry put here answers "no such
    type" until then, and from then on is xarray's own (made on the first read after
    the import, and put in the cache in its place).  Returns whether the entry was put;
    where xarray's cache is not as expected, or dask is already imported, nothing is
    changed.  ``xr``: the xarray module (:func:`when_imported` passes it)."""
    try:
        from xarray.namedarray import pycompat
    except ImportError:
        return False
    cache = getattr(pycompat, "_cached_duck_array_modules", None)
    record = getattr(pycompat, "DuckArrayModule", None)
    if not isinstance(cache, dict) or record is None or "dask" in cache \
            or "dask.array" in sys.modules:
        return False
    cache["dask"] = _DaskWhenImported(cache, record)
    return True


class _DaskWhenImported:
    """xarray's record of dask as a duck-array library, made when dask.array is there."""

    def __init__(self, cache: dict, record):
        self._cache, self._record = cache, record

    @property
    def type(self) -> tuple:
        array = sys.modules.get("dask.array")
        if getattr(array, "Array", None) is None:   # not imported (or half-way through)
            return ()
        return self._real().type

    def _real(self):
        real = self._record("dask")       # xarray's own, which imports dask.array
        if self._cache.get("dask") is self:
            self._cache["dask"] = real
        return real

    def __getattr__(self, attr):          # module, version, available: xarray's own
        if attr.startswith("_"):
            raise AttributeError(attr)
        return getattr(self._real(), attr)


when_imported("xarray", dask_checked_lazily)
