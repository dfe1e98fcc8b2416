"""A signal that arrives while numba compiles is raised where Python can raise it.

numba's code generator calls back into Python through ctypes: llvmlite's object-cache
hooks (``ExecutionEngine._raw_object_cache_notify`` and ``_raw_object_cache_getbuffer``)
run Python code in the middle of LLVM's work.  An exception raised inside such a
callback cannot cross the C frames below it: ctypes prints it ("Exception ignored
in ...") and LLVM goes on without the object file.  So a Ctrl-C that landed there was
swallowed (``phasemap simulate`` went on and exited 0), or left numba's library half
built, and the next call raised numba's ``RuntimeError: no compiled object yet``
(issue 44; measured: 3 of 8 interrupted first compiles).

While numba compiles in the main thread, the Python handlers of SIGINT, SIGTERM and
SIGHUP are wrapped: a signal that arrives inside one of those callbacks is sent again
:data:`RETRY` seconds later (the callbacks copy a buffer and return), and anywhere else
the handler runs at once, as before.  Handlers are restored when the outermost compile
ends.  Nothing changes for a signal that is ignored or left to the operating system.
``import phasemap`` installs it (:func:`install`), for every numba compile in the process.
Loading a compiled function from numba's cache fires no compile event and is not covered;
it takes milliseconds, where a compile takes seconds to minutes.
"""

from __future__ import annotations

import os
import signal
import threading

#: Seconds before a signal that arrived inside a ctypes callback is sent again.
RETRY = 0.01
#: The signals whose Python handlers are wrapped while numba compiles.
SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP")
                if hasattr(signal, n))
#: Functions that C code calls back: an exception raised in them is lost.
CALLBACKS = frozenset({"_raw_object_cache_notify", "_raw_object_cache_getbuffer"})

_STATE = {"depth": 0, "saved": {}, "installed": False}


def in_callback(frame) -> bool:
    """Whether ``frame`` (the one a signal interrupted) runs inside a ctypes callback of
    llvmlite's, where a raised exception would be lost."""
    while frame is not None:
        code = frame.f_code
        if code.co_name in CALLBACKS and "llvmlite" in code.co_filename:
            return True
        frame = frame.f_back
    return False


def _wrap(handler):
    def wrapped(signum, frame):
        if in_callback(frame):
            threading.Timer(RETRY, os.kill, (os.getpid(), signum)).start()
            return
        handler(signum, frame)

    wrapped.phasemap_wraps = handler
    return wrapped


def _start() -> None:
    if threading.current_thread() is not threading.main_thread():
        return  # only the main thread handles signals (and may set handlers)
    _STATE["depth"] += 1
    if _STATE["depth"] > 1:
        return
    for sig in SIGNALS:
        current = signal.getsignal(sig)
        if callable(current) and not hasattr(current, "phasemap_wraps"):
            _STATE["saved"][sig] = current
            signal.signal(sig, _wrap(current))


def _end() -> None:
    if threading.current_thread() is not threading.main_thread() or _STATE["depth"] == 0:
        return
    _STATE["depth"] -= 1
    if _STATE["depth"] == 0:
        for sig, handler in _STATE["saved"].items():
            # a handler the compiled code set meanwhile is left as it is
            if getattr(signal.getsignal(sig), "phasemap_wraps", None) is handler:
                signal.signal(sig, handler)
        _STATE["saved"].clear()


def install() -> None:
    """Listen to numba's compile events (once per process)."""
    from phasemap.core.compiletime import on_compile

    if not _STATE["installed"]:
        on_compile(_start, _end)
        _STATE["installed"] = True
