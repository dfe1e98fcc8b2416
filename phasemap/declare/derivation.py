"""The derivation of a declared system: equations, candidate branches, their solutions.

One derivation serves both the generated module (:mod:`phasemap.declare.emit`)
and the conditions the bifurcation tracer reads
(:mod:`phasemap.declare.admissibility`).  It is deterministic: the sampler that
probes the declared domain is seeded, so deriving again gives the same rows.
"""

from __future__ import annotations

from dataclasses import dataclass

from phasemap.core.memo import Memo
from phasemap.declare.edges import Edge, edge_candidates, find_edges, on_edge
from phasemap.declare.equations import Equations
from phasemap.declare.modes import Candidate, candidates, slip_velocity
from phasemap.declare.solvers import Solution, problem, solve


@dataclass
class Derivation:
    """Everything derived from a declaration, before code is printed.

    ``solutions`` maps each mode-kind combination and edge (a candidate's
    ``key``: one generated branch function each, ``mode_0``, ``mode_1``... in
    order of first use) to its :class:`~phasemap.declare.solvers.Solution`;
    several candidate branches share one function and differ in its arguments
    (slip sign, N sign, root).  ``factors`` holds each contact's slip factor
    ``k_c`` and ``edges`` the :class:`~phasemap.declare.edges.Edge` s where some
    vanish; the candidates that exist only there come after the others.
    """

    S: object
    eqs: Equations
    velocity: object
    kappa: dict
    candidates: list[Candidate]
    solutions: dict
    factors: dict
    edges: list[Edge]

    @property
    def still(self) -> set:
        """The contacts that are at rest on some edge (their slips start there too)."""
        return {c for e in self.edges for c in e.contacts}

    @property
    def positions(self):
        """The coordinates with a rate (the state's positions)."""
        return [c for c in self.S.coordinates if c.rate]

    def inputs_of(self, e):
        """``e`` with sin(q) and cos(q) of state positions as the inputs ``sin_q``, ``cos_q``."""
        import sympy as sp

        trig = {}
        for c in self.positions:
            qs = sp.Symbol(c.name, real=True)
            trig[sp.sin(qs)] = sp.Symbol(f"sin_{c.name}", real=True)
            trig[sp.cos(qs)] = sp.Symbol(f"cos_{c.name}", real=True)
        return sp.sympify(e).xreplace(trig)


_DERIVED = Memo("derivation.derived")


def derive(S) -> Derivation:
    """Derive the equations of ``S`` and solve every mode combination (sympy; once per
    declaration object)."""
    return _DERIVED.get((S,), (), lambda: _derive(S))


def _derive(S) -> Derivation:
    eqs = Equations(S)
    eqs.velocity, eqs.kappa, factors = slip_velocity(eqs)
    rows = candidates(S, eqs.kappa)
    edges = find_edges(eqs, factors)
    for edge in edges:
        rows += edge_candidates(S, eqs.kappa, edge, rows)
    solutions: dict[tuple, Solution] = {}
    for row in rows:
        if row.key in solutions:
            continue
        fname = f"mode_{len(solutions)}"
        if row.edge is None:
            solutions[row.key] = solve(eqs, problem(eqs, row.kinds, fname))
        else:
            at = on_edge(eqs, edges[row.edge])
            solutions[row.key] = solve(at, problem(at, row.kinds, fname, at_rest=False),
                                       edge=True)
    return Derivation(S, eqs, eqs.velocity, eqs.kappa, rows, solutions, factors, edges)
