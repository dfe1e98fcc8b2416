"""The names of the sliding bifurcations of a periodic orbit: what a change of its mode
sequence is, read from the two sequences and the durations of their segments (see
:func:`phasemap.continue_orbit`).

At a sliding bifurcation (di Bernardo, Kowalczyk and Nordmark 2002; Kowalczyk and
Piiroinen 2008, for a dry-friction oscillator) segments of zero length appear in the
orbit, or shrink into it.  The orbit with more segments has them short, the other has
none, and what they are, between which neighbours, names the bifurcation.  With the
contact whose mode changes, ``slip_a`` and ``slip_b`` slips the two ways:

* ``crossing_sliding``: a stick between opposite slips (a reversal, the crossing of the
  surface of zero relative velocity, reaches the edge of the sticking region);
* ``grazing_sliding``: a stick inside a slip (``slip_a, stick, slip_a``: the slip grazes
  zero relative velocity at the edge of the sticking region);
* ``adding_sliding``: a slip and a stick after a stick (``stick, slip_a, stick``: the
  motion leaves the sticking region tangentially and comes back to it at once);
* ``switching_sliding``: a slip the other way between a stick and a slip
  (``stick, slip_b, slip_a``: the motion leaving the sticking region crosses zero
  relative velocity at once).

A run of segments counts as short where it lasts less than the geometric mean of the
shortest run and the period: near a bifurcation the new segments last a power of the
distance to it (its square root at a grazing), the others a finite time, so the mean
lies between them.  The short runs removed, the sequence must be the other one;
otherwise, or where more than one contact changes its mode, the change is a
``sequence_change``.
"""

from __future__ import annotations

import math

import numpy as np

from phasemap.motion.hybrid import SLIP_NEG, SLIP_POS, STICK


def kind(old, old_tau, new, new_tau) -> str:
    """The name of the change from the segments ``old`` (durations ``old_tau``) to
    ``new`` (``new_tau``): one of the module's kinds, or ``sequence_change``."""
    a, b = _runs(old, old_tau), _runs(new, new_tau)
    changing = {c for runs in (a, b) for c in range(len(runs[0][0]))
                if len({m[c] for m, _ in runs}) > 1}
    if len(a) == len(b) or len(changing) != 1:
        return "sequence_change"
    c = changing.pop()
    more, fewer = (b, a) if len(b) > len(a) else (a, b)
    more = merged([(m[c], d) for m, d in more])
    fewer = merged([(m[c], d) for m, d in fewer])
    if len(more) <= len(fewer):
        return "sequence_change"
    period = sum(d for _, d in more)
    floor = min(d for _, d in more)
    short = [d < math.sqrt(max(floor, 0.0) * period) for _, d in more]
    kept = merged([r for r, s in zip(more, short) if not s])
    if not any(short) or all(short) or not _cyclic_equal([m for m, _ in kept],
                                                          [m for m, _ in fewer]):
        return "sequence_change"
    names = {_name(more, short, i) for i in _starts(short)}
    return names.pop() if len(names) == 1 else "sequence_change"


def _runs(segs, taus):
    """The segments' contact modes and durations, neighbours of the same modes merged
    (cyclically: a forced orbit's period may end inside a phase)."""
    return merged([(tuple(s.modes), float(t)) for s, t in zip(segs, np.asarray(taus))])


def merged(runs):
    """``(modes, duration)`` runs with neighbours of the same modes merged, cyclically
    (the last into the first), their durations summed."""
    out = []
    for m, d in runs:
        if out and out[-1][0] == m:
            out[-1] = (m, out[-1][1] + d)
        else:
            out.append((m, d))
    if len(out) > 1 and out[0][0] == out[-1][0]:
        out[0] = (out[0][0], out[0][1] + out.pop()[1])
    return out


def _cyclic_equal(x, y) -> bool:
    return len(x) == len(y) and any(x[r:] + x[:r] == y for r in range(len(x)))


def _starts(short):
    """The first index of each cyclic run of short segments."""
    n = len(short)
    return [i for i in range(n) if short[i] and not short[i - 1]]


def _name(more, short, i) -> str:
    """The name of the run of short segments that starts at ``i``, from its modes and its
    neighbours'."""
    n = len(more)
    run = []
    j = i
    while short[j % n] and len(run) < n:
        run.append(more[j % n][0])
        j += 1
    before, after = more[(i - 1) % n][0], more[j % n][0]
    slips = (SLIP_POS, SLIP_NEG)
    if run == [STICK] and before in slips and after in slips:
        return "crossing_sliding" if before != after else "grazing_sliding"
    if run == [after, STICK] and before == STICK and after in slips:
        return "adding_sliding"
    if len(run) == 1 and run[0] in slips and before == STICK and after in slips \
            and after != run[0]:
        return "switching_sliding"
    return "sequence_change"
