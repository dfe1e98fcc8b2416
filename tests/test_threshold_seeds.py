"""phasemap.threshold and phasemap.boundaries against the seed systems' closed forms.

Each closed form is derived here (INDEPENDENT), not read from the tracer, nor from
:mod:`phasemap.facts` or the studies' claims, which are checked against it: the
elliptic pendulum's lambda_k = (3 - cos 2 phi - k f sin 2 phi)/2 has its least value
(3 - sqrt(1 + f^2))/2, zero first at f = 2 sqrt 2 where tan 2 phi = f; the ladder's
slide coefficient 2 - f^2; its rest (omega = 0) needs tan(phi/2) <= f, phi <= 2 arctan
f; the hinge's turning coefficient vanishes at delta = l and rest holds where
l |sin phi| <= delta; the wheel's bracket of (13) vanishes first where its least value
over phi, rho^2 + r^2 + l^2 - l sqrt(4 r^2 + delta^2), does.  The hand models
(elliptic, hinge) run their own kernels for the classes and their declared twins'
conditions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import phasemap
from phasemap import claims

P = math.pi
CASES = {f"{c.study}: {c.what}": c for c in claims.CASES}

#: compiles the ladder's admissibility conditions, as the ladder study does: one xdist
#: group, so that they are compiled once (tests/conftest.py)
XDIST_GROUP = "studies"


#: Each case's value and point, derived here (not read from phasemap.claims
#: or phasemap.facts, which the studies print): the elliptic pendulum's lambda_+ has least
#: value (3 - sqrt(1 + f^2))/2, zero at f = sqrt 8 where tan 2 phi = f; the ladder's slide
#: coefficient 2 - f^2 and its rest tan(phi/2) <= f; the hinge's turning coefficient
#: vanishes at delta = l and it rests while l |sin phi| <= delta; the wheel's bracket
#: rho^2 + r^2 + l^2 - 2 r l cos phi + delta l sin phi has least value rho^2 + r^2 + l^2
#: - l sqrt(4 r^2 + delta^2), zero at delta^2 = ((rho^2 + r^2 + l^2)/l)^2 - 4 r^2 = 5 for
#: r = 1, l = rho = 1/2; the rod's 1 + 3 cos^2 - 3 f sin cos = 0 needs f = (4 + t^2)/(3 t),
#: t = tan theta, least (4/3) at t = 2.
INDEPENDENT = {
    "elliptic_pendulum: no solution (xdot > 0) first exists":
        (math.sqrt(8.0), {"phi": 0.5 * math.atan(math.sqrt(8.0))}),
    "ladder: slide coefficient vanishes": (math.sqrt(2.0), {}),
    "ladder: static zone (omega = 0, f = 0.5) ends": (2.0 * math.atan(0.5), {}),
    "hinge_pendulum: turning coefficient vanishes": (1.0, {}),
    "hinge_pendulum: stagnation zone (omega = 0, delta = 0.5) ends": (P / 6, {}),
    "wheel: singular bracket first vanishes": (math.sqrt(5.0), {}),
    "painleve_rod: first paradox (xdot < 0)": (4.0 / 3.0, {"theta": math.atan(2.0)}),
}


@pytest.mark.parametrize("name", list(CASES))
def test_threshold_closed_form(name):
    case = CASES[name]
    value, at = INDEPENDENT[name]
    # the closed form the studies print is this one (to rounding)
    assert abs(case.value - value) <= 1e-15 * value and set(case.at) == set(at)
    t = phasemap.threshold(**case.call)
    assert t is not None and t.kind == case.kind
    assert abs(t.value - value) <= 1e-10, (t, value)
    for var, want in at.items():
        assert abs(t.at[var] - want) <= 1e-10, (t, var, want)
    assert t.residual <= 1e-12
    if math.isfinite(t.bound):  # the raster's best cell bounds the exact value
        assert (t.value <= t.bound) if t.side == "min" else (t.value >= t.bound)


def test_the_studies_claims():
    (c,) = claims.threshold_claims("elliptic_pendulum")
    assert c.verdict == "agrees" and "2.828427124746" in c.measured and c.paper.startswith("f = 2")


def test_wheel_bracket_point():
    """The wheel's bracket rho^2 + r^2 + l^2 - 2 r l cos phi + delta l sin phi (rolling
    one way) is least where tan phi = -delta / (2 r): the fold lies there."""
    case = CASES["wheel: singular bracket first vanishes"]
    t = phasemap.threshold(**case.call)
    phi, value = t.at["phi"], case.value
    assert abs(math.tan(phi) + value / 2.0) <= 1e-9 or abs(math.tan(phi) - value / 2.0) <= 1e-9


def test_ladder_static_zone_is_two_arctan_f():
    b = phasemap.boundaries("ladder", {"phi": (0.05, 1.5), "f": (0.05, 0.95)},
                            fixed={"omega": 0.0}, layer="stagnation")
    assert b.sizes["piece"] == 1
    assert np.max(np.abs(b.phi.values - 2.0 * np.arctan(b.f.values))) <= 1e-12
    # rest (1) on the side of small phi: on the left where the piece runs up in f
    # (the left normal (-df, dphi) points to smaller phi)
    up = b.f.values[-1] > b.f.values[0]
    assert (int(b.class_left[0]), int(b.class_right[0])) == ((1, 0) if up else (0, 1))
    # it leaves the slice at f = 0.05 and at phi = 1.5 (f = tan 0.75)
    ends = np.sort(b.point_f.values[b.point_kind.values == "end"])
    assert np.allclose(ends, [0.05, math.tan(0.75)], rtol=0, atol=1e-10)


def test_hinge_stagnation_zone_is_l_sin_phi_equals_delta():
    b = phasemap.boundaries("hinge_pendulum", {"phi": (-3.0, 3.0), "delta": (0.05, 1.4)},
                            fixed={"omega": 0.0, "l": 1.0}, layer="stagnation")
    assert b.sizes["piece"] == 2
    assert np.max(np.abs(np.abs(np.sin(b.phi.values)) - b.delta.values)) <= 1e-12
    folds = b.point_kind.values == "fold_delta"
    assert np.allclose(np.sort(b.point_phi.values[folds]), [-P / 2, P / 2], rtol=0, atol=1e-10)
    assert np.allclose(b.point_delta.values[folds], 1.0, rtol=0, atol=1e-10)
    assert np.all(b.point_residual.values <= 1e-12)
