"""Dynamic jam: a slip phase that reaches its singular point, where the normal force grows
without bound but its impulse stays bounded (Genot and Brogliato 1999; Or and Rimon
2012; GUIDE section 8).  The impulse at zero normal velocity that stops the slip is
applied there, and a ``jam`` event recorded.  Each function takes the
:class:`phasemap.motion.hybrid.Motion` as ``self``."""

from __future__ import annotations

import math

import numpy as np

from phasemap.core import events as ev
from phasemap.motion.hybrid.phases import (JAM_TOL, OPEN, QUIET, SLIP_NEG, SLIP_POS, SMOOTH,
                                           STICK, TOL, normalised_det, slipping, system)


def sign(self, q, u, modes, rho, t):
    """The sign of the phase's :meth:`Motion.singularity` at its start: the factor that makes
    its event function positive (0, not watched, for a phase without a slip, or one
    already at its singular point)."""
    if not slipping(modes):
        return 0.0
    det = self.singularity(q, u, modes, rho, t)
    return 0.0 if abs(det) <= JAM_TOL else math.copysign(1.0, det)


def sliding(self, q, u, t):
    """The modes of a state's touching contacts as they move now (a contact that
    slips: that slip; one at relative rest: stick; the others open).  A two-sided
    contact's friction also depends on its reaction's sign, which the state does not
    tell: see :func:`signs_known`."""
    P = self.mech.pieces(q, u, self.p, t)
    sc = self.scales(q, u, P)
    g, J, mu = P[2], P[3], P[5]
    v = self.relative(J, u, t)
    modes = []
    for c in range(self.k):
        touching = g[c] <= TOL * sc[3] and abs(v[c, 0]) <= TOL * sc[0]
        if not touching and self.one_sided[c]:     # (a two-sided contact never opens)
            modes.append(OPEN)
        elif mu[c] == 0.0:
            modes.append(SMOOTH)
        elif abs(v[c, 1]) > TOL * sc[0]:
            modes.append(SLIP_POS if v[c, 1] > 0.0 else SLIP_NEG)
        else:
            modes.append(STICK)
    return tuple(modes)


def signs_known(self, modes) -> bool:
    """Whether the phase ``modes`` fixes its friction forces' senses without the reactions'
    signs: no closed contact is two-sided (``rho`` +1 throughout)."""
    return all(self.one_sided[c] for c, m in enumerate(modes) if m != OPEN)


def at_singular(self, t, q, u, modes, rho, fate):
    """The phase ``modes`` stopped at ``(t, q, u)`` (its singularity reached zero, or
    the step size collapsed): a dynamic jam where it is one; else the motion ends,
    with ``singular`` where the phase is at its singular point, or ``fate``."""
    jump = jam(self, t, q, u, modes, rho, past=fate == ev.SINGULAR)
    if jump is not None:
        return self._decide(t, *jump, modes, QUIET, -1, {})
    if slipping(modes) and abs(
            self.singularity(q, u, modes, rho, t)) <= JAM_TOL:
        fate = ev.SINGULAR
    self._end(t, q, u, modes, fate)
    return None


def jam(self, t, q, u, modes, rho=None, past=False):
    """The state after a dynamic jam of the phase ``modes`` at ``(t, q, u)``, or None
    where it is not at one.  ``rho``: the sign of N each contact's friction assumes in
    the phase (None: +1, pressing; a two-sided contact's may be -1, pulling).

    A slip phase is at its singular point where its reaction matrix ``A`` (the held
    accelerations against the reactions: the phase's :meth:`Motion.singularity` within
    :data:`JAM_TOL` of zero) has a null vector ``lam``: reactions along ``lam`` move no
    held acceleration, so on the way the normal forces grow without bound along it
    while the normal velocities stay zero.  Their impulse is what stops the slip
    (Genot and Brogliato 1999; Or and Rimon 2012): the impulse ``p lam`` with ``p``
    the least that brings a slipping contact to relative rest.  For one contact,
    ``P_n = -v_t / (W_tn - s rho mu W_tt)`` and ``P_t = -s rho mu P_n`` (with ``B =
    W_nn - s rho mu W_nt = 0``, the normal velocity does not change): the friction
    opposes the slip whichever way a two-sided contact's reaction acts.  None also
    where the normal forces before the jam do not act in the phase's sense ``rho``
    (the phase was not the motion), or the impulse would act against it at a contact
    or stop no slip.  ``past``: the state is just past
    the singular point (its determinant rooted), where the forces' sign has flipped.
    Records the ``jam`` event."""
    if modes is None or not slipping(modes):
        return None
    M, h, g, J, b, mu = self.mech.pieces(q, u, self.p, t)
    v = self.relative(J, u, t)
    if not self.mech.plain:
        mu = self.mech.kinetic(q, u, self.p, t, np.abs(v[:, 1]), mu)
    r = np.ones(len(modes)) if rho is None else np.asarray(rho, dtype=float)
    cols, rows, rhs, owner = system(modes, r, J, b, mu, None, self.rolls)
    G, R = np.array(cols).T, np.array(rows)
    X = np.linalg.solve(M, G)
    if abs(normalised_det(R @ X, R, G, X, M)) > JAM_TOL:
        return None
    # the null vector of A = R X, in the scaled reactions (columns of unit length)
    dc = 1.0 / np.sqrt(np.maximum((G * X).sum(axis=0), 1e-300))
    lam = np.linalg.svd((R @ X) * dc)[2][-1] * dc
    normals = np.array([j == 0 for c, j in owner])
    # the normal impulses in the phase's sense (rho N >= 0 at every contact)
    sense = np.array([r[c] for c, j in owner if j == 0])
    if (sense * lam[normals]).sum() < 0.0:
        lam = -lam
    if (sense * lam[normals]).min() < -1e-9 * np.abs(lam).max():
        return None
    # the reactions grow without bound along +lam only where the phase's normal forces,
    # on this side of the singular point (``past``: on the far side, just crossed), act in
    # its sense: where they do not, a one-sided contact opens (a two-sided one's friction
    # turns) first, and the phase was not the motion
    sol = self.solve(q, u, modes, r, t)
    if sol is None:
        return None
    pressing = sense * sol[1][[c for c, j in owner if j == 0]] * (-1.0 if past else 1.0)
    weights = sense * lam[normals] / np.abs(lam[normals]).max()
    if np.any(pressing[weights > 1e-6] < 0.0):
        return None
    du = X @ lam
    p, stop = math.inf, -1
    for c, m in enumerate(modes):
        if m in (SLIP_POS, SLIP_NEG):
            rate = float(J[c, 1] @ du)
            if rate * v[c, 1] < 0.0 and -v[c, 1] / rate < p:
                p, stop = -v[c, 1] / rate, c
    if stop < 0:
        return None
    u1 = u + p * du
    Pn = p * lam[owner.index((stop, 0))]
    s = 1.0 if modes[stop] == SLIP_POS else -1.0
    # the tangential impulse: the friction's, or a rolling disc's force along the surface
    Pt = p * lam[owner.index((stop, 2))] if self.rolls[stop] \
        else -s * r[stop] * mu[stop] * Pn
    dKE = 0.5 * float(u1 @ M @ u1 - u @ M @ u)
    self.rec.event(t, ev.JAM, stop, np.concatenate([q, u]), modes, (Pn, Pt, dKE))
    held = [c for c, m in enumerate(modes) if m == STICK] + [stop]
    return self.project(q, u1, [c for c, m in enumerate(modes) if m != OPEN], held, t=t)
