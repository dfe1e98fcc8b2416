"""Two systems phasemap never saw, with two rough one-sided contacts (issue 37): a drawer
tilted in a slot, jammed by its wedge, and a rod against a wall lying on a peg
(tests/unseen.py).  Each against the full-coordinate enumeration of tests/oracles.py,
and the bifurcation tracer on them.

The drawer at rest with both corners sticking is statically indeterminate: the guides
can squeeze it along the line through its two corners, r = R(psi) (a, c), with no
load at all.  That squeeze holds in both friction cones exactly where
f >= f_w = (a cos psi - c sin psi) / (a sin psi + c cos psi) (the line's slope to the
guides' normal), and then any load is held by squeezing hard enough.  Below f_w the
squeeze is bounded above; where the member without squeeze already pulls a corner out of
its cone, the drawer slips for every f < f_w: its stagnation begins at f = f_w, a line
on which no pair of the family's bounds meets (one bound runs off to infinity).
"""

from __future__ import annotations

import numpy as np
import pytest

import phasemap
from phasemap.core import numerics as nx
from phasemap.core import tiers

import oracles
import unseen

#: the drawer's default geometry (tests/unseen.py)
A, C, PSI = 0.5, 0.25, 0.3
F_W = oracles.drawer_wedge(A, C, PSI)


@pytest.fixture(scope="module")
def drawer():
    return unseen.drawer().model


@pytest.fixture(scope="module")
def peg_rod():
    return unseen.peg_rod().model


def _drawer_states(rng, n):
    for i in range(n):
        yield dict(xdot=0.0 if i % 2 else float(rng.uniform(-2, 2)), f=rng.uniform(0, 2),
                   a=rng.uniform(0.2, 1), c=rng.uniform(0.1, 0.5), psi=rng.uniform(0.05, 1.1),
                   d=rng.uniform(-1, 1), p=rng.uniform(0, 20), g=rng.uniform(0, 15), m=1.0)


def _peg_states(rng, n):
    for i in range(n):
        th = rng.uniform(0.02, 0.98)
        yield dict(theta=th, omega=0.0 if i % 2 else float(rng.uniform(-3, 3)),
                   f=rng.uniform(0, 2), l=1.0, p=rng.uniform(0.1, 1.9) * np.cos(th), g=9.81,
                   m=1.0)


def _oracle(name, v):
    if name == "drawer":
        return oracles.drawer(v["xdot"], v["f"], v["a"], v["c"], v["psi"], v["d"], v["p"],
                              v["g"], v["m"])
    return oracles.peg_rod(v["theta"], v["omega"], v["f"], v["l"], v["p"], v["g"], v["m"])


@pytest.mark.parametrize("name", ["drawer", "peg_rod"])
def test_random_states_agree_with_the_enumeration(name, request):
    """500 random states each (half at rest): n_solutions and stagnation are the
    full-coordinate enumeration's."""
    m = request.getfixturevalue(name)
    rng = np.random.default_rng(37)
    states = (_drawer_states if name == "drawer" else _peg_states)(rng, 500)
    wrong, n = [], 0
    for v in states:
        want = _oracle(name, v)
        if want.margin < 1e-6:
            continue
        got = phasemap.classify(m, **v)
        n += 1
        if (int(got.n_solutions), bool(got.stagnation)) != (want.n_solutions, want.stagnation):
            wrong.append(v)
    assert n > 450 and not wrong, wrong[:3]


def test_the_wedge_line_from_the_enumeration():
    """The closed form f_w, checked on the independent enumeration: at rest, pushed at
    d = 0.6, the drawer sticks just above f_w and not just below, whatever the load
    (gravity and push scaled together, the squeeze with them)."""
    for scale in (0.1, 1.0, 30.0):
        for f, sticks in ((F_W * (1 - 1e-9), False), (F_W * (1 + 1e-9), True)):
            got = oracles.drawer(0.0, f, A, C, PSI, 0.6, 10.0 * scale, 9.81 * scale, 1.0)
            assert got.stagnation == sticks, (scale, f)


