"""The event-driven motion in full coordinates: phases, their events, what follows each
(see :mod:`phasemap.motion.hybrid`)."""


from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from phasemap.core import events as ev
from phasemap.motion.impact import tangential_impact  # noqa: F401 - the package's name

from phasemap.motion.hybrid import binding, flow, jam, landing, stepping
from phasemap.motion.hybrid.phases import (  # noqa: F401 - the package's names
    MODE_NAMES, OPEN, QUIET, SLIP_NEG, SLIP_POS, SMOOTH, STICK, TOL, kind_of, normalised_det,
    system)
#: The events whose state jumps by an impulse (the saved points hold both sides).
JUMPS = (ev.IMPACT, ev.IWC, ev.JAM)
#: The Painleve policies where the accelerations have two or more solutions.
POLICIES = ("liftoff", "iwc", "stop")
#: The rebound speed (of the contact's normal velocity, in its units) below which the
#: impacts of one contact are taken to accumulate (Zeno), by default.
ZENO_SPEED = 1e-6

@dataclass
class Options:
    t_end: float
    rtol: float = 1e-10
    atol: float | None = None
    max_step: float = math.inf
    max_steps: int = 1_000_000
    max_events: int = 10_000
    impact_law: str = "stronge"
    restitution: float = 0.0
    painleve: str = "liftoff"
    zeno_speed: float = ZENO_SPEED


@dataclass
class Record:
    """What a motion through contact changes saves."""

    t: list = field(default_factory=list)
    y: list = field(default_factory=list)
    modes: list = field(default_factory=list)
    ev_t: list = field(default_factory=list)
    ev_kind: list = field(default_factory=list)
    ev_contact: list = field(default_factory=list)
    ev_y: list = field(default_factory=list)
    ev_modes: list = field(default_factory=list)
    ev_impulse: list = field(default_factory=list)   # (P_n, P_t, dKE) or NaNs
    fate: int = ev.HORIZON
    n_steps: int = 0

    def point(self, t, y, modes):
        self.t.append(float(t))
        self.y.append(np.array(y, dtype=float))
        self.modes.append(tuple(modes))

    def points(self, ts, ys, modes):
        """:meth:`point` of each time of ``ts`` and row of ``ys`` (copied)."""
        self.t.extend(ts.tolist())
        self.y.extend(np.array(ys, dtype=float))
        self.modes.extend([tuple(modes)] * len(ts))

    def event(self, t, kind, contact, y, modes, impulse=(math.nan,) * 3):
        self.ev_t.append(float(t))
        self.ev_kind.append(int(kind))
        self.ev_contact.append(int(contact))
        self.ev_y.append(np.array(y, dtype=float))
        self.ev_modes.append(tuple(modes))
        self.ev_impulse.append(tuple(float(x) for x in impulse))


