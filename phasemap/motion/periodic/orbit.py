"""Periodic orbits of a declared system on its exact hybrid flow: the motion settled on a
cycle, its mode sequence read from the events, the orbit solved by multiple shooting and
its Floquet multipliers (see :mod:`phasemap.motion.periodic`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from phasemap.core import args as _args
from phasemap.core import events as ev
from phasemap.motion.hybrid import MODE_NAMES, OPEN, Motion, Options, Record, dataset
from phasemap.motion.hybrid.results import start_values
from phasemap.motion.periodic import floquet as fq
from phasemap.motion.periodic import segments
from phasemap.motion.periodic.section import Section, returns, section_cycle, unit

#: Events across which the state jumps by an impulse: not in the orbits solved here yet.
IMPULSIVE = (ev.IMPACT, ev.IWC, ev.ZENO, ev.JAM)
#: The longest period, in forcing periods, searched for in a forced system's settled motion.
MAX_MULTIPLE = 16
#: How near (relative to the state's scale) a settled motion returns to a state to count
#: as a cycle: the shooting's first guess, which Newton's method then solves.
SETTLED = 1e-4
#: ``segment_end`` of a segment ended by a Poincare section (an orbit that meets no event)
#: and of one ended by the forcing period.
SECTION_END, PERIOD_END = -2, -1
#: How near 1 (absolutely) a nontrivial Floquet multiplier (an autonomous orbit's, of its
#: Poincare map) must be for the orbit to count as one of a continuum.
CONTINUUM = 1e-6


@dataclass
class Segment:
    """One phase of the orbit: its contact modes, the sign of N each two-sided contact's
    friction assumes, and the event function that ends it (None: the end of the period,
    in a forced system, or the Poincare ``section`` of an autonomous orbit that meets no
    event)."""

    modes: tuple
    rho: np.ndarray
    index: int | None
    kind: int
    section: Section | None = None

    @property
    def ended(self) -> bool:
        """Whether a condition (an event function or the section) ends the segment, so
        that the shooting has an equation for it."""
        return self.index is not None or self.section is not None


class Linearised(NamedTuple):
    """The Floquet multipliers of an orbit (largest first), the index of the trivial one
    (-1: none, a forced orbit), whether every other lies inside the unit circle, the
    orbit sampled into a Record, and whether it is one of a continuum (a nontrivial
    multiplier of its return map at 1, :data:`CONTINUUM`)."""

    multipliers: np.ndarray
    trivial: int
    stable: bool
    record: Record
    continuum: bool


def system_of(model):
    """The declaration of ``model``: a friction oscillator's name, a System, or a model
    that has a declaration."""
    from phasemap.declare.system import System
    from phasemap.systems import OSCILLATORS, get_model

    if isinstance(model, System):
        return model
    if isinstance(model, str) and model in OSCILLATORS:
        from phasemap.systems.oscillators import OSCILLATORS as systems

        return systems[model]
    m = get_model(model)
    S = getattr(m, "declaration", None)
    if S is None:
        raise ValueError(f"{m.name}: periodic orbits run on a declared system's motion in "
                         "full coordinates; this model is written by hand (use its declared "
                         "twin in phasemap.systems.seeds)")
    return getattr(S, "system", S)


def periodic_orbit(model, start=None, period=None, *, settle=None, rtol=1e-12, tol=1e-10,
                   samples=400, max_iter=50):
    """The periodic orbit the motion from ``start`` settles on, solved on the exact hybrid
    flow.

    The motion (:func:`phasemap.simulate`'s, in full coordinates) runs in chunks, at most
    ``settle`` seconds in all, until a chunk holds a cycle (a forced system: the stroboscopic points one or more
    forcing periods apart that agree; an autonomous one: two events of the same kind at
    states that agree, or, where the motion meets no event, its return to a Poincare
    section at the state it left).  Its mode sequence is read from the events: one *segment* per
    phase, each ended by the event that ended it.  The orbit is then solved by multiple
    shooting: the unknowns are each segment's initial state and duration, the equations
    the continuity across each event (through the projection onto the next phase's
    contacts), each event's condition, and, in a forced system, a period that is the
    multiple of the forcing period.  The Floquet multipliers are the eigenvalues of the
    linearised return map (variational equations and a saltation matrix at every event,
    :mod:`phasemap.motion.periodic.floquet`) on the contacts' manifold.

    Parameters
    ----------
    model : str or System
        a friction oscillator's name (``"belt"``, ``"stribeck_belt"``, ``"den_hartog"``,
        ``"duffing"``), a declared model's name or a :class:`phasemap.declare.System`.
    start : dict, optional
        the start (coordinates, rates, parameters by name; the defaults elsewhere).
    period : float, optional
        a guess of the orbit's period: the motion from ``start`` is taken to be on the
        orbit, and one period of it is read (no settling).  In a forced system it is a
        multiple of the forcing period.
    settle : float, optional
        how long the motion runs before its cycle is read (default: 100 forcing periods;
        an autonomous system, 500 of its time scales).
    rtol : float
        the tolerance of the integration (1e-14 to 1e-6).
    tol : float
        the shooting's residual, relative to the state's scale.
    samples : int
        points of the orbit saved in the Dataset (the segment ends besides).

    Returns
    -------
    xarray.Dataset
        the orbit's state on ``t`` (as :func:`phasemap.simulate` gives a motion in full
        coordinates), its segments on ``segment`` (``segment_mode_<contact>``,
        ``segment_duration``, ``segment_end``: the event that ends it, or -2 for the
        Poincare section that ends an autonomous orbit without events), ``period``,
        ``floquet`` (complex, on ``multiplier``), ``residual``, ``stable`` and
        ``continuum`` (1: a nontrivial multiplier at 1, the orbit one of a family of
        periodic orbits, such as a centre's; on a continuum the orbit returned is the
        one through the settled motion's state).

    Raises
    ------
    ValueError
        one line: a bad argument, a motion that comes to rest or leaves its domain, no
        cycle found within ``settle``, an orbit with impacts (not solved yet), a
        shooting that does not converge.

    Examples
    --------
    The belt's stick-slip orbit (m = k = g = 1, f_s = 1, f_k = 0.5, v = 0.2): a slip
    segment of pi + 2 arctan(v / delta) (the block slower than the belt) and a stick
    segment of 2 (f_s - f_k) / v = 5, riding with the belt:

    >>> import phasemap
    >>> orbit = phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2})
    >>> round(float(orbit.period), 9), orbit.segment_duration.values.round(9).tolist()
    (8.902605408, [3.902605408, 5.0])
    >>> names = orbit.segment_mode_belt.attrs["flag_meanings"].split()
    >>> [names[m] for m in orbit.segment_mode_belt.values]
    ['slip_neg', 'stick']
    >>> abs(orbit.floquet.values).round(8).tolist()     # the flow's 1; the stick's 0
    [1.0, 0.0]
    """
    S = system_of(model)
    from phasemap.declare.full import mechanics

    mech = mechanics(S)
    name = mech.name
    no_rolling(mech)
    if start is not None and not isinstance(start, Mapping):
        raise ValueError(f"{name}: start must be a dict of values by name, got "
                         f"{_args.describe(start)}")
    start = {} if start is None else dict(start)
    rtol = _args.finite("rtol", rtol, name)
    if not 1e-14 <= rtol <= 1e-6:
        raise ValueError(f"{name}: rtol must be in [1e-14, 1e-6], got {rtol!r}")
    tol = _args.finite("tol", tol, name, lower=0.0, lower_open=True)
    samples = _args.count("samples", samples, name)
    q, u, p = start_values(mech, start)
    forcing = None if mech.period is None else float(mech.period(*p))
    motion = Motion(mech, p, Options(1.0, rtol=rtol))
    sc = motion.scales_at(q, u, 0.0)
    scale_t = math.sqrt(sc[3] / sc[2])
    if period is not None:
        period = _args.finite("period", period, name, lower=0.0, lower_open=True)
        if forcing is not None:
            period = forcing * max(1, round(period / forcing))
            rec = _run(mech, p, q, u, 0.0, period, rtol, forcing)
            t_a, t_b, z0 = 0.0, period, np.concatenate([q, u])
        else:
            rec = _run(mech, p, q, u, 0.0, 2.5 * period, rtol, forcing)
            t_a, t_b, z0 = _guessed_cycle(name, rec, period)
    else:
        if settle is None:
            settle = 100 * forcing if forcing is not None else 500 * scale_t
        settle = _args.finite("settle", settle, name, lower=0.0, lower_open=True)
        rec, (t_a, t_b, z0) = _settled(name, mech, p, q, u, settle, rtol, forcing, sc,
                                       scale_t)
    segs, w = _segments(name, motion, rec, t_a, t_b, z0, forcing, sc)
    t_a = phase_time(t_a, forcing)
    # a motion without events on one of a continuum of orbits (its return map's
    # multiplier 1 already at the first guess): the orbit through its own start
    pinned = segs[0].section is not None and linearised(motion, segs, w, t_a, forcing,
                                                        rtol).continuum
    try:
        w, res = _shoot(name, motion, segs, w, t_a, forcing, rtol, tol, sc, max_iter,
                        pinned=pinned)
    except ValueError:
        if not pinned:      # a weakly attracting cycle that looked like a continuum
            raise
        w, res = _shoot(name, motion, segs, w, t_a, forcing, rtol, tol, sc, max_iter)
    return _orbit_dataset(S, mech, motion, segs, w, t_a, forcing, res, samples, rtol, start)


def phase_time(t, forcing):
    """A forced orbit's start time as its phase of the forcing, in [0, period): the
    forcing repeats, and a continuation in the forcing period keeps that phase."""
    return t if forcing is None else t - forcing * math.floor(t / forcing)


def _settled(name, mech, p, q, u, settle, rtol, forcing, sc, scale_t):
    """The motion run in chunks (MAX_MULTIPLE + 4 forcing periods, or 50 time scales)
    until a chunk holds a cycle, at most ``settle`` in all: ``(that chunk's record,
    cycle)``."""
    chunk = (MAX_MULTIPLE + 4) * forcing if forcing is not None else 50 * scale_t
    t, z = 0.0, np.concatenate([q, u])
    n = mech.n
    while True:
        t1 = min(t + chunk, settle)
        rec = _run(mech, p, z[:n], z[n:], t, t1, rtol, forcing)
        try:
            return rec, _cycle(name, rec, forcing, sc)
        except ValueError:
            if t1 >= settle or rec.fate != ev.HORIZON:
                raise
        t, z = t1, np.array(rec.y[-1]) if forcing is not None else np.array(rec.ev_y[-1])


def _run(mech, p, q, u, t0, t1, rtol, forcing) -> Record:
    te = None
    if forcing is not None:
        k = int(math.floor((t1 - t0) / forcing * (1 + 1e-12)))
        te = t0 + forcing * np.arange(k + 1)
        te[-1] = min(te[-1], t1)
    m = Motion(mech, p, Options(t1, rtol=rtol, max_events=1_000_000))
    return m.run(q, u, t0=t0, t_eval=te)


def _cycle(name, rec: Record, forcing, sc):
    """``(t_a, t_b, state at t_a)`` of the last cycle of the settled motion."""
    if rec.fate != ev.HORIZON:
        raise ValueError(f"{name}: the motion ends with {ev.Event(rec.fate).name.lower()} "
                         "before it settles, so it has no periodic orbit there")
    scale = max(sc[0], sc[3])
    if forcing is not None:
        ys = np.array(rec.y)
        ts = np.array(rec.t)
        last = len(ys) - 1
        for mult in range(1, min(MAX_MULTIPLE, last) + 1):
            if np.max(np.abs(ys[last] - ys[last - mult])) <= SETTLED * scale:
                return float(ts[last - mult]), float(ts[last]), ys[last - mult]
        raise ValueError(f"{name}: the motion has not settled on a cycle of at most "
                         f"{MAX_MULTIPLE} forcing periods within settle= (the stroboscopic "
                         "points still differ): give a longer settle or a start nearer the "
                         "orbit")
    kinds = rec.ev_kind
    if all(k in (ev.START, ev.HORIZON) for k in kinds):
        return section_cycle(name, rec, scale, SETTLED)
    last = len(kinds) - 1
    while last > 0 and kinds[last] in (ev.HORIZON, ev.START):
        last -= 1
    for j in range(last - 1, 0, -1):
        if (rec.ev_t[last] - rec.ev_t[j] > 1e-6 * math.sqrt(sc[3] / sc[2])
                and kinds[j] == kinds[last] and rec.ev_contact[j] == rec.ev_contact[last]
                and rec.ev_modes[j] == rec.ev_modes[last]
                and np.max(np.abs(rec.ev_y[j] - rec.ev_y[last])) <= SETTLED * scale):
            return float(rec.ev_t[j]), float(rec.ev_t[last]), np.array(rec.ev_y[j])
    raise ValueError(f"{name}: the motion has not settled on a cycle within settle= (no "
                     "event repeats at the same state): give a longer settle or a start "
                     "nearer the orbit")


def _guessed_cycle(name, rec: Record, period):
    """``(t_a, t_b, state at t_a)``: from the first event of an autonomous motion to the
    event of the same kind nearest one ``period`` later (a motion that meets no event:
    to its return to the hyperplane through its start nearest one ``period`` later)."""
    kinds = rec.ev_kind
    first = next((i for i, k in enumerate(kinds) if k not in (ev.START, ev.HORIZON)), None)
    if first is None:
        ys = np.array(rec.y)
        back = [(t, z) for t, z in returns(rec, ys[0], unit(ys[1] - ys[0]))
                if t > rec.t[0] + 0.5 * period] if len(ys) >= 5 and np.any(
                    ys[1] != ys[0]) else []
        if not back:
            raise ValueError(f"{name}: the motion from the start meets no event and does "
                             "not come back to its section within 2.5 periods: it is not "
                             "near a periodic orbit of that period")
        t_b = min(back, key=lambda b: abs(b[0] - rec.t[0] - period))[0]
        return float(rec.t[0]), t_b, ys[0]
    same = [j for j in range(first + 1, len(kinds)) if kinds[j] == kinds[first]
            and rec.ev_contact[j] == rec.ev_contact[first]
            and rec.ev_modes[j] == rec.ev_modes[first]]
    if not same:
        raise ValueError(f"{name}: no event repeats within 2.5 periods of the start: it is "
                         "not near a periodic orbit of that period")
    j = min(same, key=lambda j: abs(rec.ev_t[j] - rec.ev_t[first] - period))
    return float(rec.ev_t[first]), float(rec.ev_t[j]), np.array(rec.ev_y[first])


def _segments(name, motion, rec: Record, t_a, t_b, z0, forcing, sc):
    """The segments of one period of ``rec`` (which runs from ``t_a`` to ``t_b``) and the
    first guess of the unknowns: each segment's initial state, then the durations."""
    kinds = [k for k in rec.ev_kind]
    inside = [i for i, t in enumerate(rec.ev_t) if t_a < t <= t_b and kinds[i] not in
              (ev.START, ev.HORIZON)]
    bad = [ev.Event(kinds[i]).name.lower() for i in inside if kinds[i] in IMPULSIVE]
    if bad:
        raise ValueError(f"{name}: the orbit goes through an impulsive event ({bad[0]}): "
                         "orbits with impacts are not solved yet")
    allowed = (ev.STICK, ev.SLIP, ev.REVERSAL, ev.SWITCH, ev.LIFTOFF, ev.RECONTACT)
    odd = [kinds[i] for i in inside if kinds[i] not in allowed]
    if odd:
        raise ValueError(f"{name}: the cycle meets a {ev.Event(odd[0]).name.lower()} event; "
                         "it is not a periodic orbit")
    first = max((i for i, t in enumerate(rec.ev_t) if t <= t_a and kinds[i] != ev.HORIZON),
                default=None)
    modes0 = tuple(rec.ev_modes[first]) if first is not None else tuple(rec.modes[0])
    later = inside if forcing is not None else inside[:-1]
    starts = [(t_a, z0, modes0)] + [(rec.ev_t[i], rec.ev_y[i], tuple(rec.ev_modes[i]))
                                    for i in later]
    ends_t = [rec.ev_t[i] for i in inside] + ([t_b] if forcing is not None else [])
    if forcing is None and not inside:      # a smooth orbit: ended by a Poincare section
        rho = _rho(motion, z0, modes0, t_a, sc)
        section = section_at(motion, z0, t_a, modes0, rho, sc)
        if section is None:
            raise ValueError(f"{name}: the motion is at an equilibrium, not on an orbit")
        return ([Segment(tuple(int(m) for m in modes0), rho, None, SECTION_END, section)],
                np.append(np.asarray(z0, dtype=float), t_b - t_a))
    segs, zs, taus = [], [], []
    for j, (t, z, modes) in enumerate(starts):
        t_end = ends_t[j]
        rho = _rho(motion, z, modes, t, sc)
        at_end = forcing is not None and j == len(starts) - 1
        index, kind = None, -1
        if not at_end:
            i_ev = inside[j]
            kind = kinds[i_ev]
            index = _event_index(motion, rec, i_ev, modes, rho, sc, t_end)
        segs.append(Segment(tuple(int(m) for m in modes), rho, index, int(kind)))
        zs.append(np.asarray(z, dtype=float))
        taus.append(float(t_end - t))
    if any(tau <= 0 for tau in taus):
        raise ValueError(f"{name}: a segment of the cycle has no length")
    return segs, np.concatenate(zs + [np.array(taus)])


