"""The compiled tracer: one set of numba functions for every model.

What is particular to a model reaches the tracer as the addresses of its
compiled functions, in the tuple ``F`` (:data:`ADDRESSES`, made once per model
by :func:`functions`): so the tracer compiles once (and is cached on disk), and
a new model or slice compiles only its small generated condition module.  Each
is called at its address in numba's calling convention:

``_values(F, x, out, scale)``, ``_gradient(F, k, x, g)``, ``_hessian(F, k, x, g, H)``
    the generated condition module (:mod:`phasemap.bifurcation.conditions`)
    of the slice's two axes: every condition's value and tie scale; one
    condition's value, tie scale and gradient (and Hessian) in (x, y);
``_classify(F, v, out, layer)``
    the model's class at a state, from its own ``point`` and ``summarize``
    (:func:`classifier`).

Coordinates
-----------
The tracer works in the unit square: ``u = (x - x_lo) / (x_hi - x_lo)`` and
``w`` likewise, so that step lengths, curvature and the chord error of a
vertex are fractions of the slice.  ``geo = (x_lo, x_span, y_lo, y_span)``
and the input slots ``ix``, ``iy`` place a point of the square in the input
vector ``v`` of the model (the fixed values already in it).

Records
-------
The vertices are records (:data:`VERTEX`): ``u, w, residual, error`` and ``curve, kind,
condition, other, left, right, owned``: what a vertex is (:data:`REGULAR`,
:data:`CROSSING`...), the condition it lies on, the other condition or axis that
defines a special point, the layer's class on each side (-1 where a side is not
sampled: at a crossing or an end), and whether the stretch is this condition's (0
where a condition that ranks first vanishes there too).  ``curves[c] = (condition,
first, stop, closed)``; ``counts = (vertices, curves, overflow)``.

A march (:func:`_march`) reads its slice from a :data:`Slice`, writes to a
:data:`Store`, keeps the special points of a step as :data:`SPECIAL` records, and the
state it goes back to as an :data:`At`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

from phasemap.core.jit import njit
from phasemap.core.memo import Memo
from phasemap.core import numerics as nx
from phasemap.core import calls, interpret, tiers
from phasemap.core.codegen import call_cells
from phasemap.core.types import B1, B2, F1, F2, I1, I2, S3

# vertex kinds
REGULAR = 0
CROSSING = 1
FOLD_X = 2
FOLD_Y = 3
END = 4
TANGENCY = 5
#: the class on a side changes where no condition vanishes (the conditions are incomplete)
CHANGE = 6
#: the curve could not be continued (its gradient vanishes: a singular point)
STALL = 7

#: Largest distance of a chord from its curve, as a fraction of the slice.
CHORD = 5e-5
#: Longest step (a fraction of the slice): crossings and class changes between two
#: vertices are found from the signs at the vertices.
H_MAX = 1.0 / 48.0
#: Shortest step before a curve is declared stalled.
H_MIN = 1e-9
#: Largest turn of the tangent over one step (rad).
ANGLE = 0.15
#: A vertex lies on its condition to this fraction of the condition's tie scale.
RESIDUAL = 1e-12
#: A marching curve samples the classes on its sides at least at every this many vertices
#: (and wherever a condition changes sign; see _march).
SIDE_EVERY = 8
#: Newton iterations per solve.
MAX_IT = 40
#: A condition whose value at a curve's vertex is below this fraction of its tie scale
#: vanishes there too: its zero set runs with the curve (the stretch is traced once, by
#: the condition that ranks first).
COVANISH = 1e-10
#: A curve longer than this (in slices) is stopped: it does not close.
MAX_LENGTH = 1000.0


# -- helpers without model globals ---------------------------------------------------

#: A traced vertex (see the module's docstring).
VERTEX = np.dtype([("u", np.float64), ("w", np.float64), ("residual", np.float64),
                   ("error", np.float64), ("curve", np.int64), ("kind", np.int64),
                   ("condition", np.int64), ("other", np.int64), ("left", np.int64),
                   ("right", np.int64), ("owned", np.int64)])
#: A special point found on one step of a march: where along the step (s), where, how
#: well (residual, error), what (kind) and the other condition or axis that defines it.
SPECIAL = np.dtype([("s", np.float64), ("u", np.float64), ("w", np.float64),
                    ("residual", np.float64), ("error", np.float64), ("kind", np.int64),
                    ("other", np.int64)])
#: What a march reads, and its scratch: the model's functions (:data:`ADDRESSES`); each
#: condition's group and rank, and which are traced; the input vector, the slice's input
#: slots and placement; gradient and Hessian scratch; the layer's outputs and index; the
#: conditions' tie scales; side-sample scratch; the tolerances in u and w.
Slice = namedtuple("Slice", ["F", "grp", "active", "v", "ix", "iy", "geo", "g", "H", "out",
                             "layer", "cs", "scr", "tol_u", "tol_w"])
#: Where a trace writes: the vertices (:data:`VERTEX`), the counts (vertices, curves,
#: overflow) and each condition's raster of traced cells.
Store = namedtuple("Store", ["verts", "counts", "mark"])
#: A march's state at a vertex, which it goes back to: the vertex and its tangent, the
#: next step's length; the vertex's own step length, tie scale and gradient norm (for
#: its side samples); the length travelled, the steps (-1 where the loop closed), the
#: classes on its left and right, whether its stretch is this condition's, the steps
#: taken in all (going back counts again), whether a loop is still looked for, and the
#: number of vertices written.
At = namedtuple("At", ["u", "w", "tu", "tw", "h", "hq", "us", "un", "travelled", "steps",
                       "la", "ra", "owned", "done", "closing", "n"])


@njit(cache=True, error_model="numpy")
def _solve2(a, b, c, d, r0, r1):
    """The solution of [[a, b], [c, d]] z = (r0, r1); NaN when singular."""
    det = a * d - b * c
    if det == 0.0 or not math.isfinite(det):
        return np.nan, np.nan
    return (r0 * d - b * r1) / det, (a * r1 - r0 * c) / det


@njit(cache=True, error_model="numpy")
def _push(verts, counts, u, w, res, err, curve, kind, cond, other, left, right, owned=1):
    """Append one vertex; set the overflow flag when the buffer is full."""
    n = counts[0]
    if n >= verts.shape[0]:
        counts[2] = 1
        return
    q = verts[n]
    q.u, q.w, q.residual, q.error = u, w, res, err
    q.curve, q.kind, q.condition, q.other = curve, kind, cond, other
    q.left, q.right, q.owned = left, right, owned
    counts[0] = n + 1


@njit(cache=True, error_model="numpy")
def _swap(records, a, b):
    """Swap records a and b of a record array."""
    if a != b:
        tmp = records[a:a + 1].copy()
        records[a] = records[b]
        records[b] = tmp[0]


@njit(cache=True, error_model="numpy")
def _mark(mark, k, ua, wa, ub, wb):
    """Mark every cell of the raster ``mark[k]`` (n x n cells over the unit square)
    that the segment from (ua, wa) to (ub, wb) passes through (Amanatides and Woo)."""
    n = mark.shape[1]
    x0, y0, x1, y1 = ua * n, wa * n, ub * n, wb * n
    i = min(max(int(math.floor(x0)), 0), n - 1)
    j = min(max(int(math.floor(y0)), 0), n - 1)
    i1 = min(max(int(math.floor(x1)), 0), n - 1)
    j1 = min(max(int(math.floor(y1)), 0), n - 1)
    dx, dy = x1 - x0, y1 - y0
    si = 1 if dx > 0.0 else -1
    sj = 1 if dy > 0.0 else -1
    tx = ((i + (1 if si > 0 else 0)) - x0) / dx if dx != 0.0 else np.inf
    ty = ((j + (1 if sj > 0 else 0)) - y0) / dy if dy != 0.0 else np.inf
    ddx = 1.0 / abs(dx) if dx != 0.0 else np.inf
    ddy = 1.0 / abs(dy) if dy != 0.0 else np.inf
    mark[k, i, j] = 1
    for it in range(4 * n + 4):
        if i == i1 and j == j1:
            break
        if tx < ty:
            i += si
            tx += ddx
        else:
            j += sj
            ty += ddy
        if i < 0 or j < 0 or i >= n or j >= n:
            break
        mark[k, i, j] = 1


@njit(cache=True, error_model="numpy")
def _seen(mark, k, u, w):
    """A cell of ``mark[k]`` within 1e-4 of (u, w) is marked."""
    n = mark.shape[1]
    for a in (-1e-4, 1e-4):
        for b in (-1e-4, 1e-4):
            i = min(max(int((u + a) * n), 0), n - 1)
            j = min(max(int((w + b) * n), 0), n - 1)
            if mark[k, i, j]:
                return True
    return False


@njit(cache=True, error_model="numpy")
def _note(sp, n, s, u, w, kind, other, res, err):
    """Record special point n of a step (:data:`SPECIAL`): where along it (s), where,
    what, how well; the next n."""
    p = sp[n]
    p.s, p.u, p.w, p.residual, p.error = s, u, w, res, err
    p.kind, p.other = kind, other
    return n + 1


@njit(cache=True, error_model="numpy")
def _seed(seeds, m, k, u, w, kind):
    """Write the seed (k, u, w, kind) as row m where ``seeds`` has room; the next row."""
    if m < seeds.shape[0]:
        seeds[m, 0], seeds[m, 1], seeds[m, 2], seeds[m, 3] = k, u, w, kind
    return m + 1


@njit(cache=True, error_model="numpy")
def _near(near, u, w):
    """The cell of ``near`` (n x n over the unit square) at (u, w)."""
    n = near.shape[0]
    return near[min(max(int(u * n), 0), n - 1), min(max(int(w * n), 0), n - 1)]


@njit(cache=True, error_model="numpy")
def class_changes(classes):
    """The class changes of a raster: rows ``(i, j, di, dj)``, the cells (i, j) and
    (i + di, j + dj) (a neighbour along one axis) differ, in the order of i, j and the
    axis.  Two passes: each cell's changes as bits (the last row apart, so that the
    loop over the others has no test and vectorises), then the rows of the cells that
    have one, read eight cells at a time (a word of bits that is zero is skipped)."""
    n0, n1 = classes.shape
    bits = np.zeros((n0, n1 + (-n1) % 8), dtype=np.int8)  # rows of whole words
    count = 0
    for i in range(n0 - 1):
        for j in range(n1 - 1):
            c = classes[i, j]
            down = classes[i + 1, j] != c
            right = classes[i, j + 1] != c
            bits[i, j] = down + 2 * right
            count += int(down) + int(right)
        down = classes[i + 1, n1 - 1] != classes[i, n1 - 1]
        bits[i, n1 - 1] = down
        count += down
    if n0 > 0:
        for j in range(n1 - 1):
            right = classes[n0 - 1, j + 1] != classes[n0 - 1, j]
            bits[n0 - 1, j] = 2 * right
            count += right
    words = bits.view(np.int64)
    out = np.empty((count, 4), dtype=np.int64)
    n = 0
    for i in range(n0):
        for q in range(words.shape[1]):
            if words[i, q] == 0:
                continue
            for j in range(8 * q, min(8 * q + 8, n1)):
                f = bits[i, j]
                for d in range(2):
                    if f & (1 << d):
                        out[n, 0] = i
                        out[n, 1] = j
                        out[n, 2] = 1 - d
                        out[n, 3] = d
                        n += 1
    return out[:n]


@njit(cache=True, error_model="numpy")
def near_changes(shape, changes, radius):
    """Cells of a raster of ``shape`` within ``radius`` cells (in each axis) of a cell
    with a class change (rows of :func:`class_changes`), of its neighbour below and of
    its neighbour to the right: where a boundary of the raster's classes can pass."""
    n0, n1 = shape
    # the square of cells around each of those cells, as two passes: along j from the
    # cells, then along i over whole rows (which vectorises)
    rows = np.zeros((n0, n1), dtype=np.bool_)
    for r in range(changes.shape[0]):
        i, j = changes[r, 0], changes[r, 1]
        for a, b0, b1 in ((i, j, j + 1), (i + 1, j, j)):
            if a < n0:
                for b in range(max(b0 - radius, 0), min(b1 + radius + 1, n1)):
                    rows[a, b] = True
    near = np.zeros((n0, n1), dtype=np.bool_)
    for i in range(n0):
        for a in range(max(i - radius, 0), min(i + radius + 1, n0)):
            for j in range(n1):
                near[i, j] |= rows[a, j]
    return near


