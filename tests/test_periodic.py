"""Periodic orbits of friction oscillators (issue 39): found on the exact hybrid flow,
their Floquet multipliers, and their continuation through nonsmooth bifurcations, each
against a closed form or an independent computation of the test's own."""

import math
import re

import numpy as np
import pytest

import phasemap
from phasemap.core import events as ev
from phasemap.declare import SLIP_SPEED, Parameter, PointContact
from phasemap.declare.full import mechanics
from phasemap.motion import hybrid
from phasemap.systems.oscillators import DEN_HARTOG
from test_oscillators import _block, _den_hartog_amplitude, c, fk, fs, x, y


# -- periodic orbits ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def belt_orbit():
    return phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2})


def test_belt_orbit_period_stick_segment_and_multipliers(belt_orbit):
    """The belt's stick-slip orbit from periodic_orbit: T = 2 delta/v + pi + 2 arctan(v /
    delta) = 8.902605407815, a stick segment of exactly 5, x_min = -0.038516480713, and
    the Floquet multipliers 1 (along the flow) and exactly 0 (the stick segment collapses
    every start onto the belt's speed)."""
    o = belt_orbit
    T = 1.0 / 0.2 + math.pi + 2 * math.atan(0.2 / 0.5)
    assert abs(float(o.period) - T) < 1e-9
    names = o.segment_mode_belt.attrs["flag_meanings"].split()
    modes = [names[m] for m in o.segment_mode_belt.values]
    assert sorted(modes) == ["slip_neg", "stick"]
    stick = modes.index("stick")
    assert abs(float(o.segment_duration[stick]) - 5.0) < 1e-9
    lam = np.sort(np.abs(o.floquet.values))
    assert lam[0] <= 1e-12
    assert abs(lam[1] - 1.0) < 1e-6
    assert int(o.stable) == 1 and float(o.residual) < 1e-10 and int(o.continuum) == 0
    # x_min: the slip segment's lowest point, pi/2 + arctan... after its start, from the
    # orbit's own start state, against the closed form
    slip = modes.index("slip_neg")
    t0 = float(o.segment_start[slip])
    i0 = int(np.argmin(np.abs(o.t.values - t0)))
    state = {"x": float(o.x[i0]), "xdot": float(o.xdot[i0]), "y": 0.0, "y_dot": 0.0}
    assert abs(state["x"] - 1.0) < 1e-9 and abs(state["xdot"] - 0.2) < 1e-9
    dt = math.pi + math.atan(0.2 / 0.5)
    low = phasemap.simulate("belt", dt, rtol=1e-12, t_eval=[dt], **state)
    assert abs(float(low.x[-1]) - (0.5 - math.hypot(0.5, 0.2))) < 1e-9
    assert abs(float(low.x[-1]) - (-0.038516480713)) < 1e-9     # the figure


def test_orbit_dataset_is_self_describing(belt_orbit):
    o = belt_orbit
    assert o.attrs["phasemap_kind"] == "periodic_orbit"
    for name in ("period", "floquet", "residual", "stable", "segment_duration",
                 "segment_end", "segment_mode_belt", "x", "xdot"):
        assert "long_name" in o[name].attrs, name
    assert o.floquet.dims == ("multiplier",) and np.iscomplexobj(o.floquet.values)
    assert o.segment_duration.dims == ("segment",)
    # the saved orbit closes on itself
    assert abs(float(o.x[0]) - float(o.x[-1])) < 1e-9
    assert abs(float(o.t[-1]) - float(o.t[0]) - float(o.period)) < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("Om, r", [(0.8, 0.2), (1.5, 0.3)])
def test_den_hartog_orbit_against_its_amplitude(Om, r):
    """periodic_orbit on Den Hartog's oscillator: the orbit's turning points (its
    reversals) are at +-X0 of the closed form, half a period apart; the period is the
    forcing's."""
    o = phasemap.periodic_orbit("den_hartog", start={"Omega": Om, "f": r})
    X0 = _den_hartog_amplitude(Om, r)
    turns = o.event_x.values[o.event_kind.values == ev.REVERSAL]
    assert turns.size == 2
    assert np.allclose(np.sort(turns), [-X0, X0], rtol=0, atol=1e-9)
    t_turn = o.event_t.values[o.event_kind.values == ev.REVERSAL]
    assert abs(abs(t_turn[1] - t_turn[0]) - math.pi / Om) < 1e-9
    assert int(o.stable) == 1 and np.all(np.abs(o.floquet.values) < 1)
    assert int(o.continuum) == 0


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_saltation_monodromy_agrees_with_differences_of_the_return_map(seed):
    """On random Den Hartog orbits (the forcing frequency and friction drawn), the
    multipliers of the monodromy built from saltation matrices agree with those of the
    return map differentiated by central differences (the test's own computation)."""
    rng = np.random.default_rng(seed)
    Om, r = rng.uniform(0.4, 0.7), rng.uniform(0.05, 0.3)
    o = phasemap.periodic_orbit("den_hartog", start={"Omega": Om, "f": r})
    mech = mechanics(DEN_HARTOG)
    p = np.array([1.0, 1.0, 1.0, 1.0, Om, r])
    t_a, T = float(o.t[0]), float(o.period)
    z0 = np.array([float(o.x[0]), 0.0, float(o.xdot[0]), 0.0])

    def ret(z):
        rec = hybrid.run_full(mech, p, z[:2], z[2:], t_end=t_a + T, rtol=1e-13, atol=1e-13,
                              max_step=math.inf, max_steps=10**6, max_events=10**4, t0=t_a,
                              t_eval=[t_a + T])
        return np.array([rec.y[-1][0], rec.y[-1][2]])

    h = 1e-6
    D = np.zeros((2, 2))
    for j, i in enumerate((0, 2)):
        zp, zm = z0.copy(), z0.copy()
        zp[i] += h
        zm[i] -= h
        D[:, j] = (ret(zp) - ret(zm)) / (2 * h)
    fd = np.sort_complex(np.linalg.eigvals(D))
    got = np.sort_complex(o.floquet.values)
    assert np.allclose(got, fd, atol=1e-6), (got, fd)


