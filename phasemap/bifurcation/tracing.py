"""``phasemap.boundaries``: the class boundaries of a 2-D slice as exact curves."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache
from typing import Mapping

import numpy as np
import xarray as xr

from phasemap.core import tiers
from phasemap.core.memo import Memo
from phasemap.core import args as _args
from phasemap.atlas.dataset import cf_header
from phasemap.core.codegen import CELLS_SIGNATURE, grid_kernel
from phasemap.maps.layers import layers_for
from phasemap.core.model import Model
from phasemap.systems import get_model, reference
from phasemap.bifurcation import _trace as T
from phasemap.bifurcation.conditions import Conditions, compiled, values_of

#: Layers whose classes fill regions of a slice (``singular`` holds on curves).
LAYERS = ("n_solutions", "stagnation", "contact_lost")
_LAYER_CODE = {"n_solutions": 0, "stagnation": 1, "contact_lost": 2, "singular": 3}
#: Point kinds by vertex kind (``fold_<axis>`` is filled in with the axis name).
_KIND_NAMES = {T.CROSSING: "crossing", T.END: "end", T.TANGENCY: "tangency",
               T.CHANGE: "change", T.STALL: "stall"}

#: Nodes per side of the raster that seeds the tracing.
SEED_NODES = 33
#: Cells per side of the raster whose class changes every piece must explain.
CHECK_CELLS = 128
#: A seed starts a piece only within this many cells of a class change of that raster.
NEAR = 2


@dataclass
class Slice:
    """A validated 2-D slice: the model, its axes, fixed values and compiled pieces."""

    model: Model
    x: str
    y: str
    lo: np.ndarray  # (x_lo, y_lo)
    hi: np.ndarray
    fixed: dict
    conds: Conditions
    fns: tuple  # addresses of the functions a trace takes (phasemap.bifurcation._trace.ADDRESSES)
    base: np.ndarray  # the input vector with the fixed values
    #: traced by the tracer's interpreted twins (phasemap.bifurcation._trace.runs): then
    #: ``fns`` may hold handles of interpreted condition functions, which only they take
    twins: bool = False

    @cached_property
    def geo(self) -> np.ndarray:
        """(x_lo, x_span, y_lo, y_span): the map from the unit square to the axes (made
        once: every kernel call and conversion reads it; do not write it)."""
        return np.array([self.lo[0], self.hi[0] - self.lo[0], self.lo[1], self.hi[1] - self.lo[1]])

    @property
    def slots(self) -> tuple[int, int]:
        inputs = self.model.inputs
        return inputs.index(self.x), inputs.index(self.y)

    def physical(self, uw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows (u, w) of the unit square in the axes' units."""
        g0, g1, g2, g3 = self.geo.tolist()
        return g0 + uw[:, 0] * g1, g2 + uw[:, 1] * g3


def parse_tol(tol) -> float:
    """The tolerance ``tol`` as a float in (0, 1), or ValueError naming it."""
    try:
        tol = _args.real("tol", tol)
    except (TypeError, ValueError):
        raise ValueError(f"tol must be a number, got {_args.describe(tol)}") from None
    if not 0.0 < tol < 1.0:
        raise ValueError(f"tol must be in (0, 1), got {tol:g}")
    return tol


def check_tol(tol: float, ranges: Mapping) -> None:
    """ValueError unless ``tol`` (an accuracy in each coordinate, in its units) can be met
    on every range ``{name: (lo, hi)}``: below twice the spacing of doubles at a range's
    largest magnitude, Newton's corrections stall on rounding, and a threshold asked for
    to 1e-16 came back 8.1e-5 off, silently."""
    if not ranges:
        return
    need, name, lo, hi = max((2.0 * float(np.spacing(max(abs(float(lo)), abs(float(hi))))),
                              name, float(lo), float(hi)) for name, (lo, hi) in ranges.items())
    if tol < need:
        raise ValueError(f"tol = {tol:g} cannot be met: double precision resolves {name} in "
                         f"[{lo:g}, {hi:g}] only to about {need:.2g}; pass a larger tol")


def parse_range(m: Model, what: str, value) -> tuple[float, float]:
    """A range ``(lo, hi)`` of finite numbers with lo < hi, or ValueError naming ``what``."""
    return _args.finite_range(what, value, m.name)


def header(m: Model, kind: str, fixed: Mapping, **extra) -> dict:
    """The global attributes of a result: the CF header every phasemap Dataset carries
    (:func:`phasemap.atlas.dataset.cf_header`), then ``extra`` and the fixed values."""
    attrs = cf_header(m, kind) | extra
    for name, value in fixed.items():
        attrs[f"phasemap_fixed_{name}"] = value
    return attrs


