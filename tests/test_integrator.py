"""The time integrator (phasemap.motion.integrate through phasemap.simulate) against independent solutions.

References are written here from the models' docstring derivations, not
imported from phasemap: the weightless hinge pendulum's closed form (36), and
scipy's DOP853 at rtol 1e-12 on the equations of motion, stage by stage, with
its own events.  Kernels are compiled once per model (numba's on-disk cache
keeps them between runs).
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from conftest import assert_atlas_round_trip
from scipy.integrate import solve_ivp

import phasemap
from phasemap.motion.integrate import METHODS

G = 9.81


def all_finite(ds: xr.Dataset) -> bool:
    return all(np.isfinite(ds[v].values).all() for v in ds.variables
               if ds[v].dtype.kind == "f")


def kinds(ds: xr.Dataset) -> list[str]:
    return [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]


# ------------------------------------------------------ independent references
def weightless(t, phi0, omega0, delta, l):
    """Eq. (36): phi'' = -sgn(omega) k omega^2, k = delta / sqrt(l^2 - delta^2)."""
    k = delta / math.sqrt(l * l - delta * delta)
    grow = 1.0 + k * abs(omega0) * t
    return phi0 + math.copysign(1.0, omega0) * np.log(grow) / k, omega0 / grow


def weightless_run(t_end, omega0, n=None, **options):
    """The weightless hinge pendulum (delta = 0.3, l = 1) simulated from phi = 0 with
    ``options`` (saved at ``n`` times over [0, t_end] when given), and its exact
    (phi, omega) from (36) at the saved times: ``(ds, phi, omega)``."""
    if n is not None:
        options["t_eval"] = np.linspace(0, t_end, n)
    ds = phasemap.simulate("hinge_pendulum", t_end, phi=0.0, omega=omega0, delta=0.3, g=0.0,
                           **options)
    return (ds, *weightless(ds.t.values, 0.0, omega0, 0.3, 1.0))


def hinge_rhs(delta, l, g):
    """l phi'' = u - g sin phi with l u = -sigma delta sqrt(Q_n^2 + u^2), Q_n = l w^2 + g cos phi,
    solved for u: u = -sigma delta |Q_n| / sqrt(l^2 - delta^2)."""
    k = delta / math.sqrt(l * l - delta * delta)

    def rhs(t, y, sigma):
        phi, w = y
        qn = l * w * w + g * math.cos(phi)
        return [w, (-sigma * k * abs(qn) - g * math.sin(phi)) / l]
    return rhs


def wheel_rhs(delta, r, l, rho, g):
    """B phi'' = -l (r sin phi + delta sigma cos phi) w^2 - g l sin phi - delta sigma g,
    B = rho^2 + r^2 + l^2 - 2 r l cos phi + delta sigma l sin phi (momentum of C and
    angular momentum about C with the rolling constraint)."""
    def rhs(t, y, sigma):
        phi, w = y
        s, c = math.sin(phi), math.cos(phi)
        b = rho * rho + r * r + l * l - 2 * r * l * c + delta * sigma * l * s
        return [w, (-l * (r * s + delta * sigma * c) * w * w - g * l * s - delta * sigma * g) / b]
    return rhs


def staged_reference(rhs, phi0, omega0, t_end, l, delta, rtol=1e-12):
    """Stage-by-stage DOP853: rest where l |sin phi| <= delta at a velocity zero (both
    systems), else the motion restarts towards the falling side, sigma = -sgn(sin phi)."""
    t, y = 0.0, [phi0, omega0]
    sigma = math.copysign(1.0, omega0) if omega0 != 0.0 else -math.copysign(1.0, math.sin(phi0))
    stages, reversals = [], []
    while True:
        def zero(t, y, sigma):
            return sigma * y[1]
        zero.terminal, zero.direction = True, -1
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=rtol, atol=rtol,
                        events=zero, dense_output=True, args=(sigma,))
        if sol.status == 0:
            stages.append((t, t_end, sol.sol))
            return dict(fate="horizon", t=t_end, phi=sol.y[0, -1], reversals=reversals,
                        stages=stages)
        t_ev, phi = sol.t_events[0][0], sol.y_events[0][0][0]
        stages.append((t, t_ev, sol.sol))
        t, y = t_ev, [phi, 0.0]
        if l * abs(math.sin(phi)) <= delta:
            return dict(fate="rest", t=t, phi=phi, reversals=reversals, stages=stages)
        reversals.append(t)
        sigma = -math.copysign(1.0, math.sin(phi))


def reference_states(ref, times):
    out = []
    for t in times:
        if t >= ref["t"]:
            out.append([ref["phi"], 0.0] if ref["fate"] == "rest" else [np.nan, np.nan])
            continue
        for t0, t1, sol in ref["stages"]:
            if t0 <= t <= t1:
                out.append(sol(t))
                break
    return np.array(out)


# --------------------------------------------------------------- closed form
@pytest.mark.parametrize("method", METHODS)
def test_weightless_hinge_pendulum_matches_the_exact_solution(method):
    # A Dormand-Prince step keeps its local error below rtol |y| + atol (|y| <= 10 here),
    # and the motion is contractive in omega (omega' = -k omega^2), so the global error
    # stays within a few hundred local errors over the ~160 steps: about 1e-10 x 10 x 10.
    # 1e-8 is the bound with a margin; measured 3e-10.
    t = np.linspace(0.0, 10.0, 201)
    for omega0 in (5.0, -3.0):
        ds = phasemap.simulate("hinge_pendulum", 10.0, method=method, rtol=1e-10, t_eval=t, phi=0.5,
                               omega=omega0, delta=0.3, g=0.0)
        phi, omega = weightless(t, 0.5, omega0, 0.3, 1.0)
        assert ds.attrs["end_reason"] == "horizon"
        assert np.max(np.abs(ds.phi.values - phi)) < 1e-8
        assert np.max(np.abs(ds.omega.values - omega)) < 1e-8
        # the saved steps (no t_eval) are on the solution too
        steps = phasemap.simulate("hinge_pendulum", 10.0, method=method,
                                  rtol=1e-10, phi=0.5, omega=omega0, delta=0.3, g=0.0)
        phi, omega = weightless(steps.t.values, 0.5, omega0, 0.3, 1.0)
        assert np.max(np.abs(steps.phi.values - phi)) < 1e-8


@pytest.mark.parametrize("method", METHODS)
def test_dense_output_is_as_accurate_as_the_steps(method):
    # t_eval states come from the continuous extension (order 4): between the steps they
    # must be as accurate as at the steps (a wrong dense coefficient made them O(h)).
    t = np.linspace(0.0, 10.0, 1001)
    for rtol, bound in ((1e-6, 1e-4), (1e-9, 1e-7)):
        ds = phasemap.simulate("hinge_pendulum", 10.0, method=method,
                               rtol=rtol, t_eval=t, phi=0.0, omega=5.0, delta=0.3, g=0.0)
        phi, _ = weightless(t, 0.0, 5.0, 0.3, 1.0)
        assert np.max(np.abs(ds.phi.values - phi)) < bound, rtol


# ------------------------------------------------- through reversals, to rest
CASES = {
    "hinge_pendulum": dict(values=dict(phi=2.5, omega=0.0, delta=0.05), t_end=20.0,
                           rhs=hinge_rhs(0.05, 1.0, G), l=1.0, delta=0.05),
    "wheel": dict(values=dict(phi=2.0, omega=0.0, delta=0.05), t_end=20.0,
                  rhs=wheel_rhs(0.05, 1.0, 0.5, 0.5, G), l=0.5, delta=0.05),
}


@pytest.fixture(scope="module")
def references():
    return {name: staged_reference(c["rhs"], c["values"]["phi"], c["values"]["omega"],
                                   c["t_end"], c["l"], c["delta"])
            for name, c in CASES.items()}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("model", list(CASES))
def test_reversals_and_rest_match_an_independent_solution(model, references, method):
    case, ref = CASES[model], references[model]
    assert len(ref["reversals"]) >= 3 and ref["fate"] == "rest"
    t = np.linspace(0.0, case["t_end"], 401)
    # rtol 1e-11: the hinge's acceleration has a kink where Q_n = l w^2 + g cos phi = 0,
    # where one step can add ~300 rtol (3e-8 at rtol 1e-10); 1e-7 keeps a wide margin here
    ds = phasemap.simulate(model, case["t_end"], method=method,
                           rtol=1e-11, t_eval=t, **case["values"])
    assert ds.attrs["end_reason"] == "rest"
    assert int(ds.attrs["n_reversals"]) == len(ref["reversals"])
    ev_t = ds.event_t.values[np.array(kinds(ds)) == "reversal"]
    np.testing.assert_allclose(ev_t, ref["reversals"], rtol=0, atol=1e-7)
    phi_rest = float(ds.event_phi[-1])
    assert case["l"] * abs(math.sin(phi_rest)) <= case["delta"]  # inside the stagnation zone
    assert abs(phi_rest - ref["phi"]) < 1e-7
    assert abs(float(ds.event_t[-1]) - ref["t"]) < 1e-7
    want = reference_states(ref, t)
    assert np.max(np.abs(ds.phi.values - want[:, 0])) < 1e-7
    assert np.max(np.abs(ds.omega.values - want[:, 1])) < 1e-7
    assert float(ds.event_omega[-1]) == 0.0 and all(ds.omega.values[t > ref["t"]] == 0.0)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("rtol", [1e-6, 1e-9, 1e-12])
def test_first_velocity_zero_located_to_the_tolerance(rtol, method):
    rhs = hinge_rhs(0.05, 1.0, G)

    def zero(t, y, sigma):
        return sigma * y[1]
    zero.terminal, zero.direction = True, -1
    ref = solve_ivp(rhs, (0.0, 5.0), [2.5, 0.0], method="DOP853", rtol=1e-13, atol=1e-13,
                    events=zero, args=(-1.0,))
    t_ref = ref.t_events[0][0]
    ds = phasemap.simulate("hinge_pendulum", 5.0, method=method,
                           rtol=rtol, phi=2.5, omega=0.0, delta=0.05)
    t_ev = float(ds.event_t[1])
    assert kinds(ds)[1] == "reversal"
    assert abs(t_ev - t_ref) <= 10.0 * rtol * max(1.0, t_ref)
    # the classification just before the event is the old branch, just after the new one
    before = ds.isel(t=int(np.searchsorted(ds.t.values, t_ev)) - 1)
    assert float(before.t) < t_ev
    c = phasemap.classify("hinge_pendulum", phi=float(before.phi), omega=float(before.omega),
                          delta=0.05)
    assert [b.name for b in c.branches] == ["turn_neg"]
    after = phasemap.simulate("hinge_pendulum", 5.0, method=method,
                              rtol=rtol, phi=2.5, omega=0.0, delta=0.05, t_eval=[t_ev + 1e-6])
    c = phasemap.classify("hinge_pendulum", phi=float(after.phi[0]), omega=float(after.omega[0]),
                          delta=0.05)
    assert [b.name for b in c.branches] == ["turn_pos"]
    assert int(ds.event_branch[1]) == phasemap.MODELS["hinge_pendulum"].branches.index("turn_pos")


@pytest.mark.parametrize("name", [
    # rod_on_step's point and integrator are test_declare's too: compiled once, not on
    # both workers at once (17.6 s of CPU twice)
    pytest.param(n, marks=pytest.mark.kernels_with("tests/test_declare.py"))
    if n == "rod_on_step" else n for n in sorted(phasemap.MODELS)])
def test_rest_speed_is_the_tolerance_of_the_classification(name):
    """The integrator roots a velocity where it reaches the contract's ``rest_speed``
    (the end of a stage that stops or reverses): it must be the very speed at which
    ``point`` starts to count the velocity as zero: there its rows are those at rest,
    one ulp faster the rows of the other direction and of stick do not apply."""
    m = phasemap.MODELS[name]
    full = {k: float(x) for k, x in m.complete({}).items()}
    vel = m.inputs.index(m.velocity)
    v = m.input_vector(full)
    m.derive(v)
    speed = m.contract.rest_speed(v)
    assert speed > 0.0

    def rows(velocity):
        v[vel] = velocity
        out = np.empty((len(m.branches), m.n_fields))
        m.point(v, out)
        return out

    at_rest = rows(0.0)
    for sign in (1.0, -1.0):
        np.testing.assert_array_equal(rows(sign * speed), at_rest)
        moving = rows(sign * np.nextafter(speed, np.inf))
        away = [b for b, d in enumerate(m.directions) if d * sign <= 0.0]
        assert away and all(moving[away, 0] == 0), (name, sign, moving[:, 0])
        assert not np.array_equal(moving, at_rest, equal_nan=True)


# ------------------------------------------------------------ stick and slip
@pytest.mark.parametrize("method", METHODS)
def test_elliptic_pendulum_sticks_exactly_and_slips_at_the_friction_limit(method):
    f = 0.3
    ds = phasemap.simulate("elliptic_pendulum", 10.0, method=method, rtol=1e-10, phi=1.0, omega=0.0,
                           xdot=0.5, f=f)
    m = phasemap.MODELS["elliptic_pendulum"]
    stick = m.branches.index("stick")
    k = kinds(ds)
    assert k.count("stick") >= 3 and k.count("slip") >= 3
    # every stick stage: slider velocity exactly 0.0, position exactly constant
    branch = ds.branch.values
    edges = np.flatnonzero(np.diff(np.r_[0, (branch == stick).astype(int), 0]))
    assert len(edges) >= 6
    for start, stop in zip(edges[::2], edges[1::2]):
        block = ds.isel(t=slice(start, stop))
        assert np.all(block.xdot.values == 0.0)
        assert np.all(block.x.values == block.x.values[0])
    # each slip starts where |F| = f |N|: the stick branch has just become inadmissible
    for i in np.flatnonzero(np.array(k) == "slip"):
        state = {n: float(ds[f"event_{n}"][i]) for n in ("phi", "omega", "xdot")}
        assert state["xdot"] == 0.0
        c = phasemap.classify("elliptic_pendulum", f=f, **state)
        row = next(b for b in c.candidates if b.name == "stick")
        margin = abs(row.reactions["F"]) - f * abs(row.reactions["N"])
        assert row.status == phasemap.BranchStatus.INADMISSIBLE
        assert 0.0 < margin <= 1e-9 * G  # ~0: located to the model's 1e-12 tie tolerance
        assert c.n_solutions == 1


# --------------------------------------------------------------- extreme cases
R2 = math.sqrt(2.0)


@pytest.mark.parametrize("method", ["DOPRI5", "DOP853"])
def test_a_slider_velocity_that_dips_through_zero_inside_one_step_stops_there(method):
    """The elliptic pendulum's bar spinning fast (omega = 20) shakes the slider: sliding
    forward, its velocity falls to a minimum and rises again within about 1e-3 s.  With
    the start chosen so that the minimum is -1e-4 (the slider's own velocity enters no
    equation, so the start shifts the whole slip by a constant), the velocity reaches
    zero inside what is one step at rtol 1e-8, and the slider stops there: the
    integrator checks the minimum where the velocity's rate turns inside a step (it
    went straight on before).  The time against the slip integrated with the unreduced
    equations of tests/reference.py (scipy, max_step 1e-4)."""
    import reference as ref
    from scipy.optimize import brentq, minimize_scalar

    l, g, m, f = 1.0, 9.81, 1.0, 0.3

    def rhs(t, y):      # sliding forward; the guide's reaction of the sign it has
        phi, omega, xd = y
        out = ref.elliptic_slip(phi, omega, xd, f, l, g, m, 1.0, 1.0)
        if out["N"] < 0.0:
            out = ref.elliptic_slip(phi, omega, xd, f, l, g, m, 1.0, -1.0)
        return [omega, out["phi_ddot"], out["x_ddot"]]

    slip = solve_ivp(rhs, (0.0, 0.45), [0.3, 20.0, 20.0], rtol=1e-12, atol=1e-12,
                     max_step=1e-4, dense_output=True)
    low = minimize_scalar(lambda t: slip.sol(t)[2], bounds=(0.39, 0.41), method="bounded",
                          options={"xatol": 1e-12})
    shift = -float(low.fun) - 1e-4
    t_zero = brentq(lambda t: slip.sol(t)[2] + shift, 0.3, float(low.x), xtol=1e-14)
    ds = phasemap.simulate("elliptic_pendulum", 0.6, method=method, rtol=1e-8, phi=0.3,
                           omega=20.0, xdot=20.0 + shift, f=f, through_contacts=False)
    kinds = [int(k) for k in ds.event_kind.values]
    first = next(i for i, k in enumerate(kinds) if k not in (phasemap.Event.START,
                                                             phasemap.Event.SWITCH))
    assert kinds[first] == phasemap.Event.STICK, kinds
    assert abs(float(ds.event_t[first]) - t_zero) <= 1e-7


@pytest.mark.parametrize("method", ["DOPRI5"])  # DOP853's events: the hinge, elliptic, wheel
@pytest.mark.parametrize("f, phi, omega, ends", [
    (R2 - 1e-9, 0.3, -0.5, {"rest"}),
    # spinning fast towards the wall: the (near-singular) kept slide and flying off both
    # contacts are both consistent: two solutions from t = 0
    (R2 + 1e-9, 0.5, -4.0, {"indeterminate"}),
    # (8) is singular at f = sqrt 2, but leaving the wall is the unique solution
    (R2, 0.3, 0.5, {"contact_lost"}),
])
def test_ladder_with_f_near_sqrt2(f, phi, omega, ends, method):
    ds = phasemap.simulate("ladder", 1.0, method=method, rtol=1e-10, phi=phi, omega=omega, f=f,
                           through_contacts=False)
    assert all_finite(ds)
    assert ds.attrs["end_reason"] in ends


def _wall_release(f, phi0, omega0, l=1.0, g=9.81):
    """Where the ladder's wall reaction vanishes on the sliding stage through (phi0, omega0):
    the first integral of (8), u = c e^{lam phi} + a sin phi + b cos phi, its derivative
    phi'' = u'/2 and the wall reaction from the momentum equations (tests/references/
    ladder.py), in 40-digit arithmetic, the root bracketed and bisected.  Independent of
    phasemap's integrators and of the double-precision cancellation in 2 - f^2 near sqrt 2."""
    import mpmath as mp

    with mp.workdps(40):
        f, g, l, phi0, omega0 = map(mp.mpf, (f, g, l, phi0, omega0))
        s = 1 if omega0 > 0 else -1
        q = 4 + 32 * f ** 2 + f ** 4
        lam = 6 * s * f / (2 - f * f)
        a = -6 * s * f * g * (5 - 4 * f ** 2) / (l * q)
        b = -3 * g * (2 - 15 * f ** 2 + f ** 4) / (l * q)
        c0 = omega0 ** 2 - a * mp.sin(phi0) - b * mp.cos(phi0)

        def wall(phi):  # N_wall (1 + f^2)/m
            e = c0 * mp.exp(lam * (phi - phi0))
            u = e + a * mp.sin(phi) + b * mp.cos(phi)
            acc = (lam * e + a * mp.cos(phi) - b * mp.sin(phi)) / 2
            xdd = l * mp.cos(phi) * acc - l * mp.sin(phi) * u
            ydd = -l * mp.sin(phi) * acc - l * mp.cos(phi) * u
            return xdd + s * f * (g + ydd)

        lo, hi = phi0 - mp.mpf("1e-7"), phi0 - mp.mpf("1e-9")
        assert wall(lo) < 0 < wall(hi)
        return float(mp.findroot(wall, (lo, hi), solver="bisect"))


