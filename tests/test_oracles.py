"""The full-coordinate oracles of ``oracles.py`` validated on their own.

Against the hand models (``references.ladder.MODEL`` and ``references.wheel.MODEL``,
the paper's equations) wherever the hand model keeps its contacts, against the
running (declared) ladder and wheel everywhere, and against closed forms derived by hand (Painleve rod:
B N = m (g - l sin(theta) omega^2), the pivot (stick) solution, the threshold
f = 4/3 at tan(theta) = 2; rod on a step: the kept-kept coefficient and its
threshold f = 2/sqrt(3)).  States close to a tie of a decisive inequality
(relative margin below 1e-7) are skipped and counted.
"""

from __future__ import annotations

import math

import numpy as np
import oracles as O
from references import ladder as hand_ladder
from references import wheel as hand_wheel

import phasemap

N_STATES = 1000
MARGIN = 1e-7


def _close(a, b, scale, rtol=1e-7):
    return abs(a - b) <= rtol * (abs(a) + abs(b) + scale)


# ---------------------------------------------------------------------------
# Painleve rod
# ---------------------------------------------------------------------------

def _rod_state(rng, f=None):
    f = rng.choice([rng.uniform(0, 1.3), rng.uniform(1.4, 4)]) if f is None else f
    l, g, m = rng.uniform(0.2, 3), rng.uniform(0.5, 20), rng.uniform(0.1, 5)
    theta = rng.uniform(0.01, math.pi - 0.01)
    omega = rng.normal() * rng.choice([0.3, 1, 3]) * math.sqrt(g / l)
    xdot = 0.0 if rng.random() < 1 / 3 else rng.normal() * math.sqrt(g * l)
    return theta, omega, xdot, f, l, g, m


def test_painleve_rod_against_closed_forms():
    rng = np.random.default_rng(11)
    checked = at_rest = skipped = 0
    seen = set()
    while checked < N_STATES:
        theta, omega, xdot, f, l, g, m = st = _rod_state(rng)
        a = O.painleve_rod(*st)
        if a.margin < MARGIN:
            skipped += 1
            continue
        got = a.by_modes()
        rhs = g - l * math.sin(theta) * omega ** 2          # B N / m
        sep_ok = rhs < 0                                     # free fall opens the gap
        scale = m * (g + l * omega ** 2)
        expected = set()
        if xdot != 0.0:
            s = 1.0 if xdot > 0 else -1.0
            B = O.painleve_rod_B(theta, f, s)
            if abs(B) > 1e-6:
                N = m * rhs / B
                if N >= 0:
                    name = ("slip+",) if s > 0 else ("slip-",)
                    expected.add(name)
                    md = got[name]
                    assert _close(md.N[0], N, scale)
                    assert _close(md.F[0], -s * f * N, scale)
                    tdd = -3.0 / (m * l) * (math.cos(theta) + s * f * math.sin(theta)) * N
                    assert _close(md.qdd[2], tdd, g / l + omega ** 2)
            if sep_ok:
                expected.add(("sep",))
            assert set(got) == expected, (st, got.keys(), expected)
            n = len(expected)
            assert a.n_solutions == n
            seen.add((s * math.cos(theta) < 0, B > 0, n))
        else:
            # stick: A is a pivot, (4/3) m l^2 theta'' = -m g l cos(theta)
            tdd = -3.0 * g * math.cos(theta) / (4.0 * l)
            ax = -l * math.sin(theta) * tdd - l * math.cos(theta) * omega ** 2
            ay = l * math.cos(theta) * tdd - l * math.sin(theta) * omega ** 2
            N, F = m * (ay + g), m * ax
            stick = N >= 0 and abs(F) <= f * N
            assert a.stagnation == stick
            if stick:
                md = got[("stick",)]
                assert _close(md.N[0], N, scale) and _close(md.F[0], F, scale)
                assert _close(md.qdd[2], tdd, g / l + omega ** 2)
            assert (("sep",) in got) == sep_ok
            if f < 4.0 / 3.0:
                # below the threshold the zero-slip problem is always uniquely solvable
                assert a.n_solutions == 1, (st, list(got))
            at_rest += 1
        checked += 1
    assert at_rest > 250 and skipped < 50
    # the sample reaches unique, none and two
    assert {n for *_, n in seen} >= {0, 1, 2}


