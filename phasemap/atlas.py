"""Atlases on disk: CF-compliant netCDF writing, atomically, and a human summary.

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

Writing is atomic: :func:`atomic_path` yields a temporary file in the
destination folder (``.phasemap.<random>.part``, short whatever the name),
fsyncs it and renames it onto the destination only on success, so a reader
never sees a half-written atlas and an interrupted write leaves an existing
file untouched.  Without ``overwrite`` the last step is an exclusive rename
that fails if the destination appeared meanwhile.  The temporary file is
removed on any exception and on every signal that ends the process (SIGINT,
SIGTERM, SIGHUP: :func:`removed_on_signals`; while netCDF writes, a signal is
raised at the next safe point, :func:`signals_deferred`); one left by a process killed
outright (SIGKILL, a power cut) is removed by the next write into its folder
once it is a day old.  A dask-backed atlas is written by threads that all
finish before the temporary file goes.  A chunk-by-chunk writer that opens
``netCDF4.Dataset`` itself reuses it::

    with atomic_path("atlas.nc") as tmp:
        with netCDF4.Dataset(tmp, "w") as nc:
            ...  # close the file before the block ends
"""

from __future__ import annotations

import contextlib
import ctypes
import datetime as _dt
import errno
import math
import os
import pathlib
import re
import shutil
import signal
import stat
import tempfile
import threading
import time
from typing import Iterator, Mapping

import numpy as np
import xarray as xr

from ._dataset import CONVENTIONS, curve_axes, curve_kind, motion_kind
from ._version import __version__
from .progress import human_bytes

__all__ = [
    "CHUNK_BYTES",
    "CONVENTIONS",
    "Terminated",
    "WriteError",
    "atomic_path",
    "cf_encoding",
    "default_chunks",
    "destination",
    "describe_atlas",
    "no_partial_file",
    "open_atlas",
    "prepare",
    "removed_on_signals",
    "write_atlas",
]

#: Upper bound on the uncompressed size of one netCDF chunk of a layer.
CHUNK_BYTES = 1 << 20

#: Attributes that are serialisation, which belong in ``encoding``.
_ENCODING_KEYS = ("_FillValue", "missing_value", "scale_factor", "add_offset",
                  "dtype", "chunksizes", "zlib", "complevel", "shuffle", "contiguous")

#: Layers are read in slabs of at most this many bytes by :func:`describe_atlas`.
_SLAB_BYTES = 16 << 20

#: Temporary files: ``.phasemap.<8 random characters>.part`` (``tempfile.mkstemp``'s).
PART_PREFIX, PART_SUFFIX = ".phasemap.", ".part"
#: A temporary file of ours older than this (s) is a leftover, removed when writing beside it.
STALE_PART_SECONDS = 86400.0
_PART = re.compile(re.escape(PART_PREFIX) + r"[a-z0-9_]{8}" + re.escape(PART_SUFFIX) + "$")


# --------------------------------------------------------------------------- writing


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
    if not 1 <= int(complevel) <= 9:
        raise ValueError(f"complevel must be between 1 and 9, got {complevel}")
    chunks = dict(chunks or {})
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
        raise TypeError(f"write_atlas needs an xarray.Dataset, got {type(ds).__name__}")
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


def exists_message(path: pathlib.Path) -> str:
    """What a writer says when ``path`` exists and may not be replaced: the Python keyword
    and the command line's flag."""
    return f"{path} exists; pass overwrite=True (--overwrite on the command line) to replace it"


#: Free space below which a failed write is put down to a full disk, whatever the writer said.
FULL_BYTES = 64 * 1024


class WriteError(ValueError):
    """Writing failed (a full disk, an I/O error); no partial file was left."""


