"""phase_curve: stage by stage omega(phi) against independent integrations in time.

The motion equations below are written out here from the derivations in the
model docstrings (not imported from phasemap) and integrated in *time* with
scipy's DOP853 at rtol 1e-12; the reactions at events come from the unreduced
Newton-Euler solves of ``reference.py``.  Stop and reversal decisions of the
reference use the stagnation zones derived by hand (ladder phi <= 2 arctan f,
wheel and pendulum l |sin phi| <= delta).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import reference as ref
import xarray as xr
from references import ladder as hand_ladder
from scipy.integrate import solve_ivp

from phasemap.motion import phase
from phasemap.core.events import Event
from phasemap.motion.phase import phase_curve

#: The tracer against references that keep the contacts (the paper's equations) runs on
#: the hand modules; the running ladder and wheel also count leaving a contact, which
#: ends some of these curves earlier (test_running_models_end_where_the_oracle_says).
HAND = {"ladder": hand_ladder.MODEL}

G = 9.81


# ------------------------------------------------ independent equations -----
def ladder_acc(phi, w, s, f, l):
    """(8) with the length restored: 2 l (2 - f^2) phi'' = 3 [2 s f l w^2 - 2 s f g cos + (1 - f^2) g sin]."""
    return 3.0 * (2 * s * f * l * w * w - 2 * s * f * G * math.cos(phi)
                  + (1 - f * f) * G * math.sin(phi)) / (2 * l * (2 - f * f))


def wheel_acc(phi, w, s, delta, r, l, rho):
    """(13), minus sign on the w^2 term (erratum)."""
    sp, cp = math.sin(phi), math.cos(phi)
    return ((-l * (r * sp + delta * s * cp) * w * w - G * l * sp - delta * s * G)
            / (rho ** 2 + r ** 2 + l ** 2 - 2 * r * l * cp + delta * s * l * sp))


def hinge_acc(phi, w, s, delta, l):
    """(34): l phi'' = -g sin phi - s delta |l w^2 + g cos phi| / sqrt(l^2 - delta^2)."""
    return (-G * math.sin(phi) - s * delta * abs(l * w * w + G * math.cos(phi))
            / math.sqrt(l * l - delta * delta)) / l


def ladder_reactions(phi, w, s, f, l):
    r = ref.ladder_slip(phi, w, f, l, G, 1.0, s)
    return r["N_floor"], r["N_wall"]


def wheel_normal(phi, w, s, delta, r, l, rho):
    return ref.wheel_roll(phi, w, delta, r, l, rho, G, 1.0, s)["N"]


class System:
    """An independently written system: acceleration, rest zone, one-sided contacts."""

    def __init__(self, name, acc, rests, contacts=None, **params):
        self.name, self.params = name, params
        self.acc = lambda phi, w, s: acc(phi, w, s, **params)
        self.rests = lambda phi: rests(phi, **params)
        self.contacts = (lambda phi, w, s: contacts(phi, w, s, **params)) if contacts else None


def ladder(f, l=1.0):
    return System("ladder", ladder_acc,
                  lambda phi, f, l: phi <= 2 * math.atan(f) + 1e-12,
                  ladder_reactions, f=f, l=l)


def wheel(delta, r=1.0, l=0.5, rho=0.5):
    return System("wheel", wheel_acc,
                  lambda phi, delta, r, l, rho: l * abs(math.sin(phi)) <= delta + 1e-12,
                  lambda *a, **k: (wheel_normal(*a, **k),), delta=delta, r=r, l=l, rho=rho)


def hinge(delta, l=1.0):
    return System("hinge_pendulum", hinge_acc,
                  lambda phi, delta, l: l * abs(math.sin(phi)) <= delta + 1e-12,
                  delta=delta, l=l)


def reference_stage(system, phi, w, s, lo, hi, method):
    """One stage of constant s by time integration: (sol, kind, phi_end, omega_end)."""
    def stop_zero(t, y):
        return y[1]

    def leave(t, y):
        return y[0] - (hi if s > 0 else lo)

    def contact(j):
        def reaction(t, y):
            return system.contacts(y[0], y[1], s)[j]
        reaction.terminal, reaction.direction = True, -1
        return reaction

    stop_zero.terminal, stop_zero.direction = True, -s
    leave.terminal, leave.direction = True, s
    events = [stop_zero, leave]
    if system.contacts is not None:
        events += [contact(j) for j in range(len(system.contacts(phi, w, s)))]
    sol = solve_ivp(lambda t, y: (y[1], system.acc(y[0], y[1], s)), (0.0, 100.0), (phi, w),
                    method=method, rtol=1e-12, atol=1e-12, dense_output=True, events=events)
    hit = [i for i, te in enumerate(sol.t_events) if te.size]
    assert hit, "the reference stage did not end within 100 s"
    i = min(hit, key=lambda i: sol.t_events[i][0])
    phi_e, w_e = sol.y_events[i][0]
    if i == 0:
        kind = "rest" if system.rests(phi_e) else "reversal"
    else:
        # 0 and pi/2 are the ladder's own domain edges (upright, flat): left_domain
        edge = (hi if s > 0 else lo) in (0.0, math.pi / 2)
        kind = ("left_domain" if edge else "horizon") if i == 1 else "contact_lost"
    return sol, kind, phi_e, w_e


def reference_chain(system, phi0, omega0, lo, hi, max_stages=50, method="DOP853"):
    """Stages of the motion by time integration: [(sol, kind, phi_end, omega_end, s)]."""
    if omega0 == 0.0:
        starts = [s for s in (1.0, -1.0) if s * system.acc(phi0, 0.0, s) > 0]
        if system.rests(phi0) or not starts:
            return []
        s = starts[0]
    else:
        s = math.copysign(1.0, omega0)
    chain = []
    phi, w = phi0, omega0
    while len(chain) < max_stages:
        if system.contacts is not None and min(system.contacts(phi, w, s)) < 0.0:
            chain.append((None, "contact_lost", phi, w, s))
            break
        sol, kind, phi_e, w_e = reference_stage(system, phi, w, s, lo, hi, method)
        chain.append((sol, kind, phi_e, w_e, s))
        if kind != "reversal":
            break
        phi, w, s = phi_e, 0.0, -s
    return chain


def reference_u(sol, phis, s, acc):
    """omega^2 of a (monotone) reference stage at the angles phis.

    The time of each angle comes from a fine table of the dense output and
    Newton steps; the remaining angle error d is corrected to first order,
    u(phi + d) = u(phi) + 2 phi'' d, since u = omega^2 is smooth in phi.
    """
    table_t = np.linspace(0.0, sol.t[-1], 4001)
    t = np.interp(s * phis, s * sol.sol(table_t)[0], table_t)
    for _ in range(3):
        phi, w = sol.sol(t)
        step = np.divide(phis - phi, w, out=np.zeros_like(w), where=np.abs(w) > 1e-3)
        t = np.clip(t + step, 0.0, sol.t[-1])
    phi, w = sol.sol(t)
    d = phis - phi
    assert np.max(np.abs(d)) < 1e-5
    return w ** 2 + 2.0 * np.array([acc(p, v, s) for p, v in zip(phi, w)]) * d


def assert_matches(ds, chain, system, u_scale, tol=1e-8):
    """Same stages, reasons and end points; omega^2 at every output angle within tol * u_scale."""
    assert ds.sizes["stage"] == len(chain)
    reasons = [Event(int(c)).name.lower() for c in ds.stage_end_reason.values]
    assert reasons == [c[1] for c in chain]
    stage_of = ds.point_stage.values
    for i, (sol, kind, phi_e, w_e, s) in enumerate(chain):
        assert ds.stage_sign.values[i] == s
        assert ds.stage_end_phi.values[i] == pytest.approx(phi_e, abs=1e-9)
        assert ds.stage_end_omega.values[i] == pytest.approx(w_e, abs=1e-6 * math.sqrt(u_scale))
        phis = ds.phi.values[stage_of == i]
        u = ds.omega_squared.values[stage_of == i]
        if sol is None:  # ends where it starts
            assert phis.size == 1 and u[0] == pytest.approx(w_e ** 2, rel=1e-15)
            continue
        assert phis.size >= 200
        np.testing.assert_allclose(u, reference_u(sol, phis, s, system.acc), rtol=0,
                                   atol=tol * u_scale)


# ------------------------------------------------ against integration -------
@pytest.mark.parametrize("f, phi0, omega0", [
    (0.3, 1.0, 0.0),     # falls from rest, leaves the floor
    (0.3, 1.2, -1.2),    # thrown up, stops outside the zone, reverses, falls
    (0.5, 0.4, -0.8),    # thrown up, stops inside the zone
    (0.2, 0.1, 2.0),     # the wall would pull at once
    (1.2, 1.0, 1.0),     # high friction: stops at once
    (1.6, 1.3, 3.0),     # f > sqrt 2 (lam < 0): reaches the floor
    (2.5, 1.0, -3.0),    # f > sqrt 2, thrown up: leaves a contact on the way
])
def test_ladder_curve_matches_integration(f, phi0, omega0):
    system = ladder(f, l=0.8)
    ds = phase_curve(HAND["ladder"], phi=phi0, omega=omega0, f=f, l=0.8)
    chain = reference_chain(system, phi0, omega0, 0.0, math.pi / 2)
    assert_matches(ds, chain, system, u_scale=G / 0.8)


@pytest.mark.parametrize("params, phi0, omega0", [
    ({}, 1.0, 0.0),                                       # damped swings to rest
    ({}, 0.0, 7.0),                                       # over the top, then swings
    ({"delta": 0.1, "l": 0.8, "rho": 0.3}, 2.0, 0.0),
    ({"delta": 0.02, "l": 0.3}, 0.5, -3.0),
    ({"delta": 0.3, "l": 0.5}, 0.0, 6.0),                 # delta < l but a wide zone
    ({"delta": 0.6, "l": 0.5}, 0.0, -4.0),                # delta >= l: rest everywhere
])
def test_wheel_curve_matches_integration(params, phi0, omega0):
    full = {"delta": 0.05, "r": 1.0, "l": 0.5, "rho": 0.5, **params}
    system = wheel(**full)
    ds = phase_curve("wheel", phi=phi0, omega=omega0, **full)
    chain = reference_chain(system, phi0, omega0, phi0 - 4 * math.pi, phi0 + 4 * math.pi)
    assert_matches(ds, chain, system, u_scale=G / full["l"])


@pytest.mark.parametrize("delta, phi0, omega0, method", [
    (0.05, 2.5, 0.0, "DOP853"),    # starts where l omega^2 + g cos phi < 0
    (0.05, 0.0, 7.0, "DOP853"),    # over the top once, then swings about phi = 2 pi
    (0.3, 1.5, 0.0, "DOP853"),
    (0.6, 0.0, -9.0, "DOP853"),    # k = 0.75
    (0.1, 3.0, 0.5, "DOP853"),
    (0.999, 2.0, 8.0, "Radau"),    # k = 22: pieces with fast layers (stiff in time)
])
def test_hinge_curve_matches_integration(delta, phi0, omega0, method):
    system = hinge(delta)
    ds = phase_curve("hinge_pendulum", phi=phi0, omega=omega0, delta=delta)
    chain = reference_chain(system, phi0, omega0, phi0 - 4 * math.pi, phi0 + 4 * math.pi,
                            method=method)
    assert_matches(ds, chain, system, u_scale=G)


# ------------------------------------------------ ladder near f = sqrt 2 ----
@pytest.mark.parametrize("df, phi0, omega0, method", [
    # f below sqrt 2: e^{lam (phi - phi0)} grows along the motion (|lam| = 8.5e6)
    (-1e-6, 1.0, 1.0, "DOP853"),    # stops within 5e-8 rad
    (-1e-6, 0.3, -0.5, "DOP853"),   # phi decreasing: stops within 2e-8 rad
    # f above sqrt 2: it decays along the motion, onto a slow curve
    (1e-6, 0.01, -10.0, "DOP853"),  # leaves a contact 6e-6 rad further
    (1e-6, 0.91, 3.0, "Radau"),     # follows the slow curve to the floor (stiff in time)
])
def test_ladder_near_sqrt2_is_finite_and_matches_equation_8(df, phi0, omega0, method):
    f = math.sqrt(2.0) + df
    ds = phase_curve(HAND["ladder"], phi=phi0, omega=omega0, f=f)
    for name in ("phi", "omega", "omega_squared"):
        assert np.all(np.isfinite(ds[name].values)), name
    assert np.all(ds.omega_squared.values >= 0.0)
    system = ladder(f, l=1.0)
    chain = reference_chain(system, phi0, omega0, 0.0, math.pi / 2, method=method)
    assert_matches(ds, chain, system, u_scale=G, tol=1e-7)
    # the end point is located to (near) machine precision in phi - phi0
    travel = ds.stage_end_phi.values[0] - phi0
    assert travel == pytest.approx(chain[0][2] - phi0, rel=1e-6)


@pytest.mark.parametrize("phi0, omega0", [(0.05, -0.5), (0.5, -0.5), (0.9, -0.5),
                                          (0.9, 0.5), (1.2, 0.5), (1.55, 0.5)])
def test_the_running_ladder_traces_through_its_near_singular_determinant(phi0, omega0):
    """f = sqrt 2 - 1e-10: the declared ladder stops within about 1e-12 rad where the hand
    module stops.  Its sliding determinant is generated as 2 (2 - f^2) / 9, the two slip
    signs written as one (``declare.solvers.one_direction``); expanded, its rounding changed
    with phi, and the tracer stopped at once with step_failure from each of these starts."""
    f = math.sqrt(2.0) - 1e-10
    ds = phase_curve("ladder", phi=phi0, omega=omega0, f=f, points_per_stage=20)
    hand = phase_curve(HAND["ladder"], phi=phi0, omega=omega0, f=f, points_per_stage=20)
    assert ds.attrs["end_reason"] == hand.attrs["end_reason"] == "rest"
    end = ds.stage_end_phi.values[-1]
    assert end == pytest.approx(hand.stage_end_phi.values[-1], abs=1e-14)
    assert 0 < (end - phi0) * np.sign(omega0) < 1e-11


def test_ladder_closed_form_never_overflows():
    """|lam| up to 1e11 from both sides of sqrt 2: finite curves, nothing past U_MAX."""
    for df in (-1e-10, -1e-6, -1e-3, 1e-3, 1e-6, 1e-10):
        for phi0 in (0.05, 0.5, 0.9, 1.2, 1.55):
            for omega0 in (-5.0, -0.5, 0.0, 0.5, 5.0):
                ds = phase_curve(HAND["ladder"], phi=phi0, omega=omega0,
                                 f=math.sqrt(2.0) + df, points_per_stage=20)
                assert np.all(np.isfinite(ds.omega_squared.values))
                assert np.all(np.isfinite(ds.stage_end_omega.values))
                assert ds.attrs["end_reason"] != "step_failure"


# ------------------------------------------------ zones, counts by hand -----
def test_stops_inside_and_reversals_outside_the_stagnation_zones():
    cases = [("ladder", ladder_rest_zone, {"f": f}, {"phi": p, "omega": w})
             for f in (0.2, 0.5, 0.9) for p in (0.3, 0.8, 1.3) for w in (-2.0, -0.7, 0.0)]
    cases += [("wheel", sin_zone, {"delta": d, "l": l}, {"phi": p, "omega": w})
              for d, l in ((0.02, 0.5), (0.1, 0.3), (0.3, 0.5)) for p in (0.5, 2.0)
              for w in (0.0, -4.0)]
    cases += [("hinge_pendulum", sin_zone, {"delta": d}, {"phi": p, "omega": w})
              for d in (0.03, 0.2, 0.7) for p in (0.5, 2.5) for w in (0.0, 5.0)]
    seen = {"rest": 0, "reversal": 0}
    for name, inside, params, start in cases:
        ds = phase_curve(name, **start, **params, points_per_stage=10)
        for reason, phi_e, w_e in zip(ds.stage_end_reason.values, ds.stage_end_phi.values,
                                      ds.stage_end_omega.values):
            if reason == Event.REST:
                assert w_e == 0.0 and inside(phi_e, **params), (name, params, start, phi_e)
                seen["rest"] += 1
            elif reason == Event.REVERSAL:
                assert w_e == 0.0 and not inside(phi_e, **params), (name, params, start, phi_e)
                seen["reversal"] += 1
    assert seen["rest"] >= 20 and seen["reversal"] >= 40, seen


def ladder_rest_zone(phi, f):
    return phi <= 2 * math.atan(f) + 1e-9


def sin_zone(phi, delta, l=1.0):
    return l * abs(math.sin(phi)) <= delta + 1e-9


def coulomb_swings(amplitude, k, zone):
    """Linearised swings phi'' = -w0^2 (phi + sigma k): each half swing is a half
    period about the centre -sigma k, so |A| drops by exactly 2 k.  Returns the
    reversal angles and the rest angle (the first turning point with |A| <= zone)."""
    turns = []
    a = amplitude
    while True:
        a = 2 * k * math.copysign(1.0, a) - a   # mirror about the centre k sgn(a)
        if abs(a) <= zone:
            return turns, a
        turns.append(a)


@pytest.mark.parametrize("name, params, a0, k, zone", [
    # hinge: l phi'' = -g sin phi - sigma k |l w^2 + g cos phi| ~ -g (phi + sigma k)
    ("hinge_pendulum", {"delta": 0.02}, 0.2, 0.02 / math.sqrt(1 - 0.02 ** 2), 0.02),
    # wheel: (rho^2 + (r - l)^2) phi'' ~ -g l (phi + sigma delta / l)
    ("wheel", {"delta": 0.01, "l": 0.5}, 0.32, 0.02, 0.02),
    ("wheel", {"delta": 0.02, "l": 0.5, "rho": 0.3}, 0.25, 0.04, 0.04),
])
def test_reversal_count_matches_the_linearised_coulomb_oscillator(name, params, a0, k, zone):
    """Small swings lose 2 k of amplitude per half swing and stop once |A| <= zone."""
    turns, rest = coulomb_swings(a0, k, zone)
    loss = 2 * k
    # the estimate is far enough from the zone's edge for its count to be robust
    assert min(abs(t) for t in turns) - zone >= 0.25 * loss
    assert zone - abs(rest) >= 0.25 * loss
    ds = phase_curve(name, phi=a0, omega=0.0, **params, points_per_stage=10)
    assert list(ds.stage_end_reason.values) == [Event.REVERSAL] * len(turns) + [Event.REST]
    assert ds.attrs["n_reversals"] == len(turns) >= 2
    # nonlinear corrections (O(a0^2) of the loss) stay below 15 % of one swing's loss
    np.testing.assert_allclose(ds.stage_end_phi.values, turns + [rest], atol=0.15 * loss)


# ------------------------------------------------ contacts and singular points
@pytest.mark.parametrize("phi0", [0.05, 0.3, 0.7])
def test_frictionless_ladder_leaves_the_wall_at_two_thirds_height(phi0):
    """f = 0 from rest: energy gives omega^2 = 3 g (cos phi0 - cos phi) / (2 l), and the wall
    reaction N_wall = m xc'' vanishes where the top is at 2/3 of its starting height."""
    l = 1.3
    ds = phase_curve("ladder", phi=phi0, omega=0.0, f=0.0, l=l)
    assert ds.attrs["end_reason"] == "contact_lost"
    phi_c = math.acos(2.0 / 3.0 * math.cos(phi0))
    assert ds.stage_end_phi.values[0] == pytest.approx(phi_c, abs=1e-12)
    np.testing.assert_allclose(ds.omega_squared.values,
                               3 * G * (math.cos(phi0) - np.cos(ds.phi.values)) / (2 * l),
                               rtol=1e-12, atol=1e-12 * G / l)
    n_floor, n_wall = ladder_reactions(phi_c, ds.stage_end_omega.values[0], 1.0, 0.0, l)
    assert abs(n_wall) <= 1e-10 * G and n_floor > 0


@pytest.mark.parametrize("model, params, start", [
    ("ladder", {"f": 0.1, "l": 1.0}, {"phi": 0.2, "omega": 2.5}),    # fast: soon off the wall
    ("ladder", {"f": 0.3, "l": 1.0}, {"phi": 0.9, "omega": -1.5}),   # up, reversal, down, off
    ("ladder", {"f": 0.6, "l": 0.7}, {"phi": 1.2, "omega": 1.5}),
    ("wheel", {}, {"phi": math.pi, "omega": 4.4}),
    ("wheel", {"delta": 0.1, "l": 0.8, "rho": 0.2}, {"phi": 1.5, "omega": 4.0}),  # bounces at 5.0
])
def test_contact_is_lost_where_the_independent_reaction_vanishes(model, params, start):
    """The curve ends where the independent solve's reaction vanishes.  The ladder then
    leaves a contact; the wheel can neither roll on (it would pull) nor hop (the oracle:
    free flight does not open the gap): rolling without slip acts as unbounded friction."""
    import oracles

    ds = phase_curve(model, **start, **params)
    assert ds.attrs["end_reason"] == {"ladder": "contact_lost", "wheel": "no_solution"}[model]
    assert ds.sizes["point"] > 1  # it moved before leaving the contact
    phi_c, w_c = ds.stage_end_phi.values[-1], ds.stage_end_omega.values[-1]
    s = float(ds.stage_sign.values[-1])
    full = {"delta": 0.05, "r": 1.0, "l": 0.5, "rho": 0.5, **params}

    def reactions(phi, w):
        if model == "ladder":
            return ladder_reactions(phi, w, s, params["f"], params["l"])
        return (wheel_normal(phi, w, s, **full),)
    at_end = reactions(phi_c, w_c)
    assert min(at_end) == pytest.approx(0.0, abs=1e-9 * G)
    if model == "wheel":
        assert not oracles.wheel(phi_c, w_c, full["delta"], full["r"], full["l"], full["rho"],
                                 G, 1.0).separating
    # every other point of the last stage keeps both contacts pushing
    sel = ds.point_stage.values == ds.sizes["stage"] - 1
    for phi, w in zip(ds.phi.values[sel][:-1], ds.omega.values[sel][:-1]):
        assert min(reactions(phi, w)) > -1e-9 * G


def test_wheel_ends_singular_where_its_bracket_vanishes():
    """rho^2 + r^2 + l^2 - 2 r l cos phi + delta l sin phi = 0 at phi* ~ -0.489; the curve
    agrees with the integration in time up to where the bracket is 1e-3."""
    p = {"delta": 0.5, "r": 1.0, "l": 1.0, "rho": 0.02}
    ds = phase_curve("wheel", phi=-0.6, omega=2.0, **p)
    assert ds.attrs["end_reason"] == "singular"

    def bracket(phi):
        return (p["rho"] ** 2 + p["r"] ** 2 + p["l"] ** 2 - 2 * p["r"] * p["l"] * math.cos(phi)
                + p["delta"] * p["l"] * math.sin(phi))

    from scipy.optimize import brentq
    phi_star = brentq(bracket, -0.6, -0.3, xtol=1e-15)
    assert ds.stage_end_phi.values[0] == pytest.approx(phi_star, abs=1e-10)
    assert np.isfinite(ds.stage_end_omega.values[0])

    def near(t, y):
        return bracket(y[0]) - 1e-3
    near.terminal = True
    system = wheel(**p)
    sol = solve_ivp(lambda t, y: (y[1], system.acc(y[0], y[1], 1.0)), (0, 10), (-0.6, 2.0),
                    method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True, events=near)
    phis = ds.phi.values[ds.phi.values <= sol.y[0, -1]]
    assert phis.size > 150
    np.testing.assert_allclose(ds.omega_squared.values[:phis.size],
                               reference_u(sol, phis, 1.0, system.acc), atol=1e-9 * G)


# ------------------------------------------------ the collocation's order ---
def test_collocation_converges_at_order_twelve():
    """Exponential Gauss collocation with 6 nodes: the error of omega^2 ~ h^12, h the panel
    width.  The wheel's u-slope is not zero (z = beta h != 0 exercises the phi-functions) and
    its bracket has complex zeros 0.96 from the real axis, so the panels feel them."""
    from phasemap.models import get_model
    delta, r, l, rho, phi0, u0, span = 0.1, 1.0, 0.5, 0.5, -1.0, 40.0, 2.0

    def bracket(phi):
        return rho ** 2 + r ** 2 + l ** 2 - 2 * r * l * math.cos(phi) + delta * l * math.sin(phi)

    def slope(phi, u):  # the paper's first-integral equation, solved for u'
        sp, cp = math.sin(phi), math.cos(phi)
        return [(-2 * l * (r * sp + delta * cp) * u[0] - 2 * G * l * sp - 2 * delta * G)
                / bracket(phi)]

    exact = solve_ivp(slope, (phi0, phi0 + span), [u0], method="DOP853", rtol=1e-13,
                      atol=1e-13).y[0, -1]
    m = get_model("wheel")
    full = {k: float(x) for k, x in m.complete(dict(phi=phi0, omega=math.sqrt(u0), delta=delta,
                                                     r=r, l=l, rho=rho)).items()}

    def run(n):
        h = span / n * (1 + 1e-12)  # n panels of width h: every panel accepted
        _, stages = phase._trace(m, full, (phi0 - 1, phi0 + span), 1, 2, rtol=math.inf,
                                 h_max=h, h_first=h)
        assert stages[0, 3] == Event.HORIZON
        return stages[0, 5]

    assert phase.NODES == 6
    ns = np.array([2, 3, 4, 5])
    errors = np.array([abs(run(n) - exact) for n in ns])
    order = np.polyfit(np.log(span / ns), np.log(errors), 1)[0]
    assert 10.0 <= order <= 14.0, (order, errors)
    # with the adaptive panels the result is at the reference's own accuracy
    ds = phase_curve("wheel", phi=phi0, omega=math.sqrt(u0), delta=delta, r=r, l=l, rho=rho,
                     phi_range=(phi0 - 1, phi0 + span))
    assert ds.attrs["end_reason"] == "horizon"
    assert ds.stage_end_omega.values[0] ** 2 == pytest.approx(exact, rel=1e-12)


def test_stiff_ladder_stage_matches_the_closed_form():
    """f = sqrt 2 + 1e-6 (slope |lam| = 8.5e6): the exponential weights carry the boundary
    layer and the slow curve; omega^2 at every output point against the ladder's closed form
    (phasemap.systems.seeds.closed_forms, independent of the tracer)."""
    from phasemap.systems.seeds.closed_forms import ladder_omega_squared
    f, phi0, omega0 = math.sqrt(2.0) + 1e-6, 0.6, -3.0
    ds = phase_curve("ladder", phi=phi0, omega=omega0, f=f)
    sel = ds.point_stage.values == 0
    phis, u = ds.phi.values[sel], ds.omega_squared.values[sel]
    exact = np.array([ladder_omega_squared(p, phi0, omega0, f, 1.0, G) for p in phis])
    np.testing.assert_allclose(u, exact, rtol=0, atol=1e-10 * G)


# ------------------------------------------------ starts, limits, horizon ---
@pytest.mark.parametrize("model, grid", [
    ("ladder", {"phi": np.linspace(0.0, math.pi / 2, 9), "f": [0.0, 0.4, 1.0, 1.5, 2.5]}),
    ("wheel", {"phi": np.linspace(-3, 3, 7), "delta": [0.0, 0.05, 0.6], "l": [0.3, 1.0], "rho": [0.1]}),
    ("hinge_pendulum", {"phi": np.linspace(-3, 3, 7), "delta": [0.0, 0.1, 1.0, 1.2]}),
])
def test_start_from_rest_follows_classify(model, grid):
    """At omega = 0 the curve stops, or starts on the unique admissible branch, as classify says."""
    import itertools

    import phasemap
    names = list(grid)
    seen = set()
    for values in itertools.product(*grid.values()):
        kw = dict(zip(names, values))
        c = phasemap.classify(model, omega=0.0, **kw)
        ds = phase_curve(model, omega=0.0, **kw, points_per_stage=5, max_stages=1)
        first = Event(int(ds.stage_end_reason.values[0]))
        if c.n_solutions == 1 and not c.stagnation:
            acc = c.branches[0].accelerations["phi_ddot"]
            assert ds.stage_sign.values[0] == np.sign(acc)
            assert ds.sizes["point"] > 1 or first == Event.LEFT_DOMAIN  # at the ladder's end
            seen.add("moves")
        else:
            # two, a continuum (the ladder lying flat: the foot sticks, the top slides,
            # the compression is free) or more: the motion is not determined
            expected = {(1, True): Event.REST}.get((c.n_solutions, c.stagnation),
                                                   Event.INDETERMINATE)
            if c.n_solutions == 3:
                expected = Event.CONTINUUM
            if c.n_solutions == 0:
                expected = (Event.SINGULAR if c.singular else
                            Event.CONTACT_LOST if c.contact_lost else Event.NO_SOLUTION)
            assert (first, ds.sizes["point"], ds.stage_sign.values[0]) == (expected, 1, 0), kw
            seen.add(first.name)
    assert "moves" in seen and "REST" in seen, seen


@pytest.mark.parametrize("model, params, start, reason", [
    ("ladder", {"f": math.sqrt(2.0)}, {"phi": 0.8, "omega": 1.0}, Event.SINGULAR),
    ("hinge_pendulum", {"delta": 1.0, "l": 1.0}, {"phi": 0.5, "omega": 2.0}, Event.SINGULAR),
    ("hinge_pendulum", {"delta": 1.2, "l": 1.0}, {"phi": 0.5, "omega": 2.0}, Event.NO_SOLUTION),
    ("wheel", {}, {"phi": math.pi, "omega": 5.0}, Event.CONTACT_LOST),
])
def test_stage_that_cannot_start_is_reported_at_its_start(model, params, start, reason):
    ds = phase_curve(model, **start, **params)
    assert ds.sizes["stage"] == 1 and ds.sizes["point"] == 1
    assert ds.stage_end_reason.values[0] == reason
    assert ds.attrs["end_reason"] == reason.name.lower()
    assert ds.stage_end_phi.values[0] == start["phi"]
    assert ds.stage_end_omega.values[0] == start["omega"]


def test_max_stages_ends_on_the_last_reversal():
    full = phase_curve("hinge_pendulum", phi=0.2, omega=0.0, delta=0.02)
    cut = phase_curve("hinge_pendulum", phi=0.2, omega=0.0, delta=0.02, max_stages=2)
    assert list(cut.stage_end_reason.values) == [Event.REVERSAL, Event.MAX_EVENTS]
    assert cut.attrs["end_reason"] == "max_events"
    np.testing.assert_array_equal(cut.stage_end_phi.values, full.stage_end_phi.values[:2])


def test_frictionless_pendulum_conserves_energy_up_to_the_horizon():
    """delta = 0: u - 2 g cos(phi) / l is constant, and the curve ends at phi0 + 4 pi."""
    l, phi0, omega0 = 0.7, 0.4, -9.0
    ds = phase_curve("hinge_pendulum", phi=phi0, omega=omega0, delta=0.0, l=l)
    assert ds.attrs["end_reason"] == "horizon"
    assert ds.stage_end_phi.values[0] == phi0 - 4 * math.pi
    energy = ds.omega_squared.values - 2 * G * np.cos(ds.phi.values) / l
    np.testing.assert_allclose(energy, omega0 ** 2 - 2 * G * math.cos(phi0) / l, rtol=1e-13)
    assert np.all(ds.omega.values < 0)
    # a narrower range ends sooner
    ds = phase_curve("hinge_pendulum", phi=phi0, omega=omega0, delta=0.0, l=l,
                     phi_range=(0.0, 1.0))
    assert ds.stage_end_phi.values[0] == 0.0


def test_rest_state_gives_a_one_point_curve():
    ds = phase_curve("hinge_pendulum", phi=0.05, omega=0.0, delta=0.1)
    assert (ds.sizes["point"], ds.sizes["stage"]) == (1, 1)
    assert ds.attrs["end_reason"] == "rest" and ds.stage_sign.values[0] == 0
    assert ds.omega.values[0] == 0.0 and ds.phi.values[0] == 0.05


# ------------------------------------------------ input and output ----------
@pytest.mark.parametrize("call, message", [
    (lambda: phase_curve("elliptic_pendulum", phi=0.1, omega=0.0), "simulate"),
    (lambda: phase_curve("no_such_model", phi=0.1, omega=0.0), "unknown model"),
    (lambda: phase_curve("ladder", phi=0.5, omega=0.0, mu=0.3), "unknown variable 'mu'"),
    (lambda: phase_curve("ladder", phi=2.0, omega=0.0), "phi = 2 is outside its domain"),
    (lambda: phase_curve("ladder", phi=0.5, omega=0.0, l=-1.0), "l = -1 is outside"),
    (lambda: phase_curve("wheel", phi=0.5, omega=0.0, l=2.0, r=1.0), "must not exceed r"),
    (lambda: phase_curve("hinge_pendulum", phi=np.array([0.1, 0.2]), omega=0.0),
     "phi must be a scalar"),
    (lambda: phase_curve("hinge_pendulum", phi=float("nan"), omega=0.0), "phi must be finite"),
    (lambda: phase_curve("hinge_pendulum", phi="left", omega=0.0), "phi must be a real number"),
    (lambda: phase_curve("hinge_pendulum", phi=0.1, omega=0.0, phi_range=(1.0, 2.0)),
     "must contain phi"),
    (lambda: phase_curve("hinge_pendulum", phi=0.1, omega=0.0, phi_range=(2.0, -2.0)),
     "low < high"),
    (lambda: phase_curve("hinge_pendulum", phi=0.1, omega=0.0, phi_range=3.0),
     "two numbers"),
    (lambda: phase_curve("ladder", phi=0.1, omega=0.0, phi_range=(-1.0, 1.0)),
     "outside its domain"),
    (lambda: phase_curve("wheel", phi=0.1, omega=0.0, max_stages=0), "max_stages"),
    (lambda: phase_curve("wheel", phi=0.1, omega=0.0, max_stages=2.5), "max_stages"),
    (lambda: phase_curve("wheel", phi=0.1, omega=0.0, points_per_stage=1), "points_per_stage"),
    (lambda: phase_curve("wheel", phi=0.1, omega=0.0, points_per_stage=True),
     "points_per_stage"),
])
def test_bad_input_raises_a_clear_value_error(call, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        call()


def test_dataset_is_cf_described_and_survives_netcdf(tmp_path):
    from conftest import cfchecks

    import phasemap
    ds = phase_curve("wheel", phi=1.0, omega=0.0, delta=0.05)
    assert set(ds.dims) == {"point", "stage"}
    assert ds.attrs["phasemap_kind"] == "phase_curve"
    assert ds.attrs["phasemap_model"] == "wheel"
    assert ds.attrs["phasemap_version"] == phasemap.__version__
    assert ds.attrs["phasemap_fixed_delta"] == 0.05
    assert ds.attrs["end_reason"] == Event(int(ds.stage_end_reason[-1])).name.lower() == "rest"
    for name, var in ds.variables.items():
        assert var.attrs.get("long_name"), name
        assert "units" in var.attrs or "flag_values" in var.attrs, name
    flags = ds.stage_end_reason.attrs
    assert list(flags["flag_values"]) == [int(e) for e in Event]
    assert flags["flag_meanings"].split() == [e.name.lower() for e in Event]
    # each stage starts where the previous one ended, with omega = 0 after a reversal
    np.testing.assert_array_equal(ds.stage_start_phi.values[1:], ds.stage_end_phi.values[:-1])
    assert np.all(ds.stage_sign.values[1:] == -ds.stage_sign.values[:-1])
    # omega carries the sign of its stage
    sign = ds.stage_sign.values[ds.point_stage.values]
    assert np.all(ds.omega.values * sign >= 0)
    np.testing.assert_allclose(ds.omega.values ** 2, ds.omega_squared.values, rtol=1e-14)
    path = tmp_path / "curve.nc"
    ds.to_netcdf(path)
    with xr.open_dataset(path) as back:
        assert back.identical(ds)
    report = cfchecks(phasemap.write_atlas(ds, tmp_path / "atlas.nc"), tmp_path)
    assert "ERRORS detected: 0" in report and "WARNINGS given: 0" in report


def test_docstring_example_runs():
    import doctest
    result = doctest.testmod(phase)
    assert result.attempted >= 2 and result.failed == 0


@pytest.mark.parametrize("model, params, start", [
    ("ladder", {"f": 1.6, "l": 0.8}, {"phi": 1.3, "omega": 3.0}),
    ("ladder", {"f": 2.5, "l": 0.8}, {"phi": 1.0, "omega": -3.0}),
    ("ladder", {"f": 0.3, "l": 1.0}, {"phi": 0.9, "omega": -1.5}),
])
def test_running_models_end_where_the_oracle_says(model, params, start):
    """The running (declared) ladder traces the hand module's curve until its
    own classification stops it; where it stops, the independent full-coordinate oracle
    has no unique kept-contact continuation, and the fate is what the oracle counts."""
    import oracles

    run = phase_curve(model, **start, **params)
    hand = phase_curve(HAND[model], **start, **params)
    end_phi, end_w = float(run.stage_end_phi.values[-1]), float(run.stage_end_omega.values[-1])
    lo, hi = sorted((float(hand.phi.values[0]), float(hand.stage_end_phi.values[-1])))
    assert lo - 1e-9 <= end_phi <= hi + 1e-9  # on the hand module's path, no farther
    a = oracles.ladder(end_phi, end_w, params["f"], params["l"], G, 1.0)
    reason = run.attrs["end_reason"]
    assert reason in {"no_solution", "contact_lost", "indeterminate", "rest"}, reason
    if reason == "no_solution":      # keeping needs a pull from here on; leaving is no better
        assert not a.separating
    elif reason == "contact_lost":   # leaving is consistent, or the end is the tie N = 0
        assert a.separating or any(np.min(np.abs(md.N)) < 1e-8 * G for md in a.all_kept)
    elif reason == "indeterminate":  # keeping and leaving are both consistent
        assert a.separating and a.all_kept
    else:                            # rest (it was allowed here with nothing checked)
        assert a.stagnation


def test_a_looser_rtol_keeps_the_curve_to_its_tolerance():
    """rtol trades accuracy for fewer panels: the wheel swinging to rest keeps its stages
    and reasons, and its omega^2 stays within a small multiple of rtol of the default's."""
    tight = phase_curve("wheel", phi=1.0, omega=0.0)
    loose = phase_curve("wheel", phi=1.0, omega=0.0, rtol=1e-8)
    assert loose.attrs["phasemap_rtol"] == 1e-8 and tight.attrs["phasemap_rtol"] == 1e-14
    assert list(loose.stage_end_reason.values) == list(tight.stage_end_reason.values)
    u_ref = G / 1.0  # the wheel's velocity scale squared, g / r
    np.testing.assert_allclose(loose.stage_end_phi.values, tight.stage_end_phi.values,
                               atol=1e-6)
    np.testing.assert_allclose(loose.omega_squared.values, tight.omega_squared.values,
                               atol=1e-6 * u_ref)
    assert not np.array_equal(loose.omega_squared.values, tight.omega_squared.values)
    for bad in (1e-16, 0.1, "tight", float("nan")):
        with pytest.raises(ValueError, match="rtol"):
            phase_curve("wheel", phi=1.0, omega=0.0, rtol=bad)