def test_a_period_guess_reads_one_period_without_settling():
    o = phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2}, period=9.0)
    assert abs(float(o.period) - (5.0 + math.pi + 2 * math.atan(0.4))) < 1e-9


# -- orbits that meet no event ---------------------------------------------------------

_mu = Parameter("mu", "s-1", "van der Pol's coefficient", default=1.0, lower=0.0)
_v = Parameter("v", "m s-1", "speed of the belt", default=10.0)


def _van_der_pol_on_a_belt():
    """A block on a belt ten times faster than it ever moves (it slips backwards all the
    time: x'' = -x + f_k + F), with van der Pol's force F = mu (1 - (x - f_k)^2) x':
    about x = f_k, the van der Pol oscillator, whose limit cycle meets no event."""
    return _block("vdp_belt", PointContact("belt", point=(x, y), friction=fk,
                                           surface_velocity=_v),
                  parameters=(_v, fk, _mu),
                  forces={x: _mu * (1 - (x - fk) ** 2) * x.rate})


def _van_der_pol_reference(mu):
    """The period of van der Pol's limit cycle and its nontrivial Floquet multiplier
    exp(integral of the divergence mu (1 - xi^2) over a period) (Liouville), from scipy
    alone: the motion settled, then timed between two maxima of xi."""
    from scipy.integrate import solve_ivp

    def f(t, y):
        return [y[1], mu * (1 - y[0] ** 2) * y[1] - y[0], mu * (1 - y[0] ** 2)]

    def top(t, y):
        return y[1]
    top.direction = -1
    settled = solve_ivp(f, (0, 300), [1.0, 0.0, 0.0], rtol=1e-12, atol=1e-13).y[:, -1]
    sol = solve_ivp(f, (0, 20), [settled[0], settled[1], 0.0], events=top, rtol=1e-12,
                    atol=1e-13)
    (t1, t2), (y1, y2) = sol.t_events[0][:2], sol.y_events[0][:2]
    return t2 - t1, math.exp(y2[2] - y1[2])


def test_a_limit_cycle_without_events_is_solved_on_a_section():
    """The van der Pol limit cycle (mu = 1) on the belt: no event, so the orbit is one
    segment ended by a Poincare section through its start; its period and its
    nontrivial multiplier agree with scipy's to 1e-9 and 1e-7; it is isolated and
    stable, and continue_orbit follows it (the section rebuilt from the Dataset)."""
    S = _van_der_pol_on_a_belt()
    T, mult = _van_der_pol_reference(1.0)
    o = phasemap.periodic_orbit(S, start={"x": 1.0, "xdot": 0.0})
    assert abs(float(o.period) - T) < 1e-9 and abs(T - 6.66328685932) < 1e-9
    assert o.segment_end.values.tolist() == [-2]
    from phasemap.atlas.read import orbit_lines
    assert orbit_lines(o)[3].split()[-1] == "section"     # the table's "ends with"
    lam = np.sort(np.abs(o.floquet.values))
    assert abs(lam[0] - mult) < 1e-7 and abs(lam[1] - 1.0) < 1e-7
    assert int(o.stable) == 1 and int(o.continuum) == 0
    # followed in mu, its section rebuilt from the Dataset
    b = phasemap.continue_orbit(o, "mu", (1.0, 1.1), steps=1, model=S)
    assert b.point_kind.values.tolist() == ["end"]
    assert abs(float(b.period[-1]) - _van_der_pol_reference(1.1)[0]) < 1e-8