@contextlib.contextmanager
def no_partial_file(path: pathlib.Path, *, overwrite: bool = True) -> Iterator[pathlib.Path]:
    """:func:`atomic_path`, with I/O errors turned into a one-line :class:`WriteError`."""
    try:
        with atomic_path(path, overwrite=overwrite) as tmp:
            yield tmp
    except Exception as err:
        io = isinstance(err, OSError) or (isinstance(err, RuntimeError)
                                          and str(err).startswith("NetCDF"))
        try:
            space = shutil.disk_usage(path.parent).free
        except OSError:
            space = None
        # a writer on a full disk may say something else (HDF5: "Permission denied";
        # matplotlib's PDF writer: an AttributeError while it cleans up)
        full = space is not None and space < FULL_BYTES
        if not (io or full):
            raise  # not an I/O error: a failure of the computation
        reason = " ".join(str(err).split()) or type(err).__name__
        if full and getattr(err, "errno", None) != errno.ENOSPC:
            reason = (f"no space left on the device (the writer said {type(err).__name__}: "
                      f"{reason[:120]})")
        free = "?" if space is None else human_bytes(space)
        raise WriteError(f"cannot write {path}: {reason} ({free} free on {path.parent}); "
                         + left_behind(err)) from None


def left_behind(err: BaseException) -> str:
    """What a failed write left: "no file was left", or the temporary file that could
    not be removed (:func:`atomic_path` records it on the error)."""
    left = getattr(err, "phasemap_left", None)
    if left is None:
        return "no file was left"
    return f"its temporary file {left[0]} could not be removed ({left[1]}): remove it by hand"


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, overwrite: bool = True) -> Iterator[pathlib.Path]:
    """Yield a temporary path next to ``path``; move it onto ``path`` on success.

    The temporary file (``.phasemap.<random>.part`` in the destination folder,
    so the final rename never crosses file systems, and short, so any legal
    name works) exists, empty, when the block starts; the block overwrites it
    and must close it.  On a normal exit the file is fsynced, given the
    permissions a new file would get from the umask, and renamed over ``path``
    with :func:`os.replace`, or, without ``overwrite``, renamed only if
    ``path`` does not exist at that moment.  On any exception,
    ``KeyboardInterrupt`` included, and on a signal that ends the process
    (:func:`removed_on_signals`), it is removed and ``path`` is left as it
    was.  Temporary files of ours older than a day in the folder (left by a
    killed process) are removed first.

    Raises
    ------
    ValueError
        if the destination folder does not exist, ``path`` is a folder, or
        (without ``overwrite``) ``path`` appeared meanwhile.
    """
    path = destination(path)
    _remove_stale_parts(path.parent)
    with removed_on_signals():
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=PART_PREFIX, suffix=PART_SUFFIX)
        os.close(fd)
        tmp = pathlib.Path(name)
        try:
            yield tmp
            with open(tmp, "rb") as fh:
                os.fsync(fh.fileno())
            os.chmod(tmp, 0o666 & ~_umask())
            if overwrite:
                _check_replaceable(path)  # again: the name may have changed meanwhile
                os.replace(tmp, path)
            else:
                _rename_exclusive(tmp, path)
        except BaseException as err:
            try:
                tmp.unlink()
            except FileNotFoundError:
                pass
            except OSError as stuck:  # a folder made read-only meanwhile: say so
                with contextlib.suppress(AttributeError, TypeError):
                    err.phasemap_left = (tmp, stuck.strerror or str(stuck))
            raise
    _fsync_folder(path.parent)


def _remove_stale_parts(folder: pathlib.Path) -> None:
    """Remove our temporary files in ``folder`` older than :data:`STALE_PART_SECONDS`."""
    now = time.time()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        if not _PART.match(entry.name):
            continue
        with contextlib.suppress(OSError):
            if entry.is_file(follow_symlinks=False) and \
                    now - entry.stat(follow_symlinks=False).st_mtime > STALE_PART_SECONDS:
                os.unlink(entry.path)


def _rename_exclusive(src: pathlib.Path, dst: pathlib.Path) -> None:
    """Rename ``src`` to ``dst`` unless ``dst`` exists, atomically (ValueError if it does).

    Linux's ``renameat2(RENAME_NOREPLACE)`` where the file system has it, else a
    hard link (which fails on an existing name) and an unlink; on a file system
    with neither, a check followed by a rename.
    """
    try:
        _renameat2_noreplace(src, dst)
        return
    except FileExistsError:
        raise ValueError(exists_message(dst)) from None
    except OSError as err:
        if err.errno not in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.ENOTSUP):
            raise
    try:
        os.link(src, dst)
    except FileExistsError:
        raise ValueError(exists_message(dst)) from None
    except OSError:
        if dst.exists():
            raise ValueError(exists_message(dst)) from None
        os.replace(src, dst)
        return
    os.unlink(src)


