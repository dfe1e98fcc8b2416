"""Motion through contact changes (issue 38): lift-off, flight, impacts, impacts without
collision and Zeno, each checked against a closed form derived here."""

import dataclasses
import math

import numpy as np
import pytest
import sympy as sp

import phasemap
from phasemap.core import events as ev
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System
from phasemap.declare.full import mechanics
from phasemap.motion import hybrid
from phasemap.systems.seeds.ladder import SYSTEM as LADDER

G = 9.81


def _ladder_with_top_on_floor():
    """The seed ladder with a third contact: its top end B on the floor (it cannot close
    all three at once, so it has no reduced model: full coordinates only)."""
    phi, xc, yc = LADDER.coordinates
    f, l = LADDER.parameters[0], LADDER.parameters[1]
    top = PointContact("top", (xc - l * sp.sin(phi), yc + l * sp.cos(phi)), normal=(0, 1),
                       friction=f)
    return dataclasses.replace(LADDER, name="ladder_three", contacts=LADDER.contacts + (top,),
                               coordinates=(dataclasses.replace(phi, upper=math.inf), xc, yc),
                               names={})


def _ball():
    m = Parameter("m", "kg", "mass of the ball", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", G, 0.0)
    f = Parameter("f", "1", "friction coefficient", 0.3, 0.0)
    x = Coordinate("x", "m", "horizontal position",
                   rate=Rate("vx", "m s-1", "horizontal velocity"))
    y = Coordinate("y", "m", "height above the floor")
    return System("ball", "A ball on a rough floor", "test", coordinates=(x, y),
                  parameters=(m, g, f), bodies=(Body(m, (x, y)),), potential=m * g * y,
                  contacts=(PointContact("floor", (x, y), normal=(0, 1), friction=f),))


BALL = _ball()


@pytest.fixture(scope="module")
def falling_ladder():
    """The frictionless ladder (length 2l = 1) released at rest from 60 degrees to the
    floor (phi0 = 30 degrees from the wall), through its release from the wall."""
    return phasemap.simulate("ladder", t_end=1.0, rtol=1e-12, phi=math.radians(30),
                             omega=0.0, f=0.0, l=0.5)


def test_ladder_leaves_the_wall_where_energy_says(falling_ladder):
    ds = falling_ladder
    kinds = ds.event_kind.values.tolist()
    assert kinds == [ev.START, ev.LIFTOFF, ev.LEFT_DOMAIN]
    assert ds.attrs["phasemap_coordinates"] == "full"
    assert ds.attrs["phasemap_reduced_end"] == "contact_lost"
    at = kinds.index(ev.LIFTOFF)
    assert ds.event_contact.values[at] == 1      # the wall
    # both contacts smooth, the centre on a circle of radius l: N_wall = 0 where
    # cos phi = (2/3) cos phi0, i.e. sin theta = (2/3) sin theta0 from the floor
    theta0 = math.radians(60.0)
    theta_s = math.asin(2.0 / 3.0 * math.sin(theta0))
    assert abs((math.pi / 2 - float(ds.event_phi[at])) - theta_s) <= 1e-9
    # (2/3) m l^2 omega^2 = m g l (cos phi0 - cos phi)
    l = 0.5
    omega_s = math.sqrt(1.5 * G / l * (math.sin(theta0) - math.sin(theta_s)))
    assert abs(float(ds.event_omega[at]) - omega_s) <= 1e-8
    assert abs(float(ds.event_t[at]) - 0.325031) <= 5e-7        # the issue's figure
    # after the release the centre keeps the horizontal velocity it had
    assert np.allclose(ds.xc_dot.values[ds.t.values > ds.event_t.values[at]],
                       l * math.cos(math.pi / 2 - theta_s) * omega_s, rtol=1e-8)


def test_ladder_lies_flat_at_the_issues_time(falling_ladder):
    ds = falling_ladder
    assert ds.attrs["end_reason"] == "left_domain"
    assert abs(float(ds.event_t[-1]) - 0.485174) <= 5e-7
    assert abs(float(ds.event_omega[-1]) - 4.833549) <= 5e-6
    assert abs(float(ds.event_phi[-1]) - math.pi / 2) <= 1e-12
    # the floor contact held throughout the flight: the foot's height is zero
    foot = ds.yc.values - 0.5 * np.cos(ds.phi.values)
    assert np.abs(foot).max() <= 1e-10


@pytest.mark.parametrize("name", ["ladder", "wheel", "painleve_rod", "rod_on_step"])
def test_the_pieces_on_python_floats_are_numpys_bit_for_bit(name):
    """Mechanics.pieces runs the generated function on Python floats (twice as fast as on
    NumPy's scalars): the same doubles at random states of every declared built-in model;
    and where Python would raise instead of giving inf or nan (a division by zero), the
    pieces are NumPy's, as the compiled kernels' are."""
    S = phasemap.get_model(name).declaration
    mech = mechanics(getattr(S, "system", S))
    p = np.array([mech.defaults[k] for k in mech.parameters], dtype=float)
    rng = np.random.default_rng(7)
    for _ in range(200):
        q, u = rng.uniform(-3, 3, mech.n), rng.uniform(-10, 10, mech.n)
        got = np.concatenate([np.ravel(x) for x in mech.pieces(q, u, p, 0.0)])
        numpy = np.array(mech._pieces(*q, *u, *p, 0.0), dtype=float)
        assert got.tobytes() == numpy.tobytes()

    def dividing(*args):
        return [x / (args[0] - args[0]) if i == 0 else x
                for i, x in enumerate(mech._pieces(*args))]

    broken = dataclasses.replace(mech, _pieces=dividing)
    M = broken.pieces(np.ones(mech.n), np.ones(mech.n), p, 0.0)[0]
    assert not np.isfinite(M.flat[0]) and np.all(np.isfinite(M.flat[1:]))


def test_reduced_motions_are_untouched():
    """A motion that meets no contact change is the reduced integrator's own Dataset."""
    ds = phasemap.simulate("ladder", t_end=2.0, phi=0.2, omega=0.0, f=0.5)
    assert "phasemap_coordinates" not in ds.attrs
    assert ds.attrs["end_reason"] == "rest"


def test_ladder_lands_on_its_top_plastically():
    S = _ladder_with_top_on_floor()
    ds = phasemap.simulate(S, t_end=0.6, rtol=1e-12, phi=math.radians(30), omega=0.0,
                           xc=0.25, yc=0.5 * math.cos(math.radians(30)), f=0.0, l=0.5)
    kinds = ds.event_kind.values.tolist()
    assert kinds[:3] == [ev.START, ev.LIFTOFF, ev.IMPACT]
    i = kinds.index(ev.IMPACT)
    assert ds.event_contact.values[i] == 2
    # landing flat, frictionless, both ends held: the vertical velocity of the centre
    # and the rotation stop; the horizontal one goes on
    m, l = 1.0, 0.5
    lost = 0.5 * m * float(ds.event_yc_dot[i]) ** 2 + 0.5 * m * l**2 / 3 * float(
        ds.event_omega[i]) ** 2
    assert abs(float(ds.event_dKE[i]) + lost) <= 1e-9
    assert abs(float(ds.event_dKE[i]) + 3.893867) <= 5e-7      # the issue's figure
    after = ds.t.values > ds.event_t.values[i]
    assert np.abs(ds.omega.values[after]).max() <= 1e-9
    assert ds.attrs["end_reason"] == "horizon"


def test_ladder_bounces_on_its_top_and_comes_to_rest():
    """The same landing with restitution e = 0.5 (issue 38: several contacts with e > 0):
    the foot, closed and sliding, is held; the top takes P = m (1 + e) v / 3, v = 2 l omega
    (its effective mass with the foot held is m / 3), loses (1 - e^2) of 3.893867 J and
    bounces.  Each bounce lasts e times the one before, each loses e^2 times the energy,
    and the impacts accumulate where that geometric series ends: a zeno event there, then
    the ladder lies flat."""
    S = _ladder_with_top_on_floor()
    e, m, l = 0.5, 1.0, 0.5
    ds = phasemap.simulate(S, t_end=3.0, rtol=1e-12, phi=math.radians(30), omega=0.0,
                           xc=0.25, yc=0.5 * math.cos(math.radians(30)), f=0.0, l=l,
                           restitution=e)
    kinds = ds.event_kind.values.tolist()
    assert kinds[:3] == [ev.START, ev.LIFTOFF, ev.IMPACT] and ev.ZENO in kinds
    impacts = [i for i, k in enumerate(kinds) if k == ev.IMPACT]
    assert 10 < len(impacts) < 60                                 # bounded work
    i = impacts[0]
    v = 2 * l * float(ds.event_omega[i])
    assert float(ds.event_impulse_n[i]) == pytest.approx(m * (1 + e) * v / 3, rel=1e-9)
    assert float(ds.event_dKE[i]) == pytest.approx(-(1 - e * e) * 3.893867, abs=5e-7)
    assert float(ds.event_dKE[i]) == pytest.approx(-(1 - e * e) * m * v * v / 6, rel=1e-9)
    t = ds.event_t.values[impacts]
    ratio = np.diff(t)[1:] / np.diff(t)[:-1]
    assert np.all(np.abs(ratio - e) <= 2e-3) and abs(ratio[-1] - e) <= 1e-6
    loss = ds.event_dKE.values[impacts]
    assert np.allclose(loss[1:5] / loss[:4], e * e, rtol=1e-2)
    t_zeno = float(ds.event_t[kinds.index(ev.ZENO)])
    assert abs(t_zeno - (t[-1] + (t[-1] - t[-2]) * e / (1 - e))) <= 1e-9
    after = ds.t.values > t_zeno
    assert np.abs(ds.omega.values[after]).max() <= 1e-9
    assert np.abs(ds.phi.values[after] - math.pi / 2).max() <= 1e-9


def test_bouncing_ball_comes_to_rest_at_the_zeno_time():
    e, h0 = 0.5, 1.0
    ds = phasemap.simulate(BALL, t_end=3.0, rtol=1e-12, restitution=e, x=0.0, y=h0,
                           vx=0.0, y_dot=0.0)
    kinds = ds.event_kind.values.tolist()
    assert kinds[-2:] == [ev.ZENO, ev.REST]
    t_inf = math.sqrt(2 * h0 / G) * (1 + e) / (1 - e)
    assert abs(float(ds.event_t[-1]) - t_inf) <= 1e-9
    assert kinds.count(ev.IMPACT) < 40                          # bounded work
    # each rebound is e times the speed before it
    at = np.flatnonzero(ds.event_kind.values == ev.IMPACT)
    v = -ds.event_y_dot.values[at]
    assert np.allclose(v[1:] / v[:-1], e, rtol=1e-9)


def test_no_drift_after_a_hundred_impacts():
    ds = phasemap.simulate(BALL, t_end=60.0, rtol=1e-10, restitution=0.95, x=0.0, y=1.0,
                           vx=0.5, y_dot=0.0)
    at = np.flatnonzero(ds.event_kind.values == ev.IMPACT)
    assert at.size >= 100
    assert np.abs(ds.event_y.values[at]).max() <= 1e-12
    assert ds.y.values.min() >= -1e-12
    assert np.all(ds.event_dKE.values[at] <= 0.0)


def test_impact_without_collision_of_the_rod_in_full_coordinates():
    """Genot and Brogliato's tangential impact: theta = arctan 2, f = 1.5, x_A' = -1."""
    from phasemap.systems.painleve_rod import SYSTEM as ROD

    mech = mechanics(ROD)
    p = np.array([{"f": 1.5, "l": 1.0, "g": G, "m": 1.0}[k] for k in mech.parameters])
    theta = math.atan(2.0)
    rec = hybrid.run_full(mech, p, np.array([theta, 0.0, 0.0]), np.array([0.0, -1.0, 0.0]),
                          t_end=0.1, rtol=1e-12, atol=1e-12, max_step=math.inf,
                          max_steps=10_000, max_events=100)
    assert rec.ev_kind[0] == ev.IWC
    P_n, P_t, dKE = rec.ev_impulse[0]
    assert abs(P_n - 0.3) <= 1e-12 and abs(P_t - 0.4) <= 1e-12
    assert abs(dKE + 0.2) <= 1e-12                                # 0.5 -> 0.3
    # the state after it (the first point saved; the event holds the state before): the
    # rod sticks
    assert rec.t[0] == 0.0 and rec.ev_y[0][4] == -1.0
    y = rec.y[0]
    th, w, xd, yd = y[0], y[3], y[4], y[5]
    assert abs(w - 0.3 * math.sqrt(5)) <= 1e-12
    assert abs((xd - math.sin(th) * w) + 0.6) <= 1e-12           # x_G'
    assert abs((yd + math.cos(th) * w) - 0.3) <= 1e-12           # y_G'
    assert rec.modes[0] == (hybrid.STICK,)


@pytest.mark.parametrize("bad, message", [
    ({"impact_law": "elastic"}, "impact_law must be one of"),
    ({"restitution": 1.5}, "restitution must be in"),
    ({"painleve": "guess"}, "painleve must be one of"),
    ({"zeno_speed": -1.0}, "zeno_speed"),
])
def test_contact_options_are_checked(bad, message):
    with pytest.raises(ValueError, match=message):
        phasemap.simulate(BALL, t_end=1.0, y=1.0, **bad)


def test_full_starts_are_checked():
    with pytest.raises(ValueError, match="inside the obstacle"):
        phasemap.simulate(BALL, t_end=1.0, y=-0.1)
    with pytest.raises(ValueError, match="unknown variable"):
        phasemap.simulate(BALL, t_end=1.0, y=1.0, z_dot=2.0)
    with pytest.raises(ValueError, match="one number per"):
        phasemap.simulate(BALL, t_end=1.0, y=[1.0, 2.0])


def test_full_motion_dataset_is_self_describing(tmp_path):
    ds = phasemap.simulate(BALL, t_end=0.5, x=0.0, y=0.5, vx=1.0, y_dot=1.0, restitution=0.3,
                           t_eval=np.linspace(0.0, 0.5, 11))
    assert ds.t.size == 11 and np.all(np.isfinite(ds.y.values))
    assert ds.mode_floor.attrs["flag_meanings"].split()[1:] == list(hybrid.MODE_NAMES)
    assert ds.y_dot.attrs["units"] == "m s-1"
    path = tmp_path / "ball.nc"
    ds.to_netcdf(path)
    import xarray as xr

    with xr.open_dataset(path) as back:
        assert back.attrs["phasemap_impact_law"] == "stronge"
        assert int((back.event_kind == ev.IMPACT).sum()) >= 1


def _rod_with_both_ends():
    """Painleve's rod with its other end B declared as a second contact (open at first)."""
    from phasemap.systems.painleve_rod import SYSTEM as ROD

    theta, x, y = ROD.coordinates
    f, l = ROD.parameters[:2]
    end_b = PointContact("B", (x + 2 * l * sp.cos(theta), y + 2 * l * sp.sin(theta)),
                         friction=f)
    return dataclasses.replace(ROD, name="rod_two_ends", contacts=ROD.contacts + (end_b,),
                               coordinates=(dataclasses.replace(theta, lower=-math.inf), x, y))


def test_rod_lands_on_its_other_end_and_comes_to_rest():
    """The rod falls sliding, lands flat on B (a plastic impact with A closed: Moreau's
    impulse-level solution of both contacts), and stops: a rest held by a family of
    friction forces (two rough points on one line), found by linear programming."""
    ds = phasemap.simulate(_rod_with_both_ends(), theta=1.0, omega=0.0, xdot=1.0, f=0.3,
                           t_end=3.0, rtol=1e-10)
    kinds = [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]
    assert kinds[-2:] == ["impact", "rest"], kinds
    assert ds.event_contact.values[-2] == 1
    assert abs(float(ds.event_theta[-1])) <= 1e-12          # lying flat
    assert float(ds.event_t[-1]) < 3.0
    state = [v for v in ("omega", "xdot", "y_dot") if v in ds]
    assert all(abs(float(ds[f"event_{v}"][-1])) <= 1e-12 for v in state)
    assert float(ds.event_dKE[-2]) < 0.0
    # the floor reactions at rest carry the weight
    assert abs(float(ds.N_A[-1] + ds.N_B[-1]) - G) <= 1e-9


def test_through_contacts_false_is_the_reduced_fate():
    ds = phasemap.simulate("ladder", t_end=1.0, phi=math.radians(30), omega=0.0, f=0.0, l=0.5,
                           through_contacts=False)
    assert ds.attrs["end_reason"] == "contact_lost"
    assert "phasemap_coordinates" not in ds.attrs
    # recorded, so that a figure's dense curve runs the same motion again (the default
    # would go on through the lift-off: another motion, and its saved points were drawn)
    from phasemap.plot.motion import dense_motion

    assert ds.attrs["phasemap_through_contacts"] == "false"
    mid = 0.5 * (ds.t.values[1:] + ds.t.values[:-1])
    again = dense_motion(ds, mid)
    assert again is not None and again.attrs["end_reason"] == "contact_lost"
    tight = phasemap.simulate("ladder", t_end=1.0, phi=math.radians(30), omega=0.0, f=0.0,
                              l=0.5, through_contacts=False, rtol=1e-12, t_eval=mid)
    assert np.allclose(again.phi.values, tight.phi.values, rtol=0, atol=1e-6)
    del ds.attrs["phasemap_through_contacts"]
    assert dense_motion(ds, mid) is None
    assert "phasemap_through_contacts" not in phasemap.simulate(
        "ladder", t_end=1.0, phi=math.radians(30), omega=0.0, f=0.0, l=0.5).attrs
    with pytest.raises(ValueError, match="no reduced model"):
        phasemap.simulate(_ladder_with_top_on_floor(), t_end=1.0, through_contacts=False)


def test_outline_strip_draws_the_motion(falling_ladder, tmp_path):
    import matplotlib.pyplot as plt

    fig = falling_ladder.phasemap.strip()
    ax = fig.axes[0]
    # one outline per drawn time, and the floor and the wall
    assert len(ax.lines) > 7
    assert any(t.get_text() for t in fig.texts) or ax.get_title() is not None
    fig.savefig(tmp_path / "strip.png")
    plt.close(fig)
    with pytest.raises(ValueError, match="times must be"):
        falling_ladder.phasemap.strip(times=[5.0])


def test_a_full_coordinate_motion_is_drawn_by_its_coordinates(falling_ladder, tmp_path):
    """Its default figure drew every variable on t (17 panels, the labels overlapping):
    the coordinates alone now; their rates and the reactions by name."""
    import matplotlib.pyplot as plt

    import figure_review

    ds = falling_ladder
    fig = ds.phasemap.plot()
    panels = [a for a in fig.axes if a.axison]
    coordinates = [n for n in ds.data_vars if f"event_{n}" in ds.data_vars
                   and ds[n].dims == ("t",) and "flag_values" not in ds[n].attrs
                   and not ds[n].attrs.get("units", "").endswith("s-1")]
    assert len(panels) == len(coordinates) == 3, coordinates
    assert not figure_review.layout_problems(fig)
    plt.close(fig)
    rates = [n for n in ds.data_vars if f"event_{n}" in ds.data_vars and ds[n].dims == ("t",)
             and ds[n].attrs.get("units", "").endswith("s-1")]
    fig = ds.phasemap.plot(rates[:2])   # named: drawn
    assert len([a for a in fig.axes if a.axison]) == 2
    plt.close(fig)


def test_cli_prints_a_motion_through_contact_changes(capsys):
    from phasemap.cli import main

    code = main(["simulate", "ladder", "phi=0.5236", "omega=0", "f=0", "l=0.5", "--t-end",
                 "1"])
    out = capsys.readouterr().out
    assert code == 0
    assert "liftoff" in out and "wall" in out and "xc_dot" in out


def _random_body():
    """A body of random shape: its centre of mass off the line through the contact point,
    its inertia a parameter of its own, one point A on the floor."""
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", G, 0.0)
    f = Parameter("f", "1", "friction coefficient", 0.5, 0.0)
    a = Parameter("a", "m", "centre of mass along the body", 1.0)
    b = Parameter("b", "m", "centre of mass across the body", 0.0)
    J = Parameter("J", "kg m2", "moment of inertia about the centre", 0.3, 0.0,
                  lower_open=True)
    th = Coordinate("theta", "rad", "angle", 1.0, rate=Rate("omega", "rad s-1", "rate"))
    x = Coordinate("x", "m", "A along the floor", rate=Rate("xdot", "m s-1", "A's velocity"))
    y = Coordinate("y", "m", "A's height")
    c, s = sp.cos(th), sp.sin(th)
    G_ = (x + a * c - b * s, y + a * s + b * c)
    return System("random_body", "a body of random shape on a floor", "test",
                  coordinates=(th, x, y), parameters=(m, g, f, a, b, J),
                  bodies=(Body(m, G_, inertia=J, angle=th),), potential=m * g * G_[1],
                  contacts=(PointContact("A", (x, y), friction=f),))


def _impacts(rec, mech, p):
    """Per impact of a motion's record: ``(P_n, dKE, KE before, state before, state
    after, modes after)``; the state after is the last point saved at the impact's time."""
    for i, kind in enumerate(rec.ev_kind):
        if kind != ev.IMPACT:
            continue
        P_n, _, dKE = rec.ev_impulse[i]
        y = rec.ev_y[i]
        ke = 0.5 * y[3:] @ mech.pieces(y[:3], y[3:], p)[0] @ y[3:]
        at = [j for j, t in enumerate(rec.t) if t == rec.ev_t[i]][-1]
        yield P_n, dKE, ke, y, rec.y[at], rec.modes[at]


@pytest.mark.parametrize("law", ["stronge", "poisson"])
def test_random_impacts_never_gain_energy_and_end_complementary(law):
    """Random single-contact impacts of the declared rod and of a random body: under
    Stronge's and Poisson's laws the kinetic energy never grows, and after the impact
    the contact does not approach (v_n >= 0), is closed where it does not separate, and
    has pushed (P_n >= 0)."""
    from phasemap.systems.painleve_rod import SYSTEM as ROD

    rng = np.random.default_rng(38)
    n_impacts = 0
    for S in (ROD, _random_body()):
        mech = mechanics(S)
        for _ in range(40):
            vals = {"f": rng.uniform(0.0, 2.0), "l": rng.uniform(0.3, 2.0), "g": G,
                    "m": rng.uniform(0.5, 3.0), "a": rng.uniform(0.2, 2.0),
                    "b": rng.uniform(-0.5, 0.5), "J": rng.uniform(0.05, 1.0)}
            p = np.array([vals[k] for k in mech.parameters])
            q = np.array([rng.uniform(0.1, 1.5), 0.0, 0.0])
            u = np.array([rng.uniform(-3, 3), rng.uniform(-2, 2), rng.uniform(-3, -0.1)])
            rec = hybrid.run_full(mech, p, q, u, t_end=0.05, rtol=1e-10, atol=1e-10,
                                  max_step=math.inf, max_steps=5_000, max_events=50,
                                  impact_law=law, restitution=rng.uniform(0.0, 1.0))
            for P_n, dKE, ke, y, after, modes in _impacts(rec, mech, p):
                n_impacts += 1
                assert dKE <= 1e-12 * max(ke, 1.0) and P_n >= 0.0
                J = mech.pieces(after[:3], after[3:], p)[3][0]
                v_n = J[0] @ after[3:]
                assert v_n >= -1e-9 * (1.0 + abs(J[0] @ y[3:]))
                if modes[0] != hybrid.OPEN:      # closed: it does not move off
                    assert abs(v_n) <= 1e-9 * (1.0 + abs(J[0] @ y[3:]))
    assert n_impacts >= 80


def test_painleve_policies_where_the_accelerations_have_two_solutions():
    """The rod sliding back, turning fast: slipping on and lifting off both solve the
    accelerations (n = 2).  ``liftoff`` lifts off, ``iwc`` jumps by an impact without
    collision, ``stop`` ends the motion there."""
    start = dict(theta=0.7, omega=-5.0, xdot=-1.0, f=2.0)
    assert phasemap.classify("painleve_rod", **start).n_solutions == 2

    def kinds(policy):
        ds = phasemap.simulate("painleve_rod", t_end=0.3, painleve=policy, **start)
        return [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values], ds

    lift, ds = kinds("liftoff")
    assert lift[0] == "liftoff" and float(ds.event_t[0]) == 0.0
    assert float(ds.y.max()) > 0.0                     # it flies
    jump, ds = kinds("iwc")
    assert jump[0] == "iwc" and float(ds.event_impulse_n[0]) > 0.0
    stop, _ = kinds("stop")
    assert stop == ["indeterminate"]


def test_rod_on_step_lifts_off_the_floor_and_lands_again():
    """The rod on the step lifts its foot off the floor (the reduced model's
    contact_lost), flies about the step's corner, and lands: plastic impacts that
    alternate between the floor and the corner, each smaller than the one before, until
    both stay closed and the rod slides on to the end of the step."""
    ds = phasemap.simulate("rod_on_step", theta=1.2, omega=-1.0, f=0.3, h=0.8, t_end=3.0)
    kinds = [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]
    assert kinds[:3] == ["start", "liftoff", "impact"]
    assert kinds[-1] == "left_domain"
    at = np.flatnonzero(ds.event_kind.values == ev.IMPACT)
    P = ds.event_impulse_n.values[at]
    assert np.all(P > 0.0) and np.all(np.diff(P) < 0.0)
    assert np.all(ds.event_dKE.values[at] <= 0.0)
    foot = ds.point_y_floor.values                     # never below the floor
    assert foot.min() >= -1e-9


def test_a_step_of_almost_no_height_makes_redundant_contacts_that_answer():
    """The fuzz (issue 42) found simulate('rod_on_step', h=1e-12) raising TypeError: the
    floor and the step's corner nearly coincide, the reactions of the two closed contacts
    form a family, and the search for an admissible member read the sign of N of a
    one-sided contact from an argument that is None for them."""
    ds = phasemap.simulate("rod_on_step", 0.5, h=1e-12)
    assert ds.attrs["end_reason"] in ("left_domain", "rest", "horizon")
    assert np.all(np.isfinite(ds.N_floor.values[np.isfinite(ds.N_floor.values)]))
    assert np.isfinite(ds.N_floor.values).any()


def test_a_full_motion_keeps_to_the_memory_available(monkeypatch):
    """Issue 42: the saved points of a motion in full coordinates are bounded by the
    memory available, as the reduced integrator's are; a motion cut there says so."""
    from phasemap.motion.hybrid import start

    monkeypatch.setattr(start, "available_memory", lambda: 4_000_000)
    with pytest.warns(RuntimeWarning, match="would not fit in the memory"):
        ds = phasemap.simulate(BALL, t_end=60.0, rtol=1e-10, restitution=0.95, y=1.0,
                               max_step=1e-3)
    assert ds.attrs["end_reason"] == "max_steps"
    assert "pass t_eval=" in ds.attrs["end_message"]
    assert ds.t.size < 5_000


def test_a_declaration_may_give_the_fixed_coordinate_a_rate():
    """The issue's bouncing ball: a point mass with x, y and both rates, and one smooth
    floor. Closing its contact fixes y, so it has no reduced model with y's rate; it moves
    in full coordinates, its rates named as declared. Without friction it slides on after
    the impacts accumulate."""
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", G, 0.0)
    x = Coordinate("x", "m", "position", rate=Rate("vx", "m s-1", "horizontal velocity"))
    y = Coordinate("y", "m", "height", rate=Rate("vy", "m s-1", "vertical velocity"))
    ball = System("ball_rates", "a ball with both rates", "test", coordinates=(x, y),
                  parameters=(m, g), bodies=(Body(m, (x, y)),), potential=m * g * y,
                  contacts=(PointContact("floor", (x, y), friction=0),))
    ds = phasemap.simulate(ball, t_end=3.0, rtol=1e-12, restitution=0.5, y=1.0, vy=0.0,
                           vx=0.2)
    kinds = [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]
    assert "zeno" in kinds and kinds[-1] == "horizon"
    t_inf = math.sqrt(2.0 / G) * 1.5 / 0.5
    assert abs(float(ds.event_t[kinds.index("zeno")]) - t_inf) <= 1e-9
    assert np.allclose(ds.vx.values, 0.2, rtol=0, atol=1e-12)      # no friction
    assert abs(float(ds.x[-1]) - 0.2 * 3.0) <= 1e-9


def test_a_full_coordinate_declaration_is_validated_like_any_other():
    """A system that moves in full coordinates only is checked as every declaration is:
    the problem named in one line, not a sympy error from deep inside."""
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", G, 0.0)
    x = Coordinate("x", "m", "position", rate=Rate("vx", "m s-1", "horizontal velocity"))
    y = Coordinate("y", "m", "height", rate=Rate("vy", "m s-1", "vertical velocity"))
    ball = System("ball_no_law", "a ball", "test", coordinates=(x, y), parameters=(m, g),
                  bodies=(Body(m, (x, y)),), potential=m * g * y,
                  contacts=(PointContact("floor", (x, y)),))
    for call in (lambda: mechanics(ball),
                 lambda: phasemap.simulate(ball, t_end=1.0, y=1.0, vy=0.0)):
        with pytest.raises(ValueError,
                           match="ball_no_law: contact 'floor': has no friction law"):
            call()


def _rod_slip_to_its_singular_point(theta, omega, xdot, f, until="B"):
    """The Painleve rod (m = l = 1) slipping with x_A' < 0, integrated here from the
    equations derived by hand (not from the declaration): N (1 + 3 c^2 - 3 f s c) = g -
    s omega^2 (s, c = sin, cos theta), theta'' = 3 N (f s - c), x_G'' = f N.  Stops where
    B = 1 + 3 c^2 - 3 f s c reaches 1e-10 (``until="N"``: where N reaches 0):
    ``(t, theta, omega, x_A')``."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        th, w, xd = y
        s, c = math.sin(th), math.cos(th)
        N = (G - s * w * w) / (1.0 + 3.0 * c * c - 3.0 * f * s * c)
        wd = 3.0 * N * (f * s - c)
        return [w, wd, f * N + s * wd + c * w * w]           # x_A'' = x_G'' + s w' + c w^2

    def near(t, y):
        s, c = math.sin(y[0]), math.cos(y[0])
        if until == "N":
            return G - s * y[1] * y[1]
        return 1.0 + 3.0 * c * c - 3.0 * f * s * c - 1e-10
    near.terminal = True
    sol = solve_ivp(rhs, (0.0, 1.0), [theta, omega, xdot], method="LSODA", rtol=1e-12,
                    atol=1e-14, events=near)
    return (float(sol.t_events[0][0]), *sol.y_events[0][0])


@pytest.mark.parametrize("start", [(0.55, 3.6, -4.0), (0.60, 3.9, -4.0), (0.50, 3.0, -6.0)])
@pytest.mark.parametrize("full", [False, True], ids=["reduced_start", "full_start"])
def test_dynamic_jam_of_the_rod_stops_its_slip_with_the_sliding_impulse(start, full):
    """At f = 2 these slips run into the Genot-Brogliato singular point (B -> 0 with the
    free normal acceleration -> 0; N grows without bound, still slipping): a ``jam``, the
    impulse at v_n = 0 that stops the slip, P_n = -v_t / (W_tn - s f W_tt), P_t = -s f P_n,
    then the rod flies off (its spin now lifts it) until it lies flat at theta = pi."""
    f = 2.0
    theta0, omega0, xdot0 = start
    extra = {"y": 0.0, "y_dot": 0.0} if full else {}
    ds = phasemap.simulate("painleve_rod", 1.0, rtol=1e-10, theta=theta0, omega=omega0,
                           xdot=xdot0, f=f, **extra)
    kinds = ds.event_kind.values.tolist()
    assert kinds == [ev.START, ev.JAM, ev.LEFT_DOMAIN]
    assert ds.attrs.get("phasemap_reduced_end", "singular") == "singular"
    t_j, th, w, xd = _rod_slip_to_its_singular_point(theta0, omega0, xdot0, f)
    assert abs(float(ds.event_t[1]) - t_j) <= 1e-6
    s, c = math.sin(th), math.cos(th)
    # the jam's impulse, from the state the event holds (before it), in closed form
    th1, w1, xd1 = (float(ds[f"event_{k}"][1]) for k in ("theta", "omega", "xdot"))
    s1, c1 = math.sin(th1), math.cos(th1)
    B = 1.0 + 3.0 * c1 * c1 - 3.0 * f * s1 * c1
    assert abs(B) <= 1e-5 and abs(float(ds.event_y_dot[1])) <= 1e-12
    W_nt, W_tt = -3.0 * s1 * c1, 1.0 + 3.0 * s1 * s1
    P_n = -xd1 / (W_nt + f * W_tt)                             # s = sgn x_A' = -1
    assert P_n > 0.0
    assert abs(float(ds.event_impulse_n[1]) - P_n) <= 1e-9 * P_n
    assert abs(float(ds.event_impulse_t[1]) - f * P_n) <= 1e-9 * P_n
    # the state just after it, against the hand-integrated slip and the same impulse
    P_n = -xd / (-3.0 * s * c + f * (1.0 + 3.0 * s * s))
    w_after = w + 3.0 * (-c * P_n + s * f * P_n)                # I = 1/3: r x P
    at = np.flatnonzero(ds.t.values == float(ds.event_t[1]))[-1]
    assert abs(float(ds.omega[at]) - w_after) <= 1e-6 * abs(w_after)
    assert abs(float(ds.xdot[at])) <= 1e-9 and abs(float(ds.y_dot[at])) <= 1e-9
    KE = lambda w_, xd_, yd_: 0.5 * ((xd_ - s1 * w_) ** 2 + (yd_ + c1 * w_) ** 2 + w_ * w_ / 3)
    dKE = KE(float(ds.omega[at]), 0.0, 0.0) - KE(w1, xd1, 0.0)
    assert float(ds.event_dKE[1]) < 0.0
    assert abs(float(ds.event_dKE[1]) - dKE) <= 1e-8 * abs(dKE)
    # then free flight: the spin is constant until the rod lies flat at theta = pi
    t_flat = float(ds.event_t[1]) + (math.pi - th1) / float(ds.omega[at])
    assert abs(float(ds.event_t[2]) - t_flat) <= 1e-9
    assert float(ds.event_theta[2]) == pytest.approx(math.pi, abs=1e-12)
    assert ds.attrs["end_message"].endswith("theta reached 3.14159 rad")


def _slot_rod():
    """The Painleve rod (m = l = 1) with its end A in a rough slot: the contact two-sided,
    so A's reaction may pull (N < 0), and the friction -f |N| sgn x_A' then turns with N's
    sign."""
    f = Parameter("f", "1", "friction coefficient in the slot", default=2.0, lower=0.0)
    g = Parameter("g", "m s-2", "gravitational acceleration", default=G, lower=0.0)
    theta = Coordinate("theta", "rad", "angle of the rod to the slot", default=1.0,
                       lower=0.0, upper=math.pi,
                       rate=Rate("omega", "rad s-1", "angular velocity", scale=sp.sqrt(g)))
    x = Coordinate("x", "m", "position of end A along the slot",
                   rate=Rate("xdot", "m s-1", "velocity of end A", scale=sp.sqrt(g)))
    y = Coordinate("y", "m", "height of end A")
    return System("slot_rod", "a uniform rod with its end A in a rough slot", "test",
                  coordinates=(theta, x, y), parameters=(f, g),
                  bodies=(Body(1, (x + sp.cos(theta), y + sp.sin(theta)),
                               inertia=sp.Rational(1, 3), angle=theta),),
                  potential=g * (y + sp.sin(theta)),
                  contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f,
                                         sided="two", long_name="end A in the slot"),))


def test_a_dynamic_jam_at_a_two_sided_contact_whose_reaction_pulls():
    """A rod in a slot, spun fast (g - sin(theta) omega^2 < 0) while A slides forward: the
    slot pulls (N < 0), so the friction f |N| acts backwards as f N would forwards, and
    the slip obeys the one-sided rod's equations with x_A' < 0: N B = g - s omega^2,
    B = 1 + 3 c^2 - 3 f s c -> 0, N -> -infinity.  It jams there (the two-sided
    contact's jam used to end ``singular``: the impulse assumed a pressing reaction):
    P_n = -v_t / (W_nt + f W_tt) < 0, P_t = f P_n, the slip stopped, the slot kept.
    Run on the declaration's interpreted twins (the same bits as its machine code)."""
    from phasemap.core import tiers

    f, theta0, omega0, xdot0 = 2.0, 0.55, 5.0, 4.0
    s0 = math.sin(theta0)
    B0 = 1.0 + 3.0 * math.cos(theta0) ** 2 - 3.0 * f * s0 * math.cos(theta0)
    assert (G - s0 * omega0 ** 2) / B0 < 0.0      # the slot pulls from the start
    with tiers.forced("off"):
        ds = phasemap.simulate(_slot_rod(), 0.05, rtol=1e-10, theta=theta0, omega=omega0,
                               xdot=xdot0, f=f)
    kinds = ds.event_kind.values.tolist()
    assert kinds[:2] == [ev.START, ev.JAM], kinds
    assert ds.attrs.get("phasemap_reduced_end") == "singular"
    t_j, th, w, xd = _rod_slip_to_its_singular_point(theta0, omega0, xdot0, f)
    assert abs(float(ds.event_t[1]) - t_j) <= 1e-6
    th1, w1, xd1 = (float(ds[f"event_{k}"][1]) for k in ("theta", "omega", "xdot"))
    s1, c1 = math.sin(th1), math.cos(th1)
    assert abs(1.0 + 3.0 * c1 * c1 - 3.0 * f * s1 * c1) <= 1e-5
    P_n = -xd1 / (-3.0 * s1 * c1 + f * (1.0 + 3.0 * s1 * s1))
    assert P_n < 0.0                               # the slot's impulse pulls
    assert abs(float(ds.event_impulse_n[1]) - P_n) <= 1e-9 * abs(P_n)
    assert abs(float(ds.event_impulse_t[1]) - f * P_n) <= 1e-9 * abs(P_n)
    s, c = math.sin(th), math.cos(th)
    P_n = -xd / (-3.0 * s * c + f * (1.0 + 3.0 * s * s))
    w_after = w + 3.0 * (-c + s * f) * P_n           # I = 1/3: r x P
    at = np.flatnonzero(ds.t.values == float(ds.event_t[1]))[-1]
    assert abs(float(ds.omega[at]) - w_after) <= 1e-6 * abs(w_after)
    assert abs(float(ds.xdot[at])) <= 1e-9
    assert np.abs(ds.y.values).max() <= 1e-12 and np.abs(ds.y_dot.values).max() <= 1e-12
    assert float(ds.event_dKE[1]) < 0.0


def test_a_slip_velocity_that_dips_through_zero_inside_one_step_is_not_missed():
    """Ueda's oscillator with dry friction (x'' + 0.05 x' + x^3 = F0 cos t - 0.01 sgn x',
    F0 = 8.118): sliding back, its velocity rises through zero, forward for 0.04, and back
    (a pair of reversals), all inside what would be one step at rtol 1e-12.  The slip
    velocity's rate turning from negative to positive inside a step is checked at its
    minimum, as a gap's is: both reversals are found, at the times of the slips
    integrated here with scipy (max_step 1e-3), where they were missed before (and the
    orbit's continuation reported its mode sequence changing at F0 = 8.1188 going down,
    8.1202 going up)."""
    from scipy.integrate import solve_ivp

    F0, f, c = 8.118, 0.01, 0.05
    ds = phasemap.simulate("duffing", 2 * math.pi, k=0.0, beta=1.0, c=c, f=f, Omega=1.0,
                           F0=F0, x=2.40463071, xdot=-0.322798, rtol=1e-12)
    assert ds.event_kind.values.tolist() == [ev.START] + [ev.REVERSAL] * 4 + [ev.HORIZON]
    t, y = 0.0, [2.40463071, -0.322798]
    for k, s in enumerate((-1.0, 1.0)):      # slipping back, then forward
        def stop(tt, yy):
            return yy[1]
        stop.terminal, stop.direction = True, -s
        sol = solve_ivp(lambda tt, yy, s=s: [yy[1], F0 * math.cos(tt) - yy[0] ** 3
                                             - c * yy[1] - f * s],
                        (t, t + 2.0), y, rtol=1e-12, atol=1e-14, max_step=1e-3,
                        events=stop)
        t, y = float(sol.t_events[0][0]), sol.y_events[0][0]
        assert abs(float(ds.event_t[1 + k]) - t) <= 1e-8
        assert s * (F0 * math.cos(t) - y[0] ** 3) < -f      # a reversal, not a stop
    assert float(ds.event_t[2]) - float(ds.event_t[1]) < 0.05


def test_a_slip_phase_singularity_is_b_over_its_scale():
    """``Motion.singularity`` of the rod's slip is B = W_nn - s f W_nt over |n| |n - s f t|
    in the inverse mass metric (W of the rod by hand, m = l = 1), so its zero is B's;
    a phase without a slip is never singular (1)."""
    from phasemap.systems.painleve_rod import SYSTEM as ROD

    mech = mechanics(ROD)
    rng = np.random.default_rng(7)
    for _ in range(20):
        f = rng.uniform(0.0, 3.0)
        p = np.array([{"f": f, "l": 1.0, "g": G, "m": 1.0}[k] for k in mech.parameters])
        motion = hybrid.Motion(mech, p, hybrid.Options(t_end=1.0))
        th = rng.uniform(0.05, math.pi - 0.05)
        q, u = np.array([th, 0.0, 0.0]), np.array([rng.normal(), rng.normal(), 0.0])
        s, c = math.sin(th), math.cos(th)
        W_nn, W_nt, W_tt = 1.0 + 3.0 * c * c, -3.0 * s * c, 1.0 + 3.0 * s * s
        for mode, sg in ((hybrid.SLIP_POS, 1.0), (hybrid.SLIP_NEG, -1.0)):
            B = W_nn - sg * f * W_nt
            scale = math.sqrt(W_nn * (W_nn - 2.0 * sg * f * W_nt + f * f * W_tt))
            assert abs(motion.singularity(q, u, (mode,)) - B / scale) <= 1e-12
        assert motion.singularity(q, u, (hybrid.STICK,)) == 1.0
        assert motion.singularity(q, u, (hybrid.OPEN,)) == 1.0


def test_a_slip_that_lifts_off_before_its_singular_point_does_not_jam():
    """At f = 1.5 the approach to the singular point runs where N changes sign first:
    the rod lifts off (at the time of N = 0 of the hand-integrated slip), no jam."""
    ds = phasemap.simulate("painleve_rod", 0.05, rtol=1e-10, theta=0.8, omega=3.3,
                           xdot=-3.0, f=1.5)
    assert ev.JAM not in ds.event_kind.values.tolist()
    assert ds.event_kind.values.tolist()[:2] == [ev.START, ev.LIFTOFF]
    t_lift = _rod_slip_to_its_singular_point(0.8, 3.3, -3.0, 1.5, until="N")[0]
    assert abs(float(ds.event_t[1]) - t_lift) <= 1e-9


@pytest.mark.parametrize("omega", [-0.3, -1.0, -4.0])
def test_a_jam_of_two_slipping_contacts_brings_the_rod_on_a_step_to_rest(omega):
    """The rod on a step (f = 2, edge at a = h / (l sin theta) = 1.25 along the rod) with
    both contacts slipping, at a zero of the kept-kept coefficient D of its hand
    derivation (docs/systems/rod_on_step.md, (S3)): the phase's singularity vanishes
    there, and the jam's impulse (the reaction matrix's null vector, both normal
    impulses pressing) stops both slips at once, since with both kept the rod has one
    freedom and both slip velocities are h omega / sin^2 theta times 1 and cos theta:
    the rod is at rest after it, and all its kinetic energy is gone."""
    from scipy.optimize import brentq

    from phasemap.systems.rod_on_step import SYSTEM as STEP

    f, l, a, s = 2.0, 1.0, 1.25, -1.0

    def D(th):
        sn, cs = math.sin(th), math.cos(th)
        return (3 * a * a - (6 * a - 4) * sn * sn - f * f * (3 * a - 4) * sn * sn
                + 2 * s * f * (3 * a - 2) * sn * cs - s * f * (3 * a - 4) * sn * cs)

    th0 = brentq(D, 0.6, 0.8)
    h = a * l * math.sin(th0)
    mech = mechanics(STEP)
    p = np.array([{"f": f, "l": l, "h": h, "g": G, "m": 1.0}[k] for k in mech.parameters])
    motion = hybrid.Motion(mech, p, hybrid.Options(t_end=0.05))
    slip = (hybrid.SLIP_NEG, hybrid.SLIP_NEG)

    def state(th):
        return (np.array([th, -h / math.tan(th), 0.0]),
                np.array([omega, h * omega / math.sin(th) ** 2, 0.0]))

    assert abs(motion.singularity(*state(th0), slip)) <= 1e-12
    # 1e-8 rad to one side of it, the slip presses both contacts (N without bound): the
    # side a slip that is the motion comes from; on the other side both would pull
    sides = [th0 + e for e in (1e-8, -1e-8)
             if np.all(motion.solve(*state(th0 + e), slip)[1] > 0.0)]
    assert len(sides) == 1
    q, u = state(sides[0])
    assert np.all(mech.pieces(q, u, p, 0.0)[3][:, 1] @ u < 0.0)
    assert 0.0 < abs(motion.singularity(q, u, slip)) <= 1e-9
    assert abs(motion.singularity(q, u, (hybrid.SLIP_NEG, hybrid.STICK))) > 1e-3
    rec = hybrid.run_full(mech, p, q, u, t_end=0.05, rtol=1e-12, atol=1e-12,
                          max_step=math.inf, max_steps=10_000, max_events=100)
    assert rec.ev_kind == [ev.JAM, ev.REST]
    P_n, P_t, dKE = rec.ev_impulse[0]
    assert P_n > 0.0 and abs(P_t - f * P_n) <= 1e-12 * P_n    # slipping with s = -1
    M = mech.pieces(q, u, p, 0.0)[0]
    assert abs(dKE + 0.5 * u @ M @ u) <= 1e-9 * (0.5 * u @ M @ u)
    assert np.abs(rec.y[0][3:]).max() <= 1e-12 * abs(omega)
    assert rec.modes[0] == (hybrid.STICK, hybrid.STICK)


def test_the_wheel_flies_off_and_lands_perfectly_rough():
    """The wheel (r = 1, l = 0.5, rho = 0.5, no rolling friction) at phi = 2.5591 spinning
    at omega = 8.2805 must leave the floor at once (the reduced model ends there with
    ``contact_lost``).  It flies: its centre of mass on a parabola, its spin constant,
    until the disc's lowest point reaches the floor, at the time a root of that gap,
    found here by hand.  It lands perfectly rough (it rolls without slip): every impulse
    acts at the contact point K, so the angular momentum about K is kept, and it rolls
    after it: omega+ = H_K / (I + m |KC|^2), x_A' = r omega+, y_A' = 0."""
    from scipy.optimize import brentq

    r, l, rho, m = 1.0, 0.5, 0.5, 1.0
    phi0, om0 = 2.5591, 8.2805
    ds = phasemap.simulate("wheel", 3.0, phi=phi0, omega=om0, delta=0.0, rtol=1e-12)
    kinds = ds.event_kind.values.tolist()
    assert kinds[:2] == [ev.LIFTOFF, ev.IMPACT] and ds.attrs["phasemap_reduced_end"] == \
        "contact_lost"
    C0 = np.array([r * phi0 - l * math.sin(phi0), r - l * math.cos(phi0)])
    v0 = np.array([r * om0 - l * math.cos(phi0) * om0, l * math.sin(phi0) * om0])

    def gap(t):     # the disc's centre height less r: y_C + l cos phi - r
        return C0[1] + v0[1] * t - 0.5 * G * t * t + l * math.cos(phi0 + om0 * t) - r

    ts = np.linspace(1e-6, 2.0, 20001)
    k = int(np.flatnonzero(np.array([gap(t) for t in ts]) < 0.0)[0])
    t_land = brentq(gap, ts[k - 1], ts[k], xtol=1e-15)
    assert abs(float(ds.event_t[1]) - t_land) <= 1e-9
    phi = phi0 + om0 * t_land
    C = C0 + v0 * t_land + np.array([0.0, -0.5 * G * t_land ** 2])
    vC = v0 + np.array([0.0, -G * t_land])
    d = C - np.array([C[0] + l * math.sin(phi), 0.0])            # K to C
    H_K = m * rho ** 2 * -om0 + m * (d[0] * vC[1] - d[1] * vC[0])  # (the disc turns by -phi)
    om1 = -H_K / (m * rho ** 2 + m * d @ d)
    after = np.flatnonzero(ds.t.values == float(ds.event_t[1]))[-1]
    assert float(ds.omega[after]) == pytest.approx(om1, abs=1e-9)
    assert float(ds.xa_dot[after]) == pytest.approx(r * om1, abs=1e-9)
    assert abs(float(ds.ya_dot[after])) <= 1e-9
    KE = lambda w, v: 0.5 * m * v @ v + 0.5 * m * rho ** 2 * w * w
    vC1 = om1 * np.array([d[1], -d[0]]) * -1.0                  # rolling about K
    assert float(ds.event_dKE[1]) == pytest.approx(KE(om1, vC1) - KE(om0, vC), abs=1e-9)
    assert float(ds.event_dKE[1]) < 0.0


def test_random_rough_landings_of_the_wheel_never_gain_energy_and_end_complementary():
    """The wheel dropped in flight at random (spin, velocity, rolling friction, centre of
    mass) lands perfectly rough: every impact loses energy, and after it the contact is
    closed and rolls (v_n = 0, no slip) where it took a normal impulse, or leaves with its
    slip stopped (v_n >= 0, v_t = 0) where the tangential impulse alone turned it away."""
    from phasemap.systems.seeds.wheel import SYSTEM as WHEEL

    mech = mechanics(WHEEL)
    rng = np.random.default_rng(11)
    seen = 0
    for _ in range(12):
        values = {"delta": rng.uniform(0.0, 0.3), "r": 1.0, "l": rng.uniform(0.0, 0.8),
                  "rho": rng.uniform(0.3, 0.8), "g": G, "m": 1.0}
        p = np.array([values[k] for k in mech.parameters])
        q = np.array([rng.uniform(-3, 3), 0.0, 1.0 + rng.uniform(0.01, 0.3)])
        u = np.array([rng.normal(0, 5), rng.normal(0, 2), rng.normal(0, 1)])
        rec = hybrid.run_full(mech, p, q, u, t_end=0.6, rtol=1e-10, atol=1e-12,
                              max_step=math.inf, max_steps=20_000, max_events=50)
        for P_n, dKE, KE0, y0, y, modes in _impacts(rec, mech, p):
            seen += 1
            assert dKE <= 1e-12 * KE0 and P_n >= 0.0
            J = mech.pieces(y[:3], y[3:], p)[3][0]
            v_n, v_t = J[0] @ y[3:], J[2] @ y[3:]
            scale = 1.0 + np.abs(y0[3:]).max()
            assert abs(v_t) <= 1e-9 * scale
            assert v_n >= -1e-9 * scale
            if P_n > 0.0:
                assert abs(v_n) <= 1e-9 * scale
    assert seen >= 8


def test_a_two_sided_contact_whose_reaction_changes_sign_goes_on_with_its_friction_flipped():
    """The elliptic pendulum's slider on its two-sided guide, declared and moved in full
    coordinates: where the guide's reaction changes sign, the friction's sign flips and
    the motion goes on (not a Painleve inconsistency, not a flicker), event for event
    as the hand-written reduced model moves it."""
    from phasemap.declare import loader

    mech = mechanics(loader.system("phasemap.systems.seeds.elliptic_pendulum"))
    p = np.array([{**mech.defaults, "f": 0.3}[k] for k in mech.parameters])
    rec = hybrid.run_full(mech, p, np.zeros(3), np.array([7.0, 1.0, 0.0]), t_end=2.0,
                          rtol=1e-10, atol=1e-10, max_step=math.inf, max_steps=20_000,
                          max_events=100)
    hand = phasemap.simulate("elliptic_pendulum", 2.0, rtol=1e-10, phi=0.0, omega=7.0,
                             xdot=1.0, f=0.3)
    assert rec.ev_kind == hand.event_kind.values.tolist()
    assert ev.SWITCH in rec.ev_kind and rec.fate == ev.HORIZON
    assert np.allclose(rec.ev_t, hand.event_t.values, rtol=0, atol=1e-7)


def test_the_strip_draws_a_rolling_disc_by_its_rim(tmp_path):
    """The hopping wheel's strip draws each outline as the disc's rim (its radius, from
    the Dataset's ``phasemap_radius_floor``) with a spoke to the centre of mass, and its
    rolling moment is not drawn as a force along the floor."""
    import matplotlib.pyplot as plt

    ds = phasemap.simulate("wheel", 0.65, phi=2.5591, omega=8.2805, delta=0.0, rtol=1e-12)
    assert float(ds.attrs["phasemap_radius_floor"]) == 1.0
    assert ds.F_floor.attrs["units"] == "N m"
    times = [0.0, 0.3, 0.6]
    fig = ds.phasemap.strip(times=times, forces=False)
    rims = [ln.get_xydata() for ln in fig.axes[0].lines if len(ln.get_xydata()) == 97]
    assert len(rims) == len(times)
    for rim, t in zip(rims, times):
        centre = rim[:-1].mean(axis=0)
        assert np.allclose(np.hypot(*(rim - centre).T), 1.0, atol=1e-9)
        # the rim's centre is the disc's: x_A, y_A of the motion at that time
        i = int(np.argmin(np.abs(ds.t.values - t)))
        if ds.t.values[i] == t:
            assert np.allclose(centre, [float(ds.xa[i]), float(ds.ya[i])], atol=1e-9)
    fig.savefig(tmp_path / "wheel.png")
    plt.close(fig)