def make_slice(model, axes: Mapping, fixed: Mapping | None, conditions=None) -> Slice:
    """Validate a slice (two axes with their ranges, fixed values) and compile its tracer."""
    m = get_model(model)
    if not isinstance(axes, Mapping) or len(axes) != 2:
        raise ValueError(f"{m.name}: axes must name two variables with their ranges, "
                         f"{{x: (lo, hi), y: (lo, hi)}}; got {_args.describe(axes)}")
    axes = _args.mapping("axes", axes, m.name)
    fixed = _args.mapping("fixed", fixed, m.name)
    names = list(axes)
    variables = m.variables
    lo, hi = [], []
    for name in names:
        if name not in variables:
            raise ValueError(f"{m.name}: unknown variable {name!r}; allowed: {', '.join(m.names)}")
        if name in fixed:
            raise ValueError(f"{m.name}: {name!r} is both an axis and fixed")
        a, b = parse_range(m, f"axis {name}", axes[name])
        lo.append(a)
        hi.append(b)
    for name, value in fixed.items():
        if np.ndim(value) != 0:
            raise ValueError(f"{m.name}: fixed value {name} must be a scalar")
    full = _complete(m, variables, fixed, names, lo, hi)
    fixed = {n: float(v) for n, v in full.items() if n not in axes}
    base = m.input_vector({**fixed, names[0]: lo[0], names[1]: lo[1]})
    # which conditions can bound a class here, read from the values alone; only their
    # derivatives are compiled (a moving slice of the drawer needs 11 of its 62), and
    # the trace's own test (phasemap.bifurcation._trace._applicable_all, the same
    # function on the same arguments) never asks for another's
    # the tier of the whole slice: on the tracer's twins (while numba compiles it) the
    # condition functions not yet compiled are twins too, compiled in the background
    twins = T.on_twins(T.runs())
    values = values_of(m, conditions)
    ref = reference(m)
    probe = Slice(m, names[0], names[1], np.array(lo), np.array(hi), fixed, values,
                  T.functions(m, values, twins, (T.compile_conditions,
                                                 (ref, conditions, None, None), {})),
                  base, twins)
    active, _ = _applicable(probe)
    subset = None if active.all() else tuple(np.flatnonzero(active).tolist())
    conds = compiled(m, tuple(names), conditions, subset)
    return replace(probe, conds=conds, fns=T.functions(m, conds, twins, (
        T.compile_conditions, (ref, conditions, tuple(names), subset), {})))


def _complete(m: Model, variables: dict, fixed: dict, names: list, lo: list,
              hi: list) -> dict:
    """The slice's values completed with the model's defaults (:meth:`Model.complete`),
    the axes validated at the slice's four corners.

    Where each axis's range lies in its variable's domain, the axes enter as numbers
    (Model.complete's fast path; a third of the cost) and the model's own check
    (:attr:`Model.check`, if any) sees the corners; otherwise, and wherever a check
    fails, the corners go through Model.complete, whose error is the one raised.
    ``variables``: the model's (:attr:`Model.variables`, a new dict at every access)."""
    corners = {names[0]: np.array([lo[0], hi[0]]).reshape(-1, 1),
               names[1]: np.array([lo[1], hi[1]]).reshape(1, -1)}
    if all(variables[n]._fine(a) and variables[n]._fine(b) for n, a, b in zip(names, lo, hi)):
        try:
            full = m.complete({**fixed, names[0]: lo[0], names[1]: lo[1]})
            if m.check is not None:
                m.check({**full, **corners})
            return full
        except ValueError:
            pass
    return m.complete({**fixed, **corners})


#: The points of the unit square where :func:`_active` compares the conditions.
_SURVEY = np.random.default_rng(20261123).uniform(0.02, 0.98, size=(12, 2))


_KINDS = Memo("tracing.kinds")


def _kinds(m: Model, conds: Conditions) -> tuple[np.ndarray, np.ndarray]:
    """Per condition, once per model and condition set: the index of its branch among
    the model's candidates (-1 for none or a branch the model does not have), and
    whether it is the velocity condition."""
    def make():
        index = {b.name: i for i, b in enumerate(m.candidates)}
        branch = np.array([index.get(br, -1) if br else -1 for br in conds.branches],
                          dtype=np.int64)
        return branch, np.array([k == "velocity" for k in conds.kinds], dtype=bool)

    return _KINDS.get((m, conds), (), make)


