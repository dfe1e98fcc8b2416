"""One process compiles a function at a time: a second that needs it meanwhile waits,
then loads what the first saved in numba's cache, instead of compiling it side by side.

Two test processes compiled the same kernels at once (35 of them twice in one run of the
suite, 70 s of CPU), and so would the workers of a dask cluster sharing one cache, or a
script and the background compile of its kernel (:mod:`phasemap.core.tiers`).
:func:`install` wraps numba's ``Dispatcher.compile`` for the functions whose cache is
phasemap's (:func:`phasemap.core.cache._ours`): inside numba's compiler lock (so the
threads of one process never wait on one another's file locks), an exclusive ``flock``
on ``<name>.nbk`` beside the function's index is held while numba loads it from the cache
or compiles and saves it.  A question to numba's cache alone (``load_overload``, which
:func:`phasemap.core.tiers._load` asks without compiling) takes no lock.
"""

from __future__ import annotations

import contextlib
import functools
import os
import pathlib
import time

#: The longest a process waits for another that compiles the same function (then it
#: compiles it itself): a kernel compiles in a few seconds to a few minutes.
COMPILE_WAIT = 600.0


#: The locks this process holds, by file: a compile inside a compile of the same function
#: (another signature it calls itself with) must not wait for its own lock.  (numba's
#: compiler lock, which every compile holds, keeps them to one thread at a time.)
_HELD: set[str] = set()


def lock(cache) -> int | None:
    """An exclusive lock on compiling one function (``<name>.nbk`` beside its index), held
    while numba loads or compiles and saves it: a second process that needs the function
    meanwhile waits, then loads what the first saved, instead of compiling it too (two
    test processes, the workers of a dask cluster, a script and the background compile of
    its kernel).  The descriptor, which the caller closes; None where no lock can be had
    (no ``fcntl``, a folder that is not writable) or after :data:`COMPILE_WAIT` seconds of
    waiting."""
    try:
        import fcntl

        index = pathlib.Path(cache._cache_file._index_path)
        index.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(index.with_suffix(".nbk"),
                     os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o600)
    except (ImportError, OSError, AttributeError):
        return None
    deadline = time.monotonic() + COMPILE_WAIT
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return fd
        except BlockingIOError:
            if time.monotonic() > deadline:
                os.close(fd)
                return None
            time.sleep(0.05)
        except OSError:
            os.close(fd)
            return None


def install(ours) -> None:
    """Wrap numba's ``Dispatcher.compile`` (once) so that a function whose cache
    ``ours(cache)`` says is phasemap's is compiled under :func:`lock`."""
    from numba.core import dispatcher, sigutils
    from numba.core.compiler_lock import global_compiler_lock

    compile_ = dispatcher.Dispatcher.compile
    if getattr(compile_, "_phasemap_locked", False):
        return

    @functools.wraps(compile_)
    def compile(self, sig):
        cache = getattr(self, "_cache", None)
        if not ours(cache):
            return compile_(self, sig)
        with global_compiler_lock:
            key = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
            if (tuple(sigutils.normalize_signature(sig)[0]) in self.overloads
                    or key is None or key in _HELD):
                return compile_(self, sig)
            fd = lock(cache)
            if fd is not None:
                _HELD.add(key)
            try:
                return compile_(self, sig)
            finally:
                if fd is not None:
                    _HELD.discard(key)
                    with contextlib.suppress(OSError):
                        os.close(fd)     # (closing the descriptor releases its lock)

    compile._phasemap_locked = True
    dispatcher.Dispatcher.compile = compile
