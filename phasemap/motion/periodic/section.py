"""Poincare sections: how an autonomous orbit that meets no event is cut into one
segment, the motion's returns to a hyperplane read off its saved steps (see
:func:`phasemap.periodic_orbit`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Section(NamedTuple):
    """The hyperplane through ``point`` normal to the unit vector ``normal`` (in the state
    ``(q, u)``), crossed in the direction of ``normal``."""

    point: np.ndarray
    normal: np.ndarray


def unit(d):
    """``d`` scaled to unit length."""
    return np.asarray(d, dtype=float) / float(np.linalg.norm(d))


def returns(rec, ref, normal):
    """The motion's crossings of the hyperplane through ``ref`` normal to ``normal``, in
    the direction of ``normal``: ``(t, state)`` each, on the cubic through the four saved
    steps around the crossing (the time its root between the two that bracket it; about
    1e-5 of the state's scale at the integrator's steps, against 1e-4 by straight
    lines, which took a cycle of twice the period for the period)."""
    from scipy.optimize import brentq

    ts, ys = np.array(rec.t), np.array(rec.y)
    s = (ys - ref) @ normal
    out = []
    for i in np.flatnonzero((s[:-1] < 0.0) & (s[1:] >= 0.0)) + 1:
        j = min(max(int(i) - 2, 0), len(ts) - 4)
        nodes = ts[j:j + 4]

        def at(t, vals, nodes=nodes):
            return sum(vals[a] * np.prod([(t - nodes[b]) / (nodes[a] - nodes[b])
                                          for b in range(4) if b != a]) for a in range(4))
        if s[i] == 0.0:
            t = float(ts[i])
        else:
            t = brentq(lambda t: at(t, s[j:j + 4]), ts[i - 1], ts[i], xtol=1e-15)
        out.append((float(t), np.asarray(at(t, ys[j:j + 4]), dtype=float)))
    return out


def section_cycle(name, rec, scale, settled):
    """``(t_a, t_b, state)`` of a motion that meets no event: its last return to the
    hyperplane through its end (normal to its direction there) that comes back to the
    end's state, the end, and the end's state (the motion's own, not interpolated: an
    autonomous orbit may start anywhere on it, and one of a continuum is the orbit
    through that state).  A return counts where it misses the end's state by at most
    ``settled`` of the state's scale and of the cycle's own extent, so that a motion
    spiralling into an equilibrium, whose returns are all near it, is no cycle."""
    ys, ts = np.array(rec.y), np.array(rec.t)
    if len(ys) >= 5 and np.any(ys[-1] != ys[-2]):
        ref, normal = ys[-1], unit(ys[-1] - ys[-2])
        for t, z in reversed(returns(rec, ref, normal)[:-1]):
            cycle = ys[ts >= t]
            extent = float(np.max(cycle.max(axis=0) - cycle.min(axis=0)))
            if np.max(np.abs(z - ref)) <= settled * min(scale, extent):
                return t, float(ts[-1]), ref
    raise ValueError(f"{name}: the motion meets no event and does not come back to a state "
                     "it was in within settle= (it may be approaching a rest or an "
                     "equilibrium): give a longer settle or a start nearer an orbit")