def _unstable_stribeck_cycle(c, v=0.5, delta=3.0):
    """Half the range of x on the unstable slip cycle of a block on
    a spring (m = k = g = 1), damped by c, on a belt at v with the slip coefficient
    1 / (1 + delta (v - x')), from scipy alone: the fixed point of the return map from
    one maximum of x to the next, by Brent's method (an unstable cycle is as good a root
    as any), its lowest point refined on the dense output."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq, minimize_scalar

    def f(t, y):
        return [y[1], -y[0] - c * y[1] + 1 / (1 + delta * (v - y[1]))]

    def top(t, y):
        return y[1]
    top.direction = -1

    def ret(x0):
        first = solve_ivp(f, (0, 1.0), [x0, 0.0], rtol=1e-12, atol=1e-13).y[:, -1]
        return solve_ivp(f, (1.0, 20.0), first, events=top, rtol=1e-12, atol=1e-13,
                         dense_output=True)
    xeq = 1 / (1 + delta * v)
    x0 = brentq(lambda x0: ret(x0).y_events[0][0][0] - x0, xeq + 0.5, xeq + 0.56,
                xtol=1e-14)
    sol = ret(x0)
    ts = np.linspace(1.0, sol.t_events[0][0], 4001)
    k = int(np.argmin(sol.sol(ts)[0]))
    low = minimize_scalar(lambda t: sol.sol(t)[0], bounds=(ts[k - 1], ts[k + 1]),
                          method="bounded", options={"xatol": 1e-12}).fun
    return (x0 - low) / 2


def test_an_unstable_orbit_without_events_is_followed_on_its_own_crossing():
    """A block on a belt with a falling (Stribeck) friction law and viscous damping c:
    the steady slip is stable, and an unstable slip cycle (a subcritical Hopf) surrounds
    it.  Followed in c from 0.5 to 0.6 it grows (its multiplier above 1); its amplitude at
    0.6 agrees with scipy's to 1e-8.  The section's equation holds where the orbit
    crosses it either way: the shooting once converged on another orbit's crossing the
    other way, which the continuation took for a grazing-sliding at c = 0.55."""
    delta = Parameter("delta", "s m-1", "decay of the slip coefficient with the speed",
                      default=3.0, lower=0.0)
    v = Parameter("v", "m s-1", "speed of the belt", default=0.5)
    S = _block("damped_stribeck", PointContact(
        "belt", point=(x, y), friction=fs / (1 + delta * SLIP_SPEED), static_friction=fs,
        surface_velocity=v), parameters=(v, fs, delta, c), dissipation=c * x.rate ** 2 / 2)
    o = phasemap.periodic_orbit(S, start={"x": 0.4 + 0.196, "xdot": 0.0, "c": 0.5},
                                period=2 * math.pi)
    assert int(o.stable) == 0 and np.max(np.abs(o.floquet.values)) > 1.1
    b = phasemap.continue_orbit(o, "c", (0.5, 0.6), steps=2, model=S)
    assert b.point_kind.values.tolist() == ["end"] and np.all(b.n_segments.values == 1)
    assert np.all(b.stable.values == 0)
    assert abs(float(b.amplitude_x[-1]) - _unstable_stribeck_cycle(0.6)) < 1e-8


def test_a_centre_of_slip_orbits_is_reported_as_a_continuum():
    """With f_s = f_k the belt's block slips backwards for ever on any swing below the
    belt's speed: x'' = -x + f_k, a centre, every orbit periodic with period 2 pi.  The
    orbit is the one through the start (amplitude 0.1 from x = 0.6), both multipliers are
    1, and it is reported as one of a continuum (the friction analogue of
    n_solutions = 3), which continue_orbit refuses in one line."""
    start = {"x": 0.6, "xdot": 0.0, "f_s": 0.5, "f_k": 0.5}
    for kw in ({}, {"period": 6.0}):
        o = phasemap.periodic_orbit("belt", start=start, **kw)
        assert abs(float(o.period) - 2 * math.pi) < 1e-9
        assert int(o.continuum) == 1 and int(o.stable) == 0
        assert np.allclose(np.abs(o.floquet.values), 1.0, atol=1e-7)
        radius = math.hypot(float(o.segment_x[0]) - 0.5, float(o.segment_xdot[0]))
        assert abs(radius - 0.1) < 1e-9
    with pytest.raises(ValueError, match="one of a continuum") as err:
        phasemap.continue_orbit(o, "v", (0.2, 0.3))
    assert "\n" not in str(err.value)
    from phasemap.atlas.read import orbit_lines
    assert "one of a continuum" in orbit_lines(o)[0]


@pytest.mark.parametrize("damping, settle", [(0.1, 60.0), (1.0, None)])
def test_a_motion_without_events_that_does_not_return_says_so(damping, settle):
    """Viscous damping on the same centre: the swing decays, the motion meets no event
    and never comes back to a state, and periodic_orbit says so in one line; also where
    it has decayed to the rounding (c = 1 over the default settle), whose returns are all
    at the equilibrium."""
    block = _block("damped", PointContact("belt", point=(x, y), friction=fk,
                                          static_friction=fs, surface_velocity=_v),
                   parameters=(_v, fs, fk, c), dissipation=c * x.rate ** 2 / 2)
    with pytest.raises(ValueError, match="meets no event and does not come back") as err:
        phasemap.periodic_orbit(block, start={"x": 0.6, "xdot": 0.0, "f_s": 0.5,
                                              "v": 0.2, "c": damping}, settle=settle)
    assert "\n" not in str(err.value)


def test_a_forced_orbit_of_one_segment_against_its_closed_form():
    """A forced block slipping backwards on a fast belt all the time, x'' + x = f_k +
    F0 cos(Omega t): one segment, ended by the forcing period, no event.  Its orbit is
    x = f_k + F0 cos(Omega t) / (1 - Omega^2); its multipliers, an undamped oscillator's
    over 2 pi / Omega, exp(+-2 pi i / Omega) (+-i at Omega = 0.8), so it is isolated."""
    import sympy as sp

    from phasemap.declare import TIME

    F0 = Parameter("F0", "N", "amplitude of the applied force", default=0.3)
    Om = Parameter("Omega", "rad s-1", "forcing frequency", default=0.8, lower=0.0,
                   lower_open=True)
    block = _block("forced_belt", PointContact("belt", point=(x, y), friction=fk,
                                               surface_velocity=_v),
                   parameters=(_v, fk, F0, Om), forces={x: F0 * sp.cos(Om * TIME)},
                   period=2 * sp.pi / Om)
    X = 0.3 / (1 - 0.64)
    o = phasemap.periodic_orbit(block, start={"x": 0.5 + X, "xdot": 0.0})
    assert o.segment_end.values.tolist() == [-1]
    assert abs(float(o.period) - 2 * math.pi / 0.8) < 1e-12
    t0 = float(o.segment_start[0])
    assert abs(float(o.segment_x[0]) - (0.5 + X * math.cos(0.8 * t0))) < 1e-9
    assert abs(float(o.segment_xdot[0]) + 0.8 * X * math.sin(0.8 * t0)) < 1e-9
    assert np.allclose(np.sort_complex(o.floquet.values), [-1j, 1j], atol=1e-7)
    assert int(o.continuum) == 0
    # the shooting's Jacobian of its one segment (whose start is also the next one's)
    # against central differences of the residual
    from phasemap.motion.periodic import continuation, orbit

    mech = mechanics(block)
    p = np.array([float(o.attrs[f"phasemap_parameter_{nm}"]) for nm in mech.parameters])
    segs, w, t_a = continuation._from_dataset(mech, o, p, 1e-12)
    motion = hybrid.Motion(mech, p, hybrid.Options(1.0, rtol=1e-12))
    sc = motion.scales(w[:2], w[2:4], mech.pieces(w[:2], w[2:4], p, t_a))

    def residual(v):
        ends, _ = orbit._ends(motion, segs, v, t_a, 1e-12, sc)
        return orbit._residual(motion, segs, v, ends, 2 * math.pi / 0.8, sc)
    ends, starts = orbit._ends(motion, segs, w, t_a, 1e-12, sc)
    J = orbit.jacobian(motion, segs, w, ends, starts, 2 * math.pi / 0.8, 1e-12, sc)
    D = np.column_stack([(residual(w + e) - residual(w - e)) / 2e-6
                         for e in 1e-6 * np.eye(w.size)])
    assert np.allclose(J, D, atol=1e-5), (J, D)


@pytest.mark.parametrize("model, kw, match", [
    ("block", {"start": {"x": 1.2}}, "ends with rest"),
    ("belt", {"rtol": 0.5}, "rtol must be in"),
    ("elliptic_pendulum", {}, "written by hand"),
    ("belt", {"start": {"z": 1.0}}, "unknown variable"),
    ("belt", {"start": [0.0, 0.2]}, "start must be a dict"),
])
def test_periodic_orbit_errors_are_one_line(model, kw, match):
    if model == "block":
        model = _block("block", PointContact("floor", point=(x, y), friction=fk,
                                             static_friction=fs))
    with pytest.raises(ValueError, match=match) as err:
        phasemap.periodic_orbit(model, **kw)
    assert "\n" not in str(err.value)


# -- continuation -------------------------------------------------------------------------

def _den_hartog_stop_threshold(Om):
    """The friction r* at which Den Hartog's non-stop orbit first sticks at its reversals,
    computed here from the slip's closed form x = -r + V cos(Om t) + A cos t + B sin t
    (x'' + x = cos(Om t) - r): the symmetric half orbit from x = -X0 at rest to X0 at rest
    (four equations in A, B, t0, X0), and the stick condition at the reversal,
    |cos(Om t1) - X0| <= r, tight at r*."""
    from scipy.optimize import brentq, fsolve

    V = 1 / (1 - Om**2)

    def eqs(z, r):
        A, B, t0, X0 = z
        t1 = t0 + math.pi / Om

        def x(t):
            return -r + V * math.cos(Om * t) + A * math.cos(t) + B * math.sin(t)

        def v(t):
            return -V * Om * math.sin(Om * t) - A * math.sin(t) + B * math.cos(t)
        return [x(t0) + X0, v(t0), x(t1) - X0, v(t1)]

    z = None
    for t0 in np.linspace(0, 2 * math.pi / Om, 32, endpoint=False):
        zz, info, ok, _ = fsolve(eqs, [0.0, 0.0, t0, _den_hartog_amplitude(Om, 0.2)],
                                 args=(0.2,), full_output=True, xtol=1e-14)
        if ok == 1 and zz[3] > 0 and np.max(np.abs(info["fvec"])) < 1e-12:
            z = zz
            break
    sols = {0.2: z}
    for r in np.arange(0.25, 0.9, 0.05):
        z = fsolve(eqs, z, args=(r,), xtol=1e-14)
        sols[float(r)] = z

    def margin(r):
        near = sols[min(sols, key=lambda k: abs(k - r))]
        A, B, t0, X0 = fsolve(eqs, near, args=(r,), xtol=1e-15)
        return abs(math.cos(Om * (t0 + math.pi / Om)) - X0) - r

    return brentq(margin, 0.5, 0.85, xtol=1e-15)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:xtol=")
def test_continuation_locates_the_stops_of_den_hartog_orbit():
    """Den Hartog's orbit (Omega = 0.8) followed in the friction: its reversals turn into
    stops (a crossing-sliding bifurcation) at r*, located by the continuation to 1e-8 of
    the threshold computed here from the closed form; beyond, the orbit has its two stick
    segments and the continuation goes on along it."""
    r_star = _den_hartog_stop_threshold(0.8)
    assert abs(r_star - 0.8174063857) < 1e-9
    o = phasemap.periodic_orbit("den_hartog", start={"f": 0.78})
    b = phasemap.continue_orbit(o, "f", (0.78, 0.83), steps=2)
    kinds = [str(k) for k in b.point_kind.values]
    assert kinds[0] == "crossing_sliding"
    assert abs(float(b.point_f[0]) - r_star) < 1e-8
    before, after = b.f.values < r_star, b.f.values > r_star
    assert set(b.n_segments.values[before]) == {3}      # slip, slip, slip (period cut)
    assert set(b.n_segments.values[after]) == {5}       # two stick segments more
    assert np.allclose(b.period.values, 2 * math.pi / 0.8, atol=1e-12)
    assert kinds[-1] == "end" and abs(float(b.point_f[-1]) - 0.83) < 1e-12


@pytest.mark.slow
def test_continuation_of_the_belt_orbit_in_the_belt_speed():
    """The belt's stick-slip orbit followed in v: no change of its sequence, and its
    period T(v) = 2 delta / v + pi + 2 arctan(v / delta) at every point."""
    o = phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2})
    b = phasemap.continue_orbit(o, "v", (0.2, 0.5), steps=3)
    v = b.v.values
    T = 2 * 0.5 / v + math.pi + 2 * np.arctan(v / 0.5)
    assert v.size == 4
    assert np.allclose(b.period.values, T, rtol=0, atol=1e-9)
    assert [str(k) for k in b.point_kind.values] == ["end"]
    assert np.all(b.stable.values == 1)
    # the slip swings about x = f_k = 0.5 with the amplitude sqrt(delta^2 + v^2) (it
    # starts at x = 1 moving up at v), past both ends of the stick
    assert np.allclose(b.amplitude_x.values, np.hypot(0.5, v), rtol=0, atol=1e-9)


@pytest.mark.parametrize("old, new, kind", [
    # a reversal gains a stick at each end of a symmetric swing (a forced orbit, whose
    # period ends inside a slip: merged)
    ([("+", 2.0), ("-", 3.1), ("+", 1.1)], [("+", 3.1), ("s", 1e-6), ("-", 3.1), ("s", 1e-6)],
     "crossing_sliding"),
    ([("s", 5.0), ("-", 3.9)], [("s", 5.0), ("-", 2.0), ("s", 1e-4), ("-", 1.9)],
     "grazing_sliding"),
    ([("s", 5.0), ("-", 3.9)], [("s", 5.0), ("-", 1e-5), ("s", 2e-5), ("-", 3.9)],
     "adding_sliding"),
    ([("s", 5.0), ("-", 3.9)], [("s", 5.0), ("+", 1e-5), ("-", 3.9)], "switching_sliding"),
    # the same sequence with one segment more but none short, or another order
    ([("s", 5.0), ("-", 3.9)], [("s", 5.0), ("-", 2.0), ("s", 1.0), ("-", 1.9)],
     "sequence_change"),
    ([("s", 5.0), ("-", 3.9)], [("+", 5.0), ("s", 1e-5), ("-", 3.9)], "sequence_change"),
])
def test_sliding_bifurcations_are_named_from_the_short_segments(old, new, kind):
    """The names of sliding bifurcations from the sequences and their durations, either
    way round (a segment born, or shrinking into the orbit)."""
    from phasemap.motion.periodic.orbit import Segment
    from phasemap.motion.periodic.sliding import kind as name

    modes = {"+": hybrid.SLIP_POS, "-": hybrid.SLIP_NEG, "s": hybrid.STICK}

    def segs(runs):
        return ([Segment((modes[m],), np.ones(1), 1, -1) for m, _ in runs],
                np.array([d for _, d in runs]))
    assert name(*segs(old), *segs(new)) == kind
    assert name(*segs(new), *segs(old)) == kind
    # with a second contact closed all the time, the same; with it changing too, not named
    two = [((hybrid.STICK, modes[m]), d) for m, d in new]
    segs2 = ([Segment(m, np.ones(2), 1, -1) for m, _ in two], np.array([d for _, d in two]))
    old2 = ([Segment((hybrid.STICK, modes[m]), np.ones(2), 1, -1) for m, _ in old],
            np.array([d for _, d in old]))
    assert name(*old2, *segs2) == kind
    mixed = ([Segment((hybrid.SLIP_POS if i == 0 else hybrid.STICK, modes[m]), np.ones(2), 1,
                      -1) for i, (m, _) in enumerate(new)], segs2[1])
    assert name(*old2, *mixed) == "sequence_change"


def test_continuation_checks_its_arguments():
    o = phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2})
    with pytest.raises(ValueError, match="unknown parameter 'w'"):
        phasemap.continue_orbit(o, "w", (0.1, 0.3))
    with pytest.raises(ValueError, match="outside the span"):
        phasemap.continue_orbit(o, "v", (0.3, 0.5))
    with pytest.raises(ValueError, match="lo < hi"):
        phasemap.continue_orbit(o, "v", (0.5, 0.1))


def test_cli_orbit_prints_and_writes_a_cf_file(capsys, tmp_path):
    import xarray as xr

    from phasemap.cli import main

    out = tmp_path / "belt.nc"
    code = main(["orbit", "belt", "x=0", "xdot=0.2", "-o", str(out)])
    text = capsys.readouterr().out
    assert code == 0
    assert "period    8.9026054078" in text and f"wrote {out}" in text
    # the segments' table: the slip ends with the stick, the stick with the slip
    assert re.search(r"^ +0 +3\.9026054078\d* +slip_neg +stick$", text, re.M), text
    assert re.search(r"^ +1 +5 +stick +slip$", text, re.M), text
    assert "Floquet multipliers" in text
    with xr.open_dataset(out) as ds:
        assert abs(float(ds.period) - 8.902605407815) < 1e-9
        assert ds.floquet_real.dims == ("multiplier",)
        assert ds.attrs["phasemap_kind"] == "periodic_orbit"
    from phasemap.atlas.cfcheck import cfcheck

    report, passed = cfcheck(out)
    assert passed, report
    assert main(["info", str(out)]) == 0
    summary = capsys.readouterr().out
    assert "phasemap periodic orbit" in summary and "period    8.9026054078" in summary
    assert "stick" in summary and "Floquet multipliers" in summary


def test_cli_simulates_an_oscillator_by_name(capsys):
    from phasemap.cli import main

    code = main(["simulate", "belt", "x=0", "xdot=0.2", "--t-end", "10", "--rtol", "1e-10"])
    text = capsys.readouterr().out
    assert code == 0 and "slip" in text and "stick" in text and "belt" in text


def test_a_special_point_is_drawn_on_its_own_arm_of_a_turning_branch():
    """A branch that turns (p = 1, 2, 3, 2, 1) stored without the points' own values (an
    older file): a period doubling at a vertex of the second arm, p = 2, is drawn at that
    vertex (matched by its period), not on the first arm where p = 2 too."""
    import xarray as xr

    from phasemap.plot.orbits import _at_point

    ds = xr.Dataset({"period": ("vertex", [6.0, 6.1, 6.2, 6.3, 6.4]),
                     "point_period": ("point", [6.3])})
    p, v = np.array([1.0, 2.0, 3.0, 2.0, 1.0]), np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    assert _at_point(ds, 0, "amplitude_x", 2.0, p, v) == 3.0
    assert _at_point(ds, 0, "amplitude_x", 2.5, p, v) == 1.5     # interpolated, first arm


def test_orbit_and_branch_figures_pass_the_review(tmp_path):
    """ds.phasemap.plot() of an orbit (its phase plane, segments by mode) and of a branch
    (stable solid, special points by kind), checked as the tour's figures are."""
    import matplotlib.pyplot as plt

    import figure_review as fr

    o = phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2})
    fig = o.phasemap.plot()
    a = fig.axes[0]
    assert a.get_xlabel() == "x (m)" and a.get_ylabel() == "xdot (m s-1)"
    labels = [t.get_text() for t in a.get_legend().get_texts()]
    assert "belt stick" in labels and "belt slip neg" in labels
    stick = [ln for ln in a.get_lines() if ln.get_label() == "belt stick"][0]
    assert np.allclose(stick.get_ydata(), 0.2, atol=1e-9)      # riding with the belt
    for check in (fr.layout_problems, fr.unit_problems, fr.greyscale_problems,
                  fr.legend_drawn_problems):
        assert check(fig) == [], check.__name__
    plt.close(fig)
    b = phasemap.continue_orbit(o, "v", (0.2, 0.3), steps=1)
    fig = b.phasemap.plot()
    assert fig.axes[0].get_xlabel() == "v (m s-1)"
    for check in (fr.layout_problems, fr.legend_drawn_problems):
        assert check(fig) == [], check.__name__
    plt.close(fig)


