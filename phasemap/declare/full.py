"""A declaration in its full coordinates, as numbers: what a motion through contact
changes integrates (:mod:`phasemap.motion.hybrid`).

The reduced equations (:mod:`phasemap.declare.equations`) hold every contact closed and
eliminate the coordinates the contacts fix.  Once a contact opens, those coordinates are
free: the body flies.  :func:`mechanics` turns the free system (every coordinate with
its rate, :class:`phasemap.declare.equations.FreeEquations`: the same Lagrangian and
contact kinematics) into one numeric function of ``(q, q', parameters)`` that returns
the mass matrix ``M``, the generalised forces ``h``, and per contact its gap ``g``, its
rows ``J`` (the contact velocities are ``J q'``: normal; tangential, or a rolling disc's
spin, where friction acts; a rolling disc's tangent, held while it rolls), their bias
``J' q'`` and its friction coefficient.  :func:`closure` gives the full coordinates of
a state of the reduced model (its contacts closed).

Both are sympy's ``lambdify`` functions, kept as their printed source in a generated
module of the kernel cache (:func:`generated`), and shipped with the built-in
declarations' derivations: only a declaration's first motion through contact changes
imports sympy.
"""

from __future__ import annotations

import builtins
import json
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from phasemap.core.memo import Memo

_MECHANICS = Memo("declare.full.mechanics")
_CLOSURES = Memo("declare.full.closure")


@dataclass(frozen=True)
class Contact:
    """One contact of the full-coordinate system."""

    name: str
    one_sided: bool
    index: int       # its position in the contacts that have a normal and a tangent
    #: a rolling disc: friction (rolling resistance) acts on its spin, and its tangent is
    #: held while it is closed (it rolls without slip)
    rolls: bool = False


