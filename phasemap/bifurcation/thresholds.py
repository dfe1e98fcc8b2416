"""The least (or greatest) parameter at which a class exists, on a line or in a plane:
:class:`Threshold` (the result), :class:`Spec` (a call's checked arguments) and
:func:`solve`.  :func:`phasemap.threshold` (:mod:`phasemap.bifurcation.search`) takes
the other cases."""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from phasemap.core import args as _args
from phasemap.core import numerics as nx
from phasemap.maps.grid import evaluate
from phasemap.maps.layers import layers_for
from phasemap.core.model import Model
from phasemap.bifurcation import _trace as T
from phasemap.bifurcation.tracing import (LAYERS, Slice, Traced, check_tol, condition_name, make_slice, parse_range,
                      parse_tol, trace, unresolved_points)
from phasemap.bifurcation.conditions import compiled

#: Samples of a one-dimensional threshold's line.
LINE_SAMPLES = 2048
#: Candidate kinds preferred where several reach the same value (a fold is the
#: smooth extremum; a crossing a corner; an end a piece's end on an edge).
_PREFERENCE = {T.FOLD_X: 2, T.FOLD_Y: 0, T.CROSSING: 1, T.TANGENCY: 1, T.END: 3,
               T.STALL: 5, T.CHANGE: 5, T.REGULAR: 4}


@dataclass(frozen=True)
class Threshold:
    """The infimum (``side="min"``) or supremum of a parameter over a class's region.

    ``value``
        the threshold;
    ``at``
        where it is attained: ``{name: value}`` for the parameter and every
        name ranged over;
    ``condition``
        the condition(s) that vanish there (two for a crossing), in the
        model's names ("" on a range's edge inside the region);
    ``kind``
        ``fold_<param>`` (a boundary turns back in the parameter), ``crossing``
        (two boundaries meet), ``end`` (a boundary meets the edge of another
        range), ``edge`` (the region reaches the parameter's own range edge)
        or ``root`` (one range only: a boundary point on the line);
    ``residual``
        the largest residual of its defining equations, relative to their tie
        scales;
    ``bound``
        the raster's best cell in the region (a cell's width from the exact value);
    ``unresolved``
        points where an extremum of a condition may reach zero within a cell of the
        seed raster and could not be resolved (a warning names them): a region
        thinner than a cell there could lie beyond ``value``.
    """

    param: str
    value: float
    at: dict = field(default_factory=dict)
    condition: str = ""
    kind: str = ""
    residual: float = 0.0
    error: float = 0.0
    bound: float = math.nan
    side: str = "min"
    unresolved: tuple = ()

    def __post_init__(self):
        # plain floats: the numbers print and compare as they read
        object.__setattr__(self, "value", float(self.value))
        object.__setattr__(self, "at", {str(k): float(v) for k, v in self.at.items()})

    def __repr__(self) -> str:
        at = ", ".join(f"{k}={v:.12g}" for k, v in self.at.items())
        return (f"Threshold({self.param} {'>=' if self.side == 'min' else '<='} "
                f"{self.value:.15g} at {at}; {self.kind} of {self.condition or '-'}; "
                f"residual {self.residual:.1e})")


def solve(spec: "Spec", conditions=None) -> "Threshold | None":
    """The threshold of ``spec`` on a line (no further ranged name) or in a plane (one):
    what :func:`phasemap.threshold` computes in those cases."""
    if len(spec.others) == 0:
        return _line(spec, conditions)
    if len(spec.others) == 1:
        return _plane(spec, conditions)
    raise ValueError(f"solve: {len(spec.others)} further ranged names; over two, "
                     "phasemap.threshold takes the volume")


def on_a_default_edge(spec: "Spec", over: Mapping, result: "Threshold | None") -> None:
    """Warn where the threshold lies on an edge of the parameter's default range (one the
    user did not give): the region goes on beyond it, and so may the threshold."""
    if result is None or spec.param in over:
        return
    lo, hi = spec.ranges[spec.param]
    slack = max(1e3 * spec.tol, 1e-7 * (hi - lo))
    for edge in (lo, hi):
        if abs(result.value - edge) <= slack:
            warnings.warn(f"{spec.model.name}: the threshold {spec.param} = {result.value:.10g}"
                          f" lies on the edge of its default range [{lo:g}, {hi:g}]; the "
                          f"region may go on beyond it: pass over={{{spec.param!r}: (lo, hi)}}",
                          stacklevel=3)