@pytest.mark.parametrize("method", ["DOPRI5"])  # the hand model: one compile, not two
def test_ladder_just_above_sqrt2_stops_clearly_when_the_stage_is_stiff(method):
    # f = sqrt2 + 1e-9 makes the stage stiff: a boundary layer of width ~1e-10 rad, then
    # N_wall < 0 on the slow manifold at phi = 0.4999999929693 (_wall_release below).  At
    # rtol 1e-10 simulate finds it too.  At rtol 1e-8 explicit steps sit at the stability
    # limit off the manifold and never see the contact loss; they used to crawl to
    # max_steps (10^6 steps, t = 3.6e-4 s).  Hairer's stiffness test now stops the run
    # within a few dozen steps with end_reason 'stiff', which says why.  The hand module
    # keeps both contacts; the running ladder calls this start indeterminate (above).
    from references import ladder as hand_ladder

    tight = phasemap.simulate(hand_ladder.MODEL, 1.0, method=method,
                              rtol=1e-10, phi=0.5, omega=-4.0, f=R2 + 1e-9)
    assert tight.attrs["end_reason"] == "contact_lost"
    assert abs(float(tight.event_phi[-1]) - _wall_release(R2 + 1e-9, 0.5, -4.0)) < 1e-8
    loose = phasemap.simulate(hand_ladder.MODEL, 1.0, method=method,
                              rtol=1e-8, phi=0.5, omega=-4.0, f=R2 + 1e-9)
    assert loose.attrs["end_reason"] in {"contact_lost", "stiff"}
    assert int(loose.attrs["n_steps"]) < 1000 and all_finite(loose)
    assert "phase_curve" in phasemap.Event.STIFF.message


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("delta", [1.0 - 1e-12, 1.0])
def test_hinge_with_delta_at_l_cannot_start(delta, method):
    ds = phasemap.simulate("hinge_pendulum", 1.0, method=method, phi=1.0, omega=2.0, delta=delta)
    assert all_finite(ds)
    assert ds.attrs["end_reason"] in {"singular", "no_solution"}
    assert float(ds.event_t[-1]) == 0.0 and int(ds.attrs["n_steps"]) == 0


