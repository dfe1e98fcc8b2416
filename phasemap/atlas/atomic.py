"""Atomic files: a reader never sees a half-written file, and an interrupted write
leaves nothing behind.

:func:`atomic_path` yields a temporary file in the destination folder
(``.phasemap.<random>.part``, short whatever the name), fsyncs it and renames it onto the
destination only on success, so an interrupted write leaves an existing file untouched.
Without ``overwrite`` the last step is an exclusive rename that fails if the destination
appeared meanwhile.  The temporary file is removed on any exception and on every signal
that ends the process (SIGINT, SIGTERM, SIGHUP: :func:`removed_on_signals`; while netCDF
writes, a signal is raised at the next safe point, :func:`signals_deferred`); one left by
a process killed outright (SIGKILL, a power cut) is removed by the next write into its
folder once it is a day old.  A device node, FIFO or socket is never replaced
(:func:`destination`).  A chunk-by-chunk writer that opens ``netCDF4.Dataset`` itself
uses it too::

    with atomic_path("atlas.nc") as tmp:
        with netCDF4.Dataset(tmp, "w") as nc:
            ...  # close the file before the block ends

:func:`no_partial_file` wraps it for writers that raise on a full disk, and says so in
one line (:class:`WriteError`).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import pathlib
import re
import shutil
import signal
import stat
import tempfile
import threading
import time
from typing import Iterator


from phasemap.core import args as _args
from phasemap.core.progress import human_bytes


#: Temporary files: ``.phasemap.<8 random characters>.part`` (``tempfile.mkstemp``'s).
PART_PREFIX, PART_SUFFIX = ".phasemap.", ".part"


#: A temporary file of ours older than this (s) is a leftover, removed when writing beside it.
STALE_PART_SECONDS = 86400.0


_PART = re.compile(re.escape(PART_PREFIX) + r"[a-z0-9_]{8}" + re.escape(PART_SUFFIX) + "$")


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
    path = _args.path("path", path)
    folder = path.parent
    try:
        folder_exists, is_folder = folder.is_dir(), path.is_dir()
    except OSError as err:  # a name too long, a folder that cannot be searched
        raise ValueError(f"cannot write {path}: {err.strerror or err}") from None
    if not folder_exists:
        raise ValueError(f"cannot write {path}: folder {folder} does not exist")
    if is_folder:
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
