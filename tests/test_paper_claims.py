"""The seed paper's claims about solvability and rest, each as a test, with the sharp versions."""

from __future__ import annotations

import math

import numpy as np
import pytest
import oracles
import reference as ref
from references import ladder as hand_ladder
from references import wheel as hand_wheel

import phasemap

G = 9.81
SQRT2 = math.sqrt(2.0)
F_SHARP = 2.0 * math.sqrt(2.0)  # the elliptic pendulum's sharp threshold


# ---------------------------------------------------------------- ladder -----
@pytest.mark.parametrize("phi, omega", [(0.3, 1.0), (0.8, -2.0), (1.2, 0.5), (0.1, 4.0)])
def test_ladder_singular_at_sqrt2_has_no_acceleration(phi, omega):
    """(8) has no solution at f = sqrt 2 (the hand module); leaving a contact may have one:
    the running ladder counts exactly the independent oracle's separations."""
    hand = phasemap.classify(hand_ladder.MODEL, phi=phi, omega=omega, f=SQRT2)
    assert hand.singular and hand.n_solutions == 0 and not hand.branches
    c = phasemap.classify("ladder", phi=phi, omega=omega, f=SQRT2)
    kept = {b.name: b for b in c.candidates}["slide_pos" if omega > 0 else "slide_neg"]
    assert c.singular and kept.status == phasemap.BranchStatus.NO_SOLUTION
    assert c.n_solutions == oracles.ladder(phi, omega, SQRT2, 1.0, G, 1.0).n_solutions
    assert all(b.status == phasemap.BranchStatus.SEPARATION for b in c.branches)


def test_ladder_sqrt2_continuum_where_the_right_side_vanishes_too():
    """At f = sqrt 2 and 2 sqrt2 l omega^2 = 2 sqrt2 g cos phi + g sin phi every phi'' solves (8)."""
    phi = 0.8
    omega = math.sqrt((2 * SQRT2 * G * math.cos(phi) + G * math.sin(phi)) / (2 * SQRT2))
    c = phasemap.classify("ladder", phi=phi, omega=omega, f=SQRT2)
    assert c.singular and c.n_solutions == 3
    assert c.solvability is phasemap.Solvability.CONTINUUM


def test_ladder_not_singular_off_sqrt2():
    for f in (SQRT2 * (1 - 1e-6), SQRT2 * (1 + 1e-6)):
        assert not phasemap.classify("ladder", phi=0.5, omega=1.0, f=f).singular


def test_ladder_above_sqrt2_sliding_ladder_is_a_genuine_paradox():
    """Beyond sqrt 2 the sliding ladder would need a contact to pull (the hand module's
    contact_lost), and leaving the wall, the floor or both is not consistent either
    (except near the wall): no solution at all, a genuine Painleve paradox."""
    none = 0
    for phi in np.linspace(0.05, 1.5, 15):
        hand = phasemap.classify(hand_ladder.MODEL, phi=phi, omega=1.0, f=3.0)
        assert hand.n_solutions == 0 and hand.contact_lost and not hand.singular
        c = phasemap.classify("ladder", phi=phi, omega=1.0, f=3.0)
        assert c.n_solutions == oracles.ladder(phi, 1.0, 3.0, 1.0, G, 1.0).n_solutions
        assert c.contact_lost == (c.n_solutions > 0) and not c.singular
        none += c.n_solutions == 0
    assert none == 14  # only phi = 0.05 leaves the wall


# ----------------------------------------------------- elliptic pendulum -----
def _lam(phi, f, k):
    return 1 + math.sin(phi) ** 2 - k * f * math.sin(phi) * math.cos(phi)


@pytest.mark.parametrize("f", [3.0, 4.0, 8.0])
def test_elliptic_paradoxes_where_the_paper_says(f):
    """phi in (0, pi/2) with (28): no solution for xdot > 0, two for xdot < 0; unique elsewhere."""
    found = 0
    for phi in np.linspace(0.01, math.pi / 2 - 0.01, 157):
        for omega in (0.0, 0.5, -1.0):
            lam_pos = _lam(phi, f, 1.0)
            if abs(lam_pos) < 1e-6:
                continue
            right = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=1.0, f=f)
            left = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=-1.0, f=f)
            if lam_pos < 0:  # condition (28)
                found += 1
                assert right.n_solutions == 0 and left.n_solutions == 2, (phi, omega)
            else:
                assert right.n_solutions == 1 and left.n_solutions == 1, (phi, omega)
    assert found > 0


def test_elliptic_threshold_is_sharp():
    """Paradox regions exist iff f > 2 sqrt 2 (the paper proves only f <= 2 is safe)."""
    phis = np.linspace(-math.pi, math.pi, 2001)

    def count_paradox(f):
        n = 0
        for phi in phis:
            for xdot in (1.0, -1.0):
                c = phasemap.classify("elliptic_pendulum", phi=phi, omega=0.3, xdot=xdot, f=f)
                n += c.n_solutions != 1
        return n

    assert count_paradox(F_SHARP * (1 - 1e-3)) == 0
    assert count_paradox(F_SHARP * (1 + 1e-2)) > 0
    # lambda = (3 - cos 2phi - f sin 2phi)/2 touches zero at 2 phi = atan2(f, 1)
    phi_star = 0.5 * math.atan2(F_SHARP, 1.0)
    assert _lam(phi_star, F_SHARP, 1.0) == pytest.approx(0.0, abs=1e-12)
    assert phasemap.classify("elliptic_pendulum", phi=phi_star, omega=0.3, xdot=1.0,
                             f=F_SHARP).singular