@pytest.mark.parametrize("method", METHODS)
def test_elliptic_pendulum_near_lambda_zero_never_continues_silently(method):
    f = 3.0  # > 2 sqrt 2: lambda_+ = 1 + s^2 - f s c vanishes at tan(phi) = 1/2 and 1
    root = math.atan(0.5)
    for phi, xdot in ((root, 0.5), (root + 1e-8, 0.5), (root + 1e-8, -0.5)):
        ds = phasemap.simulate("elliptic_pendulum", 2.0, method=method,
                               phi=phi, omega=0.0, xdot=xdot, f=f)
        assert all_finite(ds)
        assert ds.attrs["end_reason"] in {"singular", "no_solution", "indeterminate"}
        assert float(ds.event_t[-1]) == 0.0
    # sliding into lambda_- = 1 + s^2 + f s c = 0 (phi = 3 pi / 4): stops there
    ds = phasemap.simulate("elliptic_pendulum", 5.0, method=method, rtol=1e-10, phi=0.9, omega=-3.0,
                           xdot=50.0, f=f)
    assert all_finite(ds) and ds.attrs["end_reason"] == "singular"
    phi = float(ds.event_phi[-1])
    assert abs(1 + math.sin(phi) ** 2 + f * math.sin(phi) * math.cos(phi)) < 1e-8