#: Which of a contact's two event functions (Motion.watch: 2c its gap or N, 2c + 1 its
#: slip velocity or friction slack) each kind of event is.
_WHICH = {ev.LIFTOFF: 0, ev.RECONTACT: 0, ev.STICK: 1, ev.SLIP: 1, ev.REVERSAL: 1}


def section_at(motion, z, t, modes, rho, sc) -> Section | None:
    """The Poincare section of an orbit without events that starts at ``z`` (time ``t``,
    its phase ``modes``): through ``z``, normal to the flow there; None at an equilibrium
    (a flow below 1e-12 of the state's scale)."""
    field = fq.field(motion, np.append(z, t), modes, rho)[:-1]
    if not np.max(np.abs(field)) > 1e-12 * max(sc[0], sc[3]):
        return None
    return Section(np.array(z, dtype=float), unit(field))


def no_rolling(mech) -> None:
    """ValueError where a contact is a rolling disc: the periodic orbits here hold a closed
    contact by its normal and friction rows, not by a rolling disc's no-slip row."""
    rolling = [c.name for c in mech.contacts if c.rolls]
    if rolling:
        raise ValueError(f"{mech.name}: periodic orbits of a rolling contact "
                         f"({', '.join(rolling)}) are not built; phasemap.simulate runs "
                         "its motion")


