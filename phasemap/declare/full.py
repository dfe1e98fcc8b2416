"""A declaration in its full coordinates, as numbers: what a motion through contact
changes integrates (:mod:`phasemap.motion.hybrid`).

The reduced equations (:mod:`phasemap.declare.equations`) hold every contact closed and
eliminate the coordinates the contacts fix.  Once a contact opens, those coordinates are
free: the body flies.  :func:`mechanics` turns the free system (every coordinate with
its rate, :class:`phasemap.declare.equations.FreeEquations`: the same Lagrangian and
contact kinematics) into one numeric function of ``(q, q', parameters)`` that returns
the mass matrix ``M``, the generalised forces ``h``, and per contact its gap ``g``, its
rows ``J`` (normal, tangential: the contact velocities are ``J q'``), their bias
``J' q'`` and its friction coefficient.  :func:`closure` gives the full coordinates of
a state of the reduced model (its contacts closed).
"""

from __future__ import annotations

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
    #: (q, u, p, t) -> the flat list [M (n*n), h (n), g (k), J (2k*n), bias (2k), mu (k)]
    #: (``mu``: the static coefficients, the limits of sticking)
    _pieces: Callable
    #: (q, p) -> [x, y of each body's centre of mass, then of each contact's body point]
    _points: Callable = None
    #: p -> per contact (nx, ny, offset) of its surface (a point contact) or (nan, nan,
    #: nan) (an edge contact: the obstacle is the corner, its body point in ``points``)
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

    def points(self, q, p):
        """``(centres, contacts)``: each body's centre of mass (b, 2) and each contact's
        body point (k, 2) at the positions ``q``."""
        a = np.array(self._points(*q, *p), dtype=float)
        b = self.n_bodies
        return a[:2 * b].reshape(b, 2), a[2 * b:].reshape(-1, 2)

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
        (arrays; ``J`` is (k, 2, n), ``b`` (k, 2): normal then tangential; ``mu`` the
        static coefficients)."""
        n, k = self.n, len(self.contacts)
        flat = np.array(self._pieces(*q, *u, *p, t), dtype=float)
        i = 0
        M = flat[i:i + n * n].reshape(n, n)
        i += n * n
        h = flat[i:i + n]
        i += n
        g = flat[i:i + k]
        i += k
        J = flat[i:i + 2 * k * n].reshape(k, 2, n)
        i += 2 * k * n
        b = flat[i:i + 2 * k].reshape(k, 2)
        i += 2 * k
        return M, h, g, J, b, flat[i:i + k]


def mechanics(S) -> Mechanics:
    """The :class:`Mechanics` of the declaration ``S`` (sympy once per declaration).

    Raises ValueError naming the contact where a contact is not a point or edge contact
    (a rolling contact or a joint: their motion through contact changes is not built)."""
    made = _MECHANICS.get((S,), (), lambda: _made(S))
    if isinstance(made, ValueError):
        raise made
    return made


def _made(S):
    """:func:`_make`, or the ValueError it raised (kept, so that a declaration whose
    contacts cannot open is derived once, not at every motion that ends at one)."""
    try:
        return _make(S)
    except ValueError as err:
        return err


def rate_name(c) -> str:
    """The name of a coordinate's rate in the full coordinates."""
    return c.rate.name if c.rate is not None else f"{c.name}_dot"