_RENAME_NOREPLACE = 1
_AT_FDCWD = -100


def _renameat2_noreplace(src: pathlib.Path, dst: pathlib.Path) -> None:
    libc = _libc()
    fn = getattr(libc, "renameat2", None)
    if fn is None:
        raise OSError(errno.ENOSYS, "renameat2 is not available")
    if fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), _RENAME_NOREPLACE) != 0:
        code = ctypes.get_errno()
        raise OSError(code, os.strerror(code), str(dst))


_LIBC: list = []


def _libc():
    if not _LIBC:
        try:
            _LIBC.append(ctypes.CDLL(None, use_errno=True))
        except OSError:
            _LIBC.append(None)
    return _LIBC[0]


class Terminated(SystemExit):
    """The process got SIGTERM or SIGHUP while a temporary file was open.

    A :class:`SystemExit` with status 128 + the signal number, raised in the
    main thread so that every ``finally`` runs (temporary files are removed)
    and the process then ends as a terminated one would.
    """

    def __init__(self, signum: int):
        super().__init__(128 + signum)
        self.signum = signum

    def __str__(self) -> str:
        return f"terminated by {signal.Signals(self.signum).name}"


#: Signals that end a process by default, turned into exceptions while work is under way.
ENDING_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP", "SIGINT")
                       if hasattr(signal, n))
_HANDLERS = {"depth": 0, "saved": {}}
_HANDLERS_LOCK = threading.Lock()


def _raise_terminated(signum, frame):
    if signum == getattr(signal, "SIGINT", None):
        raise KeyboardInterrupt
    raise Terminated(signum)


@contextlib.contextmanager
def removed_on_signals() -> Iterator[None]:
    """Inside the block, the signals that would end the process at once (SIGTERM,
    SIGHUP, and SIGINT where it is not already ``KeyboardInterrupt``) raise
    :class:`Terminated` (or ``KeyboardInterrupt``) instead, so that temporary files
    are removed by the code that made them before the process ends.

    Only the main thread can handle signals; elsewhere, and for signals the
    program handles itself, nothing changes.  Blocks nest.
    """
    install = threading.current_thread() is threading.main_thread()
    if install:
        with _HANDLERS_LOCK:
            if _HANDLERS["depth"] == 0:
                for sig in ENDING_SIGNALS:
                    current = signal.getsignal(sig)
                    if current is signal.SIG_DFL:
                        _HANDLERS["saved"][sig] = current
                        signal.signal(sig, _raise_terminated)
            _HANDLERS["depth"] += 1
    try:
        yield
    finally:
        if install:
            with _HANDLERS_LOCK:
                _HANDLERS["depth"] -= 1
                if _HANDLERS["depth"] == 0:
                    for sig, handler in _HANDLERS["saved"].items():
                        signal.signal(sig, handler)
                    _HANDLERS["saved"].clear()


_DEFERRED = {"active": False, "pending": []}


def _defer(signum, frame):
    if _DEFERRED["pending"]:  # asked twice: stop at once
        _raise_terminated(signum, frame)
    _DEFERRED["pending"].append(signum)


