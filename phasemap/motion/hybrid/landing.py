"""Where an open contact's gap reaches zero: an impact (one contact by the law chosen,
several at once or a rolling disc by Moreau's impulse-level solution), or a contact
without one; and where the impacts of a bouncing contact accumulate (Zeno).  Each
function takes the :class:`phasemap.motion.hybrid.Motion` as ``self`` (see
:mod:`phasemap.motion.hybrid`)."""

from __future__ import annotations

import math

import numpy as np

from phasemap.core import events as ev
from phasemap.motion.hybrid.phases import OPEN, QUIET, TOL
from phasemap.motion.impact import delassus, impact, simultaneous, zeno_time


def closing(self, t, q, u, modes, c):
    """An open contact's gap reached zero: an impact, or a contact without one."""
    closed = [d for d, m in enumerate(modes) if m != OPEN]
    q, u = self.project(q, u, closed + [c], moving=closed, t=t)
    M, h, g, J, b, mu = self.mech.pieces(q, u, self.p, t)
    v = self.relative(J, u, t)
    mu = self.mech.kinetic(q, u, self.p, t, np.abs(v[:, 1]), mu)
    sc = self.scales(q, u, (M, h, g, J, b, mu))
    y = np.concatenate([q, u])
    if v[c, 0] >= -TOL * sc[0]:    # touching without approaching: no impulse
        q, u = self.project(q, u, closed + [c], t=t)
        return self._decide(t, q, u, modes, ev.RECONTACT, c, {})
    o = self.o
    if not closed and not self.rolls[c]:
        r = impact(delassus(M, J[c, :2]), v[c, :2], mu=float(mu[c]), e=o.restitution, law=o.impact_law)
        Pc = np.array([r.P_n, r.P_t])
        u = u + np.linalg.solve(M, J[c, :2].T @ Pc)
        self.rec.event(t, ev.IMPACT, c, y, modes, (r.P_n, r.P_t, r.dKE))
        if r.v_n > TOL * sc[0]:     # a rebound
            a_n = self.solve(q, u, modes, None, t)[3][c, 0]
            if a_n < 0.0 and r.v_n < o.zeno_speed and o.restitution < 1.0:
                self.zeno_until = zeno_time(t, r.v_n, a_n, o.restitution)
                self.zeno_contact = c
                q, u = self.project(q, u, [c], t=t)
            return self._decide(t, q, u, modes, QUIET, c, {})
        q, u = self.project(q, u, [c], t=t)
        return self._decide(t, q, u, modes, QUIET, c, {})
    K = closed + [c]
    rolling = [i for i, d in enumerate(K) if self.rolls[d]]   # (rows: no slip after)
    JK = np.concatenate([J[d, :2] for d in K] + [J[K[i], 2:] for i in rolling])
    W = delassus(M, JK)
    v0 = np.concatenate([v[d, :2] for d in K] + [v[K[i], 2:] for i in rolling])
    P0 = np.zeros(v0.size)
    if rolling:
        # a rolling disc is perfectly rough (Routh): its slip stops at once, by a
        # tangential impulse with no normal one (the limit mu -> oo of the frictional
        # impact), before the normal impact
        H = np.arange(2 * len(K), v0.size)
        P0[H] = -np.linalg.solve(W[np.ix_(H, H)], v0[H])
    v1 = v0 + W @ P0
    j = 2 * K.index(c)
    # Moreau's generalised Newton law on what the slip's stop left (where that alone
    # turned the landing contact away, it stays open): the landing contact rebounds with
    # e times its approach; the closed ones (v_n = 0 before) take impulses and stay
    sols = simultaneous(W, v1, mu[K], e=o.restitution, held=rolling, delassus_made=True)
    if len(sols) != 1:
        self._end(t, q, u, modes, ev.INDETERMINATE if sols else ev.NO_SOLUTION, c)
        return None
    s = sols[0]
    P = P0 + s.P
    u = u + np.linalg.solve(M, JK.T @ P)
    dKE = float(P @ v0 + 0.5 * P @ W @ P)
    tang = P[j + 1] if not self.rolls[c] else P[2 * len(K) + rolling.index(K.index(c))]
    self.rec.event(t, ev.IMPACT, c, y, modes, (P[j], tang, dKE))
    rebound = s.v[j] > TOL * sc[0]
    now = [d for d, mode in zip(K, s.modes) if mode != "open" and not (d == c and rebound)]
    q, u = self.project(q, u, now, t=t)
    if rebound and 0.0 < o.restitution < 1.0 and s.v[j] < o.zeno_speed:
        free = self.solve(q, u, [m if d in now else OPEN for d, m in enumerate(modes)],
                          None, t)
        if free is not None and free[3][c, 0] < 0.0:
            # it bounces on the contacts that hold: the impacts accumulate
            self.zeno_until = zeno_time(t, s.v[j], free[3][c, 0], o.restitution)
            self.zeno_contact = c
    return self._decide(t, q, u, modes, QUIET, c, {})


def zeno(self, t, q, u, modes):
    """The impacts accumulate at ``t``: the contact is closed, a ``zeno`` event."""
    c = self.zeno_contact
    closed = [d for d, m in enumerate(modes) if m != OPEN]
    q, u = self.project(q, u, sorted(set(closed) | {c}), t=t)
    self.rec.event(t, ev.ZENO, c, np.concatenate([q, u]), modes)
    self.zeno_until = -math.inf
    return self._decide(t, q, u, modes, QUIET, c, {})