def test_painleve_rod_threshold_is_four_thirds_at_arctan_two():
    f_min, theta_star = O.painleve_rod_threshold()
    # closed form: B(theta, f, s=-1) = 0 needs f = (1 + 3 cos^2) / (3 sin cos) = (4 + t^2) / (3 t)
    th = np.linspace(1e-4, math.pi / 2 - 1e-4, 200001)
    need = (1 + 3 * np.cos(th) ** 2) / (3 * np.sin(th) * np.cos(th))
    k = int(np.argmin(need))
    assert abs(need[k] - 4 / 3) < 1e-8 and abs(th[k] - math.atan(2.0)) < 1e-4
    assert f_min == 4 / 3 and abs(theta_star - math.atan(2.0)) < 1e-15
    assert abs(math.degrees(theta_star) - 63.4349488) < 1e-6
    l, g, m = 1.0, 9.81, 1.0
    # just above: none at rest-like omega, two when l sin(theta) omega^2 > g; mirror for xdot > 0
    for theta, xdot in ((theta_star, -1.0), (math.pi - theta_star, 1.0)):
        assert O.painleve_rod(theta, 0.0, xdot, 4 / 3 + 1e-3, l, g, m).n_solutions == 0
        w = 1.2 * math.sqrt(g / (l * math.sin(theta)))
        two = O.painleve_rod(theta, w, xdot, 4 / 3 + 1e-3, l, g, m)
        assert two.n_solutions == 2 and {md.modes for md in two.modes} == {("sep",), (("slip+",) if xdot > 0 else ("slip-",))[0:1]}
        # exactly at the threshold the state is singular with a positive right side: none
        assert O.painleve_rod(theta, 0.0, xdot, 4 / 3, l, g, m).n_solutions == 0
        # just below: unique
        assert O.painleve_rod(theta, 0.0, xdot, 4 / 3 - 1e-3, l, g, m).n_solutions == 1
        assert O.painleve_rod(theta, w, xdot, 4 / 3 - 1e-3, l, g, m).n_solutions == 1
    # below 4/3 no state has a paradox (random states, both slip signs and zero slip)
    rng = np.random.default_rng(12)
    for _ in range(400):
        st = _rod_state(rng, f=rng.uniform(0, 4 / 3 - 1e-3))
        a = O.painleve_rod(*st)
        assert a.n_solutions == 1 or a.margin < MARGIN, (st, a.n_solutions)


# ---------------------------------------------------------------------------
# Ladder and wheel against the hand models
# ---------------------------------------------------------------------------

_LADDER_NAMES = {("slip+", "slip-"): "slide_pos", ("slip-", "slip+"): "slide_neg",
                 ("stick", "stick"): "stick"}


