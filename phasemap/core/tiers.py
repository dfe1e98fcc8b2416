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
* ``off``: always the twin (to debug, or where nothing should be compiled; slow for many
  calls); a function the twin cannot reproduce is still compiled.

A shared driver that calls a model's functions at their addresses (the bifurcation
tracer, :func:`phasemap.bifurcation._trace.runs`) has twins too: where the driver's twin
calls a function at an address (:func:`at_address`), the function's machine code runs
from Python (:func:`addressed`), or its own twin where it is not compiled either, at a
stand-in address (:func:`handle`).

Machine code already in the process or in the cache always runs, except under ``off``.
Two processes never compile the same function at once in the background: the first
leaves a marker in the cache folder (``compiling/``), the other waits for its result.
One call compiles in one child whatever it needs (classify's point function and
summary), and a process runs at most :data:`MAX_JOBS` at once.  If a background compile
fails, the process compiles for itself, with one line on stderr naming the child's log
(and shows numba's error if that fails too).  A motion the twin has not finished within
a few seconds goes on to the machine code (:func:`phasemap.simulate`).  Not on Windows,
where every first call compiles (as ``eager``).

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

__all__ = ["MODES", "addressed", "at_address", "callable_at", "forced", "handle", "is_twin",
           "mode", "runner", "twin", "wait_for"]

#: The values of ``$PHASEMAP_JIT``, the default first.
MODES = ("background", "eager", "off")

#: Seconds between looks at the kernel cache for machine code another process is building.
POLL = 0.5
#: A marker older than this (seconds), or whose process is gone, is abandoned.
STALE = 1800.0
#: The longest :func:`wait_for` waits for a background compile (seconds), then compiles.
WAIT = 900.0
#: Background compiles of one process at once, niced (a call beyond them runs its twin
#: and starts its compile at a later call, once one has ended).
MAX_JOBS = max(2, os.cpu_count() or 2)

_LOCK = threading.RLock()
_STATE: dict = {}
#: the pickled warm call -> its background compile (one per call, whatever it compiles)
_JOBS: dict = {}


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
            return interpret.plain(self.function(*map(interpret.records, args)))


def twin(dispatcher):
    """The interpreted twin of the jitted ``dispatcher``, called as :func:`runner` calls
    it (:class:`phasemap.core.interpret.Unsupported` where there is none)."""
    return _Twin(interpret.interpreted(dispatcher))


def runner(dispatcher, args: tuple | None, warm=None, sig: tuple | None = None):
    """What to call with ``args`` instead of the jitted ``dispatcher``: the dispatcher itself
    where its machine code is here or in the cache (or ``$PHASEMAP_JIT`` is ``eager``),
    else its interpreted twin.

    ``warm`` is ``(function, args, kwargs)``, picklable: a call that compiles the
    dispatcher's machine code for ``args`` into the cache when run in a fresh process
    under ``PHASEMAP_JIT=eager``.  Without it, or where the cache is this process's own,
    machine code is compiled here (as ``eager``).  ``sig``, the argument types, stands
    for ``args`` where the caller knows them.
    """
    how = mode()
    if how == "eager":
        return dispatcher
    if sig is None:
        sig = tuple(dispatcher.typeof_pyval(a) for a in args)
    if how == "background" and sig in dispatcher.overloads:
        return dispatcher
    key = (id(dispatcher), sig)
    with _LOCK:
        state = _STATE.get(key)
        if state is None:
            state = _STATE[key] = {"dispatcher": dispatcher, "twin": None, "job": None,
                                   "look": 0.0, "failed": False}
            try:
                state["twin"] = _Twin(interpret.interpreted(dispatcher))
            except Exception:  # noqa: BLE001 - no twin (Unsupported, or its source): compile
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


#: address -> the Python-callable entry point of the compiled overload whose code is there
_AT: dict = {}


def addressed(dispatcher, args) -> int:
    """:func:`phasemap.core.calls.address` (the address of ``dispatcher``'s machine code for
    the argument types ``args``), remembered for :func:`at_address`: a driver's twin calls
    what the compiled driver calls at that address."""
    from phasemap.core import calls

    at = calls.address(dispatcher, args)
    if at not in _AT:
        _AT[at] = dispatcher.overloads[tuple(args)].entry_point
    return at


#: id(dispatcher) -> (dispatcher, its handle): :func:`handle`'s stand-in addresses
_HANDLES: dict = {}


def handle(dispatcher) -> int:
    """A stand-in address of ``dispatcher``'s interpreted twin (a negative number: never an
    address of machine code), for a driver's twin to take where the compiled driver takes
    the function's address and the function is not compiled yet (:func:`at_address` calls
    the twin).  Only twins may take it: machine code would jump to it."""
    with _LOCK:
        held = _HANDLES.get(id(dispatcher))
        if held is None:
            at = -(len(_HANDLES) + 1)
            _AT[at] = _Twin(interpret.interpreted(dispatcher))
            held = _HANDLES[id(dispatcher)] = (dispatcher, at)
    return held[1]


def callable_at(at: int):
    """What runs at the address ``at`` (of :func:`addressed` or :func:`handle`), called from
    Python: the machine code's entry point, or the interpreted twin."""
    return _AT[at]


def at_address(index: int | None = None):
    """What an interpreted driver calls where the compiled one calls a function at its
    address (an intrinsic of :func:`phasemap.core.calls.typer`, registered with
    :func:`phasemap.core.interpret.register`): that function's machine code, from Python,
    with the same arguments (or its twin, at a :func:`handle`).  The address is the first
    argument, or with ``index`` element ``index`` of it (a model's set of functions).

    A shared driver's twin answers while the driver compiles (the bifurcation tracer's,
    :func:`phasemap.bifurcation._trace.runs`)."""
    if index is None:
        def call(at, *args):
            return _AT[at](*args)
    else:
        def call(table, *args):
            return _AT[table[index]](*args)
    return call


def is_twin(function) -> bool:
    """Whether ``function`` (what :func:`runner` chose) is an interpreted twin."""
    return isinstance(function, _Twin)


class _Job:
    """A background compile: this process's child, or another process's (its marker)."""

    __slots__ = ("process", "marker", "log", "users")

    def __init__(self, process, marker, log=None):
        self.process, self.marker, self.log, self.users = process, marker, log, 0

    def done(self) -> bool:
        if self.process is not None:
            return self.process.poll() is not None
        return not _alive(self.marker)

    def failure(self) -> str:
        """Why it left no machine code, in a few words."""
        if self.process is None:
            return "in another process ended without machine code this process can load"
        code = self.process.returncode
        where = f"; its output is in {self.log}" if self.log else ""
        return (f"failed (exit {code}{where})" if code else
                "left no machine code in the kernel cache")

    def wait(self, timeout: float) -> None:
        if self.process is not None:
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                pass
            return
        deadline = time.monotonic() + timeout
        while not self.done() and time.monotonic() < deadline:
            time.sleep(POLL)


def wait_for(dispatcher, sig, timeout: float = WAIT) -> bool:
    """Where this process started (or waits for) a background compile of ``dispatcher``
    for the argument types ``sig``, wait for it to end (at most ``timeout`` seconds) and
    load its machine code, rather than compile the same function a second time (a fate
    map after a first simulate); True where the machine code is then loaded."""
    sig = tuple(sig)
    if sig in dispatcher.overloads:
        return True
    with _LOCK:
        state = _STATE.get((id(dispatcher), sig))
        job = None if state is None else state["job"]
    if job is None:
        return False
    job.wait(timeout)
    with _LOCK:
        return _load(dispatcher, sig)


def _ready(state, sig) -> bool:
    """Whether the machine code is (now) loaded from the cache."""
    now = time.monotonic()
    job = state["job"]
    done = job is not None and job.done()
    if not done and now < state["look"]:
        return False
    state["look"] = now + POLL
    if _load(state["dispatcher"], sig):
        return True
    if done:
        _say(f"the background compile of {_name(state['dispatcher'])} {job.failure()}; "
             "compiling it in this process")
        state["job"] = None
        state["failed"] = True
    return False


def _background(state, sig, warm) -> bool:
    """Start (once) the process that compiles into the cache, or wait for one; False where
    the caller must compile for itself."""
    from phasemap.core import cache

    if state["job"] is not None:
        return True
    if warm is None or state["failed"] or not _cached(state["dispatcher"]) or \
            os.name == "nt":  # (no os.kill(pid, 0) to see whether a marker's process lives)
        return False
    try:
        folder = cache.folder()
    except cache.CacheError:
        return False
    if folder in getattr(cache, "_PRIVATE", ()):  # another process could not load it
        return False
    try:
        payload = pickle.dumps(warm)
    except Exception:  # noqa: BLE001 - a call another process cannot make: compile here
        return False
    job = _JOBS.get(payload)
    if job is not None and not job.done():  # the same call compiles it already
        state["job"] = job
        return True
    if sum(not j.done() for j in _JOBS.values()) >= MAX_JOBS:
        return True  # the twin meanwhile; the next call tries again
    marker = folder / "compiling" / _key(state["dispatcher"], sig)
    if not _claim(marker):
        state["job"] = _Job(None, marker)  # another process compiles it: its result
        return True
    try:
        job = _spawn(payload, marker)
    except OSError:
        _release(marker)
        return False
    state["job"] = _JOBS[payload] = job
    return True


def _cached(dispatcher) -> bool:
    """Whether the dispatcher saves its machine code to the disk (``cache=True``), where
    another process's compile can reach this one."""
    from numba.core.caching import NullCache

    return not isinstance(getattr(dispatcher, "_cache", None), (NullCache, type(None)))


def _key(dispatcher, sig) -> str:
    """The marker's name: the function, its argument types, and what decides whether
    another process's machine code is this one's (numba, Python, numba's cache folder)."""
    import numba

    py = dispatcher.py_func
    text = (f"{py.__module__}.{py.__qualname__}{sig} {numba.__version__} {sys.executable} "
            f"{os.environ.get('NUMBA_CACHE_DIR', '')}")
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
    """Whether ``marker``'s process still compiles (a marker just made, its pid not yet
    written, counts as alive)."""
    try:
        age = time.time() - marker.stat().st_mtime
        text = marker.read_text().strip()
    except OSError:
        return False
    if age > STALE:
        return False
    try:
        pid = int(text)
    except ValueError:
        return age < 10.0
    if pid <= 0:
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


def _spawn(payload: bytes, marker) -> _Job:
    """The child that runs the pickled call; it writes its pid into the marker, and its
    output goes to ``<marker>.log`` (kept where it fails)."""
    log = marker.with_suffix(".log")
    # the child imports what the call needs as this process does (a declaration beside
    # the user's script, not only beside the working folder)
    path = os.pathsep.join([p for p in sys.path if p] +
                           [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
    env = dict(os.environ, PHASEMAP_JIT="eager", PYTHONPATH=path)
    with open(log, "wb") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "phasemap.core.tiers", str(marker)], stdin=subprocess.PIPE,
            stdout=out, stderr=subprocess.STDOUT, env=env, start_new_session=True,
            close_fds=True)
    try:
        process.stdin.write(payload)
        process.stdin.close()
    except OSError:
        pass
    return _Job(process, marker, log)


def _load(dispatcher, sig) -> bool:
    """Load the machine code for ``sig`` from the kernel cache, as numba's own
    ``Dispatcher.compile`` does before it compiles; False where it is not there."""
    from numba.core.compiler_lock import global_compiler_lock

    from phasemap.core.compilelock import loaded

    if sig in dispatcher.overloads:
        return True
    cache = getattr(dispatcher, "_cache", None)
    if cache is None:
        return False
    with global_compiler_lock:
        if sig in dispatcher.overloads:
            return True
        return loaded(dispatcher, sig) is not None


def _name(dispatcher) -> str:
    return dispatcher.py_func.__qualname__


def _say(message: str) -> None:
    from phasemap.core import cache

    cache._say(message)


def _main() -> int:
    """The background compile: run the pickled call on stdin, then remove the marker (and
    the log, where the call succeeded)."""
    import pathlib

    from phasemap.core.cache import _write_atomic

    marker = pathlib.Path(sys.argv[1])
    log = marker.with_suffix(".log")
    try:
        _write_atomic(marker, str(os.getpid()).encode())  # never an empty marker
        if hasattr(os, "nice"):
            os.nice(10)
        function, args, kwargs = pickle.loads(sys.stdin.buffer.read())
        function(*args, **kwargs)
    finally:
        _release(marker)
    _release(log)
    return 0


def _forget() -> None:
    """In a forked child: the parent's background compiles are not this process's."""
    global _LOCK
    _LOCK = threading.RLock()
    _STATE.clear()
    _JOBS.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget)


if __name__ == "__main__":
    sys.exit(_main())
