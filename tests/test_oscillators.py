"""Friction oscillators (issue 39): damping, static and kinetic friction, friction that
depends on the sliding speed, moving surfaces and forcing in time, each checked against a
closed form derived here or an independent integration."""

import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

import phasemap
from phasemap.core import events as ev
from phasemap.declare import (SLIP_SPEED, TIME, Body, Coordinate, EdgeContact, Parameter,
                              PointContact, Rate, System)
from phasemap.declare.build import canonical
from phasemap.declare.full import mechanics
from phasemap.motion import hybrid
from phasemap.systems.oscillators import BELT, DEN_HARTOG, STRIBECK_BELT

m = Parameter("m", "kg", "mass", default=1.0, lower=0.0, lower_open=True)
k = Parameter("k", "N m-1", "stiffness", default=1.0, lower=0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", default=1.0, lower=0.0,
              lower_open=True)
c = Parameter("c", "kg s-1", "damping", default=0.1, lower=0.0)
fs = Parameter("f_s", "1", "static friction coefficient", default=1.0, lower=0.0)
fk = Parameter("f_k", "1", "kinetic friction coefficient", default=0.5, lower=0.0)
x = Coordinate("x", "m", "position", rate=Rate("xdot", "m s-1", "velocity"))
y = Coordinate("y", "m", "height")


def _block(name, contact, parameters=(fs, fk), potential=k * x**2 / 2 + m * g * y, **kw):
    return System(name, "a block on a spring", "test", coordinates=(x, y),
                  parameters=(m, k, g, *parameters), bodies=(Body(m, (x, y)),),
                  potential=potential, contacts=(contact,), **kw)


def _events(ds):
    return [(float(t), ev.Event(int(kind)).name.lower(), float(xx))
            for t, kind, xx in zip(ds.event_t.values, ds.event_kind.values, ds.event_x.values)]


def test_belt_stick_slip_orbit_matches_its_closed_form():
    """Mass on a belt, m = k = g = 1, f_s N = 1, f_k N = 0.5, v = 0.2: sticking, the
    block rides with the belt from x = 0 until k x = f_s N (x = 1, after 1/v = 2 delta / v
    = 5); slipping, x'' = -x + f_k about x = 1/2 with the amplitude sqrt(delta^2 + v^2),
    until x' = v again at x = 0, after pi + 2 arctan(v / delta)."""
    ds = phasemap.simulate("belt", 30.0, rtol=1e-12, x=0.0, xdot=0.2)
    evs = _events(ds)
    sticks = [t for t, kind, _ in evs if kind == "stick"]
    slips = [t for t, kind, _ in evs if kind == "slip"]
    delta, v = 0.5, 0.2
    T = 2 * delta / v + math.pi + 2 * math.atan(v / delta)
    assert abs(T - 8.902605407815) < 1e-11
    assert len(sticks) >= 3 and len(slips) >= 3
    assert np.allclose(np.diff(sticks), T, rtol=0, atol=1e-9)
    assert np.allclose(np.diff(slips), T, rtol=0, atol=1e-9)
    assert abs(slips[0] - 5.0) < 1e-9                       # the stick segment lasts 5
    assert all(abs(xx - 1.0) < 1e-9 for _, kind, xx in evs if kind == "slip")
    assert all(abs(xx) < 1e-9 for _, kind, xx in evs if kind == "stick")
    # x_min: the lowest point of the slip, from a dense sample of one slip segment
    te = np.linspace(slips[0], sticks[0], 20001)
    dense = phasemap.simulate("belt", float(te[-1]), rtol=1e-12, x=0.0, xdot=0.2, t_eval=te)
    i = int(np.argmin(dense.x.values))
    t_min = slips[0] + math.pi + math.atan(v / delta)       # where x' = 0 in the slip
    assert abs(te[i] - t_min) <= (te[1] - te[0])
    x_min = 0.5 - math.hypot(delta, v)
    assert abs(x_min - (-0.038516480713)) < 1e-11
    exact = phasemap.simulate("belt", t_min, rtol=1e-12, x=0.0, xdot=0.2, t_eval=[t_min])
    assert abs(float(exact.x[-1]) - x_min) < 1e-9
    assert abs(float(exact.xdot[-1])) < 1e-9
    # sticking means moving with the belt, the friction force balancing the spring
    stuck = ds.mode_belt.values == hybrid.STICK
    assert np.allclose(ds.xdot.values[stuck], 0.2, atol=1e-12)
    assert np.allclose(ds.F_belt.values[stuck], ds.x.values[stuck], atol=1e-9)