#: Where :func:`_applicable` classifies the slice (unit square): its centre, and its
#: corners too where the velocity is an axis (its sign picks the branches).
_PROBES = np.array([(0.5, 0.5)])
_PROBES_VELOCITY = np.array([(0.5, 0.5), (0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (1.0, 0.0)])


def _applicable_args(sl: Slice) -> tuple:
    """What the trace's compiled :func:`phasemap.bifurcation._trace._applicable_all` takes
    to do what :func:`_applicable` does (:data:`phasemap.bifurcation._trace.APPLICABLE`)."""
    m = sl.model
    velocity_axis = m.velocity in (sl.x, sl.y)
    branch, velocity = _kinds(m, sl.conds)
    return (_PROBES_VELOCITY if velocity_axis else _PROBES, branch, velocity,
            sl.conds.rest_only, velocity_axis, m.inputs.index(m.velocity))


def _applicable(sl: Slice) -> tuple[np.ndarray, np.ndarray]:
    """Which conditions can bound a class in the slice, before comparing their values
    (:func:`_active`), and the input vector of the last probe (its derived inputs
    filled) for that comparison: :func:`phasemap.bifurcation._trace._applicable_all`,
    which a trace runs inside its one call."""
    active = np.empty(len(sl.conds), dtype=bool)
    v = sl.base.copy()
    m = sl.model
    T.runs(sl.twins)["applicable"](sl.fns, v, np.empty((len(m.candidates), m.n_fields)),
                                   *sl.slots, sl.geo, _applicable_args(sl), active)
    return active, v


def _active(sl: Slice) -> tuple[np.ndarray, np.ndarray]:
    """Which conditions can bound a class in the slice, and one representative per
    group of conditions with the same zero set.

    A condition is dropped when its branch does not apply anywhere in the slice
    (the velocity's sign excludes it), when it holds only at rest and the
    velocity is an axis (a line), or when it does not vary over the slice.
    Conditions whose values are proportional at random points of the slice
    share their zero set: one traces it.  Returns ``(active, group)``.
    """
    active, v = _applicable(sl)
    # values at random points: constant conditions, and proportional ones
    ix, iy = sl.slots
    vals = np.empty((len(_SURVEY), len(sl.conds)))
    run = T.runs(sl.twins)
    run["survey"](sl.fns, v, ix, iy, sl.geo, _SURVEY, vals)
    group = run["groups"](vals, active)
    return active, group


@dataclass
class Traced:
    """What the tracer found in a slice (unit-square coordinates)."""

    pv: np.ndarray  # piece vertices (u, w)
    pp: np.ndarray  # piece of each vertex
    pq: np.ndarray  # index of each piece vertex in the vertex buffers
    pieces: np.ndarray  # (curve, condition, left, right, closed)
    points_f: np.ndarray  # (u, w, residual, error)
    points_i: np.ndarray  # (kind, condition, other)
    group: np.ndarray
    active: np.ndarray
    buf: "_Buffers"  # every traced curve, pieces or not
    classes: np.ndarray | None = None  # the check raster (cell centres)
    #: rows (condition, u, w): extrema of a condition that may reach zero within a seed
    #: raster cell and that neither a refinement nor a traced curve resolved
    unresolved: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))
    #: rows (i, j, di, dj): class changes of the check raster, from cell (i, j) to
    #: (i + di, j + dj), that no piece explains (kept with ``strict=False`` only)
    unexplained: np.ndarray = field(default_factory=lambda: np.empty((0, 4), np.int64))
    raster: dict | None = None  # the check raster's cell centres, by axis name


class _Buffers:
    """The growing vertex buffers of a trace."""

    def __init__(self, nc: int, vertices: int = 1 << 14, curves: int = 1 << 10):
        self.verts = np.empty(vertices, dtype=T.VERTEX)
        self.curves = np.empty((curves, 4), dtype=np.int64)
        self.counts = np.zeros(3, dtype=np.int64)

    def grown(self) -> "_Buffers":
        bigger = _Buffers(0, 4 * self.verts.shape[0], 4 * self.curves.shape[0])
        return bigger