@pytest.mark.slow
def test_continuation_in_the_forcing_frequency():
    """Den Hartog's orbit followed in Omega (its forcing period changes along the branch):
    the amplitude at each point is the closed form's."""
    o = phasemap.periodic_orbit("den_hartog", start={"f": 0.2})
    b = phasemap.continue_orbit(o, "Omega", (0.8, 0.84), steps=2)
    assert b.Omega.values.tolist() == pytest.approx([0.8, 0.82, 0.84], abs=1e-12)
    exact = [_den_hartog_amplitude(float(w), 0.2) for w in b.Omega.values]
    assert np.allclose(b.amplitude_x.values, exact, rtol=0, atol=1e-8)
    assert np.allclose(b.period.values, 2 * math.pi / b.Omega.values, rtol=0, atol=1e-9)


def _duffing(ref_values):
    """The built-in ``duffing`` at a reference's values (tests/references/duffing_fold.py
    names them F, r, k1 for F0, f, k)."""
    names = {"F": "F0", "r": "f", "k1": "k"}
    return {names.get(nm, nm): v for nm, v in ref_values.items()}


@pytest.mark.parametrize("name", ["belt", "den_hartog", "stribeck_belt"])
def test_the_jump_derivative_is_the_loop_of_differences(name):
    """The saltation's jump derivative takes its differences' projections in one compiled
    call (``Motion.project_velocities``): the bits of the loop of central differences of
    ``project_velocity``, one projection each, at random states, the held contacts' time
    column included."""
    from phasemap.declare.full import mechanics
    from phasemap.motion.hybrid import Motion, Options
    from phasemap.motion.periodic import floquet as fq
    from phasemap.motion.periodic import orbit

    mech = mechanics(orbit.system_of(name))
    p = np.array([mech.defaults[k] for k in mech.parameters])
    m = Motion(mech, p, Options(1.0))
    n = mech.n
    rng = np.random.default_rng(4)
    for _ in range(10):
        X = rng.normal(size=2 * n + 1)
        q, u, t = X[:n], X[n:2 * n], X[2 * n]
        for closed, held in [([0], ()), ([0], (0,))]:
            got = fq.jump_derivative(m, X, closed, held)
            for j in range(n):
                want = fq.difference(lambda r: m.project_velocity(r, u, closed, held, t), q, j)
                assert np.array_equal(got[n:2 * n, j], want)
            if held:
                want = fq.difference(lambda s: m.project_velocity(q, u, closed, held, s[0]),
                                     np.array([t]), 0)
                assert np.array_equal(got[n:2 * n, 2 * n], want)
            else:
                assert np.array_equal(got[:, 2 * n], np.eye(2 * n + 1)[:, 2 * n])


