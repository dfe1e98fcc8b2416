"""Which tier answers a call: machine code, or its interpreted twin while numba compiles.

A model's compiled point function takes numba seconds to minutes to build (the declared
ladder's about 10 s of CPU) and answers in a microsecond; its interpreted twin
(:mod:`phasemap.core.interpret`) is ready in a fraction of a second and answers in
0.03-1.3 ms, with the same bits.  ``$PHASEMAP_JIT`` chooses how a call whose machine code
is neither in this process nor in the kernel cache is answered:

* ``background`` (the default): at once, by the twin, while a separate low-priority
  process compiles the machine code into the kernel cache.  Once it has finished, the
  calls after it load and run the machine code.  A script's first :func:`phasemap.classify`
  answers in about a second instead of ten, and a loop of them speeds up when the
  compiler is done.
* ``eager``: compile in this process before answering (numba's own way; what the test
  suite's compiled-kernel tests and ``phasemap warm`` use).
* ``off``: always the twin, never machine code (to debug, or where nothing may be
  compiled; slow for many calls).

Machine code already in the process or in the cache always runs, except under ``off``.
Two processes never compile the same function at once in the background: the first
leaves a marker in the cache folder (``compiling/``), the other waits for its result.
If the background compile fails, the process compiles for itself (and shows numba's error
if that fails too).

>>> import os
>>> from phasemap.core import tiers
>>> tiers.mode() in tiers.MODES
True
"""

from __future__ import annotations

import contextlib
import contextvars
import hashlib
import os
import pickle
import subprocess
import sys
import threading
import time

import numpy as np

from phasemap.core import interpret

__all__ = ["MODES", "forced", "mode", "runner", "wait_for"]

#: The values of ``$PHASEMAP_JIT``, the default first.
MODES = ("background", "eager", "off")

#: Seconds between looks at the kernel cache for machine code another process is building.
POLL = 0.5
#: A marker older than this (seconds), or whose process is gone, is abandoned.
STALE = 1800.0

_LOCK = threading.RLock()
_STATE: dict = {}


_FORCED: contextvars.ContextVar = contextvars.ContextVar("phasemap_jit", default=None)


def mode() -> str:
    """``$PHASEMAP_JIT``, checked: ``background`` (the default), ``eager`` or ``off``
    (or what :func:`forced` says, inside it)."""
    forced = _FORCED.get()
    if forced is not None:
        return forced
    raw = os.environ.get("PHASEMAP_JIT", "").strip().lower()
    if not raw:
        return MODES[0]
    if raw not in MODES:
        raise ValueError(f"PHASEMAP_JIT={os.environ['PHASEMAP_JIT']!r} is not one of "
                         f"{', '.join(MODES)} (unset it for the default, background)")
    return raw


@contextlib.contextmanager
def forced(how: str):
    """Inside, calls are answered as under ``PHASEMAP_JIT=how`` (in this thread or task):
    ``phasemap warm`` compiles with ``forced("eager")``, whatever the environment says."""
    if how not in MODES:
        raise ValueError(f"forced({how!r}): expected one of {', '.join(MODES)}")
    token = _FORCED.set(how)
    try:
        yield
    finally:
        _FORCED.reset(token)


class _Twin:
    """The interpreted twin of a function, run with numpy's floating-point warnings off
    (compiled code raises none)."""

    __slots__ = ("function",)

    def __init__(self, function):
        self.function = function

    def __call__(self, *args):
        with np.errstate(all="ignore"):
            return self.function(*args)


def runner(dispatcher, args: tuple, warm=None):
    """What to call with ``args`` instead of the jitted ``dispatcher``: the dispatcher itself
    where its machine code is here or in the cache (or ``$PHASEMAP_JIT`` is ``eager``),
    else its interpreted twin.

    ``warm`` is ``(function, args, kwargs)``, picklable: a call that compiles the
    dispatcher's machine code for ``args`` into the cache when run in a fresh process
    under ``PHASEMAP_JIT=eager``.  Without it, or where the cache is this process's own,
    machine code is compiled here (as ``eager``).
    """
    how = mode()
    if how == "eager":
        return dispatcher
    sig = tuple(dispatcher.typeof_pyval(a) for a in args)
    if how == "background" and sig in dispatcher.overloads:
        return dispatcher
    key = (id(dispatcher), sig)
    with _LOCK:
        state = _STATE.get(key)
        if state is None:
            state = _STATE[key] = {"dispatcher": dispatcher, "twin": None, "process": None,
                                   "look": 0.0, "marker": None}
            try:
                state["twin"] = _Twin(interpret.interpreted(dispatcher))
            except interpret.Unsupported:
                state["twin"] = None
        if state["twin"] is None:
            return dispatcher  # no twin: numba compiles, as before
        if how == "off":
            return state["twin"]
        if _ready(state, sig):
            return dispatcher
        if not _background(state, sig, warm):
            return dispatcher
        return state["twin"]