def _event_index(motion, rec, i, modes, rho, sc, t):
    """The index of the event function that ended a segment: from the event's kind and
    contact, or, for another kind, the function nearest zero at the event."""
    kind, c = rec.ev_kind[i], rec.ev_contact[i]
    if kind in _WHICH and c >= 0:
        return 2 * int(c) + _WHICH[kind]
    n = motion.n
    z = np.asarray(rec.ev_y[i])
    return int(np.argmin(np.abs(motion.watch(z[:n], z[n:], modes, rho, sc, t))))


def _rho(motion, z, modes, t, sc):
    n = motion.n
    if all(motion.one_sided[c] or m == OPEN for c, m in enumerate(modes)):
        return np.ones(motion.k)
    sol = motion.admissible(z[:n], z[n:], modes, sc, t=t)
    return np.ones(motion.k) if sol is None else sol[4]


def _jump(motion, z, t, nxt: Segment):
    n = motion.n
    closed = [c for c, m in enumerate(nxt.modes) if m != OPEN]
    held = [c for c, m in enumerate(nxt.modes) if MODE_NAMES[m] == "stick"]
    q, u = motion.project(z[:n], z[n:], closed, held, t=t)
    return np.concatenate([q, u])


def _unpack(w, K, n2):
    return [w[j * n2:(j + 1) * n2] for j in range(K)], w[K * n2:]