def test_a_branch_that_comes_back_fast_lands_on_the_spans_end():
    """Round the fold and back down, the branch runs fast in Omega towards the span's
    start: the parabola through the last three points overshoots the end, and the step
    that lands on it is the secant's, never behind the last point (once, predicted from
    the parabola, it went back and the branch turned at 16 folds that are not there)."""
    from references import duffing_fold as ref

    o = phasemap.periodic_orbit("duffing", start={**_duffing(ref.FOLD), "Omega": 1.55,
                                                  "x": 0.19, "xdot": 1.96})
    b = phasemap.continue_orbit(o, "Omega", (1.545, 1.6), steps=2)
    assert [str(kd) for kd in b.point_kind.values] == ["end", "fold", "end"]
    assert abs(float(b.point_Omega[1]) - ref.OMEGA_UPPER) < 1e-9
    om = b.Omega.values
    top = int(np.argmax(om))
    assert np.all(np.diff(om[:top + 1]) > 0) and np.all(np.diff(om[top:]) < 0)


def test_a_grazing_event_leaves_the_multipliers_undefined_not_an_error(monkeypatch):
    """Where the flow meets an event tangentially the saltation matrix is not defined
    (NaN): the multipliers are NaN and the orbit is not called stable, where NumPy's
    eigenvalues of a NaN matrix raised."""
    from phasemap.declare.full import mechanics
    from phasemap.motion.hybrid import Motion, Options
    from phasemap.motion.periodic import continuation, floquet, orbit

    o = phasemap.periodic_orbit("belt")
    mech = mechanics(orbit.system_of("belt"))
    p = np.array([float(o.attrs[f"phasemap_parameter_{nm}"]) for nm in mech.parameters])
    segs, w, t_a = continuation._from_dataset(mech, o, p, 1e-12)
    motion = Motion(mech, p, Options(1.0, rtol=1e-12))
    good = orbit.linearised(motion, segs, w, t_a, None, 1e-12)
    assert np.all(np.isfinite(good.multipliers))
    monkeypatch.setattr(floquet, "saltation",
                        lambda DJ, Fm, Fp, grad: np.full_like(DJ, np.nan))
    got = orbit.linearised(motion, segs, w, t_a, None, 1e-12)
    assert got.multipliers.shape == good.multipliers.shape
    assert np.all(np.isnan(got.multipliers)) and not got.stable and got.trivial == -1


