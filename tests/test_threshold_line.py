"""threshold on a line where a sample falls within a condition's ties (issue 37, item 6).

The Painleve rod pushed back at rest (xdot < 0, omega = 0) has no solution where its
slide coefficient 1 + 3 cos^2 theta - 3 f sin theta cos theta is negative: beyond
f_r = (1 + 3 cos^2 theta) / (3 sin theta cos theta) (derived here).  With
tan theta = t, f_r = (4 + t^2) / (3 t): the theta whose t solves
t^2 - 3 f_r t + 4 = 0 puts the root at a chosen f_r.  Where f_r is one of the line's
samples, the coefficient there lies within its ties and the kernel may class that
sample on either side: the class changes between two samples where the coefficient
does not change sign.  A large root (small theta) has the widest ties in f.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import phasemap
from phasemap.bifurcation.thresholds import LINE_SAMPLES

ROD = {"xdot": -1.0, "omega": 0.0}


def _theta_for_root(fr: float, small: bool) -> float:
    """theta (tan theta = t) where the slide coefficient vanishes at f = fr."""
    b = 3.0 * fr
    t = (b - math.sqrt(b * b - 16.0)) / 2.0 if small else (b + math.sqrt(b * b - 16.0)) / 2.0
    return math.atan(t)


@pytest.mark.parametrize("fr, small", [(1.5, True), (1.5, False), (19.5, True), (19.5, False)])
def test_a_sample_on_the_root(fr, small):
    theta = _theta_for_root(fr, small)
    rng = (0.0, 2.0 * fr)
    assert np.linspace(*rng, LINE_SAMPLES + 1)[LINE_SAMPLES // 2] == fr  # a sample on it
    t = phasemap.threshold("painleve_rod", "f", value=0, over={"f": rng},
                           fixed={**ROD, "theta": theta})
    want = (1 + 3 * math.cos(theta) ** 2) / (3 * math.sin(theta) * math.cos(theta))
    assert t.kind == "root" and abs(t.value - want) <= 1e-12 * want, (t, want)
    assert t.residual <= 1e-12


@pytest.mark.parametrize("theta", [0.0683, 0.00683])
def test_a_large_root(theta):
    want = (1 + 3 * math.cos(theta) ** 2) / (3 * math.sin(theta) * math.cos(theta))
    t = phasemap.threshold("painleve_rod", "f", value=0, over={"f": (0.0, 2.05 * want)},
                           fixed={**ROD, "theta": theta})
    assert t.kind == "root" and abs(t.value - want) <= 1e-12 * want, (t, want)


@pytest.mark.parametrize("excess", [1e-7, 1e-8])
@pytest.mark.parametrize("side", ["min", "max"])
def test_a_region_thinner_than_a_sample(excess, side):
    """At f = 4/3 + excess the slide coefficient 5/2 + 3/2 cos 2 theta - 3/2 f sin 2 theta
    is negative only where cos(2 theta + arctan f) < -5 / (3 sqrt(1 + f^2)): a window of
    theta narrower than a sample of the line (issue 37, item 5)."""
    f = 4.0 / 3.0 + excess
    a = math.acos(-5.0 / (3.0 * math.sqrt(1.0 + f * f)))
    lo, hi = sorted([(a - math.atan(f)) / 2, (2 * math.pi - a - math.atan(f)) / 2])
    rng = (0.1, 1.5)
    assert hi - lo < (rng[1] - rng[0]) / LINE_SAMPLES
    t = phasemap.threshold("painleve_rod", "theta", value=0, over={"theta": rng},
                           fixed={**ROD, "f": f}, side=side)
    assert t is not None and t.kind == "root" and t.condition == "coef_A_slip_neg"
    assert abs(t.value - (lo if side == "min" else hi)) <= 1e-10, (t, lo, hi)
    assert t.residual <= 1e-12
