"""threshold(..., along=...): where the threshold passes from one candidate to another
(issue 37, item 7).

The rod with radius of gyration k (tests/test_threshold_along.py, derived there) has
its first paradox where kappa + cos^2 theta - f sin theta cos theta = 0 (kappa =
k^2/l^2) turns back in f: at tan theta* = sqrt(1 + 1/kappa).  With theta ranged up to
1.2 only, theta* lies beyond that edge for k < k* = 1/sqrt(tan^2 1.2 - 1): there the
least f is the boundary's end on the edge theta = 1.2, f = (kappa + cos^2 1.2) /
(sin 1.2 cos 1.2); beyond k* the fold.  One switch, at k*, where the fold leaves
through the edge: both candidates meet there, on the condition.
"""

from __future__ import annotations

import math

import numpy as np

import phasemap

from test_threshold_along import gyration_rod

#: compiles the same gyration rod as test_threshold_over
XDIST_GROUP = "tests/test_threshold_over.py"

EDGE = 1.2


def _coefficient(k, theta, f):
    return k * k + np.cos(theta) ** 2 - f * np.sin(theta) * np.cos(theta)


def test_the_switch_from_the_edge_to_the_fold_is_solved():
    ds = phasemap.threshold(gyration_rod(), "f", value=0,
                            over={"theta": (0.05, EDGE), "f": (0.0, 6.0)},
                            fixed={"xdot": -1.0, "omega": 0.0, "l": 1.0},
                            along={"k": (0.2, 1.5)})
    assert list(ds.kind.values) == ["end", "fold_f"]
    assert list(ds.point_kind.values) == ["switch"]
    k, theta, f = (float(ds[f"point_{n}"].values[0]) for n in ("k", "theta", "f"))
    # the point lies on the condition at its own coordinates, at the edge, and gives the
    # exact threshold at its own k (the fold's where theta* lies inside, else the end's)
    assert abs(_coefficient(k, theta, f)) <= 1e-12
    assert abs(theta - EDGE) <= 1e-6
    inside = math.atan(math.sqrt(1 + 1 / k**2)) <= EDGE
    exact = (2 * k * math.sqrt(1 + k * k) if inside
             else (k * k + math.cos(EDGE) ** 2) / (math.sin(EDGE) * math.cos(EDGE)))
    assert abs(f - exact) <= 1e-10
    # where the fold reaches the edge (the two candidates touch: located to sqrt(tol))
    k_star = 1.0 / math.sqrt(math.tan(EDGE) ** 2 - 1.0)
    assert abs(k - k_star) <= 1e-4
    # every vertex lies on the condition; the fold's on theta*
    assert np.max(np.abs(_coefficient(ds.k.values, ds.theta.values, ds.f.values))) <= 1e-12
    fold = ds.piece.values == 1
    kf = ds.k.values[fold]
    assert np.max(np.abs(ds.theta.values[fold] - np.arctan(np.sqrt(1 + 1 / kf**2)))) <= 1e-9
