"""phasemap.boundaries and phasemap.threshold: exact pieces, points and thresholds.

Each slice is traced once per module (its tracer compiles once per model and
condition set).  The closed forms are derived here, independently of the
tracer: the Painleve rod's coefficient and its fold (4/3 at arctan 2), its
singular points, a loop and a loop touching the slice's edges.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
import xarray as xr

import phasemap
from phasemap.bifurcation import Condition, boundaries, threshold
from phasemap.bifurcation import _trace
from phasemap.core import tiers

from conftest import assert_atlas_round_trip

TH, OM, F, L, G, M = sp.symbols("theta omega f l g m", real=True)


def rod_conditions(coefficient=True):
    """The Painleve rod's conditions in its generated names, derived here: the slide's
    coefficient (the determinant of the contact problem, a third of
    1 + 3 cos^2 - 3 sigma' f sin cos), its normal force's numerator and the gap
    acceleration of the end lifting off (l omega^2 sin theta - g, the free rod's)."""
    s, c = sp.sin(TH), sp.cos(TH)
    out = []
    for sig, b in ((1, "A_slip_pos"), (-1, "A_slip_neg")):
        if coefficient:
            out.append(Condition(f"coef_{b}", b, "coefficient",
                                 sig * c * F * s + c**2 + sp.Rational(1, 3),
                                 sp.Abs(F) + sp.Rational(4, 3)))
        out.append(Condition(f"N_A_{b}", b, "normal", M / 3 * (G - L * OM**2 * s),
                             sp.Abs(M) / 3 * (sp.Abs(G) + sp.Abs(L) * OM**2)))
    out.append(Condition("gap_A_A_separated", "A_separated", "gap", L * OM**2 * s - G,
                         sp.Abs(G) + sp.Abs(L) * OM**2, strict=True))
    return out


ROD = rod_conditions()
SLIDE_BACK = {"xdot": -1.0, "omega": 0.0}


def test_hand_conditions_are_the_rods():
    """The coefficient used here has the sign of the model's own coef layer (its
    generated determinant) at random states: the same physics."""
    rng = np.random.default_rng(3)
    theta = rng.uniform(0.05, 1.5, 400)
    for fv in rng.uniform(0, 3, 5):
        ds = phasemap.Scene("painleve_rod", axes={"theta": np.sort(theta)},
                            fixed={"xdot": -1.0, "f": fv}, layers=["coef_A_slip_neg"]).compute()
        t = np.sort(theta)
        mine = 1 + 3 * np.cos(t) ** 2 - 3 * fv * np.sin(t) * np.cos(t)
        assert np.all(np.sign(mine) == np.sign(ds.coef_A_slip_neg.values))


@pytest.fixture(scope="module")
def rod_fold():
    return boundaries("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)}, fixed=SLIDE_BACK,
                      conditions=ROD)


def test_rod_first_paradox_is_a_fold_at_four_thirds(rod_fold):
    b = rod_fold
    assert list(b.condition.values) == ["coef_A_slip_neg"]
    assert (int(b.class_left[0]), int(b.class_right[0])) in ((0, 1), (1, 0))
    fold = b.point_kind.values == "fold_f"
    assert fold.sum() == 1
    assert abs(float(b.point_f[fold][0]) - 4 / 3) <= 1e-10
    assert abs(float(b.point_theta[fold][0]) - math.atan(2)) <= 1e-10
    # it ends on the edge f = 3, where 1 + 3 cos^2 = 9 sin cos: 4 + t^2 = 9 t, t = tan theta
    ends = np.sort(b.point_theta.values[b.point_kind.values == "end"])
    assert np.allclose(ends, np.arctan(np.sort(np.roots([1, -9, 4]))), rtol=0, atol=1e-10)
    assert np.all(b.point_residual.values <= 1e-12)
    assert np.all(b.point_error.values <= 1e-10)


def test_rod_vertices_lie_on_the_coefficient_and_follow_its_curvature(rod_fold):
    th, f = rod_fold.theta.values, rod_fold.f.values
    c, s = np.cos(th), np.sin(th)
    assert np.max(np.abs(1 / 3 + c**2 - f * s * c) / (4 / 3 + f)) <= 1e-12
    # chords stay within the tracer's chord error of the exact curve f(theta)
    exact = (1 + 3 * np.cos(th) ** 2) / (3 * np.sin(th) * np.cos(th))
    assert np.max(np.abs(exact - f)) <= 1e-12 * 3
    # each chord's largest distance from the exact curve between its vertices, in the
    # slice's units (theta spans 1.3, f 3)
    worst = 0.0
    for a, b in zip(range(len(th) - 1), range(1, len(th))):
        t = np.linspace(th[a], th[b], 41)
        u = (t - th[a]) / 1.3
        w = ((1 + 3 * np.cos(t) ** 2) / (3 * np.sin(t) * np.cos(t)) - f[a]) / 3.0
        du, dw = (th[b] - th[a]) / 1.3, (f[b] - f[a]) / 3.0
        worst = max(worst, np.max(np.abs(u * dw - w * du)) / math.hypot(du, dw))
    assert worst <= 1.5 * _trace.CHORD
    mid = 0.5 * (th[1:] + th[:-1])
    steps = np.hypot(np.diff(th) / 1.3, np.diff(f) / 3.0)
    assert np.max(steps) <= _trace.H_MAX * 1.01
    # where the curve bends most (near the fold) the vertices are closest
    assert steps[np.argmin(np.abs(mid - math.atan(2)))] < np.median(steps)


def test_rod_singular_points_are_crossings():
    """In (theta, omega) at f = 2 the slide's coefficient vanishes on two lines, and its
    normal force with the free-flight acceleration on g = l sin(theta) omega^2: they
    cross at the singular points of Genot and Brogliato (1999)."""
    b = boundaries("painleve_rod", {"theta": (0.1, 1.5), "omega": (-5.0, 5.0)},
                   fixed={"xdot": -1.0, "f": 2.0}, conditions=ROD)
    # 1 + 3 c^2 - 6 s c = 0  <=>  (1 + t^2) + 3 - 6 t = 0 with t = tan theta
    roots = sorted(math.atan(t) for t in np.roots([1, -6, 4]))
    cross = b.point_kind.values == "crossing"
    got = sorted(zip(np.round(b.point_theta.values[cross], 9), b.point_omega.values[cross]))
    want = sorted((round(r, 9), s * math.sqrt(9.81 / math.sin(r))) for r in roots for s in (1, -1))
    assert len(got) == 4
    for (t1, w1), (t2, w2) in zip(got, want):
        assert abs(t1 - t2) <= 1e-9 and abs(w1 - w2) <= 1e-10
    assert set(b.condition.values) == {"coef_A_slip_neg", "N_A_A_slip_neg"}
    # none (0) below the normal force's curve and two (2) above it, beyond the lines
    pairs = {tuple(sorted(p)) for p in zip(b.class_left.values, b.class_right.values)}
    assert pairs == {(0, 1), (1, 2), (0, 2)}


def _block():
    """A block on a rough floor lifted by a force m g (theta^2 + omega^2) / r^2 that grows
    with a flywheel's state: its normal force vanishes on the circle of radius r."""
    from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

    f = Parameter("f", "1", "friction coefficient", default=0.5, lower=0.0)
    r = Parameter("r", "1", "radius of the loop", default=1.0, lower=0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
    m = Parameter("m", "kg", "mass of the block", default=1.0, lower=0.0, lower_open=True)
    theta = Coordinate("theta", "rad", "angle of the flywheel",
                       rate=Rate("omega", "rad s-1", "its angular velocity"))
    x = Coordinate("x", "m", "position of the block",
                   rate=Rate("xdot", "m s-1", "velocity of the block", scale=sp.sqrt(g)))
    y = Coordinate("y", "m", "height of the block")
    system = System("lifted_block", "a block lifted by a flywheel's force", "test",
                    coordinates=(theta, x, y), parameters=(f, r, g, m),
                    bodies=(Body(m, (x, y)), Body(m, (0, 0), inertia=m, angle=theta)),
                    potential=m * g * y,
                    forces={y: m * g * (theta**2 + theta.rate**2) / r**2},
                    contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f),))
    R = sp.Symbol("r", real=True)
    n = M * G * (1 - (TH**2 + OM**2) / R**2)
    scale = sp.Abs(G) * (1 + (TH**2 + OM**2) / R**2)
    conds = [Condition("N_A_A_slip_pos", "A_slip_pos", "normal", n, sp.Abs(M) * scale),
             Condition("gap_A_A_separated", "A_separated", "gap", -n / M, scale)]
    return system.model, conds


@pytest.fixture(scope="module")
def block():
    return _block()


def test_a_closed_loop(block):
    model, conds = block
    b = boundaries(model, {"theta": (-2, 2), "omega": (-2, 2)}, fixed={"xdot": 1.0},
                   layer="contact_lost", conditions=conds)
    assert b.sizes["piece"] == 1 and int(b.closed[0]) == 1
    th, om = b.theta.values, b.omega.values
    assert th[0] == th[-1] and om[0] == om[-1]
    assert np.max(np.abs(np.hypot(th, om) - 1)) <= 1e-12
    # the loop's left is inside (kept: 0) if it runs counter-clockwise
    ccw = np.sum(th[:-1] * om[1:] - th[1:] * om[:-1]) > 0
    assert (int(b.class_left[0]), int(b.class_right[0])) == ((0, 1) if ccw else (1, 0))
    folds = sorted(zip(b.point_kind.values, np.round(b.point_theta.values, 12),
                       np.round(b.point_omega.values, 12)))
    assert folds == [("fold_omega", 0.0, -1.0), ("fold_omega", 0.0, 1.0),
                     ("fold_theta", -1.0, 0.0), ("fold_theta", 1.0, 0.0)]


def test_a_loop_touching_the_slice_edges(block):
    """omega in (-1, 1): the unit circle touches both edges, where it turns back in omega."""
    model, conds = block
    b = boundaries(model, {"theta": (-2, 2), "omega": (-1, 1)}, fixed={"xdot": 1.0},
                   layer="contact_lost", conditions=conds)
    assert b.sizes["piece"] == 1 and int(b.closed[0]) == 1
    kinds = sorted(b.point_kind.values)
    assert kinds == ["fold_omega", "fold_omega", "fold_theta", "fold_theta"]
    at_edge = b.point_kind.values == "fold_omega"
    assert np.allclose(np.abs(b.point_omega.values[at_edge]), 1.0, rtol=0, atol=1e-12)


def test_a_piece_ending_on_the_slice_edge(block):
    model, conds = block
    b = boundaries(model, {"theta": (-2, 2), "omega": (-0.5, 1.5)}, fixed={"xdot": 1.0},
                   layer="contact_lost", conditions=conds)
    assert b.sizes["piece"] == 1 and int(b.closed[0]) == 0
    ends = b.point_kind.values == "end"
    assert np.allclose(np.sort(b.point_theta.values[ends]), [-math.sqrt(0.75), math.sqrt(0.75)],
                       rtol=0, atol=1e-10)
    assert np.all(b.point_omega.values[ends] == -0.5)
    assert b.omega.values[0] == -0.5 and b.omega.values[-1] == -0.5


def test_round_trip_and_cf(rod_fold, tmp_path):
    assert_atlas_round_trip(rod_fold, tmp_path, "boundaries.nc")
    # built directly (no merge): the Dataset xarray's constructor builds from its parts
    made = xr.Dataset({k: v.variable for k, v in rod_fold.data_vars.items()},
                      coords={"piece": rod_fold.piece.variable}, attrs=rod_fold.attrs)
    xr.testing.assert_identical(rod_fold, made)
    assert dict(rod_fold.sizes) == dict(made.sizes) and rod_fold.piece.dims == ("vertex",)


def test_a_missing_condition_is_reported_with_its_cells():
    with pytest.raises(ValueError, match=r"class change\(s\) of n_solutions.*theta="):
        boundaries("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)}, fixed=SLIDE_BACK,
                   conditions=rod_conditions(coefficient=False))


def test_unexplained_class_changes_come_back_as_data_when_not_strict(tmp_path):
    """Issue 37 item 9: a user debugging a declaration gets the traced pieces with the
    class changes no piece explains, as data, and a warning, without private functions.
    The rod's slide coefficient left out: every change across the paradox's boundary is
    unexplained; each lies where the coefficient 1 + 3 cos^2 - 3 f sin cos changes sign
    between its two cells, and its classes are 'none' and 'unique'."""
    axes = {"theta": (0.2, 1.5), "f": (0.0, 3.0)}
    with pytest.warns(UserWarning, match=r"class change\(s\) of n_solutions.*unexplained_"):
        b = boundaries("painleve_rod", axes, fixed=SLIDE_BACK,
                       conditions=rod_conditions(coefficient=False), strict=False)
    assert b.sizes["unexplained"] > 10
    classes = {int(a) for a in b.unexplained_class_from.values} | {
        int(a) for a in b.unexplained_class_to.values}
    assert classes == {0, 1}

    def coef(theta, f):
        return 1 + 3 * np.cos(theta) ** 2 - 3 * f * np.sin(theta) * np.cos(theta)

    a = coef(b.unexplained_theta_from.values, b.unexplained_f_from.values)
    c = coef(b.unexplained_theta_to.values, b.unexplained_f_to.values)
    assert (a * c <= 0).all()
    assert b.unexplained_class_from.attrs["flag_meanings"].split()[:2] == ["none", "unique"]
    back = phasemap.open_atlas(phasemap.write_atlas(b, tmp_path / "b.nc")).load()
    xr.testing.assert_identical(back[["unexplained_theta_from", "unexplained_class_to"]],
                                b[["unexplained_theta_from", "unexplained_class_to"]])



def test_uncovered_is_every_change_with_no_hit_around_either_cell():
    """The completeness check against numpy: dilate the cells the pieces pass through
    by one cell, and keep the class changes with neither cell in the dilation."""
    rng = np.random.default_rng(7)
    n = 24
    for trial in range(20):
        classes = (rng.uniform(size=(n, n)) < rng.uniform(0.05, 0.5)).astype(np.int8)
        pv = rng.uniform(size=(rng.integers(1, 8), 2))
        pp = np.sort(rng.integers(0, 3, size=len(pv)))
        hit = np.zeros((1, n, n), dtype=np.int8)
        for q in range(len(pv)):
            end = pv[q + 1] if q + 1 < len(pv) and pp[q + 1] == pp[q] else pv[q]
            _trace._mark(hit, 0, pv[q, 0], pv[q, 1], end[0], end[1])
        padded = np.pad(hit[0], 1)
        near = np.zeros((n, n), dtype=bool)
        for di in range(3):
            for dj in range(3):
                near |= padded[di:di + n, dj:dj + n] != 0
        want = [(i, j, di, dj) for i in range(n) for j in range(n) for di, dj in ((1, 0), (0, 1))
                if i + di < n and j + dj < n and classes[i, j] != classes[i + di, j + dj]
                and not (near[i, j] or near[i + di, j + dj])]
        got = _trace.uncovered(classes, pv, pp)
        assert [tuple(r) for r in got] == want, trial
        assert got.dtype == np.int64 and got.shape == (len(want), 4)


def _seed_rows_reference(cv, need, ks, n):
    """The seeding rule of _seeds_all in plain Python: per condition and node in C order,
    a sign change to the needed node below or to the right (interpolated), then a
    local minimum of |c| with one sign among every needed neighbour in the raster."""
    rows = []
    for q, k in enumerate(ks):
        c = cv[q]
        for i in range(1, n + 1):
            for j in range(1, n + 1):
                if not need[i, j]:
                    continue
                a = c[i, j]
                for d, (i2, j2) in enumerate(((i + 1, j), (i, j + 1))):
                    b = c[i2, j2]
                    if need[i2, j2] and (a * b < 0 or (a == 0 and b != 0)):
                        t = a / (a - b)
                        rows.append((k, (i - 1 + (t if d == 0 else 0)) / (n - 1),
                                     (j - 1 + (t if d == 1 else 0)) / (n - 1), 0))
                around = [(i + di, j + dj) for di in (-1, 0, 1) for dj in (-1, 0, 1)
                          if (di or dj) and 1 <= i + di <= n and 1 <= j + dj <= n]
                if a == a and a != 0 and all(
                        need[p] and (c[p] != c[p] or (c[p] * a > 0 and abs(c[p]) > abs(a)))
                        for p in around):
                    rows.append((k, (i - 1) / (n - 1), (j - 1) / (n - 1), 1))
    return np.array(rows, dtype=float).reshape(-1, 4)


def test_seed_rows_follow_the_rule_and_count_beyond_the_buffer():
    """The seeds of a raster (sign changes and isolated minima, NaN where a condition is
    undefined, nodes not needed) are the rule's, in its order; a buffer too small
    for them holds the first rows and the count is of them all (_seeds_all then
    calls again with room for every row)."""
    rng = np.random.default_rng(11)
    n = 9
    kinds = set()
    for trial in range(12):
        ks = np.array([0, 2, 3], dtype=np.int64)
        x = np.linspace(-1, 1, n)
        cv = np.empty((len(ks), n + 2, n + 2))
        cv[:, 1:-1, 1:-1] = (rng.uniform(-1, 1, (len(ks), 1, 1)) + x[:, None] ** 2
                             + rng.uniform(-0.5, 0.5, (len(ks), 1, 1)) * x[None, :]
                             + rng.normal(0, 0.05, (len(ks), n, n)))
        cv[rng.uniform(size=cv.shape) < 0.03] = np.nan
        cv[0, 1 + rng.integers(n), 1 + rng.integers(n)] = 0.0
        need = np.zeros((n + 2, n + 2), dtype=bool)
        need[1:-1, 1:-1] = rng.uniform(size=(n, n)) < 0.85
        want = _seed_rows_reference(cv, need, ks, n)
        seeds = np.full((len(want) + 4, 4), -7.0)
        count = _trace._seed_rows(cv, need, ks, n, seeds)
        assert count == len(want) and np.array_equal(seeds[:count], want), trial
        assert np.all(seeds[count:] == -7.0)
        small = np.full((max(len(want) // 2, 1), 4), -7.0)
        assert _trace._seed_rows(cv, need, ks, n, small) == len(want)
        assert np.array_equal(small, want[:len(small)]) or len(want) == 0
        kinds |= set(want[:, 3].tolist())
    assert kinds == {0.0, 1.0}  # sign changes and minima both occur in these rasters


def test_applicable_conditions_are_those_of_the_statuses_at_the_probes():
    """The compiled choice of the conditions that can bound a class (_applicable_all, run
    inside a trace) is this plain reading of the model's statuses (its point function,
    through the tracer's classify, compiled already): the branches that apply at the
    slice's centre (and corners, where the velocity is an axis), rest-only conditions
    only at rest, the velocity's condition only on a velocity axis (rest read from the
    model's velocity scale)."""
    from phasemap.core import numerics as nx
    from phasemap.bifurcation import tracing

    for model, axes, fixed in (
            ("hinge_pendulum", {"phi": (-3, 3), "delta": (0.05, 1.4)}, {"omega": 0.0}),
            ("hinge_pendulum", {"phi": (-3, 3), "delta": (0.05, 1.4)}, {"omega": 0.7}),
            ("hinge_pendulum", {"phi": (-3, 3), "omega": (-2, 2)}, {}),
            ("hinge_pendulum", {"phi": (-3, 3), "omega": (0.1, 2)}, {}),
            ("painleve_rod", {"theta": (0.2, 1.5), "f": (0, 3)}, SLIDE_BACK)):
        sl = tracing.make_slice(model, axes, fixed)
        m, conds = sl.model, sl.conds
        on_velocity = m.velocity in axes
        applies = np.zeros(len(m.candidates), dtype=bool)
        out = np.empty((len(m.candidates), m.n_fields))
        v = sl.base.copy()
        probes = [(0.5, 0.5)] + ([(0, 0), (1, 1), (0, 1), (1, 0)] if on_velocity else [])
        for u, w in probes:
            v[sl.slots[0]] = sl.lo[0] + u * (sl.hi[0] - sl.lo[0])
            v[sl.slots[1]] = sl.lo[1] + w * (sl.hi[1] - sl.lo[1])
            _trace.classifier(m)(v, out, 0)  # derive, then point, into out
            applies |= out[:, nx.STATUS] != nx.ABSENT
        names = m.velocity_scale.py_func.__code__.co_varnames
        scale = m.velocity_scale(*(v[m.inputs.index(n)] for n in
                                   names[:m.velocity_scale.py_func.__code__.co_argcount]))
        rest = not on_velocity and abs(sl.fixed[m.velocity]) <= nx.TOL * scale
        index = {b.name: i for i, b in enumerate(m.candidates)}
        want = np.array([(not br or index.get(br, -1) < 0 or applies[index[br]])
                         and (rest or not ro) and (on_velocity or kind != "velocity")
                         for br, ro, kind in zip(conds.branches, conds.rest_only, conds.kinds)])
        active, last = tracing._applicable(sl)
        assert np.array_equal(active, want) and np.array_equal(last, v), (model, axes, fixed)
        assert 0 < active.sum() < len(active)
        # only those conditions' derivatives are compiled (issue 37, speed)
        assert conds.subset == tuple(np.flatnonzero(active)), (model, axes, fixed)


def test_a_slice_compiles_the_derivatives_of_the_conditions_it_can_meet():
    """Issue 37 (speed): a slice's derivative module holds the gradients of the conditions
    that can bound a class in it (a moving slice of the drawer: 11 of 62, compiled in a
    third of the time), bit for bit those of the module of every condition; any other
    condition's gradient and Hessian are NaN, and the values are the model's one module,
    whatever the slice; the trace asks for no other condition."""
    from phasemap.bifurcation import conditions, tracing

    axes = {"phi": (-3, 3), "delta": (0.05, 1.4)}
    sl = tracing.make_slice("hinge_pendulum", axes, {"omega": 0.7})
    m, conds = sl.model, sl.conds
    sub = set(conds.subset)
    assert 0 < len(sub) < len(conds)
    assert conds.values is conditions.values_of(m).values
    assert tracing.make_slice("hinge_pendulum", axes, {"omega": 0.0}).conds.values \
        is conds.values
    whole = conditions.compiled(m, ("phi", "delta"))
    assert whole.subset is None and whole.values is conds.values
    rng = np.random.default_rng(3)
    g, gw, H, Hw = np.empty(2), np.empty(2), np.empty((2, 2)), np.empty((2, 2))
    for _ in range(20):
        v = sl.base.copy()
        v[sl.slots[0]], v[sl.slots[1]] = rng.uniform(-3, 3), rng.uniform(0.05, 1.4)
        for k in range(len(conds)):
            got, want = conds.module.hessian(k, v, g, H), whole.module.hessian(k, v, gw, Hw)
            if k in sub:
                assert np.array_equal(np.array(got + tuple(g) + tuple(H.ravel())),
                                      np.array(want + tuple(gw) + tuple(Hw.ravel())),
                                      equal_nan=True), k
            else:
                assert np.all(np.isnan(got)) and np.all(np.isnan(conds.module.gradient(k, v, g)))
    tr = tracing.trace(sl, "n_solutions", 1e-10)
    assert set(np.flatnonzero(tr.active)) <= sub


def test_class_changes_are_a_plain_scans():
    """Every pair of neighbouring cells with different classes, in scan order, for
    rasters whose rows are not whole words of eight cells, a single row or column,
    and none."""
    rng = np.random.default_rng(5)
    for shape in ((128, 128), (33, 127), (1, 9), (9, 1), (2, 2), (0, 0), (17, 130)):
        for trial in range(4):
            a = (rng.integers(0, 3, size=shape) * (rng.uniform(size=shape) < rng.uniform())
                 ).astype(np.int8)
            n0, n1 = shape
            want = [(i, j, di, dj) for i in range(n0) for j in range(n1)
                    for di, dj in ((1, 0), (0, 1))
                    if i + di < n0 and j + dj < n1 and a[i, j] != a[i + di, j + dj]]
            got = _trace.class_changes(a)
            assert got.dtype == np.int64 and [tuple(r) for r in got] == want, (shape, trial)


def test_full_buffers_are_grown_and_the_trace_is_the_same(monkeypatch):
    """Where the vertex buffers fill, the trace runs again with larger ones: its pieces,
    points and completeness check are those of a trace that never filled them."""
    from phasemap.bifurcation import tracing

    sl = tracing.make_slice("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)},
                            SLIDE_BACK, ROD)
    want = tracing.trace(sl, "n_solutions", 1e-10)
    sizes = tracing._Buffers.__init__.__defaults__
    monkeypatch.setattr(tracing._Buffers.__init__, "__defaults__", (16, 1))
    got = tracing.trace(sl, "n_solutions", 1e-10)
    assert got.buf.verts.shape[0] > 16 and want.buf.verts.shape[0] == sizes[0]
    for field in ("pv", "pp", "pieces", "points_f", "points_i", "classes"):
        assert np.array_equal(getattr(got, field), getattr(want, field)), field


def test_the_check_raster_is_the_grid_evaluators():
    """The 128^2 check raster, from the scene's grid kernel called directly, is what
    phasemap.maps.grid.evaluate makes of the same cells (axes in either order, derived
    inputs on the outer or the inner axis)."""
    from phasemap.bifurcation import tracing
    from phasemap.maps.grid import evaluate
    from phasemap.maps.layers import layers_for

    changing = 0
    for model, axes, fixed, layer in (
            ("hinge_pendulum", {"phi": (-3, 3), "delta": (0.05, 1.4)}, {"omega": 0.0},
             "stagnation"),
            ("hinge_pendulum", {"delta": (0.05, 1.4), "phi": (-3, 3)}, {"omega": 0.0},
             "stagnation"),
            ("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)}, SLIDE_BACK, "n_solutions")):
        sl = tracing.make_slice(model, axes, fixed)
        cells = tracing._cell_centres(sl, 40)
        want = evaluate(sl.model, cells, sl.fixed, [layers_for(sl.model)[layer]])[layer]
        got = tracing._check_raster(sl, layer, cells)
        assert got.dtype == np.int8 and np.array_equal(got, want), (model, layer)
        changing += np.unique(want).size > 1
    assert changing == 3  # the comparison sees class changes, not only uniform rasters

@pytest.mark.parametrize("kw, match", [
    (dict(axes={"theta": (0.2, 1.5)}), "two variables"),
    (dict(axes={"theta": (0.2, 1.5), "f": (3.0, 0.0)}), "lo < hi"),
    (dict(axes={"theta": (0.2, 1.5), "nope": (0, 1)}), "unknown variable 'nope'"),
    (dict(axes={"theta": (0.2, 1.5), "f": (0, 3)}, fixed={"f": 1.0}), "both an axis and fixed"),
    (dict(axes={"theta": (0.2, 1.5), "f": (0, 3)}, layer="singular"), "layer must be"),
    (dict(axes={"theta": (0.2, 1.5), "f": (0, 3)}, tol=0.0), "tol must be"),
    (dict(axes={"theta": (0.2, 1.5), "f": (-1, 3)}), "outside its domain"),
])
def test_bad_input(kw, match):
    with pytest.raises(ValueError, match=match):
        boundaries("painleve_rod", **{"fixed": SLIDE_BACK, "conditions": ROD, **kw})


# -- thresholds ---------------------------------------------------------------------------

def test_threshold_first_paradox():
    t = threshold("painleve_rod", "f", value=0, over={"theta": (0.1, 1.5), "f": (0, 3)},
                  fixed=SLIDE_BACK, conditions=ROD)
    assert abs(t.value - 4 / 3) <= 1e-10 and abs(t.at["theta"] - math.atan(2)) <= 1e-10
    assert t.kind == "fold_f" and t.condition == "coef_A_slip_neg" and t.residual <= 1e-12
    # the raster's best cell bounds it from above, within a cell
    assert t.value <= t.bound <= t.value + 3.0 / 128 * 1.5


def test_threshold_on_a_line_and_an_empty_region():
    t = threshold("painleve_rod", "f", value=0, over={"f": (0, 3)},
                  fixed={**SLIDE_BACK, "theta": math.atan(2)}, conditions=ROD)
    assert abs(t.value - 4 / 3) <= 1e-10 and t.kind == "root"
    # sliding the other way the coefficient stays positive: no paradox in these ranges
    assert threshold("painleve_rod", "f", value=0, over={"theta": (0.1, 1.5), "f": (0, 3)},
                     fixed={"xdot": 1.0, "omega": 0.0}, conditions=ROD) is None


def test_threshold_of_the_singular_set_and_a_supremum():
    t = threshold("painleve_rod", "f", layer="singular", value=1,
                  over={"theta": (0.1, 1.5), "f": (0, 3)}, fixed=SLIDE_BACK, conditions=ROD)
    assert abs(t.value - 4 / 3) <= 1e-10 and t.kind == "fold_f"
    # the unique region reaches up to the edge f = 3
    t = threshold("painleve_rod", "f", value=1, side="max",
                  over={"theta": (0.1, 1.5), "f": (0, 3)}, fixed=SLIDE_BACK, conditions=ROD)
    assert t.value == 3.0 and t.kind == "edge"


@pytest.mark.parametrize("kw, match", [
    (dict(param="nope"), "unknown variable"),
    (dict(layer="fate"), "layer must be"),
    (dict(value=7), "flag values"),
    (dict(side="least"), "side must be"),
    (dict(over={"theta": (1, 0)}), "lo < hi"),
    (dict(fixed={"f": 1.0}), "cannot be fixed"),
])
def test_threshold_bad_input(kw, match):
    args = {"param": "f", "value": 0, "over": {"theta": (0.1, 1.5)}, "fixed": SLIDE_BACK,
            "conditions": ROD, **kw}
    with pytest.raises(ValueError, match=match):
        threshold("painleve_rod", **args)


def test_map_figure_draws_the_exact_boundary():
    """ds.phasemap.plot(boundaries=True): the map's slice traced, its piece drawn as a
    curve on the rod's coefficient (not the raster's stair)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ds = phasemap.Scene("painleve_rod", axes={"theta": np.linspace(0.2, 1.5, 24),
                                              "f": np.linspace(0.0, 3.0, 24)},
                        fixed=SLIDE_BACK, layers=["n_solutions"]).compute()
    fig = ds.phasemap.plot(x="theta", boundaries=True)
    try:
        curves = [ln for ln in fig.axes[0].lines if len(ln.get_xdata()) > 20]
        assert len(curves) == 1
        th, f = (np.asarray(a, float) for a in curves[0].get_data())
        c, s = np.cos(th), np.sin(th)
        assert np.max(np.abs(1 / 3 + c**2 - f * s * c) / (4 / 3 + f)) <= 1e-12
    finally:
        plt.close(fig)


def test_the_generated_hessian_is_the_exact_one_to_differencing_accuracy():
    """The conditions module's hessian (forward differences of the exact gradient) against
    sympy's exact Hessian, at random points of the rod's conditions and of one with a
    domain edge (sqrt(3 - f): its forward point is NaN within a step of f = 3, where the
    difference goes backward and is finite, with the exact one's signs, though not
    accurate: the curvature there changes on the scale of the step); its value and
    gradient are the exact ones, and the input vector comes back bit for bit."""
    from phasemap.bifurcation.conditions import compiled

    m = phasemap.get_model("painleve_rod")
    edge = Condition("edge", "", "domain", sp.sqrt(3 - F) * sp.sin(TH) ** 2, 1)
    conds = ROD + [edge]
    C = compiled(m, ("theta", "f"), conds)
    rng = np.random.default_rng(11)
    names = {"theta": TH, "f": F, "omega": OM, "l": L, "g": G, "m": M}
    for k, name in enumerate(C.names):
        if name == m.velocity:
            continue
        expr = next(c.expr for c in conds if c.name == name)
        grad = [sp.diff(expr, TH), sp.diff(expr, F)]
        hess = sp.hessian(expr, (TH, F))
        for i in range(20):
            point = dict(theta=rng.uniform(0.05, 1.5), omega=rng.uniform(-3, 3),
                         f=rng.uniform(0, 3), l=rng.uniform(0.5, 2), g=9.81, m=1.0)
            if name == "edge" and i == 0:
                point["f"] = 3.0 - 1e-9  # the forward point leaves the domain
            v = m.input_vector({**point, "xdot": -1.0})
            before = v.copy()
            g, H = np.empty(2), np.empty((2, 2))
            c, s = C.module.hessian(k, v, g, H)
            assert np.array_equal(v, before)
            subs = {names[n]: point[n] for n in names}
            assert c == pytest.approx(float(expr.subs(subs)), rel=1e-13, abs=1e-13)
            assert g == pytest.approx([float(d.subs(subs)) for d in grad], rel=1e-12, abs=1e-12)
            want = np.array(hess.subs(subs), dtype=float)
            size = np.abs(want).max() + np.abs(g).max() + abs(c)
            assert np.all(np.isfinite(H)), (name, point)
            if name == "edge" and i == 0:
                assert np.array_equal(np.sign(H), np.sign(want)), (H, want)
                continue
            assert np.abs(H - want).max() <= 1e-6 * size, (name, point, H, want)


# -- the tracer's interpreter tier (issue 40) ----------------------------------------------

def same_result(got, want) -> None:
    """Two results of boundaries (or threshold's Datasets) alike: every variable and
    coordinate bit for bit (NaNs alike), every attribute but the time stamps."""
    assert set(got.variables) == set(want.variables)
    for name in want.variables:
        a, b = want[name].values, got[name].values
        assert a.dtype == b.dtype and a.shape == b.shape, name
        if a.dtype.kind == "f":
            assert np.array_equal(a, b, equal_nan=True), name
            assert np.array_equal(np.signbit(a), np.signbit(b)), name   # -0.0 apart
        else:
            assert np.array_equal(a, b), name
    stamps = {"history", "date_created"}
    assert {k: v for k, v in got.attrs.items() if k not in stamps} == \
        {k: v for k, v in want.attrs.items() if k not in stamps}


def in_both_tiers(call):
    """``call()`` on the tracer's machine code, then on its interpreted twins (what a first
    ``boundaries`` runs while numba compiles the tracer in the background)."""
    with tiers.forced("eager"):
        want = call()
    with tiers.forced("off"):
        run = _trace.runs()
        assert all(tiers.is_twin(f) for f in run.values()), run
        got = call()
    return got, want


@pytest.mark.parametrize("case", ["rod fold", "rod crossings", "contact lost", "loop at the edges",
                                  "unexplained"])
def test_the_tracers_twin_traces_bit_for_bit(case, block):
    """The twins of the tracer's entry points trace every slice as its machine code does:
    the rod's fold and its singular crossings (velocity an axis), a closed loop, a loop
    that the slice's edges cut, and a trace with unexplained class changes kept."""
    model, conds = block
    calls = {
        "rod fold": lambda: boundaries("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)},
                                       fixed=SLIDE_BACK),
        "rod crossings": lambda: boundaries("painleve_rod", {"theta": (0.1, 1.5),
                                                             "omega": (-5.0, 5.0)},
                                            fixed={"xdot": -1.0, "f": 2.0}),
        "contact lost": lambda: boundaries(model, {"theta": (-2, 2), "omega": (-2, 2)},
                                           fixed={"xdot": 1.0}, layer="contact_lost",
                                           conditions=conds),
        "loop at the edges": lambda: boundaries(model, {"theta": (-2, 2), "omega": (-1, 1)},
                                                fixed={"xdot": 1.0}, layer="contact_lost",
                                                conditions=conds),
        "unexplained": lambda: boundaries("painleve_rod", {"theta": (0.2, 1.5),
                                                           "f": (0.0, 3.0)},
                                          fixed=SLIDE_BACK,
                                          conditions=rod_conditions(coefficient=False),
                                          strict=False),
    }
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # (the unexplained changes' warning, in both)
        got, want = in_both_tiers(calls[case])
    same_result(got, want)
    if case == "unexplained":   # no piece: the coefficient's is unexplained, as data
        assert got.sizes["unexplained"] > 10
    else:
        assert got.sizes["piece"] >= 1


def test_the_tracers_twin_finds_thresholds_and_grows_its_buffers_alike(monkeypatch):
    """A threshold (traced, then refined by Newton's method) and a trace whose vertex
    buffers fill (run again with larger ones: ``assemble``, ``uncovered`` and ``mark``
    called from Python between the entry points) in both tiers."""
    from phasemap.bifurcation import tracing

    got, want = in_both_tiers(lambda: threshold(
        "painleve_rod", "f", value=0, over={"theta": (0.1, 1.5), "f": (0, 3)},
        fixed=SLIDE_BACK, conditions=ROD))
    assert (got.value, got.at, got.kind, got.residual) == (want.value, want.at, want.kind,
                                                           want.residual)
    assert abs(got.value - 4 / 3) <= 1e-10
    # on a line (no trace: Newton on the conditions, their twins called from Python) and
    # along a further parameter
    for call in (lambda: threshold("painleve_rod", "f", value=0, over={"f": (0, 3)},
                                   fixed={**SLIDE_BACK, "theta": math.atan(2)},
                                   conditions=ROD),
                 lambda: threshold("painleve_rod", "f", value=0, over={"theta": (0.1, 1.5),
                                                                       "f": (0, 3)},
                                   fixed=SLIDE_BACK, along={"l": (0.5, 0.6)})):
        got, want = in_both_tiers(call)
        if isinstance(want, xr.Dataset):
            same_result(got, want)
        else:
            assert (got.value, got.at, got.kind, got.residual) == (
                want.value, want.at, want.kind, want.residual)
    sl = tracing.make_slice("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)},
                            SLIDE_BACK, ROD)
    monkeypatch.setattr(tracing._Buffers.__init__, "__defaults__", (16, 1))
    got, want = in_both_tiers(lambda: tracing.trace(sl, "n_solutions", 1e-10))
    assert got.buf.verts.shape[0] > 16
    for field in ("pv", "pp", "pq", "pieces", "points_f", "points_i", "classes", "group",
                  "active", "unresolved"):
        a, b = getattr(want, field), getattr(got, field)
        assert type(a) is type(b) and a.dtype == b.dtype, field   # plain arrays, not records
        assert np.array_equal(a, b), field


def test_a_process_traces_on_the_twins_under_off_and_loads_the_tracer_where_it_is_built():
    """Fresh processes on the suite's caches, where this one has compiled the tracer
    (into the kernel cache, as a background compile does). Under ``PHASEMAP_JIT=off``:
    the boundaries of the rod's first paradox with none of the tracer's functions compiled
    or loaded (the rod's own functions are: the twins call them at their addresses).
    Under ``background``: the tracer's machine code loaded from the cache, nothing compiled
    and no background compile started (the cache once looked for it under another key than
    the one it was saved under, and every later process traced on the twins, starting
    another compile).  The fold at f = 4/3 in both."""
    import json
    import os
    import subprocess
    import sys
    import textwrap

    with tiers.forced("eager"):
        _trace.runs()   # compiled (or loaded), and saved in the suite's cache
        boundaries("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)}, fixed=SLIDE_BACK)
    code = textwrap.dedent("""
        import json, numba
        import phasemap
        from phasemap.bifurcation import _trace
        from phasemap.core import tiers
        b = phasemap.boundaries("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)},
                                fixed={"xdot": -1.0, "omega": 0.0})
        tracer = [k for k, v in vars(_trace).items()
                  if isinstance(v, numba.core.dispatcher.Dispatcher) and v.signatures
                  and k not in ("_no_gradient", "_no_hessian")]
        fold = b.point_f.values[b.point_kind.values == "fold_f"]
        from phasemap.bifurcation import tracing
        sl = tracing.make_slice("painleve_rod", {"theta": (0.2, 1.5), "f": (0.0, 3.0)},
                                {"xdot": -1.0, "omega": 0.0})
        own = [bool(f.signatures) for f in (sl.conds.values, sl.conds.module.gradient,
                                            sl.conds.module.hessian,
                                            _trace.classifier(sl.model))]
        print(json.dumps({"tracer": tracer, "fold": fold.tolist(), "jobs": len(tiers._JOBS),
                          "own": own, "handles": [a < 0 for a in sl.fns],
                          "pieces": int(b.sizes["piece"]), "machine": bool(_trace._ENTRIES),
                          "compiled": [k for k, v in vars(_trace).items()
                                       if isinstance(v, numba.core.dispatcher.Dispatcher)
                                       and sum(v._cache_misses.values())]}))
    """)
    got = {}
    for how in ("off", "background"):
        env = dict(os.environ, PHASEMAP_JIT=how)   # the suite's caches
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, timeout=600, check=True)
        got[how] = json.loads(out.stdout.strip().splitlines()[-1])
        assert got[how]["pieces"] >= 1 and len(got[how]["fold"]) == 1, how
        assert abs(got[how]["fold"][0] - 4 / 3) <= 1e-10, how
    assert got["off"]["tracer"] == [] and not got["off"]["machine"]
    # nor the rod's conditions and class function: the twins' handles stand for them
    assert got["off"]["own"] == [False] * 4 and got["off"]["handles"] == [True] * 4
    assert got["background"]["machine"] and got["background"]["jobs"] == 0
    assert got["background"]["own"] == [True] * 4 and not any(got["background"]["handles"])
    assert "_trace_all" in got["background"]["tracer"] and got["background"]["compiled"] == []


def test_a_class_change_on_a_line_where_other_conditions_vanish_too_is_their_crossing():
    """The rod on a step at rest over (f, theta): on the gap line theta = arctan(4/3) two
    family conditions vanish too, all along it, and the class on the line's sides changes
    where a third crosses it, at f = 4/3.  The tracer once took one of the two that lie
    on the line as the change's explanation, could not solve for their 'crossing' (the
    same line) and left a point of kind 'change' at f = 1.3333322, 1e-6 off, with no
    residual.  (On the twins, which trace as the machine code does bit for bit, above:
    the rod on a step's conditions are not compiled for one test.)"""
    with tiers.forced("off"):
        b = boundaries("rod_on_step", {"f": (0.0, 2.0), "theta": (0.45, 1.55)},
                       fixed={"omega": 0.0})
    kinds = [str(k) for k in b.point_kind.values]
    assert "change" not in kinds and np.all(np.isfinite(b.point_residual.values))
    line = math.atan(4.0 / 3.0)
    gap = [p for p in range(b.sizes["piece"]) if str(b.condition.values[p]).startswith("gap_")]
    assert gap
    f = np.concatenate([b.f.values[b.piece.values == p] for p in gap])
    theta = np.concatenate([b.theta.values[b.piece.values == p] for p in gap])
    assert np.max(np.abs(theta - line)) <= 1e-12
    assert abs(f.min() - 4.0 / 3.0) <= 1e-10 and f.max() == 2.0
    cross = [(float(b.point_f[i]), float(b.point_theta[i])) for i in range(b.sizes["point"])
             if kinds[i] == "crossing"]
    assert any(abs(x - 4.0 / 3.0) <= 1e-10 and abs(y - line) <= 1e-12 for x, y in cross)
