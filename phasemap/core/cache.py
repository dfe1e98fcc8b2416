"""The kernel cache: generated modules and numba's compiled code, on disk, verified and bounded.

phasemap prints the code it generates (a declared system's derivation, a
model's per-point contract, one grid kernel per scene shape) into real
``.py`` files so that numba can cache what it compiles from them (code built
with ``exec`` has no file and recompiles in every process).  This module
owns that folder:

* **Where.** ``$PHASEMAP_CACHE_DIR``, else ``~/.cache/phasemap/kernels``.
  A folder that cannot be created or written, that another user owns or that
  others (its group included) can write is refused, with one line on stderr; phasemap then uses
  ``$TMPDIR/phasemap-kernels-<uid>`` (created ``0700``, and refused in turn
  if it is not private), else a private temporary folder for this process
  only, removed at exit.
* **Verified.** Every generated file starts with the SHA-256 of the rest of
  its text.  A file that is empty, truncated, edited or fails to import is
  generated again, once, atomically, with one line on stderr.  numba's index
  and data files of phasemap's code are pickles holding machine code: each
  function's are hashed when phasemap saves them (``<name>.nbh`` beside the
  index), and a file that does not match, or that phasemap did not write, is
  never unpickled: it is removed and the function compiled again, with one
  line.
* **Trusted.** Nothing is loaded from a file, or a folder, that another user
  owns or that anyone else (group included) can write: the cache folder is
  refused as a whole (see *Where*), and numba's folders and files for
  phasemap's code are refused one by one (compiled instead, with one line
  naming the folder); folders that numba creates under a permissive umask
  are made writable by their owner only.
* **Atomic.** Files are written under a temporary name and renamed; a write
  that fails (a full disk) leaves no temporary file, and the module is
  generated in a private temporary folder instead (or, if that fails too,
  :class:`CacheError` says why in one line).  numba's own files that cannot
  be saved are skipped with one line: the code runs, and compiles again in
  the next process.
* **Bounded.** One least-recently-used bound, :func:`limit` bytes
  (``$PHASEMAP_CACHE_MAX_MB``, default :data:`DEFAULT_MAX_MB`), covers the
  whole cache: the generated modules (declared systems, contracts, grid
  kernels) with their numba files, wherever numba keeps them (beside the
  files, or under ``$NUMBA_CACHE_DIR``), and numba's files for phasemap's
  own compiled functions (the integrators and phase-curve tracers compiled
  per model).  Loading an entry marks it used.
* **Loaded lean.** numba's compiled code of phasemap's is loaded without
  numba's refresh of its typing and lowering registries, which a process's
  first load otherwise pays (0.4-0.6 s, most of a warm first map): loading
  machine code needs only numba's runtime, and every compilation still
  refreshes them for itself.

``phasemap cache info`` describes the cache and ``phasemap cache clear``
empties it (:func:`info`, :func:`clear`).

>>> from phasemap.core import cache
>>> cache.info().limit == cache.limit()
True
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import importlib.util
import linecache
import math
import os
import pathlib
import re
import shutil
import stat
import sys
import tempfile
import threading
from typing import Iterator
from dataclasses import dataclass

__all__ = ["CacheError", "CacheInfo", "DEFAULT_MAX_MB", "clear", "folder", "info", "limit",
           "load_module", "module_text", "prune"]

#: Default bound on the whole cache (MB, 10^6 bytes); ``$PHASEMAP_CACHE_MAX_MB`` overrides it.
DEFAULT_MAX_MB = 500

#: The first line of every generated file: this prefix, the SHA-256 of the rest, then
#: :data:`REWRITER` and which version of :mod:`phasemap.core.selects` rewrote the rest.
HASH_PREFIX = "# phasemap-sha256 "
#: Between the hash and the rewriter's version on a generated file's first line: the
#: file's name hashes the text before the rewrite, so a file another version of the
#: rewriter wrote is found by this, and generated again.
REWRITER = " rewritten-by "

#: numba's files: ``<stem>.<function>-<line>.pyXY.nbi`` and ``....pyXY.<n>.nbc``, and
#: phasemap's hashes of them, ``....pyXY.nbh``, and locks, ``....pyXY.nbl`` (its files)
#: and ``....pyXY.nbk`` (its compilation).
_NUMBA_FILE = re.compile(r"^(?P<stem>[^.]+(?:\.[^.]+?)?)-\d+\.py\d+(?:\.\d+)?\.nb[ichlk]$")
#: Python's bytecode of a generated module (earlier versions imported them from files).
_BYTECODE = re.compile(r"^(?P<stem>[^.]+)\.cpython-\d+\.pyc$")

_PACKAGE = pathlib.Path(__file__).resolve().parents[1]  # phasemap/
_LOADED: dict[str, object] = {}
_LOCK = threading.RLock()
_SAID: set[str] = set()
_ROOT: dict[tuple, pathlib.Path] = {}
_PRIVATE: list[pathlib.Path] = []


class CacheError(ValueError):
    """The kernel cache cannot be written anywhere (a full disk); the message is one line."""


def _say(message: str, unless: str = "") -> None:
    """One line on stderr, once per process (not at all if a line that starts with
    ``unless`` was said)."""
    if unless and any(said.startswith(unless) for said in _SAID):
        return
    if message not in _SAID:
        _SAID.add(message)
        print(f"phasemap: kernel cache: {message}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- where


def folder() -> pathlib.Path:
    """The folder of the generated modules (created if needed, checked, writable).

    Raises
    ------
    CacheError
        if no folder can be written at all.
    """
    env = os.environ.get("PHASEMAP_CACHE_DIR")
    key = (env, tempfile.gettempdir(), os.environ.get("HOME"))
    with _LOCK:
        if key not in _ROOT:
            _ROOT[key] = _resolve(env)
        return _ROOT[key]


def _resolve(env: str | None) -> pathlib.Path:
    root = pathlib.Path(env) if env else pathlib.Path.home() / ".cache" / "phasemap" / "kernels"
    what = "PHASEMAP_CACHE_DIR" if env else "the default folder"
    problem = _usable(root, private=False)
    if problem is None:
        return root
    fallback = pathlib.Path(tempfile.gettempdir()) / f"phasemap-kernels-{os.getuid()}"
    second = _usable(fallback, private=True)
    if second is None:
        _say(f"cannot use {root} ({what}: {problem}); using {fallback}")
        return fallback
    return _private(f"cannot use {root} ({problem}) nor {fallback} ({second})")


def _usable(root: pathlib.Path, private: bool) -> str | None:
    """Why ``root`` cannot hold the cache, or None: created if missing, ours, not
    writable by others (``private``: by no one else at all), and writable."""
    try:
        root.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = os.lstat(root)
    except OSError as err:
        return err.strerror or str(err)
    if not stat.S_ISDIR(st.st_mode):
        return "not a folder"
    if st.st_uid != os.getuid():
        return f"owned by another user (uid {st.st_uid})"
    if st.st_mode & 0o022:
        return f"writable by others (mode {stat.S_IMODE(st.st_mode):o})"
    if private and st.st_mode & 0o077:
        with contextlib.suppress(OSError):
            os.chmod(root, 0o700)
    try:
        fd, probe = tempfile.mkstemp(dir=root, prefix=".probe.")
    except OSError as err:
        return err.strerror or str(err)
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(probe)
    return None


def _private(reason: str) -> pathlib.Path:
    """A private temporary folder for this process only (removed at exit)."""
    try:
        path = pathlib.Path(tempfile.mkdtemp(prefix="phasemap-kernels-"))
    except OSError as err:
        raise CacheError(f"{reason}; and no temporary folder can be made either "
                         f"({err.strerror or err}): free some disk space or set "
                         "PHASEMAP_CACHE_DIR") from None
    if not _PRIVATE:
        atexit.register(lambda: [shutil.rmtree(p, ignore_errors=True) for p in _PRIVATE])
    _PRIVATE.append(path)
    _say(f"{reason}; compiling in a private temporary folder for this run ({path})")
    return path


# --------------------------------------------------------------------------- load


def load_module(stem: str, text, rewritten=None):
    """The module ``stem`` of the kernel cache, imported and registered in ``sys.modules``.

    The file is written from ``text()`` (a callable, called only when needed)
    if it is missing, atomically, with the hash of its text on its first line.
    What is written is ``text()`` rewritten by :func:`phasemap.core.selects.selects`;
    ``rewritten``, a callable, gives that rewrite ready made (a shipped derivation's,
    written by this version of the rewriter: :func:`rewriter`), so it is not run again.
    A file that fails the check or its import is written again once, with one
    line on stderr.  Writing a new file prunes the cache to :func:`limit`.
    """
    with _LOCK:
        if stem not in _LOADED:
            _LOADED[stem] = _load_or_generate(stem, text, rewritten)
        return _LOADED[stem]


def _load_or_generate(stem: str, text, rewritten=None):
    root = folder()
    path = root / f"{stem}.py"
    if path.exists():
        try:
            return _import(stem, path)
        except _Stale:      # (after an upgrade, every file: one line says it for all)
            _say(f"{root} holds files another version of phasemap wrote (another "
                 "phasemap/core/selects.py rewrote them); generating each again as it is "
                 "needed")
        except _Damaged as why:
            _say(f"{path} was damaged ({why}); generating it again")
        except FileNotFoundError:  # removed meanwhile by another process's pruning
            pass
    if rewritten is not None:
        body = rewritten()
    else:
        from phasemap.core.selects import selects   # numba's, imported where a kernel is made

        body = selects(text())
    try:
        root.mkdir(parents=True, exist_ok=True)   # removed while this process ran
        _write(path, body)
    except OSError as err:
        root = _private(f"cannot write {path.name} into {root} ({err.strerror or err})")
        path = root / f"{stem}.py"
        try:
            _write(path, body)
        except OSError as again:
            raise CacheError(f"cannot write the kernel cache in {root} either "
                             f"({again.strerror or again}); free some disk space or set "
                             "PHASEMAP_CACHE_DIR") from None
    try:
        module = _import(stem, path)
    except _Damaged as why:  # what was just written cannot be imported: a real error
        raise (why.__cause__ or why) from None
    prune(keep={stem})
    return module


class _Damaged(Exception):
    """A cache file that fails its check or its import (the message says how)."""


class _Stale(_Damaged):
    """A cache file intact, but rewritten by another version of the rewriter."""


def _write(path: pathlib.Path, body: str) -> None:
    """Write ``body`` under a hash line to ``path``, atomically: no temporary file is left."""
    data = body.encode()
    _write_atomic(path, hash_line(data) + data)


def hash_line(data: bytes) -> bytes:
    """The first line of a generated file whose rest is ``data``: its hash, and the
    version of the rewriter (:mod:`phasemap.core.selects`) that wrote it."""
    return f"{HASH_PREFIX}{hashlib.sha256(data).hexdigest()}{REWRITER}{rewriter()}\n".encode()


@functools.lru_cache(maxsize=1)
def rewriter() -> str:
    """The version of the rewriter (:mod:`phasemap.core.selects`): its file's hash, 16
    hex digits."""
    return hashlib.sha256((_PACKAGE / "core" / "selects.py").read_bytes()).hexdigest()[:16]


def _write_atomic(path: pathlib.Path, raw: bytes) -> None:
    """Write ``raw`` to ``path`` under a temporary name (owner-only, as mkstemp makes it)
    and rename it; no temporary file is left, whatever fails."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem[:40]}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _verified(path: pathlib.Path) -> str:
    """The text of ``path`` after its hash line, if the hash matches."""
    raw = path.read_bytes()
    head, sep, data = raw.partition(b"\n")
    if not raw:
        raise _Damaged("it is empty")
    if not head.startswith(HASH_PREFIX.encode()) or not sep:
        raise _Damaged("it has no content hash")
    digest, _, by = head[len(HASH_PREFIX):].strip().partition(REWRITER.encode())
    if hashlib.sha256(data).hexdigest().encode() != digest:
        raise _Damaged("its content does not match its hash")
    if by != rewriter().encode():
        raise _Stale("another version of phasemap/core/selects.py rewrote it")
    return data.decode()