def test_ladder_against_hand_model():
    rng = np.random.default_rng(13)
    checked = at_rest = skipped = added = 0
    while checked < N_STATES:
        phi = rng.uniform(0.01, math.pi / 2 - 0.01)
        f = rng.choice([rng.uniform(0, 1.3), rng.uniform(1.5, 4)])
        l, g, m = rng.uniform(0.2, 3), rng.uniform(0.5, 20), rng.uniform(0.1, 5)
        omega = 0.0 if rng.random() < 1 / 3 else rng.normal() * 3 * math.sqrt(g / l)
        a = O.ladder(phi, omega, f, l, g, m)
        if a.margin < MARGIN:
            skipped += 1
            continue
        c = phasemap.classify(hand_ladder.MODEL, phi=phi, omega=omega, f=f, l=l, g=g, m=m)
        run = phasemap.classify("ladder", phi=phi, omega=omega, f=f, l=l, g=g, m=m)
        assert (run.n_solutions, run.stagnation) == (a.n_solutions, a.stagnation)
        kept = {_LADDER_NAMES[md.modes]: md for md in a.all_kept}
        hand = {b.name: b for b in c.branches}
        assert set(kept) == set(hand), (phi, omega, f, kept.keys(), hand.keys())
        for name, b in hand.items():
            md = kept[name]
            assert _close(md.qdd[2], b.accelerations["phi_ddot"], g / l + omega ** 2)
            if name != "stick":           # at rest the reactions are statically indeterminate
                assert _close(md.N[0], b.reactions["N_floor"], m * g)
                assert _close(md.N[1], b.reactions["N_wall"], m * g)
        assert a.stagnation == c.stagnation
        if not c.contact_lost and not a.separating:
            assert a.n_solutions == c.n_solutions
        added += bool(a.separating)
        checked += 1
        at_rest += omega == 0.0
    assert at_rest > 250 and skipped < 50 and added > 50


def test_wheel_against_hand_model():
    rng = np.random.default_rng(14)
    checked = at_rest = skipped = hops = 0
    while checked < N_STATES:
        state = hand_wheel.random_state(rng)
        phi, omega, delta, r, l, rho, g, m = state.values()
        c = phasemap.classify(hand_wheel.MODEL, **state)
        run = phasemap.classify("wheel", **state)
        a = O.wheel(phi, omega, delta, r, l, rho, g, m)
        if c.singular or a.margin < MARGIN or any(abs(b.coefficient) < 1e-6 for b in c.candidates
                                                  if not math.isnan(b.coefficient)):
            skipped += 1
            continue
        names = {("roll+",): "roll_pos", ("roll-",): "roll_neg", ("rest",): "stick"}
        kept = {names[md.modes]: md for md in a.all_kept}
        hand = {b.name: b for b in c.branches}
        assert set(kept) == set(hand), (phi, omega, delta, kept.keys(), hand.keys())
        for name, b in hand.items():
            md = kept[name]
            assert _close(-md.qdd[2], b.accelerations["phi_ddot"], g / r + omega ** 2)
            assert _close(md.N[0], b.reactions["N"], m * g)
            assert _close(md.F[0], b.reactions["F"], m * g)
        assert a.stagnation == c.stagnation
        if not c.contact_lost:
            assert not a.separating and a.n_solutions == c.n_solutions
        assert (run.n_solutions, run.stagnation) == (a.n_solutions, a.stagnation)
        hops += bool(a.separating)
        checked += 1
        at_rest += omega == 0.0
    assert at_rest > 250 and skipped < 100 and hops > 10


# ---------------------------------------------------------------------------
# What counting separation changes (docs/systems/separation_findings.md)
# ---------------------------------------------------------------------------

def _hand_and_running(name, **values):
    hand = {"ladder": hand_ladder, "wheel": hand_wheel}[name].MODEL
    return phasemap.classify(hand, **values), phasemap.classify(name, **values)


