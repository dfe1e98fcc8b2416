"""A periodic orbit followed in a parameter, through the changes of its mode sequence
(see :mod:`phasemap.motion.periodic`)."""

from __future__ import annotations

import math

import numpy as np

from phasemap.core import args as _args
from phasemap.core import events as ev
from phasemap.motion.hybrid import MODE_NAMES, STICK, Motion, Options
from phasemap.motion.periodic import orbit as _orbit
from phasemap.motion.periodic.orbit import Segment

#: Points of the orbit sampled per branch point for its amplitudes.
SAMPLES = 200


def continue_orbit(orbit, param: str, span, *, model=None, steps: int = 40,
                   rtol: float | None = None, tol: float = 1e-10, locate: float = 1e-10):
    """Follow the periodic orbit ``orbit`` (a :func:`phasemap.periodic_orbit` Dataset) in
    the parameter ``param`` across ``span = (lo, hi)``.

    The orbit is continued in ``steps`` equal steps of the parameter (a secant predictor,
    the multiple-shooting Newton corrector of :func:`phasemap.periodic_orbit`).  After
    every step the orbit is checked against the motion itself: the hybrid motion from the
    orbit's start, run for one period, must go through the same mode sequence (no event
    inside a segment, each phase admissible all along).  Where it does not, the mode
    sequence changes between the two steps: the parameter where it changes is located by
    bisection to ``locate`` (relative to the span), the point is named, the new sequence
    is read from the motion just beyond it, and the continuation goes on with it, without
    the user's help (the motion beyond may settle on an orbit of another period: the
    branch goes on along it).  A real Floquet multiplier through -1 is marked as a period
    doubling at the step where it is seen (to within a step; not located).  Where Newton's
    method stops converging, even in shorter steps, the branch ends there, marked
    ``fold``: a fold, or any other end of the branch's convergence (natural-parameter
    continuation does not turn round a fold).

    Kinds of special points: ``crossing_sliding`` (a stick segment is born at, or shrinks
    into, a reversal of the slip: the crossing point reaches the edge of the sticking
    region), ``grazing_sliding`` (a stick segment appears where the orbit had no event),
    ``sequence_change`` (another change of the mode sequence, among them a stuck
    contact's friction limit reached tangentially inside its stick segment),
    ``period_doubling``, ``fold`` (no convergence beyond) and ``end`` (the end of the
    span).  ``grazing_sliding`` is named from the sequences alone (a stick segment more
    and no reversal less): it is not checked further.

    Parameters
    ----------
    orbit : xarray.Dataset
        a periodic orbit from :func:`phasemap.periodic_orbit`.
    param : str
        a parameter of the model.
    span : (float, float)
        the range to follow it across; it must hold the orbit's value.
    model : System, optional
        the declaration, where the orbit's model is not a built-in name.
    steps : int
        steps across the whole span.
    rtol, tol
        the integration's and the shooting's tolerances (default: the orbit's rtol).
    locate : float
        how closely a special point is located, relative to the span.

    Returns
    -------
    xarray.Dataset
        shaped like that of :func:`phasemap.threshold` with ``along=``: on ``vertex``
        the branch (``<param>``, ``period``, ``amplitude_<coordinate>``, ``stable``,
        ``floquet_max``: the largest nontrivial multiplier's modulus, ``n_segments``,
        ``residual``), on ``point`` the special points (``point_<param>``,
        ``point_kind``, ``point_period``, ``point_residual``).

    Raises
    ------
    ValueError
        one line: an unknown parameter, a span that is not a finite pair with lo < hi or
        does not hold the orbit's value, a model that cannot be resolved.

    Examples
    --------
    Den Hartog's non-stop orbit (Omega = 0.8), followed in the friction until its
    reversals turn into stops:

    >>> import phasemap
    >>> o = phasemap.periodic_orbit("den_hartog", start={"f": 0.2})
    >>> b = phasemap.continue_orbit(o, "f", (0.2, 0.5), steps=12)     # doctest: +SKIP
    >>> str(b.point_kind.values[0]), round(float(b.point_f[0]), 6)     # doctest: +SKIP
    ('crossing_sliding', ...)
    """
    S = _orbit.system_of(model if model is not None else orbit.attrs["phasemap_model"])
    from phasemap.declare.full import mechanics

    mech = mechanics(S)
    name = mech.name
    if param not in mech.parameters:
        raise ValueError(f"{name}: unknown parameter {param!r}; the parameters are "
                         f"{', '.join(mech.parameters)}")
    try:
        lo, hi = (float(x) for x in span)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: span must be a pair (lo, hi) of numbers, got "
                         f"{_args.describe(span)}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"{name}: span must be finite with lo < hi, got ({lo:g}, {hi:g})")
    steps = _args.count("steps", steps, name)
    rtol = float(orbit.attrs.get("phasemap_rtol", 1e-12)) if rtol is None else float(rtol)
    p0 = np.array([float(orbit.attrs[f"phasemap_parameter_{nm}"]) for nm in mech.parameters])
    i_par = mech.parameters.index(param)
    lam0 = float(p0[i_par])
    if not lo - 1e-12 * (hi - lo) <= lam0 <= hi + 1e-12 * (hi - lo):
        raise ValueError(f"{name}: the orbit's {param} = {lam0:g} is outside the span "
                         f"({lo:g}, {hi:g})")
    segs, w, t_a = _from_dataset(mech, orbit, p0, rtol)
    h = (hi - lo) / steps
    ctx = _Context(name, mech, p0, i_par, rtol, tol, locate * (hi - lo), t_a)
    points, marks = [ctx.point(lam0, segs, w, float(orbit.residual))], []
    for d, end in ((1.0, hi), (-1.0, lo)):
        if abs(end - lam0) <= 1e-12 * (hi - lo):
            continue
        ctx.t_a, ctx.jac = t_a, []      # each direction from the orbit's own start
        got, special = ctx.follow(lam0, segs, w, d * h, end)
        points += got
        marks += special
    order = sorted(range(len(points)), key=lambda i: points[i]["lam"])
    points = [points[i] for i in order]
    marks.sort(key=lambda m: m["lam"])
    return _branch_dataset(S, mech, param, points, marks, (lo, hi))