def _raise_pending(*_) -> None:
    pending = _DEFERRED["pending"]
    # dask's callbacks are global: a compute in another thread must not take the signal
    if pending and threading.current_thread() is threading.main_thread():
        signum = pending[0]
        pending.clear()
        _raise_terminated(signum, None)


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Inside the block, an ending signal (SIGINT, SIGTERM, SIGHUP) is raised at the next
    safe point instead of wherever the main thread happens to be.

    netCDF writing runs in library code that holds locks; an exception raised
    between a lock's acquire and its release (Ctrl-C during ``to_netcdf``)
    leaves the lock held, and the file's close then waits for it forever.
    Here the first signal is only recorded.  It is raised (as
    ``KeyboardInterrupt`` or :class:`Terminated`) after the next dask task
    finishes, from dask's scheduler loop in the main thread, or when the
    block ends; a second signal is raised at once.  Handlers the program
    installed itself, and ignored signals, are left alone.  Only the main
    thread can handle signals; elsewhere the block changes nothing.
    """
    if _DEFERRED["active"] or threading.current_thread() is not threading.main_thread():
        yield
        return
    from dask.callbacks import Callback

    ours = (signal.SIG_DFL, signal.default_int_handler, _raise_terminated)
    saved = {}
    for sig in ENDING_SIGNALS:
        current = signal.getsignal(sig)
        if any(current is handler for handler in ours):
            saved[sig] = current
            signal.signal(sig, _defer)
    _DEFERRED["active"] = True
    try:
        with Callback(posttask=_raise_pending):
            yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        _DEFERRED["active"] = False
        _raise_pending()  # also over an error of the block's own: the signal ends the work


def destination(path: str | os.PathLike) -> pathlib.Path:
    """``path`` as a Path, checked writable in principle: its folder exists, and it is
    nothing but a regular file (or a symbolic link, which a write replaces, never its
    target) if it exists.  A device node, a FIFO or a socket is never replaced, not even
    with ``overwrite`` (as root, ``-o /dev/null --overwrite`` would replace the real one)."""
    path = pathlib.Path(os.path.expanduser(os.fspath(path)))
    folder = path.parent
    if not folder.is_dir():
        raise ValueError(f"cannot write {path}: folder {folder} does not exist")
    if path.is_dir():
        raise ValueError(f"cannot write {path}: it is a folder")
    _check_replaceable(path)
    return path


def _check_replaceable(path: pathlib.Path) -> None:
    """ValueError unless ``path`` is missing, a regular file or a symbolic link."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as err:
        raise ValueError(f"cannot write {path}: {err.strerror or err}") from None
    if not (stat.S_ISREG(mode) or stat.S_ISLNK(mode)):
        kind = ("a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else
                "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "not a regular file")
        raise ValueError(f"cannot write {path}: it is {kind}, which phasemap never replaces; "
                         "choose a file name")


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


def _umask() -> int:
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _fsync_folder(folder: pathlib.Path) -> None:
    """Make the rename durable; not every platform can open a folder."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# --------------------------------------------------------------------------- reading


def open_atlas(path: str | os.PathLike, **kwargs) -> xr.Dataset:
    """Open an atlas file lazily, checking that it is one.

    Close the result (or use it in a ``with`` block) when done.

    Parameters
    ----------
    path : str or os.PathLike
        an atlas file written by :func:`write_atlas` or ``phasemap atlas``.
    **kwargs
        passed to :func:`xarray.open_dataset` (``chunks=`` for dask arrays).

    Returns
    -------
    xarray.Dataset
        the atlas, its layers read lazily.

    Raises
    ------
    ValueError
        with a one-line message if the file does not exist, is not netCDF, or
        is not a phasemap atlas.

    Examples
    --------
    >>> import phasemap
    >>> phasemap.open_atlas("no_such_atlas.nc")
    Traceback (most recent call last):
    ...
    ValueError: no_such_atlas.nc: no such file

    Reading one back is shown in :func:`write_atlas`.
    """
    path = pathlib.Path(os.path.expanduser(os.fspath(path)))
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    kwargs.setdefault("engine", "netcdf4")
    kwargs.setdefault("decode_times", False)
    kwargs.setdefault("decode_timedelta", False)
    try:
        ds = xr.open_dataset(path, **kwargs)
    except Exception as err:  # netCDF4 and HDF5 raise a variety of types
        reason = " ".join(str(err).split()) or type(err).__name__
        raise ValueError(f"{path}: not a readable netCDF file ({reason})") from None
    try:
        _check_is_atlas(ds, str(path))
    except ValueError:
        ds.close()
        raise
    return ds


def describe_atlas(path_or_ds: str | os.PathLike | xr.Dataset) -> str:
    """A human summary of an atlas, as ``phasemap info`` prints it.

    It names the model, the axes (size, range, units, uniform or not), the
    fixed values, every layer with its units, and for each categorical layer
    the count and percentage of cells in each class, then the version and time
    that made the atlas.  Layers are read in slabs, so a large file is never
    loaded whole.

    Parameters
    ----------
    path_or_ds : str, os.PathLike or xarray.Dataset
        an atlas file, or an atlas in memory.

    Returns
    -------
    str
        the summary, several lines.

    Raises
    ------
    ValueError
        if the file does not exist, is not netCDF or is not a phasemap atlas.

    Examples
    --------
    >>> import numpy as np, phasemap
    >>> ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 4),
    ...                                     "f": [0.0, 0.5, 1.0]}, fixed={"omega": 0.0}).compute()
    >>> print(phasemap.describe_atlas(ds))   # doctest: +ELLIPSIS
    phasemap atlas (in memory)
    ...
      cells     12 = 4 phi x 3 f
    ...
    """
    if isinstance(path_or_ds, xr.Dataset):
        _check_is_atlas(path_or_ds, "dataset")
        return _describe(path_or_ds, "(in memory)")
    with open_atlas(path_or_ds) as ds:
        try:
            return _describe(ds, str(path_or_ds))
        except (OSError, RuntimeError) as err:  # a damaged file opens but fails to read
            reason = " ".join(str(err).split()) or type(err).__name__
            raise ValueError(f"{path_or_ds}: cannot read the atlas ({reason})") from None


def _check_is_atlas(ds: xr.Dataset, where: str) -> None:
    if "phasemap_model" not in ds.attrs:
        raise ValueError(f"{where}: not a phasemap atlas (no phasemap_model global attribute)")
    if not ds.data_vars:
        raise ValueError(f"{where}: not a phasemap atlas (no layers)")


#: What a motion's description reads, by kind.
_MOTION_VARIABLES = {"trajectory": ("t", "event_kind", "event_t"),
                     "phase_curve": ("stage_end_reason",)}


def _describe(ds: xr.Dataset, where: str) -> str:
    kind = motion_kind(ds)
    if kind is not None:
        missing = [n for n in _MOTION_VARIABLES[kind] if n not in ds.variables]
        if missing:
            raise ValueError(f"{where}: phasemap_kind says {kind}, but it has no "
                             f"{', '.join(missing)}")
        return _describe_motion(ds, where, kind)
    if curve_kind(ds) is not None:
        return _describe_curves(ds, where, curve_kind(ds))
    return _describe_grid(ds, where)


def _made_by(a) -> str:
    """The summary's line of the version and time that made a file."""
    return (f"  made by   phasemap {a.get('phasemap_version', '?')}, "
            f"{a.get('date_created', 'creation time unknown')}")


