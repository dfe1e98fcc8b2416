"""What a continuation samples along an orbit (see
:mod:`phasemap.motion.periodic.continuation`): each coordinate's extremes, and whether a
segment's conditions dip below zero inside it."""

from __future__ import annotations

import numpy as np

from phasemap.motion.periodic import orbit as _orbit
from phasemap.motion.periodic import segments

#: Points of the orbit sampled per branch point for its amplitudes.
SAMPLES = 200


def extrema(motion, segs, w, t_a, rtol, forcing=None, traced=None):
    """Each coordinate's least and greatest value over the orbit: at the segments' ends,
    or where its rate vanishes inside one (located on the segment's dense output); and,
    for a forced orbit (``forcing`` its period), its states at the forcing's phase 0 in
    order (what :func:`phasemap.orbit_diagram` samples; an empty array otherwise).
    ``traced``: the orbit's :class:`~phasemap.motion.periodic.segments.Traced`, whose
    segments are integrated once for every sample and search (made here if not given)."""
    from scipy.optimize import brentq

    n = motion.n
    n2 = 2 * n
    K = len(segs)
    zs, taus = _orbit._unpack(w, K, n2)
    traced = traced or segments.Traced(motion, segs, w, t_a, rtol)
    low, high = np.full(n, np.inf), np.full(n, -np.inf)
    t = t_a
    strobes = []
    if forcing is not None:
        period = float(np.sum(taus))
        first = forcing * np.ceil(t_a / forcing - 1e-12)   # (t_a a rounding past 0)
        times = first + forcing * np.arange(max(int(round(period / forcing)), 1))
        starts = t_a + np.concatenate([[0.0], np.cumsum(taus)[:-1]])
        where = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, K - 1)
    for j, seg in enumerate(segs):

        def sol(s, j=j):
            return traced.at(j, s)
        if forcing is not None:
            strobe = np.sort(np.clip(times[where == j], t, t + taus[j]))
            if strobe.size:
                strobes.extend(traced.samples(j, strobe)[1])
        ts = np.linspace(t, t + taus[j], SAMPLES // K + 2)
        ys = traced.samples(j, ts)[1].T
        found = [ys[:n, 0], ys[:n, -1]]
        for i in range(n):
            rate = ys[n + i]
            for k in np.flatnonzero(np.sign(rate[:-1]) * np.sign(rate[1:]) < 0):
                tk = brentq(lambda s: sol(s)[n + i], ts[k], ts[k + 1], xtol=1e-14)
                found.append(np.where(np.arange(n) == i, sol(tk)[:n], np.nan))
        vals = np.array(found)
        low = np.fmin(low, np.nanmin(vals, axis=0))
        high = np.fmax(high, np.nanmax(vals, axis=0))
        t += taus[j]
    return low, high, np.array(strobes, dtype=float).reshape(-1, n2)


#: Samples per segment where its conditions are checked for a dip below zero.
DIP_SAMPLES = 24


def dips(motion, segs, w, t_a, rtol, traced=None) -> bool:
    """Whether a condition of a segment's phase (its event functions but the one that
    ends it) goes below zero inside the segment: sampled, and each sampled minimum near
    zero refined on the dense output (a tangency between samples is found).  ``traced``:
    as :func:`extrema`'s."""
    from scipy.optimize import minimize_scalar

    n = motion.n
    n2 = 2 * n
    K = len(segs)
    zs, taus = _orbit._unpack(w, K, n2)
    traced = traced or segments.Traced(motion, segs, w, t_a, rtol)
    t = t_a
    z0 = zs[0]
    sc = motion.scales_at(z0[:n], z0[n:], t_a)
    scale = max(sc)
    for j, seg in enumerate(segs):

        def watch(s, y=None, j=j, seg=seg):
            y = traced.at(j, s) if y is None else y
            out = motion.watch(y[:n], y[n:], seg.modes, seg.rho, sc, s)[:2 * motion.k]
            if seg.index is not None and seg.index < out.size:
                out = np.delete(out, seg.index)
            return out

        ts = np.linspace(t, t + taus[j], DIP_SAMPLES)[1:-1]
        ys = traced.samples(j, ts)[1]
        vals = motion.watch_many(ts, ys, seg.modes, seg.rho, sc)[:, :2 * motion.k]
        if seg.index is not None and seg.index < vals.shape[1]:
            vals = np.delete(vals, seg.index, axis=1)
        if vals.size and np.min(vals) < -1e-9 * scale:
            return True
        for i in range(vals.shape[1] if vals.size else 0):
            k = int(np.argmin(vals[:, i]))
            if vals[k, i] > 1e-3 * scale:
                continue
            lo, hi = ts[max(k - 1, 0)], ts[min(k + 1, len(ts) - 1)]
            if hi <= lo:
                continue
            best = minimize_scalar(lambda s, i=i: watch(s)[i], bounds=(lo, hi),
                                   method="bounded", options={"xatol": 1e-13 * (1 + hi)})
            if best.fun < -1e-9 * scale:
                return True
        t += taus[j]
    return False