def test_elliptic_unique_everywhere_below_threshold():
    rng = np.random.default_rng(11)
    for _ in range(3000):
        f = rng.uniform(0, F_SHARP * 0.999)
        phi, omega = rng.uniform(-math.pi, math.pi), rng.normal() * 3
        xdot = rng.choice([-1.0, 1.0]) * rng.uniform(0.01, 5)
        c = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=xdot, f=f)
        assert c.n_solutions == 1, c


def test_elliptic_degenerate_lambda_zero():
    """At lambda = 0 (22)-(25) have no solution unless Q = g + l cos phi omega^2 = 0 too."""
    f = 4.0
    # lambda_{+1}(phi) = 0 at the smaller root in (0, pi/2)
    from scipy.optimize import brentq

    phi0 = brentq(lambda p: _lam(p, f, 1.0), 0.2, 0.6)
    c = phasemap.classify("elliptic_pendulum", phi=phi0, omega=0.0, xdot=1.0, f=f)
    assert c.singular


def test_elliptic_three_isolated_solutions_at_rest():
    """Finding: at xdot = 0 beyond the threshold stick and both N-signs of one slide coexist."""
    phi, omega, f = 2.344, -3.596, 7.152
    c = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=0.0, f=f)
    names = {b.name for b in c.branches}
    assert c.n_solutions == 4 and c.solvability is phasemap.Solvability.THREE_OR_MORE
    assert names == {"stick", "slide_pos_Npos", "slide_pos_Nneg"}
    # the independent two-particle solve agrees that all three are admissible
    stick = ref.elliptic_stick(phi, omega, f, 1.0, G, 1.0)
    assert abs(stick["F"]) <= f * abs(stick["N"])
    for rho in (1.0, -1.0):
        sol = ref.elliptic_slip(phi, omega, 0.0, f, 1.0, G, 1.0, 1.0, rho)
        assert rho * sol["N"] > 0 and sol["x_ddot"] > 0


# --------------------------------------------------------- hinge pendulum -----
def test_hinge_no_solution_for_delta_above_l():
    rng = np.random.default_rng(5)
    checked = 0
    while checked < 500:
        l = rng.uniform(0.2, 3)
        delta = l * rng.uniform(1.001, 4)
        phi, omega = rng.uniform(-4, 4), rng.normal() * 3
        if omega == 0 or abs(l * omega ** 2 + G * math.cos(phi)) < 1e-6:
            continue
        c = phasemap.classify("hinge_pendulum", phi=phi, omega=omega, delta=delta, l=l)
        assert c.n_solutions == 0 and not c.singular, c
        checked += 1


def test_hinge_beyond_paper_solution_where_the_reaction_vanishes():
    """For delta > l the state with l omega^2 + g cos phi = 0 still moves (R = 0, no friction)."""
    phi = 2.5
    omega = math.sqrt(-G * math.cos(phi))
    c = phasemap.classify("hinge_pendulum", phi=phi, omega=omega, delta=2.0)
    assert c.n_solutions == 1
    assert c.branches[0].accelerations["phi_ddot"] == pytest.approx(-G * math.sin(phi))
    # at delta = l the same state has a continuum of solutions
    c = phasemap.classify("hinge_pendulum", phi=phi, omega=omega, delta=1.0)
    assert c.singular and c.n_solutions == 3


def test_hinge_unique_below_l():
    for phi in np.linspace(-3, 3, 31):
        for omega in (-2.0, 0.7):
            c = phasemap.classify("hinge_pendulum", phi=phi, omega=omega, delta=0.6)
            assert c.n_solutions == 1


# ------------------------------------------------------------------ wheel -----
def test_wheel_rests_everywhere_and_moves_one_way_for_delta_at_least_l():
    """delta >= l: every angle is in the stagnation zone, and it never rolls back from rest."""
    for phi in np.linspace(-math.pi, math.pi, 61):
        c = phasemap.classify("wheel", phi=phi, omega=0.0, delta=0.6, l=0.5)
        assert c.stagnation and c.n_solutions == 1, c


def test_wheel_bounces_when_spinning_fast():
    """Condition (12): at high speed with the centre of mass high the wheel leaves the floor:
    rolling on would need the floor to pull (the hand module), and the hop is the unique
    solution."""
    hand = phasemap.classify(hand_wheel.MODEL, phi=math.pi, omega=10.0)
    assert hand.contact_lost and hand.n_solutions == 0
    c = phasemap.classify("wheel", phi=math.pi, omega=10.0)
    assert c.contact_lost and c.n_solutions == 1 and c.branches[0].name == "floor_separated"
    c = phasemap.classify("wheel", phi=0.0, omega=10.0)
    assert not c.contact_lost and c.n_solutions == 1


def test_hinge_beyond_paper_two_solutions_at_horizontal_rest_for_delta_above_l():
    """delta > l at phi = pi/2, omega = 0: rest, and free fall with R = 0 (no friction) too."""
    c = phasemap.classify("hinge_pendulum", phi=math.pi / 2, omega=0.0, delta=2.0)
    assert c.n_solutions == 2 and c.stagnation
    fall = {b.name: b for b in c.branches}["turn_neg"]
    assert fall.accelerations["phi_ddot"] == pytest.approx(-G)
    assert fall.reactions["R_t"] == pytest.approx(0.0, abs=1e-12)