def test_static_friction_holds_until_the_spring_beats_it():
    """A block on a floor at rest, f_s = 1 > f_k = 0.5 (m = k = g = 1): it stays where
    |x| <= 1; from x0 = 1.2 it slips with f_k, x = 1/2 + 0.7 cos t, and stops for good at
    t = pi, x = -0.2 (where static friction holds the spring)."""
    S = _block("block", PointContact("floor", point=(x, y), friction=fk, static_friction=fs))
    held = phasemap.simulate(S, 10.0, rtol=1e-12, x=0.99)
    assert held.attrs["end_reason"] == "rest" and float(held.t[-1]) == 0.0
    for x0 in (1.2, -1.2):
        ds = phasemap.simulate(S, 10.0, rtol=1e-12, x=x0)
        assert ds.attrs["end_reason"] == "rest"
        assert abs(float(ds.t[-1]) - math.pi) < 1e-9
        assert abs(float(ds.x[-1]) + math.copysign(0.2, x0)) < 1e-9
        te = np.linspace(0.0, 3.0, 7)
        mid = phasemap.simulate(S, 3.0, rtol=1e-12, x=x0, t_eval=te)
        exact = math.copysign(0.5, x0) + math.copysign(0.7, x0) * np.cos(te)
        assert np.allclose(mid.x.values, exact, atol=1e-9)
    # with f_s = f_k (Coulomb's law with one coefficient) the start at 0.99 slips at once,
    # x = 1/2 + 0.49 cos t, and stops at t = pi, x = 0.01
    plain = _block("plain", PointContact("floor", point=(x, y), friction=fk))
    ds = phasemap.simulate(plain, 10.0, rtol=1e-12, x=0.99)
    assert abs(float(ds.t[-1]) - math.pi) < 1e-9 and abs(float(ds.x[-1]) - 0.01) < 1e-9


def test_friction_that_falls_with_the_speed_matches_an_independent_integration():
    """The Stribeck belt (f = f_s / (1 + delta |v_rel|), v = 0.2): from rest on the belt
    the block slips forward until it rides with it; each slip segment agrees with
    solve_ivp of x'' = -x + s f_s / (1 + delta |x' - v|) (s the sign of v - x')."""
    ds = phasemap.simulate("stribeck_belt", 20.0, rtol=1e-12, x=0.0, xdot=0.0)
    evs = _events(ds)
    sticks = [t for t, kind, _ in evs if kind == "stick"]
    slips = [t for t, kind, _ in evs if kind == "slip"]
    assert sticks and slips

    def rhs(_, z):
        vr = z[1] - 0.2
        return [z[1], -z[0] - math.copysign(1.0, vr) * 1.0 / (1 + 3.0 * abs(vr))]

    ref = solve_ivp(rhs, (0.0, sticks[0]), [0.0, 0.0], rtol=1e-12, atol=1e-13,
                    dense_output=True)
    te = np.linspace(0.0, sticks[0] * 0.999, 9)
    got = phasemap.simulate("stribeck_belt", 20.0, rtol=1e-12, x=0.0, xdot=0.0, t_eval=te)
    assert np.allclose(got.x.values, ref.sol(te)[0], atol=1e-8)
    # the slip after the first stick starts where k x = f_s (static friction: x = 1) and
    # slips back against the belt, f_s / (1 + delta |v_rel|) forward, until it rides again
    start = slips[0]
    assert all(abs(xx - 1.0) < 1e-9 for _, kind, xx in evs if kind == "slip")
    end = next(t for t in sticks if t > start)
    ref2 = solve_ivp(lambda t, z: [z[1], -z[0] + 1.0 / (1 + 3.0 * abs(z[1] - 0.2))],
                     (start, end), [1.0, 0.2], rtol=1e-12, atol=1e-13, dense_output=True)
    te2 = np.linspace(start, end, 7)[1:-1]
    got2 = phasemap.simulate("stribeck_belt", 20.0, rtol=1e-12, x=0.0, xdot=0.0, t_eval=te2)
    assert np.all(got2.xdot.values < 0.2)
    assert np.allclose(got2.x.values, ref2.sol(te2)[0], atol=1e-7)
    assert abs(ref2.y[1, -1] - 0.2) < 1e-6         # it rides with the belt again there


def _den_hartog_amplitude(Om, r):
    V = 1 / (1 - Om**2)
    U = math.sin(math.pi / Om) / (Om * (1 + math.cos(math.pi / Om)))
    return math.sqrt(V**2 - r**2 * U**2)