def test_the_drawers_conditions_decide_its_branches(drawer):
    """The conditions' contract (phasemap.declare.admissibility) on the drawer, whose stick
    row is a family: wherever a branch applies it is admissible exactly where all its
    conditions hold; the wedge line is among them, as the slope of each cone's bound."""
    from phasemap.declare import conditions

    conds = conditions(drawer)
    names = {c.name for c in conds}
    assert {"slope_limit_pos_upper_stick", "slope_limit_pos_lower_stick"} <= names
    rng = np.random.default_rng(3)
    states = list(_drawer_states(rng, 600))
    cols = {k: np.array([s[k] for s in states]) for k in states[0]}
    rest = cols["xdot"] == 0.0
    held = {c.name: c.holds(cols, rest) for c in conds}
    out = np.full((len(drawer.branches), drawer.n_fields), np.nan)
    seen = {True: 0, False: 0}
    for i, s in enumerate(states):
        v = drawer.input_vector(s)
        drawer.derive(v)
        drawer.point(v, out)
        for b, branch in enumerate(drawer.branches):
            if out[b, nx.STATUS] == nx.ABSENT:
                continue
            ok = out[b, nx.STATUS] in (nx.ADMISSIBLE, nx.SEPARATION)
            assert ok == all(held[c.name][i] for c in conds if c.branch == branch), (branch, s)
            seen[ok] += 1
    assert seen[True] > 300 and seen[False] > 300


def test_the_drawers_boundaries_hold_its_wedge_line(drawer):
    """boundaries over (d, f) at rest explains every class change of its check raster
    (it raised before the slopes were conditions), and its stagnation starts on f = f_w
    for the handle low enough (d > 0.1447...) to 1e-12."""
    b = phasemap.boundaries(drawer, {"d": (-1.0, 1.0), "f": (0.0, 2.0)}, fixed={"xdot": 0.0},
                            layer="stagnation")
    wedge = [p for p in range(b.sizes["piece"]) if "slope_" in str(b.condition.values[p])]
    assert len(wedge) == 1
    sel = b.piece.values == wedge[0]
    assert np.max(np.abs(b.f.values[sel] - F_W)) <= 1e-12
    assert b.d.values[sel].max() == 1.0 and b.d.values[sel].min() < 0.2
    _sides_agree(b, "d", (-1.0, 1.0), (0.0, 2.0), lambda d, f: oracles.drawer(
        0.0, f, A, C, PSI, d, 10.0, 9.81, 1.0).stagnation)
    assert np.all(b.point_residual.values <= 1e-10)


@pytest.mark.parametrize("d", [0.3, 0.9])
def test_the_drawers_threshold_is_the_wedge(drawer, d):
    """Where the handle is low, the least f at which the drawer can stay is f_w: on the
    line of f (it raised before, "class changes not explained" on a slice), and over a
    slice in d."""
    line = phasemap.threshold(drawer, "f", layer="stagnation", value=1, over={"f": (0.0, 2.0)},
                              fixed={"xdot": 0.0, "d": d})
    assert abs(line.value - F_W) <= 1e-12 and line.residual <= 1e-10
    plane = phasemap.threshold(drawer, "f", layer="stagnation", value=1,
                               over={"f": (0.0, 2.0), "d": (d - 0.1, d + 0.1)},
                               fixed={"xdot": 0.0})
    assert abs(plane.value - F_W) <= 1e-12 and plane.residual <= 1e-10


