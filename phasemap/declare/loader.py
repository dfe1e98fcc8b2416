"""Declared systems' models, loaded from the kernel cache without sympy when it is warm.

A declared system (:mod:`phasemap.declare`) is derived with sympy once; the
generated module then lives in the kernel cache.  Building the
:class:`phasemap.declare.System` itself still imports sympy (about a second),
so a process that only maps a declared model would pay for sympy every time.
It does not: beside the generated module, the cache keeps a *manifest* of the
model (its variables, branches and the name of the generated module), keyed
on a hash of

* the declaration file's own bytes, and the bytes of every phasemap module
  it imports (its domain check may live in one);
* the sources of :mod:`phasemap.declare` and the shared numerics, this module,
  and the versions of sympy, numba, numpy and phasemap.

A declaration is eligible when it imports nothing but ``math``, ``numpy``,
``sympy`` and phasemap modules, calls no ``open``/``exec``/``eval``/``__import__``,
and its ``check`` (if any) is a function of another importable module: then
everything its model depends on is in the key, and a changed file (or
anything it imports from phasemap) misses the cache, which derives the new
model.  Otherwise every process builds the declaration, as before.

A model loaded from a manifest carries a :class:`Declaration` that builds the
System (with sympy) only when something asks for it: re-deriving,
:func:`phasemap.declare.conditions`, printing its equations.

The built-in declarations (``phasemap.systems.DECLARED``) ship their derivations in the
package (:data:`SHIPPED`, written by ``python -m phasemap.systems.ship``): with an empty
kernel cache, their first model is read from there, without sympy, while the shipped key
(:func:`key_of` without the versions) is the tree's.
"""

from __future__ import annotations

import ast
import hashlib
import importlib
import importlib.util
import json
import os
import pathlib
import sys

import numba
import numpy as np

from phasemap.core.memo import Memo
from phasemap.core import cache as _cache
from phasemap.core import codegen as _codegen
from phasemap._version import __version__
from phasemap.core.model import Candidate, Derived, Dynamics, Model, Variable
from phasemap.declare.runtime import checks, declare_sources

#: Bumped when the manifest's layout changes (3: the default axes as pairs in their order).
FORMAT = 3
#: Imports a declaration may make and stay eligible (their versions are in the key).
_PURE = {"__future__", "math", "numpy", "sympy"}
#: Calls that may read what the key does not hold.
_DYNAMIC = {"open", "exec", "eval", "compile", "__import__", "import_module", "read_text",
            "read_bytes", "loadtxt", "load", "genfromtxt"}
_PACKAGE = pathlib.Path(__file__).resolve().parents[1]  # phasemap/
#: The derivations of the built-in declarations, shipped in the package so that a first
#: classify does not wait for sympy: one JSON file per declaration module, written by
#: ``python -m phasemap.systems.ship`` (:mod:`phasemap.systems.ship`).
SHIPPED = _PACKAGE / "systems" / "derived"

#: a declaration's source (module name or file) -> its Model, and its System
_MODELS = Memo("loader.models")
_SYSTEMS = Memo("loader.systems")
#: a shipped derivation's file and the hash of its bytes -> its JSON data
_RECORDS = Memo("loader.records")


class _Miss(Exception):
    """Not in the kernel cache."""


def _missing():
    raise _Miss


def load(source) -> Model:
    """The Model declared in a Python file: its ``SYSTEM`` (a :class:`System`).

    With a warm kernel cache and an unchanged file, the model is loaded without
    running the file (and without sympy): see :mod:`phasemap.declare.loader`.
    ``phasemap.get_model(path)`` and every command that takes a model
    (``phasemap atlas my_rod.py ...``) call it for a path ending in ``.py``.

    Parameters
    ----------
    path : str or os.PathLike
        a Python file that assigns a :class:`System` to ``SYSTEM``.

    Returns
    -------
    phasemap.Model
        ``SYSTEM.model``: derived once per declaration, then loaded from the
        kernel cache.

    Raises
    ------
    ValueError
        naming the file when it cannot be read or declares no system, and the
        part of the declaration that is wrong.

    Examples
    --------
    >>> import phasemap.systems.painleve_rod as rod
    >>> from phasemap.declare import load
    >>> model = load(rod.__file__)
    >>> model.name, [v.name for v in model.state]
    ('painleve_rod', ['theta', 'omega', 'xdot'])
    """
    source = _normal(source)
    return _MODELS.get((), (source,), lambda: _load(source))


def _load(source: str) -> Model:
    path = _file(source)
    key = key_of(path)
    model = _from_manifest(key, path, source) if key else None
    if model is None:
        model = _from_shipped(path, source)
    if model is None:
        S = system(source)
        model = S.model
        if key:
            _write_manifest(key, path, S, model)
    return model