@njit(cache=True, error_model="numpy")
def groups(vals, active):
    """Drop from ``active`` the conditions constant over the sample points (rows of
    ``vals``) and those proportional there to an earlier active one, whose zero
    set they share: ``c_k(p) c_j(0) = c_k(0) c_j(p)`` at every point p.  Returns
    each condition's group (the active condition that traces its zero set).
    A NaN value is neither constant nor proportional."""
    npts, nc = vals.shape
    for k in range(nc):
        lo, hi, size, defined = np.inf, -np.inf, 0.0, True
        for p in range(npts):
            x = vals[p, k]
            defined = defined and x == x
            lo = min(lo, x)
            hi = max(hi, x)
            size = max(size, abs(x))
        if defined and hi - lo <= 1e-13 * size:
            active[k] = False
    group = np.arange(nc)
    for k in range(nc):
        if not active[k] or not abs(vals[0, k]) > 0.0:
            continue
        for j in range(k):
            if not active[j] or not abs(vals[0, j]) > 0.0:
                continue
            same = True
            for p in range(npts):
                a = vals[p, k] * vals[0, j]
                b = vals[0, k] * vals[p, j]
                if not abs(a - b) <= 1e-9 * (abs(a) + abs(b)):
                    same = False
                    break
            if same:
                group[k] = j
                active[k] = False
                break
    return group


@njit(cache=True, error_model="numpy")
def _yields(k, grp, active, F, v, ix, iy, geo, u, w, cv, cs):
    """A condition that ranks before k vanishes with it at (u, w): the stretch there is
    that condition's to trace (:func:`_owned`), and a seed of k there starts no piece.
    A condition whose every term vanishes there (scale 0) does not take it: it is zero
    to the order of its terms, as the peg rod's wall reaction, a multiple of omega^2
    where the peg lets go, is on omega = 0, where it changes no sign and its curve
    cannot be followed, while the velocity's sign there changes the class."""
    v[ix] = geo[0] + u * geo[1]
    v[iy] = geo[2] + w * geo[3]
    _values(F, v, cv, cs)
    for j in range(cv.shape[0]):
        if active[j] and grp[j, 0] != grp[k, 0] and grp[j, 1] < grp[k, 1] \
                and abs(cv[j]) <= COVANISH * cs[j] and cs[j] > 0.0:
            return True
    return False


@njit(cache=True, error_model="numpy")
def _owned(k, grp, active, cv, cs, mark, ua, wa, ub, wb):
    """Whether the curve of k traces the stretch from (ua, wa) to (ub, wb), whose end's
    condition values are cv: 0 where a condition that ranks first vanishes there too
    (its zero set runs with this curve; it traces the stretch; not one whose every term
    vanishes, see :func:`_yields`), and the cells of the conditions that rank after k and
    vanish too are marked as traced."""
    owned = 1
    for j in range(cv.shape[0]):
        if active[j] and grp[j, 0] != grp[k, 0] and abs(cv[j]) <= COVANISH * cs[j]:
            if grp[j, 1] < grp[k, 1]:
                owned = 0 if cs[j] > 0.0 else owned
            else:
                _mark(mark, j, ua, wa, ub, wb)
    return owned


@njit(cache=True, error_model="numpy")
def _inside(u, w, slack):
    return (u >= -slack) & (u <= 1.0 + slack) & (w >= -slack) & (w <= 1.0 + slack)


# -- the model's class: a template (its globals are the model's contract) -----------------

def _class_template(v, out, layer):
    """The layer's class at the state ``v`` (names set; derived inputs are filled)."""
    DERIVE(v)
    POINT(v, out)
    n, stag, lost, sing = nx.summarize(out, STICK)
    if layer == 0:
        return n
    if layer == 1:
        return 1 if stag else 0
    if layer == 2:
        return 1 if lost else 0
    return 1 if sing else 0


@njit(cache=True, error_model="numpy")
def _class_at(F, v, out, layer, ix, iy, geo, u, w):
    v[ix] = geo[0] + u * geo[1]
    v[iy] = geo[2] + w * geo[3]
    return _classify(F, v, out, layer)


@njit(cache=True, error_model="numpy")
def _grad(F, k, v, ix, iy, geo, u, w, g):
    """Condition ``k`` at (u, w): (value, scale, d/du, d/dw)."""
    v[ix] = geo[0] + u * geo[1]
    v[iy] = geo[2] + w * geo[3]
    c, s = _gradient(F, k, v, g)
    return c, s, g[0] * geo[1], g[1] * geo[3]


@njit(cache=True, error_model="numpy")
def _hess(F, k, v, ix, iy, geo, u, w, g, H):
    """Condition ``k`` at (u, w): (value, scale, c_u, c_w, c_uu, c_uw, c_ww)."""
    v[ix] = geo[0] + u * geo[1]
    v[iy] = geo[2] + w * geo[3]
    c, s = _hessian(F, k, v, g, H)
    return (c, s, g[0] * geo[1], g[1] * geo[3], H[0, 0] * geo[1] * geo[1],
            H[0, 1] * geo[1] * geo[3], H[1, 1] * geo[3] * geo[3])


@njit(cache=True, error_model="numpy")
def _side(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, su, sw, cvp, scr):
    """The class at (su, sw), a side sample of the curve point (u, w) whose condition
    values are ``cvp``: -1 outside the slice, or where another condition's zero
    set passes between the two (the sample would see that condition's class change,
    not this curve's: near a crossing, or where the curves nearly touch).  A zero set
    through (u, w) itself (far closer than the sample) runs with this curve there."""
    if not _inside(su, sw, 0.0):
        return -1
    v[ix] = geo[0] + su * geo[1]
    v[iy] = geo[2] + sw * geo[3]
    _values(F, v, scr[1], scr[2])
    eps = math.hypot(su - u, sw - w)
    for j in range(active.shape[0]):
        if active[j] and grp[j, 0] != grp[k, 0] and (cvp[j] > 0.0) != (scr[1, j] > 0.0):
            c, s, cu, cw = _grad(F, j, v, ix, iy, geo, u, w, g)
            if abs(c) > 1e-3 * eps * math.hypot(cu, cw):
                return -1
    v[ix] = geo[0] + su * geo[1]
    v[iy] = geo[2] + sw * geo[3]
    return _classify(F, v, out, layer)


@njit(cache=True, error_model="numpy")
def _sides(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, tu, tw, eps, scr):
    """The classes left and right of the direction (tu, tw) at the curve point (u, w),
    ``eps`` away (-1 for a side that cannot be sampled, see SIDE)."""
    v[ix] = geo[0] + u * geo[1]
    v[iy] = geo[2] + w * geo[3]
    _values(F, v, scr[0], scr[2])
    return _sides_with(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, tu, tw, eps,
                       scr[0], scr)


@njit(cache=True, error_model="numpy")
def _sides_with(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, tu, tw, eps, cvp,
                scr):
    """:func:`_sides` at a curve point whose condition values ``cvp`` are known."""
    left = _side(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, u - eps * tw,
                 w + eps * tu, cvp, scr)
    right = _side(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, u + eps * tw,
                  w - eps * tu, cvp, scr)
    return left, right


@njit(cache=True, error_model="numpy")
def _correct(F, k, v, ix, iy, geo, g, pu, pw, du, dw):
    """Newton on c = 0 and (du, dw) . (x - p) = 0 from p: the curve's point whose
    projection on the direction (du, dw) is p's.  Returns (ok, u, w, residual, step) and
    c's (scale, c_u, c_w) at that point.

    Where the next step would be at most 1e-15 (in the unit square), the point before it
    is the answer, with the value and gradient already evaluated there: it is that
    close to the root (Newton's step is its error there), and stepping would cost one
    more gradient per vertex, a quarter of the corrector.
    """
    u, w = pu, pw
    last = np.inf
    for it in range(MAX_IT):
        c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
        if not (math.isfinite(c) and math.isfinite(cu) and math.isfinite(cw)):
            return False, u, w, np.inf, np.inf, s, cu, cw
        r = du * (u - pu) + dw * (w - pw)
        a, b = _solve2(cu, cw, du, dw, -c, -r)
        if not math.isfinite(a):
            return False, u, w, np.inf, np.inf, s, cu, cw
        last = abs(a) + abs(b)
        if last <= 1e-15:
            res = abs(c) / s if s > 0.0 else abs(c)
            return res <= RESIDUAL, u, w, res, last, s, cu, cw
        u += a
        w += b
        if last <= 1e-13 and abs(c) <= 0.01 * RESIDUAL * s:
            break
    c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
    res = abs(c) / s if s > 0.0 else abs(c)
    return res <= RESIDUAL, u, w, res, last, s, cu, cw


@njit(cache=True, error_model="numpy")
def _project(F, k, v, ix, iy, geo, g, u, w):
    """The nearest point of c = 0 to (u, w), by Newton along the gradient."""
    for it in range(MAX_IT):
        c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
        n2 = cu * cu + cw * cw
        if not (math.isfinite(c) and n2 > 0.0):
            return False, u, w
        a = -c * cu / n2
        b = -c * cw / n2
        u += a
        w += b
        if abs(a) + abs(b) <= 1e-15:
            break
    c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
    return abs(c) <= RESIDUAL * s, u, w


@njit(cache=True, error_model="numpy")
def _system(F, what, k, j, v, ix, iy, geo, g, H, u, w):
    """A special point's two defining equations at (u, w), their Jacobian and residual:
    ``(F0, F1, dF0/du, dF0/dw, dF1/du, dF1/dw, residual)``.

    ``what`` 0: ``c_k = c_j = 0`` (a crossing); 1: ``c_k = 0, dc_k/dw = 0`` (the curve
    turns back in u: a fold in u); 2: ``c_k = 0, dc_k/du = 0`` (a fold in w).  The
    residual is relative to the tie scales, a derivative's to the gradient's norm.
    """
    if what == 0:
        c1, s1, a1, b1 = _grad(F, k, v, ix, iy, geo, u, w, g)
        c2, s2, a2, b2 = _grad(F, j, v, ix, iy, geo, u, w, g)
        return c1, c2, a1, b1, a2, b2, max(abs(c1) / s1, abs(c2) / s2)
    c, s, cu, cw, huu, huw, hww = _hess(F, k, v, ix, iy, geo, u, w, g, H)
    n = max(math.hypot(cu, cw), 1e-300)
    if what == 1:
        return c, cw, cu, cw, huw, hww, max(abs(c) / s, abs(cw) / n)
    return c, cu, cu, cw, huu, huw, max(abs(c) / s, abs(cu) / n)


@njit(cache=True, error_model="numpy")
def _solve(F, what, k, j, v, ix, iy, geo, g, H, u, w, tol_u, tol_w):
    """Newton on the defining equations ``what`` (see SYSTEM) from (u, w), to a step
    below 1e-3 of the tolerances: (ok, u, w, residual, last step in tolerances)."""
    err = np.inf
    for it in range(MAX_IT):
        f0, f1, a, b, c, d, res = _system(F, what, k, j, v, ix, iy, geo, g, H, u, w)
        du, dw = _solve2(a, b, c, d, -f0, -f1)
        if not math.isfinite(du):
            return False, u, w, np.inf, np.inf
        u += du
        w += dw
        err = max(abs(du) / tol_u, abs(dw) / tol_w)
        if err <= 1e-3:
            break
    res = _system(F, what, k, j, v, ix, iy, geo, g, H, u, w)[6]
    return err <= 1.0, u, w, res, err


@njit(cache=True, error_model="numpy")
def _fold_on_step(F, axis, k, v, ix, iy, geo, g, H, u, w, qu, qw, a0, a1, tol_u, tol_w):
    """The fold in ``axis`` between the curve points (u, w) and (qu, qw), whose tangents
    have the components a0 and a1 (of opposite signs) in that axis: :func:`_solve` from
    where the component interpolates to zero."""
    a = a0 / (a0 - a1)
    return _solve(F, 1 + axis, k, -1, v, ix, iy, geo, g, H, u + a * (qu - u), w + a * (qw - w),
                  tol_u, tol_w)


@njit(cache=True, error_model="numpy")
def _edge(F, k, v, ix, iy, geo, g, u, w, fixed_u, tol_u, tol_w):
    """Newton on c = 0 along an edge (u fixed when ``fixed_u``, else w) from (u, w)."""
    err = np.inf
    for it in range(MAX_IT):
        c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
        d = cw if fixed_u else cu
        if d == 0.0 or not math.isfinite(c):
            return False, u, w, np.inf, np.inf
        step = -c / d
        if fixed_u:
            w += step
            err = abs(step) / tol_w
        else:
            u += step
            err = abs(step) / tol_u
        if err <= 1e-3:
            break
    c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
    return err <= 1.0, u, w, abs(c) / s, err


@njit(cache=True, error_model="numpy")
def _tangent(F, k, v, ix, iy, geo, g, u, w, su, sw):
    """The unit tangent at (u, w), oriented along (su, sw); (0, 0) where c has no gradient."""
    c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
    return _orient(s, cu, cw, su, sw)


@njit(cache=True, error_model="numpy")
def _orient(s, cu, cw, su, sw):
    """:func:`_tangent` from c's scale and gradient: (t_u, t_w, |grad c|, scale)."""
    n = math.hypot(cu, cw)
    if not (n > 0.0):
        return 0.0, 0.0, n, s
    tu, tw = -cw / n, cu / n
    if tu * su + tw * sw < 0.0:
        tu, tw = -tu, -tw
    return tu, tw, n, s