def _ends(motion, segs, w, t_a, rtol, sc):
    """Per segment its end after the jump into the next phase and its event function's
    value there (None at the end of a forcing period), and its start times."""
    n2 = 2 * motion.n
    K = len(segs)
    zs, taus = _unpack(w, K, n2)
    starts = t_a + np.concatenate([[0.0], np.cumsum(taus)[:-1]])
    return [_end(motion, segs, j, zs[j], starts[j], taus[j], rtol, sc) for j in range(K)], starts


def _end(motion, segs, j, z, t, tau, rtol, sc):
    n = motion.n
    seg, nxt = segs[j], segs[(j + 1) % len(segs)]
    end = segments.end(motion, z, t, tau, seg, rtol)
    if seg.section is not None:     # in the event functions' units, as _residual reads it
        w = float(seg.section.normal @ (end - seg.section.point)) * max(sc) / max(sc[0], sc[3])
        return _jump(motion, end, t + tau, nxt), w
    if seg.index is None:
        return end, None
    w = motion.watch(end[:n], end[n:], seg.modes, seg.rho, sc, t + tau)[seg.index]
    return _jump(motion, end, t + tau, nxt), w


def _residual(motion, segs, w, ends, forcing, sc):
    """The shooting equations, per segment: continuity into the next segment's start
    (relative to the state's scale), the event's condition (relative to the event
    functions' scale); a forced system's period last."""
    n2 = 2 * motion.n
    K = len(segs)
    zs, taus = _unpack(w, K, n2)
    scale, ws = max(sc[0], sc[3]), max(sc)
    out = []
    for j, (after, wv) in enumerate(ends):
        out.append((zs[(j + 1) % K] - after) / scale)
        if wv is not None:
            out.append([wv / ws])
    if forcing is not None:
        total = float(np.sum(taus))
        out.append([(total - forcing * round(total / forcing)) / forcing])
    return np.concatenate([np.atleast_1d(np.asarray(x, dtype=float)) for x in out])


