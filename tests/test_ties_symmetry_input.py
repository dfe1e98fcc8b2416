"""Which side of each boundary a tie goes to, symmetries (hypothesis), and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import phasemap
from phasemap.core.model import MAX_MAGNITUDE, MIN_POSITIVE
from phasemap.models import MODELS

G = 9.81


# ------------------------------------------------------------------ ties -----
def test_tie_ladder_static_boundary_goes_to_rest():
    f = 0.3
    c = phasemap.classify("ladder", phi=2 * math.atan(f), omega=0.0, f=f)
    assert c.stagnation and c.n_solutions == 1
    assert [b.name for b in c.branches] == ["stick"]
    assert not phasemap.classify("ladder", phi=2 * math.atan(f) + 1e-9, omega=0.0, f=f).stagnation


@pytest.mark.parametrize("model", ["wheel", "hinge_pendulum"])
def test_tie_rest_boundary_sin_phi_equals_delta_over_l(model):
    delta, l = 0.1, 0.5
    phi = math.asin(delta / l)
    c = phasemap.classify(model, phi=phi, omega=0.0, delta=delta, l=l)
    assert c.stagnation and c.n_solutions == 1
    assert not phasemap.classify(model, phi=phi + 1e-9, omega=0.0, delta=delta, l=l).stagnation


def test_tie_elliptic_friction_limit_goes_to_stick():
    phi, omega = 0.7, 0.4
    s, c_ = math.sin(phi), math.cos(phi)
    n = G * (1 + c_ * c_) + 2 * c_ * omega ** 2
    fr = s * (G * c_ + 2 * omega ** 2)
    f_limit = abs(fr) / abs(n)
    at = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=0.0, f=f_limit)
    below = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=0.0,
                              f=f_limit * (1 - 1e-9))
    assert at.stagnation and not below.stagnation
    assert at.n_solutions == 1  # the slide from rest has zero acceleration at the tie


def test_tie_elliptic_zero_normal_reaction_counted_once():
    """Q = g + l cos phi omega^2 = 0: N = 0, no friction, one solution in the N >= 0 branch."""
    phi = 2.5
    omega = math.sqrt(-G / math.cos(phi))
    for xdot in (1.0, -1.0):
        c = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=xdot, f=5.0)
        assert c.n_solutions == 1
        assert c.branches[0].name.endswith("_Npos")
        assert abs(c.branches[0].reactions["N"]) < 1e-12


def test_tie_singular_within_tolerance_of_sqrt2():
    """2 - f^2 is a tie within TOL = 1e-12 of the magnitude of its terms (about 4): f a
    relative 1e-13 off sqrt 2 (2 - f^2 ~ 4e-13) is singular on either side, 1e-11 off
    (4e-11) and 1.41421356 (7e-9) are not.  (f = 1.4142135623730951 was tested here
    beside math.sqrt(2.0): the same double, so nothing within the tolerance was.)"""
    r2 = math.sqrt(2.0)
    for f in (r2, r2 * (1 - 1e-13), r2 * (1 + 1e-13)):
        assert phasemap.classify("ladder", phi=0.5, omega=1.0, f=f).singular, f
    for f in (r2 * (1 - 1e-11), r2 * (1 + 1e-11), 1.41421356):
        assert not phasemap.classify("ladder", phi=0.5, omega=1.0, f=f).singular, f


def test_tie_hinge_singular_at_delta_equal_l():
    c = phasemap.classify("hinge_pendulum", phi=0.4, omega=1.0, delta=1.0, l=1.0)
    assert c.singular and c.n_solutions == 0


def test_velocity_within_tolerance_of_zero_is_at_rest():
    """A grid through zero built with linspace may miss 0.0 by rounding; it still sticks."""
    c = phasemap.classify("hinge_pendulum", phi=0.001, omega=1e-15)
    assert c.stagnation
    c = phasemap.classify("hinge_pendulum", phi=0.001, omega=1e-6)
    assert not c.stagnation and [b.name for b in c.branches] == ["turn_pos"]


def test_grazing_one_sided_contact_is_kept():
    """Wheel with N = 0 exactly (g + l cos phi omega^2 = 0 at phi = pi): not lost."""
    omega = math.sqrt(G / 0.5)
    c = phasemap.classify("wheel", phi=math.pi, omega=omega, delta=0.0)
    assert c.branches and abs(c.branches[0].reactions["N"]) < 1e-12
    assert not c.contact_lost
    assert phasemap.classify("wheel", phi=math.pi, omega=omega * (1 + 1e-9), delta=0.0).contact_lost


# ------------------------------------------------------------- symmetry -----
angles = st.floats(-2 * math.pi, 2 * math.pi, allow_nan=False)
speeds = st.floats(-20, 20, allow_nan=False)


def _same(a, b, flip):
    assert a.n_solutions == b.n_solutions
    assert a.stagnation == b.stagnation and a.singular == b.singular
    assert a.contact_lost == b.contact_lost
    acc_a = sorted(flip * x for br in a.branches for x in br.accelerations.values())
    acc_b = sorted(x for br in b.branches for x in br.accelerations.values())
    np.testing.assert_allclose(acc_a, acc_b, rtol=1e-9, atol=1e-9)


@settings(max_examples=300, deadline=None)
@given(angles, speeds, st.one_of(st.just(0.0), speeds), st.floats(0, 10))
def test_elliptic_mirror_symmetry(phi, omega, xdot, f):
    a = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=xdot, f=f)
    b = phasemap.classify("elliptic_pendulum", phi=-phi, omega=-omega, xdot=-xdot, f=f)
    _same(a, b, -1.0)


@settings(max_examples=200, deadline=None)
@given(angles, st.one_of(st.just(0.0), speeds), st.floats(0, 1.5))
def test_wheel_and_hinge_mirror_symmetry(phi, omega, delta):
    for model, extra in (("wheel", {"delta": delta * 0.5}), ("hinge_pendulum", {"delta": delta})):
        a = phasemap.classify(model, phi=phi, omega=omega, **extra)
        b = phasemap.classify(model, phi=-phi, omega=-omega, **extra)
        _same(a, b, -1.0)


@settings(max_examples=200, deadline=None)
@given(st.floats(0, math.pi / 2), st.one_of(st.just(0.0), speeds), st.floats(0, 4),
       st.floats(0.1, 10))
def test_ladder_scaling_l_and_g_together(phi, omega, f, alpha):
    """phi'' depends on l and g only through g / l: scaling both leaves it unchanged."""
    a = phasemap.classify("ladder", phi=phi, omega=omega, f=f)
    b = phasemap.classify("ladder", phi=phi, omega=omega, f=f, l=alpha, g=G * alpha)
    _same(a, b, 1.0)


@pytest.mark.xfail(strict=True, reason="known defect, open: at the stop phi = 0 with a "
                   "subnormal f the ladder's tie at N_wall = 0 is decided by the scale of g")
def test_ladder_scaling_with_a_subnormal_friction_coefficient():
    """Found by a random (non-derandomized) draw of the test above: f = 5e-324 at phi = 0,
    omega = -2 classifies the slip row at the stop admissible for (l, g) = (0.5, 4.905) and
    not for (1, 9.81); the same on the tree before this stop (a86891a)."""
    a = phasemap.classify("ladder", phi=0.0, omega=-2.0, f=5e-324)
    b = phasemap.classify("ladder", phi=0.0, omega=-2.0, f=5e-324, l=0.5, g=G * 0.5)
    _same(a, b, 1.0)


@settings(max_examples=100, deadline=None)
@given(angles, speeds, st.floats(0.1, 10))
def test_hinge_reactions_scale_with_mass_and_periodic_in_phi(phi, omega, m):
    a = phasemap.classify("hinge_pendulum", phi=phi, omega=omega)
    b = phasemap.classify("hinge_pendulum", phi=phi + 2 * math.pi, omega=omega, m=m)
    _same(a, b, 1.0)
    for x, y in zip(a.branches, b.branches):
        for k in x.reactions:
            assert y.reactions[k] == pytest.approx(m * x.reactions[k], rel=1e-8, abs=1e-8)


# ------------------------------------------------------------ bad input -----
@pytest.mark.parametrize("model, values, words", [
    ("ladderr", {}, ["unknown model 'ladderr'", "ladder, wheel"]),
    ("ladder", {"delta": 0.1}, ["ladder", "unknown variable 'delta'", "allowed: phi, omega, f"]),
    ("ladder", {"phi": math.nan}, ["ladder", "phi must be finite"]),
    ("wheel", {"omega": math.inf}, ["wheel", "omega must be finite"]),
    ("ladder", {"l": -1.0}, ["ladder", "l = -1", "(0, inf]"]),
    ("ladder", {"l": 0.0}, ["ladder", "l = 0", "(0, inf]"]),
    ("elliptic_pendulum", {"f": -0.1}, ["elliptic_pendulum", "f = -0.1", "[0, inf]"]),
    ("hinge_pendulum", {"delta": -0.2}, ["hinge_pendulum", "delta = -0.2"]),
    ("wheel", {"delta": -0.01}, ["wheel", "delta"]),
    ("ladder", {"phi": 2.0}, ["ladder", "phi = 2", "[0, 1.5707963267948966]"]),
    ("ladder", {"phi": -0.1}, ["ladder", "phi = -0.1"]),
    ("wheel", {"l": 1.5, "r": 1.0}, ["wheel", "must not exceed r"]),
    ("wheel", {"rho": 0.0}, ["wheel", "rho = 0"]),
    ("hinge_pendulum", {"g": -9.81}, ["hinge_pendulum", "g = -9.81"]),
    ("hinge_pendulum", {"m": 0.0}, ["hinge_pendulum", "m = 0"]),
    ("ladder", {"phi": [0.1, 0.2]}, ["ladder", "phi must be a scalar"]),
    ("ladder", {"phi": "abc"}, ["ladder", "phi"]),
])
def test_bad_input_is_a_clear_value_error(model, values, words):
    with pytest.raises(ValueError) as err:
        phasemap.classify(model, **values)
    for w in words:
        assert w in str(err.value)
    assert "numba" not in str(err.value).lower()


def test_cases_the_model_handles_are_classified_not_refused():
    assert phasemap.classify("hinge_pendulum", phi=1.0, omega=1.0, delta=1.5).n_solutions == 0
    c = phasemap.classify("ladder", phi=0.5, omega=1.0, f=10.0)  # a genuine paradox
    assert c.n_solutions == 0 and not c.singular and c.candidates
    assert phasemap.classify("wheel", phi=1.0, omega=0.0, delta=2.0, l=0.5).stagnation
    assert phasemap.classify("wheel", phi=1.0, omega=1.0, g=0.0).n_solutions == 1


def test_defaults_fill_missing_names():
    c = phasemap.classify("elliptic_pendulum")
    assert c.values == phasemap.MODELS["elliptic_pendulum"].defaults
    assert c.values["f"] == 0.3 and c.values["l"] == 1.0


@pytest.mark.parametrize("model", sorted(MODELS))
def test_no_overflow_is_ever_counted_as_a_solution(model):
    """At random states with every value anywhere in its allowed range (1e-30 to 1e30),
    each admissible branch has finite accelerations and reactions."""
    m = MODELS[model]
    rng = np.random.default_rng(10)
    checked = 0
    for _ in range(1500):
        values = {}
        for var in m.state + m.params:
            kind = rng.integers(4)
            mag = 10.0 ** rng.uniform(-30, 30)
            x = 0.0 if kind == 0 else (MAX_MAGNITUDE if kind == 1 else mag)
            if var.lower >= 0:
                x = max(x, MIN_POSITIVE) if var.lower_open else x
                if var.upper < math.inf:
                    x = min(x, var.upper)
            elif rng.integers(2):
                x = -x
            values[var.name] = x
        if model == "wheel":
            values["l"] = min(values["l"], values["r"])
        if m.check is not None:  # a cross-variable domain (the rod on a step must touch it)
            try:
                m.check(values)
            except ValueError:
                continue
        c = phasemap.classify(m, **values)
        for b in c.branches:
            if b.status != phasemap.BranchStatus.ADMISSIBLE:
                continue  # a continuum has no values
            numbers = [*b.accelerations.values(), *b.reactions.values()]
            assert all(math.isfinite(x) for x in numbers), (repr(values), b)
            checked += 1
    assert checked > (100 if m.check is not None else 500)  # a check refuses most draws