def module_text(module) -> str:
    """The text a module of the kernel cache was generated from (its file after the hash
    line), as :func:`load_module`'s ``text`` would give it again."""
    return _verified(pathlib.Path(module.__file__))


def _import(stem: str, path: pathlib.Path):
    problem = _distrust(path)
    if problem is not None:
        raise _Damaged(problem)
    body = _verified(path)
    # numba's disk cache re-imports a function's module by name when it loads
    # the function in a new process: register it under that name.  The code is
    # compiled from the verified text, never from a .pyc beside it, one line down
    # for the hash line, so that tracebacks and ``inspect.getsource`` see the file's lines.
    name = f"phasemap_kernel_{stem}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    # what tracebacks and inspect.getsource read (the interpreter tier): the verified text,
    # not the file again (mtime None: linecache keeps it)
    linecache.cache[str(path)] = (len(body) + 1, None, ("\n" + body).splitlines(True),
                                  str(path))
    try:
        exec(compile("\n" + body, str(path), "exec"), module.__dict__)
    except Exception as err:
        sys.modules.pop(name, None)
        first = (str(err).strip().splitlines() or [""])[0]
        raise _Damaged(f"{type(err).__name__}: {first}" if first else type(err).__name__) \
            from err
    _touch(path)
    return module


def _touch(path) -> None:
    with contextlib.suppress(OSError):
        os.utime(path)