def wait_for(dispatcher, sig) -> bool:
    """Where this process started (or waits for) a background compile of ``dispatcher``
    for the argument types ``sig``, wait for it to end and load its machine code, rather
    than compile the same function a second time (a fate map after a first simulate);
    True where the machine code is then loaded."""
    sig = tuple(sig)
    if sig in dispatcher.overloads:
        return True
    with _LOCK:
        state = _STATE.get((id(dispatcher), sig))
        process = None if state is None else state["process"]
        marker = None if state is None else state["marker"]
    if state is None:
        return False
    if process is not None:
        process.wait()
    elif marker is not None:
        deadline = time.monotonic() + STALE
        while marker.exists() and _alive(marker) and time.monotonic() < deadline:
            time.sleep(POLL)
    with _LOCK:
        return _load(dispatcher, sig)


def _ready(state, sig) -> bool:
    """Whether the machine code is (now) loaded from the cache."""
    now = time.monotonic()
    process = state["process"]
    done = process is not None and process.poll() is not None
    if not done and now < state["look"]:
        return False
    state["look"] = now + POLL
    if _load(state["dispatcher"], sig):
        return True
    if done:
        why = (f"failed (exit {process.returncode})" if process.returncode else
               "left no machine code in the kernel cache")
        _say(f"the background compile of {_name(state['dispatcher'])} {why}; compiling it "
             "in this process")
        state["process"] = None
        state["failed"] = True
    return False


def _background(state, sig, warm) -> bool:
    """Start (once) the process that compiles into the cache; False where the caller
    must compile for itself."""
    from phasemap.core import cache

    if warm is None or state.get("failed") or not _cached(state["dispatcher"]):
        return False
    if state["process"] is not None or state["marker"] is not None:
        return True
    try:
        folder = cache.folder()
    except cache.CacheError:
        return False
    if folder in getattr(cache, "_PRIVATE", ()):  # another process could not load it
        return False
    marker = folder / "compiling" / _key(state["dispatcher"], sig)
    if not _claim(marker):
        state["marker"] = marker  # another process compiles it: wait for its result
        return True
    try:
        state["process"] = _spawn(warm, marker)
    except (OSError, pickle.PicklingError, TypeError, AttributeError):
        _release(marker)
        return False
    state["marker"] = marker
    return True


def _cached(dispatcher) -> bool:
    """Whether the dispatcher saves its machine code to the disk (``cache=True``), where
    another process's compile can reach this one."""
    from numba.core.caching import NullCache

    return not isinstance(getattr(dispatcher, "_cache", None), (NullCache, type(None)))


def _key(dispatcher, sig) -> str:
    py = dispatcher.py_func
    text = f"{py.__module__}.{py.__qualname__}{sig}"
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _claim(marker) -> bool:
    """Create ``marker`` (this process compiles), unless a live process holds it."""
    try:
        marker.parent.mkdir(mode=0o700, exist_ok=True)
    except OSError:
        return False
    for _ in range(2):
        try:
            fd = os.open(marker, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:
            if _alive(marker):
                return False
            _release(marker)
            continue
        except OSError:
            return False
        with os.fdopen(fd, "w") as fh:
            fh.write(str(os.getpid()))
        return True
    return False


def _alive(marker) -> bool:
    try:
        age = time.time() - marker.stat().st_mtime
        pid = int(marker.read_text().strip() or "0")
    except (OSError, ValueError):
        return False
    if age > STALE or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _release(marker) -> None:
    try:
        os.unlink(marker)
    except OSError:
        pass


def _spawn(warm, marker) -> subprocess.Popen:
    payload = pickle.dumps((warm, str(marker)))
    env = dict(os.environ, PHASEMAP_JIT="eager")
    process = subprocess.Popen(
        [sys.executable, "-m", "phasemap.core.tiers"], stdin=subprocess.PIPE,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
        start_new_session=True, close_fds=True)
    try:
        process.stdin.write(payload)
        process.stdin.close()
    except OSError:
        pass
    with open(marker, "w") as fh:  # the child's pid: it removes the marker when done
        fh.write(str(process.pid))
    return process


def _load(dispatcher, sig) -> bool:
    """Load the machine code for ``sig`` from the kernel cache, as numba's own
    ``Dispatcher.compile`` does before it compiles; False where it is not there."""
    from numba.core.compiler_lock import global_compiler_lock

    if sig in dispatcher.overloads:
        return True
    cache = getattr(dispatcher, "_cache", None)
    if cache is None:
        return False
    with global_compiler_lock:
        if sig in dispatcher.overloads:
            return True
        cres = cache.load_overload(sig, dispatcher.targetctx)
        if cres is None:
            return False
        if not cres.objectmode:
            dispatcher.targetctx.insert_user_function(cres.entry_point, cres.fndesc,
                                                      [cres.library])
        dispatcher.add_overload(cres)
    return True


def _name(dispatcher) -> str:
    return dispatcher.py_func.__qualname__


def _say(message: str) -> None:
    from phasemap.core import cache

    cache._say(message)


def _main() -> int:
    """The background compile: run the pickled call on stdin, then remove the marker."""
    try:
        os.nice(10)
    except OSError:
        pass
    warm, marker = pickle.loads(sys.stdin.buffer.read())
    try:
        function, args, kwargs = warm
        function(*args, **kwargs)
    finally:
        _release(marker)
    return 0


if __name__ == "__main__":
    sys.exit(_main())
