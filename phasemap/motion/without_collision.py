"""A reduced motion through its impacts without collision: where a declared system's
motion on its reduced model ends with ``no_solution`` at a contact that slips into its
obstacle (a Painleve inconsistency), the impact without collision there and the motion
from the state after it, joined into one (what :func:`phasemap.simulate` runs before a
motion goes on in full coordinates)."""

from __future__ import annotations

import numpy as np

from phasemap.core import events as ev
from phasemap.core.lazy import xarray as xr
from phasemap.core.model import Model
from phasemap.motion import hybrid
from phasemap.motion.hybrid.start import mechanics_of
from phasemap.motion.integrate import NO_STOP

#: The most impacts without collision one motion goes through (each ends a stage).
MAX_IMPACTS = 10_000


def through_impacts(m: Model, integrate, v, y0, run, names, full):
    """Integrate, and where the motion of a declared system ends with ``no_solution`` at
    a contact that slips into the obstacle (a Painleve inconsistency), apply the impact
    without collision there (:func:`phasemap.motion.impact.impact`, e = 0) and go on
    from the state after it: the integrator's outputs joined, times shifted, the fate
    ``no_solution`` replaced by an ``iwc`` event; and the impacts ``(t, P_n, P_t, dKE)``.
    A motion that meets no such state is the integrator's own, bit for bit."""
    t_end, rtol, atol, h_max, max_steps, max_events, save, te = run
    res = integrate(v, y0, *run, NO_STOP)
    if int(res.fate) != ev.NO_SOLUTION or getattr(m, "declaration", None) is None:
        return (*res, [])
    parts, impacts, t0 = [res], [], 0.0
    while int(res.fate) == ev.NO_SOLUTION and len(impacts) < MAX_IMPACTS:
        jump = impact_without_collision(m, names, res.y, full)
        if jump is None:
            break
        y0, kick = jump
        t0 += float(res.t)
        impacts.append((t0, *kick))
        steps = max_steps - sum(int(r.n_steps) for r in parts)
        events = max_events - sum(len(r.events) - 1 for r in parts)
        if steps <= 0 or events <= 1 or t0 >= t_end:
            break
        done = sum(len(r.y_eval) for r in parts)
        res = integrate(v, y0, t_end - t0, rtol, atol, h_max, steps, events, save,
                        te[done:] - t0, NO_STOP)
        parts.append(res)
    if len(parts) == 1:  # the impact could not go on (no steps, events or time left)
        return (*res, [])
    return (*joined(parts, [i[0] for i in impacts]), impacts[:len(parts) - 1])


def joined(parts, starts):
    """The integrator outputs of consecutive stages of one motion as one: the times of
    each after the first shifted by its start.  The terminal event of each but the last
    (its ``no_solution``, where the impact without collision was applied) becomes its
    ``iwc`` event: the state before the impulse, as every impulsive event keeps it (an
    impact's and a jam's in full coordinates too), with the branch the next stage starts
    on; that stage's start event is dropped (the state after the impulse is its first
    saved point)."""
    offsets = [0.0, *starts[:len(parts) - 1]]
    points, events, evals = [], [], []
    for k, (r, t0) in enumerate(zip(parts, offsets)):
        pts, evs = r.points.copy(), r.events.copy()
        pts[:, 0] += t0
        evs[:, 0] += t0
        if k and int(evs[0, 1]) == ev.START and len(evs) > 1:
            evs = evs[1:]
        if k < len(parts) - 1:
            evs[-1, 1] = ev.IWC
            evs[-1, 2] = parts[k + 1].events[0, 2]
        points.append(pts)
        events.append(evs)
        evals.append(r.y_eval)
    last = parts[-1]
    return (last.fate, float(last.t) + offsets[-1], last.y,
            sum(int(r.n_reversals) for r in parts), sum(int(r.n_steps) for r in parts),
            np.concatenate(points), np.concatenate(events), np.concatenate(evals))


def impact_without_collision(m: Model, names, y, full):
    """The state after the impact without collision at the end state ``y`` of a declared
    system with one contact, and ``(P_n, P_t, dKE)``; None where that is not what the
    state calls for (the normal velocity is not zero, or the slip does not force the
    contact in: the impact is refused), or the system has other contacts."""
    from phasemap.declare.full import closure

    S = m.declaration       # (a loaded model's stays unbuilt: full.py reads the cache)
    values = {**full, **dict(zip(names, (float(x) for x in y)))}
    try:
        mech = mechanics_of(S)
        if len(mech.contacts) != 1:
            return None
        q, qd = closure(S)(values)
    except (ValueError, KeyError):
        return None     # a contact that cannot take an impulse, or a value missing
    M, _, _, J, _, mu = mech.pieces(q, qd, [float(values[k]) for k in mech.parameters])
    vn, vt = J[0, :2] @ qd
    if abs(vn) > 1e-9 * (abs(vt) + 1e-300):
        return None
    try:
        after, r = hybrid.tangential_impact(M, J[0, :2], qd, float(mu[0]), None,
                                            J[0, 2] if mech.contacts[0].rolls else None)
    except ValueError:
        return None
    y1 = np.array(y, dtype=float)
    for rate, value in zip(mech.rates, after):
        if rate in names:
            y1[names.index(rate)] = value
    return y1, (r.P_n, r.P_t, r.dKE)


def impact_variables(ds: xr.Dataset, impacts) -> None:
    """The impulses and the energy change of each impact, on the events: NaN at events
    that are not impacts."""
    kinds = ds.event_kind.values
    at = np.flatnonzero(kinds == ev.IWC)
    for j, (name, long_name, units) in enumerate((
            ("event_impulse_n", "normal impulse of the impact on the body", "N s"),
            ("event_impulse_t", "tangential impulse of the impact on the body", "N s"),
            ("event_dKE", "change of kinetic energy in the impact", "J"))):
        col = np.full(kinds.shape, np.nan)
        col[at] = [i[1 + j] for i in impacts]
        ds[name] = xr.Variable("event", col, {"long_name": long_name, "units": units})
