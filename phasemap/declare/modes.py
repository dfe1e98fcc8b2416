"""The candidate branches of a declared system: combinations of its contacts' modes."""

from __future__ import annotations

import enum
import itertools
from dataclasses import dataclass

import numpy as np

from phasemap.declare.law import SEPARATED, STICK, STICKING, Mode
from phasemap.declare.validation import fail


class Presence(enum.IntEnum):
    """Where a candidate branch applies (its row passes the number to its function)."""

    #: while moving in the branch's direction, and from rest
    ALWAYS = 0
    #: only at rest (a contact sticks)
    AT_REST = 1
    #: only while moving: the second copy of a row that needs no slip direction
    MOVING = 2


@dataclass(frozen=True)
class Candidate:
    """One candidate branch: its generated name, direction, presence and mode per contact."""

    name: str
    direction: float
    presence: Presence
    modes: tuple[Mode, ...]
    #: the index of the :class:`phasemap.declare.edges.Edge` it exists on (None: everywhere)
    edge: int | None = None

    @property
    def kinds(self) -> tuple[str, ...]:
        return tuple(m.kind for m in self.modes)

    @property
    def key(self) -> tuple:
        """What one generated function solves: the mode kinds, and the edge."""
        return (self.kinds, self.edge)

    def args(self) -> list[float]:
        """The constants the row passes first to its function (presence, then per-contact
        slip sign, N sign and root)."""
        return [float(self.presence)] + [a for m in self.modes for a in m.args]


def slip_velocity(eqs):
    """The one state velocity every contact slips with, each contact's sign of it, and its
    slip factor: contact c slips with ``k_c(q) v`` (``k_c`` of the sign ``kappa_c`` over the
    domain, zero at most on its edges, :mod:`phasemap.declare.edges`).

    The sign is read at sample points of the declared domain that pass the
    declaration's ``check``; a factor that vanishes at a point counts with the
    sign it has elsewhere.
    """
    import sympy as sp

    S = eqs.S
    velocity, kappa, factors = None, {}, {}
    for c in S.contacts:
        v = sp.expand(eqs.channels[c.name][c.slip_channel][2])
        involved = []
        for r in eqs.rates:
            k = sp.diff(v, r)
            if k != 0 and np.max(np.abs(eqs.numeric(k, 8))) > 1e-12:
                involved.append((r, k))
        if len(involved) != 1:
            fail(S, f"contact {c.name!r}", f"its slip velocity {v} involves "
                 f"{len(involved)} rates; phasemap needs every contact to slip with one "
                 "state velocity (a multiple of one rate)")
        r, k = involved[0]
        if velocity is not None and r != velocity:
            fail(S, f"contact {c.name!r}", f"slips with {r}, another contact with "
                 f"{velocity}: contacts that slip with different state velocities are "
                 "not supported yet")
        velocity = r
        vals = eqs.numeric(k, 24)
        big = vals[np.abs(vals) > 1e-9 * max(1.0, float(np.max(np.abs(vals))))]
        if np.all(big > 0):
            kappa[c.name] = 1
        elif np.all(big < 0):
            kappa[c.name] = -1
        else:
            on = sorted(str(x) for x in k.free_symbols if not str(x).startswith("_k_"))
            fail(S, f"contact {c.name!r}", f"its slip velocity {v} changes sign against "
                 f"{r} inside the domain (the factor {k} depends on "
                 f"{', '.join(on) or 'nothing'}): restrict the domain of "
                 + ("those parameters and coordinates" if on else "the coordinates")
                 + " (their bounds, which may be parameters or expressions, or check=)")
        factors[c.name] = k
    return velocity, kappa, factors


def candidates(S, kappa: dict) -> list[Candidate]:
    """Every candidate branch; the first row with direction 0 is the stick branch.

    Every contact slips with the same state velocity v (contact i with
    v_i = k_i(q) v, sgn k_i = kappa_i; :func:`slip_velocity` checks it).  While
    every contact stays closed, v_i = k_i v holds along the motion, so at v = 0
    each tangential acceleration is k_i v': one contact sticking (k_i v' = 0)
    stops all of them, and slips starting in directions of different
    s_i kappa_i ask v' for two signs at once.  Such rows can never be
    admissible inside the domain and are not generated.  At a bound where
    some k_i = 0 (the ladder lying flat, phi = pi/2) that contact cannot
    start to slip either, so a slide from rest is not admissible there: the
    hand ladder keeps the limit from inside instead, and the two differ on
    that edge (683 cells of a 2048^2 rest map, BENCHMARKS.md).  A row with a
    separated contact has more freedom and is kept.
    """
    combos = list(itertools.product(*(c.modes() for c in S.contacts)))
    stick_all = tuple(STICKING for _ in S.contacts)
    rows = []
    for combo in [stick_all] + [c for c in combos if c != stick_all]:
        name = "stick" if combo == stick_all else "_".join(
            c.token(m) for c, m in zip(S.contacts, combo))
        kept = [(c, m) for c, m in zip(S.contacts, combo) if m.kind != SEPARATED]
        signs = {m.slip * kappa[c.name] for c, m in kept if m.kind != STICK}
        n_stick = sum(m.kind == STICK for _, m in kept)
        if len(kept) == len(combo) and (len(signs) > 1 or 0 < n_stick < len(kept)):
            continue  # kinematically impossible (see above)
        if n_stick:
            rows.append(Candidate(name, 0.0, Presence.AT_REST, combo))
        elif not signs:  # every contact separated: any direction
            rows.append(Candidate(name, 1.0, Presence.ALWAYS, combo))
            rows.append(Candidate(name + "_moving_neg", -1.0, Presence.MOVING, combo))
        elif len(signs) == 1:
            rows.append(Candidate(name, float(signs.pop()), Presence.ALWAYS, combo))
        else:
            rows.append(Candidate(name, 0.0, Presence.AT_REST, combo))
    return rows