def _prefixed(a, prefix: str) -> list[tuple[str, str, str]]:
    """The attributes named ``prefix<name>``, as rows (name, "=", value) of a table."""
    return [(k[len(prefix):], "=", _number(v)) for k, v in a.items() if k.startswith(prefix)]


def _describe_curves(ds: xr.Dataset, where: str, kind: str) -> str:
    """Boundaries or a threshold curve: its axes, pieces by condition, special points."""
    a = ds.attrs
    x, y = curve_axes(ds)
    lines = [f"phasemap {'threshold curve' if kind == 'threshold' else kind} {where}"]
    if "title" in a:
        lines.append(f"  title     {a['title']}")
    lines.append(f"  model     {a['phasemap_model']}")
    if kind == "threshold":
        lines.append(f"  threshold the {a.get('phasemap_side', '')} {y} at which "
                     f"{a.get('phasemap_layer', '?')} = {_number(a.get('phasemap_value'))}, "
                     f"followed in {x}")
    else:
        lines.append(f"  layer     {a.get('phasemap_layer', '?')}, over {x} and {y}")
    for name in (x, y):
        values = np.asarray(ds[name].values, dtype=float)
        span = (f"from {np.nanmin(values):.6g} to {np.nanmax(values):.6g}"
                if np.isfinite(values).any() else "(no vertex)")
        units = str(ds[name].attrs.get("units", ""))
        lines.append(f"  {name:<9} {span} {'' if units == '1' else units}".rstrip())
    conditions = np.asarray(ds["condition"].values).astype(str) if "condition" in ds else []
    counts: dict[str, int] = {}
    for c in conditions:
        counts[c] = counts.get(c, 0) + 1
    lines.append(f"  pieces    {ds.sizes.get('piece', 0)} with {ds.sizes.get('vertex', 0)} "
                 "vertices" + (": " + ", ".join(f"{c} {n}" for c, n in counts.items())
                               if counts else ""))
    kinds = np.asarray(ds["point_kind"].values).astype(str) if "point_kind" in ds else []
    points: dict[str, int] = {}
    for k in kinds:
        points[k] = points.get(k, 0) + 1
    lines.append(f"  points    {len(kinds)}" + (": " + ", ".join(
        f"{k} {n}" for k, n in points.items()) if points else ""))
    for name in ("residual", "point_residual"):
        if name in ds and ds[name].size and np.isfinite(ds[name].values).any():
            lines.append(f"  {'residual' if name == 'residual' else 'points residual':<9} "
                         f"at most {np.nanmax(np.abs(ds[name].values)):.3g} (relative to "
                         "the conditions' tie scales)")
    if "phasemap_tol" in a:
        lines.append(f"  tolerance {_number(a['phasemap_tol'])}")
    lines.append(_made_by(a))
    fixed = _prefixed(a, "phasemap_fixed_")
    lines.append("fixed")
    lines += _table(fixed) if fixed else ["  (none)"]
    return "\n".join(lines)