# --------------------------------------------------------------------------- numba's files


def _probe():
    """A function whose line number the numba locators read (they need one)."""


@functools.lru_cache(maxsize=None)
def _numba_folder_for(source_folder: pathlib.Path, numba_cache_dir: str) -> pathlib.Path | None:
    """Where numba keeps what it compiles from files in ``source_folder``."""
    from numba.core import caching

    py_file = str(source_folder / "__phasemap_probe__.py")
    for cls in (caching.UserProvidedCacheLocator, caching.InTreeCacheLocator,
                caching.UserWideCacheLocator):
        if cls is caching.UserProvidedCacheLocator and not numba_cache_dir:
            continue
        locator = cls(_probe, py_file)
        try:
            locator.ensure_cache_path()
        except OSError:
            continue
        return pathlib.Path(locator.get_cache_path())
    return None


def _numba_folder(source_folder: pathlib.Path) -> pathlib.Path | None:
    from numba.core import config

    return _numba_folder_for(source_folder, config.CACHE_DIR or "")


def _ours(cache) -> bool:
    """Whether a numba cache belongs to phasemap's code or to the kernel cache."""
    func = getattr(cache, "_py_func", None)
    source = getattr(getattr(func, "__code__", None), "co_filename", "")
    if not source:
        return False
    parent = pathlib.Path(source).resolve().parent
    if parent == _PACKAGE or _PACKAGE in parent.parents:
        return True
    return any(parent == root.resolve() for root in set(_ROOT.values()) | set(_PRIVATE))


