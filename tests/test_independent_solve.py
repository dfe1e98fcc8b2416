"""phasemap's closed forms against an independent solve of the unreduced equations.

``reference.py`` solves the full Newton-Euler systems (accelerations and
reactions together) with numpy's linear algebra, the ladder's rest with a
linear program and the hinge pendulum's unsquared irrational equation by
root-finding.  It imports nothing from phasemap.  Here the GUIDE's branch and
admissibility rules are applied to those solutions and compared with
``classify()`` at >= 1000 random states per model, a third of them at zero
relative velocity.  The ladder and the wheel run as declarations
(phasemap.systems.seeds), which also count leaving a contact: the reference's
kept-contact solutions are checked against the hand modules (the paper's closed
forms) and against the running models' kept branches.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import reference as ref
from references import ladder as hand_ladder
from references import wheel as hand_wheel

import phasemap

N_STATES = 1000
RTOL = 1e-7


def _close(a, b, scale):
    return abs(a - b) <= RTOL * (abs(a) + abs(b) + scale)


def _code(n_isolated: int) -> int:
    return 4 if n_isolated >= 3 else n_isolated


def _check_branches(c, expected, scale, kept_only=False):
    """Every admissible branch phasemap reports has the reference's numbers
    (``kept_only``: every branch that keeps the contacts; separations aside)."""
    got = {b.name: b for b in c.branches
           if not kept_only or b.status == phasemap.BranchStatus.ADMISSIBLE}
    assert set(got) == set(expected), (c, expected)
    for name, numbers in expected.items():
        b = got[name]
        for key, value in numbers.items():
            mine = {**b.accelerations, **b.reactions}[key]
            assert _close(mine, value, scale), (c, name, key, value)


def _check_state(c, run, expected, stagnation, lost, scale):
    """At one state, the hand module (``c``) against the reference's ``expected`` branches
    and its stagnation and lost contact; the running model (``run``) against its kept
    branches and stagnation."""
    assert c.n_solutions == _code(len(expected)), c
    assert c.stagnation == stagnation, c
    assert c.contact_lost == lost, c
    _check_branches(c, expected, scale)
    _check_branches(run, expected, scale, kept_only=True)
    assert run.stagnation == stagnation


def _moving_branches(omega, names, solve, keeps_contact):
    """The reference's branches in the directions +1 and -1 (``names``) that apply at
    ``omega`` and start in their direction from rest: ``{name: solve(s)}`` for those
    that keep the contact, and whether one of them would need it to pull."""
    expected, lost = {}, False
    for s, name in zip((1.0, -1.0), names):
        if omega != 0.0 and s * omega < 0:
            continue
        sol = solve(s)
        if omega == 0.0 and not s * sol["phi_ddot"] > 0:
            continue
        if keeps_contact(sol):
            expected[name] = sol
        else:
            lost = True
    return expected, lost


def _far_from_singular(c, tol=1e-6):
    return all(abs(b.coefficient) > tol or math.isnan(b.coefficient) for b in c.candidates)


def _sample_states(seed, check_one):
    """``check_one(rng)`` on random states until ``N_STATES`` were checked; it returns the
    state's omega, or None where it skipped the state.  A quarter of them must be at rest."""
    rng = np.random.default_rng(seed)
    checked = at_rest = 0
    while checked < N_STATES:
        omega = check_one(rng)
        if omega is None:
            continue
        checked += 1
        at_rest += omega == 0.0
    assert at_rest > 250