def trace(sl: Slice, layer: str, tol: float, seed_nodes: int = SEED_NODES,
          check_cells: int = CHECK_CELLS, only: np.ndarray | None = None,
          strict: bool = True) -> Traced:
    """Trace every boundary piece of the slice and check it against a finer raster.

    ``only``: a mask of the conditions to trace, whole (not only where they
    bound a class; no check against the raster).  Class changes of the raster that
    no piece explains raise ValueError, or with ``strict=False`` are kept in
    ``Traced.unexplained`` (rows: the two cells' indices on the raster) with a warning.
    """
    fns, m = sl.fns, sl.model
    run = T.runs(sl.twins)
    code = _LAYER_CODE[layer]
    if only is not None:
        check_cells = 0
    ix, iy = sl.slots
    geo = sl.geo
    tol_u, tol_w = tol / geo[1], tol / geo[3]
    v = sl.base.copy()
    out = np.empty((len(m.candidates), m.n_fields))
    nc = len(sl.conds)
    buf = _Buffers(nc)
    mark = np.zeros((nc, seed_nodes - 1, seed_nodes - 1), dtype=np.int8)
    if check_cells:
        axes = _cell_centres(sl, check_cells)
        # the check raster, _active's comparison of the conditions, the seeds, the trace,
        # its pieces and the completeness check: one call
        active = np.empty(nc, dtype=bool)
        classes, near, seeds, group, grp, changes, *assembled, bad = run["seed_trace"](
            fns, _SURVEY, sl.base.copy(), _applicable_args(sl), _raster_args(sl, layer, axes),
            NEAR, active, _rank(sl.conds), v, out, ix, iy, geo, code, seed_nodes, buf.verts,
            buf.counts, buf.curves, mark, tol_u, tol_w)
    else:
        active, group = _active(sl)
        if only is not None:
            active = active & only
        grp = _ranked(sl.conds, group)
        near = np.ones((1, 1), dtype=bool)
        seeds = run["seeds"](fns, active, v, ix, iy, geo, seed_nodes, near)
        run["trace"](fns, seeds, grp, active, v, out, ix, iy, geo, code, buf.verts,
                     buf.counts, buf.curves, mark, near, tol_u, tol_w, only is None)
    thin = run["thin"](fns, active, v, ix, iy, geo, seed_nodes)
    extra = thin[thin[:, 3] == 0.0]
    more = 0
    if len(extra):
        if check_cells:  # a seed of a thin region starts a curve where no class change is near
            n = near.shape[0]
            cell = np.clip((extra[:, 1:3] * n).astype(np.int64), 0, n - 1)
            near[cell[:, 0], cell[:, 1]] = True
        if not buf.counts[2]:
            more = run["trace"](fns, extra, grp, active, v, out, ix, iy, geo, code, buf.verts,
                                buf.counts, buf.curves, mark, near, tol_u, tol_w,
                                only is None)
        seeds = np.concatenate((seeds, extra))
    full = bool(buf.counts[2])
    while buf.counts[2]:  # the buffers were full: again with larger ones
        buf = buf.grown()
        mark[:] = 0
        run["trace"](fns, seeds, grp, active, v, out, ix, iy, geo, code, buf.verts,
                     buf.counts, buf.curves, mark, near, tol_u, tol_w, only is None)
    if check_cells and not full and not more:
        traced = Traced(*assembled, group, active, buf)
    else:
        traced = _assembled(buf, group, active, run)
    traced.unresolved = _unresolved(thin, mark)
    if check_cells:
        traced.classes = classes
        if full or more:
            bad = run["uncovered"](check_cells, changes, traced.pv, traced.pp)
        if len(bad):
            rescue = _rescue_seeds(sl, active, bad, check_cells)
            if len(rescue):
                fine = np.zeros((nc, check_cells, check_cells), dtype=np.int8)
                for p in range(len(traced.pieces)):
                    sel = traced.pv[traced.pp == p]
                    for q in range(len(sel) - 1):
                        run["mark"](fine, int(traced.pieces[p, 1]), sel[q, 0], sel[q, 1],
                                sel[q + 1, 0], sel[q + 1, 1])
                run["trace"](fns, rescue, grp, active, v, out, ix, iy, geo, code, buf.verts,
                             buf.counts, buf.curves, fine, near, tol_u, tol_w, True)
                if buf.counts[2]:
                    raise RuntimeError(f"{m.name}: more than {buf.verts.shape[0]} vertices")
                traced = _assembled(buf, group, active, run)
                traced.classes, traced.unresolved = classes, _unresolved(thin, mark)
                bad = run["uncovered"](check_cells, changes, traced.pv, traced.pp)
            if len(bad):
                message = _uncovered_message(sl, layer, classes, bad, axes)
                if strict:
                    raise ValueError(message)
                warnings.warn(message + "; returned with those cells as unexplained_*",
                              stacklevel=3)
                traced.unexplained = np.asarray(bad, dtype=np.int64).reshape(-1, 4)
                traced.raster = axes
    return traced


#: Which condition traces a stretch where several vanish together: the first kind here
#: (a start from rest is where a stick ends, so the stick's limit names it).
KIND_RANK = ("coefficient", "normal", "gap", "friction_limit", "family", "discriminant", "root",
             "domain", "velocity", "start")


@lru_cache(maxsize=None)
def _rank(conds: Conditions) -> np.ndarray:
    """Each condition's rank (:data:`KIND_RANK`, then its index), once per condition set."""
    order = sorted(range(len(conds)), key=lambda k: (KIND_RANK.index(conds.kinds[k])
                                                      if conds.kinds[k] in KIND_RANK
                                                      else len(KIND_RANK), k))
    rank = np.empty(len(conds), dtype=np.int64)
    rank[order] = np.arange(len(conds))
    return rank


def _ranked(conds: Conditions, group: np.ndarray) -> np.ndarray:
    """Per condition: its group (conditions proportional in the slice) and its rank."""
    grp = np.empty((len(conds), 2), dtype=np.int64)
    grp[:, 0] = group
    grp[:, 1] = _rank(conds)
    return grp