@pytest.mark.parametrize("method", METHODS)
def test_extreme_initial_velocities(method):
    ds, phi, omega = weightless_run(1.0, 1e6, 11, method=method, rtol=1e-10)
    assert all_finite(ds) and ds.attrs["end_reason"] == "horizon"
    assert np.max(np.abs(ds.phi.values - phi)) < 1e-8            # phi reaches 40 rad
    assert np.max(np.abs(ds.omega.values - omega)) < 1e-8 * 1e6  # relative to omega0
    tiny = phasemap.simulate("hinge_pendulum", 1.0, method=method,
                             phi=0.0, omega=1e-300, delta=0.3, g=0.0)
    assert all_finite(tiny) and tiny.attrs["end_reason"] == "horizon"
    assert float(tiny.phi[-1]) == pytest.approx(1e-300, rel=1e-12)
    # with gravity 1e-300 rad/s is zero for the model: the same motion as from rest
    a = phasemap.simulate("hinge_pendulum", 5.0, method=method, phi=1.0, omega=1e-300)
    b = phasemap.simulate("hinge_pendulum", 5.0, method=method, phi=1.0, omega=0.0)
    assert a.attrs["end_reason"] == b.attrs["end_reason"]
    assert float(a.event_phi[-1]) == float(b.event_phi[-1])
    # an omega whose square would overflow is refused before any work
    with pytest.raises(ValueError, match="too large"):
        phasemap.simulate("hinge_pendulum", 1.0, method=method, phi=1.0, omega=1e300)