class _Context:
    """What one continuation keeps: the system, the parameters, the tolerances."""

    def __init__(self, name, mech, p0, i_par, rtol, tol, locate, t_a):
        self.name, self.mech, self.p0, self.i = name, mech, p0, i_par
        self.rtol, self.tol, self.locate, self.t_a = rtol, tol, locate, t_a
        self.jac = []       # the last shooting Jacobian (the chord method's)

    def params(self, lam):
        p = self.p0.copy()
        p[self.i] = lam
        return p

    def motion(self, lam):
        return Motion(self.mech, self.params(lam), Options(1.0, rtol=self.rtol))

    def forcing(self, lam):
        per = self.mech.period
        return None if per is None else float(per(*self.params(lam)))

    def shoot(self, lam, segs, w, max_iter=30):
        motion = self.motion(lam)
        n = self.mech.n
        z = w[:2 * n]
        sc = motion.scales(z[:n], z[n:], self.mech.pieces(z[:n], z[n:], motion.p, self.t_a))
        segs = [Segment(s.modes, s.rho, s.index, s.kind) for s in segs]
        w, res = _orbit._shoot(self.name, motion, segs, w, self.t_a, self.forcing(lam),
                               self.rtol, self.tol, sc, max_iter, self.jac)
        return w, res

    def point(self, lam, segs, w, res=0.0):
        motion = self.motion(lam)
        mult, trivial, stable, _ = _orbit.linearised(motion, segs, w, self.t_a,
                                                     self.forcing(lam), self.rtol)
        low, high = _extrema(motion, segs, w, self.t_a, self.rtol)
        others = np.delete(mult, trivial) if trivial >= 0 else mult
        n2 = 2 * self.mech.n
        return {"lam": lam, "w": w, "segs": segs, "period": float(np.sum(w[len(segs) * n2:])),
                "amplitude": (high - low) / 2,
                "stable": stable, "mult": others,
                "floquet_max": float(np.abs(others).max()) if others.size else 0.0,
                "residual": res}

    def admissible(self, lam, segs, w) -> bool:
        """Whether every segment's phase holds all along it (its conditions, such as a
        stuck contact's friction slack, never dip below zero inside it, minima between
        samples located), and the motion itself runs through the orbit's mode
        sequence."""
        n2 = 2 * self.mech.n
        K = len(segs)
        if np.any(w[K * n2:] <= 0.0):
            return False
        if _dips(self.motion(lam), segs, w, self.t_a, self.rtol):
            return False
        return _same(_sequence(self, lam, segs, w), [s.modes for s in segs])

    def follow(self, lam0, segs, w, h, end):
        """The branch from ``lam0`` towards ``end`` in steps ``h``: its points and its
        special points."""
        points, marks = [], []
        lam, prev = lam0, None
        while (end - lam) * h > 1e-12 * abs(h):
            step = h if abs(end - lam) > abs(h) else end - lam
            for _ in range(8):          # shorter steps where Newton's method fails
                new = lam + step
                guess = w if prev is None else w + (w - prev[1]) * (step / (lam - prev[0]))
                try:
                    w_new, res = self.shoot(new, segs, guess)
                    break
                except ValueError:
                    step /= 4
            else:
                marks.append(self.mark(lam, segs, w, "fold", 0.0))
                return points, marks
            if self.admissible(new, segs, w_new):
                point = self.point(new, segs, w_new, res)
                doubling = _crossed_minus_one(points[-1]["mult"] if points else None,
                                              point["mult"])
                if doubling:
                    marks.append(self.mark(new, segs, w_new, "period_doubling", res))
                points.append(point)
                prev, lam, w = (lam, w), new, w_new
                continue
            # the sequence changes between lam and new: bisection on the old sequence
            # (where its orbit stops existing, Newton's method failing, counts as beyond)
            a, wa, b, wb = lam, w, new, w_new
            while abs(b - a) > self.locate:
                mid = 0.5 * (a + b)
                guess = wa if wb is None else wa + (wb - wa) * ((mid - a) / (b - a))
                try:
                    wm, _ = self.shoot(mid, segs, guess, max_iter=8)
                except ValueError:
                    b, wb = mid, None
                    continue
                if self.admissible(mid, segs, wm):
                    a, wa = mid, wm
                else:
                    b, wb = mid, wm
            # the new sequence, read a little beyond (where its new segment has a length
            # the motion resolves), then followed from there
            past = b + math.copysign(max(10 * self.locate, 1e-6 * abs(h)), h)
            kind, new_segs, w_next = self.beyond(past, segs, wa if wb is None else wb)
            marks.append(self.mark(a, segs, wa, kind, 0.0))
            if new_segs is None:
                return points, marks
            try:
                w_next, res = self.shoot(past, new_segs, w_next)
            except ValueError:
                return points, marks
            points.append(self.point(past, new_segs, w_next, res))
            prev, lam, w, segs = None, past, w_next, new_segs
        marks.append(self.mark(lam, segs, w, "end", 0.0))
        return points, marks

    def beyond(self, lam, segs, w):
        """The kind of the sequence change and the new segments, from the motion just
        beyond ``lam`` (it settles on the new orbit near the old one)."""
        n = self.mech.n
        p = self.params(lam)
        motion = self.motion(lam)
        z = w[:2 * n]
        sc = motion.scales(z[:n], z[n:], self.mech.pieces(z[:n], z[n:], p, self.t_a))
        forcing = self.forcing(lam)
        scale_t = math.sqrt(sc[3] / sc[2])
        T = float(np.sum(w[len(segs) * 2 * n:]))
        try:
            rec, (t_a, t_b, z0) = _orbit._settled(
                self.name, self.mech, p, z[:n], z[n:], self.t_a + 50 * T, self.rtol,
                forcing, sc, scale_t) if forcing is None else _settle_forced(
                self, lam, z, T, sc)
            new_segs, w_new = _orbit._segments(self.name, motion, rec, t_a, t_b, z0,
                                               forcing, sc)
        except ValueError:
            return "sequence_change", None, None
        self.t_a, self.jac = _orbit.phase_time(t_a, forcing), []
        return _kind(segs, new_segs), new_segs, w_new

    def mark(self, lam, segs, w, kind, res):
        n2 = 2 * self.mech.n
        return {"lam": lam, "kind": kind, "period": float(np.sum(w[len(segs) * n2:])),
                "residual": res}