def _describe_motion(ds: xr.Dataset, where: str, kind: str) -> str:
    """A trajectory (times, events) or a phase curve (points, stages), as what it is."""
    from .events import Event

    a = ds.attrs
    lines = [f"phasemap {kind.replace('_', ' ')} {where}"]
    if "title" in a:
        lines.append(f"  title     {a['title']}")
    lines.append(f"  model     {a['phasemap_model']}")
    if kind == "trajectory":
        t = np.asarray(ds["t"].values, dtype=float)
        span = f", t from {t.min():.6g} to {t.max():.6g} s" if t.size else ""
        lines.append(f"  saved     {t.size} states{span}")
        codes = np.asarray(ds["event_kind"].values).tolist()
        count_of = "events"
    else:
        lines.append(f"  points    {ds.sizes.get('point', 0)} points of omega(phi) on "
                     f"{ds.sizes.get('stage', 0)} stages")
        codes = np.asarray(ds["stage_end_reason"].values).tolist()
        count_of = "stages end"
    counts: dict[str, int] = {}
    for code in codes:
        try:
            name = Event(int(code)).name.lower()
        except ValueError:
            name = f"(unlisted {code})"
        counts[name] = counts.get(name, 0) + 1
    lines.append(f"  {count_of:<9} {len(codes)}: " + ", ".join(f"{n} {k}" for n, k in
                                                             counts.items()))
    if "end_reason" in a:
        lines.append(f"  ended     {a['end_reason']}: {a.get('end_message', '')}")
    if "n_reversals" in a:
        lines.append(f"  reversals {int(np.squeeze(a['n_reversals']))}")
    lines.append(_made_by(a))
    start = _prefixed(a, "phasemap_initial_")
    fixed = _prefixed(a, "phasemap_fixed_")
    lines.append("initial state")
    lines += _table(start) if start else ["  (none)"]
    lines.append("parameters")
    lines += _table(fixed) if fixed else ["  (none)"]
    if kind == "trajectory":
        rows = [("t (s)", "event", *[str(n)[len("event_"):] for n in ds.data_vars
                                     if str(n).startswith("event_")
                                     and str(n) not in ("event_t", "event_kind",
                                                        "event_branch")])]
        names = [f"event_{n}" for n in rows[0][2:]]
        for i in range(ds.sizes.get("event", 0)):
            e = ds.isel(event=i)
            try:
                name = Event(int(e.event_kind)).name.lower()
            except ValueError:
                name = str(int(e.event_kind))
            rows.append((f"{float(e.event_t):.6g}", name,
                         *(f"{float(e[n]):.6g}" for n in names)))
        lines.append("events")
        lines += _table(rows)
    return "\n".join(lines)


