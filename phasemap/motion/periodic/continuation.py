"""A periodic orbit followed in a parameter, through the changes of its mode sequence
(see :mod:`phasemap.motion.periodic`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from phasemap.core import args as _args
from phasemap.core import events as ev
from phasemap.motion.hybrid import MODE_NAMES, Motion, Options
from phasemap.motion.periodic import orbit as _orbit
from phasemap.motion.periodic import segments, sliding
from phasemap.motion.periodic.arclength import doubling_test, parabola, torus_test, unit
from phasemap.motion.periodic.orbit import Segment
from phasemap.motion.periodic.sampling import dips, extrema

#: The longest step along a branch, in the arclength's metric: two nominal steps (a
#: nominal step, a change of the parameter by (hi - lo) / steps with the orbit's change
#: over it, is sqrt(2) long).
DS_MAX = 2.0 * math.sqrt(2.0)


def continue_orbit(orbit, param: str, span, *, model=None, steps: int = 40,
                   rtol: float | None = None, tol: float = 1e-10, locate: float = 1e-10,
                   max_points: int | None = None):
    """Follow the periodic orbit ``orbit`` (a :func:`phasemap.periodic_orbit` Dataset) in
    the parameter ``param`` across ``span = (lo, hi)``.

    The orbit is continued by pseudo-arclength: a first step of ``(hi - lo) / steps`` in
    the parameter, then steps along the secant of the last two points, each corrected by
    Newton's method on the multiple-shooting equations of :func:`phasemap.periodic_orbit`
    with the parameter an unknown, on the hyperplane normal to the secant.  The
    arclength measures the parameter in units of that first step and the orbit's
    unknowns in units of their change per such step (read off the first one), so that a
    branch that does not turn takes about ``steps`` steps; a step grows (to twice that)
    where Newton's method converges at once and shrinks where it fails.  Where the parameter turns, the branch goes round the
    fold, which is located as the parameter's extremum along the branch and marked
    ``fold``.  After every step the orbit is checked against the motion itself: the hybrid
    motion from the orbit's start, run for one period, must go through the same mode
    sequence (no event inside a segment, each phase admissible all along).  Where it does
    not, the mode sequence changes between the two steps: the parameter where it changes is located by
    bisection to ``locate`` (relative to the span), the point is named, the new sequence
    is read from the motion just beyond it, and the continuation goes on with it, without
    the user's help: first from one period of the motion started on the old orbit (it
    goes through the new sequence near the old orbit, stable or not), else from the
    motion settled (which may be on an orbit of another period: the branch goes on along
    it).  Where a real Floquet multiplier passes -1 between two
    points of one sequence, the period doubling is located (Brent's method on the
    multipliers along the branch) and is a point of the branch too; a complex pair
    through the unit circle is located the same way and marked ``torus``.  Where
    Newton's method stops converging, even in steps 4^7 times shorter, the branch ends
    there, marked ``no_convergence``.

    Kinds of special points: the sliding bifurcations, where segments of zero length
    appear in the orbit or shrink into it (:mod:`phasemap.motion.periodic.sliding`
    names them from the two sequences and their segments' durations):
    ``crossing_sliding`` (a stick between opposite slips: a reversal reaches the edge of
    the sticking region), ``grazing_sliding`` (a stick inside a slip), ``adding_sliding``
    (a slip and a stick after a stick), ``switching_sliding`` (a slip the other way
    between a stick and a slip); ``sequence_change`` (another change of the mode
    sequence, among them a stuck contact's friction limit reached tangentially inside
    its stick segment), ``period_doubling``, ``torus``, ``fold`` (the parameter turns),
    ``continuum`` (beyond a change of the sequence the orbits form a continuum, a family
    through the nearby states: the branch ends there), ``no_convergence``,
    ``max_points`` (the branch has ``max_points`` points: a closed branch, an isola,
    goes round for ever) and ``end`` (the end of the span).  Crossing-sliding is checked
    against an independent computation (Den Hartog's stops); the other three are named
    by the same rule but no test meets them in a physical system yet.

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
    max_points : int, optional
        the most points in each direction from the orbit (default ``10 * steps + 10``).

    Returns
    -------
    xarray.Dataset
        shaped like that of :func:`phasemap.threshold` with ``along=``: on ``vertex``
        the branch in its order along the arc (first the part followed towards ``lo``,
        reversed) (``<param>``, ``period``, ``amplitude_<coordinate>``, ``stable``,
        ``floquet_max``: the largest nontrivial multiplier's modulus, ``n_segments``,
        ``residual``; a forced orbit's states at the forcing's phase 0,
        ``section_<variable>`` on ``(vertex, section)``, the points
        :func:`phasemap.orbit_diagram` samples), on ``point`` the special points
        (``point_<param>``, ``point_kind``, ``point_period``, ``point_residual``).

    Raises
    ------
    ValueError
        one line: an unknown parameter, a span that is not a finite pair with lo < hi or
        does not hold the orbit's value, a model that cannot be resolved, an orbit that
        is one of a continuum (``orbit.continuum``).

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
    _orbit.no_rolling(mech)
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
    if int(orbit.get("continuum", 0)):
        raise ValueError(f"{name}: the orbit is one of a continuum (a family of periodic "
                         "orbits through the nearby states: a multiplier 1 besides the "
                         "flow's), so it has no branch of its own to follow")
    segs, w, t_a = _from_dataset(mech, orbit, p0, rtol)
    h = (hi - lo) / steps
    max_points = 10 * steps + 10 if max_points is None else _args.count(
        "max_points", max_points, name)
    ctx = _Context(name, mech, p0, i_par, rtol, tol, locate * (hi - lo), t_a, (lo, hi),
                   max_points)
    points, marks = [ctx.point(lam0, segs, w, float(orbit.residual))], []
    for d, end in ((-1.0, lo), (1.0, hi)):
        if abs(end - lam0) <= 1e-12 * (hi - lo):
            continue
        ctx.start(t_a)      # each direction from the orbit's own start
        got, special = ctx.follow(lam0, segs, w, d * h, end)
        if d < 0:           # the branch in its order along the arc, from the lo side
            points, marks = got[::-1] + points, special[::-1] + marks
        else:
            points, marks = points + got, marks + special
    return _branch_dataset(S, mech, param, points, marks, (lo, hi))


class _Context:
    """What one continuation keeps: the system, the parameters, the tolerances."""

    def __init__(self, name, mech, p0, i_par, rtol, tol, locate, t_a, span, max_points):
        self.name, self.mech, self.p0, self.i = name, mech, p0, i_par
        self.rtol, self.tol, self.locate, self.t_a = rtol, tol, locate, t_a
        self.lo, self.hi = span
        self.max_points = max_points
        self._traced = self._motion = None
        self.start(t_a)

    def start(self, t_a):
        """A fresh start of the branch from the orbit (each direction its own)."""
        self.t_a = t_a
        self.jac = []       # the last shooting Jacobian (the chord method's)
        self.arc_jac = None     # the same with the parameter's column (the corrector's)
        self.w_scale = self.ds = None       # the arclength's metric and step
        self._arc_prev = None               # the last step's two points

    def params(self, lam):
        p = self.p0.copy()
        p[self.i] = lam
        return p

    def motion(self, lam):
        """The motion at ``lam`` that the segments are integrated on (the last one kept:
        a step asks for it again and again, and a segment changes nothing in it)."""
        if self._motion is None or self._motion[0] != lam:
            self._motion = (lam, Motion(self.mech, self.params(lam),
                                        Options(1.0, rtol=self.rtol)))
        return self._motion[1]

    def forcing(self, lam):
        per = self.mech.period
        return None if per is None else float(per(*self.params(lam)))

    def shoot(self, lam, segs, w, max_iter=30):
        motion = self.motion(lam)
        sc = self.scale_of(motion, w)
        segs = [dataclasses.replace(s) for s in segs]
        w, res = _orbit._shoot(self.name, motion, segs, w, self.t_a, self.forcing(lam),
                               self.rtol, self.tol, sc, max_iter, self.jac)
        return w, res

    def traced(self, lam, segs, w):
        """The orbit ``w``'s segments at ``lam``, each integrated once for all of its
        checks (:class:`~phasemap.motion.periodic.segments.Traced`): the last orbit's
        kept, for its admissibility and its point ask for the same one."""
        last = self._traced
        if not (last is not None and last[0] == (lam, self.t_a) and last[1] is segs
                and np.array_equal(last[2], w)):
            w = w.copy()        # (the key and the segments' starts: the caller's may change)
            self._traced = last = ((lam, self.t_a), segs, w, segments.Traced(
                self.motion(lam), segs, w, self.t_a, self.rtol))
        return last[3]

    def point(self, lam, segs, w, res=0.0):
        traced = self.traced(lam, segs, w)
        motion = traced.motion
        low, high, strobes = extrema(motion, segs, w, self.t_a, self.rtol, self.forcing(lam),
                                     traced)
        mult, trivial, stable, _, continuum = _orbit.linearised(
            motion, segs, w, self.t_a, self.forcing(lam), self.rtol, traced=traced)
        others = np.delete(mult, trivial) if trivial >= 0 else mult
        n2 = 2 * self.mech.n
        return {"lam": lam, "w": w, "segs": segs, "period": float(np.sum(w[len(segs) * n2:])),
                "amplitude": (high - low) / 2, "strobes": strobes,
                "stable": stable, "mult": others,
                "floquet_max": float(np.abs(others).max()) if others.size else 0.0,
                "residual": res, "continuum": continuum}

    def admissible(self, lam, segs, w) -> bool:
        """Whether every segment's phase holds all along it (its conditions, such as a
        stuck contact's friction slack, never dip below zero inside it, minima between
        samples located), and the motion itself runs through the orbit's mode
        sequence."""
        n2 = 2 * self.mech.n
        K = len(segs)
        if np.any(w[K * n2:] <= 0.0):
            return False
        traced = self.traced(lam, segs, w)
        if dips(traced.motion, segs, w, self.t_a, self.rtol, traced):
            return False
        return _same(_sequence(self, lam, segs, w), [s.modes for s in segs])

    def scale_of(self, motion, w):
        """The scales of the orbit ``w``'s start (held through one solve)."""
        n = self.mech.n
        z = w[:2 * n]
        return motion.scales_at(z[:n], z[n:], self.t_a)

    def residual(self, lam, segs, w, sc):
        """The shooting equations at ``(w, lam)``, with the pieces of their Jacobian."""
        motion = self.motion(lam)
        ends, starts = _orbit._ends(motion, segs, w, self.t_a, self.rtol, sc)
        r = _orbit._residual(motion, segs, w, ends, self.forcing(lam), sc)
        return r, (motion, ends, starts)

    def jacobian(self, lam, segs, w, sc, r, pieces):
        """The shooting equations' Jacobian in ``(w, lam)``: the orbit's columns as in
        :func:`phasemap.motion.periodic.orbit.jacobian`, the parameter's by a difference."""
        motion, ends, starts = pieces
        J = _orbit.jacobian(motion, segs, w, ends, starts, self.forcing(lam), self.rtol, sc)
        h = 0.1 * math.sqrt(self.rtol) * max(1.0, abs(lam))
        return np.column_stack([J, (self.residual(lam + h, segs, w, sc)[0] - r) / h])

    def correct(self, segs, X_pred, t, D, max_iter=12):
        """Newton's method on the shooting equations and the pseudo-arclength condition
        (the orbit on the hyperplane through ``X_pred`` normal to ``t`` in the metric
        ``D``): ``(X, residual, iterations)``; ValueError where it does not converge.  The
        Jacobian is a chord kept along the branch, updated by Broyden's rule after every
        step taken (about two steps a point from :meth:`arc`'s parabola, where the chord
        alone from the secant took four or five), and computed afresh where a step does
        not contract the residual tenfold."""
        K = len(segs)
        N = X_pred.size - 1
        X = X_pred.copy()
        sc = self.scale_of(self.motion(X[-1]), X[:N])
        r, pieces = self.residual(X[-1], segs, X[:N], sc)
        res = float(np.max(np.abs(r)))
        M, fresh = None, False
        if self.arc_jac is not None and self.arc_jac.shape == (r.size, N + 1):
            M = np.vstack([self.arc_jac, t * D])        # the last one first (a chord)
        for it in range(max_iter):
            if res <= 0.1 * self.tol:
                return X, res, it
            if M is None:
                self.arc_jac = self.jacobian(X[-1], segs, X[:N], sc, r, pieces)
                M = np.vstack([self.arc_jac, t * D])
                fresh = True
            rhs = np.concatenate([r, [float(t * D @ (X - X_pred))]])
            step = np.linalg.lstsq(M, rhs, rcond=None)[0]
            for _ in range(8):
                trial = X - step
                if np.all(trial[N - K:N] > 0):
                    r_t, pieces_t = self.residual(trial[-1], segs, trial[:N], sc)
                    res_t = float(np.max(np.abs(r_t)))
                    if res_t < res:
                        break
                step = step / 2
            else:
                if fresh:
                    break
                M = None            # the chord went stale: a fresh Jacobian
                continue
            contraction = res_t / res
            dx = trial - X          # Broyden's update of the chord along the step taken
            self.arc_jac = self.arc_jac + np.outer(r_t - r - self.arc_jac @ dx,
                                                   dx / float(dx @ dx))
            M = np.vstack([self.arc_jac, t * D])
            X, r, pieces, res = trial, r_t, pieces_t, res_t
            if contraction > 0.1:
                M, fresh = None, False
            else:
                fresh = False
        if res <= max(self.tol, 10 * self.rtol):
            return X, res, max_iter
        raise ValueError(f"{self.name}: the pseudo-arclength corrector did not converge "
                         f"(residual {res:.2g})")

    def follow(self, lam0, segs, w, h, end):
        """The branch from ``lam0`` in the direction of ``h`` until the parameter leaves
        the span at ``end`` (or at the span's other end, after a fold), by steps of
        pseudo-arclength: its points and its special points."""
        lo, hi = sorted((self.lo, self.hi))
        points, marks = [], []
        lam = lam0
        # a first step in the parameter, then secants along the branch
        first = self.natural(lam, segs, w, h, end)
        if first is None:
            marks.append(self.mark(lam, segs, w, "no_convergence", 0.0))
            return points, marks
        new, w_new, res = first
        last = {"mult": self.multipliers(lam, segs, w)}       # the point at lam
        while True:
            if not self.admissible(new, segs, w_new):
                got = self.change(lam, segs, w, new, w_new, h)
                marks.append(got[0])
                if got[1] is None:
                    return points, marks
                point, segs = got[1], got[1]["segs"]
                points.append(point)
                last = point
                lam, w = point["lam"], point["w"]
                h = math.copysign(abs(h), got[2])
                first = self.natural(lam, segs, w, h, hi if h > 0 else lo)
                if first is None:
                    marks.append(self.mark(lam, segs, w, "no_convergence", 0.0))
                    return points, marks
                new, w_new, res = first
                if len(points) >= self.max_points:
                    marks.append(self.mark(lam, segs, w, "max_points", 0.0))
                    return points, marks
                continue
            point = self.point(new, segs, w_new, res)
            for test in (doubling_test, torus_test):
                if (test(last["mult"]) > 0) != (test(point["mult"]) > 0):
                    got = self.doubling(lam, w, new, w_new, segs, h, test)
                    if got is not None:
                        marks.append(got[0])
                        points.append(got[1])
            points.append(point)
            last = point
            if not lo + 1e-12 * (hi - lo) < new < hi - 1e-12 * (hi - lo):
                marks.append(self.mark(new, segs, w_new, "end", 0.0))
                return points, marks
            if len(points) >= self.max_points:
                marks.append(self.mark(new, segs, w_new, "max_points", 0.0))
                return points, marks
            step = self.arc(lam, w, new, w_new, segs, h, lo, hi)
            if step is None:
                # the secant is no tangent (after a change of the sequence, it spans a
                # new segment's square-root growth): a step in the parameter, then
                # secants from there
                toward = math.copysign(abs(h), new - lam) if new != lam else h
                nat = self.natural(new, segs, w_new, toward, hi if toward > 0 else lo)
                if nat is None:
                    marks.append(self.mark(new, segs, w_new, "no_convergence", 0.0))
                    return points, marks
                self.ds = self._arc_prev = None     # (the next parabola not through a)
                lam, w = new, w_new
                new, w_new, res = nat
                continue
            X, res, fold = step
            # the fold itself, a point of the branch too, where its orbit is admissible
            # (else the sequence changes before it, which the next step locates)
            if fold is not None and (fold[1] is None or self.admissible(
                    fold[1]["lam"], segs, fold[1]["w"])):
                marks.append(fold[0])
                if fold[1] is not None:
                    points.insert(len(points) - fold[2], fold[1])
            lam, w, new, w_new = new, w_new, float(X[-1]), X[:-1]

    def natural(self, lam, segs, w, h, end):
        """One step in the parameter (shorter where Newton's method fails): ``(lam, w,
        residual)`` or None."""
        step = h if abs(end - lam) > abs(h) else end - lam
        for _ in range(8):
            try:
                w_new, res = self.shoot(lam + step, segs, w)
                return lam + step, w_new, res
            except ValueError:
                step /= 4
        return None

    def arc(self, lam_a, w_a, lam_b, w_b, segs, h, lo, hi):
        """The next point along the secant from ``a`` through ``b``, a pseudo-arclength
        step as long as the last (longer where it converged at once, shorter where it
        failed), the parameter cut at the span's ends: ``(X, residual, fold)`` (``fold``:
        :meth:`fold`'s, where the parameter turned), or None where it does not converge."""
        Xa, Xb = np.append(w_a, lam_a), np.append(w_b, lam_b)
        D = self.metric(Xa, Xb, h)
        t, L = unit(Xb - Xa, D)
        ds = self.ds if self.ds else L
        # the point before a, where the last step was from it to a: a parabola through
        # the three predicts better than the secant (one Newton step fewer a point)
        prev, self._arc_prev = self._arc_prev, (Xa, Xb)
        Xz = prev[0] if (prev is not None and prev[0].size == Xa.size
                         and np.array_equal(prev[1], Xa)) else None
        for _ in range(8):
            X_pred = Xb + ds * t if Xz is None else parabola(Xz, Xa, Xb, ds, D)
            if not lo <= X_pred[-1] <= hi:      # beyond the span: the secant's step, as
                X_pred = Xb + ds * t            # it lands on the end (never behind b)
            over = (X_pred[-1] - hi) if X_pred[-1] > hi else (lo - X_pred[-1]) if (
                X_pred[-1] < lo) else 0.0
            if over > 0 and abs(t[-1]) > 0:     # the span's end: land on it
                ds = ds * (1 - over / abs(ds * t[-1]))
                X_pred = Xb + ds * t
            try:
                X, res, iters = self.correct(segs, X_pred, t, D)
            except ValueError:
                ds /= 4
                continue
            turned = (X[-1] - lam_b) * (lam_b - lam_a) < 0
            if not turned and (over > 0 or not lo <= X[-1] <= hi):  # the span's end exactly
                X[-1] = hi if X[-1] > 0.5 * (lo + hi) else lo
                try:
                    X[:-1], res = self.shoot(float(X[-1]), segs, X[:-1])
                except ValueError:
                    ds /= 4
                    continue
            self.ds = min(ds * (1.5 if iters <= 3 else 1.0), DS_MAX)
            fold = None
            if (X[-1] - lam_b) * (lam_b - lam_a) < 0:
                fold = self.fold(Xa, Xb, X, segs, D)
            return X, res, fold
        return None

    def metric(self, Xa, Xb, h):
        """The arclength's metric: the parameter in units of the nominal step ``h``, the
        orbit's unknowns in units of their change per nominal step, read off the first
        step of the branch (or of its sequence) from ``a`` to ``b``."""
        if self.w_scale is None:        # the orbit's change per nominal step
            dw = np.abs(Xb[:-1] - Xa[:-1])
            per = min(abs(h / (Xb[-1] - Xa[-1])), 1e3) if Xb[-1] != Xa[-1] else 1.0
            self.w_scale = max(float(np.sqrt(np.mean(dw * dw))) * per,
                               1e-3 * (1.0 + float(np.abs(Xb[:-1]).max())))
        N = Xa.size - 1
        return np.append(np.full(N, 1.0 / (N * self.w_scale**2)), 1.0 / h**2)

    def fold(self, Xa, Xb, Xc, segs, D):
        """The fold between the points ``a`` and ``c`` (the parameter turns at ``b``):
        the greatest (or least) parameter along the branch, on the hyperplanes normal to
        the chord from ``a`` to ``c``: ``(mark, point, 1 where it lies before b else
        0)``; the point is None where the fold is b itself (already a point)."""
        from scipy.optimize import minimize_scalar

        t, L = unit(Xc - Xa, D)
        sign = 1.0 if Xb[-1] > Xa[-1] else -1.0
        found = {}

        def minus(sig):
            try:
                X, res, _ = self.correct(segs, Xa + sig * L * t, t, D)
            except ValueError:
                return math.inf
            found[sig] = (X, res)
            return -sign * X[-1]

        s_b = float(t * D @ (Xb - Xa)) / L
        known = {0.0: Xa, s_b: Xb, 1.0: Xc}      # b is on its own hyperplane
        for sig, X in known.items():
            found[sig] = (X, 0.0)

        def value(sig):
            return -sign * known[sig][-1] if sig in known else minus(sig)

        try:
            best = minimize_scalar(value, bracket=(0.0, s_b, 1.0), options={"xtol": 1e-7})
            X, res = found[best.x]
            at_b = best.x == s_b
        except (ValueError, KeyError):      # no bracket after all: b, the turning point
            X, res, at_b = Xb, 0.0, True
        lam = float(X[-1])
        point = None if at_b else self.point(lam, segs, X[:-1], res)   # b is a vertex
        return (self.mark(lam, segs, X[:-1], "fold", res, point), point,
                int(not at_b and best.x < s_b))

    def multipliers(self, lam, segs, w):
        """The orbit's Floquet multipliers but the trivial one."""
        mult, trivial, _, _, _ = _orbit.linearised(self.motion(lam), segs, w, self.t_a,
                                                self.forcing(lam), self.rtol)
        return np.delete(mult, trivial) if trivial >= 0 else mult

    def doubling(self, lam, w, new, w_new, segs, h, test=None):
        """The period doubling or torus point between the orbits at ``lam`` and ``new``:
        the root (Brent's method) of ``test`` (:func:`~.arclength.doubling_test`, the
        default, or :func:`~.arclength.torus_test`) along the branch, on the hyperplanes
        normal to the chord between them: ``(mark, point)``, its kind read from the
        multipliers there (a real one at -1, or a complex pair on the unit circle); None
        where there is neither (the corrector failed, or the root is not a bifurcation)."""
        from scipy.optimize import brentq

        Xa, Xb = np.append(w, lam), np.append(w_new, new)
        D = self.metric(Xa, Xb, h)
        t, L = unit(Xb - Xa, D)
        found = {}
        test = test or doubling_test

        def g(sig):
            X, res = (Xa, 0.0) if sig == 0.0 else (Xb, 0.0) if sig == 1.0 else \
                self.correct(segs, Xa + sig * L * t, t, D)[:2]
            found[sig] = (X, res)
            return test(self.multipliers(float(X[-1]), segs, X[:-1]))

        try:
            xtol = max(1e-13, min(1e-6, 0.1 * self.locate / max(abs(new - lam), 1e-300)))
            sig = brentq(g, 0.0, 1.0, xtol=xtol, rtol=4 * np.finfo(float).eps)
        except ValueError:          # the corrector failed inside, or no change of sign
            return None
        X, res = found[sig]
        at = float(X[-1])
        point = self.point(at, segs, X[:-1], res)
        real = [m for m in point["mult"] if abs(m.imag) <= 1e-6]
        if any(abs(m + 1.0) <= 1e-6 for m in real):
            kind = "period_doubling"
        elif any(abs(abs(m) - 1.0) <= 1e-6 for m in point["mult"] if abs(m.imag) > 1e-6):
            kind = "torus"
        else:
            return None
        return self.mark(at, segs, X[:-1], kind, res, point), point

    def change(self, lam, segs, w, new, w_new, h):
        """The change of the mode sequence between the admissible orbit at ``lam`` and
        the inadmissible one at ``new``, located by bisection along the chord between them
        (where the old sequence's orbit stops existing, the corrector failing, counts as
        beyond); the new sequence read just beyond it: ``(mark, first point on the new
        sequence or None, direction of the parameter)``."""
        Xa, Xb = np.append(w, lam), np.append(w_new, new)
        D = self.metric(Xa, Xb, h)
        t, L = unit(Xb - Xa, D)
        # in the parameter where at least a quarter of the chord's squared length is
        # along it (the shooting alone, as cheap as a step of natural-parameter
        # continuation), else along the chord
        along = t[-1] ** 2 * D[-1] >= 0.25
        a, wa, b, wb, s_a, s_b = lam, w, new, w_new, 0.0, 1.0
        while abs(b - a) > self.locate and s_b - s_a > 1e-12:
            mid = 0.5 * (s_a + s_b)
            pred = Xa + mid * L * t
            try:
                if along:
                    guess = wa if wb is None else wa + (wb - wa) * ((pred[-1] - a) / (b - a))
                    X = np.append(self.shoot(float(pred[-1]), segs, guess, max_iter=8)[0],
                                  pred[-1])
                else:
                    X = self.correct(segs, pred, t, D, max_iter=8)[0]
            except ValueError:
                b, wb, s_b = float(pred[-1]), None, mid
                continue
            if self.admissible(float(X[-1]), segs, X[:-1]):
                a, wa, s_a = float(X[-1]), X[:-1], mid
            else:
                b, wb, s_b = float(X[-1]), X[:-1], mid
        direction = math.copysign(1.0, new - lam) if new != lam else math.copysign(1.0, h)
        past = b + math.copysign(max(10 * self.locate, 1e-6 * abs(h)), direction)
        mark = self.mark(a, segs, wa, "sequence_change", 0.0)     # at the old phase
        if not min(self.lo, self.hi) <= past <= max(self.lo, self.hi):
            return mark, None, direction        # the change is at the span's end
        t_a, n2 = self.t_a, 2 * self.mech.n
        for settle in (False, True):        # the orbit's own continuation, else settled
            self.t_a = t_a
            new_segs, w_next = self.beyond(past, segs, wa if wb is None else wb, settle)
            if new_segs is None:
                continue
            mark["kind"] = sliding.kind(segs, wa[len(segs) * n2:], new_segs,
                                        w_next[len(new_segs) * n2:])
            try:
                w_next, res = self.shoot(past, new_segs, w_next)
            except ValueError:
                continue
            if self.admissible(past, new_segs, w_next):
                break
        else:
            self.t_a = t_a
            return mark, None, direction        # the motion beyond settles on none
        point = self.point(past, new_segs, w_next, res)
        if point["continuum"]:      # no branch of one orbit beyond: it ends here
            mark["kind"] = "continuum"
            return mark, None, direction
        self.w_scale, self.ds, self.arc_jac = None, None, None     # a new sequence
        self._arc_prev = None
        return mark, point, direction

    def beyond(self, lam, segs, w, settle=False):
        """The new segments and the first guess of their orbit, from the motion just
        beyond ``lam``, from the old orbit's start: run for about a period, it goes
        through the new sequence near the old orbit, stable or not; with ``settle``, run
        until it settles (on an orbit that may be another).  ``(None, None)`` where it
        closes on none."""
        n = self.mech.n
        p = self.params(lam)
        motion = self.motion(lam)
        z = w[:2 * n]
        sc = self.scale_of(motion, w)
        forcing = self.forcing(lam)
        scale_t = math.sqrt(sc[3] / sc[2])
        T = float(np.sum(w[len(segs) * 2 * n:]))
        try:
            if not settle:
                span = 2.2 * T if forcing is None else forcing * max(1, round(T / forcing))
                rec = _orbit._run(self.mech, p, z[:n], z[n:], self.t_a, self.t_a + span,
                                  self.rtol, forcing)
                t_a, t_b, z0 = _orbit._cycle(self.name, rec, forcing, sc)
            else:
                rec, (t_a, t_b, z0) = _orbit._settled(
                    self.name, self.mech, p, z[:n], z[n:], self.t_a + 50 * T, self.rtol,
                    forcing, sc, scale_t) if forcing is None else _settle_forced(
                    self, lam, z, T, sc)
            new_segs, w_new = _orbit._segments(self.name, motion, rec, t_a, t_b, z0,
                                               forcing, sc)
        except ValueError:
            return None, None
        self.t_a, self.jac = _orbit.phase_time(t_a, forcing), []
        return new_segs, w_new

    def mark(self, lam, segs, w, kind, res, point=None):
        """A special point (of the orbit ``w``; its amplitude from ``point``, the same
        orbit's branch point, where there is one)."""
        n2 = 2 * self.mech.n
        if point is None:
            low, high, _ = extrema(self.motion(lam), segs, w, self.t_a, self.rtol)
            amplitude = (high - low) / 2
        else:
            amplitude = point["amplitude"]
        return {"lam": lam, "kind": kind, "period": float(np.sum(w[len(segs) * n2:])),
                "amplitude": amplitude, "residual": res}


def _settle_forced(ctx, lam, z, T, sc):
    n = ctx.mech.n
    forcing = ctx.forcing(lam)
    mult = max(1, round(T / forcing))
    rec = _orbit._run(ctx.mech, ctx.params(lam), z[:n], z[n:], ctx.t_a,
                      ctx.t_a + 40 * mult * forcing, ctx.rtol, forcing)
    return rec, _orbit._cycle(ctx.name, rec, forcing, sc)


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


def _same(seq, modes) -> bool:
    """Whether the mode sequences ``seq`` and ``modes`` are the same, cyclically merged."""
    if seq is None:
        return False

    def runs(x):
        return [m for m, _ in sliding.merged([(tuple(m), 0.0) for m in x])]
    return runs(seq) == runs(modes)


def _from_dataset(mech, orbit, p0, rtol):
    """The segments and unknowns of a periodic-orbit Dataset."""
    motion = Motion(mech, p0, Options(1.0, rtol=rtol))
    K = orbit.sizes["segment"]
    names = list(mech.coordinates) + list(mech.rates)
    zs = [np.array([float(orbit[f"segment_{nm}"][j]) for nm in names]) for j in range(K)]
    n = mech.n
    t_a = float(orbit.segment_start[0])
    sc = motion.scales_at(zs[0][:n], zs[0][n:], t_a)
    segs = []
    for j in range(K):
        modes = tuple(int(orbit[f"segment_mode_{c.name}"][j]) for c in mech.contacts)
        index = int(orbit.segment_event_index[j])
        t_j = float(orbit.segment_start[j])
        rho = _orbit._rho(motion, zs[j], modes, t_j, sc)
        section = None
        if index == _orbit.SECTION_END:
            section = _orbit.section_at(motion, zs[j], t_j, modes, rho, sc)
        segs.append(Segment(modes, rho, None if index < 0 else index,
                            int(orbit.segment_end[j]), section))
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
            data[f"point_amplitude_{c}"] = (
                "point", np.array([m["amplitude"][j] for m in marks]),
                {"long_name": f"half the range of {c} over the orbit at the special point",
                 "units": u})
    m = max((len(p["strobes"]) for p in points), default=0)
    if mech.period is not None and m:     # where a forced orbit crosses phase 0
        at = np.full((len(points), m, 2 * n), np.nan)
        for i, p in enumerate(points):
            at[i, :len(p["strobes"])] = p["strobes"]
        for j, (nm, un) in enumerate(_orbit.state_variables(mech)):
            data[f"section_{nm}"] = (("vertex", "section"), at[:, :, j], {
                "long_name": f"{nm} where the orbit is at the forcing's phase 0, in order "
                             "(what phasemap.orbit_diagram samples; NaN past the orbit's "
                             "period in forcing periods)", "units": un})
    attrs = {"Conventions": CONVENTIONS, "title": f"phasemap orbit branch: {S.title}",
             "source": f"phasemap {__version__}", "references": S.citation,
             "phasemap_version": __version__, "date_created": created(),
             "phasemap_kind": "orbit_branch", "phasemap_model": S.name,
             "phasemap_parameter": param, "phasemap_span": np.array(span, dtype=float),
             "phasemap_modes": " ".join(MODE_NAMES)}
    return xr.Dataset(data, attrs=attrs)