@pytest.mark.parametrize("method", METHODS)
def test_tolerance_at_the_edge_of_double_precision(method):
    ds, phi, _ = weightless_run(10.0, 5.0, 51, method=method, rtol=1e-14)
    assert ds.attrs["end_reason"] == "horizon"
    assert np.max(np.abs(ds.phi.values - phi)) < 1e-12
    with pytest.raises(ValueError, match=r"rtol must be in \[1e-14, 0.1\]"):
        phasemap.simulate("hinge_pendulum", 1.0, method=method, rtol=1e-15)


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize("kwargs, words", [
    (dict(zeta=1.0), "unknown variable 'zeta'"),
    (dict(phi=math.nan), "phi must be finite"),
    (dict(omega=math.inf), "omega must be finite"),
    (dict(t_end=0.0), "t_end must be a positive number"),
    (dict(t_end=-2.0), "t_end must be a positive number"),
    (dict(t_end=math.inf), "t_end must be finite"),
    (dict(t_eval=[0.0, 2.0, 1.0]), "t_eval must be a sorted 1-D sequence"),
    (dict(t_eval=[0.0, 20.0]), "t_eval must be a sorted 1-D sequence"),
    (dict(t_eval=[-1.0, 1.0]), "t_eval must be a sorted 1-D sequence"),
    (dict(t_eval=[[0.0, 1.0]]), "t_eval must be a sorted 1-D sequence"),
    (dict(t_eval=[0.0, math.nan]), "t_eval must be a sorted 1-D sequence"),
    (dict(t_eval=["soon"]), "hinge_pendulum: t_eval"),
])
def test_bad_input_raises_a_clear_value_error(kwargs, words):
    kwargs = dict(kwargs)
    t_end = kwargs.pop("t_end", 10.0)
    with pytest.raises(ValueError, match=words):
        phasemap.simulate("hinge_pendulum", t_end, **kwargs)


# ----------------------------------------------------------------- fate map
def test_hinge_fate_map_rests_in_the_stagnation_zone_and_round_trips(tmp_path):
    delta, l = 0.1, 1.0
    scene = phasemap.Scene("hinge_pendulum",
                           axes={"phi": np.linspace(-3.0, 3.0, 13), "omega": [-4.0, 0.0, 2.5]},
                           fixed={"delta": delta},
                           layers=["fate", "n_reversals", "t_final", "t_rest", "phi_rest"],
                           options={"t_end": 30.0})
    ds = scene.compute()
    rest = ds.fate.values == phasemap.Event.REST
    assert rest.sum() >= 30
    assert np.all(l * np.abs(np.sin(ds.phi_rest.values[rest])) <= delta * (1 + 1e-12))
    assert np.array_equal(np.isnan(ds.t_rest.values), ~rest)
    assert np.array_equal(np.isnan(ds.phi_rest.values), ~rest)
    assert np.all(ds.t_rest.values[rest] == ds.t_final.values[rest])
    # the same cell by simulate
    i, j = np.argwhere(rest & (ds.n_reversals.values > 0))[0]
    one = phasemap.simulate("hinge_pendulum", 30.0, rtol=1e-6, phi=float(ds.phi[i]),
                            omega=float(ds.omega[j]), delta=delta)
    assert one.attrs["end_reason"] == "rest"
    assert float(one.event_phi[-1]) == float(ds.phi_rest[i, j])
    assert int(one.attrs["n_reversals"]) == int(ds.n_reversals[i, j])
    assert_atlas_round_trip(ds, tmp_path, "fates.nc")