def test_separation_findings_examples():
    """What counting separation changes: the hand module (contacts kept) against the
    oracle and against the running, declared model."""
    # ladder, the example: hand "none" + contact_lost; the ladder leaves the wall
    c, run = _hand_and_running("ladder", phi=0.5, omega=3.0, f=0.3)
    a = O.ladder(0.5, 3.0, 0.3, 1.0, 9.81, 1.0)
    assert c.n_solutions == 0 and c.contact_lost
    assert a.n_solutions == 1 and [md.modes for md in a.modes] == [("slip+", "sep")]
    assert run.n_solutions == 1 and run.contact_lost
    assert [b.name for b in run.branches] == ["floor_slip_pos_wall_separated"]
    # ladder, f > sqrt 2: the hand model's unique slide gains a second solution (leaving the wall)
    c, run = _hand_and_running("ladder", phi=0.962, omega=3.0, f=1.469)
    a = O.ladder(0.962, 3.0, 1.469, 1.0, 9.81, 1.0)
    assert c.n_solutions == 1 and not c.contact_lost
    assert a.n_solutions == 2 and {md.modes for md in a.modes} == {("slip+", "slip-"),
                                                                      ("slip+", "sep")}
    assert run.n_solutions == 2 and {b.name for b in run.branches} == {
        "slide_pos", "floor_slip_pos_wall_separated"}
    # ladder, f > sqrt 2: neither sliding nor leaving a contact is consistent: none stays none
    a = O.ladder(0.128, 3.0, 2.816, 1.0, 9.81, 1.0)
    assert a.n_solutions == 0
    assert phasemap.classify("ladder", phi=0.128, omega=3.0, f=2.816).n_solutions == 0
    # ladder at rest (the default map): nothing changes
    for phi in np.linspace(0.05, 1.5, 12):
        for f in np.linspace(0.05, 2.9, 12):
            c, run = _hand_and_running("ladder", phi=phi, omega=0.0, f=f)
            n = O.ladder(phi, 0.0, f, 1.0, 9.81, 1.0).n_solutions
            assert n == c.n_solutions == run.n_solutions
    # wheel spinning fast with its centre of mass high: it hops
    w = dict(r=1.0, l=0.5, rho=0.5, g=9.81, m=1.0)
    c, run = _hand_and_running("wheel", phi=-3.013, omega=6.0, delta=0.02, **w)
    a = O.wheel(-3.013, 6.0, 0.02, **w)
    assert c.n_solutions == 0 and c.contact_lost and a.n_solutions == 1
    assert a.modes[0].modes == ("sep",)
    assert run.n_solutions == 1 and [b.name for b in run.branches] == ["floor_separated"]
    # ... but in a band before the top neither rolling nor hopping is consistent
    c, run = _hand_and_running("wheel", phi=-2.116, omega=6.0, delta=0.02, **w)
    a = O.wheel(-2.116, 6.0, 0.02, **w)
    assert c.n_solutions == 0 and c.contact_lost and a.n_solutions == 0
    assert run.n_solutions == 0


# ---------------------------------------------------------------------------
# Rod on a step (docs/systems/rod_on_step.md)
# ---------------------------------------------------------------------------

def _step_D(theta, a, f, fe, s):
    """Kept-kept coefficient (up to a negative factor), a = AK / l; docs eq. (S3)."""
    S, C = math.sin(theta), math.cos(theta)
    return (3 * a * a - (6 * a - 4) * S * S - f * fe * (3 * a - 4) * S * S
            + s * f * (3 * a - 2) * 2 * S * C - s * fe * (3 * a - 4) * S * C)


