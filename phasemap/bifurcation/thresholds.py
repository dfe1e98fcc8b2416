"""``phasemap.threshold``: the least (or greatest) parameter at which a class exists."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from .. import _numerics as nx
from ..grid import evaluate
from ..layers import layers_for
from ..model import Model
from ..models import get_model
from . import _trace as T
from .tracing import LAYERS, Slice, Traced, condition_name, make_slice, parse_range, trace
from .conditions import compiled

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
        the raster's best cell in the region (a cell's width from the exact value).
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

    def __post_init__(self):
        # plain floats: the numbers print and compare as they read
        object.__setattr__(self, "value", float(self.value))
        object.__setattr__(self, "at", {str(k): float(v) for k, v in self.at.items()})

    def __repr__(self) -> str:
        at = ", ".join(f"{k}={v:.12g}" for k, v in self.at.items())
        return (f"Threshold({self.param} {'>=' if self.side == 'min' else '<='} "
                f"{self.value:.15g} at {at}; {self.kind} of {self.condition or '-'}; "
                f"residual {self.residual:.1e})")


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
        None where the region is empty in the given ranges.

    Raises
    ------
    ValueError
        naming the argument: an unknown model, parameter, variable or layer, a
        range that is empty or outside the domain, more than two names in ``over``
        besides the parameter (not supported), or a region whose extremum cannot
        be located to ``tol``.

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
        from .curve import threshold_curve

        return threshold_curve(m, param, layer, value, over, fixed, side, tol, along,
                               conditions)
    spec = _Spec.make(m, param, layer, value, over, fixed, side, tol)
    if len(spec.others) == 0:
        return _line(spec, conditions)
    if len(spec.others) == 2:
        from .curve import threshold_volume

        return threshold_volume(spec, conditions)
    return _plane(spec, conditions)


@dataclass
class _Spec:
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
    def make(m: Model, param, layer, value, over, fixed, side, tol) -> "_Spec":
        if param not in m.variables:
            raise ValueError(f"{m.name}: unknown variable {param!r}; allowed: {', '.join(m.names)}")
        if layer not in LAYERS + ("singular",):
            raise ValueError(f"layer must be one of {', '.join(LAYERS + ('singular',))}, "
                             f"got {layer!r}")
        reg = layers_for(m)[layer]
        try:
            value = int(value)
        except (TypeError, ValueError):
            raise ValueError(f"value must be one of the flag values of {layer}, "
                             f"got {value!r}") from None
        if value not in reg.flag_values:
            raise ValueError(f"value must be one of the flag values of {layer} "
                             f"({reg.flag_meanings}: {list(reg.flag_values)}), got {value}")
        if layer == "singular" and value != 1:
            raise ValueError("layer singular holds on curves: only value=1 has a threshold")
        if side not in ("min", "max"):
            raise ValueError(f"side must be 'min' or 'max', got {side!r}")
        try:
            tol = float(tol)
        except (TypeError, ValueError):
            raise ValueError(f"tol must be a number, got {tol!r}") from None
        if not 0.0 < tol < 1.0:
            raise ValueError(f"tol must be in (0, 1), got {tol:g}")
        over = dict(over or {})
        fixed = dict(fixed or {})
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
        return _Spec(m, param, layer, value, ranges, others, fixed, side, tol)


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

def _plane(spec: _Spec, conditions) -> Threshold | None:
    other, p = spec.others[0], spec.param
    axes = {other: spec.ranges[other], p: spec.ranges[p]}
    sl = make_slice(spec.model, axes, spec.fixed, conditions)
    if spec.layer == "singular":
        only = np.array([k == "coefficient" for k in sl.conds.kinds])
        tr = trace(sl, "n_solutions", spec.tol, only=only)
        n = int(tr.buf.counts[0])
        rows = np.arange(n)
        rows = rows[np.isin(tr.buf.vi[:n, 2], np.flatnonzero(only))]
        return _best(sl, spec, tr, rows, edge=None, bound=math.nan)
    tr = trace(sl, spec.layer, spec.tol)
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


def _best(sl: Slice, spec: _Spec, tr: Traced, rows: np.ndarray, edge, bound) -> Threshold | None:
    """The least (greatest) parameter among the candidate vertices ``rows`` and, where
    the region reaches the parameter's own edge (cells ``edge`` along the other
    axis), that edge."""
    vf, vi = tr.buf.vf, tr.buf.vi
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
        pvals = lo + vf[rows, 1] * (hi - lo)
        extreme = np.min(sign * pvals)
        near = rows[sign * pvals <= extreme + spec.tol]
        q = min(near, key=lambda r: (_PREFERENCE[int(vi[r, 1])], sign * vf[r, 1]))
        best = sign * extreme
    edge_value = lo if spec.side == "min" else hi
    if edge is not None and (best is None or sign * edge_value <= sign * best + spec.tol):
        # the region reaches the parameter's own edge: a piece's end there, if any
        at_edge = [] if not len(rows) else rows[(vi[rows, 1] == T.END)
                                                & (np.abs(vf[rows, 1] - (0.0 if sign > 0 else 1.0))
                                                   <= 1e-15)]
        if len(at_edge):
            q = at_edge[0]
            other_value = olo + vf[q, 0] * (ohi - olo)
            cond = condition_name(sl, tr, int(vi[q, 2]))
            res = float(vf[q, 2])
        else:
            other_value = olo + float(edge[0]) * (ohi - olo)
            cond, res = "", 0.0
        result = Threshold(spec.param, edge_value, {spec.others[0]: other_value,
                                                    spec.param: edge_value}, cond, "edge",
                           res, 0.0, bound, spec.side)
    else:
        kind = int(vi[q, 1])
        names = [condition_name(sl, tr, int(vi[q, 2]))]
        if kind in (T.CROSSING, T.TANGENCY) and vi[q, 3] >= 0:
            names.append(condition_name(sl, tr, int(vi[q, 3])))
        if kind == T.FOLD_Y:
            kname = f"fold_{spec.param}"
        elif kind == T.FOLD_X:
            kname = f"fold_{spec.others[0]}"
        else:
            kname = {T.CROSSING: "crossing", T.END: "end", T.TANGENCY: "tangency",
                     T.REGULAR: "flat", T.STALL: "stall", T.CHANGE: "change"}[kind]
        pv = lo + vf[q, 1] * (hi - lo)
        result = Threshold(spec.param, float(pv), {spec.others[0]: olo + vf[q, 0] * (ohi - olo),
                                                   spec.param: float(pv)},
                           " ".join(names), kname, float(vf[q, 2]), float(vf[q, 3]) * spec.tol,
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

def _line(spec: _Spec, conditions) -> Threshold | None:
    m, p = spec.model, spec.param
    lo, hi = spec.ranges[p]
    C = compiled(m, (p,), conditions)
    full = m.complete({**spec.fixed, p: np.array([lo, hi])})
    fixed = {n: float(v) for n, v in full.items() if n != p}
    samples = np.linspace(lo, hi, LINE_SAMPLES + 1)
    base = m.input_vector({**fixed, p: lo})
    slot = m.inputs.index(p)
    nc = len(C)
    values = np.empty((len(samples), nc))
    scales = np.empty(nc)
    v = base.copy()
    for i, x in enumerate(samples):
        v[slot] = x
        C.module.values(v, values[i], scales)
    g = np.empty(1)

    def root(k, a, b):
        """c_k = 0 between samples a and b, by Newton from the secant point."""
        ca, cb = values[a, k], values[b, k]
        x = samples[a] + ca / (ca - cb) * (samples[b] - samples[a])
        for it in range(T.MAX_IT):
            v[slot] = x
            c, s = C.module.gradient(k, v, g)
            if g[0] == 0.0 or not math.isfinite(c):
                return None
            step = -c / g[0]
            x += step
            if abs(step) <= 1e-3 * spec.tol:
                break
        v[slot] = x
        c, s = C.module.gradient(k, v, g)
        if not (samples[a] - spec.tol <= x <= samples[b] + spec.tol):
            return None
        return x, abs(c) / s if s > 0 else abs(c), abs(step)

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
    classes = evaluate(m, {p: samples}, fixed, [layers_for(m)[spec.layer]])[spec.layer]
    inside = classes == spec.value
    if not inside.any():
        return None
    first = 0 if spec.side == "min" else len(samples) - 1
    if inside[first]:
        return Threshold(p, samples[first], {p: float(samples[first])}, "", "edge", 0.0, 0.0,
                         float(samples[first]), spec.side)
    for i in order:
        a, b = (i, i + 1) if spec.side == "min" else (i + 1, i)
        if inside[b] and not inside[a]:
            found = []
            for k in range(nc):
                if C.rest_only[k] and abs(fixed.get(m.velocity, 1.0)) > 0 and m.velocity != p:
                    continue
                if values[i, k] * values[i + 1, k] < 0.0:
                    r = root(k, i, i + 1)
                    if r is not None:
                        found.append((spec.sign * r[0], k, r))
            if not found:
                raise ValueError(f"{m.name}: {spec.layer} changes between {p} = "
                                 f"{samples[i]:.12g} and {samples[i + 1]:.12g} where no "
                                 "condition changes sign: the conditions do not explain it")
            # the root where the class becomes the region's, nearest the outside sample
            found.sort(key=lambda t: abs(t[2][0] - samples[a]))
            eps = 1e-9 * (hi - lo)
            step = 1.0 if b > a else -1.0
            good = [(k, r) for _, k, r in found
                    if _class_at(m, v, slot, r[0] + step * eps, spec.layer) == spec.value
                    and _class_at(m, v, slot, r[0] - step * eps, spec.layer) != spec.value]
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
    return None


__all__ = ["Threshold", "threshold"]
