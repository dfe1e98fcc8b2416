"""threshold(..., along=...): the first paradox of a rod with radius of gyration k.

Derived here, independently of the tracer.  A rod's end A (distance l from the
centre of mass G, angle theta to the floor) slides back (xdot < 0) on a rough
floor: m x_G'' = F, m y_G'' = N - m g, m k^2 theta'' = l (F sin theta - N cos
theta) with F = f N and y_A = y_G - l sin theta = 0, so y_G'' = l (cos theta
theta'' - sin theta omega^2).  At omega = 0, eliminating theta'' gives
N (k^2 + l^2 cos^2 - f l^2 sin cos) = m g k^2: the coefficient k^2/l^2 + cos^2 -
f sin cos changes sign first (no solution) at the least f of
f(theta) = (kappa (1 + t^2) + 1) / t, t = tan theta, kappa = k^2 / l^2: at
t = sqrt((kappa + 1) / kappa), f = 2 sqrt(kappa (kappa + 1)) = 2 (k/l) sqrt(1 + k^2/l^2).
The uniform rod (k^2 = l^2/3) gives 4/3 at arctan 2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import phasemap
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

from conftest import assert_atlas_round_trip

#: test_threshold_over declares and maps the same gyration rod: one worker compiles it
XDIST_GROUP = "tests/test_threshold_over.py"


def gyration_rod():
    """A rod whose inertia about its centre of mass is m k^2, declared with the public API."""
    k = Parameter("k", "m", "radius of gyration about the centre of mass", default=0.5,
                  lower=0.0, lower_open=True)
    return declared_rod("gyration_rod", "a rod with radius of gyration k on a rough floor", k,
                        lambda m, l: m * k**2)


def declared_rod(name, description, extra, inertia):
    """A rod on a rough floor with the further parameter ``extra`` and the inertia
    ``inertia(m, l)`` about its centre of mass (a sympy expression)."""
    f = Parameter("f", "1", "friction coefficient", default=0.5, lower=0.0)
    l = Parameter("l", "m", "distance of the end from the centre of mass", default=1.0,
                  lower=0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
    m = Parameter("m", "kg", "mass of the rod", default=1.0, lower=0.0, lower_open=True)
    theta = Coordinate("theta", "rad", "angle of the rod to the floor", default=1.0, lower=0.0,
                       upper=float(sp.pi),
                       rate=Rate("omega", "rad s-1", "angular velocity", scale=sp.sqrt(g / l)))
    x = Coordinate("x", "m", "position of end A",
                   rate=Rate("xdot", "m s-1", "velocity of end A", scale=sp.sqrt(g * l)))
    y = Coordinate("y", "m", "height of end A")
    return System(name, description, "test",
                  coordinates=(theta, x, y), parameters=(f, l, extra, g, m),
                  bodies=(Body(m, (x + l * sp.cos(theta), y + l * sp.sin(theta)),
                               inertia=inertia(m, l), angle=theta),),
                  potential=m * g * (y + l * sp.sin(theta)),
                  contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f),)).model


@pytest.fixture(scope="module")
def curve():
    return phasemap.threshold(gyration_rod(), "f", value=0,
                              over={"theta": (0.05, 1.55), "f": (0.0, 6.0)},
                              fixed={"xdot": -1.0, "omega": 0.0, "l": 1.0},
                              along={"k": (0.2, 1.5)})


def test_first_paradox_along_k(curve):
    k = curve.k.values
    assert k[0] == 0.2 and k[-1] == 1.5 and curve.sizes["piece"] == 1
    assert np.max(np.abs(curve.f.values - 2 * k * np.sqrt(1 + k**2))) <= 1e-10
    assert np.max(np.abs(curve.theta.values - np.arctan(np.sqrt(1 + 1 / k**2)))) <= 1e-10
    assert str(curve.condition.values[0]) == "coef_A_slip_neg"
    # the uniform rod lies on it: k = 1/sqrt 3 gives 4/3
    t = phasemap.threshold(gyration_rod(), "f", value=0,
                           over={"theta": (0.05, 1.55), "f": (0.0, 6.0)},
                           fixed={"xdot": -1.0, "omega": 0.0, "l": 1.0, "k": 1 / math.sqrt(3)})
    assert abs(t.value - 4 / 3) <= 1e-10 and abs(t.at["theta"] - math.atan(2)) <= 1e-10


def test_curve_round_trip(curve, tmp_path):
    assert_atlas_round_trip(curve, tmp_path, "along.nc")


def test_a_threshold_curve_file_is_summarised_and_drawn(curve, tmp_path):
    """Every kind of file phasemap writes opens in ``info`` and ``plot`` (issue 41 item 2):
    here a threshold curve, written from Python (the command line's threshold is a point)."""
    import subprocess
    import sys

    path = phasemap.write_atlas(curve, tmp_path / "curve.nc")
    cli = [sys.executable, "-m", "phasemap.cli"]
    info = subprocess.run(cli + ["info", str(path)], capture_output=True, text=True,
                          timeout=600)
    assert info.returncode == 0, info.stderr
    assert info.stdout.startswith(f"phasemap threshold curve {path}")
    assert "followed in k" in info.stdout and "pieces    1 with" in info.stdout
    drawn = subprocess.run(cli + ["plot", str(path), "-o", str(tmp_path / "fig")],
                           capture_output=True, text=True, timeout=600)
    assert drawn.returncode == 0, drawn.stderr
    fig = curve.phasemap.plot()
    ax = fig.axes[0]
    assert ax.get_xlabel().startswith("$k$") and ax.get_ylabel().startswith("$f$")
    (line,) = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == curve.sizes["vertex"]]
    assert np.allclose(line.get_xdata(), curve.k.values)


def test_a_curve_stopped_by_a_default_range_says_so_and_ends_on_its_edge():
    """Issue 41 item 3 / 37 item 10: along k, with f's range left to its default [0, 2],
    the first paradox f* = 2 k sqrt(1 + k^2) leaves it at k^2 = (sqrt 5 - 1)/2 (golden):
    the end is solved on the edge with consistent coordinates, recorded, and warned of."""
    with pytest.warns(UserWarning, match=r"f reached 2 at k = 0\.786151.*default range "
                                         r"\[0, 2\]"):
        c = phasemap.threshold(gyration_rod(), "f", value=0, over={"theta": (0.05, 1.55)},
                               fixed={"xdot": -1.0, "omega": 0.0, "l": 1.0},
                               along={"k": (0.2, 1.5)})
    assert "f reached 2 at k = 0.786151" in c.attrs["phasemap_stopped_by"]
    end = c.point_kind.values == "end"
    k, f, th = (float(c[f"point_{n}"].values[end][0]) for n in ("k", "f", "theta"))
    assert abs(k - math.sqrt((math.sqrt(5) - 1) / 2)) <= 1e-7
    assert abs(f - 2 * k * math.sqrt(1 + k * k)) <= 1e-9 and abs(f - 2.0) <= 1e-7
    assert abs(th - math.atan(math.sqrt(1 + 1 / k ** 2))) <= 1e-9
    # given a wider range, the curve goes on to the end of k's range, and nothing is said
    wide = phasemap.threshold(gyration_rod(), "f", value=0,
                              over={"theta": (0.05, 1.55), "f": (0.0, 6.0)},
                              fixed={"xdot": -1.0, "omega": 0.0, "l": 1.0},
                              along={"k": (0.2, 1.5)})
    assert "phasemap_stopped_by" not in wide.attrs and wide.k.values[-1] == 1.5
