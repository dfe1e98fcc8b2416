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

from phasemap.declare.algebra import determinant, scale_of
from phasemap.declare.api import Coordinate, numeric_bound, sym
from phasemap.declare.validation import fail


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
        self._symbols(S)
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

    def _symbols(self, S):
        import sympy as sp

        self.S = S
        self.q = [sp.Symbol(c.name, real=True) for c in S.coordinates]
        self.qd = [sp.Symbol(c.rate.name, real=True) if c.rate else
                   sp.Symbol(f"_k_v_{c.name}", real=True) for c in S.coordinates]
        self.n = len(S.coordinates)
        self.params = [sp.Symbol(p.name, real=True) for p in S.parameters]
        self.rates = [self.qd[i] for i, c in enumerate(S.coordinates) if c.rate]
        self._rng = np.random.default_rng(20261123)

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
        D = sym(S.dissipation)
        h = []
        for i in range(n):
            p = sp.diff(T, qd[i])
            h.append(sp.diff(T, q[i]) - sum(sp.diff(p, q[j]) * qd[j] for j in range(n))
                     - sp.diff(V, q[i]) + forces.get(S.coordinates[i].name, 0)
                     - (sp.diff(D, qd[i]) if D != 0 else 0))
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
            pos_sub = self._closed_positions(gaps, dq)
        vsols = sp.solve(constraints, [qd[i] for i in dep], dict=True)
        if len(vsols) != 1 or len(vsols[0]) != len(dep):
            fail(S, "contacts", "the contact constraints must fix the velocities of "
                 f"{names}: they do not (a contact "
                 "constrains the state itself, or two contacts are redundant)")
        vel_sub = vsols[0]

        def on(e):
            return sp.sympify(e).xreplace(vel_sub).xreplace(pos_sub)

        return on

    def _closed_positions(self, gaps, dq) -> dict:
        """The dependent coordinates ``dq`` where every gap is closed, as a substitution.

        An angle that enters the gaps only through its sine and cosine is solved for
        them (with ``sin^2 + cos^2 = 1``: a polynomial system, where a contact that
        fixes an angle, a block lying flat on two corners, has two solutions).  Where
        there are several, the one nearest the declared defaults is taken (the
        coordinates' ``default``, at the parameters' defaults); a ValueError when
        none is, or two are equally near, says how to choose.
        """
        import sympy as sp

        S, names = self.S, ", ".join(map(str, dq))
        sub, unknowns, sc = {}, [], {}
        for x in dq:
            if any(g.has(sp.sin(x), sp.cos(x)) for g in gaps):
                sc[x] = (sp.Dummy(f"s_{x}", real=True), sp.Dummy(f"c_{x}", real=True))
                sub.update({sp.sin(x): sc[x][0], sp.cos(x): sc[x][1]})
                unknowns += list(sc[x])
            else:
                unknowns.append(x)
        polys = [sp.expand(g).xreplace(sub) for g in gaps]
        if any(x in p.free_symbols for p in polys for x in sc):   # not only sin and cos
            sc, polys, unknowns = {}, gaps, list(dq)
        sols = sp.solve(polys + [s * s + c * c - 1 for s, c in sc.values()], unknowns,
                        dict=True)
        sols = [x for x in sols if set(x) == set(unknowns)]
        if not sols:
            fail(S, "contacts", f"closing the contacts does not fix {names} (sympy found no "
                 "solution of the gaps = 0)")
        out = []
        for x in sols:
            d = {q: x[q] for q in dq if q not in sc}
            for q, (s, c) in sc.items():
                d.update({sp.sin(q): x[s], sp.cos(q): x[c], q: sp.atan2(x[s], x[c])})
            out.append(d)
        return out[0] if len(out) == 1 else self._nearest_default(out, dq)

    def _nearest_default(self, sols, dq) -> dict:
        """Of several closures, the one nearest the declared defaults (see above)."""
        import sympy as sp

        S = self.S
        at = {sp.Symbol(p.name, real=True): sp.Float(p.default) for p in S.parameters}
        want = {sp.Symbol(c.name, real=True): float(c.default) for c in S.coordinates}
        dist, shown = [], []
        for d in sols:
            vals = {q: complex(sp.sympify(d[q]).xreplace(at).evalf()) for q in dq}
            shown.append(", ".join(f"{q} = {v.real:.6g}" for q, v in vals.items()))
            real = all(abs(v.imag) <= 1e-12 for v in vals.values())
            dist.append(sum(min(abs(v.real - want[q] + k * 2 * math.pi) for k in (-1, 0, 1))
                            for q, v in vals.items()) if real else math.inf)
        order = sorted(range(len(sols)), key=dist.__getitem__)
        best = order[0]
        if not math.isfinite(dist[best]) or abs(dist[order[1]] - dist[best]) <= 1e-9:
            fail(S, "contacts", f"closing the contacts fixes {', '.join(map(str, dq))} in "
                 f"{len(sols)} ways at the parameters' defaults ({'; '.join(shown)}): give "
                 "the coordinates defaults nearest the configuration you mean")
        return sols[best]

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
        dM = determinant(self.M)
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

    def bound_expr(self, c, side: str):
        """A coordinate's ``lower`` or ``upper`` bound as a sympy expression of the
        parameters; None where it is infinite."""
        import sympy as sp

        b = getattr(c, side)
        if numeric_bound(b):
            return sp.Float(b) if math.isfinite(b) else None
        return sym(b)

    def _draw(self):
        vals = {}
        rng = self._rng
        for p in self.S.parameters:
            lo = p.lower if math.isfinite(p.lower) else p.default - 1.0 - abs(p.default)
            hi = p.upper if math.isfinite(p.upper) else p.default + 1.0 + abs(p.default)
            lo = max(lo, p.default * 0.5 if p.default > 0 else lo)
            vals[p.name] = rng.uniform(lo, hi if hi > lo else lo + 1.0)
        for c in self.S.coordinates:
            lo, hi = (self._bound_value(c, side, vals) for side in ("lower", "upper"))
            lo = lo if math.isfinite(lo) else (hi if math.isfinite(hi) else c.default) - math.pi
            hi = hi if math.isfinite(hi) else lo + 2 * math.pi
            vals[c.name] = rng.uniform(lo, hi) if hi > lo else lo
            if c.rate:
                vals[c.rate.name] = rng.uniform(-2.0, 2.0)
        return vals

    def _bound_value(self, c, side, vals) -> float:
        import sympy as sp

        e = self.bound_expr(c, side)
        if e is None:
            return math.inf if side == "upper" else -math.inf
        return float(e.xreplace({sp.Symbol(k, real=True): v for k, v in vals.items()}))

    def _accepted(self, vals) -> bool:
        """Whether the declaration's ``check`` accepts the sample (no check: always)."""
        if self.S.check is None:
            return True
        try:
            self.S.check(dict(vals))
        except ValueError:
            return False
        return True

    def sample(self):
        """Random values for every symbol, inside the declared domains and accepted by the
        declaration's ``check`` (a ValueError naming the system if it accepts none)."""
        for _ in range(200):
            vals = self._draw()
            if self._accepted(vals):
                return vals
        fail(self.S, "check", "rejects every state sampled from the declared domains: "
             "declare the domains (bounds) of the coordinates and parameters it asks for")

    def parameter_points(self) -> list[dict]:
        """Parameter values: 16 samples, each parameter at each of its finite bounds, and
        all of them at their lower, then at their upper bounds."""
        names = [p.name for p in self.S.parameters]
        pts = [{k: v for k, v in self.sample().items() if k in names} for _ in range(16)]
        base = dict(pts[0])
        for side in ("lower", "upper"):
            corner = dict(base)
            for p in self.S.parameters:
                b = getattr(p, side)
                if math.isfinite(b):
                    pts.append({**base, p.name: b})
                    corner[p.name] = b
            pts.append(corner)
        return pts

    def points(self) -> list[dict]:
        """Fixed sample points: 16 random ones, and each coordinate at its finite bounds."""
        pts = [self.sample() for _ in range(16)]
        for c in self.S.coordinates:
            for side in ("lower", "upper"):
                pt = self.sample()
                b = self._bound_value(c, side, pt)
                if math.isfinite(b):
                    pts.append({**pt, c.name: b})
        return pts

    def at(self, e, pts) -> np.ndarray:
        """``e`` evaluated at the points of :meth:`points` (sign symbols +1)."""
        import sympy as sp

        e = sp.sympify(e)
        # sp.N, not .evalf(): a bare symbol replaced by a float is a float
        return np.array([complex(sp.N(e.xreplace({s: pt.get(s.name, 1.0)
                                                  for s in e.free_symbols}))).real
                         for pt in pts])

    def numeric(self, e, k: int, extra=None) -> np.ndarray:
        """``e`` evaluated at ``k`` random samples (sign symbols random +-1).

        Evaluated in double precision by one vectorised function of the samples
        (:func:`sympy.lambdify` with common subexpressions): substituting numbers into
        a large expression one sample at a time rebuilt its tree each time (a
        wheelbarrow's statically indeterminate mode: 160 s of derivation, 38 s so).
        Where that is not a finite real number at every sample (a square root of a
        negative number, or a division by zero), sympy evaluates the samples itself,
        as before, so that a complex value's principal branch is sympy's."""
        return self.numeric_all([e], k, extra)[0]

    def numeric_all(self, exprs, k: int, extra=None) -> np.ndarray:
        """The expressions ``exprs`` evaluated at the same ``k`` random samples, one row
        each (:meth:`numeric`): one vectorised function of them all, whose common
        subexpressions are computed once (the dropped equation of a statically
        indeterminate family and the accelerations it moves share the family's Cramer
        numerators: a wheelbarrow's took 0.5 s apiece to print and evaluate alone)."""
        import sympy as sp

        exprs = [sp.sympify(e) for e in exprs]
        # (one expression's own set, as numeric always iterated it: the random draws go
        # to its symbols in the same order as before)
        free = (exprs[0].free_symbols if len(exprs) == 1
                else set().union(*(e.free_symbols for e in exprs)))
        rows = []
        for _ in range(k):
            vals = self.sample()
            subs = {s: vals.get(s.name, None) for s in free}
            for s in free:
                if subs[s] is None:
                    subs[s] = float(self._rng.choice([-1.0, 1.0])) if s.name.startswith(
                        "_k_sig") else (extra or {}).get(s.name, self._rng.uniform(-1, 1))
            rows.append(subs)
        syms = sorted(free, key=lambda s: s.name)
        args = [np.array([r[s] for r in rows], dtype=float) for s in syms]
        out = np.full((len(exprs), k), np.nan)

        def vectorised(part, at):
            try:
                fn = sp.lambdify(syms, part, modules="numpy", cse=True)
                with np.errstate(all="ignore"):
                    got = fn(*args)
                    for i, v in zip(at, got):
                        out[i] = np.broadcast_to(np.asarray(v, dtype=float), (k,))
            except Exception:  # noqa: BLE001 - sympy's own evaluation is the reference
                out[list(at)] = np.nan
                return False
            return True

        if not vectorised(exprs, range(len(exprs))) and len(exprs) > 1:
            for i, e in enumerate(exprs):     # (the one that failed alone, as before)
                vectorised([e], [i])
        for i, e in enumerate(exprs):
            if not np.all(np.isfinite(out[i])):
                out[i] = [complex(sp.N(e.xreplace(r))).real for r in rows]
        return out


class FreeEquations(Equations):
    """The equations of the free system, every coordinate with its rate and no contact
    closed: ``M``, ``h`` (:meth:`Equations._lagrange`) and each contact's channels and
    gaps, unclosed (``channels[c][key] = (w, bias, v)``, the velocity ``v = w . qd`` and
    its acceleration ``w . q'' + bias``; ``gaps[c]``).  What the motion through contact
    changes integrates (:mod:`phasemap.declare.full`); the same Lagrangian and contact
    kinematics as the closed equations."""

    def __init__(self, S):
        import sympy as sp

        self._symbols(S)
        self.M, self.h = self._lagrange()
        self.gaps, self.channels, self.domain = {}, {}, []
        for c in S.contacts:
            kin = c.kinematics(self.vel)
            self.gaps[c.name] = kin.gaps
            self.domain += [(e, c.name) for e in kin.domain.values()]
            chans = {}
            for k, v in kin.channels.items():
                v = sp.sympify(v)
                w = [sp.diff(v, a) for a in self.qd]
                bias = sum((sp.diff(v, self.q[j]) * self.qd[j] for j in range(self.n)),
                           sp.Integer(0))
                chans[k] = (w, bias, v)
            self.channels[c.name] = chans