@dataclass(frozen=True)
class Mechanics:
    """The numeric free system of a declaration (see the module docstring)."""

    name: str
    #: the coordinates' names, and their rates' (the declared rate, else ``<name>_dot``)
    coordinates: tuple[str, ...]
    rates: tuple[str, ...]
    units: tuple[str, ...]
    long_names: tuple[str, ...]
    parameters: tuple[str, ...]
    defaults: dict
    contacts: tuple[Contact, ...]
    #: ``lower``, ``upper``: each coordinate's bounds at the parameters (a function)
    bounds: Callable
    #: the declared domain conditions (each >= 0) as one function of (q, p)
    domain: Callable
    n_domain: int
    #: (q, u, p, t) -> the flat list [M (n*n), h (n), g (k), J (3k*n), bias (3k), mu (k)]
    #: (``mu``: the static coefficients, the limits of sticking)
    _pieces: Callable
    #: (q, p) -> [x, y of each body's centre of mass, then of each contact's body point]
    _points: Callable = None
    #: p -> per contact (nx, ny, offset, radius) of its surface (a point contact: radius
    #: nan; a rolling disc: its radius, its body point the disc's point nearest the
    #: surface) or nans (an edge contact: the obstacle is the corner, its body point in
    #: ``points``)
    surfaces: Callable = None
    n_bodies: int = 0
    #: (p, t) -> per contact its surface's tangential velocity, then its rate (2k), or
    #: None where every surface is at rest
    _surface: Callable | None = None
    #: per contact, (q, u, p, t, speed) -> its slip coefficient at the sliding speed,
    #: or None where every contact slips with its static coefficient (plain Coulomb)
    _kinetic: tuple | None = None
    #: p -> the forcing period, or None: the system does not depend on the time
    period: Callable | None = None
    #: the generated module's file (what :mod:`phasemap.motion.hybrid.flowtext` rewrites)
    source: str = ""

    def points_along(self, Q, p):
        """Where the bodies and contacts are at each row of the positions ``Q`` (m, n):
        ``(centres, contacts)``, each body's centre of mass (m, b, 2) and each contact's
        body point (m, k, 2)."""
        b = self.n_bodies
        m, k = len(Q), len(self.contacts)
        a = np.array([self._points(*q, *p) for q in np.asarray(Q, dtype=float).tolist()],
                     dtype=float).reshape(m, 2 * (b + k))
        return a[:, :2 * b].reshape(m, b, 2), a[:, 2 * b:].reshape(m, k, 2)

    @property
    def n(self) -> int:
        return len(self.coordinates)

    @property
    def can_rest(self) -> bool:
        """Whether a motion that stops stays stopped: no forcing in time, no moving
        surface."""
        return self.period is None and self._surface is None

    @property
    def plain(self) -> bool:
        """Surfaces at rest and Coulomb's law with one coefficient per contact."""
        return self._surface is None and self._kinetic is None

    def surface(self, p, t):
        """``(s, s')``: each contact surface's tangential velocity and its rate at ``t``."""
        k = len(self.contacts)
        if self._surface is None:
            return np.zeros(k), np.zeros(k)
        a = np.array(self._surface(*p, t), dtype=float)
        return a[:k], a[k:]

    def kinetic(self, q, u, p, t, speed, mu):
        """Each contact's slip coefficient at the sliding speeds ``speed`` (k,); ``mu`` the
        static ones (:meth:`pieces`), which plain Coulomb slips with."""
        if self._kinetic is None:
            return mu
        return np.array([fn(*q, *u, *p, t, float(v)) for fn, v in zip(self._kinetic, speed)],
                        dtype=float)

    def pieces(self, q, u, p, t=0.0):
        """``(M, h, g, J, b, mu)`` at the state ``(q, u)``, parameters ``p`` and time ``t``
        (arrays; ``J`` is (k, 3, n), ``b`` (k, 3): per contact the normal, the channel
        friction acts on (the tangent; a rolling disc's spin), and the channel held while
        the contact is closed (a rolling disc's tangent; zero for the others); ``mu`` the
        static coefficients: a rolling disc's is its rolling-friction length)."""
        n, k = self.n, len(self.contacts)
        # (Python floats: the generated arithmetic on NumPy scalars took twice as long,
        # for the same IEEE operations and the same bits while every result is finite;
        # where Python raises instead of giving inf or nan, as a division by zero or a
        # fractional power of a negative number, NumPy's scalars give what they gave)
        try:
            flat = np.array(self._pieces(*_floats(q), *_floats(u), *_floats(p), float(t)),
                            dtype=float)
        except (ArithmeticError, TypeError, ValueError):
            with np.errstate(all="ignore"):
                flat = np.array(self._pieces(*np.asarray(q, dtype=float),
                                             *np.asarray(u, dtype=float),
                                             *np.asarray(p, dtype=float), t), dtype=float)
        i = 0
        M = flat[i:i + n * n].reshape(n, n)
        i += n * n
        h = flat[i:i + n]
        i += n
        g = flat[i:i + k]
        i += k
        J = flat[i:i + 3 * k * n].reshape(k, 3, n)
        i += 3 * k * n
        b = flat[i:i + 3 * k].reshape(k, 3)
        i += 3 * k
        return M, h, g, J, b, flat[i:i + k]


def _floats(x) -> list:
    """The numbers of ``x`` (an array or a sequence) as Python floats."""
    return np.asarray(x, dtype=float).tolist()


def mechanics(S) -> Mechanics:
    """The :class:`Mechanics` of the declaration ``S`` (a System, or a loaded model's lazy
    :class:`phasemap.declare.loader.Declaration`).

    Derived with sympy once per declaration; the functions' text is then read from the
    kernel cache (or, for a built-in declaration, from its shipped derivation), so that a
    motion through contact changes in a new process does not import sympy.

    Raises ValueError naming the contact where a contact is a joint (its motion through
    contact changes is not built)."""
    made = _MECHANICS.get((S,), (), lambda: _made(S))
    if isinstance(made, str):
        raise ValueError(made)      # (a new one each time: no traceback kept alive)
    return made


def _made(S):
    """The :class:`Mechanics` of its generated module, or the message of the ValueError
    its derivation raised (kept, so that a declaration whose contacts cannot open is
    derived once, not at every motion that ends at one)."""
    module = generated(S, "mechanics")
    if module.ERROR is not None:
        return module.ERROR
    d = json.loads(module.DATA)
    k = len(d["contacts"])
    bounds = module.bounds
    return Mechanics(
        d["name"], tuple(d["coordinates"]), tuple(d["rates"]), tuple(d["units"]),
        tuple(d["long_names"]), tuple(d["parameters"]), d["defaults"],
        tuple(Contact(*c) for c in d["contacts"]),
        lambda p: np.array(bounds(*p), dtype=float).reshape(-1, 2), module.domain,
        d["n_domain"], module.pieces, module.points, _surfaces(module.surfaces, k),
        d["n_bodies"], getattr(module, "surface", None),
        tuple(getattr(module, f"kinetic_{i}") for i in range(k)) if d["kinetic"] else None,
        getattr(module, "period", None), module.__file__)


