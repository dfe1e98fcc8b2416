"""Writing atlases: CF-compliant netCDF files, written atomically.

An *atlas* is the :class:`xarray.Dataset` that ``Scene.compute()`` returns:

* one to four dimension coordinates named after model variables (``phi``,
  ``f``...), float64, 1-D, possibly non-uniform, with ``units`` (UDUNITS
  spelling) and ``long_name``;
* data variables over all those dimensions: categorical int8 layers
  (``n_solutions``, ``stagnation``, ``contact_lost``, ``singular``) carrying
  ``flag_values``, ``flag_meanings`` and ``long_name`` but no ``units``, and
  float layers carrying ``units`` and ``long_name``, NaN where undefined;
* global provenance attributes: ``Conventions``, ``title``, ``source``,
  ``history``, ``phasemap_model``, ``phasemap_version``, ``phasemap_scene``
  (JSON), ``phasemap_fixed_<name>`` and ``date_created``.

Metadata is data and lives in ``.attrs``; serialisation (compression,
chunking, ``_FillValue``) lives only in the ``encoding`` that
:func:`cf_encoding` builds and :func:`write_atlas` hands to ``to_netcdf``.
Every atlas survives a netCDF round trip unchanged (``identical``).

``Conventions`` is ``CF-1.8`` (:data:`CONVENTIONS`): cfchecker 4.1.0, the
newest on PyPI and the independent checker used by the tests, knows CF
versions up to 1.8 and reports an error for any later version string.  An
atlas uses nothing introduced after CF-1.8.

Writing is atomic (:mod:`phasemap.atlas.atomic`): a reader never sees a half-written
atlas. A dask-backed atlas is written by threads that all finish before the
temporary file goes.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import math
import os
import pathlib
from typing import Iterator, Mapping

import numpy as np
from phasemap.core.lazy import xarray as xr

from phasemap.core import args as _args
from phasemap.atlas.dataset import CONVENTIONS
from phasemap._version import __version__
from phasemap.atlas.atomic import destination, exists_message, no_partial_file, signals_deferred


#: Upper bound on the uncompressed size of one netCDF chunk of a layer.
CHUNK_BYTES = 1 << 20


#: Attributes that are serialisation, which belong in ``encoding``.
_ENCODING_KEYS = ("_FillValue", "missing_value", "scale_factor", "add_offset",
                  "dtype", "chunksizes", "zlib", "complevel", "shuffle", "contiguous")


def cf_encoding(ds: xr.Dataset, chunks: Mapping[str, int] | None = None, *,
                complevel: int = 4) -> dict[str, dict]:
    """The per-variable ``encoding`` that :func:`write_atlas` passes to ``to_netcdf``.

    Parameters
    ----------
    ds:
        an atlas.
    chunks:
        netCDF chunk length per dimension name; missing dimensions take the
        default, every length is clipped to the dimension's size.  By default a
        layer's chunk starts from its dask chunk (or its whole shape) and the
        longest side is halved until one chunk holds at most
        :data:`CHUNK_BYTES` uncompressed.
    complevel:
        zlib level, 1 (fast) to 9 (small).

    Returns
    -------
    dict
        ``{name: {...}}`` for every variable.  Data variables get
        ``zlib``, ``complevel``, ``shuffle`` and ``chunksizes``; integer
        (categorical) layers and coordinates get ``_FillValue: None`` (no fill
        value attribute), float layers ``_FillValue: NaN``.
    """
    complevel = _args.count("complevel", complevel, "write_atlas", least=1, most=9)
    chunks = _args.mapping("chunks", chunks, "write_atlas")
    for dim, n in chunks.items():
        if dim not in ds.dims:
            raise ValueError(f"chunks: {dim!r} is not a dimension of the atlas "
                             f"(dimensions: {', '.join(map(str, ds.dims))})")
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"chunks: {dim}={n!r} must be a positive integer")
    encoding: dict[str, dict] = {}
    for name in ds.coords:
        encoding[str(name)] = {"_FillValue": None}
    for name, var in ds.data_vars.items():
        if var.dtype.kind in "OUS":  # text: CF's character arrays (CF-1.8 has no string type)
            encoding[str(name)] = {"dtype": "S1", "char_dim_name": f"{name}_length"}
            continue
        enc: dict = {"_FillValue": _fill_value(var.dtype)}
        if var.ndim > 0:
            start = _dask_chunk_shape(var) or var.shape
            start = tuple(max(1, min(int(chunks.get(d, c)), n))
                          for d, c, n in zip(var.dims, start, var.shape))
            fixed = {i for i, d in enumerate(var.dims) if d in chunks}
            shape = default_chunks(start, var.dtype.itemsize, fixed=fixed)
            enc.update(zlib=True, complevel=int(complevel), shuffle=True,
                       chunksizes=shape)
        encoding[str(name)] = enc
    return encoding


def write_atlas(ds: xr.Dataset, path: str | os.PathLike, *, complevel: int = 4,
                chunks: Mapping[str, int] | None = None,
                overwrite: bool = True) -> pathlib.Path:
    """Write an atlas to a netCDF-4 file, atomically, and return its path.

    ``Conventions``, ``date_created``, ``history``, ``source`` and
    ``phasemap_version`` are added when missing; every attribute already there
    is kept (integer ``flag_values`` are stored in their layer's dtype, as CF
    requires).  The caller's Dataset is not modified.  A dask-backed atlas is
    computed chunk by chunk while it is written, never loaded whole.  With
    ``overwrite=False`` an existing file is never replaced, even one that
    appears while the atlas is being written.

    Parameters
    ----------
    ds : xarray.Dataset
        the atlas, as :meth:`phasemap.Scene.compute` returns it.
    path : str or os.PathLike
        the file to write (``~`` is expanded); its folder must exist.
    complevel : int, default 4
        zlib compression level of the layers.
    chunks : mapping of str to int, optional
        netCDF chunk sizes by dimension; by default chunks of about a megabyte.
    overwrite : bool, default True
        replace an existing file; with False, refuse one (even one that
        appears while the atlas is written).

    Returns
    -------
    pathlib.Path
        the path written.

    Raises
    ------
    ValueError
        before anything is computed or written, if the destination folder does
        not exist, or if the atlas carries attributes netCDF cannot store
        (bools, None) or serialisation keys in ``.attrs``; when ``path`` exists
        and ``overwrite`` is false; as :class:`WriteError` when writing fails
        (a full disk), leaving no partial file.

    Examples
    --------
    >>> import os, tempfile, numpy as np, phasemap
    >>> ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 4),
    ...                                     "f": [0.0, 0.5, 1.0]}, fixed={"omega": 0.0}).compute()
    >>> path = phasemap.write_atlas(ds, os.path.join(tempfile.mkdtemp(), "ladder.nc"))
    >>> path.name
    'ladder.nc'
    >>> with phasemap.open_atlas(path) as back:
    ...     back.attrs["Conventions"], back.n_solutions.shape
    ('CF-1.8', (4, 3))
    """
    if not isinstance(ds, xr.Dataset):
        raise TypeError(f"write_atlas: ds must be an xarray.Dataset (an atlas), got "
                        f"{type(ds).__name__}")
    path = destination(path)
    if not overwrite and path.exists():
        raise ValueError(exists_message(path))
    out = prepare(ds)
    encoding = cf_encoding(out, chunks, complevel=complevel)
    with no_partial_file(path, overwrite=overwrite) as tmp:
        with signals_deferred(), _joined_writer_threads(out):
            out.to_netcdf(tmp, mode="w", format="NETCDF4", engine="netcdf4", encoding=encoding)
    return path


@contextlib.contextmanager
def _joined_writer_threads(ds: xr.Dataset) -> Iterator[None]:
    """Write a dask-backed ``ds`` on a thread pool of our own that has finished when the
    block ends, error or not.

    dask's threaded scheduler raises the first task error at once while other
    tasks are still writing; those would reopen the temporary file after it
    is removed.  Other schedulers (a distributed client) are used as they are.
    """
    import dask
    import dask.threaded
    from concurrent.futures import ThreadPoolExecutor

    lazy = [v.data for v in ds.variables.values() if dask.is_dask_collection(v.data)]
    if not lazy or dask.base.get_scheduler(collections=lazy) is not dask.threaded.get:
        yield
        return
    pool = ThreadPoolExecutor(dask.config.get("num_workers", None) or os.cpu_count() or 1)
    try:
        with dask.config.set(pool=pool):
            yield
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def prepare(ds: xr.Dataset) -> xr.Dataset:
    """A shallow copy of ``ds`` ready to write: no stale encoding, provenance filled in.

    ValueError (one line, every problem listed) for attributes netCDF cannot
    store and for serialisation keys in ``.attrs``.
    """
    problems = []
    for where, attrs in [("global", ds.attrs)] + [(str(k), v.attrs) for k, v in ds.variables.items()]:
        for key, value in attrs.items():
            if isinstance(value, (bool, np.bool_)) or value is None:
                problems.append(f"{where} attribute {key}={value!r} (netCDF stores no "
                                f"{'bools' if value is not None else 'None'}; use 0/1 or a string)")
            elif where != "global" and key in _ENCODING_KEYS:
                problems.append(f"{where} attribute {key} is serialisation; "
                                "put it in .encoding, not .attrs")
    if problems:
        raise ValueError("cannot write this atlas: " + "; ".join(problems))
    out = ds.drop_encoding()
    for name, var in out.variables.items():
        var.attrs = dict(var.attrs)
        if "flag_values" in var.attrs and np.issubdtype(var.dtype, np.integer):
            var.attrs["flag_values"] = _flag_values(str(name), var.attrs["flag_values"], var.dtype)
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0)
    stamp = now.strftime("%Y-%m-%dT%H:%M:%SZ")
    defaults = {
        "Conventions": CONVENTIONS,
        "source": f"phasemap {__version__}",
        "phasemap_version": __version__,
        "date_created": stamp,
        "history": f"{stamp} written by phasemap {__version__} (phasemap.atlas.write_atlas)",
    }
    out.attrs = {**ds.attrs, **{k: v for k, v in defaults.items() if k not in ds.attrs}}
    return out


def _flag_values(name: str, values, dtype: np.dtype) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(values))
    info = np.iinfo(dtype)
    if arr.ndim != 1 or not np.issubdtype(arr.dtype, np.integer) or \
            arr.min() < info.min or arr.max() > info.max:
        raise ValueError(f"{name}: flag_values {values!r} must be integers that fit in {dtype}")
    return arr.astype(dtype)


def _fill_value(dtype: np.dtype):
    return dtype.type(np.nan) if np.issubdtype(dtype, np.floating) else None


def _dask_chunk_shape(var: xr.Variable | xr.DataArray) -> tuple[int, ...] | None:
    chunks = var.chunks
    if not chunks:
        return None
    return tuple(max(c) if len(c) else 1 for c in chunks)


def default_chunks(shape: tuple[int, ...], itemsize: int, limit: int = CHUNK_BYTES,
                   fixed: set[int] = frozenset()) -> tuple[int, ...]:
    """Halve the longest free side of ``shape`` until a chunk holds at most ``limit`` bytes.

    Sides whose index is in ``fixed`` (chosen by the caller) are never changed.
    Halving keeps power-of-two (dask) chunk lengths exact divisors, so netCDF
    chunks tile the dask chunks they are written from.
    """
    chunk = [max(1, int(n)) for n in shape]
    free = [i for i in range(len(chunk)) if i not in fixed]
    while free and math.prod(chunk) * itemsize > limit:
        i = max(free, key=lambda j: chunk[j])
        if chunk[i] == 1:
            break
        chunk[i] = -(-chunk[i] // 2)
    return tuple(chunk)