@njit(cache=True, error_model="numpy")
def _side_eps(s, n, h):
    """How far from the curve its sides are sampled: well beyond the tie band."""
    eps = max(1e-8, 1e-9 * s / max(n, 1e-300))
    return min(eps, 0.25 * h, 1e-3)


@njit(cache=True, error_model="numpy")
def _bisect(F, k, grp, active, v, ix, iy, geo, g, out, layer, ua, wa, ub, wb, la, ra, h,
                     scr):
    """Where between the curve points a and b the side classes stop being (la, ra):
    bisection on the curve (the corrector, constrained along a -> b).  Returns the
    point just after the change and its tangent."""
    du, dw = ub - ua, wb - wa
    length = math.hypot(du, dw)
    du /= length
    dw /= length
    lo, hi = 0.0, 1.0
    u, w = ub, wb
    for it in range(60):
        mid = 0.5 * (lo + hi)
        ok, pu, pw, res, st, s, cu, cw = _correct(F, k, v, ix, iy, geo, g, ua + mid * (ub - ua),
                                                  wa + mid * (wb - wa), du, dw)
        if not ok:
            break
        tu, tw, n, s = _orient(s, cu, cw, du, dw)
        left, right = _sides(F, k, grp, active, v, g, out, layer, ix, iy, geo, pu, pw, tu, tw,
                             _side_eps(s, n, h), scr)
        if left == la and right == ra:
            lo = mid
        else:
            hi = mid
            u, w = pu, pw
        if (hi - lo) * length < 1e-10:
            break
    return u, w


@njit(cache=True, error_model="numpy")
def _explain(F, k, grp, active, v, ix, iy, geo, g, H, cv, cs, u, w, tol_u, tol_w):
    """The condition (other than k's group) that vanishes nearest (u, w) and crosses k's
    curve there, and that crossing: (j, ok, u, w, residual, error); j = -1 if none is
    near.  A condition whose gradient is parallel to k's there does not cross the curve:
    one that vanishes on the whole curve with k (the rod on a step's gap line, on which
    two family conditions vanish too) was taken before, and its crossing with k, a
    singular system, left the change at the bisection's 1e-6 with no residual."""
    v[ix] = geo[0] + u * geo[1]
    v[iy] = geo[2] + w * geo[3]
    _values(F, v, cv, cs)
    ck, sk, ku, kw = _grad(F, k, v, ix, iy, geo, u, w, g)
    nk = math.hypot(ku, kw)
    best = -1
    dist = 1e-6
    for j in range(active.shape[0]):
        if (not active[j]) or grp[j, 0] == grp[k, 0]:
            continue
        c, s, cu, cw = _grad(F, j, v, ix, iy, geo, u, w, g)
        n = math.hypot(cu, cw)
        if abs(cu * kw - cw * ku) <= 1e-9 * n * nk:
            continue   # parallel to k's curve here: no crossing
        if n > 0.0 and abs(c) / n < dist:
            dist = abs(c) / n
            best = j
    if best < 0:
        return -1, False, u, w, np.inf, np.inf
    ok, pu, pw, res, err = _solve(F, 0, k, best, v, ix, iy, geo, g, H, u, w, tol_u, tol_w)
    return best, ok, pu, pw, res, err


@njit(cache=True, error_model="numpy")
def _exit(F, k, v, ix, iy, geo, g, u, w, qu, qw, tol_u, tol_w):
    """Where the curve from (u, w) (inside) towards (qu, qw) (outside) crosses the
    slice's edge: Newton along the edge the chord crosses first."""
    t_exit = np.inf
    fixed_u = True
    eu = 0.0
    ew = 0.0
    du, dw = qu - u, qw - w
    for e in range(4):
        edge = float(e % 2)
        if e < 2 and du != 0.0:
            t = (edge - u) / du
            if 0.0 <= t < t_exit:
                t_exit, fixed_u, eu, ew = t, True, edge, w + t * dw
        elif e >= 2 and dw != 0.0:
            t = (edge - w) / dw
            if 0.0 <= t < t_exit:
                t_exit, fixed_u, eu, ew = t, False, u + t * du, edge
    if not math.isfinite(t_exit):
        return False, u, w, np.inf, np.inf
    ok, eu, ew, res, err = _edge(F, k, v, ix, iy, geo, g, eu, ew, fixed_u, tol_u, tol_w)
    ok = ok and _inside(eu, ew, 1e-12)
    return ok, min(max(eu, 0.0), 1.0), min(max(ew, 0.0), 1.0), res, err


@njit(cache=True, error_model="numpy")
def _jump(F, k, v, ix, iy, geo, g, H, u, w, tu, tw):
    """Past a singular point of the curve near (u, w) (where grad c vanishes on c = 0:
    two branches of the zero set cross) along (tu, tw).  Returns (ok, the singular
    point, its residual, the first point beyond it on the branch that goes on)."""
    pu, pw = u, w
    for it in range(MAX_IT):
        c, s, cu, cw, huu, huw, hww = _hess(F, k, v, ix, iy, geo, pu, pw, g, H)
        du, dw = _solve2(huu, huw, huw, hww, -cu, -cw)
        if not math.isfinite(du):
            return False, pu, pw, np.inf, u, w
        pu += du
        pw += dw
        if abs(du) + abs(dw) <= 1e-15:
            break
    c, s, cu, cw, huu, huw, hww = _hess(F, k, v, ix, iy, geo, pu, pw, g, H)
    res = abs(c) / s
    if res > 1e3 * RESIDUAL or math.hypot(pu - u, pw - w) > 1e-3 or not _inside(pu, pw, 0.0):
        return False, pu, pw, res, u, w
    d = 1e-7
    while d <= 1e-3:
        ok, qu, qw, r, st, qs, qcu, qcw = _correct(F, k, v, ix, iy, geo, g, pu + d * tu,
                                                   pw + d * tw, tu, tw)
        if ok and math.hypot(qu - pu - d * tu, qw - pw - d * tw) <= 0.25 * d \
                and _inside(qu, qw, 0.0):
            return True, pu, pw, res, qu, qw
        d *= 10.0
    return False, pu, pw, res, u, w


@njit(cache=True, error_model="numpy")
def _step_length(kappa):
    """The step that keeps the chord within :data:`CHORD` and the turn within
    :data:`ANGLE` at the curvature ``kappa``, at most :data:`H_MAX`."""
    h = H_MAX
    if kappa > 0.0:
        h = min(h, math.sqrt(8.0 * CHORD / kappa), ANGLE / kappa)
    return h


@njit(cache=True, error_model="numpy")
def _kappa(tu, tw, huu, huw, hww, n):
    """The curvature of a zero set whose unit tangent is (tu, tw), from the Hessian
    (huu, huw, hww) of its condition and the gradient's norm n."""
    return abs(tu * tu * huu + 2.0 * tu * tw * huw + tw * tw * hww) / n


@njit(cache=True, error_model="numpy")
def _fold_beyond_edge(sl, k, u, w, qu, qw, tu, tw, qtu, qtw, h, xu, xw):
    """The curve turns back in an axis between the vertices (u, w) and (qu, qw), both in
    the slice: where that fold lies beyond an edge by more than the tolerance, the curve
    leaves the slice there and comes back (a loop that the edge cuts by less than a
    step).  Returns (leaves, a point beyond the edge: the fold; else (xu, xw))."""
    leaves = False
    for axis in range(2):
        a0 = tu if axis == 0 else tw
        a1 = qtu if axis == 0 else qtw
        if a0 * a1 < 0.0:
            okf, fu, fw, resf, errf = _fold_on_step(sl.F, axis, k, sl.v, sl.ix, sl.iy, sl.geo,
                                                    sl.g, sl.H, u, w, qu, qw, a0, a1, sl.tol_u,
                                                    sl.tol_w)
            # beyond the edge by more than the tolerance (a fold on it, to the
            # tolerance, is a loop that touches the edge)
            if okf and not _inside(fu, fw, max(sl.tol_u, sl.tol_w)) \
                    and math.hypot(fu - u, fw - w) <= 2.0 * h:
                leaves = True
                xu, xw = fu, fw
    return leaves, xu, xw


@njit(cache=True, error_model="numpy")
def _leave(sl, k, u, w, tu, tw, h, xu, xw):
    """Where the curve, which leaves the slice within the step from (u, w) (xu, xw beyond
    the edge), crosses the edge: (ok, u, w, residual, error), and whether the march ends
    there.  From a point on an edge along a tangent into the slice (a region thinner
    than the step, that the edge cuts), the step is shortened, not ended on that edge."""
    inward = (u <= 1e-12 and tu > 0.0) or (u >= 1.0 - 1e-12 and tu < 0.0) \
        or (w <= 1e-12 and tw > 0.0) or (w >= 1.0 - 1e-12 and tw < 0.0)
    if inward and h > H_MIN:
        return False, u, w, np.inf, np.inf, False
    ok, eu, ew, res, err = _exit(sl.F, k, sl.v, sl.ix, sl.iy, sl.geo, sl.g, u, w, xu, xw,
                                 sl.tol_u, sl.tol_w)
    ok = ok and math.hypot(eu - u, ew - w) <= 2.0 * h
    return ok, eu, ew, res, err, ok or h <= H_MIN


@njit(cache=True, error_model="numpy")
def _confirmed(verts, counts, lc, rc, la, ra):
    """The side classes (lc, rc) sampled at the last vertex appended, not sampled before:
    True where they are the classes (la, ra) of the last sampled vertex (written to the
    vertex), False where the classes changed in between (the march goes back)."""
    if lc == la and rc == ra and lc >= 0 and rc >= 0:
        q = counts[0] - 1
        verts[q].left = lc
        verts[q].right = rc
        return True
    return False


@njit(cache=True, error_model="numpy")
def _step_over(sl, st, k, curve, u, w, tu, tw, la, ra, cv0):
    """Past a singular point near (u, w), where two branches of the zero set cross
    (:func:`_jump`): the crossing and the first vertex beyond it are appended, and cv0
    is left at that vertex.  Returns (ok, u, w, tu, tw, tie scale, gradient norm, left,
    right, owned) of that vertex; where no branch goes on, a stall is appended at
    (u, w) and ok is False."""
    F, v, ix, iy, geo, g = sl.F, sl.v, sl.ix, sl.iy, sl.geo, sl.g
    ok, pu, pw, rj, qu, qw = _jump(F, k, v, ix, iy, geo, g, sl.H, u, w, tu, tw)
    if not ok:
        _push(st.verts, st.counts, u, w, 0.0, 0.0, curve, STALL, k, -1, la, ra)
        return False, u, w, tu, tw, 0.0, 0.0, la, ra, -1
    _mark(st.mark, k, u, w, qu, qw)
    _push(st.verts, st.counts, pu, pw, rj, 0.0, curve, CROSSING, k, k, -1, -1)
    qtu, qtw, qn, qs = _tangent(F, k, v, ix, iy, geo, g, qu, qw, tu, tw)
    lb, rb = _sides(F, k, sl.grp, sl.active, v, g, sl.out, sl.layer, ix, iy, geo, qu, qw,
                    qtu, qtw, _side_eps(qs, qn, 1e-4), sl.scr)
    c, s, cu, cw = _grad(F, k, v, ix, iy, geo, qu, qw, g)
    _values(F, v, cv0, sl.cs)
    owned = _owned(k, sl.grp, sl.active, cv0, sl.cs, st.mark, u, w, qu, qw)
    _push(st.verts, st.counts, qu, qw, abs(c) / s, 0.0, curve, REGULAR, k, -1, lb, rb, owned)
    v[ix] = geo[0] + qu * geo[1]
    v[iy] = geo[2] + qw * geo[3]
    _values(F, v, cv0, sl.cs)
    return True, qu, qw, qtu, qtw, qs, qn, lb, rb, owned


@njit(cache=True, error_model="numpy")
def _closes(su, sw, tu0, tw0, u, w, qu, qw, h):
    """The step from (u, w) to (qu, qw) passes the loop's start (su, sw) in the start's
    direction (tu0, tw0)."""
    du, dw = qu - u, qw - w
    length2 = du * du + dw * dw
    t = ((su - u) * du + (sw - w) * dw) / length2
    if 0.0 <= t <= 1.0:
        dist = math.hypot(u + t * du - su, w + t * dw - sw)
        return dist <= max(0.1 * h, 1e-9) and du * tu0 + dw * tw0 > 0.0
    return False