def rate_name(c) -> str:
    """The name of a coordinate's rate in the full coordinates."""
    return c.rate.name if c.rate is not None else f"{c.name}_dot"


#: Bumped when the generated modules' layout changes.
GENERATED = 3


def generated(S, kind: str):
    """The generated module of ``kind`` (``"mechanics"`` or ``"closure"``) of the
    declaration ``S``: from the kernel cache, else from a built-in declaration's shipped
    derivation, else derived with sympy (:func:`text`) and written to the cache.

    Its name holds the declaration's hash (:func:`phasemap.declare.build.declaration_sha256`,
    which a loaded model's declaration carries, so that no System is built to find it),
    the sources that derive it and sympy's version."""
    import hashlib

    from phasemap.core.cache import load_module

    key = shipped_key(S, kind)
    if key is None:          # a declaration without its hash: build the System to hash it
        key = shipped_key(_system(S), kind)
    h = hashlib.sha256(key.encode() + b" " + _sympy_release()).hexdigest()[:16]
    # (named by the hash alone: a System and its loaded model's declaration find one file)
    return load_module(f"{kind}_declared_{h}", lambda: _shipped(S, kind, key) or
                       text(_system(S), kind))


def shipped_key(S, kind: str) -> str | None:
    """The key of the ``kind`` module of ``S`` without the versions (what a shipped
    derivation records), or None where ``S`` is a loaded model's declaration that does not
    carry its hash."""
    from phasemap.declare.loader import Declaration

    if isinstance(S, Declaration):
        return None if S.sha256 is None else _key(S.sha256, kind)
    from phasemap.declare.build import declaration_sha256   # a System: sympy is loaded

    return _key(declaration_sha256(S), kind)


def _key(sha: str, kind: str) -> str:
    import hashlib
    import pathlib

    from phasemap.declare.runtime import declare_sources

    h = hashlib.sha256(f"{GENERATED} {kind} {sha}".encode())
    for f in [*declare_sources(), pathlib.Path(__file__)]:
        h.update(f.read_bytes())
    return h.hexdigest()


def _sympy_release() -> bytes:
    """sympy's release file (its version), read without importing sympy."""
    import importlib.util
    import pathlib

    spec = importlib.util.find_spec("sympy")
    if spec is None or spec.origin is None:
        return b""
    release = pathlib.Path(spec.origin).parent / "release.py"
    return release.read_bytes() if release.is_file() else b""


def _system(S):
    return getattr(S, "system", S)


def _shipped(S, kind: str, key: str) -> str | None:
    """The text of a built-in declaration's shipped ``kind`` module with this key."""
    from phasemap.declare.loader import Declaration, shipped_record

    record = shipped_record(S.source) if isinstance(S, Declaration) else None
    entry = (record or {}).get(kind) or {}
    return entry.get("text") if entry.get("key") == key else None


def text(S, kind: str) -> str:
    """The generated module of ``kind`` of the System ``S``, derived with sympy."""
    head = (f'"""Generated by phasemap.declare.full from the declaration of {S.name}: '
            'do not edit."""\n\n' + HEAD)
    try:
        return head + (_closure_text(S) if kind == "closure" else _mechanics_text(S))
    except ValueError as err:
        return head + f"ERROR = {str(err)!r}\n"


class _Writer:
    """Python functions from sympy's lambdify, as text: its printed source, over the
    namespace :data:`HEAD` makes (every global name it reads is checked to be the object
    lambdify's own namespace gives it)."""

    def __init__(self):
        self.parts = []

    def add(self, name: str, args, exprs, cse: bool = False):
        import inspect

        import sympy as sp

        fn = sp.lambdify(args, exprs, modules="math", cse=cse)
        src = inspect.getsource(fn)
        if not src.startswith("def _lambdifygenerated("):
            raise ValueError(f"lambdify printed an unexpected function: {src[:80]!r}")
        ns = _namespace()
        for n in _globals_read(fn.__code__):
            want = fn.__globals__.get(n, getattr(builtins, n, None))
            if want is None or ns.get(n, getattr(builtins, n, None)) is not want:
                raise ValueError(f"its full coordinates read {n!r}, which Python's math "
                                 "module does not give (an expression sympy cannot print "
                                 "for math)")
        self.parts.append(f"def {name}(" + src[len("def _lambdifygenerated("):])

    def text(self, data: dict | None = None) -> str:
        out = "\n\n".join(self.parts)
        if data is not None:
            out += f"\n\nERROR = None\nDATA = {json.dumps(data)!r}\n"
        return out


