r"""Edges: where a contact's slip factor vanishes, so that it is at rest while the system moves.

Every frictional contact slips with a multiple of one state velocity:
``u_c = k_c(q) v`` (:func:`phasemap.declare.modes.slip_velocity`).  Inside the
domain ``k_c`` keeps one sign, so ``sgn u_c = kappa_c sgn v`` and the contacts
share one slip direction: the candidate branches of
:func:`phasemap.declare.modes.candidates` assume it.  Where ``k_c`` vanishes
(the ladder lying flat, ``phi = pi/2``: its foot's velocity ``2 l cos(phi)
omega`` is zero whatever ``omega``), contact ``c`` is at rest while the system
moves.  Its tangential acceleration there is ``u_c' = k_c' v^2 + k_c v' =
k_c' v^2``, so it sticks, or starts to slip in either direction (the slip then
needs ``s u_c' > 0``), whatever the direction of ``v``.  And at rest it can
stick while another contact slips: with ``k_c = 0`` a sticking ``c`` no longer
stops the others.

Such a set is an :class:`Edge`: a state position ``q`` at a value ``q*`` where
the factors of the contacts ``Z`` vanish, found exactly by solving ``k_c = 0``
for ``q`` (sympy).  The derivation adds, per edge, the candidate branches that
exist only there (:func:`edge_candidates`), derived with ``q = q*``
substituted (:func:`on_edge`): there a contact problem can be singular for
every state (the ladder's foot sticking while its top slides: the foot and
the top are at one height, and two of the constraints coincide), which the
solvers handle as a family of reactions (:func:`phasemap.declare.solvers.solve_indeterminate`).
Such a row applies only where every ``k_c`` of its edge vanishes to the tie
tolerance (``|k_c| <= TOL * scale(k_c)``, the rule that decides a zero
velocity) and ``q`` is nearer ``q*`` than any other edge.

The ordinary rows stay valid at an edge with one change: a slip of ``c``
starts (and is tested as starting) wherever ``c`` is at rest, at rest or on
an edge (:attr:`Edge.factors`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

from phasemap.declare.law import SEPARATED
from phasemap.declare.modes import Candidate, Presence

#: Two edges of one coordinate closer than this (in sin and cos) are one edge.
NEAR = 1e-6


@dataclass(frozen=True)
class Edge:
    """Where the slip factors of the contacts ``contacts`` vanish: ``coordinate = value``.

    ``sin``, ``cos`` are the sine and cosine of the value (exact expressions of the
    parameters: the equations of the edge read them), ``factors`` maps each of those
    contacts to its slip factor ``k_c`` (an expression of the positions and
    parameters, not substituted), and ``label`` names the edge in branch names
    (``phi_max``: the coordinate's upper bound).
    """

    index: int
    coordinate: str
    value: object
    sin: object
    cos: object
    contacts: tuple[str, ...]
    factors: tuple
    label: str
    bound: int | None = None

    @property
    def symbol(self):
        import sympy as sp

        return sp.Symbol(self.coordinate, real=True)

    def substitute(self, e):
        """``e`` on the edge: sin and cos of the coordinate by their values there."""
        import sympy as sp

        q = self.symbol
        e = sp.sympify(e).xreplace({sp.sin(q): self.sin, sp.cos(q): self.cos})
        return e.xreplace({q: self.value}) if q in e.free_symbols else e

    def proximity(self):
        """An expression that is small only near this edge: ``|sin q - sin q*| + |cos q -
        cos q*|``, the distance to it in sine and cosine."""
        import sympy as sp

        q = self.symbol
        return sp.Abs(sp.sin(q) - self.sin) + sp.Abs(sp.cos(q) - self.cos)


def find_edges(eqs, factors: dict) -> list[Edge]:
    """Every edge of the domain where some contact's slip factor vanishes.

    ``factors`` maps a contact to ``k_c``.  For each state position ``q`` that
    ``k_c`` depends on, the zeros of ``k_c`` in ``q`` are solved exactly (in the
    sine and cosine of ``q``, with ``sin^2 + cos^2 = 1``); a zero is kept where it
    lies in the declared domain of ``q`` for some parameter values (at their
    bounds, or at samples that pass the declaration's ``check``).  Contacts
    whose factors vanish at one zero share an edge.
    """
    import sympy as sp

    S = eqs.S
    found: list[list] = []   # [coordinate, (value, sin, cos), [contacts]]
    for name, k in factors.items():
        num = sp.numer(sp.together(k))
        for c in (c for c in S.coordinates if c.rate):
            q = sp.Symbol(c.name, real=True)
            if q not in num.free_symbols:
                continue
            for zero in _zeros(num, q):
                if not _in_domain(eqs, c, zero[0]):
                    continue
                for entry in found:
                    if entry[0] == c.name and _same(entry[1], zero):
                        entry[2].append(name)
                        break
                else:
                    found.append([c.name, zero, [name]])
    edges = []
    for i, (coord, (value, sin, cos), names) in enumerate(found):
        c = next(x for x in S.coordinates if x.name == coord)
        side = _bound(eqs, c, value)
        label = f"{coord}_edge{i}" if side is None else f"{coord}_{('min', 'max')[side]}"
        edges.append(Edge(i, coord, value, sin, cos, tuple(names),
                          tuple(factors[n] for n in names), label, side))
    return edges


def _zeros(expr, q) -> list[tuple]:
    """The real zeros of ``expr`` in ``q`` as ``(q*, sin q*, cos q*)``: solved in
    ``s = sin q``, ``c = cos q`` with ``s^2 + c^2 = 1`` where ``q`` enters only through
    them, else in ``q``."""
    import sympy as sp

    s, c = sp.Dummy("s", real=True), sp.Dummy("c", real=True)
    poly = expr.xreplace({sp.sin(q): s, sp.cos(q): c})
    out = []
    try:
        if q in poly.free_symbols:
            sols = [(r, sp.sin(r), sp.cos(r)) for r in sp.solve(expr, q)]
        else:
            sols = [(sp.atan2(x[s], x[c]), x[s], x[c])
                    for x in sp.solve([poly, s * s + c * c - 1], [s, c], dict=True)
                    if s in x and c in x]
    except (NotImplementedError, sp.PolynomialError):
        return out
    for zero in sols:
        if any(v.has(sp.I) for v in zero):
            continue
        if not any(_same(zero, x) for x in out):
            out.append(zero)
    return out


def _same(a, b) -> bool:
    """Two zeros ``(q*, sin, cos)`` are one."""
    import sympy as sp

    return all(sp.simplify(x - y) == 0 for x, y in zip(a[1:], b[1:]))


def _numbers(e, pt):
    """``e`` at the parameter values ``pt`` (None where it is not a real number there)."""
    import sympy as sp

    try:
        x = complex(sp.N(sp.sympify(e).xreplace(
            {sp.Symbol(k, real=True): v for k, v in pt.items()})))
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    return x.real if abs(x.imag) <= 1e-12 and math.isfinite(x.real) else None


def _in_domain(eqs, c, value) -> bool:
    """Whether ``coordinate = value`` (modulo 2 pi) lies in the coordinate's declared domain
    (an open bound excluded) at some parameter values (:meth:`Equations.parameter_points`)."""
    for pt in eqs.parameter_points():
        x0 = _numbers(value, pt)
        if x0 is None:
            continue
        lo, hi = (eqs._bound_value(c, side, pt) for side in ("lower", "upper"))
        for x in (x0, x0 + 2 * math.pi, x0 - 2 * math.pi):
            tol = 1e-12 * (1.0 + abs(x))
            above = x > lo + tol if c.lower_open else x >= lo - tol
            below = x < hi - tol if c.upper_open else x <= hi + tol
            if above and below:
                return True
    return False


def _bound(eqs, c, value) -> int | None:
    """1 where ``coordinate = value`` is the coordinate's declared upper bound (at every
    parameter point), 0 where it is the lower one, else None."""
    for side, name in ((1, "upper"), (0, "lower")):
        hits = []
        for pt in eqs.parameter_points():
            b, x = eqs._bound_value(c, name, pt), _numbers(value, pt)
            if x is not None and math.isfinite(b):
                hits.append(min(abs(x + k * 2 * math.pi - b) for k in (-1, 0, 1))
                            <= 1e-9 * (1 + abs(b)))
        if hits and all(hits):
            return side
    return None


def edge_candidates(S, kappa: dict, edge: Edge, ordinary: list[Candidate]) -> list[Candidate]:
    """The candidate branches that exist only on ``edge`` (see the module docstring).

    A contact of the edge sticks or moves either way; every other contact moves
    in the direction ``d`` of the motion (``kappa_c s_c = d``) or is separated
    (a contact off the edge cannot stick while the system moves).  Kept are the
    combinations that the ordinary rows do not cover while moving in ``d``: a
    contact of the edge sticking or moving against ``d``.  At rest each
    combination is counted once: a combination that an ordinary row already
    covers at rest, or that an earlier edge row covers, applies only while moving.
    """
    Z = set(edge.contacts)
    covered = {r.modes for r in ordinary if r.presence != Presence.MOVING and r.edge is None}
    rows: list[Candidate] = []
    for d in (1, -1):
        for combo in itertools.product(*(c.modes() for c in S.contacts)):
            ok, new = True, False
            for c, m in zip(S.contacts, combo):
                if c.name in Z:
                    ok &= m.kind != SEPARATED
                    new |= not m.moves or m.slip * kappa[c.name] != d
                else:
                    ok &= m.kind == SEPARATED or (m.moves and m.slip * kappa[c.name] == d)
            if not (ok and new):
                continue
            name = "_".join(c.token(m) for c, m in zip(S.contacts, combo)) + f"_at_{edge.label}"
            presence = Presence.MOVING if combo in covered else Presence.ALWAYS
            if any(r.modes == combo for r in rows):
                name += "_moving_neg"
            covered.add(combo)
            rows.append(Candidate(name, float(d), presence, combo, edge.index))
    return rows


def on_edge(eqs, edge: Edge):
    """``eqs`` with the edge's coordinate at its value: the equations of the edge's rows."""
    return EdgeEquations(eqs, edge)


class EdgeEquations:
    """The equations of a system on one of its edges (``q = q*`` substituted); otherwise
    the same attributes and sampler as :class:`phasemap.declare.equations.Equations`."""

    def __init__(self, eqs, edge: Edge):
        self.base, self.edge = eqs, edge
        at = edge.substitute

        self.M = eqs.M.applyfunc(at)
        self.h = [at(x) for x in eqs.h]
        self.channels = {c: {k: ([at(a) for a in w], at(b), at(v)) for k, (w, b, v) in ch.items()}
                         for c, ch in eqs.channels.items()}

    def __getattr__(self, name):
        return getattr(self.base, name)


def edge_flag(edge: Edge):
    """The rule that decides the edge at a state, as ``(factors, scales, proximity)``:
    every factor ``|k_c| <= TOL * scale_c``, and the proximity below :data:`NEAR`."""
    from phasemap.declare.algebra import scale_of

    return list(edge.factors), [scale_of(k) for k in edge.factors], edge.proximity()