def _make(S) -> Mechanics:
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
        if set(ch) != {"N", "T"} or len(eqs.gaps[c.name]) != 1:
            fail(S, f"contact {c.name!r}", "motion through contact changes takes point and "
                 f"edge contacts (a normal and a tangent, one gap), not a {type(c).__name__} "
                 "(a rolling contact or a joint cannot open yet)")
        contacts.append(Contact(c.name, getattr(c, "sided", "one") == "one", len(contacts)))
        g.append(eqs.gaps[c.name][0])
        J += list(ch["N"][0]) + list(ch["T"][0])
        b += [ch["N"][1], ch["T"][1]]
        mu.append(c.static_expr() if hasattr(c, "static_expr") else c.law_expr())
    pts, surf = [], []
    for body in S.bodies:
        pts += [sym(body.position[0]), sym(body.position[1])]
    for c in S.contacts:
        if hasattr(c, "corner"):          # an edge contact: the body touches at the corner
            pts += [sym(c.corner[0]), sym(c.corner[1])]
            surf += [sp.nan, sp.nan, sp.nan]
        else:
            pts += [sym(c.point[0]), sym(c.point[1])]
            surf += [*_unit_normal(c.normal), sym(c.offset)]
    flat = [*eqs.M, *eqs.h, *g, *J, *b, *mu]
    t, speed = sym(TIME), sym(SLIP_SPEED)
    args = [*eqs.q, *eqs.qd, *eqs.params, t]
    pieces = sp.lambdify(args, flat, modules="math", cse=True)
    moving = [sym(getattr(c, "surface_velocity", 0)) for c in S.contacts]
    surface = None
    if any(v != 0 for v in moving):
        surface = sp.lambdify([*eqs.params, t], moving + [sp.diff(v, t) for v in moving],
                              modules="math")
    kinetic = None
    if any(sp.sympify(c.law_expr()) != m_ for c, m_ in zip(S.contacts, mu)):
        kinetic = tuple(sp.lambdify([*args, speed], c.law_expr(), modules="math")
                        for c in S.contacts)
    period = None if S.period is None else sp.lambdify(eqs.params, sym(S.period),
                                                        modules="math")
    qp = [*eqs.q, *eqs.params]
    dom = [e for e, _ in eqs.domain]
    domain = sp.lambdify(qp, dom or [sp.Integer(1)], modules="math", cse=True)
    bounds_e = []
    for c in S.coordinates:
        for side in ("lower", "upper"):
            e = eqs.bound_expr(c, side)
            bounds_e.append(sp.Float(-math.inf if side == "lower" else math.inf)
                            if e is None else e)
    bounds = sp.lambdify(eqs.params, bounds_e, modules="math")
    defaults = {p.name: float(p.default) for p in S.parameters}
    defaults.update({c.name: float(c.default) for c in S.coordinates})
    defaults.update({rate_name(c): float(c.rate.default) if c.rate else 0.0
                     for c in S.coordinates})
    return Mechanics(
        S.name, tuple(c.name for c in S.coordinates), tuple(rate_name(c) for c in S.coordinates),
        tuple(c.units for c in S.coordinates), tuple(c.long_name for c in S.coordinates),
        tuple(p.name for p in S.parameters), defaults, tuple(contacts),
        lambda p: np.array(bounds(*p), dtype=float).reshape(-1, 2), domain, len(dom), pieces,
        sp.lambdify(qp, pts, modules="math"),
        _surfaces(sp.lambdify(eqs.params, surf or [sp.Integer(0)], modules="math"),
                  len(S.contacts)),
        len(S.bodies), surface, kinetic, period)


def _surfaces(fn, k):
    return lambda p: np.array(fn(*p), dtype=float)[:3 * k].reshape(k, 3)


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
    """The :class:`Closure` of a declaration that has a reduced model."""
    return _CLOSURES.get((S,), (), lambda: _closure(S))


def _closure(S) -> Closure:
    import sympy as sp

    from phasemap.declare.equations import Equations

    eqs = Equations(S)        # the closed equations only: no mode is solved for this
    free = [i for i, c in enumerate(S.coordinates) if c.rate is not None]
    args = [eqs.q[i] for i in free] + [eqs.qd[i] for i in free] + list(eqs.params)
    pos = [eqs.on(eqs.q[i]) for i in range(eqs.n)]
    rates = [eqs.on(eqs.qd[i]) for i in range(eqs.n)]
    return Closure(tuple(str(a) for a in args), sp.lambdify(args, pos, modules="math"),
                   sp.lambdify(args, rates, modules="math"))
