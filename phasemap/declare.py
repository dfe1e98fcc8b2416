r"""Declared systems: write the mechanics, get a :class:`phasemap.Model`.

A planar system with dry friction is declared in a few lines: its generalised
coordinates, parameters, bodies (mass, position, inertia), potential energy
and contacts.  phasemap derives the equations of motion with sympy (Lagrange),
enumerates every combination of contact modes, solves each in closed form,
and prints the result as numba branch functions in the kernel contract of
:mod:`phasemap.model`.  Every feature (``classify``, atlases, the CLI,
``simulate``, fate maps, phase curves, plots) then works for the system.

Example: the classic Painleve rod
---------------------------------
>>> import sympy as sp
>>> from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System
>>> f = Parameter("f", "1", "friction coefficient at the floor", default=0.5, lower=0.0)
>>> l = Parameter("l", "m", "half length of the rod", default=1.0, lower=0.0, lower_open=True)
>>> g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
>>> m = Parameter("m", "kg", "mass of the rod", default=1.0, lower=0.0, lower_open=True)
>>> theta = Coordinate("theta", "rad", "angle of the rod to the floor", default=1.0,
...                    lower=0.0, upper=float(sp.pi),
...                    rate=Rate("omega", "rad s-1", "angular velocity of the rod"))
>>> x = Coordinate("x", "m", "position of end A along the floor",
...                rate=Rate("xdot", "m s-1", "velocity of end A along the floor",
...                          scale=sp.sqrt(g * l)))
>>> y = Coordinate("y", "m", "height of end A above the floor")   # no rate: the contact fixes it
>>> rod = System(
...     "my_rod", "Painleve rod", "Painleve (1895)",
...     coordinates=(theta, x, y), parameters=(f, l, g, m),
...     bodies=(Body(m, (x + l * sp.cos(theta), y + l * sp.sin(theta)),
...                  inertia=m * l**2 / 3, angle=theta),),
...     potential=m * g * (y + l * sp.sin(theta)),
...     contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f),))
>>> model = rod.model          # derived once, then cached on disk  # doctest: +SKIP

The concepts
------------
:class:`Parameter`
    a named constant with units, a default and a domain.
:class:`Coordinate`
    a generalised coordinate.  With a :class:`Rate` (its velocity) it is part of
    the state; without one it is *dependent*: the contacts fix it (the height
    of a rod end on the floor) and phasemap solves for it.  A coordinate with a
    rate that no equation depends on (the slider position of the elliptic
    pendulum) is integrated in time but is not an input of the maps.
:class:`Body`
    a mass at a position (an expression of the coordinates), with an inertia
    about its centre of mass and its rotation angle.
:class:`PointContact`
    a point of a body on a flat surface ``normal . point = offset``: one-sided
    (``N >= 0``, it may separate) or two-sided (a guide, split on ``sgn N``),
    with Coulomb friction ``f``.
:class:`EdgeContact`
    a fixed corner touching a straight edge of a body (a rod lying across a
    step); the contact point slides along the edge.
:class:`RollingContact`
    a disc of radius ``radius`` centred at ``centre`` rolling without slip on a
    flat surface, with a rolling-friction moment ``delta N``; one-sided.
:class:`Joint`
    a point of a body pinned at ``at`` (two-sided), with a friction moment
    ``delta |R|``, ``R`` the joint's reaction force, opposing the relative
    rotation ``angle``.

Modes and what a row says
-------------------------
Every contact has modes: a point contact slips in the direction of its
relative velocity (or, at zero relative velocity, sticks or starts to slip
either way) or, if one-sided, separates (``N = F = 0``, the gap accelerating
open strictly; a vanishing ``N`` is a kept, grazing contact).  A two-sided
contact splits on the sign of ``N`` (``N = 0`` counted once, with ``N >= 0``).
A joint's friction law ``M = -sigma delta |R|`` is solved exactly: the linear
part gives the reaction affine in ``M``, squaring once gives a quadratic, and
only roots with ``sigma M <= 0`` are kept (GUIDE section 1).  Each combination
of modes is one candidate branch; ``n_solutions`` counts the admissible ones.
An admissible combination that separates a contact has the status
``SEPARATION``: it is a solution (the body leaves the contact), counted in
``n_solutions`` and flagged by ``contact_lost``.

Where the kept contacts do not determine the reactions (a ladder held at rest
by two rough contacts: four reactions, three equations), the reactions form a
one-parameter family; the combination is admissible when some member of the
family satisfies every friction limit, and phasemap reports the middle one.

Zero tests take their scale from the magnitudes of the terms of each quantity
(sin and cos count as 1, GUIDE section 1), computed alongside the quantity.

Limits (clear errors, not silent failures)
------------------------------------------
* All frictional contacts must slip with one state velocity when every contact
  is kept (their relative velocities are multiples of one rate, of a fixed
  sign over the domain): the maps and the integrator's stages are keyed on
  that velocity's sign.
* At most one joint with friction; statically indeterminate reactions with a
  family of more than one parameter are refused.
* Contact surfaces are flat (a line ``normal . point = offset``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import itertools
import json
import keyword
import math
import pathlib
import re
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from . import _numerics as nx
from ._version import __version__

__all__ = ["Parameter", "Rate", "Coordinate", "Body", "PointContact", "EdgeContact",
           "RollingContact", "Joint", "System", "load"]


# -- declaration objects ------------------------------------------------------

class _Symbolic:
    """Arithmetic on a declared name builds a sympy expression."""

    def _sympy_(self):
        import sympy as sp

        return sp.Symbol(self.name, real=True)

    def _op(name):  # noqa: N805 - a small factory of forwarding operators
        def op(self, other):
            return getattr(self._sympy_(), name)(_sym(other))
        return op

    for _n in ("add", "sub", "mul", "truediv", "pow"):
        locals()[f"__{_n}__"] = _op(f"__{_n}__")
        locals()[f"__r{_n}__"] = _op(f"__r{_n}__")
    del _n, _op

    def __neg__(self):
        return -self._sympy_()

    def __pos__(self):
        return self._sympy_()


def _sym(x):
    import sympy as sp

    return x._sympy_() if isinstance(x, _Symbolic) else sp.sympify(x)


@dataclass(frozen=True, eq=False)
class Parameter(_Symbolic):
    """A named constant: ``Parameter("l", "m", "half length", default=1.0, lower=0.0)``."""

    name: str
    units: str
    long_name: str
    default: float = 1.0
    lower: float = -math.inf
    upper: float = math.inf
    lower_open: bool = False
    upper_open: bool = False
    symbol: str = ""


@dataclass(frozen=True, eq=False)
class Rate(_Symbolic):
    """The velocity of a coordinate, a state variable.

    ``scale`` (an expression of the parameters, in the rate's units) is the
    natural size of the velocity: it counts as zero when
    ``|rate| <= 1e-12 * scale``.  The default, 1, means 1e-12 in SI units.
    """

    name: str
    units: str
    long_name: str
    default: float = 0.0
    symbol: str = ""
    scale: object = 1


@dataclass(frozen=True, eq=False)
class Coordinate(_Symbolic):
    """A generalised coordinate; with a :class:`Rate` it is a state variable."""

    name: str
    units: str
    long_name: str
    default: float = 0.0
    lower: float = -math.inf
    upper: float = math.inf
    lower_open: bool = False
    upper_open: bool = False
    symbol: str = ""
    rate: Rate | None = None


@dataclass(frozen=True, eq=False)
class Body:
    """A mass ``mass`` at ``position`` (x, y) with ``inertia`` about it, turned by ``angle``."""

    mass: object
    position: tuple
    inertia: object = 0
    angle: object = 0


@dataclass(frozen=True, eq=False)
class PointContact:
    """A body point on the flat surface ``normal . point = offset`` with Coulomb friction.

    ``normal`` points into the free side; ``sided`` is ``"one"`` (N >= 0, the
    point may lift off) or ``"two"`` (a guide: N of either sign).  The
    tangential direction is the normal turned clockwise by 90 degrees, so
    ``normal=(0, 1)`` (a floor) slips positive along +x.
    """

    name: str
    point: tuple
    normal: tuple = (0, 1)
    offset: object = 0
    friction: object = None
    sided: str = "one"
    long_name: str = ""


@dataclass(frozen=True, eq=False)
class EdgeContact(PointContact):
    """A fixed corner ``corner`` touching a straight edge of a body.

    The edge passes through the body point ``point`` with the direction angle
    ``angle`` (counter-clockwise from +x; the edge turns with the body).  The
    contact point slides along the edge; the normal force acts at the corner
    along the edge's normal.  ``side=+1`` when the corner touches the edge from
    its right (below an edge pointing along +x: a rod resting on a step), -1
    from its left.  Friction, ``sided`` and the modes are those of a
    :class:`PointContact`; the slip velocity is the body's material velocity
    at the corner along the edge.
    """

    corner: tuple = (0, 0)
    angle: object = 0
    side: int = 1
    #: optional ``(low, high)``: where along the edge (from ``point``, along the edge's
    #: direction) the corner may touch it, such as ``(0, 2 * l)`` for a rod of length
    #: 2l; outside, the state is outside the model's domain
    extent: tuple | None = None


@dataclass(frozen=True, eq=False)
class RollingContact:
    """A disc (centre ``centre``, radius ``radius``, counter-clockwise angle ``angle``)
    rolling without slip on ``normal . point = offset``, with a rolling-friction
    moment ``rolling_friction * N``.  One-sided: the disc may hop."""

    name: str
    centre: tuple
    radius: object
    angle: object
    normal: tuple = (0, 1)
    offset: object = 0
    rolling_friction: object = None
    long_name: str = ""


@dataclass(frozen=True, eq=False)
class Joint:
    """A body point pinned at ``at`` with a friction moment ``friction_radius * |R|``
    opposing the rotation ``angle`` (counter-clockwise)."""

    name: str
    point: tuple
    angle: object
    at: tuple = (0, 0)
    friction_radius: object = None
    long_name: str = ""


@dataclass(frozen=True, eq=False)
class System:
    """A declared planar system with dry friction.  ``System(...).model`` is its Model.

    ``potential`` is the potential energy; ``forces`` optional generalised
    forces ``{coordinate: expression}`` (they may depend on rates).
    ``default_axes`` is the map ``phasemap atlas NAME`` draws by default;
    ``edges`` what reaching a bound of a coordinate means (see
    :class:`phasemap.Dynamics`).
    """

    name: str
    title: str
    citation: str
    coordinates: tuple
    parameters: tuple
    bodies: tuple
    contacts: tuple
    potential: object = 0
    forces: Mapping = field(default_factory=dict)
    default_axes: Mapping = field(default_factory=dict)
    edges: Mapping = field(default_factory=dict)
    #: optional cross-variable domain check on (possibly array) values: raise ValueError
    check: object = None
    #: optional short names for branches and reactions: ``{generated name: name}``
    #: (such as ``{"floor_slip_pos_wall_slip_pos": "slide_pos", "N_floor": "N"}``);
    #: ``branch_names()`` lists the generated branch names, ``model.reactions`` the
    #: reactions (``N_<contact>``, ``F_<contact>``, ``M_<contact>``, ``Rx_``/``Ry_``)
    names: Mapping = field(default_factory=dict)

    def branch_names(self) -> tuple[str, ...]:
        """The generated branch names, before ``names`` renames them (derives the model)."""
        return tuple(_generated_names(self))

    @property
    def model(self):
        """The :class:`phasemap.Model` (derived once per declaration, cached on disk)."""
        cached = _MODELS.get(id(self))
        if cached is None or cached[0] is not self:
            cached = (self, _build(self))
            _MODELS[id(self)] = cached
        return cached[1]


_MODELS: dict[int, tuple] = {}


def load(path) -> "object":
    """The Model declared in a Python file: its ``SYSTEM`` (a :class:`System`).

    ValueError naming the file when it cannot be read or declares no system.
    """
    p = pathlib.Path(path)
    if not p.is_file():
        raise ValueError(f"{path}: no such declaration file")
    name = "phasemap_declared_" + hashlib.sha256(str(p.resolve()).encode()).hexdigest()[:12]
    spec = importlib.util.spec_from_file_location(name, p)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as e:  # a user's file: report it as a declaration error
        raise ValueError(f"{path}: the declaration failed to run: {type(e).__name__}: {e}") \
            from e
    system = getattr(module, "SYSTEM", None)
    if not isinstance(system, System):
        raise ValueError(f"{path}: the file must define SYSTEM = phasemap.declare.System(...)")
    return system.model


# -- validation ---------------------------------------------------------------

_IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def _fail(system, part: str, why: str):
    raise ValueError(f"{system.name}: {part}: {why}")


def _validate(S: System):
    """Every problem of a declaration as one ValueError naming the system and the part."""
    import sympy as sp

    if not isinstance(S.name, str) or not _IDENT.match(S.name):
        raise ValueError(f"a system's name must be an identifier, got {S.name!r}")
    names = {}
    for kind, items, cls in (("coordinate", S.coordinates, Coordinate),
                             ("parameter", S.parameters, Parameter)):
        if not isinstance(items, (tuple, list)):
            _fail(S, f"{kind}s", "must be a tuple")
        for it in items:
            if not isinstance(it, cls):
                _fail(S, f"{kind}s", f"{it!r} is not a {cls.__name__}")
            for nm in [it.name] + ([it.rate.name] if kind == "coordinate" and it.rate else []):
                if not _IDENT.match(nm) or keyword.iskeyword(nm) or nm in ("rest",) \
                        or nm.startswith(("sin_", "cos_")):
                    _fail(S, f"{kind} {nm!r}", "a name must be an identifier (not 'rest', "
                          "not starting with sin_ or cos_)")
                if nm in names:
                    _fail(S, f"{kind} {nm!r}", f"the name is already used by a {names[nm]}")
                names[nm] = kind
    if not S.coordinates:
        _fail(S, "coordinates", "declare at least one coordinate")
    if not any(c.rate for c in S.coordinates):
        _fail(S, "coordinates", "at least one coordinate needs a Rate (a state velocity)")
    if not S.bodies:
        _fail(S, "bodies", "declare at least one Body (the system has no mass)")
    if not S.contacts:
        _fail(S, "contacts", "declare at least one contact (a point contact, a rolling "
              "contact or a joint): without dry friction phasemap has nothing to map")
    known = {n for n in names}

    def expr(part, e):
        try:
            x = _sym(e)
        except (sp.SympifyError, TypeError) as err:
            _fail(S, part, f"{e!r} is not an expression ({err})")
        unknown = sorted(str(s) for s in x.free_symbols if str(s) not in known)
        if unknown:
            _fail(S, part, f"unknown name {unknown[0]!r} (declared: {', '.join(sorted(known))})")
        return x

    rates = {c.rate.name for c in S.coordinates if c.rate}
    for i, b in enumerate(S.bodies):
        if not isinstance(b, Body):
            _fail(S, "bodies", f"{b!r} is not a Body")
        if len(b.position) != 2:
            _fail(S, f"body {i}", "position must be a pair (x, y)")
        for part, e in (("mass", b.mass), ("inertia", b.inertia), ("angle", b.angle),
                        ("position x", b.position[0]), ("position y", b.position[1])):
            x = expr(f"body {i} {part}", e)
            if x.free_symbols & {sp.Symbol(r, real=True) for r in rates}:
                _fail(S, f"body {i} {part}", "must not depend on a rate")
        if _sym(b.mass) == 0:
            _fail(S, f"body {i} mass", "is zero (a missing mass term)")
    expr("potential", S.potential)
    for k, e in S.forces.items():
        nm = k.name if isinstance(k, Coordinate) else k
        if nm not in {c.name for c in S.coordinates}:
            _fail(S, "forces", f"{nm!r} is not a coordinate")
        expr(f"force on {nm}", e)
    seen = set()
    for c in S.contacts:
        if not isinstance(c, (PointContact, RollingContact, Joint)):
            _fail(S, "contacts", f"{c!r} is not a PointContact, RollingContact or Joint")
        if not _IDENT.match(c.name) or c.name in seen:
            _fail(S, f"contact {c.name!r}", "a contact needs a unique identifier as its name")
        seen.add(c.name)
        law = {PointContact: "friction", EdgeContact: "friction", RollingContact: "rolling_friction",
               Joint: "friction_radius"}[type(c)]
        if getattr(c, law) is None:
            _fail(S, f"contact {c.name!r}", f"has no friction law: give {law}= (a parameter "
                  "or an expression; 0 for a frictionless contact)")
        expr(f"contact {c.name!r} {law}", getattr(c, law))
        if isinstance(c, PointContact) and c.sided not in ("one", "two"):
            _fail(S, f"contact {c.name!r}", f"sided must be 'one' or 'two', got {c.sided!r}")
        if isinstance(c, EdgeContact) and c.side not in (1, -1):
            _fail(S, f"contact {c.name!r}", f"side must be +1 or -1, got {c.side!r}")
        for part in ("point", "centre", "normal", "at", "corner"):
            v = getattr(c, part, None)
            if v is not None:
                if len(v) != 2:
                    _fail(S, f"contact {c.name!r} {part}", "must be a pair (x, y)")
                for e in v:
                    expr(f"contact {c.name!r} {part}", e)
        for part in ("radius", "angle", "offset"):
            if getattr(c, part, None) is not None:
                expr(f"contact {c.name!r} {part}", getattr(c, part))
    if sum(isinstance(c, Joint) for c in S.contacts) > 1:
        _fail(S, "contacts", "at most one Joint with friction is supported (two friction "
              "moments make a system of quadratic equations)")


def _canonical(S: System) -> str:
    """A text that changes whenever the declaration does (the disk cache key)."""
    import sympy as sp

    def e(x):
        return sp.srepr(_sym(x))

    parts = [S.name, S.title, S.citation]
    for c in S.coordinates:
        parts.append(repr((c.name, c.units, c.long_name, c.default, c.lower, c.upper,
                           c.lower_open, c.upper_open, c.symbol)))
        if c.rate:
            parts.append(repr((c.rate.name, c.rate.units, c.rate.long_name, c.rate.default,
                               c.rate.symbol, e(c.rate.scale))))
    for p in S.parameters:
        parts.append(repr((p.name, p.units, p.long_name, p.default, p.lower, p.upper,
                           p.lower_open, p.upper_open, p.symbol)))
    for b in S.bodies:
        parts.append(repr([e(b.mass), e(b.position[0]), e(b.position[1]), e(b.inertia),
                           e(b.angle)]))
    parts.append(e(S.potential))
    parts.append(repr(sorted((k.name if isinstance(k, Coordinate) else k, e(v))
                             for k, v in S.forces.items())))
    for c in S.contacts:
        d = {k: (e(v) if not isinstance(v, (str, tuple)) else
                 (tuple(e(x) for x in v) if isinstance(v, tuple) else v))
             for k, v in c.__dict__.items()}
        parts.append(type(c).__name__ + repr(sorted(d.items())))
    parts.append(repr(sorted((k, tuple(v)) for k, v in S.default_axes.items())))
    parts.append(repr(sorted(S.edges.items())))
    parts.append(repr(getattr(S.check, "__qualname__", None)))
    return "\n".join(parts)


# -- derivation -----------------------------------------------------------------

def _scale(e):
    """The magnitude of the terms of ``e``: what its rounding error is relative to.

    Sums add the scales of their terms, products multiply them, sin and cos
    count as 1 (their rounding error is absolute), a denominator counts with
    its own magnitude, and the sign symbols (slip directions) as 1.
    """
    import sympy as sp

    if e.is_Number:
        return abs(e)
    if e.is_Symbol:
        return sp.Integer(1) if e.name.startswith(("_k_sig", "_k_rho", "_k_root")) else sp.Abs(e)
    if e.is_Add:
        return sp.Add(*(_scale(a) for a in e.args))
    if e.is_Mul:
        return sp.Mul(*(_scale(a) for a in e.args))
    if e.is_Pow:
        b, x = e.args
        if x.is_Integer and x > 0:
            return _scale(b) ** x
        if x.is_Integer:
            return sp.Abs(b) ** x
        if x == sp.Rational(1, 2):
            return sp.sqrt(_scale(b))
        return sp.Abs(e)
    if isinstance(e, (sp.sin, sp.cos)):
        return sp.Integer(1)
    if isinstance(e, sp.Abs):
        return _scale(e.args[0])
    return sp.Abs(e)


class _Context:
    """The system's equations on the contact manifold, and a numeric sampler."""

    def __init__(self, S: System):
        import sympy as sp

        self.S = S
        coords = S.coordinates
        self.q = [sp.Symbol(c.name, real=True) for c in coords]
        self.qd = [sp.Symbol(c.rate.name, real=True) if c.rate else
                   sp.Symbol(f"_k_v_{c.name}", real=True) for c in coords]
        q, qd, n = self.q, self.qd, len(coords)
        self.n = n

        def vel(e):
            e = _sym(e)
            return sum((sp.diff(e, qi) * qdi for qi, qdi in zip(q, qd)), sp.Integer(0))

        T = sp.Integer(0)
        for b in S.bodies:
            x, y = (_sym(c) for c in b.position)
            w = vel(b.angle)
            T += _sym(b.mass) * (vel(x) ** 2 + vel(y) ** 2) / 2 + _sym(b.inertia) * w ** 2 / 2
        T = sp.expand(T)
        M = sp.Matrix(n, n, lambda i, j: sp.diff(T, qd[i], qd[j]))
        V = _sym(S.potential)
        forces = {(k.name if isinstance(k, Coordinate) else k): _sym(v)
                  for k, v in S.forces.items()}
        h = []
        for i in range(n):
            p = sp.diff(T, qd[i])
            h.append(sp.diff(T, q[i]) - sum(sp.diff(p, q[j]) * qd[j] for j in range(n))
                     - sp.diff(V, q[i]) + forces.get(coords[i].name, 0))
        # contact channels: velocity expressions linear in the rates
        self.channels = {}
        self.domain = []  # (expression >= 0, contact name): where the contacts exist
        gaps, vcons = [], []
        for c in S.contacts:
            ch = {}
            if isinstance(c, EdgeContact):
                a = _sym(c.angle)
                e = [sp.cos(a), sp.sin(a)]
                nv = [-c.side * sp.sin(a), c.side * sp.cos(a)]
                P = [_sym(v) for v in c.point]
                K = [_sym(v) for v in c.corner]
                w = vel(a)
                # the body's material velocity at the corner
                vK = [vel(P[0]) - w * (K[1] - P[1]), vel(P[1]) + w * (K[0] - P[0])]
                gaps.append(nv[0] * (P[0] - K[0]) + nv[1] * (P[1] - K[1]))
                if c.extent is not None:
                    along = e[0] * (K[0] - P[0]) + e[1] * (K[1] - P[1])
                    self.domain.append((along - _sym(c.extent[0]), c.name))
                    self.domain.append((_sym(c.extent[1]) - along, c.name))
                ch["N"] = nv[0] * vK[0] + nv[1] * vK[1]
                ch["T"] = e[0] * vK[0] + e[1] * vK[1]
                vcons.append(ch["N"])
            elif isinstance(c, (PointContact, RollingContact)):
                nv = [_sym(a) for a in c.normal]
                norm = sp.sqrt(nv[0] ** 2 + nv[1] ** 2)
                nv = [sp.simplify(a / norm) for a in nv]
                tv = [nv[1], -nv[0]]
                P = [_sym(a) for a in (c.point if isinstance(c, PointContact) else c.centre)]
                vP = [vel(a) for a in P]
                gap = nv[0] * P[0] + nv[1] * P[1] - _sym(c.offset)
                ch["N"] = nv[0] * vP[0] + nv[1] * vP[1]
                ch["T"] = tv[0] * vP[0] + tv[1] * vP[1]
                vcons.append(ch["N"])
                if isinstance(c, RollingContact):
                    gap -= _sym(c.radius)
                    ch["S"] = vel(c.angle)
                    ch["T"] += _sym(c.radius) * ch["S"]
                    vcons.append(ch["T"])
                gaps.append(gap)
            else:
                P = [_sym(a) for a in c.point]
                ch["X"], ch["Y"] = vel(P[0]), vel(P[1])
                ch["S"] = vel(c.angle)
                gaps += [P[0] - _sym(c.at[0]), P[1] - _sym(c.at[1])]
                vcons += [ch["X"], ch["Y"]]
            self.channels[c.name] = ch
        # eliminate the dependent coordinates (those without a rate)
        dep = [i for i, c in enumerate(coords) if c.rate is None]
        if len(dep) != len(vcons):
            _fail(S, "coordinates", f"{len(dep)} coordinate(s) without a rate "
                  f"({', '.join(coords[i].name for i in dep) or 'none'}) but the contacts "
                  f"impose {len(vcons)} constraint(s) on the velocities: declare as many "
                  "coordinates without a Rate as the contacts fix (one per point or "
                  "rolling contact's normal, one more per rolling contact, two per joint)")
        dq = [q[i] for i in dep if any(q[i] in g.free_symbols for g in gaps)]
        pos_sub = {}
        if dq:
            sols = sp.solve(gaps, dq, dict=True)
            if len(sols) != 1:
                _fail(S, "contacts", "closing the contacts must fix the dependent "
                      f"coordinates {', '.join(map(str, dq))} uniquely; sympy found "
                      f"{len(sols)} solution(s)")
            pos_sub = sols[0]
            if set(pos_sub) != set(dq):
                _fail(S, "contacts", f"the gaps do not fix {', '.join(map(str, dq))}")
        vsols = sp.solve(vcons, [qd[i] for i in dep], dict=True)
        if len(vsols) != 1 or len(vsols[0]) != len(dep):
            _fail(S, "contacts", "the contact constraints must fix the velocities of "
                  f"{', '.join(coords[i].name for i in dep)}: they do not (a contact "
                  "constrains the state itself, or two contacts are redundant)")
        vel_sub = vsols[0]

        def on(e):
            return sp.sympify(e).xreplace(vel_sub).xreplace(pos_sub)

        self.on = on
        self.M = M.applyfunc(on)
        self.h = [on(x) for x in h]
        self.domain = [(on(e), nm) for e, nm in self.domain]
        self.dep = dep
        for name, ch in self.channels.items():
            for k, v in list(ch.items()):
                w = [sp.diff(v, a) for a in qd]
                bias = sum((sp.diff(v, q[j]) * qd[j] for j in range(n)), sp.Integer(0))
                ch[k] = ([on(a) for a in w], on(bias), on(v))
        self.params = [sp.Symbol(p.name, real=True) for p in S.parameters]
        self.rates = [qd[i] for i, c in enumerate(coords) if c.rate]
        self._rng = np.random.default_rng(20261123)
        # what must not appear any more: dependent positions and velocities
        gone = {q[i] for i in dep} | {qd[i] for i in dep}
        for e in [*self.M, *self.h] + [x for ch in self.channels.values()
                                       for (w, b, v) in ch.values() for x in (*w, b)]:
            left = e.free_symbols & gone
            if left:
                _fail(S, "coordinates", f"{sorted(map(str, left))[0]} is still in the "
                      "equations after closing the contacts: a coordinate without a rate "
                      "must be fixed by a contact's gap or be ignorable")
        # A singular mass matrix is fine when the contacts take away the
        # motions without inertia (the massless rod of a pendulum whose pivot
        # is a coordinate): each mode then solves the whole saddle-point
        # system, and fails there if the contacts do not.
        dM = self.M.det(method="berkowitz")
        det = self.numeric(dM / (_scale(dM) + 1), 16) if dM != 0 else np.zeros(1)
        self.regular = bool(np.all(np.abs(det) > 1e-12))
        for k, (name, ch) in enumerate(self.channels.items()):
            for key, (w, b, v) in ch.items():
                if key in ("N", "X", "Y") or (key == "T" and "S" in ch and "X" not in ch):
                    if np.max(np.abs(self.numeric(v, 8))) > 1e-9:
                        _fail(S, f"contact {name!r}", "its constraint velocity does not "
                              "vanish on the contact manifold")

    def sample(self):
        """Random values for every symbol, inside the declared domains."""
        vals = {}
        rng = self._rng
        for p in self.S.parameters:
            lo = p.lower if math.isfinite(p.lower) else p.default - 1.0 - abs(p.default)
            hi = p.upper if math.isfinite(p.upper) else p.default + 1.0 + abs(p.default)
            lo = max(lo, p.default * 0.5 if p.default > 0 else lo)
            vals[p.name] = rng.uniform(lo, hi if hi > lo else lo + 1.0)
        for c in self.S.coordinates:
            lo = c.lower if math.isfinite(c.lower) else c.default - math.pi
            hi = c.upper if math.isfinite(c.upper) else c.default + math.pi
            vals[c.name] = rng.uniform(lo, hi)
            if c.rate:
                vals[c.rate.name] = rng.uniform(-2.0, 2.0)
        return vals

    def points(self) -> list[dict]:
        """Fixed sample points: 16 random ones, and each coordinate at its finite bounds."""
        pts = [self.sample() for _ in range(16)]
        for c in self.S.coordinates:
            pts += [{**self.sample(), c.name: b} for b in (c.lower, c.upper) if math.isfinite(b)]
        return pts

    def at(self, e, pts) -> np.ndarray:
        """``e`` evaluated at the points of :meth:`points` (sign symbols +1)."""
        import sympy as sp

        e = sp.sympify(e)
        return np.array([complex(e.xreplace({s: pt.get(s.name, 1.0) for s in e.free_symbols})
                                 .evalf()).real for pt in pts])

    def numeric(self, e, k: int, extra=None) -> np.ndarray:
        """``e`` evaluated at ``k`` random samples (sign symbols random +-1)."""
        import sympy as sp

        e = sp.sympify(e)
        out = []
        for _ in range(k):
            vals = self.sample()
            subs = {s: vals.get(s.name, None) for s in e.free_symbols}
            for s in e.free_symbols:
                if subs[s] is None:
                    subs[s] = float(self._rng.choice([-1.0, 1.0])) if s.name.startswith(
                        "_k_sig") else (extra or {}).get(s.name, self._rng.uniform(-1, 1))
            out.append(complex(e.xreplace(subs).evalf()).real)
        return np.array(out)


# -- modes ------------------------------------------------------------------------

def _options(c):
    """The modes of one contact: (kind, slip sign, N sign, root) tuples."""
    if isinstance(c, PointContact):
        if c.sided == "one":
            return [("slip", 1, 1, 0), ("slip", -1, 1, 0), ("stick", 0, 0, 0), ("sep", 0, 0, 0)]
        return [("slip", s, r, 0) for s in (1, -1) for r in (1, -1)] + [("stick", 0, 0, 0)]
    if isinstance(c, RollingContact):
        return [("roll", 1, 0, 0), ("roll", -1, 0, 0), ("stick", 0, 0, 0), ("sep", 0, 0, 0)]
    return [("turn", s, 0, r) for s in (1, -1) for r in (-1, 1)] + [("stick", 0, 0, 0)]


def _token(c, mode) -> str:
    kind, s, rho, root = mode
    word = {"slip": "slip", "roll": "roll", "turn": "turn", "stick": "stick",
            "sep": "separated"}[kind]
    if s:
        word += "_pos" if s > 0 else "_neg"
    if rho < 0 or (kind == "slip" and isinstance(c, PointContact) and c.sided == "two"):
        word += "_Npos" if rho > 0 else "_Nneg"
    if root > 0:
        word += "_root2"
    return f"{c.name}_{word}" if c.name else word


def _rows(S: System, kappa: dict):
    """Every candidate branch: (name, direction, presence, mode tuple per contact).

    ``presence`` 0: applies while moving in ``direction`` and from rest; 1: only
    at rest; 2: only while moving (a second copy of a row that needs no slip
    direction).  The first row with direction 0 is the stick branch.

    Every contact slips with the same state velocity v (contact i with
    v_i = k_i(q) v, sgn k_i = kappa_i; :func:`_slip_velocity` checks it).  While
    every contact stays closed, v_i = k_i v holds along the motion, so at v = 0
    each tangential acceleration is k_i v': one contact sticking (k_i v' = 0)
    stops all of them, and slips starting in directions of different
    s_i kappa_i ask v' for two signs at once.  Such rows can never be
    admissible inside the domain and are not generated.  At a bound where
    some k_i = 0 (the ladder lying flat, phi = pi/2) that contact cannot
    start to slip either, so a slide from rest is not admissible there: the
    hand ladder keeps the limit from inside instead, and the two differ on
    that edge (683 cells of a 2048^2 rest map, BENCHMARKS.md).  A row with a
    separated contact has more freedom and is kept.
    """
    combos = list(itertools.product(*(_options(c) for c in S.contacts)))
    rows = []
    stick_all = tuple(("stick", 0, 0, 0) for _ in S.contacts)
    for combo in [stick_all] + [c for c in combos if c != stick_all]:
        name = "_".join(_token(c, m) for c, m in zip(S.contacts, combo))
        if combo == stick_all:
            name = "stick"
        kept = [(c, m) for c, m in zip(S.contacts, combo) if m[0] != "sep"]
        signs = {m[1] * kappa[c.name] for c, m in kept if m[0] != "stick"}
        n_stick = sum(m[0] == "stick" for _, m in kept)
        if len(kept) == len(combo) and (len(signs) > 1 or 0 < n_stick < len(kept)):
            continue  # kinematically impossible (see above)
        if n_stick:
            rows.append((name, 0.0, 1, combo))
            continue
        if not signs:  # every contact separated: any direction
            rows.append((name, 1.0, 0, combo))
            rows.append((name + "_moving_neg", -1.0, 2, combo))
        elif len(signs) == 1:
            rows.append((name, float(signs.pop()), 0, combo))
        else:
            rows.append((name, 0.0, 1, combo))
    return rows


# -- code generation ----------------------------------------------------------------

def _printer():
    import sympy as sp
    from sympy.printing.pycode import PythonCodePrinter

    class Printer(PythonCodePrinter):
        """Float literals everywhere (no mixed int/float tuples), integer powers as products."""

        def _print_Integer(self, e):
            return f"{int(e)}.0"

        def _print_Rational(self, e):
            return f"({int(e.p)}.0/{int(e.q)}.0)"

        def _print_Half(self, e):
            return "0.5"

        def _print_Pow(self, e, rational=False):
            b, x = e.args
            pb = self._print(b)
            if x.is_Integer:
                k = int(x)
                if k == 2:
                    return f"(({pb})*({pb}))"
                return f"(({pb})**{k})"
            if x == sp.Rational(1, 2):
                return f"math.sqrt({pb})"
            if x == -sp.Rational(1, 2):
                return f"(1.0/math.sqrt({pb}))"
            return f"(({pb})**({self._print(x)}))"

        def _print_Abs(self, e):
            return f"abs({self._print(e.args[0])})"

    return Printer({"fully_qualified_modules": True})


class _Row:
    """One mode-type combination: its equations solved, as code lines."""

    def __init__(self, ctx: _Context, kinds: tuple, fname: str):
        import sympy as sp

        self.ctx, self.kinds, self.fname = ctx, kinds, fname
        S, n = ctx.S, ctx.n
        # a mode combination with a sticking contact applies only where the
        # slip velocity is zero: set it to zero in its equations (the
        # kinematics of a rest is consistent only there)
        zero = {ctx.velocity: sp.Integer(0)} if "stick" in kinds else {}
        self.zero = zero
        self.args = ["_k_presence"]
        cols, cons, unknown = [], [], []
        extra = [sp.Integer(0)] * n
        reactions = []  # per contact, expressions in the unknowns' symbols (L)
        self.mu = None
        conds = []  # (kind, ...)
        self.sig = {}
        for c, kind in zip(S.contacts, kinds):
            ch = ctx.channels[c.name]
            nm = c.name
            sig = sp.Symbol(f"_k_sig_{nm}", real=True)
            rho = sp.Symbol(f"_k_rho_{nm}", real=True)

            def new(key, col, con):
                L = sp.Symbol(f"_k_L{len(unknown)}", real=True)
                unknown.append((nm, key, L))
                cols.append(col)
                if con is not None:
                    cons.append(con)
                return L

            def chan(key):
                return ch[key][0], ch[key][1].xreplace(zero)

            if isinstance(c, PointContact):
                f = _sym(c.friction)
                wN, wT = ch["N"][0], ch["T"][0]
                if kind == "slip":
                    self.args.append(sig.name)
                    r = sp.Integer(1)
                    if c.sided == "two":
                        self.args.append(rho.name)
                        r = rho
                    N = new("N", [wN[j] - sig * r * f * wT[j] for j in range(n)], chan("N"))
                    reactions += [N, -sig * r * f * N]
                    conds.append(("sign", N, r if c.sided == "two" else 1))
                    conds.append(("start", sig, "T", nm))
                    self.sig[nm] = sig
                elif kind == "stick":
                    N = new("N", wN, chan("N"))
                    F = new("F", wT, chan("T"))
                    reactions += [N, F]
                    if c.sided == "one":
                        conds.append(("sign", N, 1))
                        conds.append(("cone", f, N, F))
                    else:
                        conds.append(("cone_abs", f, N, F))
                else:
                    reactions += [sp.Integer(0), sp.Integer(0)]
                    conds.append(("open", "N", nm))
            elif isinstance(c, RollingContact):
                d = _sym(c.rolling_friction)
                wN, wT, wS = ch["N"][0], ch["T"][0], ch["S"][0]
                if kind == "roll":
                    self.args.append(sig.name)
                    N = new("N", [wN[j] - sig * d * wS[j] for j in range(n)], chan("N"))
                    F = new("F", wT, chan("T"))
                    reactions += [N, F, -sig * d * N]
                    conds.append(("sign", N, 1))
                    conds.append(("start", sig, "S", nm))
                    self.sig[nm] = sig
                elif kind == "stick":
                    N = new("N", wN, chan("N"))
                    F = new("F", wT, chan("T"))
                    Mm = new("M", wS, chan("S"))
                    reactions += [N, F, Mm]
                    conds.append(("sign", N, 1))
                    conds.append(("cone", d, N, Mm))
                else:
                    reactions += [sp.Integer(0)] * 3
                    conds.append(("open", "N", nm))
            else:
                d = _sym(c.friction_radius)
                wX, wY, wS = ch["X"][0], ch["Y"][0], ch["S"][0]
                if kind == "turn":
                    root = sp.Symbol(f"_k_root_{nm}", real=True)
                    self.args += [sig.name, root.name]
                    self.mu = sp.Symbol("_k_mu", real=True)
                    self.joint = (nm, d, sig, root)
                    X = new("X", wX, chan("X"))
                    Y = new("Y", wY, chan("Y"))
                    extra = [extra[j] + wS[j] * self.mu for j in range(n)]
                    reactions += [X, Y, self.mu]
                    conds.append(("start", sig, "S", nm))
                    self.sig[nm] = sig
                else:
                    X = new("X", wX, chan("X"))
                    Y = new("Y", wY, chan("Y"))
                    Mm = new("M", wS, chan("S"))
                    reactions += [X, Y, Mm]
                    conds.append(("joint_cone", d, X, Y, Mm))
        self.unknown, self.reactions, self.conds = unknown, reactions, conds
        k = len(unknown)
        M = ctx.M
        aM = M.adjugate() if n > 1 else sp.Matrix([[1]])
        dM = M.det(method="berkowitz") if n > 1 else M[0, 0]
        hx = [ctx.h[j].xreplace(zero) + extra[j] for j in range(n)]
        W = sp.Matrix(n, k, lambda i, j: cols[j][i]) if k else sp.zeros(n, 0)
        C = sp.Matrix(k, n, lambda i, j: cons[i][0][j]) if k else sp.zeros(0, n)
        cb = sp.Matrix(k, 1, lambda i, j: cons[i][1]) if k else sp.zeros(0, 1)
        hv = sp.Matrix(n, 1, lambda i, j: hx[i])
        self.aM, self.dM, self.hx, self.W = aM, dM, hx, W
        self.null = None
        self.qnums = None
        if not ctx.regular:
            self._saddle(M, W, C, hv, cb, n, k)
            return
        if k:
            K = (C * aM * W).applyfunc(sp.expand)
            rhs = (-(C * aM * hv) - dM * cb).applyfunc(sp.expand)
        if k == 0:
            self.D = sp.Integer(1)
            self.nums = []
            return
        D = K.det(method="berkowitz")
        Ds = _scale(D)
        vals = ctx.numeric(D / Ds, 12)
        if np.max(np.abs(vals)) > 1e-9:
            self.D, *self.nums = _reduced([D] + [self._cramer(K, rhs, i) for i in range(k)])
            self._one_direction()
            return
        # statically indeterminate: a one-parameter family of reactions
        self._indeterminate(K, rhs, k)

    def _one_direction(self):
        """Write the determinant and numerators with the one slip direction that every
        contact shares when all of them slip; the determinant also reduced and factored
        (:func:`_pythagorean`).

        When every contact slips, contact c slips with sign kappa_c s (the rows
        where they would not share s are never generated, see :func:`_rows`):
        sigma_c = kappa_c kappa_1 sigma_1.  Substituted, terms such as the
        sliding ladder's 3 f sin(phi) cos(phi) (sigma_floor - sigma_wall) vanish
        in the algebra instead of cancelling in rounding, and its determinant
        becomes 2 (2 - f^2) / 9, whose rounding does not change along the motion.
        The numerators are left expanded: reduced, their zero-test scales no longer
        matched the separated row's at a contact's release (the frictionless ladder
        leaving the wall ended ``no_solution`` instead of ``contact_lost``).
        """
        ctx = self.ctx
        if len(self.sig) < 2 or any(k not in ("slip", "roll") for k in self.kinds):
            return
        first, *others = self.sig
        sub = {self.sig[nm]: ctx.kappa[nm] * ctx.kappa[first] * self.sig[first]
               for nm in others}
        self.D = _pythagorean(self.D.xreplace(sub), ctx.q)
        self.nums = [e.xreplace(sub) for e in self.nums]

    def _saddle(self, M, W, C, hv, cb, n, k):
        """Accelerations and reactions together: [[M, -W], [C, 0]] (q'', L) = (h, -c)."""
        import sympy as sp

        A = sp.zeros(n + k, n + k)
        A[:n, :n] = M
        if k:
            A[:n, n:] = -W
            A[n:, :n] = C
        rhs = sp.Matrix.vstack(hv, -cb) if k else hv
        D = sp.expand(A.det(method="berkowitz"))
        if D == 0 or np.max(np.abs(self.ctx.numeric(D / _scale(D), 12))) < 1e-9:
            _fail(self.ctx.S, "bodies", "the mass matrix is singular on the motions the "
                  f"contacts allow (modes {', '.join(self.kinds)}): some coordinate has no "
                  "inertia (a missing mass or inertia term)")
        self.D, *nums = _reduced([D] + [sp.expand(self._cramer(A, rhs, i))
                                        for i in range(n + k)])
        self.qnums, self.nums = nums[:n], nums[n:]

    def _cramer(self, K, rhs, i):
        Ki = K.copy()
        Ki[:, i] = rhs
        return Ki.det(method="berkowitz")

    def _indeterminate(self, K, rhs, k):
        import sympy as sp

        ctx, S = self.ctx, self.ctx.S
        if self.mu is not None:
            _fail(S, f"mode {self.fname}", "a joint with statically indeterminate reactions "
                  "is not supported")
        # The family is parametrised by one reaction j0 with equation i0 dropped, by
        # Cramer on the minor Dp that is left.  Every minor may vanish somewhere in
        # the domain (the ladder: one at phi = 0, where the floor's normal is the
        # wall's tangent, another at phi = pi/2): then two parametrisations are
        # generated and the one with the larger |Dp| is taken at run time.  The
        # reported reactions, the middle of the admissible segment, do not depend
        # on the parametrisation.
        pts = ctx.points()
        choices = []
        for I in itertools.combinations(range(k), k - 1):
            for J in itertools.combinations(range(k), k - 1):
                sub = K.extract(list(I), list(J))
                Dp = sub.det(method="berkowitz")
                if Dp == 0:
                    continue
                size = np.abs(ctx.at(Dp / _scale(Dp), pts))
                if np.max(size) >= 1e-9:
                    choices.append((I, J, sub, Dp, size))
        if not choices:
            _fail(S, f"mode {self.fname}", "the reactions are indeterminate with a family of "
                  "more than one parameter: not supported")
        best = max(range(len(choices)), key=lambda a: (np.min(choices[a][4]), -a))
        picked = [best]
        if np.min(choices[best][4]) < 1e-6:
            pair = max(itertools.combinations(range(len(choices)), 2), key=lambda ab: (
                np.min(np.maximum(choices[ab[0]][4], choices[ab[1]][4])), -ab[0], -ab[1]))
            picked = list(pair)
        self.null = []
        for I, J, sub, Dp, _ in (choices[a] for a in picked):
            (i0,) = set(range(k)) - set(I)
            (j0,) = set(range(k)) - set(J)
            p = [self._cramer(sub, rhs.extract(list(I), [0]), a) for a in range(k - 1)]
            dcol = -K.extract(list(I), [j0])
            d = [self._cramer(sub, dcol, a) for a in range(k - 1)]
            # the dropped equation must hold for the whole family, and the
            # accelerations must not depend on the family's parameter
            lam_d = [sp.Integer(0)] * k
            lam_p = [sp.Integer(0)] * k
            for a, j in enumerate(J):
                lam_d[j], lam_p[j] = d[a], p[a]
            lam_d[j0] = Dp
            row_p = sum(K[i0, j] * lam_p[j] for j in range(k)) - rhs[i0] * Dp
            row_d = sum(K[i0, j] * lam_d[j] for j in range(k))
            acc_d = self.aM * self.W * sp.Matrix(lam_d)
            checks = [row_p, row_d, *acc_d]
            bad = [e for e in checks if e != 0 and np.max(np.abs(
                ctx.numeric(e / (_scale(e) + 1), 8))) > 1e-9]
            if bad:
                _fail(S, f"mode {self.fname}", "the reactions are indeterminate and the "
                      "accelerations depend on them (a continuum of motions): not supported")
            Dp, *pd = _reduced([Dp, *p, *d])
            P, Dd = [sp.Integer(0)] * k, [sp.Integer(0)] * k
            for a, j in enumerate(J):
                P[j], Dd[j] = pd[a], pd[k - 1 + a]
            Dd[j0] = Dp
            self.null.append((Dp, P, Dd))
        self.D = self.null[0][0]

    # -- printing ---------------------------------------------------------------

    def code(self, inputs_of) -> tuple[list[str], set]:
        """The function's body lines and the set of input names it reads."""
        import sympy as sp

        P = _printer()
        lines: list[str] = []
        used: set = set()
        fresh = sp.numbered_symbols("_k_x")

        def emit(pairs):
            """Assign ``name = expr`` for (name, sympy expr) pairs, with common subexpressions."""
            names = [a for a, _ in pairs]
            exprs = [inputs_of(e) for _, e in pairs]
            for e in exprs:
                used.update(s.name for s in e.free_symbols)
            reps, red = sp.cse(exprs, symbols=fresh, order="none")
            for s, e in reps:
                lines.append(f"{s} = {P.doprint(e)}")
            for a, e in zip(names, red):
                lines.append(f"{a} = {P.doprint(e)}")

        k = len(self.unknown)
        L = [u[2] for u in self.unknown]
        Ls = [sp.Symbol(f"_k_Ls{i}", real=True) for i in range(k)]
        tol = f"{nx.TOL!r}"
        # 1. the solved unknowns
        if self.null is None and self.mu is None:
            emit([("_k_D", self.D), ("_k_Ds", _scale(self.D))]
                 + [(f"_k_n{i}", e) for i, e in enumerate(self.nums)]
                 + [(f"_k_ns{i}", _scale(e)) for i, e in enumerate(self.nums)])
            lines.append(f"_k_sing = abs(_k_D) <= {tol} * _k_Ds")
            lines.append("_k_cont = " + " & ".join(
                [f"(abs(_k_n{i}) <= {tol} * _k_ns{i})" for i in range(k)] or ["False"]))
            for i in range(k):
                lines.append(f"{L[i]} = _k_n{i} / _k_D")
                lines.append(f"{Ls[i]} = _k_ns{i} / abs(_k_D)")
            lines.append("_k_real = True")
            lines.append("_k_coef = _k_D / _k_Ds")
        elif self.mu is not None:
            mu = self.mu
            n0 = [e.subs(mu, 0) for e in self.nums]
            n1 = [sp.diff(e, mu) for e in self.nums]
            emit([("_k_D", self.D), ("_k_Ds", _scale(self.D))]
                 + [(f"_k_a{i}", e) for i, e in enumerate(n0)]
                 + [(f"_k_as{i}", _scale(e)) for i, e in enumerate(n0)]
                 + [(f"_k_b{i}", e) for i, e in enumerate(n1)]
                 + [(f"_k_bs{i}", _scale(e)) for i, e in enumerate(n1)])
            nm, d, sig, root = self.joint
            ix = [i for i, u in enumerate(self.unknown) if u[0] == nm]
            X, Y = ix
            emit([("_k_dl", d)])
            lines += [
                "_k_sing0 = abs(_k_D) <= " + tol + " * _k_Ds",
                f"_k_ax, _k_ay = _k_a{X} / _k_D, _k_a{Y} / _k_D",
                f"_k_bx, _k_by = _k_b{X} / _k_D, _k_b{Y} / _k_D",
                f"_k_sx, _k_sy = _k_as{X} / abs(_k_D), _k_as{Y} / abs(_k_D)",
                "_k_d2 = _k_dl * _k_dl",
                "_k_A = 1.0 - _k_d2 * (_k_bx * _k_bx + _k_by * _k_by)",
                "_k_As = 1.0 + _k_d2 * (_k_bx * _k_bx + _k_by * _k_by)",
                "_k_B = -2.0 * _k_d2 * (_k_ax * _k_bx + _k_ay * _k_by)",
                "_k_Bs = 2.0 * _k_d2 * (_k_sx * abs(_k_bx) + _k_sy * abs(_k_by))",
                "_k_C = -_k_d2 * (_k_ax * _k_ax + _k_ay * _k_ay)",
                "_k_Cs = _k_d2 * (_k_sx * _k_sx + _k_sy * _k_sy)",
                "_k_disc = _k_B * _k_B - 4.0 * _k_A * _k_C",
                "_k_discs = _k_Bs * _k_Bs + 4.0 * _k_As * _k_Cs",
                f"_k_sing = _k_sing0 | (abs(_k_A) <= {tol} * _k_As)",
                f"_k_cont = (abs(_k_B) <= {tol} * _k_Bs) & (abs(_k_C) <= {tol} * _k_Cs)",
                f"_k_real = _k_disc >= -{tol} * _k_discs",
                f"_k_mu = (-_k_B + {root} * math.sqrt(max(_k_disc, 0.0))) / (2.0 * _k_A)",
                "_k_mus = _k_dl * math.sqrt(_k_sx * _k_sx + _k_sy * _k_sy) + abs(_k_mu)",
                f"_k_keep = ({sig} * _k_mu <= {tol} * _k_mus) & (({root} < 0.0) | "
                f"(_k_disc > {tol} * _k_discs))",
                "_k_coef = _k_A",
            ]
            for i in range(k):
                lines.append(f"{L[i]} = (_k_a{i} + _k_b{i} * _k_mu) / _k_D")
                lines.append(f"{Ls[i]} = (_k_as{i} + _k_bs{i} * abs(_k_mu)) / abs(_k_D)")
        else:
            # the family: L_j = (P_j + Dd_j t) / D (P = 0, Dd = D for the parameter)
            for r, (D, Pj, Ddj) in enumerate(self.null):
                emit([(f"_k_D_{r}", D), (f"_k_Ds_{r}", _scale(D))]
                     + [(f"_k_P{j}_{r}", e) for j, e in enumerate(Pj)]
                     + [(f"_k_PS{j}_{r}", _scale(e)) for j, e in enumerate(Pj)]
                     + [(f"_k_Dd{j}_{r}", e) for j, e in enumerate(Ddj)])
            picked = ["_k_D", "_k_Ds"] + [f"_k_{x}{j}" for x in ("P", "PS", "Dd")
                                           for j in range(k)]
            if len(self.null) == 1:
                lines += [f"{x} = {x}_0" for x in picked]
            else:
                lines.append("_k_use = abs(_k_D_0) * _k_Ds_1 >= abs(_k_D_1) * _k_Ds_0")
                lines += [f"{x} = {x}_0 if _k_use else {x}_1" for x in picked]
            lines.append(f"_k_sing = abs(_k_D) <= {tol} * _k_Ds")
            lines.append("_k_cont = False")
            lines.append("_k_real = True")
            lines.append("_k_coef = _k_D / _k_Ds")
            lines.append("_k_R = " + " + ".join(f"_k_PS{j}" for j in range(k)) + " + 0.0")
            fam = {j: (f"_k_P{j} / _k_D", f"_k_Dd{j} / _k_D") for j in range(k)}
            lines.append("_k_lo, _k_hi = -np.inf, np.inf")
            forms = self._forms()
            for form, strict in forms:
                coeffs = [sp.diff(form, L[i]) for i in range(k)]
                if any(cf.free_symbols & set(L) for cf in coeffs):
                    _fail(self.ctx.S, f"mode {self.fname}", "a nonlinear friction limit on "
                          "indeterminate reactions is not supported")
                c_names = []
                for i, cf in enumerate(coeffs):
                    if cf != 0:
                        nmc = f"_k_c{len(lines)}_{i}"
                        emit([(nmc, cf)])
                        c_names.append((i, nmc))
                g0 = " + ".join(f"{cn} * ({fam[i][0]})" for i, cn in c_names) or "0.0"
                g1 = " + ".join(f"{cn} * ({fam[i][1]})" for i, cn in c_names) or "0.0"
                g1s = " + ".join(f"abs({cn} * ({fam[i][1]}))" for i, cn in c_names) or "0.0"
                shift = (f"{'-' if strict is True else ''}{tol} * _k_R / abs(_k_D)"
                         if isinstance(strict, bool) else
                         f"({tol} if {strict} > 0.0 else -{tol}) * _k_R / abs(_k_D)")
                # a slope that cancels to rounding is zero (a ray, not a far endpoint)
                lines.append(f"_k_sl = {g1}")
                lines.append(f"_k_sl = _k_sl if abs(_k_sl) > {tol} * ({g1s}) else 0.0")
                lines.append(f"_k_lo, _k_hi = restrict_affine({g0} + {shift}, _k_sl, "
                             "_k_lo, _k_hi)")
            lines.append("_k_fam = _k_lo < _k_hi")
            lines.append("_k_t = 0.5 * (_k_lo + _k_hi) if (_k_lo > -np.inf) & (_k_hi < np.inf) "
                         "else (_k_lo if _k_lo > -np.inf else (_k_hi if _k_hi < np.inf else 0.0))")
            for i in range(k):
                a, b = fam[i]
                lines.append(f"{L[i]} = {a} + ({b}) * _k_t")
                lines.append(f"{Ls[i]} = _k_R / abs(_k_D)")
        # 2. accelerations
        n = self.ctx.n
        Q = [sp.Symbol(f"_k_Q{j}", real=True) for j in range(n)]
        Qs = [sp.Symbol(f"_k_Qs{j}", real=True) for j in range(n)]
        gen = [self.hx[a] + sum((self.W[a, i] * L[i] for i in range(k)), sp.Integer(0))
               for a in range(n)]
        gens = [_scale(self.hx[a]) + sum((_scale(self.W[a, i]) * Ls[i] for i in range(k)),
                                         sp.Integer(0)) for a in range(n)]
        acc = [sum((self.aM[j, a] * gen[a] for a in range(n)), sp.Integer(0)) / self.dM
               for j in range(n)]
        accs = [sum((_scale(self.aM[j, a]) * gens[a] for a in range(n)), sp.Integer(0))
                / sp.Abs(self.dM) for j in range(n)]
        if self.qnums is not None:  # solved together with the reactions
            Dsym = sp.Symbol("_k_D", real=True)
            if self.mu is None:
                acc = [e / Dsym for e in self.qnums]
                accs = [_scale(e) / sp.Abs(Dsym) for e in self.qnums]
            else:
                q0 = [e.subs(self.mu, 0) for e in self.qnums]
                q1 = [sp.diff(e, self.mu) for e in self.qnums]
                acc = [(a + b * self.mu) / Dsym for a, b in zip(q0, q1)]
                accs = [(_scale(a) + _scale(b) * sp.Abs(self.mu)) / sp.Abs(Dsym)
                        for a, b in zip(q0, q1)]
        emit([(str(Q[j]), acc[j]) for j in range(n)] + [(str(Qs[j]), accs[j]) for j in range(n)])
        self.Q = Q
        # 3. the conditions
        conds = []
        chans = self.ctx.channels

        def chan_acc(nm, key):
            w, b, _ = chans[nm][key]
            b = b.xreplace(self.zero)
            a = sum((w[j] * Q[j] for j in range(n)), sp.Integer(0)) + b
            s = sum((_scale(w[j]) * Qs[j] for j in range(n)), sp.Integer(0)) + _scale(b)
            return a, s

        for ci, cond in enumerate(self.conds):
            if cond[0] == "start":
                _, sig, key, nm = cond
                a, s = chan_acc(nm, key)
                emit([(f"_k_ca{ci}", a), (f"_k_cs{ci}", s)])
                conds.append(f"((not rest) | ({sig} * _k_ca{ci} > {tol} * _k_cs{ci}))")
            elif cond[0] == "open":
                _, key, nm = cond
                a, s = chan_acc(nm, key)
                emit([(f"_k_ca{ci}", a), (f"_k_cs{ci}", s)])
                conds.append(f"(_k_ca{ci} > {tol} * _k_cs{ci})")
        if self.null is None:
            for fi, (form, strict) in enumerate(self._forms()):
                scale = _scale_in(form, L, Ls)
                emit([(f"_k_g{fi}", form), (f"_k_gs{fi}", scale)])
                gt, ge = f"(_k_g{fi} > {tol} * _k_gs{fi})", f"(_k_g{fi} >= -{tol} * _k_gs{fi})"
                conds.append((gt if strict else ge) if isinstance(strict, bool)
                             else f"({ge} if {strict} > 0.0 else {gt})")
        else:
            conds.append("_k_fam")
        if self.mu is not None:
            conds.append("_k_keep")
        lines.append("_k_ok = " + (" & ".join(conds) if conds else "True"))
        emit([(f"_k_r{i}", e) for i, e in enumerate(self.reactions)])
        return lines, used

    def _forms(self):
        """The reaction inequalities as (form, strict): form >= 0 (or > 0 when strict)."""
        import sympy as sp

        out = []
        for cond in self.conds:
            if cond[0] == "sign":
                _, N, r = cond
                if r == 1:
                    out.append((N, False))
                else:  # a two-sided contact's assumed sign of N (N = 0 counted with N >= 0)
                    out.append((r * N, r))
            elif cond[0] == "cone":
                _, f, N, F = cond
                out += [(f * N - F, False), (f * N + F, False)]
            elif cond[0] == "cone_abs":
                _, f, N, F = cond
                out.append((f * sp.Abs(N) - sp.Abs(F), False))
            elif cond[0] == "joint_cone":
                _, d, X, Y, Mm = cond
                out.append((d * d * (X * X + Y * Y) - Mm * Mm, False))
        return out


def _pythagorean(e, angles):
    """``e`` reduced modulo sin(q)^2 + cos(q)^2 = 1 for every coordinate q, and factored
    (a constant times sin^2 + cos^2 becomes the constant).  Left as it is when it is
    not a polynomial in the sines and cosines."""
    import sympy as sp

    sub, back, ideal, gens = {}, {}, [], []
    for q in angles:
        if not e.has(sp.sin(q), sp.cos(q)):
            continue
        s, c = sp.Dummy(f"s_{q}"), sp.Dummy(f"c_{q}")
        sub.update({sp.sin(q): s, sp.cos(q): c})
        back.update({s: sp.sin(q), c: sp.cos(q)})
        ideal.append(s ** 2 + c ** 2 - 1)
        gens += [s, c]
    if not gens:
        return sp.factor(e)
    p = sp.expand(e.xreplace(sub))
    if p.has(*angles):  # sin(2 q), sin(q + a), ...: not a polynomial in s, c
        return e
    try:
        _, rem = sp.reduced(p, ideal, *gens)
    except sp.polys.polyerrors.PolynomialError:
        return e
    return sp.factor(rem).xreplace(back)


def _monomial(e):
    """The monomial factor common to the terms of ``e`` (such as m**4 l**4)."""
    import sympy as sp

    f = sp.factor_terms(sp.expand(e))
    if not f.is_Mul:
        return sp.Integer(1)
    return sp.Mul(*(a for a in f.args if a.is_Symbol or (a.is_Pow and a.args[0].is_Symbol
                                                         and a.args[1].is_Integer)))


def _reduced(exprs):
    """``exprs`` (a quotient's denominator and numerators) divided by their common
    monomial factor, so that no power of a parameter larger than needed is formed
    (m**5 overflows for m = 1e62)."""
    import sympy as sp

    monos = [_monomial(e) for e in exprs if e != 0]
    common = monos[0]
    for mo in monos[1:]:
        common = sp.gcd(common, mo)
    if common == 1:
        return list(exprs)
    return [sp.expand(e / common) for e in exprs]


def _scale_in(form, L, Ls):
    """The scale of an expression of the unknowns: their scales stand in for them."""
    import sympy as sp

    sub = {L[i]: Ls[i] for i in range(len(L))}
    return _scale(form).xreplace({sp.Abs(L[i]): Ls[i] for i in range(len(L))}).xreplace(sub)


# -- the generated module and the Model ---------------------------------------------

_STATUS = {"ABSENT": nx.ABSENT, "ADMISSIBLE": nx.ADMISSIBLE, "INADMISSIBLE": nx.INADMISSIBLE,
           "NO_SOLUTION": nx.NO_SOLUTION, "CONTINUUM": nx.CONTINUUM,
           "SEPARATION": nx.SEPARATION}


def _slip_velocity(ctx: _Context):
    """The one state velocity every contact slips with, and each contact's sign of it."""
    import sympy as sp

    S = ctx.S
    velocity, kappa = None, {}
    for c in S.contacts:
        key = "T" if isinstance(c, PointContact) else "S"
        v = sp.expand(ctx.channels[c.name][key][2])
        involved = []
        for r in ctx.rates:
            k = sp.diff(v, r)
            if k != 0 and np.max(np.abs(ctx.numeric(k, 8))) > 1e-12:
                involved.append((r, k))
        if len(involved) != 1:
            _fail(S, f"contact {c.name!r}", f"its slip velocity {v} involves "
                  f"{len(involved)} rates; phasemap needs every contact to slip with one "
                  "state velocity (a multiple of one rate)")
        r, k = involved[0]
        if velocity is not None and r != velocity:
            _fail(S, f"contact {c.name!r}", f"slips with {r}, another contact with "
                  f"{velocity}: contacts that slip with different state velocities are "
                  "not supported yet")
        velocity = r
        vals = ctx.numeric(k, 24)
        big = vals[np.abs(vals) > 1e-9 * max(1.0, float(np.max(np.abs(vals))))]
        if np.all(big > 0):
            kappa[c.name] = 1
        elif np.all(big < 0):
            kappa[c.name] = -1
        else:
            _fail(S, f"contact {c.name!r}", f"its slip velocity {v} changes sign against "
                  f"{r} inside the domain: restrict the domain of the coordinates")
    return velocity, kappa


def _derive(S: System) -> str:
    """The generated module's source text (sympy runs here, and only here)."""
    import sympy as sp

    ctx = _Context(S)
    velocity, kappa = _slip_velocity(ctx)
    ctx.velocity, ctx.kappa = velocity, kappa
    rows = _rows(S, kappa)
    positions = [c for c in S.coordinates if c.rate]
    trig = {}
    for c in positions:
        qs = sp.Symbol(c.name, real=True)
        trig[sp.sin(qs)] = sp.Symbol(f"sin_{c.name}", real=True)
        trig[sp.cos(qs)] = sp.Symbol(f"cos_{c.name}", real=True)

    def inputs_of(e):
        return sp.sympify(e).xreplace(trig)

    funcs, used_all = {}, set()
    for name, direction, presence, combo in rows:
        kinds = tuple(m[0] for m in combo)
        if kinds in funcs:
            continue
        fname = f"mode_{len(funcs)}"
        row = _Row(ctx, kinds, fname)
        body, used = row.code(inputs_of)
        sep = any(k == "sep" for k in kinds)
        funcs[kinds] = (fname, row.args, body, used, sep, len(row.reactions))
        used_all |= used
    # the model's inputs: state positions that the equations use, rates, parameters
    state_pos = [c for c in positions if c.name in used_all
                 or f"sin_{c.name}" in used_all or f"cos_{c.name}" in used_all]
    derived = [(f"{fn}_{c.name}", c.name, fn) for c in state_pos for fn in ("sin", "cos")
               if f"{fn}_{c.name}" in used_all]
    inputs = ([c.name for c in state_pos] + [c.rate.name for c in positions]
              + [p.name for p in S.parameters] + [d[0] for d in derived])
    scale_expr = _sym(velocity_rate(S, velocity).scale)
    n_acc = len(positions)
    out = [f'"""Generated by phasemap.declare from the declaration of {S.name}: do not edit."""',
           "import math", "import numpy as np", "from numba import njit",
           "from phasemap._numerics import restrict_affine", "", "NAN = np.nan", ""]
    printer = _printer()
    scale_args = sorted(s.name for s in scale_expr.free_symbols)
    out += ['@njit(cache=True, error_model="numpy", forceinline=True)',
            f"def velocity_scale({', '.join(scale_args)}):",
            f"    return {printer.doprint(sp.Float(1) * scale_expr)}", ""]
    if ctx.domain:
        conds = [inputs_of(e) for e, _ in ctx.domain]
        reps, red = sp.cse(conds + [inputs_of(_scale(e)) for e, _ in ctx.domain],
                           symbols=sp.numbered_symbols("_k_x"), order="none")
        used = set()
        for e in conds:
            used |= {x.name for x in e.free_symbols}
        for e in [inputs_of(_scale(e)) for e, _ in ctx.domain]:
            used |= {x.name for x in e.free_symbols}
        args = [nm for nm in inputs if nm in used]
        k = len(conds)
        out += ['@njit(cache=True, error_model="numpy", forceinline=True)',
                f"def inside({', '.join(args)}):"]
        out += [f"    {a} = {printer.doprint(b)}" for a, b in reps]
        out += ["    return " + " & ".join(
            f"(({printer.doprint(red[i])}) >= -{nx.TOL!r} * ({printer.doprint(red[k + i])}))"
            for i in range(k)), ""]
    acc_idx = [i for i, c in enumerate(S.coordinates) if c.rate]
    for kinds, (fname, args, body, used, sep, n_react) in funcs.items():
        params = args + ["rest"] + [nm for nm in inputs if nm in used]
        ok_status = _STATUS["SEPARATION" if sep else "ADMISSIBLE"]
        out += ['@njit(cache=True, error_model="numpy", forceinline=True)',
                f"def {fname}({', '.join(params)}):",
                f'    """Modes {", ".join(f"{c.name}: {k}" for c, k in zip(S.contacts, kinds))}."""']
        out += ["    " + ln for ln in body]
        out += [
            "    _k_absent = ((_k_presence == 1.0) & (not rest)) | ((_k_presence == 2.0) & rest)",
            "    _k_bad = _k_sing | _k_absent | (not _k_real)",
            f"    _k_st = {nx.ABSENT} if _k_absent else (({nx.CONTINUUM} if _k_cont else "
            f"{nx.NO_SOLUTION}) if _k_sing else ({nx.NO_SOLUTION} if not _k_real else "
            f"({ok_status} if _k_ok else {nx.INADMISSIBLE})))",
            "    return (float(_k_st), 1.0 if (_k_sing & (not _k_absent)) else 0.0,",
            "            NAN if _k_absent else _k_coef,",
            *[f"            NAN if _k_bad else _k_Q{j}," for j in acc_idx],
            *[f"            NAN if _k_bad else _k_r{i}," for i in range(n_react)],
            "            )", ""]
    spec = {
        "velocity": str(velocity),
        "inputs": inputs,
        "state_positions": [c.name for c in state_pos],
        "derived": derived,
        "scale_args": scale_args,
        "rows": [(name, direction, presence, funcs[tuple(m[0] for m in combo)][0],
                  _row_args(funcs[tuple(m[0] for m in combo)][1], presence, combo, S))
                 for name, direction, presence, combo in rows],
        "kappa": kappa,
        "domain": sorted({nm for _, nm in ctx.domain}),
        "n_acc": n_acc,
    }
    out += [f"SPEC = {json.dumps(spec)!r}", ""]
    return "\n".join(out)


def velocity_rate(S: System, velocity) -> Rate:
    for c in S.coordinates:
        if c.rate and c.rate.name == str(velocity):
            return c.rate
    raise AssertionError(velocity)


def _row_args(args, presence, combo, S):
    """The constants a row passes first to its function (presence, then per-contact signs)."""
    vals = [float(presence)]
    for c, (kind, s, rho, root) in zip(S.contacts, combo):
        if kind in ("slip", "roll", "turn"):
            vals.append(float(s))
            if kind == "slip" and isinstance(c, PointContact) and c.sided == "two":
                vals.append(float(rho))
            if kind == "turn":
                vals.append(float(root))
    assert len(vals) == len(args), (vals, args)
    return vals


def _build(S: System):
    """Validate, derive (or load the derivation from the kernel cache) and build the Model."""
    import numba
    import sympy as sp

    from . import _codegen
    from .model import Branch, Derived, Dynamics, Model, Variable

    _validate(S)
    h = hashlib.sha256(_canonical(S).encode())
    for f in (pathlib.Path(__file__), pathlib.Path(nx.__file__)):
        h.update(f.read_bytes())
    h.update(f"{sp.__version__} {numba.__version__} {np.__version__} {__version__}".encode())
    module = _codegen.load_module(f"{S.name}_declared_{h.hexdigest()[:16]}",
                                  lambda: _derive(S))
    spec = json.loads(module.SPEC)

    def var(x, **kw):
        # no symbol declared: sympy's (rho -> \rho, x_a -> x_{a}), so figures stay mathtext
        return Variable(x.name, x.units, x.long_name, x.symbol or sp.latex(sp.Symbol(x.name)),
                        **kw)

    coords = {c.name: c for c in S.coordinates}
    state = tuple(var(coords[nm], default=float(coords[nm].default), lower=coords[nm].lower,
                      upper=coords[nm].upper, lower_open=coords[nm].lower_open,
                      upper_open=coords[nm].upper_open) for nm in spec["state_positions"])
    moving = [c for c in S.coordinates if c.rate]
    state += tuple(var(c.rate, default=float(c.rate.default)) for c in moving)
    params = tuple(var(p, default=float(p.default), lower=p.lower, upper=p.upper,
                       lower_open=p.lower_open, upper_open=p.upper_open)
                   for p in S.parameters)
    derived = tuple(Derived(nm, src, getattr(np, fn)) for nm, src, fn in spec["derived"])
    accelerations = tuple(
        Variable(f"{c.name}_ddot", _per_s2(c.units), f"second derivative of the {c.long_name}",
                 f"\\ddot{{{c.symbol or c.name}}}") for c in moving)
    reactions = []
    for c in S.contacts:
        what = c.long_name or f"contact {c.name}"
        if isinstance(c, Joint):
            reactions += [Variable(f"Rx_{c.name}", "N", f"x component of the reaction of {what}"),
                          Variable(f"Ry_{c.name}", "N", f"y component of the reaction of {what}"),
                          Variable(f"M_{c.name}", "N m", f"friction moment of {what}")]
        else:
            reactions += [Variable(f"N_{c.name}", "N", f"normal reaction of {what}"),
                          Variable(f"F_{c.name}", "N", f"tangential (friction) force of {what}")]
            if isinstance(c, RollingContact):
                reactions.append(Variable(f"M_{c.name}", "N m", f"rolling-friction moment of {what}"))
    generated = [row[0] for row in spec["rows"]]
    unknown = sorted(set(S.names) - set(generated) - {r.name for r in reactions})
    if unknown:
        _fail(S, "names", f"{unknown[0]!r} is not a branch or a reaction of the system; its "
              f"branches are {', '.join(generated)}; its reactions "
              f"{', '.join(r.name for r in reactions)}")
    reactions = [dataclasses.replace(r, name=str(S.names[r.name]))
                 if r.name in S.names else r for r in reactions]
    renamed = [str(S.names.get(n, n)) for n in generated]
    for what, got in (("branch", renamed), ("reaction", [r.name for r in reactions])):
        clash = sorted({n for n in got if got.count(n) > 1})
        bad = [n for n in got if not _IDENT.match(n)]
        if clash or bad:
            _fail(S, "names", f"{what} names must be distinct identifiers: {(clash or bad)[0]!r}")
    candidates = tuple(Branch(renamed[i], float(direction), getattr(module, fname), tuple(args))
                       for i, (name, direction, presence, fname, args) in enumerate(spec["rows"]))
    positions = tuple(var(c, default=float(c.default)) for c in moving
                      if c.name not in spec["state_positions"])
    dynamics = Dynamics(coordinates=tuple((c.name, c.rate.name, f"{c.name}_ddot")
                                          for c in moving),
                        positions=positions, stick_is_rest=len(moving) == 1,
                        edges=dict(S.edges))
    axes = dict(S.default_axes) or _default_axes(S, state, params)
    return Model(
        name=S.name, title=S.title, citation=S.citation, state=state, params=params,
        derived=derived, candidates=candidates, accelerations=accelerations,
        reactions=tuple(reactions),
        coefficient=Variable("coef", "1", "determinant of the branch's contact problem, "
                             "relative to the magnitude of its terms"),
        velocity=spec["velocity"], velocity_scale=module.velocity_scale,
        default_axes=axes, dynamics=dynamics, check=_checks(S, spec, module),
        declaration=S, inside=getattr(module, "inside", None),
        domain_text=_domain_text(spec),
        # every sign a mode's law depends on (a slip's, a two-sided contact's normal
        # force's) is fixed by the mode, so a reaction changing sign ends the mode's
        # stage instead of bending its law
        kinks=())


def _domain_text(spec) -> str:
    names = spec.get("domain", [])
    if not names:
        return ""
    return ("the corner of contact " + " or ".join(repr(n) for n in names)
            + " leaves the body's edge (the contact no longer exists)")


def _checks(S: System, spec, module):
    """The model's Python-level domain check: the declaration's own, and ``inside``."""
    inside = getattr(module, "inside", None)
    if inside is None:
        return S.check
    import inspect

    names = list(inspect.signature(inside.py_func).parameters)
    text = _domain_text(spec)

    def check(values):
        if S.check is not None:
            S.check(values)
        vals = {}
        for n in names:
            src = n[4:] if n.startswith(("sin_", "cos_")) else n
            x = np.asarray(values[src], float)
            vals[n] = np.sin(x) if n.startswith("sin_") else (np.cos(x) if n.startswith("cos_")
                                                              else x)
        ok = np.vectorize(inside.py_func, otypes=[bool])(*(vals[n] for n in names))
        if not np.all(ok):
            raise ValueError(f"{S.name}: outside the domain: {text}")

    return check


def _generated_names(S: System) -> list[str]:
    m = S.model
    inverse = {v: k for k, v in S.names.items()}
    return [inverse.get(b, b) for b in m.branches]


def _model_of(system: System):
    """The model of a declaration (how a declared model is unpickled)."""
    return system.model


def _per_s2(units: str) -> str:
    return "s-2" if units == "1" else f"{units} s-2"


def _default_axes(S, state, params):
    """A first map: the first state variable with a finite domain against the first friction law."""
    axes = {}
    for v in state:
        if math.isfinite(v.lower) and math.isfinite(v.upper):
            axes[v.name] = (v.lower, v.upper, 512)
            break
    else:
        v = state[0]
        axes[v.name] = (float(v.default) - math.pi, float(v.default) + math.pi, 512)
    law = {PointContact: "friction", EdgeContact: "friction", RollingContact: "rolling_friction",
           Joint: "friction_radius"}
    c = S.contacts[0]
    sym = _sym(getattr(c, law[type(c)]))
    for p in params:
        if sym.is_Symbol and p.name == sym.name:
            axes[p.name] = (max(p.lower, 0.0), max(2.0 * p.default, 1.0), 512)
            break
    return axes