def _shoot(name, motion, segs, w, t_a, forcing, rtol, tol, sc, max_iter, cache=None,
           pinned=False):
    """Newton's method on the multiple-shooting equations (their Jacobian:
    :func:`jacobian`).  ``cache``: a list holding
    a Jacobian from a nearby orbit (a continuation's), used first (the chord method) and
    replaced by a fresh one where it stops reducing the residual.  ``pinned``: the
    segments' starts are held and only the durations solved for (Gauss-Newton), the orbit
    through the start of a continuum, on which Newton's method in every unknown would
    slide along the family."""
    ends, starts = _ends(motion, segs, w, t_a, rtol, sc)
    r = _residual(motion, segs, w, ends, forcing, sc)
    res = float(np.max(np.abs(r)))
    free = np.ones(w.size, dtype=bool)
    if pinned:
        free[:len(segs) * 2 * motion.n] = False
    chords = 0
    for _ in range(max_iter):
        if res <= 0.1 * tol:
            break
        if cache and cache[0].shape == (r.size, w.size) and chords < 3:
            chords += 1
            step = _step(cache[0], r, free)
            better = _better(motion, segs, w, step, t_a, forcing, rtol, sc, res, 1)
            if better is not None and float(np.max(np.abs(better[3]))) < 0.1 * res:
                w, ends, starts, r = better
                res = float(np.max(np.abs(r)))
                continue
        chords = 3
        Jac = jacobian(motion, segs, w, ends, starts, forcing, rtol, sc)
        if cache is not None:
            cache[:] = [Jac]
        step = _step(Jac, r, free)
        better = _better(motion, segs, w, step, t_a, forcing, rtol, sc, res, 12)
        if better is None:
            break
        w, ends, starts, r = better
        res = float(np.max(np.abs(r)))
        chords = 0
    if not res <= max(tol, 10 * rtol):
        raise ValueError(f"{name}: the shooting did not converge (residual {res:.2g} > tol "
                         f"{tol:g}): give a start nearer the orbit, a longer settle, or a "
                         "looser tol")
    _crossed(name, motion, segs, w, starts)
    return w, res