def _assembled(buf: _Buffers, group, active, run: dict) -> Traced:
    pv, pp, pq, pieces, pf, pi = run["assemble"](buf.verts, buf.curves, int(buf.counts[1]))
    return Traced(pv, pp, pq, pieces, pf, pi, group, active, buf)


@lru_cache(maxsize=None)
def _centres(n: int) -> np.ndarray:
    """The centres of n cells across the unit interval, once per n (do not write them)."""
    return (np.arange(n) + 0.5) / n


def _cell_centres(sl: Slice, n: int) -> dict:
    t = _centres(n)
    return {sl.x: sl.lo[0] + t * (sl.hi[0] - sl.lo[0]), sl.y: sl.lo[1] + t * (sl.hi[1] - sl.lo[1])}


def _check_raster(sl: Slice, layer: str, axes: dict) -> np.ndarray:
    """The layer's classes at the cell centres ``axes`` (x outer, y inner): the scene's
    own grid kernel (:func:`phasemap.core.codegen.grid_kernel`), what :func:`phasemap.maps.grid.evaluate`
    runs, called row by row from compiled code (:func:`phasemap.bifurcation._trace._raster_all`;
    a trace computes it inside its one call)."""
    at, x, xslot, xderiv, y, yderiv = _raster_args(sl, layer, axes)
    flags = np.empty((1, len(x) * len(y)), dtype=np.int8)
    T.runs(sl.twins)["raster"](at, sl.base.copy(), sl.slots[0], x, xslot, xderiv, y, yderiv,
                               flags, np.empty((0, flags.shape[1])))
    return flags.reshape(len(x), len(y))


def _raster_args(sl: Slice, layer: str, axes: dict) -> tuple:
    """The check raster's arguments (:data:`phasemap.bifurcation._trace.RASTER`) at the
    cell centres ``axes``: the grid kernel's address, x's values, the slots and values
    of x's derived inputs, y's values and its derived inputs' values."""
    at, from_x, from_y, xslot = _raster_kernel(sl.model, sl.x, sl.y, layer)
    x, y = axes[sl.x], axes[sl.y]
    xderiv = np.empty((len(from_x), len(x)))
    for k, d in enumerate(from_x):
        xderiv[k] = d.func(x)
    yderiv = np.empty((len(from_y), len(y)))
    for k, d in enumerate(from_y):
        yderiv[k] = d.func(y)
    return at, x, xslot, xderiv, y, yderiv


_RASTER_KERNELS = Memo("tracing.raster_kernels")


def _raster_kernel(m: Model, x: str, y: str, layer: str) -> tuple:
    """What the check raster takes that does not depend on the ranges, once per model,
    axes and layer: the address of the layer's grid kernel with y inner, the derived
    inputs of x and of y, and the slots of x's."""
    def make():
        from_x = [d for d in m.derived if d.source == x]
        slot = {n: i for i, n in enumerate(m.inputs)}
        cells = grid_kernel(m, (layers_for(m)[layer],), y)
        # the kernel is kept with its address, so that the code stays loaded
        return (cells, tiers.addressed(cells, CELLS_SIGNATURE.args),
                from_x, [d for d in m.derived if d.source == y],
                np.array([slot[d.name] for d in from_x], dtype=np.int64))

    return _RASTER_KERNELS.get((m,), (x, y, layer), make)[1:]


def _unresolved(thin: np.ndarray, mark: np.ndarray) -> np.ndarray:
    """The unresolved extrema of :func:`phasemap.bifurcation._trace._thin_all` (status 2)
    whose seed raster cell no traced curve of their condition crosses: rows
    (condition, u, w)."""
    rows = thin[thin[:, 3] == 2.0, :3]
    n = mark.shape[1]
    k = rows[:, 0].astype(np.int64)
    i, j = (np.clip((rows[:, 1:3] * n).astype(np.int64), 0, n - 1).T)
    return rows[mark[k, i, j] == 0]


def unresolved_points(sl: Slice, traced: Traced) -> list[dict]:
    """The unresolved extrema of a trace (:attr:`Traced.unresolved`), each as
    ``{x: value, y: value, "condition": name}``; a warning names them."""
    points = []
    if len(traced.unresolved):
        px, py = sl.physical(traced.unresolved[:, 1:3])
        for k, a, b in zip(traced.unresolved[:, 0].astype(int).tolist(), px.tolist(),
                           py.tolist()):
            points.append({sl.x: a, sl.y: b, "condition": condition_name(sl, traced, k)})
        listed = "; ".join(f"{p['condition']} at {sl.x}={p[sl.x]:.6g}, {sl.y}={p[sl.y]:.6g}"
                           for p in points[:5])
        more = f" and {len(points) - 5} more" if len(points) > 5 else ""
        warnings.warn(f"{sl.model.name}: {len(points)} extrema of a condition may reach zero "
                      f"within a cell of the {SEED_NODES}^2 seed raster, and neither Newton nor "
                      f"sampling could tell: {listed}{more}. A region thinner than that may be "
                      "missed there (see the result's unresolved points)", stacklevel=3)
    return points