def _numba_files(cache) -> list[pathlib.Path]:
    """numba's index and data files of one function, then phasemap's hash file of them."""
    index = pathlib.Path(cache._cache_file._index_path)
    base = index.name[:-len(".nbi")]
    return [index, *sorted(index.parent.glob(f"{glob_escape(base)}.*.nbc")),
            index.with_suffix(".nbh")]


def _distrust(path: pathlib.Path, *, owner_only: bool = False) -> str | None:
    """Why the file or folder ``path`` may hold what another user wrote, or None: it and
    its folder must belong to this user (or to root) and, unless ``owner_only``, be
    writable by no one else, its group included, but for a folder with the sticky bit
    (like /tmp: there only an entry's owner may replace it).  A missing ``path`` is
    checked by its folder alone."""
    uid = os.getuid()
    for p in (path, path.parent):
        try:
            st = os.stat(p)
        except FileNotFoundError:
            continue
        except OSError as err:
            return f"{p}: {err.strerror or err}"
        if st.st_uid not in (uid, 0):
            return f"{p} is owned by another user (uid {st.st_uid})"
        sticky = stat.S_ISDIR(st.st_mode) and st.st_mode & stat.S_ISVTX
        if not owner_only and st.st_mode & 0o022 and not sticky:
            return f"{p} is writable by others (mode {stat.S_IMODE(st.st_mode):o})"
    return None


@contextlib.contextmanager
def _locked(index: pathlib.Path, exclusive: bool) -> Iterator[None]:
    """Hold a lock on one function's numba files (``<name>.nbl`` beside its index): shared
    while they are checked and loaded, exclusive while they are saved and hashed, so that a
    process never reads an index whose hash another process has not written yet (two
    workers compiling one kernel at once).  Without ``fcntl`` (or where the lock file
    cannot be made) the block runs unlocked."""
    try:
        import fcntl

        fd = os.open(index.with_suffix(".nbl"), os.O_RDWR | os.O_CREAT, 0o600)
    except (ImportError, OSError):
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        yield
    finally:
        os.close(fd)


def _first_distrust(files, owner_only: bool = False) -> str | None:
    """What :func:`_distrust` finds wrong with the first of ``files`` it objects to, or None."""
    return next(filter(None, (_distrust(f, owner_only=owner_only) for f in files)), None)