def _describe_grid(ds: xr.Dataset, where: str) -> str:
    a = ds.attrs
    dims = [str(d) for d in ds.dims]
    cells = math.prod(ds.sizes[d] for d in dims)
    lines = [f"phasemap atlas {where}"]
    if "title" in a:
        lines.append(f"  title     {a['title']}")
    lines.append(f"  model     {a['phasemap_model']}")
    lines.append(f"  cells     {cells} = " + " x ".join(f"{ds.sizes[d]} {d}" for d in dims))
    lines.append(_made_by(a))
    if "Conventions" in a:
        lines.append(f"  follows   {a['Conventions']}")

    lines.append("axes")
    rows = []
    for d in dims:
        if d in ds.coords:
            x = np.asarray(ds[d].values, dtype=float)
            attrs = ds[d].attrs
            rng = f"[{x.min():.6g}, {x.max():.6g}]" if x.size else "[]"
            rows.append((d, str(x.size), rng, str(attrs.get("units", "?")), _spacing(x),
                         str(attrs.get("long_name", ""))))
        else:
            rows.append((d, str(ds.sizes[d]), "(no coordinate)", "", "", ""))
    lines += _table(rows)

    fixed = {k[len("phasemap_fixed_"):]: v for k, v in a.items() if k.startswith("phasemap_fixed_")}
    lines.append("fixed values")
    if fixed:
        lines += _table([(k, "=", _number(v)) for k, v in fixed.items()])
    else:
        lines.append("  (none)")

    lines.append("layers")
    for name, var in ds.data_vars.items():
        attrs = var.attrs
        if "flag_meanings" in attrs:
            lines.append(f"  {name} ({var.dtype}, categorical): {attrs.get('long_name', '')}")
            lines += _class_lines(var, cells)
        else:
            defined = _count_finite(var) if np.issubdtype(var.dtype, np.floating) else cells
            pct = 100.0 * defined / cells if cells else 0.0
            lines.append(f"  {name} ({var.dtype}, {attrs.get('units', 'no units')}): "
                         f"{attrs.get('long_name', '')}; defined on {defined} cells ({pct:.1f}%)")
    return "\n".join(lines)


def _number(value) -> str:
    try:
        return f"{float(np.squeeze(value)):.6g}"
    except (TypeError, ValueError):
        return str(value)


def _spacing(x: np.ndarray) -> str:
    if x.size < 2:
        return "single value"
    step = np.diff(x)
    mean = (x[-1] - x[0]) / (x.size - 1)
    scale = max(abs(mean), np.finfo(float).tiny)
    if np.all(np.abs(step - mean) <= 1e-6 * scale):
        return f"uniform, step {mean:.6g}"
    return f"non-uniform, steps {np.abs(step).min():.3g} to {np.abs(step).max():.3g}"


def _class_lines(var: xr.DataArray, cells: int) -> list[str]:
    meanings = str(var.attrs["flag_meanings"]).split()
    values = np.atleast_1d(np.asarray(var.attrs.get("flag_values", np.arange(len(meanings)))))
    counts: dict[int, int] = {}
    for block in _slabs(var):
        if block.dtype == np.int8:  # the usual case: one pass, no sort
            c = np.bincount(block.view(np.uint8).ravel(), minlength=256)
            v = np.arange(256, dtype=np.uint8).view(np.int8)
            v, c = v[c > 0], c[c > 0]
        else:
            v, c = np.unique(block, return_counts=True)
        for value, count in zip(v.tolist(), c.tolist()):
            counts[value] = counts.get(value, 0) + count
    rows = []
    for value, meaning in zip(values.tolist(), meanings):
        n = counts.pop(value, 0)
        rows.append(("  " + meaning, str(value), str(n), f"{_pct(n, cells)}%"))
    for value, n in sorted(counts.items(), key=lambda kv: str(kv[0])):
        rows.append(("  (unlisted)", str(value), str(n), f"{_pct(n, cells)}%"))
    return _table(rows, right=(1, 2, 3))


def _pct(n: int, cells: int) -> str:
    return f"{100.0 * n / cells:.2f}" if cells else "0.00"


def _count_finite(var: xr.DataArray) -> int:
    return sum(int(np.count_nonzero(np.isfinite(block))) for block in _slabs(var))


def _slabs(var: xr.DataArray) -> Iterator[np.ndarray]:
    """The values of ``var`` in slabs along its first dimension, each about :data:`_SLAB_BYTES`."""
    if var.ndim == 0:
        yield np.asarray(var.values)
        return
    per_row = max(1, var.size // max(var.shape[0], 1)) * var.dtype.itemsize
    step = max(1, _SLAB_BYTES // per_row)
    dim = var.dims[0]
    for start in range(0, var.shape[0], step):
        yield np.asarray(var.isel({dim: slice(start, start + step)}).values)


def _table(rows: list[tuple[str, ...]], right: tuple[int, ...] = ()) -> list[str]:
    if not rows:
        return []
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    out = []
    for r in rows:
        cells = [c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))]
        out.append(("  " + "  ".join(cells)).rstrip())
    return out