@dataclass
class Spec:
    """A validated threshold problem."""

    model: Model
    param: str
    layer: str
    value: int
    ranges: dict  # name -> (lo, hi), param's included
    others: list
    fixed: dict
    side: str
    tol: float

    @property
    def sign(self) -> float:
        return 1.0 if self.side == "min" else -1.0

    @staticmethod
    def make(m: Model, param, layer, value, over, fixed, side, tol) -> "Spec":
        if not isinstance(param, str):
            raise _args.WrongType(f"{m.name}: param must be a variable name (a string), got "
                                  f"{_args.describe(param)}")
        if param not in m.variables:
            raise ValueError(f"{m.name}: unknown variable {param!r}; allowed: {', '.join(m.names)}")
        if not isinstance(layer, str) or layer not in LAYERS + ("singular",):
            raise ValueError(f"layer must be one of {', '.join(LAYERS + ('singular',))}, "
                             f"got {_args.describe(layer)}")
        reg = layers_for(m)[layer]
        value = _args.count("value", value, m.name, least=-2 ** 31)
        if value not in reg.flag_values:
            raise ValueError(f"value must be one of the flag values of {layer} "
                             f"({reg.flag_meanings}: {list(reg.flag_values)}), got {value}")
        if layer == "singular" and value != 1:
            raise ValueError("layer singular holds on curves: only value=1 has a threshold")
        if not isinstance(side, str) or side not in ("min", "max"):
            raise ValueError(f"side must be 'min' or 'max', got {_args.describe(side)}")
        tol = parse_tol(tol)
        over = _args.mapping("over", over, m.name)
        fixed = _args.mapping("fixed", fixed, m.name)
        if param in fixed:
            raise ValueError(f"{m.name}: {param!r} is the parameter and cannot be fixed")
        ranges = {}
        for name, rng in over.items():
            if name not in m.variables:
                raise ValueError(f"{m.name}: unknown variable {name!r} in over; "
                                 f"allowed: {', '.join(m.names)}")
            if name in fixed:
                raise ValueError(f"{m.name}: {name!r} is both ranged over and fixed")
            ranges[name] = parse_range(m, f"over[{name!r}]", rng)
        if param not in ranges:
            ranges[param] = _default_range(m, param)
        others = [n for n in ranges if n != param]
        if len(others) > 2:
            raise ValueError(f"{m.name}: over ranges at most two names besides {param!r}, got "
                             f"{', '.join(others)}: fix the others (fixed=), or follow the "
                             "threshold in one of them with along= for each value of the rest")
        check_tol(tol, ranges)
        return Spec(m, param, layer, value, ranges, others, fixed, side, tol)


def _default_range(m: Model, param: str) -> tuple[float, float]:
    if param in m.default_axes:
        lo, hi = m.default_axes[param][:2]
        return float(min(lo, hi)), float(max(lo, hi))
    var = m.variables[param]
    if math.isfinite(var.lower) and math.isfinite(var.upper):
        return float(var.lower), float(var.upper)
    raise ValueError(f"{m.name}: give the range of {param!r} in over= (it has no default map "
                     "range and its domain is not finite)")


# -- two dimensions: the exact boundaries of the slice ------------------------------------

def _plane(spec: Spec, conditions) -> Threshold | None:
    other, p = spec.others[0], spec.param
    axes = {other: spec.ranges[other], p: spec.ranges[p]}
    sl = make_slice(spec.model, axes, spec.fixed, conditions)
    if spec.layer == "singular":
        only = np.array([k == "coefficient" for k in sl.conds.kinds])
        tr = trace(sl, "n_solutions", spec.tol, only=only)
        n = int(tr.buf.counts[0])
        rows = np.arange(n)
        rows = rows[np.isin(tr.buf.verts["condition"][:n], np.flatnonzero(only))]
        return _best(sl, spec, tr, rows, edge=None, bound=math.nan)
    tr = trace(sl, spec.layer, spec.tol)
    result = _plane_best(sl, spec, tr)
    unresolved = unresolved_points(sl, tr)
    if unresolved and result is None:
        raise ValueError(f"{sl.model.name}: no region with {spec.layer} = {spec.value} was "
                         f"found, but {len(unresolved)} extrema of a condition could not be "
                         "resolved (see the warning): a region thinner than a seed raster cell "
                         "may lie there")
    if unresolved:
        result = dataclasses.replace(result, unresolved=tuple(unresolved))
    return result