#: The modules of ``core/`` whose compiled code (njit functions, intrinsics) the cached
#: functions of other files compile in: the calls by address, the grid driver's pieces,
#: ``grow``, the events and the numerics; and ``jit``, whose dispatcher decides which
#: overloads a compiled caller links.  numba checks a cached function against its
#: own file alone, so an edit of one of these would leave the functions that compiled it
#: in stale; their hash goes into every hash file, and a change makes a miss
#: (tests/test_kernel_cache.py checks that every module of ``core/`` with compiled code
#: is here).
SHARED = ("calls", "codegen", "compile", "events", "jit", "numerics", "selects")


@functools.lru_cache(maxsize=1)
def _shared() -> str:
    """The hash file's last line: the SHA-256 of the sources of :data:`SHARED`."""
    h = hashlib.sha256()
    for name in SHARED:
        h.update((_PACKAGE / "core" / f"{name}.py").read_bytes())
    return f"{h.hexdigest()}  phasemap's shared compiled code\n"


def _digests(files: list[pathlib.Path]) -> str:
    """The hash file's text: one ``<sha256>  <name>`` line per numba file, then the hash
    of phasemap's shared compiled code (:data:`SHARED`)."""
    return _file_digests(files) + _shared()


def _file_digests(files: list[pathlib.Path]) -> str:
    lines = []
    for f in files:
        with contextlib.suppress(FileNotFoundError):
            lines.append(f"{hashlib.sha256(f.read_bytes()).hexdigest()}  {f.name}\n")
    return "".join(lines)


#: Why numba's files without a hash file of phasemap's are not loaded.
UNHASHED = "saved without phasemap's hash: by an older phasemap, or not by phasemap"
#: Why numba's files saved before phasemap's shared compiled code changed are not loaded.
STALE = "phasemap's shared compiled code has changed since they were saved"


def _unverified(files: list[pathlib.Path]) -> str | None:
    """Why numba's files of one function are not the ones phasemap saved, or None."""
    *data, hashes = files
    if not hashes.exists():
        return UNHASHED
    try:
        recorded = hashes.read_text()
    except (OSError, UnicodeDecodeError) as err:
        return f"its hash file cannot be read ({type(err).__name__})"
    if _digests(data) != recorded:
        saved = _file_digests(data)
        if recorded.startswith(saved) and "\n" not in recorded[len(saved):].rstrip("\n"):
            return STALE  # the files are what phasemap saved, against other shared code
        return "they do not match the hashes phasemap saved"
    return None


def _owner_only(paths) -> None:
    """Make each of ``paths`` that is ours writable by its owner only (numba creates its
    folders and files with the umask's mode: group-writable under ``umask 002``,
    world-writable under ``umask 000``)."""
    uid = os.getuid()
    for where in paths:
        with contextlib.suppress(OSError):
            st = os.stat(where)
            if st.st_uid == uid and st.st_mode & 0o022:
                os.chmod(where, stat.S_IMODE(st.st_mode) & ~0o022)


def glob_escape(text: str) -> str:
    return re.sub(r"([*?\[])", r"[\1]", text)


def _load_without_refresh(cache, sig, target_context, load):
    """numba's ``Cache.load_overload`` without its refresh of the target's registries.

    numba refreshes the target context before every load: the first refresh in a
    process imports and installs its typing and lowering registries (about 300
    modules of its NumPy, linalg and random support), 0.4-0.6 s, most of a warm
    process's first map.  Loading machine code from the disk needs none of it,
    only numba's runtime (NRT) linked in; any compilation refreshes for itself
    (numba's ``CompilerBase`` does), so a miss that compiles after this is unchanged.
    Where numba's private hooks are not there (another numba), its own load runs.
    """
    inner = getattr(cache, "_load_overload", None)
    guard = getattr(cache, "_guard_against_spurious_io_errors", None)
    if inner is None or guard is None:
        return load(cache, sig, target_context)
    from numba.core.runtime import rtsys

    rtsys.initialize(target_context)
    with guard():
        return inner(sig, target_context)