def _crossed(name, motion, segs, w, starts) -> None:
    """A ValueError where a segment ended by a section starts on it crossing the wrong
    way: the section's equation holds at both crossings of a hyperplane by a closed
    orbit, and only the one in the normal's direction is the return it stands for (the
    other is a solution of another orbit, which Newton's method may reach from afar).
    ``starts``: the segments' start times (:func:`_ends`')."""
    zs, _ = _unpack(w, len(segs), 2 * motion.n)
    for seg, z, t in zip(segs, zs, starts):
        if seg.section is not None and not float(seg.section.normal @ fq.field(
                motion, np.append(z, t), seg.modes, seg.rho)[:-1]) > 0.0:
            raise ValueError(f"{name}: the shooting converged on an orbit that crosses its "
                             "Poincare section the other way: give a start nearer the orbit")


def _step(Jac, r, free):
    """The least-squares Newton step in the unknowns ``free`` (the others held)."""
    step = np.zeros(free.size)
    step[free] = np.linalg.lstsq(Jac[:, free], r, rcond=None)[0]
    return step


def jacobian(motion, segs, w, ends, starts, forcing, rtol, sc):
    """The shooting equations' Jacobian in the unknowns ``w``, by differences: a
    segment's equations depend on its own start and duration (one segment integrated per
    column), on the next start (the identity) and, in a forced system, on the time it
    starts (the durations before it).  ``ends, starts``: :func:`_ends` at ``w``."""
    n2 = 2 * motion.n
    K = len(segs)
    scale = max(sc[0], sc[3])
    rows = [n2 + s.ended for s in segs]
    offs = np.concatenate([[0], np.cumsum(rows)])
    Jac = np.zeros((int(offs[-1]) + (forcing is not None), w.size))
    zs, taus = _unpack(w, K, n2)
    for j in range(K):
        o = offs[j]
        Jac[o:o + n2, ((j + 1) % K) * n2:((j + 1) % K + 1) * n2] += np.eye(n2) / scale
        base = _flat(ends[j], scale, sc)
        cols = list(range(n2)) + ["tau"] + (["t"] if forcing is not None and j else [])
        for col in cols:
            z, t, tau = zs[j].copy(), starts[j], taus[j]
            step = 0.1 * math.sqrt(rtol)      # 1e-7 at rtol 1e-12
            if col == "tau":
                h = step * max(tau, 1e-3)
                tau = tau + h
            elif col == "t":
                h = step * max(1.0, abs(t))
                t = t + h
            else:
                h = step * (1.0 + abs(z[col]))
                z[col] += h
            d = (_flat(_end(motion, segs, j, z, t, tau, rtol, sc), scale, sc) - base) / h
            if col == "tau":
                Jac[o:o + rows[j], K * n2 + j] = d
            elif col == "t":
                Jac[o:o + rows[j], K * n2:K * n2 + j] = d[:, None]
            else:       # added: with one segment, its start is also the next one's
                Jac[o:o + rows[j], j * n2 + col] += d
    if forcing is not None:
        Jac[-1, K * n2:] = 1.0 / forcing
    return Jac


def _better(motion, segs, w, step, t_a, forcing, rtol, sc, res, halvings):
    """``w - step`` (halved up to ``halvings`` times) where it lowers the residual:
    ``(w, ends, starts, residual)``, else None."""
    K = len(segs)
    n2 = 2 * motion.n
    for _ in range(halvings):
        trial = w - step
        if np.all(trial[K * n2:] > 0):
            ends, starts = _ends(motion, segs, trial, t_a, rtol, sc)
            r = _residual(motion, segs, trial, ends, forcing, sc)
            if float(np.max(np.abs(r))) < res:
                return trial, ends, starts, r
        step = step / 2
    return None


