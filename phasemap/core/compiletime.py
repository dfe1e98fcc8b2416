"""How long numba has compiled in this process: what the tour and ``--timing`` report.

numba fires its ``numba:compile`` event around a real compile (not around a load from
the on-disk cache).  Compiles nest (a kernel compiles the functions it calls), so only
the outermost one of each thread is timed.  ``import phasemap`` installs the listener.
"""

from __future__ import annotations

import threading
import time

_STATE = {"seconds": 0.0, "count": 0, "installed": False}
_LOCK = threading.Lock()
_LOCAL = threading.local()


def seconds() -> float:
    """Seconds of wall time numba has spent compiling in this process (every thread's
    outermost compiles, summed)."""
    return _STATE["seconds"]


def count() -> int:
    """Outermost compiles so far in this process."""
    return _STATE["count"]


def _start() -> None:
    depth = getattr(_LOCAL, "depth", 0)
    if depth == 0:
        _LOCAL.start = time.perf_counter()
    _LOCAL.depth = depth + 1


def _end() -> None:
    depth = getattr(_LOCAL, "depth", 0)
    if depth == 0:
        return
    _LOCAL.depth = depth - 1
    if depth == 1:
        took = time.perf_counter() - _LOCAL.start
        with _LOCK:
            _STATE["seconds"] += took
            _STATE["count"] += 1


def install() -> None:
    """Listen to numba's compile events (once per process)."""
    if not _STATE["installed"]:
        on_compile(_start, _end)
        _STATE["installed"] = True


def on_compile(start, end) -> None:
    """Call ``start()`` as each numba compile begins and ``end()`` as it ends (also when
    it fails), nested compiles included, in the thread that compiles."""
    from numba.core import event

    class Listener(event.Listener):
        def on_start(self, ev):
            start()

        def on_end(self, ev):
            end()

    event.register("numba:compile", Listener())