@pytest.mark.slow
def test_pseudo_arclength_goes_round_the_fold_of_a_hardening_oscillator():
    """A forced hardening oscillator with dry and viscous friction: its large orbit,
    followed in Omega, turns back at the fold of its resonance curve.  The continuation
    goes round it onto the unstable orbit, locates the fold (Omega as an extremum along
    the branch) to 1e-9 of scipy's own fold (tests/references/duffing_fold.py: det(DP -
    I) = 0 on the return map), and the stability changes there."""
    from references import duffing_fold as ref

    o = phasemap.periodic_orbit("duffing", start={**_duffing(ref.FOLD), "Omega": 1.55,
                                                  "x": 0.19, "xdot": 1.96})
    b = phasemap.continue_orbit(o, "Omega", (1.55, 1.6), steps=2)
    kinds = [str(kd) for kd in b.point_kind.values]
    assert kinds == ["fold", "end"]
    assert abs(float(b.point_Omega[0]) - ref.OMEGA_UPPER) < 1e-9
    om = b.Omega.values
    top = int(np.argmax(om))
    assert om.max() <= ref.OMEGA_UPPER + 1e-9 < 1.6     # it never passes the fold
    assert np.all(np.diff(om[:top + 1]) > 0) and np.all(np.diff(om[top:]) < 0)
    # back at Omega = 1.55 on the other orbit: the unstable one, of smaller amplitude
    assert om[0] == pytest.approx(1.55, abs=1e-12) and om[-1] == pytest.approx(1.55, abs=1e-12)
    assert b.stable.values[0] == 1 and b.stable.values[-1] == 0
    assert float(b.amplitude_x[-1]) < float(b.amplitude_x[0]) - 0.05
    assert np.all(b.residual.values < 1e-9)
    # the fold is a point of the branch, where the largest multiplier is 1: below 1 on
    # the stable side, above it beyond
    assert om[top] == float(b.point_Omega[0])
    assert float(b.point_amplitude_x[0]) == float(b.amplitude_x[top])
    fm, st = b.floquet_max.values, b.stable.values.astype(bool)
    assert abs(fm[top] - 1.0) < 1e-6
    others = np.arange(om.size) != top
    assert np.all(fm[st & others] < 1.0) and np.all(fm[~st & others] > 1.0)
    # the stable orbit's multipliers are those of the reference's return map there
    from scipy.optimize import root

    at = {**ref.FOLD, "Omega": 1.55}
    z = root(lambda z: ref.return_map(z, **at) - z, [0.19, 1.96], tol=1e-13).x
    assert abs(fm[0] - np.abs(np.linalg.eigvals(ref.derivative(z, **at))).max()) < 1e-6