class Motion:
    """The motion of one declaration (its :class:`phasemap.declare.full.Mechanics`) at the
    parameters ``p`` (array, in ``mech.parameters`` order)."""

    def __init__(self, mech, p, opts: Options):
        self.mech, self.p, self.o = mech, np.asarray(p, dtype=float), opts
        self.n, self.k = mech.n, len(mech.contacts)
        self.one_sided = np.array([c.one_sided for c in mech.contacts], dtype=bool)
        self.rolls = np.array([c.rolls for c in mech.contacts], dtype=bool)
        self.bounds = mech.bounds(self.p)
        self.zeno_until = -math.inf
        #: a system that depends on the time, or whose surfaces move, does not stop at
        #: a momentary rest
        self.rests = mech.can_rest
        #: the compiled flow: the phases' accelerations, event functions and steps
        self.flow = binding.Phase(mech, self.p, self.one_sided, self.rolls, (warm, (), {}))
        self._flag_memo: dict = {}

    def surf(self, t):
        """Each contact surface's tangential velocity at ``t``."""
        return self.mech.surface(self.p, t)[0]

    def relative(self, J, u, t):
        """The contacts' velocities ``(k, 2)``: normal, and tangential relative to the
        surface (a belt's own velocity taken off)."""
        v = J @ u
        if not self.mech.plain:
            v = v.copy()
            v[:, 1] -= self.surf(t)
        return v

    # -- the accelerations of a phase ---------------------------------------------

    def solve(self, q, u, modes, rho=None, t=0.0, start=()):
        """``(u', N, F, a, pieces)`` of the phase ``modes`` at ``(q, u)`` and time ``t``:
        accelerations, reactions and the contacts' accelerations ``a`` (k, 2, relative to
        the surfaces); None where the phase's linear system is singular.  ``rho``: the
        sign of N each two-sided contact's friction assumes (+1 for the one-sided).
        A slipping contact slips with its kinetic coefficient at its sliding speed; those
        in ``start`` (a slip starting from relative rest) are tested against the static
        one."""
        return self._solve(q, u, modes, rho, t, start)[0]

    def singularity(self, q, u, modes, rho=None, t=0.0):
        """The determinant of the phase's reaction matrix, each row (a held acceleration)
        and column (a reaction's direction) scaled to unit length in the inverse mass
        metric: in [-1, 1], and 0 where the phase is singular.  Only a slip makes it so
        (a phase without one has a positive definite matrix): 1 for such a phase.  For
        one slipping contact it is B = W_nn - s mu W_nt over its scale, the coefficient of
        the senior derivative that a dynamic jam drives to zero."""
        return self._solve(q, u, modes, rho, t, (), True)[1]

    def _solve(self, q, u, modes, rho=None, t=0.0, start=(), singular=False):
        """``(solve(...), singularity(...))``; the second 1.0 unless ``singular``.  On the
        compiled flow; in Python where the phase's contacts are redundant."""
        fl = self.flow
        st, det = fl.solve(np.concatenate([q, u]), t, np.asarray(modes, dtype=np.int64),
                           fl.pressing if rho is None else np.asarray(rho, dtype=float),
                           np.array([c in start for c in range(self.k)], dtype=np.bool_)
                           if start else fl.none, bool(singular))
        if st == flow.REDUNDANT:
            return self._solve_redundant(q, u, modes, rho, t, start, singular)
        if st != flow.OK:
            return None, det
        return (fl.ud.copy(), fl.N.copy(), fl.F.copy(), fl.a.copy(), fl.pieces()), det

    def _solve_redundant(self, q, u, modes, rho=None, t=0.0, start=(), singular=False):
        """:meth:`_solve` in Python, with an admissible member of a family of reactions
        (:meth:`_member`)."""
        M, h, g, J, b, mu = P = self.mech.pieces(q, u, self.p, t)
        sd = None
        if not self.mech.plain:
            sd = self.mech.surface(self.p, t)[1]
            speed = np.abs(self.relative(J, u, t)[:, 1])
            kin = self.mech.kinetic(q, u, self.p, t, speed, mu)
            mu = np.array([mu[c] if c in start else kin[c] for c in range(self.k)])
        cols, rows, rhs, owner = system(modes, rho, J, b, mu, sd, self.rolls)
        N, F = np.zeros(self.k), np.zeros(self.k)
        det = 1.0
        if not cols:
            ud = np.linalg.solve(M, h)
        else:
            G = np.array(cols).T
            R = np.array(rows)
            X = np.linalg.solve(M, np.column_stack([h, G]))
            A = R @ X[:, 1:]
            if singular and any(m in (SLIP_POS, SLIP_NEG) and mu[c] != 0.0
                                for c, m in enumerate(modes)):
                det = normalised_det(A, R, G, X[:, 1:], M)
            r_ = np.array(rhs) - R @ X[:, 0]
            # redundant contacts (a family of reactions, one member admissible) where the
            # system is near singular: its determinant against Hadamard's bound (the
            # product of its rows' norms), cheaper than a condition number
            rows_ = np.sqrt((A * A).sum(axis=1))
            if abs(np.linalg.det(A)) > 1e-12 * np.prod(rows_):
                lam = np.linalg.solve(A, r_)
            else:
                lam = self._member(A, r_, owner, modes, rho, P)
            if lam is None or not np.all(np.isfinite(lam)):
                return None, det
            ud = X[:, 0] + X[:, 1:] @ lam
            for (c, j), x in zip(owner, lam):
                if j < 2:           # (a rolling disc's force along the surface: not kept)
                    (N if j == 0 else F)[c] = x
            for c, m in enumerate(modes):
                if m in (SLIP_POS, SLIP_NEG):
                    r = 1.0 if rho is None else rho[c]
                    F[c] = -(1.0 if m == SLIP_POS else -1.0) * r * mu[c] * N[c]
        a = J @ ud + b
        if sd is not None:
            a[:, 1] -= sd
        return (ud, N, F, a, P), det

    def _member(self, A, r, owner, modes, rho, P):
        """Of the reactions ``A lam = r`` of redundant contacts (a rod lying flat on
        two rough points: a one-parameter family), one that every closed contact admits
        (N >= 0, |F| <= mu N where stuck), by linear programming; the least-norm member
        where none does (the mode is then refused by its own tests); None where
        ``A lam = r`` has no solution."""
        from scipy.optimize import linprog

        lam, *_ = np.linalg.lstsq(A, r, rcond=1e-12)
        scale = np.abs(r).max() + np.abs(A).max() * np.abs(lam).max() + 1e-300
        if np.abs(A @ lam - r).max() > 1e-9 * scale:
            return None
        mu = P[5]
        ub, b = [], []
        idx = {key: j for j, key in enumerate(owner)}
        for c, m in enumerate(modes):
            if m == OPEN:
                continue
            sign = 1.0 if rho is None else rho[c]  # as solve() reads it
            row = np.zeros(len(owner))
            row[idx[(c, 0)]] = -sign
            if self.one_sided[c] or m != SMOOTH:
                ub.append(row)
                b.append(0.0)
            if m == STICK:
                for sgn in (1.0, -1.0):
                    row = np.zeros(len(owner))
                    row[idx[(c, 1)]] = sgn
                    row[idx[(c, 0)]] = -mu[c] * sign
                    ub.append(row)
                    b.append(0.0)
        res = linprog(np.zeros(len(owner)), A_ub=np.array(ub) if ub else None,
                      b_ub=np.array(b) if b else None, A_eq=A, b_eq=r,
                      bounds=[(None, None)] * len(owner), method="highs")
        return res.x if res.status == 0 else lam

    # -- which phase follows -------------------------------------------------------

    def scales(self, q, u, P):
        """Scales of the contact velocities, reactions, accelerations and lengths at a state
        (``P``: its pieces), what every tolerance of a decision is relative to: compiled
        (:func:`flow.scales`), the numbers :meth:`survey` and the maps use."""
        return self.flow.scales(P, np.concatenate([q, u]))

    def scales_at(self, q, u, t=0.0):
        """:meth:`scales` at the state ``(q, u)`` and time ``t``, its pieces evaluated by
        the compiled flow (no NumPy arrays of them in Python)."""
        return self.flow.scales_at(np.concatenate([q, u]), t)

    def admissible(self, q, u, modes, sc, prefer=None, t=0.0, flip=()):
        """``(u', N, F, a, rho)`` of the phase ``modes`` if it is admissible at
        ``(q, u)``, else None (a two-sided contact's friction tries each sign of N).
        A slip that starts from relative rest is tested with the static coefficient."""
        vs = sc[0]
        pref = binding.preferences(self.k, prefer)
        two = [c for c, m in enumerate(modes) if m != OPEN and not self.one_sided[c]]
        start = ()
        if not self.mech.plain:
            v = self.relative(self.mech.pieces(q, u, self.p, t)[3], u, t)
            start = tuple(c for c, m in enumerate(modes)
                          if m in (SLIP_POS, SLIP_NEG) and abs(v[c, 1]) <= TOL * vs)
        for signs in np.ndindex(*(2,) * len(two)):
            rho = np.ones(self.k)
            for c, s in zip(two, signs):
                rho[c] = (1.0 - 2.0 * s) * (-1.0 if c in flip else 1.0)
            sol = self.solve(q, u, modes, rho, t, start)
            if sol is None:
                continue
            ud, N, F, a, P = sol
            M, h, g, J, b, mu = P
            v = self.relative(J, u, t)
            # the tests of flow.admits, which flow.survey runs for every phase at once
            if self.flow.admits(np.asarray(modes, dtype=np.int64), rho, self.one_sided, N, F,
                                a, g, np.ascontiguousarray(v[:, 0]),
                                np.ascontiguousarray(v[:, 1]), mu, np.asarray(sc, dtype=float),
                                pref):
                return ud, N, F, a, rho
        return None

    def each_phase(self, q, u, cand, sc, prefer=None, t=0.0, flip=()):
        """:meth:`admissible` of each phase the candidate modes ``cand`` (per contact) make,
        in :func:`flow.survey`'s order: the admissible ones as ``(modes, solution)``.  What
        :meth:`enumerate` runs where the contacts are redundant."""
        found = []
        for pick in np.ndindex(*[len(m) for m in cand]):
            modes = tuple(cand[c][i] for c, i in enumerate(pick))
            sol = self.admissible(q, u, modes, sc, prefer, t, flip)
            if sol is not None:
                found.append((modes, sol))
        return found

    def enumerate(self, q, u, prefer=None, t=0.0, flip=()):
        """Every admissible phase at ``(q, u)``, grouped by their accelerations (phases
        that move the body alike, such as slip with N = 0 and open with g'' = 0, are one
        motion): a list of groups, each a list of ``(modes, solution)``.  ``prefer``:
        ``{contact: mode}`` orders each group (the mode an event points to first)."""
        return self.survey(q, u, prefer, t, flip)[0]

    def at_parameters(self, p):
        """This motion at the parameters ``p`` from now on (a map's cells: the flow stays
        bound, its parameters are written in place)."""
        self.p[:] = p
        self.flow.p[:] = p
        self.bounds = self.mech.bounds(self.p)
        self.flow.bounds[:] = self.bounds

    def survey(self, q, u, prefer=None, t=0.0, flip=()):
        """``(groups, candidates)``: :meth:`enumerate`'s groups, and per contact the modes
        it may take at ``(q, u)`` (:func:`flow.survey`), which say what touches and what is
        at relative rest (what :func:`phasemap.classify` and the maps of a system in full
        coordinates read)."""
        # the scales, each contact's candidate modes and the admissible phases among them,
        # in one compiled call (flow.survey)
        sc, cand, found = self.flow.survey(np.concatenate([q, u]), t, flip, prefer,
                                           self.mech.plain)
        if found is None:   # redundant contacts: a member of their reactions picked here
            found = self.each_phase(q, u, cand, sc, prefer, t, flip)
            ids = np.zeros(len(found), dtype=np.int64)
            if found:
                self.flow.groups(np.array([sol[0] for _, sol in found]), len(found), self.n,
                                 sc[2], ids)
            found = [(modes, sol, int(i)) for (modes, sol), i in zip(found, ids)]
        groups = [[] for _ in range(max((g for _, _, g in found), default=-1) + 1)]
        for modes, sol, g in found:
            groups[g].append((modes, sol))
        prefer = prefer or {}
        touching = [c for c in range(self.k) if len(cand[c]) > 1]

        def rank(item):
            modes = item[0]
            return (-sum(modes[c] == m for c, m in prefer.items()),
                    -sum(m == OPEN for m in modes), -sum(m in (SLIP_POS, SLIP_NEG)
                                                          for m in modes))
        out = []
        for g in groups:
            g = sorted(g, key=rank)
            if len(g) > 1:   # a tie: the next derivative decides (kept stable: sorted)
                g = sorted(g, key=lambda item: not self._holds(q, u, item, touching, sc, t))
            out.append(g)
        return out, cand

    def _holds(self, q, u, item, touching, sc, t=0.0) -> bool:
        """Whether the phase ``item`` (modes and solution) still holds a moment later
        along its own motion: the tie between phases that move the body alike at an
        event (slip with N = 0 and open with g'' = 0; stick at the friction limit and a
        slip from zero acceleration) decided by the next derivative, as Siconos does.
        The touching contacts' conditions, strictly, at the state ``1e-6`` of the
        motion's time scale later (second-order Taylor)."""
        modes, (ud, N, F, a, rho) = item
        dt = 1e-6 * math.sqrt(sc[3] / sc[2])
        q1 = q + dt * u + 0.5 * dt * dt * ud
        u1 = u + dt * ud
        sol = self.solve(q1, u1, modes, rho, t + dt)
        if sol is None:
            return False
        ud1, N1, F1, a1, P1 = sol
        mu = P1[5]
        for c in touching:
            m = modes[c]
            if m == OPEN:
                if a1[c, 0] < 0.0 and P1[2][c] <= 0.0:
                    return False
            elif rho[c] * N1[c] < 0.0:
                return False
            elif m == STICK and abs(F1[c]) > mu[c] * rho[c] * N1[c]:
                return False
            elif m in (SLIP_POS, SLIP_NEG):
                s = 1.0 if m == SLIP_POS else -1.0
                if s * (P1[3][c, 1] @ u1 - self.surf(t + dt)[c]) < 0.0:
                    return False
        return True

    # -- projections ------------------------------------------------------------------

    def project(self, q, u, closed, held=(), fixed=(), moving=None, t=0.0):
        """The state put on the contacts ``closed`` in the mass metric: positions on their
        gaps' zero, velocities on ``J_n u = 0`` for the closed contacts (or for those in
        ``moving``, where given: a contact that closes with an impact keeps its approach)
        and ``J_t u`` on the surface's velocity for those in ``held``: the smallest change
        in kinetic-energy norm.  ``fixed``: coordinates held where they are.  Compiled
        (:func:`phasemap.motion.hybrid.flow.project`); ``numpy.linalg.LinAlgError`` where
        it has no finite result or the gaps cannot close with the fixed coordinates."""
        closed = list(closed)
        if not closed:
            return q, u
        moving = closed if moving is None else list(moving)
        return self._projected(q, u, closed, moving, held, fixed, t)

    def project_velocity(self, q, u, moving, held=(), t=0.0):
        """The velocities put on ``J_n u = 0`` for the contacts ``moving`` and ``J_t u``
        on the surface's velocity for those in ``held``, at the positions ``q``: the
        smallest change in kinetic-energy norm."""
        if not len(moving) and not len(held):
            return u
        return self._projected(q, u, (), moving, held, (), t)[1]

    def project_velocities(self, qs, us, ts, moving, held=()):
        """:meth:`project_velocity` at each state ``(qs[i], us[i], ts[i])`` (rows), in one
        compiled call: the velocities, a row each."""
        if not len(moving) and not len(held):
            return np.array(us, dtype=float)
        flags, still = self._flags((), moving, held, ())
        y = self.flow.project_many(np.hstack([np.asarray(qs, dtype=float),
                                              np.asarray(us, dtype=float)]),
                                   ts, flags[0], flags[1], flags[2], still)
        if y is None:
            raise np.linalg.LinAlgError(self._UNPROJECTED.format(self.mech.name))
        return y[:, self.n:]

    _UNPROJECTED = ("{}: the state cannot be projected onto its closed contacts (a singular "
                    "system, or values that are not finite)")

    def _flags(self, closed, moving, held, fixed):
        """The contacts ``closed``, ``moving``, ``held`` and the coordinates ``fixed`` as
        :func:`flow.project` takes them: a boolean row per contact set, and one per
        coordinate.  Made once per combination and kept (the kernels only read them)."""
        key = (tuple(closed), tuple(moving), tuple(held), tuple(fixed))
        if key not in self._flag_memo:
            flags, still = np.zeros((3, self.k), dtype=np.bool_), np.zeros(self.n, np.bool_)
            for row, which in enumerate(key[:3]):
                flags[row, list(which)] = True
            still[list(key[3])] = True
            self._flag_memo[key] = flags, still
        return self._flag_memo[key]

    def _projected(self, q, u, closed, moving, held, fixed, t):
        flags, still = self._flags(closed, moving, held, fixed)
        y = self.flow.project(np.concatenate([np.asarray(q, dtype=float),
                                              np.asarray(u, dtype=float)]),
                              t, flags[0], flags[1], flags[2], still)
        if y is None:
            raise np.linalg.LinAlgError(self._UNPROJECTED.format(self.mech.name))
        return y[:self.n], y[self.n:]

    # -- the events of a phase ----------------------------------------------------------

    def watch(self, q, u, modes, rho, sc, t=0.0, jam=0.0):
        """The event functions of a phase at ``(q, u)``, each >= 0 while it goes on:
        per contact two (open: its gap; closed: its N; slipping: its slip velocity;
        stuck: its friction slack), then each coordinate's bounds, the declared domain
        conditions, and last the phase's :meth:`singularity` times ``jam`` (its sign at
        the phase's start; 0: not watched, the function 1)."""
        out = np.ones(self.k * 2 + 2 * self.n + self.mech.n_domain + 1)
        st = self.flow.watch(np.concatenate([q, u]), t, np.asarray(modes, dtype=np.int64),
                             np.ones(self.k) if rho is None else np.asarray(rho, dtype=float),
                             jam, out)
        if st == flow.OK:
            return out
        out[:] = 1.0
        (ud, N, F, a, P), det = self._solve(q, u, modes, rho, t, (), jam != 0.0)
        if jam != 0.0:
            out[-1] = jam * det
        M, h, g, J, b, mu = P
        vs, fs, acs, L = sc
        surf = self.surf(t)
        for c, m in enumerate(modes):
            if m == OPEN:
                if self.one_sided[c]:
                    out[2 * c] = g[c]
                continue
            if self.one_sided[c]:
                out[2 * c] = N[c]
            elif m != SMOOTH:
                out[2 * c] = rho[c] * N[c]
            if m == STICK:
                out[2 * c + 1] = mu[c] * rho[c] * N[c] - abs(F[c])
            elif m in (SLIP_POS, SLIP_NEG):
                out[2 * c + 1] = (1.0 if m == SLIP_POS else -1.0) * (J[c, 1] @ u - surf[c])
        i = 2 * self.k
        out[i:i + self.n] = q - self.bounds[:, 0]
        out[i + self.n:i + 2 * self.n] = self.bounds[:, 1] - q
        if self.mech.n_domain:
            out[i + 2 * self.n:-1] = self.mech.domain(*q, *self.p)
        return out

    def watch_many(self, ts, ys, modes, rho, sc, jam=0.0):
        """:meth:`watch` at each state ``(ts[i], ys[i])`` (rows of ``q`` then ``u``), a row
        each: in one compiled call, and in Python where the phase's solve is not the plain
        one."""
        ts = np.ascontiguousarray(ts, dtype=float)
        ys = np.ascontiguousarray(ys, dtype=float)
        out = np.ones((ts.size, self.k * 2 + 2 * self.n + self.mech.n_domain + 1))
        status = self.flow.watch_many(ys, ts, np.asarray(modes, dtype=np.int64),
                                      np.ones(self.k) if rho is None else
                                      np.asarray(rho, dtype=float), jam, out)
        for i in np.flatnonzero(status != flow.OK):
            out[i] = self.watch(ys[i, :self.n], ys[i, self.n:], modes, rho, sc, ts[i], jam)
        return out

    def gap_rate(self, q, u, c, t=0.0):
        """``g'`` of contact ``c``."""
        M, h, g, J, b, mu = self.mech.pieces(q, u, self.p, t)
        return float(J[c, 0] @ u)

    def dip_rate(self, q, u, c, modes, rho, t=0.0):
        """The rate of the function contact ``c``'s mode watches for a dip between steps
        (:func:`phasemap.motion.hybrid.flow._watched`): an open contact's ``g'``, a
        slipping one's tangential acceleration relative to its surface, signed by its
        slip."""
        if modes[c] == OPEN:
            return self.gap_rate(q, u, c, t)
        s = 1.0 if modes[c] == SLIP_POS else -1.0
        sol = self.solve(q, u, modes, rho, t)
        return math.nan if sol is None else s * float(sol[3][c, 1])

    # -- the motion -------------------------------------------------------------------------

    def run(self, q, u, t0=0.0, t_eval=None, first=ev.START) -> Record:
        """The motion from ``(q, u)`` at ``t0`` to ``opts.t_end``: a :class:`Record`.
        ``first``: the first event's kind (-1: the one the modes found name, for a motion
        that goes on from the reduced model's end with every contact closed)."""
        o = self.o
        rec = Record()
        self.rec = rec
        self.t_eval = np.asarray(t_eval, dtype=float) if t_eval is not None else None
        self.i_eval = 0
        q, u = np.array(q, dtype=float), np.array(u, dtype=float)
        P = self.mech.pieces(q, u, self.p, t0)
        sc = self.scales(q, u, P)
        g = P[2]
        for c in range(self.k):
            if self.one_sided[c] and g[c] < -1e-9 * sc[3]:
                raise ValueError(f"{self.mech.name}: the start is inside the obstacle at "
                                 f"contact {self.mech.contacts[c].name!r} (gap {g[c]:.6g}): "
                                 "give the coordinates a state on or off every contact")
        t = t0
        modes = tuple(OPEN if (self.one_sided[c] and g[c] > 1e-9 * sc[3]) else STICK
                      for c in range(self.k))
        if first == -1:     # going on from the reduced model: the modes it moved in
            modes = jam.sliding(self, q, u, t)
        v = P[3] @ u
        hit = [c for c in range(self.k) if self.one_sided[c] and g[c] <= 1e-9 * sc[3]
               and v[c, 0] < -TOL * sc[0]]
        if hit:   # a start on a contact, approaching it: an impact first
            modes = tuple(OPEN if c in hit or modes[c] == OPEN else modes[c]
                          for c in range(self.k))
            if first == ev.START:
                self.rec.event(t, ev.START, -1, np.concatenate([q, u]), modes)
            step = landing.closing(self, t, q, u, modes, hit[0])
        else:
            step = self._decide(t, q, u, modes, first, -1, {})
        atol = o.rtol if o.atol is None else o.atol
        same, t_last = 0, math.nan
        while step is not None:
            t, q, u, modes, rho = step
            same = same + 1 if t == t_last else 0
            t_last = t
            if same > ev.MAX_FLICKERS:   # phases of zero length, one after another
                self._end(t, q, u, modes, ev.STEP_FAILURE)
                break
            if rec.ev_t and len(rec.ev_t) >= o.max_events:
                self._end(t, q, u, modes, ev.MAX_EVENTS)
                break
            sc = self.scales_at(q, u, t)

            t_stop = o.t_end
            if self.zeno_until > t:
                t_stop = min(t_stop, self.zeno_until)
            # a function the event's projection left a rounding error below zero starts
            # at zero (a gap just closed or opened, a slip velocity just zero)
            jam_sign = jam.sign(self, q, u, modes, rho, t)
            w0 = self.watch(q, u, modes, rho, sc, t, jam_sign)
            w0[(w0 < 0.0) & (w0 >= -TOL * self._scale_of(sc))] = 0.0
            step = stepping.phase(self, t, q, u, modes, rho, sc, t_stop, jam_sign, w0, atol)
        return rec

    @staticmethod
    def _scale_of(sc):
        """The scale the event functions' rounding errors are measured on."""
        return max(sc)

    def _save_eval(self, dense, t0, t1, modes):
        if self.t_eval is None:
            return
        te = self.t_eval
        while self.i_eval < te.size and te[self.i_eval] <= t1:
            if te[self.i_eval] >= t0:
                self.rec.point(te[self.i_eval], dense(te[self.i_eval]), modes)
            self.i_eval += 1

    def _first_event(self, dense, t0, t1, w0, w1, modes, rho, sc, jam=0.0):
        """``(t, index)`` of the earliest event function to reach zero in the step, or None.
        A gap or a slip velocity whose rate turns from negative to positive inside the
        step is checked at its minimum too (an impact, a reversal or a stop between the
        step's ends)."""
        from scipy.optimize import brentq

        n = self.n

        def at(t, i):
            if t <= t0:
                return w0[i]
            y = dense(t)
            return self.watch(y[:n], y[n:], modes, rho, sc, t, jam)[i]

        xtol = 4.0 * np.finfo(float).eps * max(abs(t0), abs(t1), 1e-300)
        best = None
        for i in np.flatnonzero((w0 >= 0.0) & (w1 < 0.0)):
            a = t0
            if w0[i] == 0.0:   # starts at zero (a gap just opened): the root after its rise
                for k in range(1, 60):
                    tm = t0 + (t1 - t0) * 0.5 ** k
                    if tm <= t0:
                        break
                    if at(tm, i) > 0.0:
                        a = tm
                        break
            r = brentq(lambda t: at(t, i), a, t1, xtol=xtol, rtol=4 * np.finfo(float).eps)
            r = self._onto_root(at, i, r, t1)
            if best is None or r < best[0]:
                best = (r, int(i))
        for c in range(self.k):
            j = flow._watched.py_func(modes, self.one_sided, c)
            if j < 0 or w1[j] < 0.0 or w0[j] <= 0.0:
                continue   # (a function that starts at zero has just left it: not a dip)

            def rate(t):
                y = dense(t)
                return self.dip_rate(y[:n], y[n:], c, modes, rho, t)
            if rate(t0) < 0.0 < rate(t1):
                tm = brentq(rate, t0, t1, xtol=xtol)
                if at(tm, j) < 0.0:
                    r = brentq(lambda t: at(t, j), t0, tm, xtol=xtol)
                    r = self._onto_root(at, j, r, tm)
                    if best is None or r < best[0]:
                        best = (r, j)
        return best

    @staticmethod
    def _onto_root(at, i, r, t1):
        """The root ``r`` moved, by ulps, to where the function is no longer positive."""
        for _ in range(64):
            if at(r, i) <= 0.0 or r >= t1:
                return min(r, t1)
            r = np.nextafter(r, math.inf) if _ < 8 else r + (t1 - r) * 1e-12 * 2 ** (_ - 8)
        return r

    # -- events -----------------------------------------------------------------------------

    def _end(self, t, q, u, modes, fate, contact=-1, fixed=()):
        q, u = self.project(q, u, [c for c, m in enumerate(modes) if m != OPEN],
                            [c for c, m in enumerate(modes) if m == STICK], fixed, t=t)
        rec = self.rec
        y = np.concatenate([q, u])
        jumped = (bool(rec.ev_t) and rec.ev_t[-1] == t and rec.ev_kind[-1] in JUMPS
                  and not (rec.y and np.array_equal(rec.y[-1], y)))
        if self.t_eval is None and (not rec.t or rec.t[-1] != t or jumped):
            rec.point(t, y, modes)    # (after a jump: its state)
        rec.event(t, fate, contact, y, modes)
        rec.fate = fate

    def _event(self, t, q, u, modes, rho, i):
        """What follows the event ``i`` of the phase ``modes`` at ``(t, q, u)``."""
        if i == 2 * self.k + 2 * self.n + self.mech.n_domain:   # the phase's singularity
            return jam.at_singular(self, t, q, u, modes, rho, ev.SINGULAR)
        if i >= 2 * self.k:
            j = i - 2 * self.k
            fixed = ()
            if j < 2 * self.n:     # a coordinate's bound: exactly on it
                fixed = (j % self.n,)
                q = q.copy()
                q[j % self.n] = self.bounds[j % self.n, j // self.n]
            self._end(t, q, u, modes, ev.LEFT_DOMAIN, fixed=fixed)
            return None
        c, which = divmod(i, 2)
        closed = [d for d, m in enumerate(modes) if m != OPEN]
        if modes[c] == OPEN:            # a gap closes
            return landing.closing(self, t, q, u, modes, c)
        if which == 0:                  # a normal reaction reaches zero
            q, u = self.project(q, u, closed, t=t)
            # (a two-sided contact's reaction changes sign: its friction's sign flips)
            flip = () if self.one_sided[c] or rho[c] < 0.0 else (c,)
            return self._decide(t, q, u, modes, ev.LIFTOFF, c, {c: OPEN}, flip=flip)
        if modes[c] == STICK:           # a stuck contact reaches its friction limit
            F = self.solve(q, u, modes, rho, t)[2][c]
            q, u = self.project(q, u, closed, t=t)
            return self._decide(t, q, u, modes, ev.SLIP, c,
                                {c: SLIP_POS if F < 0.0 else SLIP_NEG})
        q, u = self.project(q, u, closed, held=(c,), t=t)   # a slip velocity reaches zero
        return self._decide(t, q, u, modes, ev.STICK, c, {c: STICK})

    def _decide(self, t, q, u, old, kind, contact, prefer, depth=0, flip=()):
        """The phase that follows at ``(t, q, u)``; records the event (``kind``, or the one
        the change of modes names where ``kind`` is -1) and returns ``(t, q, u, modes,
        rho)``, or None where the motion ends."""
        if depth < 4 and kind != QUIET:
            now = jam.sliding(self, q, u, t)
            # (a two-sided contact's reaction sign, which its friction follows, is the
            # phase's: its jam is met where the phase's step size collapses, at_singular)
            jump = jam.jam(self, t, q, u, now) if jam.signs_known(self, now) else None
            if jump is not None:     # at a slip's singular point: a dynamic jam first
                return self._decide(t, *jump, old, QUIET, -1, {}, depth + 1)
        groups = self.enumerate(q, u, prefer, t, flip)
        if len(groups) != 1:
            if not groups:
                return self._inconsistent(t, q, u, old, contact, depth)
            if self.o.painleve == "iwc":
                jump = self._iwc(t, q, u, old) if depth < 4 else None
                if jump is not None:
                    return self._decide(t, *jump, old, QUIET, -1, {}, depth + 1)
            if self.o.painleve == "liftoff":
                opens = [sum(m == OPEN for m in g[0][0]) for g in groups]
                best = [i for i, k in enumerate(opens) if k == max(opens)]
                if len(best) == 1:
                    groups = [groups[best[0]]]
            if len(groups) != 1:
                self._end(t, q, u, old, ev.INDETERMINATE, contact)
                return None
        if kind == ev.LIFTOFF and self.one_sided[contact] and tuple(
                groups[0][0][0]) == tuple(old) and not self._holds(
                q, u, groups[0][0], [contact], self.scales_at(q, u, t), t):
            # N reached zero on its way down and the contact cannot open either: the
            # accelerations have no solution just after (a Painleve inconsistency)
            return self._inconsistent(t, q, u, old, contact, depth)
        modes, (ud, N, F, a, rho) = groups[0][0]
        held = [c for c, m in enumerate(modes) if m == STICK]
        q, u = self.project(q, u, [c for c, m in enumerate(modes) if m != OPEN], held, t=t)
        y = np.concatenate([q, u])
        sc = self.scales_at(q, u, t)
        if (self.rests and np.abs(u).max() <= TOL * sc[0]
                and np.abs(ud).max() <= TOL * sc[2] / max(sc[3], 1.0)):
            if self.zeno_until > t:
                te = self.zeno_until
                self.rec.event(te, ev.ZENO, self.zeno_contact, y, modes)
                self.zeno_until = -math.inf
                t = te
            self._end(t, q, u, modes, ev.REST, contact)
            return None
        if kind == -1:
            kind = kind_of(old, modes, contact)
            if contact < 0:
                changed = [c for c in range(self.k) if (old[c] == OPEN) != (modes[c] == OPEN)]
                changed = changed or [c for c in range(self.k) if old[c] != modes[c]]
                contact = changed[0] if len(changed) == 1 else -1
        elif kind == ev.LIFTOFF and modes[contact] != OPEN:
            kind = ev.SWITCH
        elif kind == ev.STICK and modes[contact] != STICK:
            kind = ev.REVERSAL if modes[contact] != old[contact] else ev.SWITCH
        if kind >= 0:
            self.rec.event(t, kind, contact, y, modes)
        elif kind == QUIET and self.t_eval is None:   # the state just after a jump
            self.rec.point(t, y, modes)
        return t, q, u, modes, rho

    def _inconsistent(self, t, q, u, old, contact, depth):
        """No phase follows at ``(t, q, u)`` (a Painleve inconsistency): an impact without
        collision where one applies and the motion goes on from it, else ``no_solution``."""
        jump = self._iwc(t, q, u, old) if depth < 4 else None
        if jump is not None:
            return self._decide(t, *jump, old, QUIET, -1, {}, depth + 1)
        self._end(t, q, u, old, ev.NO_SOLUTION, contact)
        return None

    def _iwc(self, t, q, u, modes):
        """An impact without collision at the one closed contact that slips into the
        obstacle: the state after it, or None."""
        M, h, g, J, b, mu = self.mech.pieces(q, u, self.p, t)
        sc = self.scales(q, u, (M, h, g, J, b, mu))
        v = self.relative(J, u, t)
        mu = self.mech.kinetic(q, u, self.p, t, np.abs(v[:, 1]), mu)
        touching = [c for c in range(self.k) if self.one_sided[c] and g[c] <= TOL * sc[3]
                    and abs(v[c, 0]) <= TOL * sc[0]]
        jumps = []
        for c in touching:
            if abs(v[c, 1]) <= TOL * sc[0] or len(touching) != 1:
                continue
            try:
                after, r = tangential_impact(M, J[c, :2], u, float(mu[c]),
                                              None if self.mech.plain else v[c, 1],
                                              J[c, 2] if self.rolls[c] else None)
            except ValueError:
                continue
            if r.P_n <= 0.0:
                continue
            jumps.append((c, after, r))
        if len(jumps) != 1:
            return None
        c, after, r = jumps[0]
        self.rec.event(t, ev.IWC, c, np.concatenate([q, u]), modes, (r.P_n, r.P_t, r.dKE))
        return self.project(q, after, [c], t=t)


def warm():
    """Compiles the compiled flow's kernels (:mod:`.flow`) into the kernel cache: a
    background compile's job (:mod:`phasemap.core.tiers`), a flight of the Painleve rod
    that lands and slides (the step's event exit included), then a segment of known
    length, the reactions of a Dataset, the Jacobian, a map's cells, a segment's kept
    steps and a batch of its conditions, and the transition matrix of the periodic
    orbits (compiled last: binding.Phase probes it)."""
    from phasemap.core import tiers
    from phasemap.declare.full import mechanics
    from phasemap.systems.painleve_rod import SYSTEM

    mech = mechanics(SYSTEM)
    p = [mech.defaults[name] for name in mech.parameters]
    with tiers.forced("eager"):
        m = Motion(mech, p, Options(t_end=0.5))
        m.run([0.7, 0.0, 0.3], [0.0, 0.5, 0.0])
        m.flow.segment(np.array([0.7, 0.0, 0.3, 0.0, 0.5, 0.0]), 0.0, 0.1, (OPEN,), None,
                       1e-8, 1e-8)
        X = np.array([0.7, 0.0, 0.3, 0.0, 0.5, 0.0, 0.0])
        m.flow.jacobian(X, (OPEN,), None, 1e-6)
        m.flow.reactions(np.zeros(1), X[None, :6], np.zeros((1, 1), dtype=np.int64))
        m.flow.cells(np.array([p]), X[None, :6], np.zeros(1), [0], True)
        # a periodic orbit's checks: a segment's kept steps and its conditions in one call
        m.flow.steps(X[:6], 0.0, 0.1, (OPEN,), None, 1e-8, 1e-8).at([0.05])
        m.watch_many(np.zeros(1), X[None, :6], (OPEN,), None, m.scales_at(X[:3], X[3:6]))
        m.project_velocities(X[None, :3], X[None, 3:6], np.zeros(1), [0])
        m.flow.transition(X, 0.01, (OPEN,), None, 1e-8, 1e-8, 1e-6)