def _rescue_seeds(sl: Slice, active, bad, n: int) -> np.ndarray:
    """Seeds for class changes of the check raster that no piece explains: each
    active condition that changes sign between the two cells, or comes within two
    cells of them."""
    C = sl.conds
    # the functions the trace took (machine code, or twins where it ran on them)
    values, gradient = tiers.callable_at(sl.fns[0]), tiers.callable_at(sl.fns[1])
    ix, iy = sl.slots
    v = sl.base.copy()
    nc = len(C)
    a = np.empty(nc)
    b = np.empty(nc)
    s = np.empty(nc)
    g = np.empty(2)
    rows = []
    for i, j, di, dj in bad:
        ua, wa = (i + 0.5) / n, (j + 0.5) / n
        ub, wb = (i + di + 0.5) / n, (j + dj + 0.5) / n
        for (u, w, out) in ((ua, wa, a), (ub, wb, b)):
            v[ix] = sl.lo[0] + u * (sl.hi[0] - sl.lo[0])
            v[iy] = sl.lo[1] + w * (sl.hi[1] - sl.lo[1])
            values(v, out, s)
        for k in np.flatnonzero(active):
            if a[k] * b[k] < 0:
                t = a[k] / (a[k] - b[k])
                rows.append((k, ua + t * (ub - ua), wa + t * (wb - wa), 0.0))
                continue
            v[ix] = sl.lo[0] + ua * (sl.hi[0] - sl.lo[0])
            v[iy] = sl.lo[1] + wa * (sl.hi[1] - sl.lo[1])
            c, sc = gradient(int(k), v, g)
            if math.hypot(g[0] * sl.geo[1], g[1] * sl.geo[3]) * 2.0 / n >= abs(c):
                rows.append((k, ua, wa, 0.0))
    return np.array(rows, dtype=float).reshape(-1, 4)


def _uncovered_message(sl, layer, classes, bad, axes) -> str:
    x, y = axes[sl.x], axes[sl.y]
    cells = []
    for i, j, di, dj in bad[:5]:
        cells.append(f"({sl.x}={x[i]:.6g}, {sl.y}={y[j]:.6g}: {classes[i, j]}) -> "
                     f"({sl.x}={x[i + di]:.6g}, {sl.y}={y[j + dj]:.6g}: {classes[i + di, j + dj]})")
    more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
    return (f"{sl.model.name}: {len(bad)} class change(s) of {layer} on a {classes.shape[0]}^2 "
            f"raster lie more than one cell from every traced piece: {'; '.join(cells)}{more}. "
            "The conditions of the model do not explain them (a condition is missing, or a "
            "piece is shorter than the tracer's seeds can reach)")


# -- the Dataset ------------------------------------------------------------------------

def _unique_points(traced: Traced, tol_uw: float):
    """The points of the trace, each once (a crossing is found from both its curves)."""
    uw = traced.points_f[:, :2].tolist()
    kinds = traced.points_i[:, 0].tolist()
    keep = []
    for q, (u, w) in enumerate(uw):
        for r in keep:
            if kinds[r] == kinds[q] and abs(uw[r][0] - u) <= tol_uw \
                    and abs(uw[r][1] - w) <= tol_uw:
                break
        else:
            keep.append(q)
    return np.array(keep, dtype=np.int64)


def condition_name(sl: Slice, traced: Traced, k: int) -> str:
    """A condition's name, with those of the conditions that share its zero set."""
    names = sl.conds.names
    same = [names[j] for j, g in enumerate(traced.group.tolist()) if g == k]
    return ",".join(dict.fromkeys([names[k], *same]))


def _variable(dim: str, data: np.ndarray, attrs: dict) -> xr.Variable:
    """A 1-D Variable of an array of ours, made as ``xr.Variable((dim,), data, attrs,
    fastpath=True)`` makes it (its four slots; no encoding) without asking whether the
    data is dask, pandas or a nested xarray object, nor parsing the dimensions: a
    fifth of the cost, and a Dataset of a slice holds 14."""
    var = object.__new__(xr.Variable)
    var._dims, var._data, var._attrs, var._encoding = (dim,), data, attrs, None
    return var


_LABELS = Memo("tracing.labels")