@pytest.mark.parametrize("rtol", [1e-3, 1e-4, 1e-6])
@pytest.mark.parametrize("start", [dict(phi=1.0, omega=0.0), dict(phi=0.0, omega=7.0)])
def test_a_loose_rtol_stops_newton_early_and_keeps_its_tolerance(start, rtol):
    """At a loose rtol each panel's Newton iteration stops once its correction is below
    phase.NEWTON rtol (not 1e-14): omega^2 and the stage ends stay within rtol of the
    default curve (a stop at rtol itself puts the wheel over the top 70 rtol off at 1e-3)."""
    assert phase.NEWTON * rtol > 1e-14
    tight = phase_curve("wheel", **start)
    loose = phase_curve("wheel", **start, rtol=rtol)
    assert list(loose.stage_end_reason.values) == list(tight.stage_end_reason.values)
    u_ref = G / 1.0  # the wheel's velocity scale squared, g / r
    np.testing.assert_allclose(loose.stage_end_phi.values, tight.stage_end_phi.values,
                               rtol=0, atol=rtol)
    np.testing.assert_allclose(loose.omega_squared.values, tight.omega_squared.values,
                               rtol=0, atol=rtol * u_ref)


@pytest.mark.parametrize("z", [0.0, 0.3, -0.7, 1.0, -1.0])
def test_the_output_pass_solves_a_panel_to_rounding(z):
    """solve_legendre (the output points' pass): du/dtau = z u + h p, u(0) = u0, with p
    interpolating e^(a tau) at the 12 output nodes, against the closed form
    e^(z tau) u0 + h (e^(a tau) - e^(z tau)) / (a - z), at points across the panel."""
    from phasemap.motion.phase import collocation as col

    a, u0, h = 0.7, 2.5, 0.4
    nv = np.exp(a * col.OUT_THETA)
    u = np.empty(col.OUT_TERMS + 1)
    nt = col.solve_legendre(z, u0, h, nv, u, np.empty(col.OUT_TERMS + 1),
                            np.empty(col.OUT_NODES))
    assert 1 <= nt <= col.OUT_TERMS  # (the terms below rounding dropped)
    for tau in np.linspace(0.0, 1.0, 17):
        exact = math.exp(z * tau) * u0 + h * (math.exp(a * tau) - math.exp(z * tau)) / (a - z)
        assert col.legendre_at(tau, u, nt) == pytest.approx(exact, rel=2e-15, abs=0)
    # the output points evaluate the sum many at a time (legendre_many): the same
    # arithmetic per point, so the same bits, for any number of terms
    taus = np.linspace(0.0, 1.0, 17)
    for terms in sorted({1, 2, 3, nt}):
        lanes = np.empty((4, col.LANES))
        lanes[0, :taus.size] = taus
        col.legendre_many(lanes, taus.size, u, terms)
        assert [float(x) for x in lanes[1, :taus.size]] == [
            col.legendre_at(float(t), u, terms) for t in taus]