def test_ladder_against_unreduced_newton_euler():
    def check_one(rng):
        phi = rng.uniform(0.0, math.pi / 2)
        f = rng.choice([rng.uniform(0, 1.3), rng.uniform(1.5, 4)])
        l, g, m = rng.uniform(0.2, 3), rng.uniform(0.5, 20), rng.uniform(0.1, 5)
        omega = 0.0 if rng.random() < 1 / 3 else rng.normal() * 3 * math.sqrt(g / l)
        c = phasemap.classify(hand_ladder.MODEL, phi=phi, omega=omega, f=f, l=l, g=g, m=m)
        run = phasemap.classify("ladder", phi=phi, omega=omega, f=f, l=l, g=g, m=m)
        scale = m * g
        expected, lost = _moving_branches(
            omega, ("slide_pos", "slide_neg"),
            lambda s: ref.ladder_slip(phi, omega, f, l, g, m, s),
            lambda r: r["N_floor"] >= 0 and r["N_wall"] >= 0)
        stagnation = omega == 0.0 and ref.ladder_can_rest(phi, f, l, g, m)
        if stagnation:
            expected["stick"] = {"phi_ddot": 0.0}
        numbers = {k: {"phi_ddot": v["phi_ddot"]} if k == "stick" else
                   {q: v[q] for q in ("phi_ddot", "N_floor", "N_wall")}
                   for k, v in expected.items()}
        _check_state(c, run, numbers, stagnation, lost, scale)
        return omega

    _sample_states(1, check_one)


def test_wheel_against_unreduced_newton_euler():
    def check_one(rng):
        state = hand_wheel.random_state(rng)
        phi, omega, delta, r, l, rho, g, m = state.values()
        c = phasemap.classify(hand_wheel.MODEL, **state)
        run = phasemap.classify("wheel", **state)
        if not _far_from_singular(c):
            return None
        expected, lost = _moving_branches(
            omega, ("roll_pos", "roll_neg"),
            lambda s: ref.wheel_roll(phi, omega, delta, r, l, rho, g, m, s),
            lambda sol: sol["N"] >= 0)
        expected = {name: {q: sol[q] for q in ("phi_ddot", "N", "F")}
                    for name, sol in expected.items()}
        if omega == 0.0:
            rest = ref.wheel_rest_moment(phi, delta, r, l, rho, g, m)
            stagnation = abs(rest["M"]) <= delta * rest["N"]
            if stagnation:
                expected["stick"] = {"phi_ddot": 0.0, "N": rest["N"], "F": rest["F"]}
        else:
            stagnation = False
        _check_state(c, run, expected, stagnation, lost, m * g)
        return omega

    _sample_states(2, check_one)


def test_elliptic_pendulum_against_two_particle_newton():
    rng = np.random.default_rng(3)
    checked = at_rest = 0
    names = {(1, 1): "slide_pos_Npos", (1, -1): "slide_pos_Nneg", (-1, 1): "slide_neg_Npos", (-1, -1): "slide_neg_Nneg"}
    seen = set()
    while checked < N_STATES:
        f = rng.choice([rng.uniform(0, 2.8), rng.uniform(2.9, 10)])
        l, g, m = rng.uniform(0.2, 3), rng.uniform(0.5, 20), rng.uniform(0.1, 5)
        phi = rng.uniform(-math.pi, math.pi)
        omega = rng.normal() * rng.choice([0.3, 1, 3]) * math.sqrt(g / l)
        xdot = 0.0 if rng.random() < 1 / 3 else rng.normal() * math.sqrt(g * l)
        c = phasemap.classify("elliptic_pendulum", phi=phi, omega=omega, xdot=xdot, f=f, l=l,
                              g=g, m=m)
        if not _far_from_singular(c):
            continue
        expected = {}
        for (sigma, rho), name in names.items():
            if xdot != 0.0 and sigma * xdot < 0:
                continue
            sol = ref.elliptic_slip(phi, omega, xdot, f, l, g, m, sigma, rho)
            if rho * sol["N"] > 0 and (xdot != 0.0 or sigma * sol["x_ddot"] > 0):
                expected[name] = {q: sol[q] for q in ("x_ddot", "phi_ddot", "N", "F")}
        stagnation = False
        if xdot == 0.0:
            st = ref.elliptic_stick(phi, omega, f, l, g, m)
            stagnation = abs(st["F"]) <= f * abs(st["N"])
            if stagnation:
                expected["stick"] = {q: st[q] for q in ("x_ddot", "phi_ddot", "N", "F")}
        assert c.n_solutions == _code(len(expected)), c
        assert c.stagnation == stagnation, c
        assert not c.contact_lost
        _check_branches(c, expected, m * (g + l * omega ** 2))
        seen.add((xdot == 0.0, c.n_solutions))
        checked += 1
        at_rest += xdot == 0.0
    assert at_rest > 250
    # The sample reaches the paradoxes, not only the unique case.
    assert {(False, 0), (False, 1), (False, 2), (True, 1), (True, 4)} <= seen


