"""threshold over two further names: the first paradox of a rod whose inertia depends
on a parameter s, least over (theta, s).

Derived here, independently of the tracer (see tests/test_threshold_along.py for
the rod with radius of gyration k): at omega = 0 the slide coefficient of the
end pushed back is kappa + cos^2 theta - f sin theta cos theta, kappa = I/(m l^2);
it first changes sign at f = 2 sqrt(kappa (kappa + 1)), tan theta =
sqrt((kappa + 1)/kappa), increasing in kappa.  With I = m l^2 ((s - 1)^2 + 1/4)
the least over s is at s = 1 (kappa = 1/4): f = sqrt(5)/2 at theta = arctan sqrt(5),
an interior extremum (c = c_theta = c_s = 0); with I = m k^2 over k in (0.3, 1.5)
it lies on k's lower edge: f = 2 k sqrt(1 + k^2) at k = 0.3.
"""

from __future__ import annotations

import math

import pytest
import sympy as sp

import phasemap
from phasemap.declare import Parameter

from test_threshold_along import declared_rod, gyration_rod

OVER = {"theta": (0.05, 1.55), "f": (0.0, 6.0)}
FIXED = {"xdot": -1.0, "omega": 0.0, "l": 1.0}


def inertia_rod():
    """A rod whose inertia about its centre of mass is m l^2 ((s - 1)^2 + 1/4)."""
    s = Parameter("s", "1", "shape parameter of the inertia", default=1.0)
    return declared_rod("inertia_rod", "a rod whose inertia varies with s, on a rough floor", s,
                        lambda m, l: m * l**2 * ((s - 1) ** 2 + sp.Rational(1, 4)))


def test_interior_minimum_over_two_names():
    t = phasemap.threshold(inertia_rod(), "f", value=0, over={**OVER, "s": (0.2, 1.9)},
                           fixed=FIXED)
    assert abs(t.value - math.sqrt(5) / 2) <= 1e-10
    assert abs(t.at["theta"] - math.atan(math.sqrt(5))) <= 1e-10
    assert abs(t.at["s"] - 1.0) <= 1e-10
    assert t.kind == "fold_f" and t.condition == "coef_A_slip_neg" and t.residual <= 1e-12
    assert set(t.at) == {"theta", "s", "f"}


def test_minimum_on_the_edge_of_the_second_name():
    t = phasemap.threshold(gyration_rod(), "f", value=0, over={**OVER, "k": (0.3, 1.5)},
                           fixed=FIXED)
    assert abs(t.value - 2 * 0.3 * math.sqrt(1 + 0.09)) <= 1e-10
    assert t.at["k"] == 0.3 and abs(t.at["theta"] - math.atan(math.sqrt(1 + 1 / 0.09))) <= 1e-10


def test_three_free_names_are_refused_naming_the_way_out():
    with pytest.raises(ValueError, match="at most two names besides 'f'.*along="):
        phasemap.threshold(gyration_rod(), "f", value=0,
                           over={**OVER, "k": (0.3, 1.5), "l": (0.5, 2.0)},
                           fixed={"xdot": -1.0, "omega": 0.0})


@pytest.mark.parametrize("tol", [1e-16, 2e-16, 1e-20])
def test_a_tolerance_below_double_precision_is_refused_in_one_line(tol):
    """tol=1e-16 once returned the rod's first paradox 8.1e-5 off, kind 'flat' (issue 37
    item 4): a tolerance below twice the spacing of doubles at a range's largest value
    cannot be met, and is refused before anything is traced, by every entry point."""
    over = {"theta": (0.1, 1.5), "f": (0.0, 3.0)}
    rod = {"xdot": -1.0, "omega": 0.0}
    words = r"^tol = .* cannot be met: double precision resolves f in \[0, 3\] only to about"
    with pytest.raises(ValueError, match=words):
        phasemap.threshold("painleve_rod", "f", over=over, fixed=rod, tol=tol)
    with pytest.raises(ValueError, match=words):
        phasemap.boundaries("painleve_rod", over, fixed=rod, tol=tol)
    with pytest.raises(ValueError, match=r"cannot be met: double precision resolves f in "):
        # f's range not given: its default range is checked
        phasemap.threshold("painleve_rod", "f", over={"theta": (0.1, 1.5)},
                           fixed=rod, tol=tol)


def test_the_smallest_tolerance_allowed_is_met():
    import numpy as np

    tol = 2.0 * float(np.spacing(3.0))
    t = phasemap.threshold("painleve_rod", "f", over={"theta": (0.1, 1.5), "f": (0.0, 3.0)},
                           fixed={"xdot": -1.0, "omega": 0.0}, tol=tol)
    assert abs(t.value - 4 / 3) <= tol and abs(t.at["theta"] - math.atan(2)) <= 1e-12


def test_a_threshold_on_the_edge_of_a_default_range_is_warned_of():
    """Issue 37 item 10: the supremum of f where the rod has no solution lies on the edge of
    f's default range: the region goes on beyond it, which the user is told."""
    rod = {"xdot": -1.0, "omega": 0.0}
    with pytest.warns(UserWarning, match=r"painleve_rod: the threshold f = 3 lies on the "
                                         r"edge of its default range \[0, 3\]"):
        t = phasemap.threshold("painleve_rod", "f", over={"theta": (0.1, 1.5)}, fixed=rod,
                               side="max")
    assert t.value == 3.0
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")   # a range given: nothing to say
        phasemap.threshold("painleve_rod", "f", over={"theta": (0.1, 1.5), "f": (0.0, 3.0)},
                           fixed=rod, side="max")
        phasemap.threshold("painleve_rod", "f", over={"theta": (0.1, 1.5)}, fixed=rod)