@pytest.mark.slow
@pytest.mark.parametrize("Om, r, X0", [(0.8, 0.2, 2.711415255438), (1.5, 0.3, 0.721110255093)])
def test_den_hartog_non_stop_orbit_has_its_closed_form_amplitude(Om, r, X0):
    """Den Hartog's x'' + x = cos(Omega t) - r sgn x': the symmetric non-stop orbit turns
    at x = +-X0 half a forcing period apart, X0 = sqrt(V^2 - r^2 U^2).  Found here by a
    shooting of our own on the motion (x(t0) = X0 at rest, x(t0 + pi/Omega) = -X0 at
    rest), against the closed form."""
    assert abs(_den_hartog_amplitude(Om, r) - X0) < 1e-11
    mech = mechanics(DEN_HARTOG)
    p = np.array([1.0, 1.0, 1.0, 1.0, Om, r])            # m, k, g, F0, Omega, f
    assert mech.parameters == ("m", "k", "g", "F0", "Omega", "f")

    def half(z):
        x0, t0 = z
        t1 = t0 + math.pi / Om
        rec = hybrid.run_full(mech, p, np.array([x0, 0.0]), np.zeros(2), t_end=t1,
                              rtol=1e-13, atol=1e-13, max_step=math.inf, max_steps=10**6,
                              max_events=10**4, t0=t0, t_eval=[t1])
        return [rec.y[-1][0] + x0, rec.y[-1][2]]

    guess = [X0 * 1.01, 0.0]
    best = None
    for t0 in np.linspace(0.0, 2 * math.pi / Om, 8, endpoint=False):
        sol, info, ok, _ = fsolve(half, [guess[0], t0], xtol=1e-13, full_output=True)
        if ok == 1 and sol[0] > 0 and np.max(np.abs(info["fvec"])) < 1e-11:
            best = sol
            break
    assert best is not None
    assert abs(best[0] - X0) < 1e-9


def test_den_hartog_runs_by_name_and_never_stops_at_a_momentary_rest():
    """With f = 0.9 the forced block stops (sticks) and starts again: a motion that stops
    under a force that changes in time is not at rest for good."""
    ds = phasemap.simulate("den_hartog", 60.0, rtol=1e-10, x=0.0, xdot=0.0, f=0.9)
    assert ds.attrs["end_reason"] == "horizon" and float(ds.t[-1]) == 60.0
    kinds = [name for _, name, _ in _events(ds)]
    assert "rest" not in kinds and kinds.count("stick") >= 3 and kinds.count("slip") >= 3
    # the applied force is the declared cos(Omega t): x'' = -x + cos(0.8 t) - 0.2 sgn x'
    te = np.linspace(0.5, 2.0, 4)                   # slipping forward from the start
    got = phasemap.simulate("den_hartog", 2.0, rtol=1e-12, x=0.0, xdot=0.0, t_eval=te)
    ref = solve_ivp(lambda t, z: [z[1], -z[0] + math.cos(0.8 * t) - 0.2], (0.0, 2.0),
                    [0.0, 0.0], rtol=1e-12, atol=1e-13, dense_output=True)
    assert np.all(got.xdot.values > 0)
    assert np.allclose(got.x.values, ref.sol(te)[0], atol=1e-9)


def test_rayleigh_dissipation_is_viscous_damping_in_every_path():
    """D = c x'^2 / 2 on a smooth floor: x'' + c x' + x = 0, the under-damped closed form
    (the reduced model's motion and its classify, and the motion in full coordinates)."""
    S = _block("damped", PointContact("floor", point=(x, y), friction=0), (c,),
               dissipation=c * x.rate**2 / 2)
    z = 0.05
    wd = math.sqrt(1 - z * z)
    te = np.linspace(0.0, 5.0, 6)
    exact = np.exp(-z * te) * (np.cos(wd * te) + z / wd * np.sin(wd * te))
    reduced = phasemap.simulate(S, 5.0, rtol=1e-12, x=1.0, t_eval=te)
    assert reduced.attrs.get("phasemap_coordinates") != "full"
    assert np.allclose(reduced.x.values, exact, atol=1e-9)
    full = phasemap.simulate(S, 5.0, rtol=1e-12, x=1.0, y=0.0, t_eval=te)
    assert full.attrs["phasemap_coordinates"] == "full"
    assert np.allclose(full.x.values, exact, atol=1e-9)
    r = phasemap.classify(S.model, x=1.0, xdot=2.0, c=0.3)
    assert r.n_solutions == 1
    assert math.isclose(r.branches[0].accelerations["x_ddot"], -1.0 - 0.3 * 2.0,
                        rel_tol=1e-14)


