"""Frictional impacts of one contact (phasemap.motion.impact), against figures worked
out independently: the rod's Delassus matrix from its geometry and from its mass matrix
and contact Jacobian, the three restitution laws on one state, the impact without
collision of the Painleve rod, random impacts against a regularised Darboux-Keller
integration by scipy, and the Zeno time against the series of bounce times."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from phasemap.motion.impact import delassus, delassus_body, impact, zeno_time


def rod_W(theta: float, m: float = 1.0, l: float = 1.0) -> np.ndarray:
    """The Delassus matrix of a uniform rod (half-length l) touching the floor with its
    end A, at angle theta to the floor, in (n, t) = ((0, 1), (1, 0)): the generalised
    coordinates (x_G, y_G, phi) with M = diag(m, m, m (2l)^2 / 12) and A = G - l (cos
    phi, sin phi), whose velocity rows are dA/dq."""
    M = np.diag([m, m, m * (2 * l) ** 2 / 12])
    J = np.array([[0.0, 1.0, -l * math.cos(theta)],     # y_A' = y_G' - l cos(phi) phi'
                  [1.0, 0.0, l * math.sin(theta)]])     # x_A' = x_G' + l sin(phi) phi'
    return J @ np.linalg.solve(M, J.T)


def test_two_routes_to_the_rods_W_agree():
    th = 0.7
    W = rod_W(th)
    assert np.allclose(W, delassus(np.diag([1, 1, 1 / 3]), [[0, 1, -math.cos(th)],
                                                            [1, 0, math.sin(th)]]))
    assert np.allclose(W, delassus_body(1.0, 1 / 3, (-math.cos(th), -math.sin(th))),
                       atol=1e-15)
    assert np.allclose(rod_W(math.pi / 4), [[2.5, -1.5], [-1.5, 2.5]])


@pytest.mark.parametrize("law, e, expected", [
    ("newton", 0.9, (1.0, 0.4, 0.05)),
    ("poisson", 0.9, (0.83125, 0.29875, -0.0790937500)),
    ("stronge", 0.9, (0.8546611649, 0.3127966989, -0.0639062500)),
    ("newton", 1.0, (1.0625, 0.4375, 0.109375)),
])
@pytest.mark.filterwarnings("ignore:Newton's law made energy")
def test_the_three_laws_on_one_state(law, e, expected):
    """The rod at 45 degrees, at rest, its end A moving at (0.5, -1), mu = 1.  Worked by
    hand: slip stops at P = 0.125 (v_n = -0.5), then stick with dv_n/dP = det W / W_tt =
    1.6 and dP_t/dP = 0.6; compression ends at P_c = 0.4375 with work -0.171875; Newton
    ends at v_n = 0.9 (P = 1), Poisson at 1.9 P_c, Stronge where 0.8 x^2 = 0.81 x 0.171875."""
    r = impact(rod_W(math.pi / 4), (-1.0, 0.5), mu=1.0, e=e, law=law)
    assert (r.P_n, r.P_t, r.dKE) == pytest.approx(expected, abs=1e-10)
    assert r.phases == ("slip_pos", "stick")
    assert r.P_compression == pytest.approx(0.4375, abs=1e-14)
    assert r.W_compression == pytest.approx(-0.171875, abs=1e-14)
    assert r.gains_energy == (law == "newton")


def test_newton_says_when_it_makes_energy():
    with pytest.warns(RuntimeWarning, match="Newton's law made energy"):
        impact(rod_W(math.pi / 4), (-1.0, 0.5), mu=1.0, e=1.0, law="newton")


def test_the_painleve_rods_impact_without_collision():
    """m = 1, l = 1, f = 1.5, theta = arctan 2, at rest but for x_A' = -1: P_n = 0.3,
    P_t = 0.4, (x_G', y_G', omega)+ = (-0.6, 0.3, 0.3 sqrt 5), KE from 0.5 to 0.3, and
    the rod sticks."""
    th = math.atan(2.0)
    r = impact(rod_W(th), (0.0, -1.0), mu=1.5, e=0.0)
    assert r.P_n == pytest.approx(0.3, abs=1e-12)
    assert r.P_t == pytest.approx(0.4, abs=1e-12)
    assert r.sticks and r.phases == ("slip_neg", "stick")
    # the body's velocities from the impulse, by Newton-Euler (independent of W)
    v_g = np.array([-1.0, 0.0]) + np.array([r.P_t, r.P_n])  # m = 1
    rho = -np.array([math.cos(th), math.sin(th)])           # A from G
    omega = 3.0 * (rho[0] * r.P_n - rho[1] * r.P_t)          # I = 1/3
    assert np.allclose([*v_g, omega], [-0.6, 0.3, 0.3 * math.sqrt(5)], atol=1e-12)
    ke = 0.5 * (v_g @ v_g) + 0.5 / 3 * omega ** 2
    assert ke == pytest.approx(0.3, abs=1e-12)
    assert r.dKE == pytest.approx(-0.2, abs=1e-12)


def regularised(W, v0, mu, e, law, eps=1e-9):
    """The same impact by scipy: dv/dP = W (1, -mu tanh(v_t / eps)) integrated in P (a
    smooth friction law, whose stick is v_t of order eps), with the work int v_n dP, the
    compression end at v_n = 0 and the law's end as events."""
    Wnn, Wnt, Wtt = W[0, 0], W[0, 1], W[1, 1]

    def f(P, y):
        vn, vt, Pt, work = y
        k = -mu * math.tanh(vt / eps)
        return [Wnn + Wnt * k, Wnt + Wtt * k, k, vn]

    opts = dict(method="LSODA", rtol=1e-11, atol=1e-13)
    cross = lambda P, y: y[0]  # noqa: E731
    cross.terminal, cross.direction = True, 1
    y0 = [v0[0], v0[1], 0.0, 0.0]
    a = solve_ivp(f, (0, 1e3), y0, events=cross, **opts)
    Pc, yc = a.t_events[0][0], a.y_events[0][0]
    Wc = yc[3]
    if e == 0.0:
        return Pc, yc[2]
    if law == "poisson":
        b = solve_ivp(f, (Pc, (1 + e) * Pc), yc, **opts)
        return b.t[-1], b.y[2, -1]
    if law == "newton":
        end = lambda P, y: y[0] + e * v0[0]  # noqa: E731
    else:
        end = lambda P, y: (y[3] - Wc) - e * e * (-Wc)  # noqa: E731
    end.terminal, end.direction = True, 1
    b = solve_ivp(f, (Pc, 1e3), yc, events=end, **opts)
    return b.t_events[0][0], b.y_events[0][0][2]