def _flat(end, scale, sc):
    after, wv = end
    return np.concatenate([-after / scale, [] if wv is None else [wv / max(sc)]])


def linearised(motion, segs, w, t_a, forcing, rtol, samples=0, traced=None) -> Linearised:
    """The Floquet multipliers of the orbit ``w`` from the variational equations and the
    saltation matrices, and, with ``samples``, the orbit sampled into a Record (see
    :class:`Linearised`).  ``traced``: the orbit's
    :class:`~phasemap.motion.periodic.segments.Traced`, whose segments' ends (and samples)
    are read from the integrations it already holds."""
    n2 = 2 * motion.n
    n = motion.n
    K = len(segs)
    zs, taus = _unpack(w, K, n2)
    period = float(np.sum(taus))
    sc = motion.scales_at(zs[0][:n], zs[0][n:], t_a)
    rec = Record()
    rec.fate = ev.HORIZON
    closed0 = [c for c, m in enumerate(segs[0].modes) if m != OPEN]
    B = fq.tangent_basis(motion, np.concatenate([zs[0], [t_a]]), closed0)
    # the monodromy applied to the directions along the contacts at the start (the time's
    # component 0, which neither the segments nor the saltations change): each segment's
    # variational equations carry those directions alone
    P = np.vstack([B, np.zeros((1, B.shape[1]))])
    t = t_a
    for j, seg in enumerate(segs):
        if samples:
            m_j = max(2, int(round(samples * taus[j] / period)))
            times = np.linspace(t, t + taus[j], m_j, endpoint=j == K - 1)
            end, states = (segments.samples(motion, zs[j], t, taus[j], seg, rtol, times)
                           if traced is None else traced.samples(j, times))
            rec.points(times, states, seg.modes)
        else:
            end = (segments.end(motion, zs[j], t, taus[j], seg, rtol) if traced is None else
                   traced.end(j))
        t_end = t + taus[j]
        if np.all(np.isfinite(P)):      # (NaN after a grazing event: NaN from there on)
            P = segments.transition(motion, np.concatenate([zs[j], [t]]), taus[j], seg, rtol,
                                    directions=P)
        Xm = np.concatenate([end, [t_end]])
        nxt = segs[(j + 1) % K]
        if not seg.ended:           # the end of the forcing period: time fixed
            grad = np.zeros(n2 + 1)
            grad[-1] = 1.0
            DJ = np.eye(n2 + 1)
            after = end
        else:
            grad = (np.append(seg.section.normal, 0.0) if seg.section is not None else
                    fq.event_gradient(motion, Xm, seg.modes, seg.rho, seg.index, sc))
            closed = [c for c, m in enumerate(nxt.modes) if m != OPEN]
            held = tuple(c for c, m in enumerate(nxt.modes) if MODE_NAMES[m] == "stick")
            DJ = fq.jump_derivative(motion, Xm, closed, held)
            after = _jump(motion, end, t_end, nxt)
            if seg.section is None:     # a section is no event of the motion
                rec.event(t_end, seg.kind, _contact_of(seg, motion), after, nxt.modes)
        Fm = fq.field(motion, Xm, seg.modes, seg.rho)
        Fp = fq.field(motion, np.concatenate([after, [t_end]]), nxt.modes, nxt.rho)
        P = fq.saltation(DJ, Fm, Fp, grad) @ P
        t = t_end
    reduced = B.T @ P[:n2]
    if not np.all(np.isfinite(reduced)):    # a grazing event: no linearised map there
        return Linearised(np.full(reduced.shape[0], np.nan, dtype=complex), -1, False, rec,
                          False)
    lam = np.linalg.eigvals(reduced).astype(complex)
    lam = lam[np.argsort(-np.abs(lam))]
    trivial = -1
    if forcing is None and lam.size:
        trivial = int(np.argmin(np.abs(lam - 1.0)))
    others = np.delete(np.abs(lam), trivial) if trivial >= 0 else np.abs(lam)
    return Linearised(lam, trivial, bool(np.all(others < 1.0 - 1e-9)), rec,
                      _continuum(reduced, B.T @ fq.field(motion, np.concatenate(
                          [zs[0], [t_a]]), segs[0].modes, segs[0].rho)[:n2], forcing))