def _plane_best(sl: Slice, spec: Spec, tr: Traced) -> Threshold | None:
    """The threshold of the traced slice ``tr`` (:func:`_best` over the pieces that bound
    the region, and the raster's cells in it)."""
    p = spec.param
    bounding = np.flatnonzero((tr.pieces[:, 2] == spec.value) | (tr.pieces[:, 3] == spec.value))
    rows = tr.pq[np.isin(tr.pp, bounding)]
    inside = tr.classes == spec.value
    cells = inside.shape[1]
    t = (np.arange(cells) + 0.5) / cells
    bound = math.nan
    if inside.any():
        js = np.flatnonzero(inside.any(axis=0))
        j = js[0] if spec.side == "min" else js[-1]
        lo, hi = spec.ranges[p]
        bound = lo + t[j] * (hi - lo)
    edge_row = 0 if spec.side == "min" else cells - 1
    edge = np.flatnonzero(inside[:, edge_row])
    return _best(sl, spec, tr, rows, edge=(edge + 0.5) / cells if len(edge) else None,
                 bound=bound)


def _best(sl: Slice, spec: Spec, tr: Traced, rows: np.ndarray, edge, bound) -> Threshold | None:
    """The least (greatest) parameter among the candidate vertices ``rows`` and, where
    the region reaches the parameter's own edge (cells ``edge`` along the other
    axis), that edge."""
    verts = tr.buf.verts
    lo, hi = spec.ranges[spec.param]
    olo, ohi = spec.ranges[spec.others[0]]
    sign = spec.sign
    if len(rows) == 0 and edge is None:
        if math.isfinite(bound):
            raise ValueError(f"{sl.model.name}: the raster has cells with {spec.layer} = "
                             f"{spec.value} but no traced piece bounds them")
        return None
    best = None
    if len(rows):
        pvals = lo + verts["w"][rows] * (hi - lo)
        extreme = np.min(sign * pvals)
        near = rows[sign * pvals <= extreme + spec.tol]
        q = min(near, key=lambda r: (_PREFERENCE[int(verts["kind"][r])], sign * verts["w"][r]))
        best = sign * extreme
    edge_value = lo if spec.side == "min" else hi
    if edge is not None and (best is None or sign * edge_value <= sign * best + spec.tol):
        # the region reaches the parameter's own edge: a piece's end there, if any
        at_edge = [] if not len(rows) else rows[(verts["kind"][rows] == T.END)
                                                & (np.abs(verts["w"][rows] - (0.0 if sign > 0 else 1.0))
                                                   <= 1e-15)]
        if len(at_edge):
            q = at_edge[0]
            other_value = olo + verts["u"][q] * (ohi - olo)
            cond = condition_name(sl, tr, int(verts["condition"][q]))
            res = float(verts["residual"][q])
        else:
            other_value = olo + float(edge[0]) * (ohi - olo)
            cond, res = "", 0.0
        result = Threshold(spec.param, edge_value, {spec.others[0]: other_value,
                                                    spec.param: edge_value}, cond, "edge",
                           res, 0.0, bound, spec.side)
    else:
        kind = int(verts["kind"][q])
        names = [condition_name(sl, tr, int(verts["condition"][q]))]
        if kind in (T.CROSSING, T.TANGENCY) and verts["other"][q] >= 0:
            names.append(condition_name(sl, tr, int(verts["other"][q])))
        if kind == T.FOLD_Y:
            kname = f"fold_{spec.param}"
        elif kind == T.FOLD_X:
            kname = f"fold_{spec.others[0]}"
        else:
            kname = {T.CROSSING: "crossing", T.END: "end", T.TANGENCY: "tangency",
                     T.REGULAR: "flat", T.STALL: "stall", T.CHANGE: "change"}[kind]
        pv = lo + verts["w"][q] * (hi - lo)
        result = Threshold(spec.param, float(pv), {spec.others[0]: olo + verts["u"][q] * (ohi - olo),
                                                   spec.param: float(pv)},
                           " ".join(names), kname, float(verts["residual"][q]), float(verts["error"][q]) * spec.tol,
                           bound, spec.side)
    if math.isfinite(bound) and sign * result.value > sign * bound + spec.tol:
        raise ValueError(f"{sl.model.name}: the exact threshold {result.value!r} lies beyond "
                         f"the raster's best cell {bound!r}: a boundary piece was missed")
    return result


def _class_at(m: Model, v: np.ndarray, slot: int, x: float, layer: str) -> int:
    """The layer's class at the input vector ``v`` with ``v[slot] = x``."""
    w = v.copy()
    w[slot] = x
    m.derive(w)
    out = np.empty((len(m.candidates), m.n_fields))
    m.point(w, out)
    n, stag, lost, sing = nx.summarize(out, m.stick_branch)
    return int({"n_solutions": n, "stagnation": stag, "contact_lost": lost,
                "singular": sing}[layer])


