"""Regions thinner than a cell of the check raster (issue 37, item 5).

The tracer seeds from the class changes of a 128^2 raster; a region that fits between
its cell centres shows none.  It is found from the extrema of each condition over the
33^2 seed raster (GUIDE section 7), and what cannot be resolved there is reported.

Closed forms, derived here: the Painleve rod pushed back at rest has the slide
coefficient c = 1 + 3 cos^2 theta - 3 f sin theta cos theta
= 5/2 + 3/2 cos 2 theta - 3/2 f sin 2 theta, least over theta where
(cos 2 theta, sin 2 theta) = (-1, f) / sqrt(1 + f^2): c_min = 5/2 - 3/2 sqrt(1 + f^2),
zero first at f = 4/3, theta = pi/2 - arctan(f)/2 = arctan 2.  A rod whose inertia is
m l^2 kappa has kappa + cos^2 theta - f sin theta cos theta, least
kappa + 1/2 - sqrt(1 + f^2)/2, negative for kappa < kappa*(f) = (sqrt(1 + f^2) - 1)/2;
with kappa = (s - 1)^2 + 1/4 (tests/test_threshold_over.py) the paradox at a fixed
f just above sqrt(5)/2 is a hole in (theta, s): |s - 1| < sqrt(kappa* - 1/4).
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
import sympy as sp

import phasemap
from phasemap.bifurcation import Condition
from phasemap.bifurcation import tracing as TR

from test_threshold_over import inertia_rod

ROD = {"xdot": -1.0, "omega": 0.0}


def _raster_misses(model, axes, fixed, value=0):
    """The check raster of the slice has no cell in the region (the region is a sliver)."""
    sl = TR.make_slice(model, axes, fixed)
    classes = TR._check_raster(sl, "n_solutions", TR._cell_centres(sl, TR.CHECK_CELLS))
    return not (classes == value).any()


@pytest.mark.parametrize("excess", [3e-3, 1e-7])
def test_rod_paradox_sliver_at_the_edge_of_f(excess):
    over = {"theta": (0.1, 1.5), "f": (0.0, 4.0 / 3.0 + excess)}
    assert _raster_misses("painleve_rod", over, ROD)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        t = phasemap.threshold("painleve_rod", "f", value=0, over=over, fixed=ROD)
    assert t is not None and t.kind == "fold_f" and not t.unresolved
    assert abs(t.value - 4.0 / 3.0) <= 1e-10
    assert abs(t.at["theta"] - math.atan(2.0)) <= 1e-10
    assert t.residual <= 1e-12
    # the sliver's boundary: one piece from the edge f = hi back to it, on c = 0
    b = phasemap.boundaries("painleve_rod", over, fixed=ROD)
    assert b.sizes["piece"] == 1
    th, f = b.theta.values, b.f.values
    c = 1 + 3 * np.cos(th) ** 2 - 3 * f * np.sin(th) * np.cos(th)
    assert np.max(np.abs(c)) <= 1e-12
    ends = b.point_kind.values == "end"
    assert ends.sum() == 2 and np.allclose(b.point_f.values[ends], over["f"][1], rtol=0,
                                           atol=1e-12)


def test_paradox_hole_inside_the_slice():
    f = math.sqrt(5.0) / 2.0 + 1e-4
    kappa = (math.sqrt(1.0 + f * f) - 1.0) / 2.0
    half = math.sqrt(kappa - 0.25)
    model = inertia_rod()
    fixed = {**ROD, "l": 1.0, "f": f}
    over = {"theta": (0.05, 1.55), "s": (0.2, 1.9)}
    assert _raster_misses(model, over, fixed)
    b = phasemap.boundaries(model, over, fixed=fixed)
    assert b.sizes["piece"] == 1 and int(b.closed[0]) == 1
    assert {int(b.class_left[0]), int(b.class_right[0])} == {0, 1}
    th, s = b.theta.values, b.s.values
    c = (s - 1) ** 2 + 0.25 + np.cos(th) ** 2 - f * np.sin(th) * np.cos(th)
    assert np.max(np.abs(c)) <= 1e-12
    theta_star = math.pi / 2 - math.atan(f) / 2
    for side, want in (("min", 1.0 - half), ("max", 1.0 + half)):
        t = phasemap.threshold(model, "s", value=0, over={"theta": over["theta"], "s": over["s"]},
                               fixed=fixed, side=side)
        assert t.kind == "fold_s" and abs(t.value - want) <= 1e-10, (side, t, want)
        assert abs(t.at["theta"] - theta_star) <= 1e-10


def test_an_extremum_that_cannot_be_resolved_is_reported():
    """A condition that touches zero as |x|^(1/2) does, at a point between the raster's
    nodes: no sampling can tell it from a tiny region where it changes sign."""
    th, f = sp.Symbol("theta", real=True), sp.Symbol("f", real=True)
    cusp = Condition("cusp", "", "normal",
                     ((th - math.sqrt(2.0) / 2) ** 2 + (f - 1 / math.pi) ** 2) ** sp.Rational(1, 4))
    axes = {"theta": (0.2, 1.5), "f": (0.0, 0.5)}
    with pytest.warns(UserWarning, match=r"1 extrema of a condition may reach zero.*cusp"):
        b = phasemap.boundaries("painleve_rod", axes, fixed=ROD, conditions=[cusp])
    (point,) = json.loads(b.attrs["phasemap_unresolved"])
    assert point["condition"] == "cusp"
    assert abs(point["theta"] - math.sqrt(2.0) / 2) <= 1.3 / 32 * 1.3
    assert abs(point["f"] - 1 / math.pi) <= 1.3 / 32 * 0.5
    # no region is found, and None would claim there is none: the threshold says why not
    with pytest.warns(UserWarning, match="cusp"), \
            pytest.raises(ValueError, match="could not be resolved"):
        phasemap.threshold("painleve_rod", "f", value=0, over=axes, fixed=ROD,
                           conditions=[cusp])


@pytest.mark.parametrize("cut", [1e-6, -1e-6])
def test_a_loop_that_an_edge_cuts_by_less_than_a_step(cut):
    """The inertia rod's paradox hole at f = sqrt(5)/2 + 1e-3, |s - 1| < h, with s's range
    starting at 1 - h + cut: cut by the edge (cut > 0) it is a piece with two ends on
    that edge, not a loop (issue 37, item 8); just inside (cut < 0), a loop."""
    f = math.sqrt(5.0) / 2.0 + 1e-3
    half = math.sqrt((math.sqrt(1.0 + f * f) - 1.0) / 2.0 - 0.25)
    lo = 1.0 - half + cut
    b = phasemap.boundaries(inertia_rod(), {"theta": (0.05, 1.55), "s": (lo, 1.9)},
                            fixed={**ROD, "l": 1.0, "f": f})
    assert b.sizes["piece"] == 1
    th, s = b.theta.values, b.s.values
    assert np.max(np.abs((s - 1) ** 2 + 0.25 + np.cos(th) ** 2 - f * np.sin(th) * np.cos(th))) \
        <= 1e-12
    ends = b.point_kind.values == "end"
    theta_star = math.pi / 2 - math.atan(f) / 2
    if cut > 0:
        assert int(b.closed[0]) == 0 and ends.sum() == 2
        assert np.all(b.point_s.values[ends] == lo) and s.min() == lo
        e = np.sort(b.point_theta.values[ends])
        assert e[0] < theta_star < e[1]
    else:
        assert int(b.closed[0]) == 1 and ends.sum() == 0
        assert abs(s.min() - (1.0 - half)) <= 1e-10