@pytest.mark.slow
def test_a_period_doubling_is_located_where_a_multiplier_passes_minus_one():
    """Ueda's oscillator with dry friction (tests/references/duffing_fold.py): its
    period-one orbit, unstable at F = 8 with a multiplier below -1, followed in F regains
    its stability through -1 (a period doubling, on one mode sequence).  The point is
    located to 2e-8 of scipy's own (det(DP + I) = 0 on the return map; its two steps of
    differences agree to 5e-9), and it is a point of the branch with the multiplier -1."""
    from references import duffing_fold as ref

    o = phasemap.periodic_orbit("duffing", start={**_duffing(ref.DOUBLING), "F0": 8.0,
                                                  "x": 2.37959359, "xdot": -0.31001823},
                                period=2 * math.pi)
    assert int(o.stable) == 0 and float(np.abs(o.floquet).max()) > 1.0
    b = phasemap.continue_orbit(o, "F0", (8.0, 8.05), steps=2)
    assert [str(kd) for kd in b.point_kind.values] == ["period_doubling", "end"]
    f_pd = float(b.point_F0[0])
    assert abs(f_pd - ref.F_DOUBLING) < 2e-8
    i = int(np.flatnonzero(b.F0.values == f_pd)[0])
    assert abs(float(b.floquet_max[i]) - 1.0) < 1e-8
    assert set(b.stable.values[:i]) == {0} and set(b.stable.values[i + 1:]) == {1}
    assert set(b.n_segments.values) == {3}      # one mode sequence all along