@njit(cache=True, error_model="numpy")
def _crossing(sl, k, j, u, w, qu, qw, c0, c1):
    """Where condition j, whose values at the curve points (u, w) and (qu, qw) are c0 and
    c1 of opposite signs, crosses the curve of k between them: Newton from the chord's
    zero; where Newton goes elsewhere, bisection of c_j on the curve first.  Returns
    (where along the step, u, w, residual, error)."""
    F, v, ix, iy, geo, g, H = sl.F, sl.v, sl.ix, sl.iy, sl.geo, sl.g, sl.H
    tol_u, tol_w = sl.tol_u, sl.tol_w
    du, dw = qu - u, qw - w
    length2 = du * du + dw * dw
    a = c0 / (c0 - c1)
    ok, xu, xw, res, err = _solve(F, 0, k, j, v, ix, iy, geo, g, H, u + a * du, w + a * dw,
                                  tol_u, tol_w)
    t = ((xu - u) * du + (xw - w) * dw) / length2
    if not (ok and -0.25 <= t <= 1.25):
        lo, hi = 0.0, 1.0
        ln = math.sqrt(length2)
        for it in range(60):
            mid = 0.5 * (lo + hi)
            okc, mu, mw, r3, s3, sc, ac, bc = _correct(F, k, v, ix, iy, geo, g, u + mid * du,
                                                       w + mid * dw, du / ln, dw / ln)
            cj, sj, aj, bj = _grad(F, j, v, ix, iy, geo, mu, mw, g)
            if (cj < 0.0) == (c0 < 0.0):
                lo = mid
            else:
                hi = mid
            if (hi - lo) * ln < 1e-3 * min(tol_u, tol_w):
                break
        ok, xu, xw, res, err = _solve(F, 0, k, j, v, ix, iy, geo, g, H, mu, mw, tol_u, tol_w)
        t = ((xu - u) * du + (xw - w) * dw) / length2
        if not (ok and -0.25 <= t <= 1.25):
            xu, xw, t = mu, mw, 0.5 * (lo + hi)
    return t, xu, xw, res, err


@njit(cache=True, error_model="numpy")
def _fold(sl, k, axis, u, w, qu, qw, a0, a1):
    """Where the curve of k turns back in ``axis`` between the curve points (u, w) and
    (qu, qw) (its tangent's component there goes from a0 to a1): (found, where along
    the step, u, w, residual, error), found where it lies on the step and in the slice
    (to 1e-12: then put on the edge)."""
    du, dw = qu - u, qw - w
    length2 = du * du + dw * dw
    okf, fu, fw, resf, errf = _fold_on_step(sl.F, axis, k, sl.v, sl.ix, sl.iy, sl.geo, sl.g,
                                            sl.H, u, w, qu, qw, a0, a1, sl.tol_u, sl.tol_w)
    t = ((fu - u) * du + (fw - w) * dw) / length2
    if okf and -0.25 <= t <= 1.25 and _inside(fu, fw, 1e-12):
        return True, t, min(max(fu, 0.0), 1.0), min(max(fw, 0.0), 1.0), resf, errf
    return False, t, fu, fw, resf, errf


@njit(cache=True, error_model="numpy")
def _unexplained(sl, k, u, w, qu, qw, la, ra, h, cv1, sp, nsp):
    """A change of the side classes from (la, ra) on the step from (u, w) to (qu, qw)
    that no crossing explains: located by bisection on the curve (:func:`_bisect`) and
    noted in ``sp`` as the crossing of the condition that vanishes there
    (:func:`_explain`), else as a change (CHANGE).  cv1 is left at (qu, qw).  Returns
    the number of special points."""
    F, grp, active, v, ix, iy, geo, g = (sl.F, sl.grp, sl.active, sl.v, sl.ix, sl.iy,
                                        sl.geo, sl.g)
    du, dw = qu - u, qw - w
    length2 = du * du + dw * dw
    xu, xw = _bisect(F, k, grp, active, v, ix, iy, geo, g, sl.out, sl.layer, u, w, qu, qw,
                     la, ra, h, sl.scr)
    j, okx, xu2, xw2, resx, errx = _explain(F, k, grp, active, v, ix, iy, geo, g, sl.H, cv1,
                                            sl.cs, xu, xw, sl.tol_u, sl.tol_w)
    t = ((xu - u) * du + (xw - w) * dw) / length2
    if j >= 0 and okx:
        nsp = _note(sp, nsp, t, xu2, xw2, CROSSING, j, resx, errx)
    else:
        nsp = _note(sp, nsp, t, xu, xw, CHANGE, -1, np.nan, np.nan)
    v[ix] = geo[0] + qu * geo[1]
    v[iy] = geo[2] + qw * geo[3]
    _values(F, v, cv1, sl.cs)
    return nsp


@njit(cache=True, error_model="numpy")
def _crossings(sp, nsp):
    """How many of a step's special points are crossings."""
    n = 0
    for i in range(nsp):
        if sp[i].kind == CROSSING:
            n += 1
    return n


@njit(cache=True, error_model="numpy")
def _append_specials(sl, st, k, curve, sp, nsp, tu, tw, h):
    """Append a step's special points in their order along it; a fold with its sides."""
    for a in range(nsp):
        best = a
        for b in range(a + 1, nsp):
            if sp[b].s < sp[best].s:
                best = b
        _swap(sp, a, best)
        p = sp[a]
        left, right = -1, -1
        if p.kind == FOLD_X or p.kind == FOLD_Y:
            ftu, ftw, fn, fs = _tangent(sl.F, k, sl.v, sl.ix, sl.iy, sl.geo, sl.g, p.u, p.w,
                                        tu, tw)
            left, right = _sides(sl.F, k, sl.grp, sl.active, sl.v, sl.g, sl.out, sl.layer,
                                 sl.ix, sl.iy, sl.geo, p.u, p.w, ftu, ftw,
                                 _side_eps(fs, fn, h), sl.scr)
        _push(st.verts, st.counts, p.u, p.w, p.residual, p.error, curve, p.kind, k, p.other,
              left, right)


@njit(cache=True, error_model="numpy")
def _march(sl, st, k, curve, su, sw, tu0, tw0, h0, closing, cv0, cv1):
    """Follow condition ``k`` from the curve point (su, sw) along (tu0, tw0), in the slice
    ``sl`` (:data:`Slice`), appending to ``st`` (:data:`Store`) as curve ``curve``; cv0 and
    cv1 are scratch for the conditions' values at a step's ends.

    Appends the vertices after the start (the start itself is not appended)
    and returns 1 if the curve came back to its start (a loop, only looked for
    when ``closing``), 0 at an edge of the slice, -1 where it stalled.

    A step: the predictor along the tangent and the corrector (:func:`_correct`); where
    the curve leaves the slice within the step (:func:`_fold_beyond_edge` too), its end
    on the edge (:func:`_leave`); a shorter step where the corrector fails or the curve
    turns too far, and past a singular point at the shortest (:func:`_step_over`); the
    loop's end (:func:`_closes`); the special points on the step, crossings
    (:func:`_crossing`), folds (:func:`_fold`) and a change of class no crossing
    explains (:func:`_unexplained`), appended in their order (:func:`_append_specials`);
    the vertex; the next step's length from the curvature there (:func:`_step_length`).

    The classes on either side (two classifications) are sampled at every
    :data:`SIDE_EVERY`-th vertex, and at every vertex of a step where anything
    happens: another condition changes sign or starts or stops vanishing with this
    one, the curve turns back in an axis, the loop closes, the curve ends.  The vertex
    before such a step is sampled too (:func:`_confirmed`).  Where a sample disagrees
    with the classes of the last sampled vertex and vertices in between were not
    sampled, the march goes back to that vertex (its :data:`At`) and steps again
    sampling every vertex: what it finds is what sampling every vertex finds, except a
    change of class that reverts within :data:`SIDE_EVERY` steps while no condition
    changes sign at the vertices (a side sample that grazes another zero set; assemble
    forgets such a sample, see _forget_isolated).

    What runs at every step is written here, and the steps that run where something
    happens are functions of their own.  numba counts a reference at every array a
    function takes and at every array read from a tuple (two atomic operations each):
    the step written as functions that took the slice's arrays cost the march a fifth
    to two fifths of its time.
    """
    F, grp, active, v, ix, iy, geo, g, H, out, layer, cs, scr, tol_u, tol_w = sl
    verts, counts, mark = st
    u, w = su, sw
    tu, tw = tu0, tw0
    h = h0
    v[ix] = geo[0] + u * geo[1]
    v[iy] = geo[2] + w * geo[3]
    _values(F, v, cv0, cs)
    c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
    n0 = math.hypot(cu, cw)
    la, ra = _sides_with(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, tu, tw,
                         _side_eps(s, n0, h), cv0, scr)
    travelled = 0.0
    steps = 0
    nc = active.shape[0]
    sp = np.empty(nc + 4, dtype=SPECIAL)  # a step's special points
    # the current vertex: its step length, tie scale and gradient norm (for its side samples)
    hq, us, un = h, s, n0
    owned_prev = -1
    pending = 0  # vertices since the last whose sides were sampled
    done = 0  # steps taken
    dense_until = -1  # sample every vertex while done <= dense_until (after going back)
    # the last sampled vertex, to go back to
    back = At(u, w, tu, tw, h, hq, us, un, travelled, steps, la, ra, owned_prev, done,
              closing, counts[0])
    back_cv = np.empty(nc)
    go_back = False
    while True:
        if go_back:
            (u, w, tu, tw, h, hq, us, un, travelled, steps, la, ra, owned_prev, done,
             closing, n_back) = back
            counts[0] = n_back
            cv0[:] = back_cv
            pending = 0
            go_back = False
        if counts[2]:
            return -1
        if pending == 0:
            back = At(u, w, tu, tw, h, hq, us, un, travelled, steps, la, ra, owned_prev, done,
                      closing, counts[0])
            back_cv[:] = cv0
        finish = travelled > MAX_LENGTH
        # the next vertex: predictor, corrector, and the tangent there along the march
        pu = u + h * tu
        pw = w + h * tw
        ok, qu, qw, res, sr, qs, qcu, qcw = False, pu, pw, np.inf, np.inf, 0.0, 0.0, 0.0
        if not finish:
            ok, qu, qw, res, sr, qs, qcu, qcw = _correct(F, k, v, ix, iy, geo, g, pu, pw, tu,
                                                         tw)
        leaves = (ok and not _inside(qu, qw, 0.0)) or (not ok and not _inside(pu, pw, 0.0))
        xu, xw = (qu, qw) if ok else (pu, pw)  # a point beyond the edge, where it leaves
        qtu, qtw, qn, qs = _orient(qs, qcu, qcw, tu, tw)
        if ok and not leaves and not finish and (tu * qtu < 0.0 or tw * qtw < 0.0):
            leaves, xu, xw = _fold_beyond_edge(sl, k, u, w, qu, qw, tu, tw, qtu, qtw, h, xu,
                                               xw)
        ex_ok, ex_u, ex_w, ex_res, ex_err = False, u, w, np.inf, np.inf
        if leaves and not finish:
            ex_ok, ex_u, ex_w, ex_res, ex_err, finish = _leave(sl, k, u, w, tu, tw, h, xu, xw)
        turn = qtu * tu + qtw * tw
        jump = math.hypot(qu - pu, qw - pw)
        rough = not ok or qn == 0.0 or turn < math.cos(2.0 * ANGLE) or jump > 0.25 * h
        stuck = not leaves and not finish and h <= H_MIN and rough
        if (finish or stuck) and pending > 0:
            # the curve ends, stalls or jumps here: the vertex before is sampled first
            lc, rc = _sides_with(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, tu,
                                 tw, _side_eps(us, un, hq), cv0, scr)
            if _confirmed(verts, counts, lc, rc, la, ra):
                pending = 0
            else:
                go_back = True
                dense_until = 1 << 62
                continue
        if finish:
            if ex_ok:
                _mark(mark, k, u, w, ex_u, ex_w)
                _push(verts, counts, ex_u, ex_w, ex_res, ex_err, curve, END, k, -1, -1, -1)
                return 0
            _push(verts, counts, u, w, 0.0, 0.0, curve, STALL, k, -1, la, ra)
            return -1
        if leaves:
            h *= 0.5
            continue
        if rough:
            if h > H_MIN:
                h *= 0.5
                continue
            # a singular point (two branches of the zero set cross): step over it
            ok, u, w, tu, tw, us, un, lb, rb, owned_prev = _step_over(sl, st, k, curve, u, w,
                                                                      tu, tw, la, ra, cv0)
            if not ok:
                return -1
            hq = 1e-4
            if lb >= 0 and rb >= 0:
                la, ra = lb, rb
            h = 1e-4
            done += 1
            continue
        # a loop: the step passes its start again
        if closing and steps >= 3 and travelled > 2.0 * h \
                and _closes(su, sw, tu0, tw0, u, w, qu, qw, h):
            qu, qw = su, sw
            qtu, qtw = tu0, tw0
            closing = False
            steps = -1  # marks the loop's end
        v[ix] = geo[0] + qu * geo[1]
        v[iy] = geo[2] + qw * geo[3]
        _values(F, v, cv1, cs)
        du, dw = qu - u, qw - w
        length2 = du * du + dw * dw
        owned = _owned(k, grp, active, cv1, cs, mark, u, w, qu, qw)
        # does anything happen on this step?
        event = owned != owned_prev or steps < 0 or tu * qtu < 0.0 or tw * qtw < 0.0
        for j in range(nc):
            if active[j] and grp[j, 0] != grp[k, 0]:
                z0 = abs(cv0[j]) <= COVANISH * cs[j]
                z1 = abs(cv1[j]) <= COVANISH * cs[j]
                event = event or z0 != z1 or (not z0 and cv0[j] * cv1[j] < 0.0)
        if event and pending > 0:
            lc, rc = _sides_with(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, tu,
                                 tw, _side_eps(us, un, hq), cv0, scr)
            if _confirmed(verts, counts, lc, rc, la, ra):
                pending = 0
            else:
                go_back = True
                dense_until = done
                continue
        # special points between (u, w) and (q): crossings, folds
        nsp = 0
        for j in range(nc):
            if (not active[j]) or grp[j, 0] == grp[k, 0]:
                continue
            if abs(cv0[j]) <= COVANISH * cs[j] or abs(cv1[j]) <= COVANISH * cs[j]:
                continue  # j vanishes with this curve here: no crossing
            if cv0[j] * cv1[j] < 0.0:
                t, xu, xw, res2, err2 = _crossing(sl, k, j, u, w, qu, qw, cv0[j], cv1[j])
                nsp = _note(sp, nsp, t, xu, xw, CROSSING, j, res2, err2)
        for axis in range(2):
            a0 = tu if axis == 0 else tw
            a1 = qtu if axis == 0 else qtw
            if a0 * a1 < 0.0:
                okf, t, fu, fw, resf, errf = _fold(sl, k, axis, u, w, qu, qw, a0, a1)
                if okf:
                    nsp = _note(sp, nsp, t, fu, fw, FOLD_X if axis == 0 else FOLD_Y, axis,
                                resf, errf)
        # the new vertex's sides (when sampled); a change that no crossing explains is located
        lb, rb = -1, -1
        sampled = event or done <= dense_until or pending + 1 >= SIDE_EVERY
        if sampled:
            lb, rb = _sides_with(F, k, grp, active, v, g, out, layer, ix, iy, geo, qu, qw, qtu,
                                 qtw, _side_eps(qs, qn, h), cv1, scr)
            if pending > 0 and not (lb == la and rb == ra and lb >= 0 and rb >= 0):
                # a change since the last sampled vertex: step there again, sampling all
                go_back = True
                dense_until = done
                continue
        known = lb >= 0 and rb >= 0
        if known and la >= 0 and ra >= 0 and (lb != la or rb != ra) \
                and _crossings(sp, nsp) == 0:
            nsp = _unexplained(sl, k, u, w, qu, qw, la, ra, h, cv1, sp, nsp)
        # the special points in order along the step, then the new vertex
        if nsp > 0:
            _append_specials(sl, st, k, curve, sp, nsp, tu, tw, h)
        _mark(mark, k, u, w, qu, qw)
        if steps < 0:  # the loop closed: its last vertex is its first
            _push(verts, counts, qu, qw, res, 0.0, curve, REGULAR, k, -1, -1, -1)
            return 1
        _push(verts, counts, qu, qw, res, 0.0, curve, REGULAR, k, -1, lb, rb, owned)
        pending = 0 if sampled else pending + 1
        owned_prev = owned
        hq, us, un = h, qs, qn
        done += 1
        travelled += math.sqrt(length2)
        steps += 1
        # the next step from the curvature here
        c, s, cu, cw, huu, huw, hww = _hess(F, k, v, ix, iy, geo, qu, qw, g, H)
        h = max(min(_step_length(_kappa(qtu, qtw, huu, huw, hww, qn)), 2.0 * h), H_MIN)
        u, w, tu, tw = qu, qw, qtu, qtw
        if known:
            la, ra = lb, rb
        for j in range(nc):
            cv0[j] = cv1[j]