def _oracle_stagnation_edge(d: float, lo: float, hi: float) -> float:
    """The least f at which the drawer can stay, by bisection on the enumeration."""
    def stays(f):
        return oracles.drawer(0.0, f, A, C, PSI, d, 10.0, 9.81, 1.0).stagnation

    assert not stays(lo) and stays(hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if stays(mid) else (mid, hi)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("d, bracket", [(0.0, (0.8, 0.9)), (0.001, (0.8, 0.9)),
                                        (0.1, (0.95, 0.98))])
def test_the_drawers_line_threshold_where_its_edge_is_curved(drawer, d, bracket):
    """With the handle high the stagnation edge lies below f_w, near other conditions'
    roots: on a wide line of f (issue 37 item 6's d = 0 and 0.001) the threshold is the
    enumeration's edge.  At d = 0.1 a family bound's root 2.2e-3 below the edge was once
    taken for it (the class check either side of a root stepped as far as half a
    sample)."""
    t = phasemap.threshold(drawer, "f", layer="stagnation", value=1, over={"f": (0.0, 30.0)},
                           fixed={"xdot": 0.0, "d": d})
    assert abs(t.value - _oracle_stagnation_edge(d, *bracket)) <= 1e-7
    assert t.residual <= 1e-10


def test_the_peg_rods_boundaries(peg_rod):
    """The rod on a wall and a peg at rest, over (theta, f): every class change explained,
    and the peg rod's static zone bounded by its family's pairs."""
    b = phasemap.boundaries(peg_rod, {"theta": (0.1, 0.9), "f": (0.0, 2.0)},
                            fixed={"omega": 0.0})
    assert b.sizes["piece"] >= 1 and np.all(b.point_residual.values <= 1e-10)
    _sides_agree(b, "theta", (0.1, 0.9), (0.0, 2.0), lambda th, f: oracles.peg_rod(
        th, 0.0, f, 1.0, 0.8, 9.81, 1.0).n_solutions)


def _sides_agree(b, x, xr, fr, oracle):
    """Every piece's side classes in the slice (x, f), against the enumeration ``oracle(x,
    f)`` just beside the piece's middle vertex (1e-6 of the slice along its left normal)."""
    u, w = (b[x].values - xr[0]) / (xr[1] - xr[0]), (b.f.values - fr[0]) / (fr[1] - fr[0])
    for p in range(b.sizes["piece"]):
        sel = np.flatnonzero(b.piece.values == p)
        q = sel[len(sel) // 2]
        du, dw = u[q + 1] - u[q - 1], w[q + 1] - w[q - 1]
        nu, nw = -dw / np.hypot(du, dw) * 1e-6, du / np.hypot(du, dw) * 1e-6  # left normal
        for sign, want in ((1, b.class_left.values[p]), (-1, b.class_right.values[p])):
            at = (xr[0] + (xr[1] - xr[0]) * (u[q] + sign * nu),
                  fr[0] + (fr[1] - fr[0]) * (w[q] + sign * nw))
            assert oracle(*at) == want, (p, sign, at)


def random_step_rod(seed: int):
    """A rod with its end A on a rough floor, lying across a rough step's edge (a
    PointContact and an EdgeContact), of random structure: where its centre of mass
    sits, its radius of gyration, a constant push along the floor at the centre; the
    step's height, the rod's angular velocity for the slice."""
    import sympy as sp

    from phasemap.declare import (Body, Coordinate, EdgeContact, Parameter, PointContact, Rate,
                                  System)

    rng = np.random.default_rng(seed)
    a = sp.Rational(int(rng.integers(30, 170)), 100)        # centre from A (rod length 2)
    k2 = sp.Rational(int(rng.integers(10, 100)), 100)       # radius of gyration squared
    push = sp.Rational(int(rng.integers(-50, 50)), 100)     # in m g
    f = Parameter("f", "1", "friction coefficient", 0.5, 0.0)
    h = Parameter("h", "m", "height of the step", 0.8, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    th = Coordinate("theta", "rad", "angle to the floor", 1.0, 0.0, float(sp.pi) / 2,
                    lower_open=True, rate=Rate("omega", "rad s-1", "angular velocity",
                                               scale=sp.sqrt(g)))
    xa, ya = Coordinate("xa", "m", "end A along the floor"), Coordinate("ya", "m", "height of A")
    system = System(f"random_step_rod_{seed}", "a random rod on a step", "test",
                    coordinates=(th, xa, ya), parameters=(f, h, g, m),
                    bodies=(Body(m, (xa + a * sp.cos(th), ya + a * sp.sin(th)),
                                 inertia=m * k2, angle=th),),
                    potential=m * g * (ya + a * sp.sin(th)),
                    forces={xa: push * m * g, th: -push * m * g * a * sp.sin(th)},
                    contacts=(PointContact("floor", (xa, ya), normal=(0, 1), friction=f),
                              EdgeContact("edge", (xa, ya), corner=(0, h), angle=th, friction=f,
                                          extent=(0, 2))))
    values = {"h": float(rng.uniform(0.3, 1.2)), "omega": float(rng.choice([0.0, -1.0, 1.0])),
              "a": float(a), "k": float(sp.sqrt(k2)), "push": float(push) * 9.81}
    return system.model, values


# each random declaration derives with sympy for seconds and compiles nothing here
@pytest.mark.slow
@pytest.mark.parametrize("seed", [2])
def test_random_step_rods_cell_by_cell(seed):
    """A random two-contact declaration: a 24^2 raster over (theta, f) cell by cell
    against the full-coordinate enumeration, through the generated functions' interpreted
    twins (the same bits as their machine code, tests/test_tiers.py; compiling them for
    this one declaration cost 30-40 s).  Its boundaries on that slice cost 70-140 s of
    the tracer's compile: the drawer and the peg rod trace theirs in every run, the random
    barrow its own under ``-m deep``."""
    model, v = random_step_rod(seed)
    lo = float(np.arcsin(v["h"] / 2)) + 0.02       # the edge on the rod: h / sin theta <= 2
    ths = np.linspace(lo, 1.5, 24)
    fs = np.linspace(0.0, 2.0, 24)
    wrong, n = [], 0
    with tiers.forced("off"):
        for th in ths:
            for f in fs:
                want = oracles.rod_on_step(th, v["omega"], f, 1.0, v["h"], 9.81, 1.0,
                                           a=v["a"], k=v["k"], push=v["push"])
                if want.margin < 1e-6:
                    continue
                got = phasemap.classify(model, theta=th, omega=v["omega"], f=f, h=v["h"])
                n += 1
                if (int(got.n_solutions), bool(got.stagnation)) != (want.n_solutions,
                                                                     want.stagnation):
                    wrong.append((th, f))
    assert n > 500 and not wrong, wrong[:3]


def test_the_peg_rods_boundaries_across_omega_zero(peg_rod):
    """Over (theta, omega) through omega = 0 with f = 1.5: no solution pushed one way,
    one the other, the rest classes on the line.  The wall's reaction where the peg lets
    go is a multiple of omega^2: it vanishes on omega = 0 with every term, and the
    velocity's curve used to yield it the line (which it cannot trace), so boundaries
    raised on every such slice."""
    b = phasemap.boundaries(peg_rod, {"theta": (0.1, 0.9), "omega": (-1.0, 1.0)},
                            fixed={"f": 1.5})
    on = [p for p in range(b.sizes["piece"]) if b.condition.values[p] == "omega"]
    assert on and all(np.all(b.omega.values[b.piece.values == p] == 0.0) for p in on)
    for p in on:
        sel = np.flatnonzero(b.piece.values == p)
        th = b.theta.values[sel[len(sel) // 2]]
        up = b.theta.values[sel[-1]] > b.theta.values[sel[0]]
        # the left normal of a piece running up in theta points to omega > 0
        left, right = (1e-7, -1e-7) if up else (-1e-7, 1e-7)
        assert oracles.peg_rod(th, left, 1.5, 1.0, 0.8, 9.81, 1.0).n_solutions \
            == b.class_left.values[p]
        assert oracles.peg_rod(th, right, 1.5, 1.0, 0.8, 9.81, 1.0).n_solutions \
            == b.class_right.values[p]


def _barrow(seed):
    """A random barrow (tests/unseen.py: a wheel rolling with rolling friction, its handles
    sliding on the floor, of random mass distribution, length and motor torque), its
    slice's angle phi, and the generalised-coordinate enumeration over (omega, f) there
    (tests/oracles.py)."""
    system, st = unseen.barrow(seed)
    phi = float(np.random.default_rng(seed).uniform(-np.pi, np.pi))
    tau = st["tau"] * 9.81

    def oracle(omega, f):
        return oracles.barrow(phi, omega, f, 0.05, 1.0, 9.81, 1.0, st["lw"], st["k"], st["mu"],
                              st["L"], tau)

    return system.model, phi, oracle


@pytest.mark.parametrize("seed", [1])
def test_random_barrows_cell_by_cell(seed):
    """A random two-contact declaration with a rolling contact: a raster over (omega, f)
    through omega = 0, cell by cell against the enumeration.  The slice holds no solution
    (the Painleve paradox where the handles are pushed ahead: omega < 0, f large), the
    wheel lifting off, rolling either way, and the statically indeterminate rest (five
    reactions, four equations).  The declaration's generated functions answer through
    their interpreted twins (``PHASEMAP_JIT=off``: the same bits as their machine code,
    tests/test_tiers.py), so this costs sympy's derivation and no compilation."""
    model, phi, oracle = _barrow(seed)
    wrong, n, seen = [], 0, set()
    with tiers.forced("off"):
        for omega in np.linspace(-2.0, 2.0, 21):
            for f in np.linspace(0.0, 6.0, 25):
                want = oracle(omega, f)
                if want.margin < 1e-6:
                    continue
                got = phasemap.classify(model, phi=phi, omega=omega, f=f)
                n += 1
                seen.add((want.n_solutions, want.stagnation))
                if (int(got.n_solutions), bool(got.stagnation)) != (want.n_solutions,
                                                                     want.stagnation):
                    wrong.append((omega, f))
    assert n > 400 and not wrong, wrong[:3]
    assert len(seen) >= 3, seen          # the slice holds several classes


@pytest.mark.deep
@pytest.mark.kernels_with("tests/test_two_contacts.py::barrow")
@pytest.mark.parametrize("seed", [1, 4])
def test_random_barrows_boundaries(seed):
    """The boundaries of the random barrow's slice: every class change of the check raster
    explained (or boundaries raises), and each piece's side classes against the
    enumeration.  ``deep``: a random declaration's tracer compiles for 2-5 min on a fresh
    clone (155 s of CPU at the suite's -O1, 185 s at numba's default), which CI's time
    cannot hold with the rest; the drawer's and the peg rod's boundaries above are traced
    in every run, and tests/test_boundaries_random.py traces random one-contact rods."""
    model, phi, oracle = _barrow(seed)
    b = phasemap.boundaries(model, {"omega": (-2.0, 2.0), "f": (0.0, 6.0)}, fixed={"phi": phi})
    assert b.sizes["piece"] >= 2 and np.all(b.point_residual.values <= 1e-10)
    _sides_agree(b, "omega", (-2.0, 2.0), (0.0, 6.0), lambda om, f: oracle(om, f).n_solutions)


@pytest.mark.parametrize("which", ["drawer", "peg rod"])
def test_two_contacts_trace_alike_on_the_tracers_twin(which, request):
    """The tracer's interpreted twins (a first ``boundaries`` while numba compiles the
    tracer) on the two-contact slices above: the same pieces, points and classes, bit
    for bit, as its machine code."""
    from phasemap.bifurcation import _trace

    model = request.getfixturevalue("drawer" if which == "drawer" else "peg_rod")
    axes, fixed = (({"d": (-1.0, 1.0), "f": (0.0, 2.0)}, {"xdot": 0.0}) if which == "drawer"
                   else ({"theta": (0.1, 0.9), "f": (0.0, 2.0)}, {"omega": 0.0}))
    layer = "stagnation" if which == "drawer" else "n_solutions"
    with tiers.forced("eager"):
        want = phasemap.boundaries(model, axes, fixed=fixed, layer=layer)
    with tiers.forced("off"):
        assert all(tiers.is_twin(f) for f in _trace.runs().values())
        got = phasemap.boundaries(model, axes, fixed=fixed, layer=layer)
    assert got.sizes["piece"] >= 1
    for name in want.variables:
        a, b = want[name].values, got[name].values
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name
        if a.dtype.kind == "f":
            assert np.array_equal(np.signbit(a), np.signbit(b)), name


def test_the_drawers_line_threshold_alike_on_the_twins(drawer):
    """A threshold on a line runs Newton on the conditions from Python: on their
    interpreted twins (while numba compiles the 62 conditions' gradients, 14 s) it finds
    the wedge's f_w with the same bits as on their machine code."""
    def call():
        return phasemap.threshold(drawer, "f", layer="stagnation", value=1,
                                  over={"f": (0.0, 2.0)}, fixed={"xdot": 0.0, "d": 0.3})

    with tiers.forced("eager"):
        want = call()
    with tiers.forced("off"):
        got = call()
    assert (got.value, got.at, got.kind, got.condition, got.residual) == (
        want.value, want.at, want.kind, want.condition, want.residual)
    assert abs(got.value - F_W) <= 1e-12
