"""Random declared systems: the traced pieces are the raster's class changes.

Each system is a rod with one end on a rough floor, declared with the public API
with random structure (where its centre of mass sits, its radius of gyration, a
constant push along the floor), sliding back at a random angular velocity.  Independently of the
tracer's own completeness check, every class change of a 64^2 raster of the
same kernels must lie within about a cell of a traced piece, and the classes the
pieces carry on their two sides must be what ``classify`` finds just beside them.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import phasemap
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

CELLS = 64


def random_rod(seed: int):
    rng = np.random.default_rng(seed)
    a = sp.Rational(int(rng.integers(50, 150)), 100)      # centre of mass from the end
    k2 = sp.Rational(int(rng.integers(5, 100)), 100) * a**2  # radius of gyration squared
    push = sp.Rational(int(rng.integers(-50, 50)), 100)   # a constant push, in m g
    f = Parameter("f", "1", "friction coefficient", default=0.5, lower=0.0)
    g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
    m = Parameter("m", "kg", "mass", default=1.0, lower=0.0, lower_open=True)
    theta = Coordinate("theta", "rad", "angle to the floor", default=1.0, lower=0.0,
                       upper=float(sp.pi), rate=Rate("omega", "rad s-1", "angular velocity",
                                                     scale=sp.sqrt(g)))
    x = Coordinate("x", "m", "position of the end",
                   rate=Rate("xdot", "m s-1", "velocity of the end", scale=sp.sqrt(g)))
    y = Coordinate("y", "m", "height of the end")
    system = System(f"random_rod_{seed}", "a random rod on a rough floor", "test",
                    coordinates=(theta, x, y), parameters=(f, g, m),
                    bodies=(Body(m, (x + a * sp.cos(theta), y + a * sp.sin(theta)),
                                 inertia=m * k2, angle=theta),),
                    potential=m * g * (y + a * sp.sin(theta)), forces={x: push * m * g},
                    contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f),))
    fixed = {"xdot": -1.0, "omega": float(rng.uniform(0.0, 5.0))}
    return system.model, fixed


@pytest.mark.parametrize("seed", [5, 11])
def test_pieces_are_the_rasters_class_changes(seed):
    model, fixed = random_rod(seed)
    axes = {"theta": (0.1, 1.5), "f": (0.0, 3.0)}
    b = phasemap.boundaries(model, axes, fixed=fixed)
    assert b.sizes["piece"] >= 1 and np.all(b.point_residual.values <= 1e-10)
    th = (np.arange(CELLS) + 0.5) / CELLS * 1.4 + 0.1
    fs = (np.arange(CELLS) + 0.5) / CELLS * 3.0
    n = phasemap.Scene(model, axes={"theta": th, "f": fs}, fixed=fixed,
                       layers=["n_solutions"]).compute().n_solutions.transpose("theta", "f").values
    # vertices in cell units; densify each piece so that a polyline is its points
    pu, pw = (b.theta.values - 0.1) / 1.4 * CELLS, b.f.values / 3.0 * CELLS
    pts = []
    for p in np.unique(b.piece.values):
        sel = b.piece.values == p
        u, w = pu[sel], pw[sel]
        for i in range(len(u) - 1):
            t = np.linspace(0, 1, 9)[:, None]
            pts.append(np.hstack([u[i] + t * (u[i + 1] - u[i]), w[i] + t * (w[i + 1] - w[i])]))
    pts = np.vstack(pts) if pts else np.empty((0, 2))
    changes = []
    for di, dj in ((1, 0), (0, 1)):
        a, c = n[:CELLS - di, :CELLS - dj], n[di:, dj:]
        for i, j in zip(*np.nonzero(a != c)):
            changes.append((i + 0.5 + di / 2, j + 0.5 + dj / 2))
    for ci, cj in changes:
        d = np.min(np.hypot(pts[:, 0] - ci, pts[:, 1] - cj)) if len(pts) else np.inf
        assert d <= 1.5, (seed, ci, cj, d)
    # the side classes, checked beside each piece's middle vertex
    for p in range(b.sizes["piece"]):
        sel = np.flatnonzero(b.piece.values == p)
        q = sel[len(sel) // 2]
        du, dw = pu[q + 1] - pu[q - 1], pw[q + 1] - pw[q - 1]
        norm = np.hypot(du, dw)
        nu, nw = -dw / norm * 1e-3, du / norm * 1e-3  # left normal, in cells
        for sign, want in ((1, b.class_left.values[p]), (-1, b.class_right.values[p])):
            state = {**fixed, "theta": 0.1 + (pu[q] + sign * nu) / CELLS * 1.4,
                     "f": (pw[q] + sign * nw) / CELLS * 3.0}
            assert phasemap.classify(model, **state).n_solutions == want, (seed, p, sign)
