"""One process compiles a function at a time: a second that needs it meanwhile waits,
then loads what the first saved in numba's cache, instead of compiling it side by side.

Processes that need one kernel at the same moment each compiled it: the workers of a dask
cluster sharing one cache, the test suite's two processes, a script and the background
compile of its kernel (:mod:`phasemap.core.tiers`).
:func:`install` wraps numba's ``Dispatcher.compile`` for the functions whose cache is
phasemap's (:func:`phasemap.core.cache._ours`).  Inside numba's compiler lock (so the
threads of one process never wait on one another's file locks), the machine code is
first loaded from the cache if it is there, without waiting for anyone; where it is not,
an exclusive ``flock`` on ``<name>.nbk`` beside the function's index is held while numba
looks again and compiles and saves it.  A question to numba's cache alone
(``load_overload``, which :func:`phasemap.core.tiers._load` asks without compiling) takes
no lock.

The lock is one per function, not per signature (numba keeps one index per function), and
advisory: a folder phasemap does not trust (another user's, or writable by others) gets
none, a wait ends after :data:`COMPILE_WAIT` seconds, and a process forked while it holds
one closes its copy of the descriptor at once (an ``flock`` belongs to the open file, which
a fork shares: the child would otherwise hold it as long as it lives).
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

#: The locks this process holds, by index file: their descriptors (None where the wait
#: ended without one).  A compile inside a compile of the same function (another signature
#: it calls itself with) must not wait for its own lock.  (numba's compiler lock, which
#: every compile holds, keeps them to one thread at a time.)
_HELD: dict[str, int | None] = {}


def lock(cache, distrust=None) -> int | None:
    """An exclusive lock on compiling one function (``<name>.nbk`` beside its index): the
    descriptor, which the caller closes; None where no lock can be had (no ``fcntl``, a
    folder that is not writable or that ``distrust(path)`` objects to) or after
    :data:`COMPILE_WAIT` seconds of waiting."""
    try:
        import fcntl

        index = pathlib.Path(cache._cache_file._index_path)
        path = index.with_suffix(".nbk")
        index.parent.mkdir(parents=True, exist_ok=True)
        if distrust is not None and distrust(path):
            return None
        fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o600)
    except (ImportError, OSError, AttributeError):
        return None
    try:
        deadline = time.monotonic() + COMPILE_WAIT
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return fd
            except BlockingIOError:
                if time.monotonic() > deadline:
                    break
                time.sleep(0.05)
            except OSError:
                break
    except BaseException:          # (an interrupt while waiting: no descriptor left open)
        os.close(fd)
        raise
    os.close(fd)
    return None


def _forget_in_child() -> None:
    """In a forked child: close its copies of the parent's lock descriptors (closing,
    not unlocking, which would release the parent's lock too)."""
    for fd in _HELD.values():
        if fd is not None:
            with contextlib.suppress(OSError):
                os.close(fd)
    _HELD.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_in_child)


def loaded(dispatcher, sig):
    """The entry point of ``sig`` loaded from numba's cache, as numba's own compile loads
    it (counted as a hit), or None where it is not there; the caller holds numba's
    compiler lock.  Also :func:`phasemap.core.tiers._load`'s question."""
    cres = dispatcher._cache.load_overload(sig, dispatcher.targetctx)
    if cres is None:
        return None
    dispatcher._cache_hits[sig] += 1
    if not cres.objectmode:
        dispatcher.targetctx.insert_user_function(cres.entry_point, cres.fndesc,
                                                  [cres.library])
    dispatcher.add_overload(cres)
    return cres.entry_point


def install(ours, distrust=None) -> None:
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
                    or key is None or key in _HELD or not self._can_compile):
                return compile_(self, sig)
            if os.path.exists(key):         # saved already (by another process, perhaps)
                entry = loaded(self, sig)
                if entry is not None:
                    return entry
            fd = None
            try:
                fd = _HELD[key] = lock(cache, distrust)
                return compile_(self, sig)       # looks again, then compiles and saves
            finally:
                _HELD.pop(key, None)
                if fd is not None:
                    with contextlib.suppress(OSError):
                        os.close(fd)     # (closing the descriptor releases its lock)

    compile._phasemap_locked = True
    dispatcher.Dispatcher.compile = compile