def random_cases(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        m = rng.uniform(0.2, 5.0)
        inertia = m * rng.uniform(0.05, 2.0)
        r = rng.uniform(-1.5, 1.5, 2)
        angle = rng.uniform(0, 2 * math.pi)
        W = delassus_body(m, inertia, r, (math.cos(angle), math.sin(angle)))
        v = (-rng.uniform(0.1, 3.0), rng.normal() * rng.choice([0.0, 1.0, 3.0]))
        yield W, v, rng.uniform(0.0, 2.0), rng.choice([0.0, rng.uniform(0, 1), 1.0])


@pytest.mark.filterwarnings("ignore:Newton's law made energy")
def test_random_impacts_keep_their_laws():
    """200 random bodies and contacts: the velocity jump is W P, the impulse stays in the
    friction cone, the contact separates or rests, a stuck contact has v_t = 0, each law's
    end holds, and Stronge and Poisson never make energy."""
    count = {"stronge": 0, "poisson": 0, "newton": 0}
    for W, v, mu, e in random_cases(200, 20261129):
        for law in count:
            r = impact(W, v, mu=mu, e=e, law=law)
            P = np.array([r.P_n, r.P_t])
            assert np.allclose(np.array(v) + W @ P, [r.v_n, r.v_t], atol=1e-12)
            assert r.P_n > 0 and abs(r.P_t) <= mu * r.P_n * (1 + 1e-12) + 1e-15
            assert r.v_n >= -1e-12
            if r.sticks:
                assert r.v_t == 0.0
            if law != "newton":
                assert r.dKE <= 1e-12 * (1 + abs(v[0]) + abs(v[1])) ** 2
            if law == "poisson":
                assert r.P_n == pytest.approx((1 + e) * r.P_compression, rel=1e-12)
            if law == "newton" and e > 0:
                assert r.v_n == pytest.approx(-e * v[0], rel=1e-12)
            count[law] += 1
    assert count == {"stronge": 200, "poisson": 200, "newton": 200}


@pytest.mark.filterwarnings("ignore:Newton's law made energy")
def test_random_impacts_agree_with_a_regularised_integration():
    """The closed form against scipy's integration of the smoothed law (independent of
    the phase logic): the impulses agree to the smoothing's own error."""
    checked = 0
    for W, v, mu, e in random_cases(25, 7):
        for law in ("stronge", "poisson", "newton"):
            r = impact(W, v, mu=mu, e=e, law=law)
            Pn, Pt = regularised(W, v, mu, e, law)
            scale = abs(v[0]) / W[0, 0] + abs(v[1]) / W[1, 1]
            assert abs(r.P_n - Pn) <= 1e-6 * scale and abs(r.P_t - Pt) <= 1e-6 * scale, (
                W, v, mu, e, law, r, Pn, Pt)
            checked += 1
    assert checked == 75


def test_zeno_time_is_the_sum_of_the_bounces():
    """A ball dropped from h0 = 1 with e = 0.5 comes to rest at sqrt(2 h0/g)(1+e)/(1-e) =
    1.354571 s: the series of its flight times, summed here term by term."""
    g, h0, e = 9.81, 1.0, 0.5
    t1, v1 = math.sqrt(2 * h0 / g), math.sqrt(2 * g * h0)
    series = t1 + sum(2 * v1 * e ** k / g for k in range(1, 200))
    predicted = zeno_time(t1, e * v1, -g, e)
    assert predicted == pytest.approx(series, abs=1e-12)
    assert predicted == pytest.approx(math.sqrt(2 * h0 / g) * (1 + e) / (1 - e), abs=1e-12)
    assert round(predicted, 6) == 1.354571


@pytest.mark.parametrize("args, message", [
    (([[1, 0], [0, -1]], (-1, 0), 0.5), "positive definite"),
    (([[1, 0.5], [0, 1]], (-1, 0), 0.5), "symmetric"),
    (([[1, 0], [0, 1]], (1.0, 0), 0.5), "separates"),
    (([[1, 0], [0, 1]], (0.0, 1.0), 0.5), "without collision"),
    (([[1, 0], [0, 1]], (-1.0, 0), -0.1), "mu must be"),
    (([[1, 0], [0, 1]], (-1.0, 0), float("nan")), "mu must be"),
    (([[1, 0], [0, 1]], (-1.0, "x"), 0.5), "v_before must be"),
])
def test_bad_input_is_refused_in_one_line(args, message):
    with pytest.raises(ValueError, match=message) as err:
        impact(*args)
    assert "\n" not in str(err.value)


def test_bad_law_and_restitution():
    W = [[1, 0], [0, 1]]
    with pytest.raises(ValueError, match="law must be one of stronge, poisson, newton"):
        impact(W, (-1, 0), 0.5, law="elastic")
    with pytest.raises(ValueError, match=r"e must be in \[0, 1\]"):
        impact(W, (-1, 0), 0.5, e=1.5)
    with pytest.raises(ValueError, match="e must be in"):
        zeno_time(0.0, 1.0, -9.81, 1.0)


def test_a_rod_landing_flat_on_both_ends():
    """A uniform rod (m = 1, half-length 1) falling flat at 1 m/s onto the floor with both
    ends: 4 contact rows on 3 freedoms.  The inelastic impact stops it, each end taking
    half the normal impulse (symmetry), and the tangential impulses are undetermined
    (they cancel in a continuum): kinetic energy 0.5 is lost."""
    from phasemap.motion.impact import simultaneous

    M = np.diag([1.0, 1.0, 1 / 3])
    J = np.array([[0, 1, -1.0], [1, 0, 0], [0, 1, 1.0], [1, 0, 0]])  # n_A, t_A, n_B, t_B
    W = J @ np.linalg.solve(M, J.T)
    sols = simultaneous(W, [-1.0, 0.0, -1.0, 0.0], [0.5, 0.5])
    assert len(sols) == 1
    s = sols[0]
    assert s.modes == ("stick", "stick") and s.continuum
    assert np.allclose(s.P, [0.5, 0.0, 0.5, 0.0], atol=1e-12)
    assert np.allclose(s.v, 0.0, atol=1e-12) and s.dKE == pytest.approx(-0.5, abs=1e-12)


def test_one_contact_at_once_is_the_plastic_impact():
    """With one contact, the impulse-level enumeration has exactly one solution, and it is
    the Darboux-Keller impact with e = 0 wherever the slip does not reverse (both end at
    v_n = 0 with the same impulse)."""
    from phasemap.motion.impact import simultaneous

    compared = 0
    for W, v, mu, _ in random_cases(150, 11):
        sols = simultaneous(W, v, [mu])
        assert len(sols) == 1 and not sols[0].continuum
        s = sols[0]
        assert s.v[0] == pytest.approx(0.0, abs=1e-12)
        assert abs(s.P[1]) <= mu * s.P[0] * (1 + 1e-12) + 1e-15 and s.dKE <= 1e-12
        r = impact(W, v, mu=mu, e=0.0)
        if "slip_pos" in r.phases and "slip_neg" in r.phases:
            continue  # a reversal: the path, not only its end, decides P_t
        assert np.allclose(s.P, [r.P_n, r.P_t], atol=1e-10 * (1 + abs(v[0]) + abs(v[1])))
        compared += 1
    assert compared > 100


def test_random_simultaneous_impacts_have_a_solution_that_keeps_the_laws():
    """Two bodies' worth of random 2-contact W (positive definite): at least one solution,
    each with its modes' complementarity, in the cone, losing energy."""
    from phasemap.motion.impact import simultaneous

    rng = np.random.default_rng(5)
    for _ in range(60):
        J = rng.normal(size=(4, 5))
        Minv = np.diag(rng.uniform(0.2, 2.0, 5))
        W = J @ Minv @ J.T
        v = np.array([-rng.uniform(0.1, 2), rng.normal(), -rng.uniform(0.1, 2), rng.normal()])
        mu = rng.uniform(0, 1.5, 2)
        sols = simultaneous(W, v, mu)
        assert sols
        for s in sols:
            for c, mode in enumerate(s.modes):
                Pn, Pt, vn, vt = s.P[2 * c], s.P[2 * c + 1], s.v[2 * c], s.v[2 * c + 1]
                if mode == "open":
                    assert Pn == 0 and Pt == 0 and vn >= -1e-12
                else:
                    assert abs(vn) <= 1e-9 and Pn >= -1e-12
                    assert abs(Pt) <= mu[c] * Pn + 1e-9
                    if mode == "stick":
                        assert abs(vt) <= 1e-9
                    else:
                        assert (vt > 0) == (mode == "slip_pos")
            assert s.dKE <= 1e-9


def test_a_delassus_matrix_made_by_the_motion_skips_only_its_check():
    """``delassus_made`` (what a landing passes: W = J M^-1 J^T by construction) gives the
    same solutions, bit for bit, as the checked call, held rows included; only the
    symmetry check is skipped, and input that is not finite is still refused."""
    from phasemap.motion.impact import delassus, simultaneous

    rng = np.random.default_rng(11)
    solved = 0
    for _ in range(40):
        A = rng.normal(size=(5, 5))
        M = A @ A.T + 5 * np.eye(5)
        W = delassus(M, rng.normal(size=(5, 5)))
        # (the held row's velocity zero, as a landing leaves it before the normal impact)
        v = np.array([-rng.uniform(0.1, 2), rng.normal(), -rng.uniform(0, 2), rng.normal(),
                      0.0])
        mu, e = rng.uniform(0, 1.5, 2), rng.uniform(0, 1)
        checked = simultaneous(W, v, mu, e=e, held=[1])
        made = simultaneous(W, v, mu, e=e, held=[1], delassus_made=True)
        assert [(s.modes, s.P.tobytes(), s.v.tobytes(), s.dKE) for s in made] == \
            [(s.modes, s.P.tobytes(), s.v.tobytes(), s.dKE) for s in checked]
        solved += bool(checked)
    assert solved >= 30
    # contacts that separate already: every one open, no impulse, the velocities kept
    W = delassus(np.diag([1.0, 2.0, 3.0]), [[1.0, 0.2, 0.0], [0.0, 1.0, 0.5], [0.3, 0.0, 1.0]])
    sols = simultaneous(W, [0.5, -0.2, 0.0], [0.4], held=[0], delassus_made=True)
    assert [s.modes for s in sols] == [("open",)]
    assert sols[0].P.tolist() == [0.0, 0.0, 0.0] and sols[0].v.tolist() == [0.5, -0.2, 0.0]
    assert sols[0].dKE == 0.0 and not sols[0].continuum
    with pytest.raises(ValueError, match="finite"):
        simultaneous(np.full((2, 2), np.nan), [-1.0, 0.0], [0.5], delassus_made=True)
    # the check skipped, and only there: a W that is not symmetric
    lopsided = [[2.0, 0.5], [0.0, 1.0]]
    with pytest.raises(ValueError, match="symmetric"):
        simultaneous(lopsided, [-1.0, 0.0], [0.5])
    assert simultaneous(lopsided, [-1.0, 0.0], [0.5], delassus_made=True)


def test_simultaneous_impacts_with_restitution():
    """Moreau's generalised Newton law at several contacts (issue 38: e > 0 was ignored
    where another contact was closed).  A uniform rod (m = 1, half-length 1) lying flat
    with end A on the floor (v_n = 0) and end B landing at v: with A held, B's effective
    mass is m / 3, so P_B = m (1 + e) v / 3, P_A = P_B / 2, B leaves at e v, A stays, and
    (1 - e^2) m v^2 / 6 is lost.  Random frictionless cases never gain energy, and each
    contact ends at v_n = -e v_n before where it takes an impulse."""
    from phasemap.motion.impact import simultaneous

    M = np.diag([1.0, 1.0, 1 / 3])
    J = np.array([[0, 1, -1.0], [1, 0, 0], [0, 1, 1.0], [1, 0, 0]])  # n_A, t_A, n_B, t_B
    W = J @ np.linalg.solve(M, J.T)
    for e, v in ((0.0, 1.0), (0.5, 1.0), (1.0, 2.0)):
        (s,) = simultaneous(W, [0.0, 0.0, -v, 0.0], [0.0, 0.0], e=e)
        assert np.allclose(s.P, [(1 + e) * v / 6, 0.0, (1 + e) * v / 3, 0.0], atol=1e-12)
        assert np.allclose(s.v[[0, 2]], [0.0, e * v], atol=1e-12)
        assert s.dKE == pytest.approx(-(1 - e * e) * v * v / 6, abs=1e-12)
    rng = np.random.default_rng(8)
    for _ in range(60):
        Jr = rng.normal(size=(4, 5))
        Wr = Jr @ np.diag(rng.uniform(0.2, 2.0, 5)) @ Jr.T
        v = np.array([-rng.uniform(0.1, 2), rng.normal(), -rng.uniform(0, 2), rng.normal()])
        e = rng.uniform(0, 1, 2)
        sols = simultaneous(Wr, v, [0.0, 0.0], e=e)
        assert sols
        for s in sols:
            assert s.dKE <= 1e-9
            for c, mode in enumerate(s.modes):
                if mode != "open":
                    assert s.v[2 * c] == pytest.approx(-e[c] * v[2 * c], abs=1e-9)
                else:
                    assert s.v[2 * c] >= -e[c] * v[2 * c] - 1e-12
    with pytest.raises(ValueError, match=r"e must be in \[0, 1\]"):
        simultaneous(W, [0.0, 0.0, -1.0, 0.0], [0.0, 0.0], e=1.5)


def test_simulate_goes_on_through_the_rods_impact_without_collision():
    """The Painleve rod (m = 1, l = 1, f = 1.5) at theta = arctan 2, at rest but for
    x_A' = -1 has no solution for its accelerations; simulate applies the impact without
    collision there (P_n = 0.3, P_t = 0.4, KE 0.5 -> 0.3), the rod sticks, and the motion
    goes on instead of ending with no_solution."""
    import phasemap

    th = math.atan(2.0)
    before = phasemap.classify("painleve_rod", theta=th, omega=0.0, xdot=-1.0, f=1.5)
    assert before.n_solutions == 0
    ds = phasemap.simulate("painleve_rod", 2.0, theta=th, omega=0.0, xdot=-1.0, f=1.5)
    kinds = [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]
    assert kinds[0] == "iwc" and ds.attrs["end_reason"] != "no_solution"
    assert float(ds.event_t[0]) == 0.0
    assert float(ds.event_impulse_n[0]) == pytest.approx(0.3, abs=1e-12)
    assert float(ds.event_impulse_t[0]) == pytest.approx(0.4, abs=1e-12)
    assert float(ds.event_dKE[0]) == pytest.approx(-0.2, abs=1e-12)
    assert np.isnan(ds.event_impulse_n.values[1:]).all()
    # the event keeps the state before the impulse, as every impulsive event does; the
    # state after it is the next saved point, at the same time
    assert (float(ds.event_omega[0]), float(ds.event_xdot[0])) == (0.0, -1.0)
    after = np.flatnonzero(ds.t.values == 0.0)
    assert after.size == 2 and int(ds.branch[after[0]]) == -1
    omega, xdot = float(ds.omega[after[1]]), float(ds.xdot[after[1]])
    assert omega == pytest.approx(0.3 * math.sqrt(5), abs=1e-12)
    assert xdot == pytest.approx(0.0, abs=1e-12)  # end A stuck
    m = phasemap.MODELS["painleve_rod"]
    assert m.branches[int(ds.event_branch[0])] == "stick"       # the branch after it
    assert m.branches[int(ds.branch[after[1]])] == "stick"
    # the kinetic energy after, from the state: G = A + l (cos, sin)
    vg = np.array([xdot - math.sin(th) * omega, math.cos(th) * omega])
    assert 0.5 * vg @ vg + 0.5 / 3 * omega ** 2 == pytest.approx(0.3, abs=1e-12)


def test_a_motion_goes_on_in_full_coordinates_after_an_impact_without_collision():
    """A rod spinning fast at f = 2.17 has no solution at its start: the impact without
    collision stops its slip and spins it up so that it must leave the floor.  The
    reduced model alone ends there with ``contact_lost`` (its last event, after the
    ``iwc``); the motion goes on in full coordinates, keeps the impact's impulses, lifts
    off from the state after the impact, and flies with a constant spin until the rod
    lies flat at theta = pi."""
    import phasemap

    start = dict(theta=0.7168, omega=3.65, xdot=-3.7154, f=2.1736)
    names = lambda ds: [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]
    reduced = phasemap.simulate("painleve_rod", 2.0, through_contacts=False, **start)
    assert names(reduced) == ["iwc", "contact_lost"]
    assert reduced.attrs["end_reason"] == "contact_lost"
    ds = phasemap.simulate("painleve_rod", 2.0, **start)
    assert names(ds) == ["iwc", "liftoff", "left_domain"]
    assert ds.attrs["phasemap_reduced_end"] == "contact_lost"
    for k in ("impulse_n", "impulse_t", "dKE"):
        assert float(ds[f"event_{k}"][0]) == float(reduced[f"event_{k}"][0])
    assert np.isnan(ds.event_impulse_n.values[1:]).all()
    assert int(ds.event_contact[0]) == 0
    # the iwc event, reduced or in full coordinates: the state before the impulse; the
    # state after it is the next saved point
    assert float(reduced.event_omega[0]) == float(ds.event_omega[0]) == start["omega"]
    omega = float(reduced.omega[1])
    assert float(reduced.t[1]) == 0.0 and omega != start["omega"]
    assert float(ds.event_omega[1]) == pytest.approx(omega, abs=1e-12)
    assert float(ds.event_xdot[1]) == pytest.approx(0.0, abs=1e-12)
    t_flat = (math.pi - start["theta"]) / omega
    assert float(ds.event_t[2]) == pytest.approx(t_flat, abs=1e-9)


def test_motions_without_such_a_state_are_untouched():
    """A hand-written model's no_solution still ends its motion (it has no declaration to
    take the impact from), and a declared motion that meets none has no impulse columns."""
    import phasemap

    ds = phasemap.simulate("elliptic_pendulum", t_end=1.0, phi=0.8, xdot=1.0, f=4.0)
    assert ds.attrs["end_reason"] == "no_solution"
    ok = phasemap.simulate("painleve_rod", 1.0, theta=1.0, omega=0.0, xdot=-1.0, f=0.3)
    assert "event_impulse_n" not in ok and "iwc" not in [
        phasemap.Event(int(k)).name.lower() for k in ok.event_kind.values]


def test_an_impact_without_collision_with_a_held_row_keeps_it_and_ends_projected():
    """``tangential_impact`` with a held row (a rolling disc's tangent: it does not slip)
    runs on the Schur complement of the Delassus matrix.  On random systems in a Painleve
    state of that complement, the held row's velocity stays zero, the impulse presses,
    energy is lost; and where the impact ends stuck at v_n = 0 all three contact
    velocities are zero, so the rates after are the rates projected in the mass metric
    onto the three rows: u - M^-1 J^T (J M^-1 J^T)^-1 J u (a closed form)."""
    from phasemap.motion.impact import tangential_impact

    rng = np.random.default_rng(4)
    done = stuck = 0
    for _ in range(400):
        A = rng.normal(size=(4, 4))
        M = A @ A.T + 0.5 * np.eye(4)
        Jc, held = rng.normal(size=(2, 4)), rng.normal(size=4)
        rows = np.vstack([Jc, held])
        # a state with v_n = 0 and the held row at 0, slipping on the second row
        base = np.linalg.svd(rows)[2][3]                       # moves none of the rows
        W3 = delassus(M, rows)
        W = W3[:2, :2] - np.outer(W3[:2, 2], W3[2, :2]) / W3[2, 2]
        u = base + np.linalg.solve(M, rows.T @ np.linalg.solve(W3, [0.0, 1.0, 0.0]))
        slip = float(Jc[1] @ u)
        s = math.copysign(1.0, slip)
        mu = rng.uniform(0.1, 4.0)
        if W[0, 0] - s * mu * W[0, 1] >= 0.0:
            continue                                          # not a Painleve state
        after, r = tangential_impact(M, Jc, u, mu, None, held)
        done += 1
        assert r.P_n > 0.0 and r.dKE <= 1e-12 * (u @ M @ u)
        assert abs(held @ after) <= 1e-12 * (1.0 + abs(u).max())
        if r.sticks and r.v_n == 0.0:
            stuck += 1
            X = np.linalg.solve(M, rows.T)
            projected = u - X @ np.linalg.solve(rows @ X, rows @ u)
            assert np.allclose(after, projected, rtol=1e-10, atol=1e-12 * abs(u).max())
    assert done >= 40 and stuck >= 10