def system(source):
    """The :class:`phasemap.declare.System` of a module name or a declaration file (built
    with sympy)."""
    source = _normal(source)
    return _SYSTEMS.get((), (source,), lambda: _system(source))


def _system(source: str):
    from phasemap.declare.system import System

    if not source.endswith(".py"):
        S = importlib.import_module(source).SYSTEM
    else:
        p = pathlib.Path(source)
        name = "phasemap_declared_" + hashlib.sha256(source.encode()).hexdigest()[:12]
        spec = importlib.util.spec_from_file_location(name, p)
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as e:  # a user's file: report it as a declaration error
            raise ValueError(f"{source}: the declaration failed to run: "
                             f"{type(e).__name__}: {e}") from e
        S = getattr(module, "SYSTEM", None)
        if not isinstance(S, System):
            raise ValueError(f"{source}: the file must define "
                             "SYSTEM = phasemap.declare.System(...)")
    return S


class Declaration:
    """The System behind a model loaded from the kernel cache, built on first use.

    Attribute access reads the :class:`phasemap.declare.System` (building it, with
    sympy, the first time); pickling ships only the source, so another process
    loads the model from its own cache.
    """

    def __init__(self, source: str, sha256: str | None = None):
        self.source = source
        #: the declaration's hash (:func:`phasemap.declare.build.declaration_sha256`),
        #: recorded when it was derived
        self.sha256 = sha256

    @property
    def system(self):
        """The System itself."""
        return system(self.source)

    @property
    def model(self) -> Model:
        return load(self.source)

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.system, name)

    def __reduce__(self):
        return Declaration, (self.source, self.sha256)

    def __repr__(self) -> str:
        return f"Declaration({self.source!r})"


def _normal(source) -> str:
    s = os.fspath(source)
    return os.path.abspath(s) if s.endswith(".py") else s


def _file(source: str) -> pathlib.Path:
    if source.endswith(".py"):
        p = pathlib.Path(source)
        if not p.is_file():
            raise ValueError(f"{source}: no such declaration file")
        return p
    return _module_file(source) or pathlib.Path(importlib.util.find_spec(source).origin)


def _module_file(name: str) -> pathlib.Path | None:
    """The file of a phasemap module, found without importing it (or None)."""
    parts = name.split(".")
    if parts[0] != "phasemap":
        return None
    base = _PACKAGE.joinpath(*parts[1:])
    for p in (base.with_suffix(".py"), base / "__init__.py"):
        if p.is_file():
            return p
    return None


def key_of(path: pathlib.Path, versions: bool = True) -> str | None:
    """The manifest key of a declaration file, or None when it is not eligible.

    ``versions=False``: the key of a shipped derivation (:data:`SHIPPED`), which holds the
    declaration and the sources that derive it but not the versions of sympy, numba, numpy
    and phasemap: a derivation made with one sympy is as right under another (its text is
    plain Python over ``math``), and numba compiles it for the machine it runs on."""
    try:
        text = path.read_bytes()
        tree = ast.parse(text)
    except (OSError, SyntaxError, ValueError):
        return None
    h = hashlib.sha256((f"{FORMAT} {numba.__version__} {np.__version__} {__version__}"
                        if versions else f"{FORMAT} shipped").encode())
    h.update(text)
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            if getattr(f, "id", None) in _DYNAMIC or getattr(f, "attr", None) in _DYNAMIC:
                return None
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level or not node.module:
                return None
            names = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
            if node.module.split(".")[0] in _PURE:
                names = [node.module]
        for name in names:
            root = name.split(".")[0]
            if root in _PURE:
                continue
            if root != "phasemap":
                return None
            f = _module_file(name)
            if f is not None:
                h.update(f.read_bytes())
    sympy = importlib.util.find_spec("sympy")
    if sympy is None or sympy.origin is None:
        return None
    if versions:
        release = pathlib.Path(sympy.origin).parent / "release.py"
        h.update(release.read_bytes() if release.is_file() else b"")
    for f in declare_sources() + [pathlib.Path(__file__)]:
        h.update(f.read_bytes())
    return h.hexdigest()


def _stem(key: str, path: pathlib.Path) -> str:
    return f"{path.stem}_declared_manifest_{key[:20]}"


def _from_manifest(key: str, path: pathlib.Path, source: str) -> Model | None:
    try:
        manifest = _codegen.load_module(_stem(key, path), _missing)
    except _Miss:
        return None
    if manifest.KEY != key or manifest.MODEL is None:
        return None
    data = json.loads(manifest.MODEL)
    try:
        module = _codegen.load_module(data["module"], _missing)
    except _Miss:  # the generated module was pruned: derive it again
        return None
    return _rebuilt(data, module, source)