#: what every generated module of this file starts with: lambdify's namespace for "math"
HEAD = "import builtins\nimport json\nimport math\nfrom math import *  # noqa\n\n"


def _namespace() -> dict:
    ns = {}
    exec(HEAD, ns)
    return ns


def _globals_read(code) -> set:
    """The global names a code object and the code nested in it read."""
    import dis
    import types

    out = {i.argval for i in dis.get_instructions(code)
           if i.opname in ("LOAD_GLOBAL", "LOAD_NAME")}
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            out |= _globals_read(c)
    return out


def _mechanics_text(S) -> str:
    import sympy as sp

    from phasemap.declare.api import SLIP_SPEED, TIME, sym
    from phasemap.declare.contacts import _unit_normal
    from phasemap.declare.equations import FreeEquations
    from phasemap.declare.validation import fail, validate

    validate(S)       # what every declaration passes: a problem named, not a sympy error
    eqs = FreeEquations(S)
    contacts, g, J, b, mu = [], [], [], [], []
    for c in S.contacts:
        ch = eqs.channels[c.name]
        rolls = set(ch) == {"N", "T", "S"}
        if (set(ch) != {"N", "T"} and not rolls) or len(eqs.gaps[c.name]) != 1:
            fail(S, f"contact {c.name!r}", "motion through contact changes takes point, "
                 "edge and rolling contacts (a normal, a tangent and a spin, one gap), not "
                 f"a {type(c).__name__} (a joint cannot open yet)")
        contacts.append([c.name, getattr(c, "sided", "one") == "one", len(contacts), rolls])
        g.append(eqs.gaps[c.name][0])
        # rows: the normal, the channel friction acts on (the tangent; a rolling disc's
        # spin), the channel held while closed (a rolling disc's tangent: no slip)
        rows = ("N", "S", "T") if rolls else ("N", "T")
        for key in rows:
            J += list(ch[key][0])
            b.append(ch[key][1])
        if not rolls:
            J += [sp.Integer(0)] * len(eqs.q)
            b.append(sp.Integer(0))
        mu.append(c.static_expr() if hasattr(c, "static_expr") else c.law_expr())
    pts, surf = [], []
    for body in S.bodies:
        pts += [sym(body.position[0]), sym(body.position[1])]
    for c in S.contacts:
        if hasattr(c, "corner"):          # an edge contact: the body touches at the corner
            pts += [sym(c.corner[0]), sym(c.corner[1])]
            surf += [sp.nan, sp.nan, sp.nan, sp.nan]
        elif hasattr(c, "radius"):        # a rolling disc: its point nearest the surface
            nv = _unit_normal(c.normal)
            pts += [sym(c.centre[j]) - sym(c.radius) * nv[j] for j in range(2)]
            surf += [*nv, sym(c.offset), sym(c.radius)]
        else:
            pts += [sym(c.point[0]), sym(c.point[1])]
            surf += [*_unit_normal(c.normal), sym(c.offset), sp.nan]
    flat = [*eqs.M, *eqs.h, *g, *J, *b, *mu]
    t, speed = sym(TIME), sym(SLIP_SPEED)
    args = [*eqs.q, *eqs.qd, *eqs.params, t]
    w = _Writer()
    w.add("pieces", args, flat, cse=True)
    moving = [sym(getattr(c, "surface_velocity", 0)) for c in S.contacts]
    if any(v != 0 for v in moving):
        w.add("surface", [*eqs.params, t], moving + [sp.diff(v, t) for v in moving])
    kinetic = any(sp.sympify(c.law_expr()) != m_ for c, m_ in zip(S.contacts, mu))
    if kinetic:
        for i, c in enumerate(S.contacts):
            w.add(f"kinetic_{i}", [*args, speed], c.law_expr())
    if S.period is not None:
        w.add("period", eqs.params, sym(S.period))
    qp = [*eqs.q, *eqs.params]
    dom = [e for e, _ in eqs.domain]
    w.add("domain", qp, dom or [sp.Integer(1)], cse=True)
    bounds_e = []
    for c in S.coordinates:
        for side in ("lower", "upper"):
            e = eqs.bound_expr(c, side)
            bounds_e.append(sp.Float(-math.inf if side == "lower" else math.inf)
                            if e is None else e)
    w.add("bounds", eqs.params, bounds_e)
    w.add("points", qp, pts)
    w.add("surfaces", eqs.params, surf or [sp.Integer(0)])
    defaults = {p.name: float(p.default) for p in S.parameters}
    defaults.update({c.name: float(c.default) for c in S.coordinates})
    defaults.update({rate_name(c): float(c.rate.default) if c.rate else 0.0
                     for c in S.coordinates})
    return w.text({
        "name": S.name, "coordinates": [c.name for c in S.coordinates],
        "rates": [rate_name(c) for c in S.coordinates],
        "units": [c.units for c in S.coordinates],
        "long_names": [c.long_name for c in S.coordinates],
        "parameters": [p.name for p in S.parameters], "defaults": defaults,
        "contacts": contacts, "n_domain": len(dom), "n_bodies": len(S.bodies),
        "kinetic": kinetic})