def test_hinge_pendulum_against_unsquared_equation():
    rng = np.random.default_rng(4)
    checked = at_rest = 0
    while checked < N_STATES:
        l, g, m = rng.uniform(0.2, 3), rng.uniform(0.5, 20), rng.uniform(0.1, 5)
        delta = l * rng.choice([rng.uniform(0, 0.99), rng.uniform(1.01, 3)])
        phi = rng.uniform(-2 * math.pi, 2 * math.pi)
        omega = 0.0 if rng.random() < 1 / 3 else rng.normal() * 2 * math.sqrt(g / l)
        c = phasemap.classify("hinge_pendulum", phi=phi, omega=omega, delta=delta, l=l, g=g, m=m)
        expected = {}
        for s, name in ((1.0, "turn_pos"), (-1.0, "turn_neg")):
            if omega != 0.0 and s * omega < 0:
                continue
            roots = ref.hinge_roots(phi, omega, delta, l, g, m, s)
            if omega == 0.0:
                roots = [a for a in roots if s * a > 0]
            assert len(roots) <= 1
            if roots:
                expected[name] = {"phi_ddot": roots[0]}
        stagnation = omega == 0.0 and ref.hinge_rest(phi, delta, l, g, m)
        if stagnation:
            expected["stick"] = {"phi_ddot": 0.0}
        assert c.n_solutions == _code(len(expected)), c
        assert c.stagnation == stagnation, c
        # the root finder brackets roots to ~1e-10 of the acceleration scale
        got = {b.name: b.accelerations["phi_ddot"] for b in c.branches}
        for name, numbers in expected.items():
            assert abs(got[name] - numbers["phi_ddot"]) <= 1e-8 * (g / l + omega ** 2 + 1)
        checked += 1
        at_rest += omega == 0.0
    assert at_rest > 250


@pytest.mark.parametrize("f", [0.0, 0.3, 1.0, 2.5])
def test_ladder_reactions_at_rest_satisfy_statics(f):
    """The reported rest reactions balance the bar with friction inside its cone, up to
    and including the bar lying flat (phi = pi/2, where the floor's tangent is the
    wall's normal).  Tangents are the normals turned clockwise: +x on the floor, -y
    on the wall."""
    for phi in np.linspace(0, min(2 * math.atan(f), math.pi / 2), 7):
        c = phasemap.classify("ladder", phi=phi, omega=0.0, f=f, g=9.81, m=2.0)
        r = {b.name: b for b in c.branches}["stick"].reactions
        w, s, co = 2.0 * 9.81, math.sin(phi), math.cos(phi)
        assert abs(r["N_wall"] + r["F_floor"]) < 1e-9 * w
        assert abs(r["N_floor"] - r["F_wall"] - w) < 1e-9 * w
        torque = s * r["N_floor"] + co * r["F_floor"] + s * r["F_wall"] - co * r["N_wall"]
        assert abs(torque) < 1e-9 * w
        assert r["N_floor"] >= 0 and r["N_wall"] >= -1e-12
        assert abs(r["F_floor"]) <= f * r["N_floor"] + 1e-9 * w
        assert abs(r["F_wall"]) <= f * r["N_wall"] + 1e-9 * w