def test_rod_on_step_power_balance_and_kinematics():
    """Every admissible kept-kept slip: C moves on its constrained path, and
    dE/dt equals the friction power (normals do no work), which is negative."""
    rng = np.random.default_rng(15)
    checked = kept_seen = 0
    while checked < N_STATES:
        hl = rng.uniform(0.05, 1.95)
        l = rng.uniform(0.2, 3)
        h = hl * l
        theta = rng.uniform(math.asin(hl / 2) + 1e-3, math.pi / 2 - 1e-3)
        f, fe = rng.uniform(0, 3), rng.uniform(0, 3)
        g, m = rng.uniform(0.5, 20), rng.uniform(0.1, 5)
        omega = 0.0 if rng.random() < 1 / 3 else rng.normal() * 3 * math.sqrt(g / l)
        a = O.rod_on_step(theta, omega, f, l, h, g, m, f_edge=fe)
        S, C = math.sin(theta), math.cos(theta)
        xAd = h * omega / S ** 2
        vC = np.array([xAd - l * S * omega, l * C * omega])
        v1, v2 = xAd, h * C * omega / S ** 2          # slip velocities (floor, edge)
        for md in a.all_kept:
            tdd = md.qdd[2]
            # C = (-h cot th + l cos th, l sin th) differentiated twice
            xdd = (h / S ** 2 - l * S) * tdd - (2 * h * C / S ** 3 + l * C) * omega ** 2
            ydd = l * C * tdd - l * S * omega ** 2
            acc = g / l + omega ** 2 * (1 + (h / (l * S * S)) ** 2) ** 2
            assert _close(md.qdd[0], xdd, l * acc) and _close(md.qdd[1], ydd, l * acc)
            if omega != 0.0:
                power = (m * vC @ md.qdd[:2] + m * l * l / 3 * omega * tdd + m * g * vC[1])
                friction = md.F[0] * v1 + md.F[1] * v2
                assert _close(power, friction, m * l * acc * (abs(omega) * l + abs(v1) + abs(v2)))
                assert friction <= 1e-9 * m * l * acc * (abs(v1) + abs(v2))
                kept_seen += 1
        checked += 1
    assert kept_seen > 100


def test_rod_on_step_rest_is_ambiguous_at_realistic_friction():
    """At rest, f = 0.5: rest (statically indeterminate) and sliding down from rest
    are both consistent.  The sliding numbers come from an independent sympy
    elimination of the three Newton-Euler equations (docs/systems/rod_on_step.md)."""
    a = O.rod_on_step(1.3047794052912547, 0.0, 0.5, 1.0, 0.6025747839173072, 9.81, 1.0)
    got = a.by_modes()
    assert a.n_solutions == 2 and a.stagnation
    assert set(got) == {("stick", "stick"), ("slip-", "slip-")}
    md = got[("slip-", "slip-")]
    assert _close(md.qdd[2], -0.08168505783908081, 10.0)
    assert _close(md.N[0], 6.779998502155996, 10.0) and _close(md.N[1], 4.036647790821362, 10.0)
    assert got[("stick", "stick")].indeterminate


def test_rod_on_step_threshold_two_over_root_three():
    f_star, a_star, t_star = 2 / math.sqrt(3), 5 / 3, math.atan(5 / math.sqrt(3))
    # the closed form has a double root there: D = 0 and grad D = 0 in (theta, a)
    eps = 1e-6
    assert abs(_step_D(t_star, a_star, f_star, f_star, -1)) < 1e-12
    for dt, da in ((eps, 0), (0, eps)):
        d = (_step_D(t_star + dt, a_star + da, f_star, f_star, -1)
             - _step_D(t_star - dt, a_star - da, f_star, f_star, -1)) / (2 * eps)
        assert abs(d) < 1e-8
    # and it is the minimum: below f_star, D keeps one sign over the whole (theta, a) range
    th = np.linspace(1e-3, math.pi / 2 - 1e-3, 600)[:, None]
    av = np.linspace(1e-3, 2.0, 600)[None, :]
    for f in (f_star - 1e-3, 0.5):
        for s in (1, -1):
            S, C = np.sin(th), np.cos(th)
            D = (3 * av * av - (6 * av - 4) * S * S - f * f * (3 * av - 4) * S * S
                 + s * f * (3 * av - 2) * 2 * S * C - s * f * (3 * av - 4) * S * C)
            assert D.min() > 0
    # at the critical geometry the kept-kept mode is not the admissible one: the rod
    # leaves the floor or the edge, so the singularity does not change the count there
    l, g, m = 1.0, 9.81, 1.0
    h = a_star * math.sin(t_star) * l
    assert abs(h - 25 / (6 * math.sqrt(7))) < 1e-12
    for f in (f_star - 1e-3, f_star + 1e-3):
        for w in (-0.1, -1.0, -3.0):
            ans = O.rod_on_step(t_star, w, f, l, h, g, m)
            assert ans.n_solutions == 1 and not ans.all_kept
