"""The contact modes of a phase in full coordinates, the tolerances of their tests, and the
linear system of a phase's reactions (see :mod:`phasemap.motion.hybrid`)."""

from __future__ import annotations

import numpy as np

from phasemap.core import events as ev

OPEN, SMOOTH, STICK, SLIP_POS, SLIP_NEG = 0, 1, 2, 3, 4
MODE_NAMES = ("open", "smooth", "stick", "slip_pos", "slip_neg")
#: Relative tolerance of the mode tests (GUIDE section 1: 1e-12 of a quantity's scale
#: for ties; the integrated state carries the step's error, so 1e-9 here).
TOL = 1e-9
#: The determinant of a slip phase's normalised reaction matrix (:meth:`Motion.singularity`)
#: at and below which the phase is at its singular point, where its normal force grows
#: without bound: the reduced integrator's threshold for ``singular`` (the coefficient of
#: the senior derivative below 1e-6 of its scale).
JAM_TOL = 1e-6
#: The kind ``Motion._decide`` takes after an event already recorded (an impact, a jam).
QUIET = -2


def slipping(modes) -> bool:
    """Whether a contact slips in the phase ``modes`` (only a slip can make its reaction
    matrix singular)."""
    return any(m in (SLIP_POS, SLIP_NEG) for m in modes)


def system(modes, rho, J, b, mu, sd=None, rolls=()):
    """The linear system of a phase's reactions: ``(cols, rows, rhs, owner)``, a column
    (the reaction's direction in the coordinates) and a row (the held acceleration) per
    closed contact's normal, per stuck contact's friction channel (its tangent; a rolling
    disc's spin) and per closed rolling disc's tangent (it rolls without slip), the held
    accelerations' right sides, and which ``(contact, 0 normal | 1 friction | 2 held)``
    each is.  ``rho``: the sign of N each contact's friction assumes (None: +1); ``sd``:
    the surfaces' tangential accelerations (None: still); ``rolls``: which contacts are
    rolling discs (none where empty)."""
    cols, rows, rhs, owner = [], [], [], []
    for c, m in enumerate(modes):
        if m == OPEN:
            continue
        r = 1.0 if rho is None else rho[c]
        s = 1.0 if m == SLIP_POS else (-1.0 if m == SLIP_NEG else 0.0)
        cols.append(J[c, 0] - s * r * mu[c] * J[c, 1])
        rows.append(J[c, 0])
        rhs.append(-b[c, 0])
        owner.append((c, 0))
        if len(rolls) and rolls[c]:
            cols.append(J[c, 2])
            rows.append(J[c, 2])
            rhs.append(-b[c, 2])
            owner.append((c, 2))
        if m == STICK:
            cols.append(J[c, 1])
            rows.append(J[c, 1])
            rhs.append(-b[c, 1] if sd is None else sd[c] - b[c, 1])
            owner.append((c, 1))
    return cols, rows, rhs, owner


def normalised_det(A, R, G, X, M):
    """det A of a phase's reaction matrix ``A = R M^-1 G`` (``X = M^-1 G``), its rows and
    columns scaled to unit length in the inverse mass metric (so in [-1, 1])."""
    dr = np.sqrt(np.maximum((R * np.linalg.solve(M, R.T).T).sum(axis=1), 1e-300))
    dc = np.sqrt(np.maximum((G * X).sum(axis=0), 1e-300))
    return float(np.linalg.det(A / dr[:, None] / dc[None, :]))


def kind_of(old, new, contact):
    """The event a change of contact modes from ``old`` to ``new`` is."""
    if contact >= 0:
        a, b = old[contact], new[contact]
        if a != OPEN and b == OPEN:
            return ev.LIFTOFF
        if a == OPEN and b != OPEN:
            return ev.RECONTACT
    for a, b in zip(old, new):
        if a != OPEN and b == OPEN:
            return ev.LIFTOFF
    for a, b in zip(old, new):
        if a == OPEN and b != OPEN:
            return ev.RECONTACT
    for a, b in zip(old, new):
        if a in (SLIP_POS, SLIP_NEG) and b == STICK:
            return ev.STICK
        if a == STICK and b in (SLIP_POS, SLIP_NEG):
            return ev.SLIP
        if {a, b} == {SLIP_POS, SLIP_NEG}:
            return ev.REVERSAL
    return ev.SWITCH if tuple(old) != tuple(new) else -1


