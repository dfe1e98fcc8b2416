"""The derivation of a declared system: equations, candidate branches, their solutions.

One derivation serves both the generated module (:mod:`phasemap.declare.emit`)
and the conditions the bifurcation tracer reads
(:mod:`phasemap.declare.admissibility`).  It is deterministic: the sampler that
probes the declared domain is seeded, so deriving again gives the same rows.
"""

from __future__ import annotations

from dataclasses import dataclass

from .equations import Equations
from .modes import Candidate, candidates, slip_velocity
from .solvers import Solution, problem, solve


@dataclass
class Derivation:
    """Everything derived from a declaration, before code is printed.

    ``solutions`` maps each mode-kind combination (one per generated branch
    function, ``mode_0``, ``mode_1``... in order of first use) to its
    :class:`~phasemap.declare.solvers.Solution`; several candidate branches
    share one function and differ in its arguments (slip sign, N sign, root).
    """

    S: object
    eqs: Equations
    velocity: object
    kappa: dict
    candidates: list[Candidate]
    solutions: dict

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


_DERIVED: dict[int, tuple] = {}


def derive(S) -> Derivation:
    """Derive the equations of ``S`` and solve every mode combination (sympy; once per
    declaration object)."""
    cached = _DERIVED.get(id(S))
    if cached is None or cached[0] is not S:
        cached = (S, _derive(S))
        _DERIVED[id(S)] = cached
    return cached[1]


def _derive(S) -> Derivation:
    eqs = Equations(S)
    eqs.velocity, eqs.kappa = slip_velocity(eqs)
    rows = candidates(S, eqs.kappa)
    solutions: dict[tuple, Solution] = {}
    for row in rows:
        if row.kinds not in solutions:
            solutions[row.kinds] = solve(eqs, problem(eqs, row.kinds, f"mode_{len(solutions)}"))
    return Derivation(S, eqs, eqs.velocity, eqs.kappa, rows, solutions)