def _guard_numba() -> None:
    """Make numba treat a damaged cache file of phasemap's as a miss, tolerate a full
    disk when it saves one, mark what it loads as used (the LRU bound), and load it
    without refreshing its registries (:func:`_load_without_refresh`)."""
    from numba.core import caching

    cls = caching.Cache
    if getattr(cls, "_phasemap_guarded", False):
        return
    load, save = cls.load_overload, cls.save_overload

    def damaged(self, files, why: str, verb: str = "was damaged") -> None:
        _say(f"numba's cache of {self._name} {verb} ({why}); compiling it again")
        for f in files:
            with contextlib.suppress(OSError):
                f.unlink()

    @functools.wraps(load)
    def load_overload(self, sig, target_context):
        if not _ours(self):
            return load(self, sig, target_context)
        files = _numba_files(self)
        if not files[0].exists():
            return None  # nothing saved yet: numba compiles
        problem = _first_distrust(files, owner_only=True)
        if problem is not None:  # another user's: never unpickled, never removed
            _say(f"not loading numba's cache of {self._name}: {problem}; compiling it "
                 "instead, and not saving it (make the folder yours and private, or set "
                 "NUMBA_CACHE_DIR)")
            return None
        with _locked(files[0], exclusive=False):
            problem = _first_distrust(files) or _unverified(files)
            if problem is not None:  # ours, but others could have written it, or damaged
                _owner_only([files[0].parent])
                damaged(self, files, problem, {UNHASHED: "is not loaded",
                                               STALE: "is out of date"}.get(problem,
                                                                            "was damaged"))
                return None
            try:
                data = _load_without_refresh(self, sig, target_context, load)
            except Exception as err:
                damaged(self, files, type(err).__name__)
                return None
        if data is not None:
            _touch(self._cache_file._index_path)
        return data

    @functools.wraps(save)
    def save_overload(self, sig, data):
        if not _ours(self):
            return save(self, sig, data)
        files = _numba_files(self)
        _owner_only([files[0].parent])
        # numba reads the index it adds to: it must be ours and what phasemap saved
        problem = _distrust(files[0].parent) or _first_distrust(files, owner_only=True)
        if problem is not None:  # said when it was not loaded, if it was another user's
            _say(f"not saving the compiled {self._name}: {problem}; it will be compiled "
                 "again next time (make the folder yours and private, or set "
                 "NUMBA_CACHE_DIR)", unless=f"not loading numba's cache of {self._name}")
            return None
        try:
            with _locked(files[0], exclusive=True):
                if files[0].exists() and (_first_distrust(files) or _unverified(files)):
                    _remove(files)
                save(self, sig, data)
                files = _numba_files(self)
                _owner_only(files[:-1])
                _write_atomic(files[-1], _digests(files[:-1]).encode())
        except OSError as err:
            _say(f"cannot save the compiled {self._name} in {self._cache_path} "
                 f"({err.strerror or err}); it will be compiled again next time")

    cls.load_overload, cls.save_overload = load_overload, save_overload
    cls._phasemap_guarded = True

    # one process compiles a function at a time (phasemap.core.compilelock)
    from phasemap.core import compilelock

    compilelock.install(_ours, _distrust)


_guard_numba()


# --------------------------------------------------------------------------- the bound


#: What ``PHASEMAP_CACHE_MAX_MB=inf`` gives: no bound.
UNBOUNDED = 2 ** 63 - 1


def limit() -> int:
    """The bound on the whole cache, in bytes (``$PHASEMAP_CACHE_MAX_MB``: a number of
    megabytes, 0 or more; ``inf`` for no bound)."""
    text = os.environ.get("PHASEMAP_CACHE_MAX_MB", "")
    try:
        mb = float(text) if text else DEFAULT_MAX_MB
    except ValueError:
        mb = math.nan
    if not mb >= 0:  # negative, or not a number
        raise ValueError(f"PHASEMAP_CACHE_MAX_MB must be a number of megabytes, 0 or more "
                         f"(inf for no bound), got {text!r}")
    return UNBOUNDED if mb * 1e6 >= UNBOUNDED else int(mb * 1e6)


@dataclass
class _Entry:
    stem: str
    kind: str
    files: list[pathlib.Path]
    size: int = 0
    used: float = 0.0


def _kind(stem: str, generated: bool) -> str:
    if not generated:
        return "compiled"
    for kind in ("declared", "contract", "grid"):
        if f"_{kind}_" in stem:
            return kind
    return "other"


def _folders() -> list[tuple[pathlib.Path, bool]]:
    """``(folder, generated)``: the generated modules, numba's files for them, and
    numba's files for phasemap's own functions."""
    root = folder()
    out = [(root, True)]
    # numba keeps a folder per source folder: the package's subpackages have their own
    sources = [(root, True), *((d, False) for d in _source_folders(_PACKAGE))]
    for source, generated in sources:
        numba_dir = _numba_folder(source)
        if numba_dir is not None and numba_dir != root and (numba_dir, generated) not in out:
            out.append((numba_dir, generated))
    return out