def test_a_fixed_velocity_starts_every_cell_of_a_fate_map():
    """Every cell of a fate map starts from the scene's own fixed values, whatever ran
    before it on its thread.  Over (phi, delta) with omega = 2.5 fixed, the integrator
    wrote each motion's last omega into the thread's input vector, and in a call of more
    than FATE_UNITS cells the next cell of a work unit started from it: results depended
    on the block sizes (a timing), and the rod on a step's theta_rest differed from run
    to run.  One call over 1 152 cells against blocks of 7 cells (one cell per unit),
    and every cell against its own simulate."""
    from phasemap.maps import blocks
    from phasemap.motion.integrate import FATE_UNITS

    scene = phasemap.Scene("hinge_pendulum",
                           axes={"phi": np.linspace(-2.5, 2.5, 48),
                                 "delta": np.linspace(0.05, 0.8, 24)},
                           fixed={"omega": 2.5}, layers=["fate", "n_reversals", "t_final"],
                           options={"t_end": 20.0})
    assert scene.size > FATE_UNITS
    whole = scene.evaluate()  # one compiled call over every cell
    parts = {n: np.empty(scene.shape, whole[n].dtype) for n in whole}
    for index, block in blocks.run_blocks(scene.axes, scene.evaluate, 7, 7, fixed=7):
        for n in parts:
            parts[n][index] = block[n]
    for n in parts:
        assert np.array_equal(parts[n], whole[n]), n
    rng = np.random.default_rng(3)
    for i, j in zip(rng.integers(0, 48, 40), rng.integers(0, 24, 40)):
        one = phasemap.simulate("hinge_pendulum", 20.0, rtol=1e-6, omega=2.5,
                                phi=float(scene.axes["phi"][i]),
                                delta=float(scene.axes["delta"][j]))
        assert one.attrs["end_reason"] == phasemap.Event(int(whole["fate"][i, j])).name.lower()
        assert float(one.event_t[-1]) == float(whole["t_final"][i, j])
        assert int(one.attrs["n_reversals"]) == int(whole["n_reversals"][i, j])


# ------------------------------------------------------- work-precision API
def test_scipy_stage_driver_and_work_precision_rows(references):
    import phasemap.motion.workprecision as wp

    staged = wp.solve_ivp_staged("hinge_pendulum", 20.0, method="DOP853", rtol=1e-10,
                                 t_eval=np.linspace(0, 20, 41), phi=2.5, omega=0.0, delta=0.05)
    ds = phasemap.simulate("hinge_pendulum", 20.0, rtol=1e-10, t_eval=np.linspace(0, 20, 41),
                           phi=2.5, omega=0.0, delta=0.05)
    assert staged.fate == ds.attrs["end_reason"] == "rest"
    # the count from this file's own staged DOP853 on the hinge's equation written here
    # (CASES: the same start, delta and t_end), not a number read off a phasemap run
    assert CASES["hinge_pendulum"]["values"] == dict(phi=2.5, omega=0.0, delta=0.05)
    assert CASES["hinge_pendulum"]["t_end"] == 20.0
    assert staged.n_reversals == int(ds.attrs["n_reversals"]) == len(
        references["hinge_pendulum"]["reversals"])
    assert [e[1] for e in staged.events] == kinds(ds)
    np.testing.assert_allclose([e[0] for e in staged.events], ds.event_t.values, atol=1e-7)
    np.testing.assert_allclose(staged.y, np.column_stack([ds.phi, ds.omega]), atol=1e-7)
    # without t_eval a stage that ends before t_end reaches no requested time: scipy 1.17
    # then returns lists, not arrays, which the driver once read as arrays
    bare = wp.solve_ivp_staged("hinge_pendulum", 20.0, method="DOP853", rtol=1e-10,
                               phi=2.5, omega=0.0, delta=0.05)
    assert bare.fate == "rest" and bare.n_reversals == staged.n_reversals
    assert bare.t.tolist() == [20.0] and abs(bare.y[0] - staged.y[-1]).max() < 1e-9
    rows = wp.work_precision("ladder", tolerances=[1e-6, 1e-9], methods=["phasemap", "RK45"],
                             repeats=1, min_time=0.0)
    assert {(r["method"], r["tol"]) for r in rows} == {(m, t) for m in ("phasemap", "RK45")
                                                      for t in (1e-6, 1e-9)}
    for r in rows:
        assert r["same_fate"] and r["fate"] == "contact_lost"
        assert 0 < r["error_final"] < 1e3 * r["tol"] and r["seconds"] > 0
    assert "speed-up" in wp.report(rows)
    with pytest.raises(ValueError, match="unknown method"):
        wp.work_precision("ladder", tolerances=[1e-6], methods=["Euler"])