@pytest.mark.slow
def test_ueda_orbit_followed_down_meets_a_stop_where_simulate_finds_it():
    """Ueda's period-one orbit at F0 = 8.12 reverses twice near x = 1.32 (its velocity
    just crosses zero there, for 0.05 of the period), then twice more.  Followed down in
    F0, the pair's first reversal reaches the edge of the sticking region: a stick
    segment appears (crossing-sliding) between 8.112563 and 8.11257, the bracket that
    simulate's settled motions give here (a stop every period below, none above).  The
    continuation once reported its sequence changing at 8.1188 instead: the motion it
    checks each orbit against missed that pair of reversals inside one step."""
    from references import duffing_fold as ref

    def stops(F0):
        ds = phasemap.simulate("duffing", 150 * 2 * math.pi, **_duffing(ref.DOUBLING),
                               F0=F0, x=2.404, xdot=-0.3226, rtol=1e-11)
        last = ds.event_t.values > float(ds.t[-1]) - 2 * math.pi
        return int(np.sum(ds.event_kind.values[last] == ev.STICK))
    assert stops(8.112563) == 1 and stops(8.11257) == 0
    o = phasemap.periodic_orbit("duffing", start={**_duffing(ref.DOUBLING), "F0": 8.12,
                                                  "x": 2.40505631, "xdot": -0.3230207},
                                period=2 * math.pi)
    assert o.sizes["segment"] == 5
    b = phasemap.continue_orbit(o, "F0", (8.1125, 8.12), steps=3)
    kinds = [str(k) for k in b.point_kind.values]
    assert kinds == ["end", "crossing_sliding"], kinds
    assert 8.112563 < float(b.point_F0[1]) < 8.11257


def test_a_symbol_that_is_not_the_declared_one_is_refused():
    """sympy tells Symbol('xdot') from the declared rate (real=True) by its assumptions,
    so a dissipation written with it would silently be zero: it is a one-line error."""
    import sympy as sp

    S = _block("damped", PointContact("floor", point=(x, y), friction=0), (c,),
               dissipation=c * sp.Symbol("xdot")**2 / 2)
    with pytest.raises(ValueError, match=r"^damped: dissipation: the symbol 'xdot' is not "
                                         r"the declared one[^\n]*$"):
        phasemap.simulate(S, 1.0, x=1.0)