@njit(cache=True, error_model="numpy")
def _trace_all(F, seeds, grp, active, v, out, ix, iy, geo, layer, verts, counts, curves, mark,
               near, tol_u, tol_w, require_sides):
    """Trace a curve from each seed ``(k, u, w)`` not on a curve already traced.

    A seed's point is projected onto its condition's zero set; it is skipped
    where the raster cell around it is already crossed by a curve of the same
    condition, and, with ``require_sides``, where the class is the same on
    both sides of the curve there (not a boundary) or where the check raster
    has no class change near it (``near``, :func:`near_changes`: most seeds of
    a model with many conditions lie on zero sets that bound nothing, and
    sampling their sides costs two classifications each).  Returns the number
    of curves traced.
    """
    g = np.empty(2)
    H = np.empty((2, 2))
    nc = active.shape[0]
    cv0 = np.empty(nc)
    cv1 = np.empty(nc)
    cs = np.empty(nc)
    scr = np.empty((3, nc))
    sl = Slice(F, grp, active, v, ix, iy, geo, g, H, out, layer, cs, scr, tol_u, tol_w)
    st = Store(verts, counts, mark)
    n = mark.shape[1]
    traced = 0
    # with require_sides, seeds in rank order: a stretch where several conditions vanish
    # is traced first by the one that ranks first, whose marks then skip the others' seeds
    # there (see _owned); the curves keep the order of their seeds
    order = np.arange(seeds.shape[0])
    if require_sides:
        rank = np.empty(seeds.shape[0], dtype=np.int64)
        for i in range(seeds.shape[0]):
            rank[i] = grp[int(seeds[i, 0]), 1]
        order = np.argsort(rank, kind="mergesort")
    first_curve = counts[1]
    origin = np.empty(curves.shape[0], dtype=np.int64)
    for i in order:
        k = int(seeds[i, 0])
        u0 = seeds[i, 1]
        w0 = seeds[i, 2]
        if _seen(mark, k, u0, w0):
            continue
        if seeds[i, 3] == 1.0:
            ok, u0, w0 = _minimum(F, k, v, ix, iy, geo, u0, w0, 2.0 / n)
            if not ok:
                continue
        ok, u, w = _project(F, k, v, ix, iy, geo, g, u0, w0)
        if not ok or not _inside(u, w, 0.0) or math.hypot(u - u0, w - w0) > 4.0 / n:
            continue
        if _seen(mark, k, u, w) or (require_sides and not _near(near, u, w)):
            continue
        if require_sides and _yields(k, grp, active, F, v, ix, iy, geo, u, w, cv0, cs):
            continue
        tu, tw, gn, s = _tangent(F, k, v, ix, iy, geo, g, u, w, 1.0, 0.0)
        if gn == 0.0 or tu == 0.0 and tw == 0.0:
            continue
        c, s, cu, cw, huu, huw, hww = _hess(F, k, v, ix, iy, geo, u, w, g, H)
        h = _step_length(_kappa(tu, tw, huu, huw, hww, gn))
        left, right = _sides(F, k, grp, active, v, g, out, layer, ix, iy, geo, u, w, tu, tw,
                            _side_eps(s, gn, h), scr)
        if require_sides and left == right:
            continue
        if counts[1] >= curves.shape[0]:
            counts[2] = 1
            return traced
        curve = counts[1]
        counts[1] += 1
        first = counts[0]
        back = _march(sl, st, k, curve, u, w, -tu, -tw, h, True, cv0, cv1)
        # the backward half, reversed: its special points keep their meaning, and the
        # sides swap with the direction of travel
        a = first
        b = counts[0] - 1
        while a < b:
            _swap(verts, a, b)
            a += 1
            b -= 1
        for q in range(first, counts[0]):
            left_q = verts[q].left
            verts[q].left = verts[q].right
            verts[q].right = left_q
        c0, s0, cu0, cw0 = _grad(F, k, v, ix, iy, geo, u, w, g)
        _values(F, v, cv0, cs)
        _push(verts, counts, u, w, abs(c0) / s0, 0.0, curve, REGULAR, k, -1, left, right,
              _owned(k, grp, active, cv0, cs, mark, u, w, u, w))
        closed = 0
        if back == 1:
            closed = 1
        else:
            _march(sl, st, k, curve, u, w, tu, tw, h, False, cv0, cv1)
        curves[curve, 0] = k
        curves[curve, 1] = first
        curves[curve, 2] = counts[0]
        curves[curve, 3] = closed
        origin[curve] = i
        traced += 1
    if require_sides and traced > 1:
        by_seed = np.argsort(origin[first_curve:counts[1]], kind="mergesort")
        rows = curves[first_curve:counts[1]].copy()
        for c in range(by_seed.shape[0]):
            curves[first_curve + c] = rows[by_seed[c]]
            verts.curve[curves[first_curve + c, 1]:curves[first_curve + c, 2]] = first_curve + c
    return traced


@njit(cache=True, error_model="numpy")
def _survey_all(F, v, ix, iy, geo, pts, vals):
    """Every condition's value at the points ``pts`` (rows (u, w) of the unit square)
    into the rows of ``vals``, NaN where a value is not finite."""
    cs = np.empty(vals.shape[1])
    for p in range(pts.shape[0]):
        v[ix] = geo[0] + pts[p, 0] * geo[1]
        v[iy] = geo[2] + pts[p, 1] * geo[3]
        _values(F, v, vals[p], cs)
        for k in range(vals.shape[1]):
            if not math.isfinite(vals[p, k]):
                vals[p, k] = np.nan


@njit(cache=True, error_model="numpy")
def _seeds_all(F, active, v, ix, iy, geo, n, near):
    """Seeds on an n x n raster of nodes (the slice's edges included): every sign change
    of an active condition between neighbouring nodes, and every node where a
    condition's magnitude has a local minimum without a sign change around it (a loop
    smaller than a cell).  Only nodes within one raster cell of a cell of ``near``
    (:func:`near_changes`) are evaluated and only they seed: a seed elsewhere
    cannot start a curve (:func:`_trace_all`).  Returns rows (condition, u, w, kind: 0 sign
    change, 1 minimum), by condition, then node.
    """
    nc = active.shape[0]
    m = near.shape[0]
    # near cells in each rectangle of cells from a summed-area table (one pass over near)
    sat = np.zeros((m + 1, m + 1), dtype=np.int64)
    for a in range(m):
        run = 0
        for b in range(m):
            run += near[a, b]
            sat[a + 1, b + 1] = sat[a, b + 1] + run
    lo = np.empty(n, dtype=np.int64)
    hi = np.empty(n, dtype=np.int64)
    for i in range(n):
        lo[i] = max(int((i - 1) / (n - 1) * m), 0)
        hi[i] = min(int((i + 1) / (n - 1) * m), m - 1) + 1
    ks = np.flatnonzero(active)
    # the active conditions' values at the needed nodes, a condition's contiguous, with a
    # frame of nodes not needed around them (no edge test for the sign changes below)
    need = np.zeros((n + 2, n + 2), dtype=np.bool_)
    cv = np.empty((ks.shape[0], n + 2, n + 2))
    row = np.empty(nc)
    cs = np.empty(nc)
    for i in range(n):
        v[ix] = geo[0] + (i / (n - 1)) * geo[1]
        for j in range(n):
            if sat[hi[i], hi[j]] - sat[lo[i], hi[j]] - sat[hi[i], lo[j]] + sat[lo[i], lo[j]] > 0:
                need[i + 1, j + 1] = True
                v[iy] = geo[2] + (j / (n - 1)) * geo[3]
                _values(F, v, row, cs)
                for q in range(ks.shape[0]):
                    cv[q, i + 1, j + 1] = row[ks[q]]
    # rows into a buffer that is not reassigned in the loops (numba keeps an array
    # variable reassigned in a loop alive with reference counts at every pass: 40 % of the
    # call); a second pass where it was too small
    seeds = np.empty((1024, 4))
    count = _seed_rows(cv, need, ks, n, seeds)
    if count > seeds.shape[0]:
        seeds = np.empty((count, 4))
        _seed_rows(cv, need, ks, n, seeds)
    return seeds[:count]


@njit(cache=True, error_model="numpy")
def _seed_rows(cv, need, ks, n, seeds):
    """The seeds of :func:`_seeds_all` from the values ``cv`` at the nodes ``need`` (each
    framed by one node not needed) into the rows of ``seeds`` that exist; their count."""
    m = 0
    for q in range(ks.shape[0]):
        k = ks[q]
        c = cv[q]
        for i in range(1, n + 1):
            for j in range(1, n + 1):
                if not need[i, j]:
                    continue
                a = c[i, j]
                for d in range(2):
                    i2 = i + 1 if d == 0 else i
                    j2 = j if d == 0 else j + 1
                    if not need[i2, j2]:
                        continue
                    b = c[i2, j2]
                    if a * b < 0.0 or (a == 0.0 and b != 0.0):
                        t = a / (a - b)
                        m = _seed(seeds, m, k, (i - 1 + (t if d == 0 else 0.0)) / (n - 1),
                                  (j - 1 + (t if d == 1 else 0.0)) / (n - 1), 0)
                # a local minimum of |c| with one sign all around (NaN, where c is not
                # defined, is neither lower nor a sign change)
                lowest = a == a and a != 0.0
                for d in range(9):
                    if not lowest:
                        break
                    if d == 4:
                        continue
                    i2 = i + d // 3 - 1
                    j2 = j + d % 3 - 1
                    if i2 < 1 or j2 < 1 or i2 > n or j2 > n:
                        continue  # beyond the raster's edge
                    if not need[i2, j2]:
                        lowest = False
                        break
                    b = c[i2, j2]
                    lowest = b != b or (b * a > 0.0 and abs(b) > abs(a))
                if lowest:
                    m = _seed(seeds, m, k, (i - 1) / (n - 1), (j - 1) / (n - 1), 1)
    return m