# ------------------------------------------------------------------- DOP853
def test_dop853_follows_scipy_dop853_on_a_smooth_stage(references):
    # The wheel's first stage (from phi = 2 at rest to the first velocity zero) is smooth:
    # at rtol 1e-12 phasemap's DOP853 and scipy's, on the independent equations, agree to
    # the tolerance (measured 6e-14 on the states, 9e-13 on the velocity zero; DOPRI5 at
    # the same rtol: 3e-11).
    case, ref = CASES["wheel"], references["wheel"]
    _, t1, sol = ref["stages"][0]
    t = np.linspace(0.0, t1, 201)[:-1]
    ds = phasemap.simulate("wheel", float(t[-1]), rtol=1e-12, t_eval=t, method="DOP853",
                           **case["values"])
    assert ds.attrs["end_reason"] == "horizon" and "8(5,3)" in ds.attrs["integrator"]
    assert np.max(np.abs(np.column_stack([ds.phi, ds.omega]) - sol(t).T)) < 1e-11
    full = phasemap.simulate("wheel", case["t_end"], rtol=1e-12, method="DOP853",
                             **case["values"])
    assert kinds(full)[1] == "reversal"
    assert abs(float(full.event_t[1]) - ref["reversals"][0]) < 1e-10


def test_dop853_has_order_8_and_its_error_follows_rtol():
    # The weightless hinge pendulum, exact solution (36).  With the error per step held
    # at rtol, an order-p method takes steps h ~ rtol^(1/p), so its error falls as
    # n_steps^-p: measured slope -8.2 for DOP853 (-6.5 for DOPRI5 on this problem), and
    # the error itself stays proportional to rtol (slope 0.8) and below it.
    rtols = 10.0 ** -np.arange(5.0, 13.0)
    steps, errors = [], []
    for rtol in rtols:
        ds, phi, _ = weightless_run(10.0, 5.0, rtol=rtol, method="DOP853")
        steps.append(int(ds.attrs["n_steps"]))
        errors.append(np.max(np.abs(ds.phi.values - phi)))
    errors = np.array(errors)
    assert -10.0 < np.polyfit(np.log(steps), np.log(errors), 1)[0] < -7.0
    assert 0.6 < np.polyfit(np.log(rtols), np.log(errors), 1)[0] < 1.2
    assert np.all(errors < rtols)
    dopri5 = phasemap.simulate("hinge_pendulum", 10.0, rtol=1e-12, phi=0.0, omega=5.0,
                               delta=0.3, g=0.0)
    assert steps[-1] * 4 < int(dopri5.attrs["n_steps"])  # 45 against 282 steps


def test_dop853_dense_output_is_of_order_7():
    # Requested times come from the order-7 continuous extension (3 extra stages per
    # step that has one): between the steps it is within a small factor of the order-8
    # steps' error (measured 20-30x, as scipy's DOP853 on the same problem), and it
    # converges; a wrong coefficient would leave it at O(h^4) or worse.
    t = np.linspace(0.0, 10.0, 1001)
    phi, omega = weightless(t, 0.0, 5.0, 0.3, 1.0)
    for rtol, bound in ((1e-6, 1e-6), (1e-9, 1e-8), (1e-12, 1e-11)):
        ds = phasemap.simulate("hinge_pendulum", 10.0, rtol=rtol, t_eval=t, method="DOP853",
                               phi=0.0, omega=5.0, delta=0.3, g=0.0)
        assert np.max(np.abs(ds.phi.values - phi)) < bound, rtol
        assert np.max(np.abs(ds.omega.values - omega)) < bound, rtol


SCENARIOS = {  # (the ladder's contact loss is the same event code; it runs DOPRI5 above)
    "hinge_pendulum": (20.0, dict(phi=2.5, omega=0.0, delta=0.05)),
    "wheel": (60.0, dict(phi=2.0, omega=0.0, delta=0.01)),
    "elliptic_pendulum": (10.0, dict(phi=1.0, omega=0.0, xdot=0.5, f=0.3)),
}


@pytest.mark.parametrize("model", list(SCENARIOS))
def test_dop853_locates_the_same_events_as_dopri5(model):
    # reversals and rest, stick and slip, contact loss: the same events in the same order,
    # at the same times and states to the tolerance
    t_end, values = SCENARIOS[model]
    a = phasemap.simulate(model, t_end, rtol=1e-11, **values)
    b = phasemap.simulate(model, t_end, rtol=1e-11, method="DOP853", **values)
    assert kinds(a) == kinds(b) and len(kinds(a)) >= 2
    assert a.attrs["end_reason"] == b.attrs["end_reason"]
    np.testing.assert_array_equal(a.event_branch.values, b.event_branch.values)
    np.testing.assert_allclose(a.event_t.values, b.event_t.values, rtol=0, atol=1e-7)
    for name in ("phi", "omega"):
        np.testing.assert_allclose(a[f"event_{name}"].values, b[f"event_{name}"].values,
                                   rtol=0, atol=1e-7)
    assert int(b.attrs["n_steps"]) < int(a.attrs["n_steps"])