def test_many_points_per_stage_answer():
    """Issue 42 item 4: ``points_per_stage=100000`` once raised numba's ``RuntimeError: no
    compiled object yet``; from the issue's state the ladder loses its wall contact at
    once, and the hinge's stages hold every point asked for."""
    ds = phase_curve("ladder", phi=0.39, omega=6.36, points_per_stage=100000)
    assert ds.attrs["end_reason"] == "contact_lost" and ds.sizes["point"] >= 1
    ds = phase_curve("hinge_pendulum", phi=0.5, omega=0.0, max_stages=3,
                     points_per_stage=100000)
    assert ds.sizes["point"] == 100000 * ds.sizes["stage"]
    assert np.all(np.isfinite(ds.omega.values))


def test_the_curves_pieces_count_no_references_but_those_that_allocate():
    """The compiled curve's pieces run without numba's reference counts, but for the two
    that allocate its output (``tracer.COUNTED``); the curve is the same either way (its
    closed forms are checked above), and numba refuses an allocation in the others."""
    from phasemap.models import get_model
    from phasemap.motion.phase import tracer

    curve = phase.kernel(get_model("hinge_pendulum"))
    built = dict(curve.py_func.__globals__, CURVE=curve)     # (each piece, by its name)
    for name, _, inline in tracer.PIECES:
        if inline == "ir":
            continue                    # (inlined into the curve's own code)
        lean = built[name].targetoptions.get("_nrt") is False
        assert lean == (name not in tracer.COUNTED), name