def _continuum(reduced, flow, forcing) -> bool:
    """Whether a nontrivial multiplier is 1 (to :data:`CONTINUUM`): of the monodromy
    ``reduced`` in a forced system, of the Poincare map (the monodromy followed by the
    projection along the ``flow`` at the start onto the hyperplane normal to it, whose
    multiplier of the flow's direction is 0) in an autonomous one.  The Poincare map keeps
    a family's multiplier a simple 1 where the monodromy holds it in a Jordan block with the
    flow's (a centre whose period changes with the amplitude), whose computed eigenvalues
    stray from 1 by the square root of the rounding."""
    M = reduced
    if forcing is None:
        f = flow / float(np.linalg.norm(flow))
        M = (np.eye(f.size) - np.outer(f, f)) @ reduced
    return bool(np.any(np.abs(np.linalg.eigvals(M) - 1.0) < CONTINUUM))


def _orbit_dataset(S, mech, motion, segs, w, t_a, forcing, res, samples, rtol, start):
    n = mech.n
    n2 = 2 * n
    K = len(segs)
    zs, taus = _unpack(w, K, n2)
    period = float(np.sum(taus))
    lam, trivial, stable, rec, continuum = linearised(motion, segs, w, t_a, forcing, rtol,
                                                      samples)
    from phasemap.motion.hybrid.start import full_attrs

    attrs = full_attrs(S, None, {"t_end": t_a + period, "rtol": rtol}, {}, start)
    attrs.update({"phasemap_kind": "periodic_orbit",
                  "title": f"phasemap periodic orbit: {S.title}"})
    seg_attrs = {"flag_values": np.arange(len(MODE_NAMES), dtype=np.int8),
                 "flag_meanings": " ".join(MODE_NAMES)}
    data = {
        "segment_duration": ("segment", np.array(taus), {
            "long_name": "duration of the segment", "units": "s"}),
        "segment_start": ("segment", t_a + np.concatenate([[0.0], np.cumsum(taus)[:-1]]), {
            "long_name": "time at which the segment starts", "units": "s"}),
        "segment_end": ("segment", np.array([s.kind for s in segs], dtype=np.int8), {
            "long_name": "event that ends the segment (-1: the end of the forcing period; "
                         "-2: the return to a Poincare section, an orbit without events)",
            "flag_values": np.array([SECTION_END, PERIOD_END, *ev.EVENT_VALUES],
                                    dtype=np.int8),
            "flag_meanings": "section period_end " + ev.EVENT_MEANINGS}),
        "period": ((), period, {"long_name": "period of the orbit", "units": "s"}),
        "floquet": ("multiplier", lam, {
            "long_name": "Floquet multipliers (eigenvalues of the linearised return map on "
                         "the contacts' manifold)", "units": "1"}),
        "residual": ((), res, {"long_name": "largest residual of the shooting equations, "
                                            "relative to the state's scale", "units": "1"}),
        "stable": ((), np.int8(stable), {
            "long_name": "orbit stability", "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "unstable stable"}),
        "continuum": ((), np.int8(continuum), {
            "long_name": "whether the orbit is one of a continuum (a family of periodic "
                         "orbits: a nontrivial multiplier 1)",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "isolated continuum"}),
    }
    data["segment_event_index"] = ("segment", np.array(
        [(SECTION_END if sg.section is not None else PERIOD_END) if sg.index is None
         else sg.index for sg in segs], dtype=np.int32), {
        "long_name": "index of the event function that ends the segment (-1: the end of "
                     "the forcing period; -2: a Poincare section through the segment's "
                     "start, normal to the flow there; phasemap.motion.hybrid.Motion.watch)"})
    for i, (nm, un) in enumerate(state_variables(mech)):
        data[f"segment_{nm}"] = ("segment", np.array([z[i] for z in zs]), {
            "long_name": f"{nm} where the segment starts", "units": un})
    for c in mech.contacts:
        data[f"segment_mode_{c.name}"] = ("segment", np.array(
            [s.modes[c.index] for s in segs], dtype=np.int8),
            {**seg_attrs, "long_name": f"mode of contact {c.name} in the segment"})
    ds = dataset(mech, rec, attrs, p=motion.p, extra=data)
    ds.attrs.update({f"phasemap_parameter_{nm}": float(v)
                     for nm, v in zip(mech.parameters, motion.p)})
    ds.attrs.update({"phasemap_trivial_multiplier": np.int64(trivial),
                     "phasemap_forcing_period": forcing if forcing is not None else np.nan})
    del ds.attrs["end_reason"], ds.attrs["end_message"]
    return ds


def state_variables(mech) -> list[tuple[str, str]]:
    """``(name, units)`` of each variable of the full state, in its order: the
    coordinates, then their rates."""
    return list(zip([*mech.coordinates, *mech.rates],
                    [*mech.units, *(f"{u} s-1" for u in mech.units)]))


def _contact_of(seg: Segment, motion) -> int:
    return -1 if seg.index is None or seg.index >= 2 * motion.k else seg.index // 2
