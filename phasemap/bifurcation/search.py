"""The public :func:`threshold`, and its cases beyond a line and a plane (those are
:func:`phasemap.bifurcation.thresholds.solve`'s): over a volume, and as a curve in a
further variable, ``threshold(..., along={a: (lo, hi)})``.

At every vertex the threshold is found exactly and globally (:func:`threshold`);
between vertices it is followed by its *defining system*: the equations that
fix the threshold's point at a given ``a``, solved by Newton with the exact
derivatives of the conditions in (other, param, a):

* a fold of a boundary in the parameter p: ``c = 0`` and ``dc/dx = 0`` in the
  other variable x (the minimally extended system of a fold curve, as MatCont
  and BifurcationKit.jl continue it);
* a crossing: ``c1 = c2 = 0``;
* an end on the edge of x's range, or a root on the line of p: ``c = 0``;
* the parameter's own range edge: ``p = lo`` (or ``hi``).

The system's tangent, ``d(x, p)/da = -J^-1 dF/da``, predicts the next vertex
and sets the step from the curvature (vertices spaced as a figure needs).
Where the exact threshold passes to another candidate (a different condition
or kind), the switch point is solved as ``p_1(a) = p_2(a)`` by Newton, with
``dp_i/da`` from each defining system.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import xarray as xr

from phasemap.core import args as _args
from phasemap.core.model import Model
from phasemap.systems import get_model
from phasemap.bifurcation.tracing import check_tol, header, parse_range
from phasemap.bifurcation import _trace as T
from phasemap.bifurcation.conditions import compiled
from phasemap.bifurcation.thresholds import Spec, Threshold, on_a_default_edge, solve

#: Largest distance of a chord from the curve, as a fraction of the ranges.
CHORD = 5e-5
#: Longest step in a, as a fraction of its range.
H_MAX = 1.0 / 32.0
#: Shortest step in a (a fraction of its range) before a switch is taken as located.
H_MIN = 1e-12


class _System:
    """The defining system of one threshold candidate, in (x, p) at a given a."""

    def __init__(self, spec: Spec, along: str, t: Threshold, conds, base):
        self.spec, self.along, self.t = spec, along, t
        self.C = conds
        self.base = base
        m = spec.model
        self.slot = {n: m.inputs.index(n) for n in conds.variables}
        self.kind = t.kind
        names = t.condition.split()
        index = {n: i for i, n in enumerate(conds.names)}
        self.k = [index[n.split(",")[0]] for n in names]
        self.x = spec.others[0] if spec.others else None
        self.n = len(conds.variables)
        self.g = np.empty(self.n)
        self.H = np.empty((self.n, self.n))

    def unknowns(self, t: Threshold) -> np.ndarray:
        if self.kind in ("fold_" + self.spec.param, "crossing"):
            return np.array([t.at[self.x], t.value])
        return np.array([t.value])

    def _vector(self, z, a):
        v = self.base.copy()
        v[self.slot[self.along]] = a
        if len(z) == 2:
            v[self.slot[self.x]] = z[0]
            v[self.slot[self.spec.param]] = z[1]
        else:
            if self.x is not None:
                v[self.slot[self.x]] = self.t.at[self.x]
            v[self.slot[self.spec.param]] = z[0]
        return v

    def residual(self, z, a):
        """F, dF/dz, dF/da and the residual relative to the tie scales."""
        v = self._vector(z, a)
        iv = {n: i for i, n in enumerate(self.C.variables)}
        ix = iv.get(self.x)
        ip, ia = iv[self.spec.param], iv[self.along]
        if self.kind == "fold_" + self.spec.param:
            c, s = self.C.module.hessian(self.k[0], v, self.g, self.H)
            g, H = self.g, self.H
            F = np.array([c, g[ix]])
            J = np.array([[g[ix], g[ip]], [H[ix, ix], H[ix, ip]]])
            Fa = np.array([g[ia], H[ix, ia]])
            res = max(abs(c) / s, abs(g[ix]) / max(math.hypot(g[ix], g[ip]), 1e-300))
        elif self.kind == "crossing":
            c1, s1 = self.C.module.gradient(self.k[0], v, self.g)
            g1 = self.g.copy()
            c2, s2 = self.C.module.gradient(self.k[1], v, self.g)
            g2 = self.g
            F = np.array([c1, c2])
            J = np.array([[g1[ix], g1[ip]], [g2[ix], g2[ip]]])
            Fa = np.array([g1[ia], g2[ia]])
            res = max(abs(c1) / s1, abs(c2) / s2)
        else:
            c, s = self.C.module.gradient(self.k[0], v, self.g)
            F = np.array([c])
            J = np.array([[self.g[ip]]])
            Fa = np.array([self.g[ia]])
            res = abs(c) / s
        return F, J, Fa, res

    def solve(self, z, a, tol):
        """Newton on F(z, a) = 0 from z: (z, residual, dz/da, error) or None."""
        z = np.array(z, dtype=float)
        err = math.inf
        for it in range(40):
            F, J, Fa, res = self.residual(z, a)
            try:
                dz = np.linalg.solve(J, -F)
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(dz)):
                return None
            z += dz
            err = float(np.max(np.abs(dz)))
            if err <= 1e-3 * tol:
                break
        if err > tol:
            return None
        F, J, Fa, res = self.residual(z, a)
        try:
            dzda = np.linalg.solve(J, -Fa)
        except np.linalg.LinAlgError:
            dzda = np.full(len(z), np.nan)
        return z, res, dzda, err


@dataclass
class _Vertex:
    a: float
    t: Threshold


def _key(t: Threshold | None):
    return None if t is None else (t.kind, t.condition)


def threshold_curve(m: Model, param: str, layer: str, value: int, over, fixed, side: str,
                    tol: float, along: Mapping, conditions=None) -> xr.Dataset:
    """The threshold of :func:`threshold` as a curve in ``along``'s variable.

    Returns an xarray Dataset shaped like that of :func:`phasemap.boundaries`:
    dimension ``vertex`` (variables named after ``along``, the parameter and
    the other ranged names; ``piece``), dimension ``piece`` (``condition``,
    ``kind``: the candidate that gives the threshold along the piece) and
    dimension ``point`` (``point_<name>`` for each, ``point_kind``: ``switch``
    where the threshold passes from one candidate to another, ``end`` where
    the region stops existing; ``point_residual``).  Where an end lies on the edge
    of a range (the parameter's, or another ranged name's, given or the default
    one), the attribute ``phasemap_stopped_by`` says which, and a warning too: the
    curve goes on beyond the range, and a wider one follows it.
    """
    if not isinstance(along, Mapping) or len(along) != 1:
        raise ValueError(f"along must name one variable with its range, {{name: (lo, hi)}}; "
                         f"got {_args.describe(along)}")
    (name, rng), = _args.mapping("along", along, m.name).items()
    if name not in m.variables:
        raise ValueError(f"{m.name}: unknown variable {name!r} in along; "
                         f"allowed: {', '.join(m.names)}")
    a_lo, a_hi = parse_range(m, f"along[{name!r}]", rng)
    fixed = _args.mapping("fixed", fixed, m.name)
    if name == param or name in _args.mapping("over", over, m.name) or name in fixed:
        raise ValueError(f"{m.name}: {name!r} in along must be neither the parameter, "
                         "ranged over, nor fixed")
    spec = Spec.make(m, param, layer, value, over, {**fixed, name: a_lo}, side, tol)
    check_tol(spec.tol, {name: (a_lo, a_hi)})
    if len(spec.others) > 1:
        raise ValueError(f"{m.name}: along needs at most one name ranged over besides "
                         f"{param!r}")
    C = T.tiered(compiled(m, (*spec.others, param, name), conditions), conditions)
    base = m.input_vector(m.complete({**spec.fixed, **{n: r[0] for n, r in spec.ranges.items()}}))
    prange = spec.ranges[param]
    span_p = prange[1] - prange[0]
    span_a = a_hi - a_lo

    def at(a):
        t = threshold(m, param, layer, value, spec.ranges, {**fixed, name: a}, side, tol,
                      conditions=conditions)
        if t is not None and t.kind == "flat" and spec.others:
            # the least vertex of a piece whose fold the tracer did not locate (near an
            # edge): the fold, where it is solved nearby
            fold = Threshold(t.param, t.value, t.at, t.condition, "fold_" + param, t.residual,
                             t.error, t.bound, t.side)
            t = _moved(spec, name, C, base, fold, a, tol, within=True) or t
        return t

    def same(t0, a1, t1):
        """The candidate t0, followed to a1, gives t1's threshold (to tol) there: another
        name for the same threshold (a key change there is no switch)."""
        if t0 is None or t1 is None:
            return None
        moved = _moved(spec, name, C, base, t0, a1, tol, within=True)
        return moved if moved is not None and abs(moved.value - t1.value) <= tol else None

    def tangent(t: Threshold, a):
        """dp/da (normalised by the ranges) of the candidate t at a."""
        if t is None or t.kind == "edge":
            return 0.0
        sysm = _System(spec, name, t, C, base)
        r = sysm.solve(sysm.unknowns(t), a, tol)
        if r is None:
            return math.nan
        return float(r[2][-1]) * span_a / span_p

    pieces: list[list[_Vertex]] = []
    points = []
    a = a_lo
    t = at(a)
    current: list[_Vertex] = []
    if t is not None:
        current.append(_Vertex(a, t))
    else:
        points.append(("start_empty", a, None))
    h = H_MAX
    slope = tangent(t, a)
    while a < a_hi:
        an = min(a + h * span_a, a_hi)
        tn = at(an)
        if _key(tn) != _key(t):
            tn = same(t, an, tn) or tn
        if _key(tn) == _key(t):
            if tn is not None:
                sn = tangent(tn, an)
                turn = abs(math.atan(sn) - math.atan(slope)) if math.isfinite(sn + slope) else 0
                # the chord's deviation from the curve, from the turn of the tangent
                dev = 0.25 * turn * math.hypot(h, h * slope)
                if dev > CHORD and h > 1e-6:
                    h *= 0.5
                    continue
                current.append(_Vertex(an, tn))
                slope = sn
                if dev > 0:
                    h = min(H_MAX, 2.0 * h, h * math.sqrt(CHORD / dev))
                else:
                    h = min(H_MAX, 2.0 * h)
            a, t = an, tn
            continue
        # the threshold passes to another candidate (or the region appears or vanishes)
        sa, st = _switch(spec, name, C, base, a, t, an, tn, at, tol, span_a)
        # both candidates solved at the switch itself (not copied from a vertex)
        before = _moved(spec, name, C, base, t, sa, tol) if t is not None else None
        after = _moved(spec, name, C, base, st, sa, tol) if st is not None else None
        if t is not None:
            current.append(_Vertex(sa, before or t))
            pieces.append(current)
        point = after or before or st or t
        if before is not None and after is not None:
            point = dataclasses.replace(after, residual=max(before.residual, after.residual))
        points.append(("switch" if (t is not None and st is not None) else "end", sa, point))
        current = []
        if st is not None:
            current.append(_Vertex(sa, after or st))
        a, t = an, tn
        if t is not None:
            current.append(_Vertex(an, tn))
        slope = tangent(t, a)
        h = H_MAX
    if current:
        pieces.append(current)
    ds = _dataset(spec, name, (a_lo, a_hi), pieces, points, tol)
    stopped = _stopped_by_ranges(spec, over or {}, name, points, tol)
    if stopped:
        ds.attrs["phasemap_stopped_by"] = "; ".join(stopped)
        warnings.warn(f"{m.name}: the threshold curve in {name} ended on a range's edge, not "
                      f"where the region ends: {'; '.join(stopped)}", stacklevel=3)
    return ds


def _stopped_by_ranges(spec, over: Mapping, along: str, points, tol) -> list[str]:
    """What a range stopped: for each end point of the curve that lies on an edge of a
    range (the parameter's or another ranged name's), which edge, and whether the range
    was a default the user did not give."""
    out = []
    for kind, a, t in points:
        if kind != "end" or t is None:
            continue
        for n, (lo, hi) in spec.ranges.items():
            x = t.value if n == t.param else t.at.get(n, math.nan)
            slack = max(1e3 * tol, 1e-7 * (hi - lo))
            edge = lo if abs(x - lo) <= slack else hi if abs(x - hi) <= slack else None
            if edge is None:
                continue
            given = n in over
            out.append(f"{n} reached {edge:g} at {along} = {a:.6g}, the edge of "
                       + (f"its range [{lo:g}, {hi:g}]" if given else
                          f"its default range [{lo:g}, {hi:g}] (pass over={{{n!r}: (lo, hi)}} "
                          "to follow it further)"))
    return out


def _moved(spec, along, C, base, t: Threshold, a: float, tol,
           within: bool = False) -> Threshold | None:
    """The candidate ``t`` followed by its defining system to ``a``; None where it does
    not converge (or, ``within``, leaves the ranges by more than ``tol``)."""
    if t.kind == "edge":
        at = dict(t.at)
        return Threshold(t.param, t.value, at, t.condition, t.kind, t.residual, t.error,
                         math.nan, t.side)
    sysm = _System(spec, along, t, C, base)
    r = sysm.solve(sysm.unknowns(t), a, tol)
    if r is None:
        return None
    z, res, dz, err = r
    at = dict(t.at)
    if len(z) == 2:
        at[sysm.x] = float(z[0])
    at[t.param] = float(z[-1])
    if within and not all(spec.ranges[n][0] - tol <= at[n] <= spec.ranges[n][1] + tol
                          for n in spec.ranges):
        return None
    return Threshold(t.param, float(z[-1]), at, t.condition, t.kind, res, err, math.nan, t.side)


def _switch(spec, along, C, base, a0, t0, a1, t1, at, tol, span_a):
    """Where between a0 and a1 the threshold passes from candidate t0 to t1.

    Where both are candidates on either side, Newton on p_0(a) = p_1(a); else
    (a region that appears or vanishes, a candidate that stops existing) by
    bisection on the exact threshold."""
    if t0 is not None and t1 is not None:
        s0 = _System(spec, along, t0, C, base) if t0.kind != "edge" else None
        s1 = _System(spec, along, t1, C, base) if t1.kind != "edge" else None
        z0 = s0.unknowns(t0) if s0 else None
        z1 = s1.unknowns(t1) if s1 else None
        a = a0 + 0.5 * (a1 - a0)
        for it in range(60):
            r0 = s0.solve(z0, a, tol) if s0 else (np.array([t0.value]), 0.0, np.zeros(1), 0.0)
            r1 = s1.solve(z1, a, tol) if s1 else (np.array([t1.value]), 0.0, np.zeros(1), 0.0)
            if r0 is None or r1 is None:
                break
            z0, z1 = r0[0], r1[0]
            G = z0[-1] - z1[-1]
            dG = r0[2][-1] - r1[2][-1]
            if dG == 0.0 or not math.isfinite(dG):
                break
            step = -G / dG
            a += step
            if not (a0 - 1e-9 * span_a <= a <= a1 + 1e-9 * span_a):
                break
            if abs(step) <= 1e-3 * tol:
                return a, t1
    lo, hi = a0, a1
    key0 = _key(t0)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if _key(at(mid)) == key0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi), at(hi) if t1 is None or t0 is None else t1


def _dataset(spec: Spec, along: str, arange, pieces, points, tol) -> xr.Dataset:
    m = spec.model
    names = [along, spec.param, *spec.others]
    V = xr.Variable
    data = {}
    coords = {n: [] for n in names}
    piece_of = []
    residual = []
    for i, piece in enumerate(pieces):
        for vx in piece:
            coords[along].append(vx.a)
            coords[spec.param].append(vx.t.value)
            for o in spec.others:
                coords[o].append(vx.t.at.get(o, math.nan))
            piece_of.append(i)
            residual.append(vx.t.residual)
    for n in names:
        var = m.variables[n]
        data[n] = V("vertex", np.array(coords[n], dtype=float),
                    {"units": var.units, "long_name": var.long_name})
    data["piece"] = V("vertex", np.array(piece_of, dtype=np.int32),
                      {"long_name": "piece the vertex belongs to (index along dimension piece)"})
    data["residual"] = V("vertex", np.array(residual, dtype=float),
                         {"units": "1", "long_name": "largest residual of the threshold's "
                          "defining equations at the vertex, relative to their tie scales"})
    data["condition"] = V("piece", np.array([p[0].t.condition for p in pieces], dtype=str),
                          {"long_name": "the condition(s) that give the threshold"})
    data["kind"] = V("piece", np.array([p[0].t.kind for p in pieces], dtype=str),
                     {"long_name": "kind of the threshold's point: fold_<param>, crossing, "
                                   "end, edge"})
    pk, pa, pv, pres = [], [], {n: [] for n in names if n != along}, []
    for kind, a, t in points:
        if kind == "start_empty":
            continue
        pk.append(kind)
        pa.append(a)
        for n in pv:
            pv[n].append(math.nan if t is None else (t.value if n == spec.param
                                                      else t.at.get(n, math.nan)))
        pres.append(math.nan if t is None else t.residual)
    data[f"point_{along}"] = V("point", np.array(pa, dtype=float),
                               {"units": m.variables[along].units,
                                "long_name": m.variables[along].long_name})
    for n, vals in pv.items():
        data[f"point_{n}"] = V("point", np.array(vals, dtype=float),
                               {"units": m.variables[n].units,
                                "long_name": m.variables[n].long_name})
    data["point_kind"] = V("point", np.array(pk, dtype=str),
                           {"long_name": "switch (the threshold passes to another candidate) "
                                         "or end (the region stops existing)"})
    data["point_residual"] = V("point", np.array(pres, dtype=float),
                               {"units": "1", "long_name": "residual of the point"})
    fixed = {n: v for n, v in spec.fixed.items() if n != along}
    attrs = header(m, "threshold", fixed,
                   phasemap_param=spec.param, phasemap_layer=spec.layer,
                   phasemap_value=spec.value, phasemap_side=spec.side,
                   phasemap_over=json.dumps(spec.ranges),
                   phasemap_along=json.dumps({along: list(arange)}), phasemap_tol=tol)
    return xr.Dataset(data, attrs=attrs)


def threshold_volume(spec: Spec, conditions=None) -> Threshold | None:
    """The threshold of :func:`threshold` over two further names ``(x, a)``: the least
    (greatest) of the threshold curve in ``a`` (:func:`threshold_curve` of the slice
    in ``x``), made exact.

    Along a piece of that curve the threshold p*(a) follows one defining system
    (a fold, a crossing, an end), whose tangent gives dp*/da exactly.  An
    interior extremum of p*(a) is the root of dp*/da between the best vertex's
    neighbours, solved by Brent's method on that exact derivative (for a fold
    of a condition c: c = c_x = c_a = 0, the fold of the boundary surface in
    p); an extremum at a piece's end (a's range edge, a switch between
    candidates, where the region appears) is the vertex itself, found exactly
    by :func:`threshold_curve`.
    """
    from scipy.optimize import brentq

    m, p = spec.model, spec.param
    x, a = spec.others
    ranges = {x: spec.ranges[x], p: spec.ranges[p]}
    ds = threshold_curve(m, p, spec.layer, spec.value, ranges, spec.fixed, spec.side, spec.tol,
                         {a: spec.ranges[a]}, conditions)
    if ds.sizes["vertex"] == 0:
        return None
    pv, av, piece = ds[p].values, ds[a].values, ds.piece.values
    i = int(np.argmin(spec.sign * pv))
    same = np.flatnonzero(piece == piece[i])
    t = threshold(m, p, spec.layer, spec.value, ranges, {**spec.fixed, a: float(av[i])},
                  spec.side, spec.tol, conditions=conditions)
    if t is None:
        return None
    best = t
    if t.kind != "edge" and same[0] < i < same[-1]:
        C = T.tiered(compiled(m, (x, p, a), conditions), conditions)
        base = m.input_vector(m.complete({**spec.fixed, x: ranges[x][0], p: ranges[p][0],
                                          a: float(av[i])}))
        sysm = _System(spec, a, t, C, base)
        z = sysm.unknowns(t)

        def slope(s):
            r = sysm.solve(z, s, spec.tol)
            if r is None:
                raise ValueError(f"{m.name}: the threshold's defining system ({t.kind} of "
                                 f"{t.condition}) cannot be followed to {a} = {s!r}")
            return spec.sign * float(r[2][-1])

        lo, hi = float(av[i - 1]), float(av[i + 1])
        if slope(lo) < 0.0 < slope(hi):
            s = brentq(slope, lo, hi, xtol=1e-3 * spec.tol, rtol=4 * np.finfo(float).eps)
            moved = _moved(spec, a, C, base, t, s, spec.tol)
            if moved is not None and spec.sign * moved.value <= spec.sign * t.value:
                best = Threshold(p, moved.value, {**moved.at, a: s}, moved.condition, moved.kind,
                                 moved.residual, moved.error, math.nan, spec.side)
    at = {**best.at, a: best.at.get(a, float(av[i]))}
    return Threshold(p, best.value, {x: at[x], a: at[a], p: best.value}, best.condition,
                     best.kind, best.residual, best.error, math.nan, spec.side)


def threshold(model, param: str, layer: str = "n_solutions", value: int = 0,
              over: Mapping | None = None, fixed: Mapping | None = None, side: str = "min",
              tol: float = 1e-10, *, along: Mapping | None = None, conditions=None):
    """The least (``side="min"``) or greatest (``"max"``) value of ``param`` over the
    region where ``layer`` equals ``value``.

    Parameters
    ----------
    model:
        a model name, a declaration file's path or a :class:`phasemap.Model`.
    param:
        the parameter (any variable of the model) whose threshold is sought.
    layer, value:
        the region: where ``layer`` (``n_solutions``, ``stagnation``,
        ``contact_lost`` or ``singular``) takes ``value``.  ``singular`` holds on
        curves, the zero sets of the branches' coefficients.
    over:
        ``{name: (lo, hi)}``: the ranges searched; ``param``'s own range may be
        given here too (otherwise the model's default map's, or its domain if
        that is finite).  One other name: the exact boundaries of that slice are
        traced (:func:`phasemap.boundaries`); none: the line of ``param``; two,
        ``x`` and ``a`` (in that order): the threshold of the slice in ``x`` is
        followed in ``a`` (``along=``) and its extremum solved exactly (an
        interior one where dp/da = 0 on its defining system: for a fold of a
        condition c, c = c_x = c_a = 0).  The first of the two should be the one
        whose slice holds the richer boundaries (it is traced; the second is
        continued).
    fixed:
        values of the other variables (the rest take the model's defaults).
    side:
        ``"min"`` (the infimum) or ``"max"`` (the supremum).
    tol:
        the accuracy of the threshold and of its point, in each coordinate.
    along:
        ``{name: (lo, hi)}``: trace the threshold as a curve in a further
        variable; a Dataset is returned instead (see :func:`threshold_curve`).
    conditions:
        the conditions to use instead of the model's own.

    Returns
    -------
    Threshold or None
        None where the region is empty in the given ranges (a region thinner than
        a raster cell included: the extrema of every condition are searched).

    Raises
    ------
    ValueError
        naming the argument: an unknown model, parameter, variable or layer, a
        range that is empty or outside the domain, more than two names in ``over``
        besides the parameter (not supported), a region whose extremum cannot
        be located to ``tol``, or no region found where an extremum of a
        condition could not be resolved (a warning names it; with a region, the
        Threshold lists such points in ``unresolved``).

    Examples
    --------
    The Painleve rod's first paradox, pushed towards its end at rest (Genot and
    Brogliato 1999): f = 4/3, at theta = arctan 2.

    >>> import phasemap
    >>> t = phasemap.threshold("painleve_rod", "f", value=0, over={"theta": (0.1, 1.5)},
    ...                        fixed={"xdot": -1.0, "omega": 0.0})       # doctest: +SKIP
    >>> round(t.value, 12), round(t.at["theta"], 12), t.kind          # doctest: +SKIP
    (1.333333333333, 1.107148717794, 'fold_f')
    """
    m = get_model(model)
    if along is not None:
        return threshold_curve(m, param, layer, value, over, fixed, side, tol, along,
                               conditions)
    spec = Spec.make(m, param, layer, value, over, fixed, side, tol)
    if len(spec.others) == 2:
        result = threshold_volume(spec, conditions)
    else:
        result = solve(spec, conditions)
    on_a_default_edge(spec, over or {}, result)
    return result


__all__ = ["threshold", "threshold_curve", "threshold_volume"]