def test_dop853_fate_map_and_bad_method(tmp_path):
    scene = dict(axes={"phi": np.linspace(-3.0, 3.0, 13), "omega": [-4.0, 0.0, 2.5]},
                 fixed={"delta": 0.1}, layers=["fate", "n_reversals", "phi_rest"])
    a = phasemap.Scene("hinge_pendulum", **scene, options={"t_end": 30.0}).compute()
    b = phasemap.Scene("hinge_pendulum", **scene,
                       options={"t_end": 30.0, "method": "DOP853"}).compute()
    np.testing.assert_array_equal(a.fate.values, b.fate.values)
    np.testing.assert_array_equal(a.n_reversals.values, b.n_reversals.values)
    np.testing.assert_allclose(a.phi_rest.values, b.phi_rest.values, rtol=0, atol=1e-4)
    assert '"method": "DOP853"' in b.attrs["phasemap_scene"]
    assert_atlas_round_trip(b, tmp_path, "fates853.nc")
    with pytest.raises(ValueError, match="method must be one of DOPRI5, DOP853"):
        phasemap.simulate("hinge_pendulum", 1.0, method="RK4")
    with pytest.raises(ValueError, match="method must be one of"):
        phasemap.Scene("hinge_pendulum", **scene, options={"method": "dop853"})


@pytest.mark.parametrize("name", ["wheel", "elliptic_pendulum", "hinge_pendulum"])
def test_the_test_after_a_step_decides_as_the_full_classification(name):
    """GOES_ON, what the integrator reads after a step, against STILL (every row
    classified, then ON_STAGE and the domain): the same decision at random states,
    moving, at rest and within the rest tolerance, for every branch and coefficient
    sign, and the stage's coefficient where it goes on."""
    from phasemap.core import numerics as nx
    from phasemap.motion.integrate import stage_kernels

    m = phasemap.get_model(name)
    stage = stage_kernels(m)
    c = stage.constants
    fill, goes_on = c["FILL"], c["GOES_ON"]
    v = m.input_vector({k: float(x) for k, x in m.defaults.items()})
    lower, upper, vel = c["LOWER"], c["UPPER"], c["VEL_Y"]
    nb = c["N_BRANCHES"]
    full, cut = np.empty((nb, c["N_FIELDS"])), np.empty((nb, c["N_FIELDS"]))
    rng = np.random.default_rng(22)
    decided = {True: 0, False: 0}
    for trial in range(200):
        y = rng.uniform(np.maximum(lower, -np.pi), np.minimum(upper, np.pi))
        y[vel] = (0.0, 1e-14 * rng.standard_normal(), y[vel], y[vel], y[vel])[trial % 5]
        for mode in range(nb):
            for coef_sign in (-1.0, 0.0, 1.0):
                expect = stage.still(v, y, full, mode, coef_sign)
                fill(v, y)
                got = goes_on(v, y, cut, mode, coef_sign)
                assert got == expect, (name, y, mode, coef_sign)
                decided[bool(got)] += 1
                if got and coef_sign != 0.0:
                    assert cut[mode, nx.COEF] == full[mode, nx.COEF]
    assert decided[True] > 0 and decided[False] > 0, decided


STOPPED = """
import os, signal, threading, time
import phasemap

def scene(t_end):
    return phasemap.Scene("hinge_pendulum", axes={"phi": [2.5, 2.4]},
                          fixed={"omega": 0.0, "delta": 0.0}, layers=["fate"],
                          options={"t_end": t_end, "max_steps": 10 ** 12,
                                   "max_events": 10 ** 12})

scene(0.1).compute()                       # compiled (or loaded) first
threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT)).start()
try:
    scene(1e9).compute()                   # frictionless: 10^9 s of swinging per cell
    print("finished")
except KeyboardInterrupt:
    print("interrupted")
"""


def test_a_ctrl_c_stops_a_fate_map_inside_a_long_trajectory():
    """Issue 44: a fate map whose cells are long trajectories took 19 s to stop on
    Ctrl-C (a signal waits for compiled code to return).  Each cell here would swing for
    10^9 s; the interrupt ends the map within a step of the integrator (the child's
    timeout bounds a hang, it times nothing)."""
    done = subprocess.run([sys.executable, "-c", STOPPED], capture_output=True, text=True,
                          timeout=300)
    assert done.stdout.strip().splitlines()[-1] == "interrupted", done.stderr[-2000:]


def test_the_integrators_pieces_count_no_references_but_the_driver():
    """Every piece of a model's integrator but the driver that allocates its records
    (``integrate.COUNTED``) is compiled without numba's reference counts, whose atomic
    operations around each call with array arguments cost a tenth of a fate cell; the
    integrator built from them still frees every array it allocates."""
    from conftest import numba_arrays

    from phasemap.core import tiers
    from phasemap.motion import integrate
    from phasemap.motion.integrate import templates as tp

    model = phasemap.get_model("wheel")
    consts = integrate.stage_kernels(model).constants
    pieces = [name for name, _, _ in tp.PIECES]
    assert all(consts[name].targetoptions.get("_nrt") is False for name in pieces)
    fn = integrate.integrator(model, "DOPRI5")
    assert fn.targetoptions.get("_nrt") is not False and "INTEGRATE" in integrate.COUNTED
    method = dict(fn.py_func.__globals__, INTEGRATE=fn)      # (its pieces, by name)
    for name in ("STEP", "DENSE", *(name for name, _, _ in tp.METHOD_PIECES)):
        assert (method[name].targetoptions.get("_nrt") is False) == \
            (name not in integrate.COUNTED), name
    with tiers.forced("eager"):
        ds = phasemap.simulate("wheel", 10.0, phi=0.5, omega=1.0)
        with numba_arrays() as counted:
            again = phasemap.simulate("wheel", 10.0, phi=0.5, omega=1.0)
            same = np.array_equal(ds.phi.values, again.phi.values)
            del again                    # (the Dataset's arrays are numba's)
    assert counted["allocated"] > 0 and counted["allocated"] == counted["freed"]
    assert same and ds.sizes["t"] > 10