def _surfaces(fn, k):
    return lambda p: np.array(fn(*p), dtype=float)[:4 * k].reshape(k, 4)


@dataclass(frozen=True)
class Closure:
    """The full coordinates of a reduced state (every contact closed)."""

    #: argument names: the reduced positions, their rates, the parameters
    args: tuple[str, ...]
    positions: Callable     # args -> q of every coordinate
    rates: Callable         # args -> q' of every coordinate

    def __call__(self, values: dict):
        a = tuple(float(values[k]) for k in self.args)
        return (np.array(self.positions(*a), dtype=float),
                np.array(self.rates(*a), dtype=float))


def closure(S) -> Closure:
    """The :class:`Closure` of a declaration that has a reduced model (a System, or a
    loaded model's lazy declaration: its text from the kernel cache, as :func:`mechanics`)."""
    return _CLOSURES.get((S,), (), lambda: _closure(S))


def _closure(S) -> Closure:
    module = generated(S, "closure")
    if module.ERROR is not None:
        raise ValueError(module.ERROR)
    return Closure(tuple(json.loads(module.DATA)["args"]), module.positions, module.rates)


def _closure_text(S) -> str:
    import sympy as sp

    from phasemap.declare.equations import Equations

    eqs = Equations(S)        # the closed equations only: no mode is solved for this
    free = [i for i, c in enumerate(S.coordinates) if c.rate is not None]
    args = [eqs.q[i] for i in free] + [eqs.qd[i] for i in free] + list(eqs.params)
    positions = [eqs.on(eqs.q[i]) for i in range(eqs.n)]
    rates = [eqs.on(eqs.qd[i]) for i in range(eqs.n)]
    # a coordinate the contacts fix only through its rate, with constant coefficients of
    # the free rates (a disc rolling on a flat floor: x' = r phi'), is that sum of the free
    # coordinates: the constraint integrated exactly, from 0 where they are all 0
    reduced_q = [eqs.q[i] for i in free]
    for i, e in enumerate(positions):
        if e != eqs.q[i] or i in free:
            continue
        coeffs = [sp.diff(rates[i], eqs.qd[j]) for j in free]
        rest = sp.expand(rates[i] - sum(c * eqs.qd[j] for c, j in zip(coeffs, free)))
        if rest == 0 and not set().union(*(sp.sympify(c).free_symbols for c in coeffs)) & (
                set(eqs.q) | set(eqs.qd)):
            positions[i] = sum(c * q for c, q in zip(coeffs, reduced_q))
    loose = sorted(map(str, set().union(*(e.free_symbols for e in positions + rates))
                       - set(args)))
    if loose:
        raise ValueError(f"{S.name}: the closed contacts do not fix {', '.join(loose)}, so "
                         "a state of the reduced model has no full coordinates")
    w = _Writer()
    w.add("positions", args, positions)
    w.add("rates", args, rates)
    return w.text({"args": [str(a) for a in args]})