@functools.lru_cache(maxsize=None)
def _source_folders(package: pathlib.Path) -> tuple[pathlib.Path, ...]:
    """The package's folders that hold Python files (numba caches per folder)."""
    return tuple(sorted({package} | {p.parent for p in package.rglob("*.py")
                                     if "__pycache__" not in p.parts}))


def _entries() -> list[_Entry]:
    entries: dict[tuple[str, bool], _Entry] = {}
    root = folder()
    for where, generated in _folders():
        try:
            names = os.listdir(where)
        except OSError:
            continue
        for name in names:
            if generated and where == root and name.endswith(".py"):
                stem = name[:-3]
            else:
                m = _NUMBA_FILE.match(name) or (_BYTECODE.match(name) if generated else None)
                if m is None:
                    continue
                stem = m["stem"].split(".")[0] if generated else m["stem"]
            path = where / name
            try:
                st = path.stat()
            except OSError:  # removed meanwhile (another process pruning)
                continue
            e = entries.setdefault((stem, generated), _Entry(stem, _kind(stem, generated), []))
            e.files.append(path)
            e.size += st.st_size
            e.used = max(e.used, st.st_mtime)
    return list(entries.values())


def prune(bound: int | None = None, keep=()) -> int:
    """Delete the least recently used entries until the cache holds at most ``bound``
    bytes (default :func:`limit`); return the bytes deleted.

    Entries loaded by this process and those in ``keep`` stay.  Files that
    another process removes meanwhile are skipped.
    """
    bound = limit() if bound is None else bound
    entries = _entries()
    total = sum(e.size for e in entries)
    freed = 0
    for e in sorted(entries, key=lambda e: e.used):
        if total - freed <= bound:
            break
        if e.stem in _LOADED or e.stem in keep:
            continue
        freed += _remove(e.files)
    return freed


def _remove(files) -> int:
    freed = 0
    for f in files:
        try:
            size = f.stat().st_size
            f.unlink()
        except OSError:  # already gone: another process pruned it
            continue
        freed += size
    return freed


@dataclass(frozen=True)
class CacheInfo:
    """What :func:`info` reports."""

    folder: pathlib.Path
    numba_folders: tuple[pathlib.Path, ...]
    counts: dict
    size: int
    limit: int

    def text(self) -> str:
        from phasemap.core.progress import human_bytes

        kinds = {"declared": "declared systems", "contract": "model contracts",
                 "grid": "grid kernels", "other": "other generated modules",
                 "compiled": "phasemap functions compiled per model (integrators, tracers)"}
        lines = [f"phasemap kernel cache {self.folder}"]
        lines += [f"  numba     {p}" for p in self.numba_folders]
        for kind, label in kinds.items():
            if self.counts.get(kind):
                lines.append(f"  {self.counts[kind]:>5}  {label}")
        if self.limit >= UNBOUNDED:
            lines.append(f"  size      {human_bytes(self.size)}, with no bound "
                         "(PHASEMAP_CACHE_MAX_MB=inf)")
        else:
            lines.append(f"  size      {human_bytes(self.size)} of at most "
                         f"{human_bytes(self.limit)} (PHASEMAP_CACHE_MAX_MB); the least "
                         "recently used go first")
        return "\n".join(lines)


def info() -> CacheInfo:
    """The cache's folders, its entries by kind, its size and its bound."""
    entries = _entries()
    counts: dict[str, int] = {}
    for e in entries:
        # (lock files alone are no function: a compile that failed leaves its .nbk)
        if not all(f.suffix in (".nbl", ".nbk") for f in e.files):
            counts[e.kind] = counts.get(e.kind, 0) + 1
    numba = tuple(dict.fromkeys(p for p, _ in _folders()[1:]))
    return CacheInfo(folder(), numba, counts, sum(e.size for e in entries), limit())


def clear() -> tuple[int, int]:
    """Delete every entry (also numba's files for phasemap's own functions); return
    ``(files, bytes)`` deleted.  Modules already imported keep working in this
    process; everything is generated and compiled again by the next one."""
    files = [f for e in _entries() for f in e.files]
    return len(files), _remove(files)