@njit(cache=True, error_model="numpy")
def _minimum(F, k, v, ix, iy, geo, u, w, radius):
    """From a node where |c_k| is least among its neighbours: the zero set of c_k
    nearby, if c_k changes sign near its stationary point.  Newton on grad c = 0 (the
    exact gradient; the Hessian by its differences), then on c along the direction of
    least curvature.  Returns (ok, u, w): a point of the zero set."""
    g = np.empty(2)
    H = np.empty((2, 2))
    u0, w0 = u, w
    for it in range(MAX_IT):
        c, s, cu, cw, huu, huw, hww = _hess(F, k, v, ix, iy, geo, u, w, g, H)
        a, b = _solve2(huu, huw, huw, hww, -cu, -cw)
        if not math.isfinite(a):
            return False, u, w
        u += a
        w += b
        if math.hypot(u - u0, w - w0) > radius:
            return False, u, w
        if abs(a) + abs(b) <= 1e-15:
            break
    c0, s, cu, cw, huu, huw, hww = _hess(F, k, v, ix, iy, geo, u, w, g, H)
    cn, sn, cun, cwn = _grad(F, k, v, ix, iy, geo, u0, w0, g)
    if c0 * cn >= 0.0:
        return False, u, w
    # along an eigenvector of the Hessian whose curvature has the sign of -c0
    tr = huu + hww
    det = huu * hww - huw * huw
    disc = math.sqrt(max(0.25 * tr * tr - det, 0.0))
    for lam in (0.5 * tr + disc, 0.5 * tr - disc):
        if lam * c0 >= 0.0:
            continue
        if abs(huw) > 0.0:
            eu, ew = lam - hww, huw
        elif abs(huu - lam) <= abs(hww - lam):
            eu, ew = 1.0, 0.0
        else:
            eu, ew = 0.0, 1.0
        en = math.hypot(eu, ew)
        eu /= en
        ew /= en
        t = math.sqrt(2.0 * abs(c0 / lam))
        for it in range(MAX_IT):
            c, s, cu, cw = _grad(F, k, v, ix, iy, geo, u + t * eu, w + t * ew, g)
            d = cu * eu + cw * ew
            if d == 0.0 or not math.isfinite(c):
                break
            step = -c / d
            t += step
            if abs(step) <= 1e-15:
                return _inside(u + t * eu, w + t * ew, 0.0), u + t * eu, w + t * ew
    return False, u, w


@njit(cache=True, error_model="numpy")
def _thin_all(F, active, v, ix, iy, geo, n):
    """Seeds that no class change of a raster gives: a region thinner than a cell of the
    check raster shows none, so :func:`_seeds_all` has no seed near it (GUIDE §7).

    On an n x n raster of nodes (the slice's edges included), per active condition c,
    its extremal nodes (c least, or greatest, among the neighbours): a sign change to a
    neighbour (an island of one node), or one found by refining the extremum near the
    node (:func:`_extremum`: the zero set passes between the nodes).  (A band between
    the zero sets of two conditions, thinner than a cell and without an extremum, is
    not looked for.)
    Returns rows (condition, u, w, status): status 0 a seed near the zero set, 2 an
    extremum that could not be refined but may reach zero within a cell (unresolved).
    """
    nc = active.shape[0]
    ks = np.flatnonzero(active)
    cv = np.empty((ks.shape[0], n, n))
    row = np.empty(nc)
    cs = np.empty(nc)
    for i in range(n):
        v[ix] = geo[0] + (i / (n - 1)) * geo[1]
        for j in range(n):
            v[iy] = geo[2] + (j / (n - 1)) * geo[3]
            _values(F, v, row, cs)
            for q in range(ks.shape[0]):
                cv[q, i, j] = row[ks[q]]
    g = np.empty(2)
    H = np.empty((2, 2))
    r = 1.0 / (n - 1)
    rows = np.empty((16, 4))
    m = 0
    for q in range(ks.shape[0]):
        k = ks[q]
        c = cv[q]
        for i in range(n):
            for j in range(n):
                a = c[i, j]
                if not a == a:
                    continue
                least, most = True, True
                flip_i, flip_j = -1, -1
                for d in range(9):
                    i2 = i + d // 3 - 1
                    j2 = j + d % 3 - 1
                    if d == 4 or i2 < 0 or j2 < 0 or i2 >= n or j2 >= n:
                        continue
                    b = c[i2, j2]
                    if not b == b:
                        continue
                    # ties: the first node of a flat stretch is its extremum
                    least = least and (b > a or (b == a and d > 4))
                    most = most and (b < a or (b == a and d > 4))
                    if a * b < 0.0:
                        flip_i, flip_j = i2, j2
                    if not (least or most):
                        break
                if not (least or most):
                    continue
                ui, wj = i / (n - 1), j / (n - 1)
                if a == 0.0:
                    rows = _row(rows, m, k, ui, wj, 0)
                    m += 1
                elif flip_i >= 0:  # an island: c has the other sign at a neighbour
                    f = a / (a - c[flip_i, flip_j])
                    rows = _row(rows, m, k, ui + f * (flip_i - i) * r,
                                wj + f * (flip_j - j) * r, 0)
                    m += 1
                elif (least and a > 0.0) or (most and a < 0.0):
                    status, u, w = _extremum(F, k, v, ix, iy, geo, ui, wj,
                                             1.0 if a > 0.0 else -1.0, r, g, H)
                    if status > 0:
                        rows = _row(rows, m, k, u, w, 0 if status == 1 else 2)
                        m += 1
    return rows[:m]


@njit(cache=True, error_model="numpy")
def _row(rows, m, k, u, w, status):
    """``rows`` with row m set to (k, u, w, status), twice as long where it was full."""
    if m >= rows.shape[0]:
        more = np.empty((2 * rows.shape[0], 4))
        more[:m] = rows[:m]
        rows = more
    rows[m, 0], rows[m, 1], rows[m, 2], rows[m, 3] = k, u, w, status
    return rows