# -- one dimension: the line of the parameter ------------------------------------------------

def _line(spec: Spec, conditions) -> Threshold | None:
    m, p = spec.model, spec.param
    lo, hi = spec.ranges[p]
    C = T.tiered(compiled(m, (p,), conditions), conditions)
    full = m.complete({**spec.fixed, p: np.array([lo, hi])})
    fixed = {n: float(v) for n, v in full.items() if n != p}
    samples = np.linspace(lo, hi, LINE_SAMPLES + 1)
    base = m.input_vector({**fixed, p: lo})
    slot = m.inputs.index(p)
    nc = len(C)
    values = np.empty((len(samples), nc))
    scales = np.empty((len(samples), nc))
    v = base.copy()
    for i, x in enumerate(samples):
        v[slot] = x
        C.values(v, values[i], scales[i])
    # a sample within a condition's ties (|c| <= TOL scale) may be classed on either side:
    # the condition changes sign there as far as the classes can tell
    with np.errstate(invalid="ignore"):
        tied = np.abs(values) <= nx.TOL * scales
    g = np.empty(1)

    def crosses(k, a, b):
        """c_k changes sign between samples a and b, or is tied at either."""
        return values[a, k] * values[b, k] < 0.0 or tied[a, k] or tied[b, k]

    def root(k, a, b):
        """c_k = 0 between samples a and b, by Newton from the secant point (from the tied
        sample where there is no sign change): (x, residual, last step, width of the ties
        around x)."""
        ca, cb = values[a, k], values[b, k]
        if ca * cb < 0.0:
            x = samples[a] + ca / (ca - cb) * (samples[b] - samples[a])
        else:
            x = samples[a] if abs(ca) * scales[b, k] <= abs(cb) * scales[a, k] else samples[b]
        step = 0.0
        for it in range(T.MAX_IT):
            v[slot] = x
            c, s = C.module.gradient(k, v, g)
            if g[0] == 0.0 or not math.isfinite(c):
                return None
            step = -c / g[0]
            x += step
            # a step below the tolerance, or the value within a hundredth of the ties
            # (large terms leave rounding noise in c and so in the step)
            if abs(step) <= 1e-3 * spec.tol or abs(c) <= 1e-2 * nx.TOL * s:
                break
        v[slot] = x
        c, s = C.module.gradient(k, v, g)
        if not (samples[a] - spec.tol <= x <= samples[b] + spec.tol) or g[0] == 0.0:
            return None
        return x, abs(c) / s if s > 0 else abs(c), abs(step), nx.TOL * s / abs(g[0])

    order = range(len(samples) - 1) if spec.side == "min" else range(len(samples) - 2, -1, -1)
    if spec.layer == "singular":
        coefs = [k for k in range(nc) if C.kinds[k] == "coefficient"]
        for i in order:
            for k in coefs:
                if values[i, k] * values[i + 1, k] <= 0.0 and values[i, k] != values[i + 1, k]:
                    r = root(k, i, i + 1)
                    if r is not None:
                        return Threshold(p, r[0], {p: r[0]}, C.names[k], "root", r[1], r[2],
                                         math.nan, spec.side)
        return None
    def excluded(k):
        """c_k holds only at rest, and the velocity is fixed and not zero."""
        return bool(C.rest_only[k]) and abs(fixed.get(m.velocity, 1.0)) > 0 and m.velocity != p

    def zero(k, xa, xb):
        """The zero of c_k between xa and xb (opposite signs), by bisection to the last
        bit."""
        v[slot] = xa
        ca = C.module.gradient(k, v, g)[0]
        while True:
            mid = 0.5 * (xa + xb)
            if mid == xa or mid == xb:
                return mid
            v[slot] = mid
            if (C.module.gradient(k, v, g)[0] < 0.0) == (ca < 0.0):
                xa = mid
            else:
                xb = mid

    def thin():
        """The region's first point (in the side's order) in a region thinner than a
        sample: an extremum of a condition between three samples of one sign where it
        changes sign (Newton on c' = 0), whose class is the region's; or None."""
        H = np.empty((1, 1))
        best = None
        mid, left, right = values[1:-1], values[:-2], values[2:]
        with np.errstate(invalid="ignore"):
            least = (mid * left > 0.0) & (mid * right > 0.0) & (np.abs(mid) < np.abs(left)) \
                & (np.abs(mid) <= np.abs(right)) & ~tied[1:-1]
        for i, k in zip(*np.nonzero(least)):
            i, k = int(i) + 1, int(k)
            if excluded(k):
                continue
            ci = values[i, k]
            x, ok = samples[i], False
            for it in range(T.MAX_IT):
                v[slot] = x
                C.module.hessian(k, v, g, H)
                dx = -g[0] / H[0, 0] if H[0, 0] != 0.0 else math.nan
                if not math.isfinite(dx):
                    break
                x += dx
                if not samples[i - 1] <= x <= samples[i + 1]:
                    break
                if abs(dx) <= 1e-3 * spec.tol:
                    ok = True
                    break
            v[slot] = x
            cx, sx = C.module.gradient(k, v, g)
            if not ok or cx * ci >= 0.0 or abs(cx) <= nx.TOL * sx:
                continue
            if spec.side == "min":
                r = zero(k, samples[i - 1], x)
            else:
                r = zero(k, x, samples[i + 1])
            step = 1.0 if spec.side == "min" else -1.0
            eps = 1e-3 * abs(x - r)
            if _class_at(m, v, slot, r + step * eps, spec.layer) != spec.value \
                    or _class_at(m, v, slot, r - step * eps, spec.layer) == spec.value:
                continue
            if best is None or spec.sign * r < spec.sign * best.value:
                v[slot] = r
                cr, sr = C.module.gradient(k, v, g)
                best = Threshold(p, r, {p: r}, C.names[k], "root",
                                 abs(cr) / sr if sr > 0 else abs(cr), 0.0, math.nan,
                                 spec.side)
        return best

    sliver = thin()
    classes = evaluate(m, {p: samples}, fixed, [layers_for(m)[spec.layer]])[spec.layer]
    inside = classes == spec.value
    if not inside.any():
        return sliver
    first = 0 if spec.side == "min" else len(samples) - 1
    if inside[first]:
        return Threshold(p, samples[first], {p: float(samples[first])}, "", "edge", 0.0, 0.0,
                         float(samples[first]), spec.side)
    for i in order:
        a, b = (i, i + 1) if spec.side == "min" else (i + 1, i)
        if sliver is not None and spec.sign * sliver.value <= spec.sign * samples[b]:
            return sliver  # met before the samples' first class change
        if inside[b] and not inside[a]:
            found = []
            for k in range(nc):
                if excluded(k):
                    continue
                if crosses(k, i, i + 1):
                    r = root(k, i, i + 1)
                    if r is not None:
                        found.append((spec.sign * r[0], k, r))
            if not found:
                raise ValueError(f"{m.name}: {spec.layer} changes between {p} = "
                                 f"{samples[i]:.12g} and {samples[i + 1]:.12g} where no "
                                 "condition changes sign: the conditions do not explain it")
            # the root where the class becomes the region's, nearest the outside sample
            found.sort(key=lambda t: abs(t[2][0] - samples[a]))
            step = 1.0 if b > a else -1.0
            good = []
            for _, k, r in found:
                # the classes either side, beyond the condition's ties (wide where its
                # terms are large): at most a thousand times that, and half a sample, so
                # that the step never reaches another condition's root nearby (a drawer's
                # stagnation edge 2.2e-3 beyond a family bound's root was taken for it)
                eps = max(1e-9 * (hi - lo), 4.0 * r[3])
                reach = min(0.5 * (samples[1] - samples[0]), 1e3 * eps)
                while eps <= reach:
                    if _class_at(m, v, slot, r[0] + step * eps, spec.layer) == spec.value \
                            and _class_at(m, v, slot, r[0] - step * eps,
                                          spec.layer) != spec.value:
                        good.append((k, r))
                        break
                    eps *= 10.0
            if good:
                # conditions that vanish together (a family's pair where both its slopes
                # do): the root of the one solved best, among those at the first one
                k, r = min((kr for kr in good if abs(kr[1][0] - good[0][1][0]) <= spec.tol),
                           key=lambda kr: kr[1][1])
                return Threshold(p, r[0], {p: r[0]}, C.names[k], "root", r[1], r[2],
                                 float(samples[b]), spec.side)
            raise ValueError(f"{m.name}: {spec.layer} changes between {p} = "
                             f"{samples[i]:.12g} and {samples[i + 1]:.12g} at none of the "
                             "conditions' roots there")
    return sliver


__all__ = ["Spec", "Threshold", "solve"]