def test_new_fields_leave_the_keys_of_declarations_before_them():
    """An atlas records its declaration's key: a declaration that uses none of the new
    fields keeps the key it had (the fields are in it only where set).  The rod's key is
    the one it had before them (commit 0a251c1)."""
    from phasemap.declare.build import declaration_sha256
    from phasemap.systems.painleve_rod import SYSTEM

    assert declaration_sha256(SYSTEM) == ("5d0b8ed72cbe51e8e88ccaec64e50a181aaac14f19c8a5405e"
                                          "71158592e0f598")
    text = canonical(SYSTEM)
    assert "static_friction" not in text and "surface_velocity" not in text
    assert "dissipation" not in text and "period" not in text
    assert "static_friction" in canonical(BELT) and "period" in canonical(DEN_HARTOG)


def _fails(S, match):
    with pytest.raises(ValueError, match=match) as err:
        S.model
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("make, match", [
    (lambda: _block("b", PointContact("floor", (x, y), friction=fk), forces={x: sp.cos(TIME)}),
     "declare the forcing period"),
    (lambda: _block("b", PointContact("floor", (x, y), friction=fk), period=2.0),
     "nothing depends on the time"),
    (lambda: _block("b", PointContact("floor", (x, y), friction=fk),
                    forces={x: sp.cos(TIME)}, period=-fk), "must be positive"),
    (lambda: _block("b", PointContact("floor", (x, y), friction=fk, static_friction=0.1)),
     "below the kinetic friction"),
    (lambda: _block("b", PointContact("floor", (x, y), friction=fk,
                                      static_friction=fs * SLIP_SPEED)),
     r"'slip_speed' \(SLIP_SPEED\) may appear only in a point contact's friction="),
    (lambda: _block("b", PointContact("floor", (x, y), friction=fk), potential=TIME * x),
     r"'t' \(TIME\) may appear only in forces= and surface_velocity="),
    (lambda: _block("b", EdgeContact("edge", (x, y), friction=fk, surface_velocity=1.0)),
     "has no surface to move"),
    (lambda: _block("b", PointContact("floor", (x, y), friction=fk, surface_velocity=x.rate)),
     "depends on 'xdot'"),
    (lambda: System("b", "b", "t", coordinates=(Coordinate("t", "m", "position",
                                                           rate=Rate("v", "m s-1", "v")), y),
                    parameters=(m, g), bodies=(Body(m, (x, y)),),
                    contacts=(PointContact("floor", (x, y), friction=0),)),
     "phasemap's own"),
])
def test_bad_oscillator_declarations_say_what_is_wrong(make, match):
    _fails(make(), match)


def test_oscillators_say_why_they_have_no_reduced_model():
    for name in phasemap.systems.OSCILLATORS:
        with pytest.raises(ValueError, match="no reduced model .* phasemap.Scene map it in "
                           "full coordinates"):
            phasemap.get_model(name)
    with pytest.raises(ValueError, match="forcing in time"):
        DEN_HARTOG.model
    with pytest.raises(ValueError, match="speed-dependent friction"):
        STRIBECK_BELT.model
    # the declaration itself, to what needs a reduced model: the same text, which names
    # what takes it (it once said that maps and classify did not)
    why = "belt: no reduced model .* phasemap.classify and phasemap.Scene map it in full"
    with pytest.raises(ValueError, match=why):
        BELT.model
    for call in (lambda: phasemap.get_model(BELT),
                 lambda: phasemap.boundaries(BELT, {"x": (-1, 1), "xdot": (-1, 1)}),
                 lambda: phasemap.phase_curve(BELT, x=0.1, xdot=0.0),
                 lambda: phasemap.threshold(BELT, "f_k", over={"x": (-1, 1)})):
        with pytest.raises(ValueError, match=why):
            call()
    assert phasemap.classify(BELT, x=0.1, xdot=0.0).n_solutions == 1


def test_a_declaration_with_a_reduced_model_is_a_model_everywhere():
    """get_model (and so boundaries, threshold, phase_curve) takes a declaration as
    classify and Scene do: its reduced model."""
    x = Coordinate("x", "m", "position", rate=Rate("xdot", "m s-1", "velocity"))
    y = Coordinate("y", "m", "height")
    m = Parameter("m", "kg", "mass", default=1.0, lower=0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravity", default=9.81, lower=0.0)
    f = Parameter("f", "1", "friction", default=0.3, lower=0.0)
    block = System("block_on_floor", "a block sliding on a rough floor", "test",
                   coordinates=(x, y), parameters=(m, g, f), bodies=(Body(m, (x, y)),),
                   potential=m * g * y,
                   contacts=(PointContact("floor", (x, y), normal=(0, 1), friction=f),))
    assert phasemap.get_model(block) is block.model
    c = phasemap.classify(block, xdot=1.0)
    assert c.n_solutions == 1 and phasemap.get_model(block).name == "block_on_floor"