def _labels(sl: Slice, layer: str) -> tuple:
    """What the Dataset of a slice takes from its model, axes and layer alone, once per
    model, axes and layer: each axis's (units, long_name), and the layer's flag values
    and meanings (the attribute dicts are made anew for every Dataset)."""
    m = sl.model
    def make():
        variables = m.variables
        reg = layers_for(m)[layer]
        return (tuple((variables[n].units, variables[n].long_name) for n in (sl.x, sl.y)),
                (tuple(reg.flag_values), reg.dtype, reg.flag_meanings)
                if reg.flag_values is not None else None)

    return _LABELS.get((m,), (sl.x, sl.y, layer), make)


def to_dataset(sl: Slice, traced: Traced, layer: str, tol: float) -> xr.Dataset:
    """The traced pieces and points as the Dataset :func:`boundaries` returns."""
    m = sl.model
    ((xu, xl), (yu, yl)), flag = _labels(sl, layer)
    px, py = sl.physical(traced.pv)
    V = _variable
    data = {
        sl.x: V("vertex", px, {"units": xu, "long_name": xl}),
        sl.y: V("vertex", py, {"units": yu, "long_name": yl}),
    }
    piece = V("vertex", traced.pp.astype(np.int32),
              {"long_name": "piece the vertex belongs to (index along dimension piece)"})
    pieces = traced.pieces
    named: dict[int, str] = {}

    def name(k: int) -> str:
        """condition_name, once per condition (points repeat their pieces' conditions)."""
        if k not in named:
            named[k] = condition_name(sl, traced, k)
        return named[k]

    def flags() -> dict:
        if flag is None:
            return {}
        return {"flag_values": np.array(flag[0], dtype=flag[1]), "flag_meanings": flag[2]}

    data["condition"] = V("piece", np.array([name(k) for k in pieces[:, 1].tolist()], dtype=str),
                          {"long_name": "the condition that vanishes on the piece"})
    data["class_left"] = V("piece", pieces[:, 2].astype(np.int8),
                           {"long_name": f"{layer} left of the piece (along its vertices)",
                            **flags()})
    data["class_right"] = V("piece", pieces[:, 3].astype(np.int8),
                            {"long_name": f"{layer} right of the piece (along its vertices)",
                             **flags()})
    data["closed"] = V("piece", pieces[:, 4].astype(np.int8),
                       {"long_name": "the piece is a closed loop (its last vertex is its first)",
                        "flag_values": np.array([0, 1], np.int8), "flag_meanings": "no yes"})
    keep = _unique_points(traced, 0.5 * tol / max(sl.geo[1], sl.geo[3]))
    pf, pi = traced.points_f[keep], traced.points_i[keep]
    qx, qy = sl.physical(pf)
    kinds = []
    other = []
    for kind, k, j in pi.tolist():
        if kind == T.FOLD_X:
            kinds.append(f"fold_{sl.x}")
        elif kind == T.FOLD_Y:
            kinds.append(f"fold_{sl.y}")
        else:
            kinds.append(_KIND_NAMES[kind])
        names = [name(k)]
        if kind in (T.CROSSING, T.TANGENCY) and j >= 0:
            names.append(name(j))
        other.append(" ".join(names))
    data[f"point_{sl.x}"] = V("point", qx, {"units": xu, "long_name": xl})
    data[f"point_{sl.y}"] = V("point", qy, {"units": yu, "long_name": yl})
    data["point_kind"] = V("point", np.array(kinds, dtype=str),
                           {"long_name": "kind of point: crossing, fold_<axis> (the piece turns "
                                         "back in that axis), end (on the slice's edge), "
                                         "tangency"})
    data["point_condition"] = V("point", np.array(other, dtype=str),
                                {"long_name": "the conditions that vanish at the point"})
    data["point_residual"] = V("point", pf[:, 2],
                               {"units": "1", "long_name": "largest residual of the point's "
                                "defining equations, relative to their tie scales"})
    data["point_error"] = V("point", pf[:, 3] * tol,
                            {"units": "1", "long_name": "size of the last Newton step in the "
                             "point's coordinates (an error estimate, in axis units)"})
    if len(traced.unexplained):
        data.update(_unexplained(sl, traced, layer, (xu, xl), (yu, yl), flags()))
    attrs = header(m, "boundaries", sl.fixed, phasemap_layer=layer,
                   phasemap_axes=json.dumps({sl.x: [sl.lo[0], sl.hi[0]],
                                             sl.y: [sl.lo[1], sl.hi[1]]}),
                   phasemap_tol=tol)
    # built directly: the variables share their dimensions and none has an index, so
    # xarray's merge and alignment (half the cost of a simple slice) have nothing to do
    dims = {"vertex": len(px), "piece": len(pieces), "point": len(qx)}
    if len(traced.unexplained):
        dims["unexplained"] = len(traced.unexplained)
    return xr.Dataset._construct_direct(
        {**data, "piece": piece}, {"piece"}, dims=dims, attrs=attrs, indexes={})