def _rebuilt(data: dict, module, source: str) -> Model:
    """The model of a manifest's ``data`` over its generated ``module``, with its check and
    its lazy declaration."""
    check = _resolve(data["check"]) if data["check"] else None
    return build(data, module, check, Declaration(source, data.get("declaration_sha256")))


def shipped_file(source: str) -> pathlib.Path | None:
    """Where the shipped derivation of a built-in declaration (a module of phasemap named
    by ``source``) lives, or None for any other declaration."""
    if source.endswith(".py") or not source.startswith("phasemap."):
        return None
    return SHIPPED / f"{source}.json"


def shipped_key(source: str) -> str | None:
    """The key a shipped derivation of the declaration module ``source`` must hold to be
    used: :func:`key_of` its file without the versions."""
    return key_of(_file(source), versions=False)


def shipped_record(source: str) -> dict | None:
    """The shipped derivation of the built-in declaration module ``source`` as its JSON
    data (read once per process), or None: not a built-in, no file, not JSON."""
    file = shipped_file(source)
    try:
        raw = file.read_bytes()
    except (AttributeError, OSError):
        return None
    return _RECORDS.get((), (str(file), hashlib.sha256(raw).hexdigest()),
                        lambda: _read_record(raw))


def _read_record(raw: bytes) -> dict | None:
    try:
        data = json.loads(raw)
    except ValueError:
        return None
    return data if isinstance(data, dict) else None


def _from_shipped(path: pathlib.Path, source: str) -> Model | None:
    """The model of a built-in declaration from its derivation shipped in the package, when
    the declaration and the sources that derive it are those it was made from."""
    data = shipped_record(source)
    if data is None:
        return None
    key = key_of(path, versions=False)
    if data.get("format") != FORMAT or key is None or data.get("key") != key:
        return None     # stale: derived again (tests/test_shipped.py says so first)
    ready = shipped_rewrite(data)
    module = _codegen.load_module(data["model"]["module"], lambda: data["source"],
                                  None if ready is None else (lambda: ready))
    return _rebuilt(data["model"], module, source)


def shipped_rewrite(data: dict) -> str | None:
    """The rewrite of a shipped record's module text (:mod:`phasemap.core.selects`) that
    the record carries, where this version of the rewriter made it of this text (written
    by ``python -m phasemap.systems.ship``); else None: the text is rewritten on use."""
    ready = data.get("rewritten") or {}
    source = data.get("source")
    if (ready.get("by") == _cache.rewriter() and isinstance(ready.get("text"), str)
            and isinstance(source, str)
            and ready.get("of") == hashlib.sha256(source.encode()).hexdigest()):
        return ready["text"]
    return None


def described(S, model: Model) -> dict | None:
    """:func:`manifest` with the declaration's hash (what a manifest stores)."""
    from phasemap.declare.build import declaration_sha256  # S is built: sympy is loaded already

    data = manifest(S, model)
    if data is not None:
        data["declaration_sha256"] = declaration_sha256(S)
    return data


def _write_manifest(key: str, path: pathlib.Path, S, model: Model) -> None:
    data = described(S, model)
    text = (f'"""The model of {path.name}, as phasemap.declare.loader loads it without sympy: '
            'generated, do not edit."""\n\n'
            f"KEY = {key!r}\nMODEL = {None if data is None else json.dumps(data)!r}\n")
    _codegen.load_module(_stem(key, path), lambda: text)


def _resolve(ref: str):
    module, _, qualname = ref.partition(":")
    obj = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def _reference(check) -> str | None:
    """``module:qualname`` of a check function another process can import without the
    declaration, or None."""
    module = getattr(check, "__module__", None)
    qualname = getattr(check, "__qualname__", "")
    if not module or "<" in qualname or module == "__main__":
        return None
    mod = sys.modules.get(module)
    if mod is None or "SYSTEM" in vars(mod):
        return None  # the declaration's own module: importing it builds the System
    try:
        return f"{module}:{qualname}" if _resolve(f"{module}:{qualname}") is check else None
    except (ImportError, AttributeError):
        return None


def _variable(v: Variable) -> list:
    return [v.name, v.units, v.long_name, v.symbol, v.default, v.lower, v.upper,
            v.lower_open, v.upper_open]