def _settle_forced(ctx, lam, z, T, sc):
    n = ctx.mech.n
    forcing = ctx.forcing(lam)
    mult = max(1, round(T / forcing))
    rec = _orbit._run(ctx.mech, ctx.params(lam), z[:n], z[n:], ctx.t_a,
                      ctx.t_a + 40 * mult * forcing, ctx.rtol, forcing)
    return rec, _orbit._cycle(ctx.name, rec, forcing, sc)


def _extrema(motion, segs, w, t_a, rtol):
    """Each coordinate's least and greatest value over the orbit: at the segments' ends,
    or where its rate vanishes inside one (located on the segment's dense output)."""
    from scipy.optimize import brentq

    n = motion.n
    n2 = 2 * n
    K = len(segs)
    zs, taus = _orbit._unpack(w, K, n2)
    low, high = np.full(n, np.inf), np.full(n, -np.inf)
    t = t_a
    for j, seg in enumerate(segs):
        sol = _orbit._flow(motion, zs[j], t, taus[j], seg, rtol, dense=True).sol
        ts = np.linspace(t, t + taus[j], SAMPLES // K + 2)
        ys = sol(ts)
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
    return low, high


#: Samples per segment where its conditions are checked for a dip below zero.
DIP_SAMPLES = 24


def _dips(motion, segs, w, t_a, rtol) -> bool:
    """Whether a condition of a segment's phase (its event functions but the one that
    ends it) goes below zero inside the segment: sampled, and each sampled minimum near
    zero refined on the dense output (a tangency between samples is found)."""
    from scipy.optimize import minimize_scalar

    n = motion.n
    n2 = 2 * n
    K = len(segs)
    zs, taus = _orbit._unpack(w, K, n2)
    t = t_a
    z0 = zs[0]
    sc = motion.scales(z0[:n], z0[n:], motion.mech.pieces(z0[:n], z0[n:], motion.p, t_a))
    scale = max(sc)
    for j, seg in enumerate(segs):
        sol = _orbit._flow(motion, zs[j], t, taus[j], seg, rtol, dense=True).sol

        def watch(s, seg=seg, sol=sol):
            y = sol(s)
            out = motion.watch(y[:n], y[n:], seg.modes, seg.rho, sc, s)[:2 * motion.k]
            if seg.index is not None and seg.index < out.size:
                out = np.delete(out, seg.index)
            return out

        ts = np.linspace(t, t + taus[j], DIP_SAMPLES)[1:-1]
        vals = np.array([watch(s) for s in ts])
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


def _sequence(ctx, lam, segs, w):
    """The modes the hybrid motion from the orbit's start goes through in one period."""
    n2 = 2 * ctx.mech.n
    K = len(segs)
    z, T = w[:n2], float(np.sum(w[K * n2:]))
    rec = Motion(ctx.mech, ctx.params(lam), Options(ctx.t_a + T, rtol=ctx.rtol,
                                                    max_events=10_000)).run(
        z[:n2 // 2], z[n2 // 2:], t0=ctx.t_a)
    if rec.fate != ev.HORIZON:
        return None
    eps = 1e-10 * T
    seq = [tuple(rec.ev_modes[0])]
    for t, kind, modes in zip(rec.ev_t, rec.ev_kind, rec.ev_modes):
        if kind in (ev.START, ev.HORIZON):
            continue
        if t <= ctx.t_a + eps:
            seq[0] = tuple(modes)
        elif t < ctx.t_a + T - eps:
            seq.append(tuple(modes))
    return seq


def _merged(seq, cyclic):
    out = []
    for m in seq:
        if not out or out[-1] != tuple(m):
            out.append(tuple(m))
    if cyclic and len(out) > 1 and out[0] == out[-1]:
        out.pop()
    return out


def _same(seq, modes) -> bool:
    if seq is None:
        return False
    return _merged(seq, True) == _merged(modes, True)


def _kind(old, new) -> str:
    """The name of a change of the mode sequence from ``old`` to ``new`` segments."""
    def sticks(segs):
        return sum(any(m == STICK for m in s.modes) for s in segs)

    def reversals(segs):
        return sum(s.kind == ev.REVERSAL for s in segs)

    if sticks(new) > sticks(old):
        return "crossing_sliding" if reversals(old) > reversals(new) else "grazing_sliding"
    if sticks(new) < sticks(old):
        return "crossing_sliding" if reversals(new) > reversals(old) else "sequence_change"
    return "sequence_change"


def _crossed_minus_one(before, after) -> bool:
    if before is None or after is None:
        return False
    real_b = [x.real for x in before if abs(x.imag) <= 1e-9]
    real_a = [x.real for x in after if abs(x.imag) <= 1e-9]
    return bool(real_b and real_a and min(real_b) > -1.0 >= min(real_a))


def _from_dataset(mech, orbit, p0, rtol):
    """The segments and unknowns of a periodic-orbit Dataset."""
    motion = Motion(mech, p0, Options(1.0, rtol=rtol))
    K = orbit.sizes["segment"]
    names = list(mech.coordinates) + list(mech.rates)
    zs = [np.array([float(orbit[f"segment_{nm}"][j]) for nm in names]) for j in range(K)]
    n = mech.n
    t_a = float(orbit.segment_start[0])
    sc = motion.scales(zs[0][:n], zs[0][n:], mech.pieces(zs[0][:n], zs[0][n:], p0, t_a))
    segs = []
    for j in range(K):
        modes = tuple(int(orbit[f"segment_mode_{c.name}"][j]) for c in mech.contacts)
        index = int(orbit.segment_event_index[j])
        rho = _orbit._rho(motion, zs[j], modes, float(orbit.segment_start[j]), sc)
        segs.append(Segment(modes, rho, None if index < 0 else index,
                            int(orbit.segment_end[j])))
    w = np.concatenate(zs + [orbit.segment_duration.values.astype(float)])
    return segs, w, t_a


def _branch_dataset(S, mech, param, points, marks, span):
    import xarray as xr

    from phasemap._version import __version__
    from phasemap.atlas.dataset import CONVENTIONS, created

    n = mech.n
    par = next(q for q in S.parameters if q.name == param)
    data = {
        param: ("vertex", np.array([p["lam"] for p in points]), {
            "long_name": par.long_name, "units": par.units}),
        "period": ("vertex", np.array([p["period"] for p in points]), {
            "long_name": "period of the orbit", "units": "s"}),
        "stable": ("vertex", np.array([p["stable"] for p in points], dtype=np.int8), {
            "long_name": "orbit stability", "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "unstable stable"}),
        "floquet_max": ("vertex", np.array([p["floquet_max"] for p in points]), {
            "long_name": "largest modulus of a nontrivial Floquet multiplier", "units": "1"}),
        "n_segments": ("vertex", np.array([len(p["segs"]) for p in points], dtype=np.int32), {
            "long_name": "segments (phases) of the orbit in one period"}),
        "residual": ("vertex", np.array([p["residual"] for p in points]), {
            "long_name": "largest residual of the shooting equations", "units": "1"}),
        f"point_{param}": ("point", np.array([m["lam"] for m in marks]), {
            "long_name": f"{par.long_name} at the special point", "units": par.units}),
        "point_kind": ("point", np.array([m["kind"] for m in marks], dtype=object), {
            "long_name": "kind of the special point"}),
        "point_period": ("point", np.array([m["period"] for m in marks]), {
            "long_name": "period of the orbit at the special point", "units": "s"}),
        "point_residual": ("point", np.array([m["residual"] for m in marks]), {
            "long_name": "residual of the shooting equations at the special point"}),
    }
    rated = {c.name for c in S.coordinates if c.rate is not None}
    for j, (c, u) in enumerate(zip(mech.coordinates, mech.units)):
        if j < n and c in rated:
            data[f"amplitude_{c}"] = ("vertex", np.array([p["amplitude"][j] for p in points]),
                                      {"long_name": f"half the range of {c} over the orbit",
                                       "units": u})
    attrs = {"Conventions": CONVENTIONS, "title": f"phasemap orbit branch: {S.title}",
             "source": f"phasemap {__version__}", "references": S.citation,
             "phasemap_version": __version__, "date_created": created(),
             "phasemap_kind": "orbit_branch", "phasemap_model": S.name,
             "phasemap_parameter": param, "phasemap_span": np.array(span, dtype=float),
             "phasemap_modes": " ".join(MODE_NAMES)}
    return xr.Dataset(data, attrs=attrs)
