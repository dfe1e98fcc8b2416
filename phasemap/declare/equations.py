"""The equations of motion of a declared system on its contact manifold (Lagrange).

:class:`Equations` derives ``M(q) q'' = h(q, q')`` from the bodies and the
potential, asks each contact law for its channels (velocity expressions) and
gaps, eliminates the coordinates the contacts fix, and checks what the rest of
the derivation relies on.  It also samples the declared domain, which is how
the derivation tells a quantity that vanishes identically from one that does
not.
"""

from __future__ import annotations

import math

import numpy as np

from .algebra import scale_of
from .api import Coordinate, sym
from .validation import fail


class Equations:
    """The system's equations on the contact manifold, and a numeric sampler.

    Attributes: ``q``, ``qd`` (coordinate and velocity symbols), ``n``, ``M``,
    ``h`` (mass matrix and generalised forces, contacts closed), ``channels``
    (per contact, per key: ``(w, bias, v)`` with ``v = w . qd`` and its
    acceleration ``w . q'' + bias``), ``domain`` (``(expression >= 0, contact)``,
    named in ``domain_labels``),
    ``params``, ``rates``, ``regular`` (the mass matrix is invertible).
    """

    def __init__(self, S):
        import sympy as sp

        self.S = S
        self.q = [sp.Symbol(c.name, real=True) for c in S.coordinates]
        self.qd = [sp.Symbol(c.rate.name, real=True) if c.rate else
                   sp.Symbol(f"_k_v_{c.name}", real=True) for c in S.coordinates]
        self.n = len(S.coordinates)
        self.params = [sp.Symbol(p.name, real=True) for p in S.parameters]
        self.rates = [self.qd[i] for i, c in enumerate(S.coordinates) if c.rate]
        self._rng = np.random.default_rng(20261123)
        M, h = self._lagrange()
        gaps, constraints = self._contacts()
        self.dep = [i for i, c in enumerate(S.coordinates) if c.rate is None]
        on = self._closing(gaps, constraints)
        self.on = on
        self.M = M.applyfunc(on)
        self.h = [on(x) for x in h]
        self.domain = [(on(e), nm) for e, nm in self.domain]
        self._close_channels()
        self._check_closed()
        self.regular = self._regular()
        self._check_constraints()

    def vel(self, e):
        """The time derivative of a position expression ``e``."""
        import sympy as sp

        e = sym(e)
        return sum((sp.diff(e, qi) * qdi for qi, qdi in zip(self.q, self.qd)), sp.Integer(0))

    def _lagrange(self):
        """The mass matrix and the generalised forces of the free system."""
        import sympy as sp

        S, q, qd, n, vel = self.S, self.q, self.qd, self.n, self.vel
        T = sp.Integer(0)
        for b in S.bodies:
            x, y = (sym(c) for c in b.position)
            w = vel(b.angle)
            T += sym(b.mass) * (vel(x) ** 2 + vel(y) ** 2) / 2 + sym(b.inertia) * w ** 2 / 2
        T = sp.expand(T)
        M = sp.Matrix(n, n, lambda i, j: sp.diff(T, qd[i], qd[j]))
        V = sym(S.potential)
        forces = {(k.name if isinstance(k, Coordinate) else k): sym(v)
                  for k, v in S.forces.items()}
        h = []
        for i in range(n):
            p = sp.diff(T, qd[i])
            h.append(sp.diff(T, q[i]) - sum(sp.diff(p, q[j]) * qd[j] for j in range(n))
                     - sp.diff(V, q[i]) + forces.get(S.coordinates[i].name, 0))
        return M, h

    def _contacts(self):
        """Each contact's channels and domain; all their gaps and velocity constraints."""
        self.channels, self.domain, self.constrained = {}, [], {}
        self.domain_labels = []
        gaps, constraints = [], []
        for c in self.S.contacts:
            kin = c.kinematics(self.vel)
            self.channels[c.name] = dict(kin.channels)
            self.constrained[c.name] = kin.constraints
            self.domain += [(e, c.name) for e in kin.domain.values()]
            self.domain_labels += [f"domain_{label}_{c.name}" for label in kin.domain]
            gaps += kin.gaps
            constraints += [kin.channels[k] for k in kin.constraints]
        return gaps, constraints

    def _closing(self, gaps, constraints):
        """``on(e)``: ``e`` with the dependent coordinates and their velocities eliminated."""
        import sympy as sp

        S, q, qd, dep = self.S, self.q, self.qd, self.dep
        names = ", ".join(S.coordinates[i].name for i in dep)
        if len(dep) != len(constraints):
            fail(S, "coordinates", f"{len(dep)} coordinate(s) without a rate "
                 f"({names or 'none'}) but the contacts "
                 f"impose {len(constraints)} constraint(s) on the velocities: declare as many "
                 "coordinates without a Rate as the contacts fix (one per point or "
                 "rolling contact's normal, one more per rolling contact, two per joint)")
        dq = [q[i] for i in dep if any(q[i] in g.free_symbols for g in gaps)]
        pos_sub = {}
        if dq:
            sols = sp.solve(gaps, dq, dict=True)
            if len(sols) != 1:
                fail(S, "contacts", "closing the contacts must fix the dependent "
                     f"coordinates {', '.join(map(str, dq))} uniquely; sympy found "
                     f"{len(sols)} solution(s)")
            pos_sub = sols[0]
            if set(pos_sub) != set(dq):
                fail(S, "contacts", f"the gaps do not fix {', '.join(map(str, dq))}")
        vsols = sp.solve(constraints, [qd[i] for i in dep], dict=True)
        if len(vsols) != 1 or len(vsols[0]) != len(dep):
            fail(S, "contacts", "the contact constraints must fix the velocities of "
                 f"{names}: they do not (a contact "
                 "constrains the state itself, or two contacts are redundant)")
        vel_sub = vsols[0]

        def on(e):
            return sp.sympify(e).xreplace(vel_sub).xreplace(pos_sub)

        return on

    def _close_channels(self):
        """Each channel as ``(w, bias, v)``: its velocity ``v = w . qd`` and its acceleration
        ``w . q'' + bias``, on the contact manifold."""
        import sympy as sp

        q, qd, n, on = self.q, self.qd, self.n, self.on
        for ch in self.channels.values():
            for k, v in list(ch.items()):
                w = [sp.diff(v, a) for a in qd]
                bias = sum((sp.diff(v, q[j]) * qd[j] for j in range(n)), sp.Integer(0))
                ch[k] = ([on(a) for a in w], on(bias), on(v))

    def _check_closed(self):
        """No dependent position or velocity is left in the equations."""
        gone = {self.q[i] for i in self.dep} | {self.qd[i] for i in self.dep}
        for e in [*self.M, *self.h] + [x for ch in self.channels.values()
                                       for (w, b, v) in ch.values() for x in (*w, b)]:
            left = e.free_symbols & gone
            if left:
                fail(self.S, "coordinates", f"{sorted(map(str, left))[0]} is still in the "
                     "equations after closing the contacts: a coordinate without a rate "
                     "must be fixed by a contact's gap or be ignorable")

    def _regular(self) -> bool:
        """Whether the mass matrix is invertible.

        A singular mass matrix is fine when the contacts take away the motions
        without inertia (the massless rod of a pendulum whose pivot is a
        coordinate): each mode then solves the whole saddle-point system, and
        fails there if the contacts do not.
        """
        dM = self.M.det(method="berkowitz")
        det = self.numeric(dM / (scale_of(dM) + 1), 16) if dM != 0 else np.zeros(1)
        return bool(np.all(np.abs(det) > 1e-12))

    def _check_constraints(self):
        """A constraint channel's velocity vanishes on the contact manifold."""
        for name, ch in self.channels.items():
            for key, (w, b, v) in ch.items():
                if key in self.constrained[name] and np.max(np.abs(self.numeric(v, 8))) > 1e-9:
                    fail(self.S, f"contact {name!r}", "its constraint velocity does not "
                         "vanish on the contact manifold")

    # -- sampling the declared domain ------------------------------------------

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