@njit(cache=True, error_model="numpy")
def _extremum(F, k, v, ix, iy, geo, u0, w0, s, r, g, H):
    """From a raster node (u0, w0) where s c_k > 0 is least among its neighbours
    (``r`` apart): does c_k change sign within two cells?

    A corner where s c grows inwards along both edges is its own minimum.  Otherwise
    the candidates are the stationary point of c (Newton on grad c = 0) and, on each
    edge of the slice within a cell, the stationary point along it (a region that the
    edge cuts has its extremum there); where none is a minimum of s c (a kink, where c
    is a root, or the edge of c's domain), the least of 3 x 3 samples around the node,
    moved to the least sample, and zoomed in where that is the centre.  A point where
    s c < 0 proves a sign change.  Returns (1, u, w) with a point of the zero set
    (:func:`_zero_between` the node and that point); (0, u0, w0) where a minimum of
    s c is positive (for the samples: above their spread and above what the gradient
    at the least loses over the window: a cusp never is), touches zero within the
    ties, or lies at the edge of c's domain (beyond which c has no sign); else
    (2, u0, w0), unresolved."""
    c, sc, cu, cw = _grad(F, k, v, ix, iy, geo, u0, w0, g)
    if (u0 == 0.0 or u0 == 1.0) and (w0 == 0.0 or w0 == 1.0) \
            and s * cu * (1.0 if u0 == 0.0 else -1.0) >= 0.0 \
            and s * cw * (1.0 if w0 == 0.0 else -1.0) >= 0.0:
        return 0, u0, w0
    radius = 2.0 * r
    for e in range(-1, 4):  # -1: the interior; then the edges u = 0, u = 1, w = 0, w = 1
        fixed_u = e < 2
        edge = float(e % 2)
        if e >= 0 and abs((u0 if fixed_u else w0) - edge) > r:
            continue
        u, w = u0, w0
        if e >= 0:
            u, w = (edge, w0) if fixed_u else (u0, edge)
        done = False
        for it in range(12):
            c, sc, cu, cw, huu, huw, hww = _hess(F, k, v, ix, iy, geo, u, w, g, H)
            if not math.isfinite(c):
                break
            if s * c < 0.0:
                return _zero_between(F, k, v, ix, iy, geo, g, u0, w0, u, w)
            if done:
                break
            if e < 0:
                a, b = _solve2(huu, huw, huw, hww, -cu, -cw)
            elif fixed_u:
                a, b = 0.0, -cw / hww
            else:
                a, b = -cu / huu, 0.0
            if not (math.isfinite(a) and math.isfinite(b)):
                break
            u += a
            w += b
            if math.hypot(u - u0, w - w0) > radius or not _inside(u, w, 0.0):
                break
            done = abs(a) + abs(b) <= 1e-10  # one more pass: the value there
        if not (done and math.isfinite(c)):
            continue
        if e < 0 and s * huu >= 0.0 and s * hww >= 0.0 and huu * hww >= huw * huw:
            return 0, u0, w0
        inward = (cu if fixed_u else cw) * (1.0 if edge == 0.0 else -1.0)
        if e >= 0 and s * (hww if fixed_u else huu) >= 0.0 and s * inward >= 0.0:
            return 0, u0, w0
    # no smooth minimum: zoom in on the least of the samples around the node
    bu, bw, half = u0, w0, r
    for it in range(128):
        au, aw = bu, bw
        hi, least, tie, slope, edge = -np.inf, np.inf, 0.0, 0.0, False
        for p in range(9):
            u = min(max(au + (p // 3 - 1) * half, 0.0), 1.0)
            w = min(max(aw + (p % 3 - 1) * half, 0.0), 1.0)
            c, sc, cu, cw = _grad(F, k, v, ix, iy, geo, u, w, g)
            if not math.isfinite(c):
                edge = True
                continue
            if s * c < 0.0:
                return _zero_between(F, k, v, ix, iy, geo, g, u0, w0, u, w)
            hi = max(hi, s * c)
            if s * c < least:
                least, tie, slope, bu, bw = s * c, COVANISH * sc, math.hypot(cu, cw), u, w
        if (least > hi - least and least > 4.0 * slope * half) or least <= tie or edge:
            # above the samples' spread and the linear model's fall over the window,
            # within the ties of zero (it touches zero, as |x| does), or at the edge of
            # c's domain
            return 0, u0, w0
        if bu == au and bw == aw:
            half *= 0.25
            if half <= 1e-15:
                break
        elif math.hypot(bu - u0, bw - w0) > radius:
            return 0, u0, w0  # the least lies nearer another node, which is looked at
    return 2, u0, w0


@njit(cache=True, error_model="numpy")
def _zero_between(F, k, v, ix, iy, geo, g, ua, wa, ub, wb):
    """A zero of c_k on the segment from (ua, wa) to (ub, wb), where it has opposite
    signs, by bisection: (1, u, w), or (2, ua, wa) where c is not finite on the way."""
    ca = _grad(F, k, v, ix, iy, geo, ua, wa, g)[0]
    lo, hi = 0.0, 1.0
    for it in range(60):
        mid = 0.5 * (lo + hi)
        c = _grad(F, k, v, ix, iy, geo, ua + mid * (ub - ua), wa + mid * (wb - wa), g)[0]
        if not math.isfinite(c):
            return 2, ua, wa
        if (c < 0.0) == (ca < 0.0):
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12:
            break
    return 1, ua + hi * (ub - ua), wa + hi * (wb - wa)


@njit(cache=True, error_model="numpy")
def _raster_all(cells_at, v, ix, xs, xslot, xderiv, ys, yderiv, flags, fields):
    """The check raster: the scene's grid kernel ``cells`` (its address ``cells_at``) over
    the values ``xs`` of the input slot ``ix`` (outer; its derived inputs ``xderiv`` in
    the slots ``xslot``) and ``ys`` (inner, derived inputs ``yderiv``), row i into
    ``flags[:, i * len(ys):]`` (what :func:`phasemap.core.codegen.driver` does, serially and
    without a call from Python)."""
    ny = ys.shape[0]
    for i in range(xs.shape[0]):
        v[ix] = xs[i]
        for k in range(xslot.shape[0]):
            v[xslot[k]] = xderiv[k, i]
        call_cells(cells_at, v, i * ny, 0, ny, ys, yderiv, flags, fields)


@njit(cache=True, error_model="numpy")
def _applicable_all(F, v, out, ix, iy, geo, applicable, active):
    """Which conditions can bound a class in the slice (into ``active``), before their
    values are compared (:func:`groups`): those of no branch or of a branch that
    applies at one of the probes (the model's own statuses, :data:`CLASS_SIG`),
    without those that hold only at rest where the velocity is fixed and not zero,
    and without the velocity's own where it is not an axis.  ``applicable``
    (:data:`APPLICABLE`): the probes, each condition's branch index, the velocity and
    rest-only masks, whether the velocity is an axis, and its input slot.  ``v`` is
    left at the last probe, its derived inputs filled."""
    probes, branch, velocity, rest_only, velocity_axis, vslot = applicable
    applies = np.zeros(out.shape[0], dtype=np.bool_)
    for p in range(probes.shape[0]):
        v[ix] = geo[0] + probes[p, 0] * geo[1]
        v[iy] = geo[2] + probes[p, 1] * geo[3]
        _classify(F, v, out, 0)
        for b in range(out.shape[0]):
            applies[b] = applies[b] or out[b, nx.STATUS] != nx.ABSENT
    rest = False
    if not velocity_axis:
        cv = np.empty(active.shape[0])
        cs = np.empty(active.shape[0])
        _values(F, v, cv, cs)
        for k in range(active.shape[0]):
            if velocity[k]:  # the velocity condition's tie scale is the velocity scale
                rest = abs(v[vslot]) <= nx.TOL * cs[k]
    for k in range(active.shape[0]):
        active[k] = (branch[k] < 0 or applies[branch[k]]) and (rest or not rest_only[k]) \
            and (velocity_axis or not velocity[k])


@njit(cache=True, error_model="numpy")
def _seed_trace_all(F, pts, vs, applicable, raster, radius, active, rank, v, out, ix, iy, geo,
                    layer, n, verts, counts, curves, mark, tol_u, tol_w):
    """One call for a whole trace (a call from Python and the parallel driver of a
    raster cost about 30 us).  The conditions that can bound a class, into ``active``
    (:func:`_applicable_all` with the arguments ``applicable``: the probes, each
    condition's branch index, velocity and rest-only masks, whether the velocity is
    an axis and its input slot; ``vs`` left at the last probe); the check raster
    ``classes`` (:func:`_raster_all` with the arguments ``raster``: the grid kernel's
    address, then x's values, derived slots and derived values, y's values and
    derived values); the conditions' values
    at the points ``pts`` (input vector ``vs``) drop from ``active`` those constant or
    proportional to another there (:func:`groups`); then the cells near a class
    change of ``classes`` (:func:`near_changes` with ``radius``), the seeds of an
    n x n raster there (:func:`_seeds_all`), the curves from them
    (:func:`_trace_all`, ``require_sides``), their pieces (:func:`assemble`) and the
    class changes of ``classes`` no piece explains (:func:`uncovered`).  Returns
    (classes, near, seeds, group, grp, changes, the six arrays of :func:`assemble`,
    uncovered): ``grp`` is each condition's group and ``rank``, ``changes`` the rows
    of :func:`class_changes`; the pieces are empty where the buffers were full
    (``counts[2]``: trace again with larger ones).
    """
    _applicable_all(F, vs, out, ix, iy, geo, applicable, active)
    cells_at, xs, xslot, xderiv, ys, yderiv = raster
    flags = np.empty((1, xs.shape[0] * ys.shape[0]), dtype=np.int8)
    _raster_all(cells_at, v.copy(), ix, xs, xslot, xderiv, ys, yderiv, flags,
                np.empty((0, flags.shape[1])))
    classes = flags[0].reshape((xs.shape[0], ys.shape[0]))
    vals = np.empty((pts.shape[0], active.shape[0]))
    _survey_all(F, vs, ix, iy, geo, pts, vals)
    group = groups(vals, active)
    grp = np.empty((active.shape[0], 2), dtype=np.int64)
    for k in range(active.shape[0]):
        grp[k, 0] = group[k]
        grp[k, 1] = rank[k]
    changes = class_changes(classes)
    near = near_changes(classes.shape, changes, radius)
    seeds = _seeds_all(F, active, v, ix, iy, geo, n, near)
    _trace_all(F, seeds, grp, active, v, out, ix, iy, geo, layer, verts, counts, curves, mark,
               near, tol_u, tol_w, True)
    pv, pp, pq, pieces, pf, pi = assemble(verts, curves, 0 if counts[2] else counts[1])
    bad = _uncovered(classes.shape[0], changes, pv, pp)
    return classes, near, seeds, group, grp, changes, pv, pp, pq, pieces, pf, pi, bad


# -- pieces and the completeness check (no model globals) ---------------------------------

@njit(cache=True, error_model="numpy")
def _known(verts, q):
    """The side classes at vertex q, (-1, -1) where they were not sampled, (-2, -2) on
    a stretch that another condition traces."""
    p = verts[q]
    kind = p.kind
    if kind == REGULAR and p.owned == 0:
        return -2, -2
    if (kind == REGULAR or kind == FOLD_X or kind == FOLD_Y or kind == TANGENCY) \
            and p.left >= 0 and p.right >= 0:
        return p.left, p.right
    return -1, -1


@njit(cache=True, error_model="numpy")
def _forget_isolated(verts, a, b):
    """Forget the sides of a vertex whose classes differ from those of the vertices
    with sampled sides before and after it, where those two agree: a class pair seen
    at one vertex only is a sample that straddles another condition (at a tangency),
    not a stretch of boundary."""
    prev = -1
    for q in range(a, b):
        if _known(verts, q)[0] < 0:
            continue
        nxt = -1
        for r in range(q + 1, b):
            if _known(verts, r)[0] >= 0:
                nxt = r
                break
        if prev >= 0 and nxt >= 0 and _known(verts, q)[0] >= 0:
            p0, p1 = _known(verts, prev)
            n0, n1 = _known(verts, nxt)
            q0, q1 = _known(verts, q)
            if p0 == n0 and p1 == n1 and (q0 != p0 or q1 != p1):
                verts[q].left = -1
                verts[q].right = -1
                continue
        prev = q


@njit(cache=True, error_model="numpy")
def assemble(verts, curves, ncurves):
    """Split traced curves into pieces: stretches with one class on each side, and
    different classes.  Returns

    ``(pv, pp, pq, pieces, points_f, points_i)``: the pieces' vertices ``(u, w)``, the
    piece of each, its index in the vertex buffers, ``pieces[p] = (curve, condition, left, right, closed)``,
    ``points_f[q] = (u, w, residual, error)`` and ``points_i[q] = (kind,
    condition, other)`` for every crossing where a piece ends, every end on an
    edge, every fold and stall on a piece.
    """
    nv = 0
    for c in range(ncurves):
        nv += curves[c, 2] - curves[c, 1]
    cap = 2 * nv + 4
    pv = np.empty((cap, 2))
    pp = np.empty(cap, dtype=np.int64)
    pq = np.empty(cap, dtype=np.int64)
    pieces = np.empty((cap, 5), dtype=np.int64)
    points_f = np.empty((cap, 4))
    points_i = np.empty((cap, 3), dtype=np.int64)
    m = 0
    npieces = 0
    npoints = 0
    breaks = np.empty(nv + 2, dtype=np.int64)
    for c in range(ncurves):
        k, a, b, closed = curves[c, 0], curves[c, 1], curves[c, 2], curves[c, 3]
        if b - a < 2:
            continue
        _forget_isolated(verts, a, b)
        # break points: a crossing (or an unexplained change) where the sides change
        nb = 0
        for q in range(a, b):
            kind = verts[q].kind
            if kind == REGULAR and q > a and verts[q - 1].kind == REGULAR \
                    and verts[q].owned != verts[q - 1].owned:
                breaks[nb] = q  # the stretch passes to or from another condition
                nb += 1
                continue
            if kind != CROSSING and kind != CHANGE:
                continue
            before = (-1, -1)
            for r in range(1, b - a):
                p = q - r
                if p < a:
                    if not closed:
                        break
                    p += b - a - 1
                before = _known(verts, p)
                if before[0] >= 0:
                    break
            after = (-1, -1)
            for r in range(1, b - a):
                p = q + r
                if p >= b:
                    if not closed:
                        break
                    p -= b - a - 1
                after = _known(verts, p)
                if after[0] >= 0:
                    break
            if before[0] != after[0] or before[1] != after[1]:
                breaks[nb] = q
                nb += 1
        # runs between break points (a closed curve's last run goes on into its first)
        nruns = nb + 1 if (not closed or nb == 0) else nb
        for r in range(nruns):
            if nb == 0:
                first, last = a, b - 1
            elif not closed:
                first = a if r == 0 else breaks[r - 1]
                last = breaks[r] if r < nb else b - 1
            else:
                first = breaks[r]
                last = breaks[r + 1] if r + 1 < nb else breaks[0] + (b - 1 - a)
            # the run's classes: the first vertex inside it with sampled sides
            left, right = -1, -1
            for q in range(first, last + 1):
                qq = q if q < b else q - (b - 1 - a)
                left, right = _known(verts, qq)
                if left >= 0:
                    break
            if left < 0 or left == right:
                continue
            piece = npieces
            npieces += 1
            pieces[piece, 0] = c
            pieces[piece, 1] = k
            pieces[piece, 2] = left
            pieces[piece, 3] = right
            pieces[piece, 4] = 1 if (closed and nb == 0) else 0
            for q in range(first, last + 1):
                qq = q if q < b else q - (b - 1 - a)
                pv[m, 0] = verts[qq].u
                pv[m, 1] = verts[qq].w
                pp[m] = piece
                pq[m] = qq
                m += 1
                kind = verts[qq].kind
                point = kind == FOLD_X or kind == FOLD_Y or kind == TANGENCY or kind == END \
                    or kind == STALL
                if kind == CROSSING or kind == CHANGE:
                    for z in range(nb):
                        point = point or breaks[z] == qq
                if point:
                    points_f[npoints, 0] = verts[qq].u
                    points_f[npoints, 1] = verts[qq].w
                    points_f[npoints, 2] = verts[qq].residual
                    points_f[npoints, 3] = verts[qq].error
                    points_i[npoints, 0] = kind
                    points_i[npoints, 1] = k
                    points_i[npoints, 2] = verts[qq].other
                    npoints += 1
    return pv[:m], pp[:m], pq[:m], pieces[:npieces], points_f[:npoints], points_i[:npoints]


@njit(cache=True, error_model="numpy")
def uncovered(classes, pv, pp):
    """Class changes of a raster that no piece passes within one cell of.

    ``classes[i, j]`` is the class at the cell centre ((i + 1/2)/nx, (j + 1/2)/ny)
    of the unit square; ``pv``, ``pp`` the pieces' vertices and piece indices.
    Returns rows ``(i, j, di, dj)``: the cells (i, j) and (i + di, j + dj) differ
    and no piece passes through the 3 x 3 cells around either.
    """
    assert classes.shape[0] == classes.shape[1]
    return _uncovered(classes.shape[0], class_changes(classes), pv, pp)


@njit(cache=True, error_model="numpy")
def _uncovered(n, changes, pv, pp):
    """:func:`uncovered` of an n x n raster from its class changes
    (:func:`class_changes`): those rows with no cell a piece passes through in the
    3 x 3 cells around either of their two cells."""
    hit = np.zeros((1, n, n), dtype=np.int8)
    for q in range(pv.shape[0]):
        if q + 1 < pv.shape[0] and pp[q + 1] == pp[q]:
            _mark(hit, 0, pv[q, 0], pv[q, 1], pv[q + 1, 0], pv[q + 1, 1])
        else:
            _mark(hit, 0, pv[q, 0], pv[q, 1], pv[q, 0], pv[q, 1])
    out = np.empty((changes.shape[0], 4), dtype=np.int64)
    m = 0
    for r in range(changes.shape[0]):
        i, j = changes[r, 0], changes[r, 1]
        if not (_hit_around(hit, i, j) or _hit_around(hit, i + changes[r, 2], j + changes[r, 3])):
            out[m] = changes[r]
            m += 1
    return out[:m]


@njit(cache=True, error_model="numpy")
def _hit_around(hit, i, j):
    """Whether a cell of ``hit[0]`` in the 3 x 3 cells around (i, j) is marked."""
    n = hit.shape[1]
    for a in range(max(i - 1, 0), min(i + 2, n)):
        for b in range(max(j - 1, 0), min(j + 2, n)):
            if hit[0, a, b]:
                return True
    return False


# -- the compiled tracer: entry points with the model's functions as arguments --------------

_C2 = types.Array(types.int8, 2, "C")
#: The vertex buffer (:data:`VERTEX` records).
VERTS = types.Array(numba.from_dtype(VERTEX), 1, "C")
#: A check raster's arguments (:func:`_raster_all`): the grid kernel's address; x's
#: values, derived slots and derived values; y's values and derived values.
RASTER = types.Tuple((types.intp, F1, I1, F2, F1, F2))
#: What decides the conditions that can bound a class (:func:`_applicable_all`): the
#: probes (unit square), per condition its branch's index and the velocity and rest-only
#: masks, whether the velocity is an axis, and its input slot.
APPLICABLE = types.Tuple((F2, I1, B1, B1, types.boolean, types.int64))
#: ``values(x, out, scale)`` of a generated condition module.
VALUES_SIG = types.void(F1, F1, F1)
#: ``gradient(k, x, g)``: (value, tie scale); the gradient in the module's variables into g.
GRADIENT_SIG = types.UniTuple(types.float64, 2)(types.int64, F1, F1)
#: ``hessian(k, x, g, H)``: the same, and the Hessian into H.
HESSIAN_SIG = types.UniTuple(types.float64, 2)(types.int64, F1, F1, F2)
#: ``classify(v, out, layer)``: the layer's class at the input vector v (a model's).
CLASS_SIG = types.int64(F1, F2, types.int64)
#: What an entry point takes for the model's functions: the addresses of their compiled
#: code (:func:`functions`), in the order ``values``, ``gradient``, ``hessian``,
#: ``classify``.
ADDRESSES = types.UniTuple(types.intp, 4)


def _typer(i, fsig, addresses, args):
    """An intrinsic's signature and code: a call of function ``i`` of :data:`ADDRESSES`
    (:func:`phasemap.core.calls.typer`)."""
    return calls.typer(fsig, addresses, args, index=i, table=ADDRESSES)


@intrinsic
def _values(typingctx, addresses, x, out, scale):
    """``values(x, out, scale)`` of the condition module (:data:`VALUES_SIG`)."""
    return _typer(0, VALUES_SIG, addresses, (x, out, scale))


@intrinsic
def _gradient(typingctx, addresses, k, x, g):
    """``gradient(k, x, g)`` of the condition module (:data:`GRADIENT_SIG`)."""
    return _typer(1, GRADIENT_SIG, addresses, (k, x, g))


@intrinsic
def _hessian(typingctx, addresses, k, x, g, H):
    """``hessian(k, x, g, H)`` of the condition module (:data:`HESSIAN_SIG`)."""
    return _typer(2, HESSIAN_SIG, addresses, (k, x, g, H))


@intrinsic
def _classify(typingctx, addresses, v, out, layer):
    """The model's ``classify(v, out, layer)`` (:data:`CLASS_SIG`, :func:`classifier`)."""
    return _typer(3, CLASS_SIG, addresses, (v, out, layer))


# what the twins of the entry points (:func:`runs`) call instead of these intrinsics
for _index, _intrinsic in enumerate((_values, _gradient, _hessian, _classify)):
    interpret.register(_intrinsic, tiers.at_address(_index))
interpret.register(call_cells, tiers.at_address())

_ENTRIES: dict = {}
_SIGNATURES: dict = {}
#: what :func:`runs` gives: the machine code's entry points and helpers, or the twins
_MACHINE: dict = {}
_TWINS: dict = {}


def _signatures() -> dict:
    """name -> (the entry point's function, its signature), for :func:`entries`."""
    if not _SIGNATURES:
        sig_trace = types.int64(ADDRESSES, F2, I2, B1, F1, F2, types.int64, types.int64,
                                F1, types.int64, VERTS, I1, I2, S3, B2, types.float64,
                                types.float64, types.boolean)
        sig_seeds = F2(ADDRESSES, B1, F1, types.int64, types.int64, F1, types.int64, B2)
        sig_survey = types.void(ADDRESSES, F1, types.int64, types.int64, F1, F2, F2)
        sig_seed_trace = types.Tuple((_C2, B2, F2, I1, I2, I2, F2, I1, I1, I2, F2,
                                      I2, I2))(
            ADDRESSES, F2, F1, APPLICABLE, RASTER, types.int64, B1, I1, F1,
            F2, types.int64, types.int64, F1, types.int64, types.int64, VERTS, I1, I2,
            S3, types.float64, types.float64)
        sig_thin = F2(ADDRESSES, B1, F1, types.int64, types.int64, F1, types.int64)
        sig_applicable = types.void(ADDRESSES, F1, F2, types.int64, types.int64, F1,
                                    APPLICABLE, B1)
        sig_raster = types.void(types.intp, F1, types.int64, F1, I1, F2, F1, F2, _C2,
                                F2)
        _SIGNATURES.update({"trace": (_trace_all, sig_trace),
                            "seeds": (_seeds_all, sig_seeds),
                            "seed_trace": (_seed_trace_all, sig_seed_trace),
                            "thin": (_thin_all, sig_thin),
                            "survey": (_survey_all, sig_survey),
                            "raster": (_raster_all, sig_raster),
                            "applicable": (_applicable_all, sig_applicable)})
    return _SIGNATURES


def entries() -> dict:
    """The tracer's entry points, compiled once (cached on disk): ``trace``, ``seeds``,
    ``seed_trace`` (the check raster, then both, after the cells near its class
    changes), ``thin`` (seeds of regions thinner than a raster cell), ``survey``,
    ``raster`` (the check raster alone) and ``applicable``.

    Each is the compiled overload's own entry point, called without the
    dispatcher (typing the arguments at every call cost 0.2-0.5 ms with the
    first-class functions the tracer took before, more than a whole trace of a
    simple slice).  The callers pass
    exactly the signature's types (C-contiguous arrays, :func:`functions`'
    addresses, :data:`ADDRESSES`).
    """
    if not _ENTRIES:
        for name, (fn, sig) in _signatures().items():
            # by the argument types, as numba's cache indexes a call's machine code (and
            # runs() looks for it there): under the whole signature, return type and all,
            # it was saved under another key, which a look-up by types never found
            fn.compile(tuple(sig.args))
            _ENTRIES[name] = _entry_point(fn, sig)
    return _ENTRIES


#: the functions a trace's Python calls between its entry points (:func:`runs`)
_HELPERS = {"assemble": assemble, "uncovered": _uncovered, "mark": _mark, "groups": groups}


def runs(twins: bool | None = None) -> dict:
    """The tracer's entry points (:func:`entries`) and the helpers its Python calls
    between them (``assemble``, ``uncovered``, ``mark``, ``groups``), as
    :mod:`phasemap.core.tiers` chooses: machine code where it is in this process or the
    kernel cache, or under ``PHASEMAP_JIT=eager``; otherwise their interpreted twins, with
    the same bits, while a background process compiles them all into the cache (numba takes
    about 30 s of CPU for the tracer, which serves every model; the twins trace the
    README's rod in about half a second, the model's own functions called as machine code
    at their addresses).  A call once that compile has ended loads the machine code.
    Under ``PHASEMAP_JIT=off``, the twins always.  ``twins``: True or False for the tier a
    slice was made for (:func:`phasemap.bifurcation.tracing.make_slice`: its functions may
    be twins' handles, which only the twins can take), None to choose."""
    if twins:
        return _twins()
    if twins is None and (not _ENTRIES or tiers.mode() == "off"):
        fn, sig = _signatures()["trace"]
        chosen = tiers.runner(fn, None, warm=(entries, (), {}), sig=tuple(sig.args))
        if tiers.is_twin(chosen):
            try:
                return _twins()
            except interpret.Unsupported:  # (a twin differs: compile, as eager)
                pass
    if not _MACHINE:
        _MACHINE.update({**entries(), **_HELPERS})
    return _MACHINE


def on_twins(run: dict) -> bool:
    """Whether ``run`` (of :func:`runs`) is the interpreted twins."""
    return run is _TWINS


def _twins() -> dict:
    """:func:`runs`' interpreted twins (made once per process)."""
    if not _TWINS:
        made = {name: tiers.twin(fn) for name, (fn, _) in _signatures().items()}
        made.update({name: tiers.twin(fn) for name, fn in _HELPERS.items()})
        _TWINS.update(made)
    return _TWINS


def _entry_point(dispatcher, sig):
    """The Python-callable entry point of ``dispatcher``'s overload for ``sig``."""
    return dispatcher.overloads[tuple(sig.args)].entry_point


_CLASSIFIERS = Memo("trace.classifiers")


def classifier(model):
    """The model's ``classify(v, out, layer)`` (its own point and summarize), for a trace
    to take at its address, compiled for :data:`CLASS_SIG` (:func:`functions`)."""
    from phasemap.core.compile import specialize

    def make():   # (compiled where its address is taken: :func:`functions`)
        contract = model.contract
        return specialize(_class_template, model, "bif_class", POINT=contract.point,
                          DERIVE=contract.derive_inline, STICK=model.stick_branch)

    return _CLASSIFIERS.get((model,), (), make)


_FUNCTIONS = Memo("trace.functions")


@njit(GRADIENT_SIG, cache=True)
def _no_gradient(k, x, g):
    """The gradient of a values-only condition set (:func:`functions`): none."""
    return np.nan, np.nan


@njit(HESSIAN_SIG, cache=True)
def _no_hessian(k, x, g, H):
    """The Hessian of a values-only condition set (:func:`functions`): none."""
    return np.nan, np.nan


def functions(model, conds, twins: bool = False, warm=None) -> tuple:
    """The addresses of the functions a trace of ``model`` with the two-variable
    condition module ``conds`` takes (:data:`ADDRESSES`), made once per model and
    module: per function, its compiled overload's code.  A values-only condition set
    (:func:`phasemap.bifurcation.conditions.values_of`) has no derivatives: its
    gradient and Hessian are NaN, for the entry points that read only values and
    classes (:func:`_applicable_all`).

    With ``twins`` (a trace on the tracer's interpreted twins, :func:`runs`), a condition
    function whose machine code is neither in the process nor in the kernel cache is
    not compiled here: its interpreted twin's handle (:func:`phasemap.core.tiers.handle`)
    stands for its address, and ``warm``, a picklable call, compiles it in a background
    process (:func:`compile_conditions`; numba takes half a minute for the drawer's 62
    conditions, 10 s for the ladder's class function).  Such a tuple is made anew at each
    call, so that a later slice takes the machine code once it is built.

    A jitted function passed as such is looked up in its dispatcher at every call
    (0.2 ms a call), and a first-class function object is unboxed through Python at
    every call (15 us for the four, measured on a call of the ``survey`` entry point).
    The overloads stay alive with their model and module, which this cache keeps.
    """
    mod = conds.module
    gradient, hessian = (_no_gradient, _no_hessian) if mod is None else (mod.gradient,
                                                                         mod.hessian)
    pairs = ((conds.values, VALUES_SIG), (gradient, GRADIENT_SIG), (hessian, HESSIAN_SIG),
             (classifier(model), CLASS_SIG))
    if twins:
        fns = []
        for fn, sig in pairs:
            args = tuple(sig.args)
            chosen = tiers.runner(fn, None, warm=warm, sig=args)
            fns.append(tiers.handle(fn) if tiers.is_twin(chosen) else
                       tiers.addressed(fn, args))
        return tuple(fns)

    def make():
        fns = []
        for fn, sig in pairs:
            # the hessian is compiled (or loaded) when first needed
            fns.append(tiers.addressed(fn, sig.args))
        return tuple(fns)

    return _FUNCTIONS.get((model, mod if mod is not None else conds.values), (), make)


def tiered(conds, conditions=None):
    """``conds`` with its functions (``values``, ``module.gradient``, ``module.hessian``) as
    :mod:`phasemap.core.tiers` chooses for calls from Python: their machine code where it
    is built (or under ``PHASEMAP_JIT=eager``), else their interpreted twins, with the same
    bits, while a background process compiles them (:func:`compile_conditions`): the
    drawer's first threshold on a line compiled its 62 conditions' gradients in f first,
    14 s of numba.  ``conditions``: those given to the call (None: the model's own)."""
    import copy
    import types

    from phasemap.systems import reference

    warm = (compile_conditions, (reference(conds.model), conditions, conds.variables,
                                 conds.subset, True), {})

    def pick(fn, sig):
        return tiers.runner(fn, None, warm=warm, sig=tuple(sig.args))

    out = copy.copy(conds)
    out.values = pick(conds.values, VALUES_SIG)
    out.module = types.SimpleNamespace(gradient=pick(conds.module.gradient, GRADIENT_SIG),
                                       hessian=pick(conds.module.hessian, HESSIAN_SIG))
    return out


def compile_conditions(model, conditions, variables, subset, values=False) -> None:
    """What a background process runs (under ``PHASEMAP_JIT=eager``) to compile a slice's
    condition functions into the kernel cache (:func:`functions`): ``model`` as
    :func:`phasemap.systems.reference` gives it, the conditions given to the trace (None:
    the model's own); with ``variables`` None the values of every condition, else their
    gradients and Hessians in ``variables`` for the conditions of ``subset`` (and their
    values with ``values``: :func:`tiered`); the values
    come with the model's class function (:func:`classifier`), which the trace takes too."""
    from phasemap.bifurcation.conditions import compiled, values_of
    from phasemap.systems import get_model

    m = get_model(model)
    if variables is None:
        tiers.addressed(values_of(m, conditions).values, VALUES_SIG.args)
        tiers.addressed(classifier(m), CLASS_SIG.args)
        return
    conds = compiled(m, tuple(variables), conditions, subset)
    if values:
        tiers.addressed(conds.values, VALUES_SIG.args)
    mod = conds.module
    tiers.addressed(mod.gradient, GRADIENT_SIG.args)
    tiers.addressed(mod.hessian, HESSIAN_SIG.args)