def manifest(S, model: Model) -> dict | None:
    """What :func:`build` needs to rebuild ``model`` from its generated module, as JSON
    data; None when the model cannot be rebuilt without its declaration."""
    from phasemap.declare.api import numeric_bound

    if not all(numeric_bound(b) for c in S.coordinates for b in (c.lower, c.upper)):
        return None  # a bound that is an expression is checked through sympy
    module = sys.modules[model.velocity_scale.py_func.__module__]
    prefix = "phasemap_kernel_"
    check = None
    if S.check is not None:
        check = _reference(S.check)
        if check is None:
            return None
    funcs = [b.func for b in model.candidates] + [model.velocity_scale] + \
        [b.edge for b in model.candidates if b.edge is not None] + \
        ([model.inside] if model.inside is not None else [])
    if not module.__name__.startswith(prefix) or any(
            getattr(module, f.py_func.__name__, None) is not f for f in funcs) or any(
            getattr(np, d.func.__name__, None) is not d.func for d in model.derived):
        return None
    dyn = model.dynamics
    return {
        "module": module.__name__[len(prefix):],
        "name": model.name, "title": model.title, "citation": model.citation,
        "state": [_variable(v) for v in model.state],
        "params": [_variable(v) for v in model.params],
        "derived": [[d.name, d.source, d.func.__name__] for d in model.derived],
        "candidates": [[b.name, b.direction, b.func.py_func.__name__, list(b.args),
                        None if b.bound is None else list(b.bound),
                        None if b.edge is None else b.edge.py_func.__name__]
                       for b in model.candidates],
        "accelerations": [_variable(v) for v in model.accelerations],
        "reactions": [_variable(v) for v in model.reactions],
        "coefficient": _variable(model.coefficient),
        "velocity": model.velocity,
        "velocity_scale": model.velocity_scale.py_func.__name__,
        "check": check,
        # pairs, not a mapping: the axes' order is the map's (a record written with sorted
        # keys would otherwise turn (theta, f) into (f, theta))
        "default_axes": [[k, list(v)] for k, v in model.default_axes.items()],
        "dynamics": None if dyn is None else {
            "coordinates": [list(c) for c in dyn.coordinates],
            "positions": [_variable(v) for v in dyn.positions],
            "stick_is_rest": dyn.stick_is_rest,
            "edges": {k: list(v) for k, v in dyn.edges.items()}},
        "inside": None if model.inside is None else model.inside.py_func.__name__,
        "domain_text": model.domain_text,
        "kinks": None if model.kinks is None else list(model.kinks),
    }


def build(data: dict, module, check, declaration) -> Model:
    """The Model of ``data`` (see :func:`manifest`) over its generated ``module``."""
    var = (lambda v: Variable(*v))
    dyn = data["dynamics"]
    inside = getattr(module, data["inside"]) if data["inside"] else None
    return Model(
        name=data["name"], title=data["title"], citation=data["citation"],
        state=tuple(map(var, data["state"])), params=tuple(map(var, data["params"])),
        derived=tuple(Derived(n, s, getattr(np, f)) for n, s, f in data["derived"]),
        candidates=tuple(Candidate(n, float(d), getattr(module, f), tuple(a),
                                None if b is None else (b[0], int(b[1])),
                                None if e is None else getattr(module, e))
                         for n, d, f, a, b, e in data["candidates"]),
        accelerations=tuple(map(var, data["accelerations"])),
        reactions=tuple(map(var, data["reactions"])),
        coefficient=var(data["coefficient"]),
        velocity=data["velocity"], velocity_scale=getattr(module, data["velocity_scale"]),
        default_axes={k: tuple(v) for k, v in data["default_axes"]},
        dynamics=None if dyn is None else Dynamics(
            coordinates=tuple(tuple(c) for c in dyn["coordinates"]),
            positions=tuple(map(var, dyn["positions"])), stick_is_rest=dyn["stick_is_rest"],
            edges={k: tuple(v) for k, v in dyn["edges"].items()}),
        check=checks(data["name"], check, inside, data["domain_text"]),
        declaration=declaration, inside=inside, domain_text=data["domain_text"],
        kinks=None if data["kinks"] is None else tuple(data["kinks"]))



def twin(model: Model):
    """The :class:`phasemap.declare.System` of a hand-written model's declared twin
    (:attr:`phasemap.Model.twin`), or None when it has none.

    TypeError when the twin lacks one of the model's branches.
    """
    if not getattr(model, "twin", None):
        return None
    S = importlib.import_module(model.twin).SYSTEM
    missing = sorted(set(model.branches) - set(S.model.branches))
    if missing:
        raise TypeError(f"the twin of {model.name!r} ({model.twin}) has no branch "
                        f"{missing[0]!r}")
    return S