def _unexplained(sl: Slice, traced: Traced, layer: str, xl, yl, flags: dict) -> dict:
    """The class changes of the check raster no piece explains, as variables on the
    dimension ``unexplained``: each change's two cells (centres and classes)."""
    bad, axes, classes = traced.unexplained, traced.raster, traced.classes
    i, j, di, dj = bad.T
    V = _variable
    out = {}
    for end, (a, b) in (("from", (i, j)), ("to", (i + di, j + dj))):
        out[f"unexplained_{sl.x}_{end}"] = V("unexplained", axes[sl.x][a],
                                             {"units": xl[0], "long_name": f"{xl[1]} of the "
                                              f"cell the unexplained change goes {end}"})
        out[f"unexplained_{sl.y}_{end}"] = V("unexplained", axes[sl.y][b],
                                             {"units": yl[0], "long_name": f"{yl[1]} of the "
                                              f"cell the unexplained change goes {end}"})
        out[f"unexplained_class_{end}"] = V(
            "unexplained", classes[a, b].astype(np.int8),
            {"long_name": f"{layer} of the cell the unexplained change goes {end}", **flags})
    return out


def boundaries(model, axes: Mapping, fixed: Mapping | None = None, layer: str = "n_solutions",
               tol: float = 1e-10, *, conditions=None, strict: bool = True) -> xr.Dataset:
    """The class boundaries of a 2-D slice of a map, as exact curves.

    Parameters
    ----------
    model:
        a model name, a declaration file's path or a :class:`phasemap.Model`.
    axes:
        ``{x: (lo, hi), y: (lo, hi)}``: the slice's two axes and their ranges.
    fixed:
        values of the other variables (the rest take the model's defaults).
    layer:
        the classes whose boundaries are traced: ``"n_solutions"``,
        ``"stagnation"`` or ``"contact_lost"``.
    tol:
        the accuracy of every point, in each coordinate (axis units).
    conditions:
        the conditions to trace (:class:`phasemap.bifurcation.Condition`);
        by default the model's own (see :mod:`phasemap.bifurcation`).
    strict:
        True (the default): class changes of the check raster that no traced
        piece explains raise ValueError.  False, for debugging a declaration:
        the pieces are returned with those changes as data on a dimension
        ``unexplained`` (``unexplained_<x>_from``, ``unexplained_<y>_from``,
        ``unexplained_class_from`` and the same ``_to``: the two cells of each
        change), with a warning.

    Returns
    -------
    xarray.Dataset
        dimension ``vertex``: the vertices' coordinates (variables named after
        the axes) and ``piece``, the piece each belongs to, in order along it;
        dimension ``piece``: ``condition`` (the quantity that vanishes on it, in
        the model's names), ``class_left`` and ``class_right`` (the layer's
        values on either side, left of the direction of its vertices) and
        ``closed``; dimension ``point``: ``point_<x>``, ``point_<y>``,
        ``point_kind`` (``crossing``, ``fold_<axis>``, ``end``, ``tangency``),
        ``point_condition``, ``point_residual`` and ``point_error``.  Its
        attributes hold the slice's fixed values, ``phasemap_tol`` and the CF
        header of an atlas (:func:`phasemap.write_atlas` writes it).

    Raises
    ------
    ValueError
        for a bad model, axis, value or layer; and where a class change of the
        check raster lies more than one cell from every traced piece (naming
        the cells).

    Warns
    -----
    UserWarning
        where an extremum of a condition may reach zero within a cell of the seed
        raster and could not be resolved (a region thinner than a cell may hide
        there); the attribute ``phasemap_unresolved`` then lists those points (JSON).

    Examples
    --------
    The Painleve rod pushed towards its end (xdot < 0): no solution beyond the
    curve where the slide's coefficient 1 + 3 cos^2 theta - 3 f sin theta cos theta
    vanishes, which turns back in f at f = 4/3:

    >>> import phasemap
    >>> b = phasemap.boundaries("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)},
    ...                         fixed={"xdot": -1.0, "omega": 0.0})   # doctest: +SKIP
    >>> fold = b.point_kind == "fold_f"                              # doctest: +SKIP
    >>> float(b.point_f[fold][0])                                    # doctest: +SKIP
    1.3333333333333333
    """
    if not isinstance(layer, str) or layer not in LAYERS:
        raise ValueError(f"layer must be one of {', '.join(LAYERS)} (classes that fill "
                         f"regions), got {_args.describe(layer)}")
    tol = parse_tol(tol)
    sl = make_slice(model, axes, fixed, conditions)
    check_tol(tol, {sl.x: (sl.lo[0], sl.hi[0]), sl.y: (sl.lo[1], sl.hi[1])})
    traced = trace(sl, layer, tol, strict=bool(strict))
    ds = to_dataset(sl, traced, layer, tol)
    points = unresolved_points(sl, traced)
    if points:
        ds.attrs["phasemap_unresolved"] = json.dumps(points)
    return ds
