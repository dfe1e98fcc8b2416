"""Declared systems on the edges of their domains (issue 23): the coordinates at their
bounds, velocities zero and not, parameters at theirs, against the independent
full-coordinate enumeration of tests/oracles.py.  The built-in ladder and Painleve
rod, and systems phasemap never saw, declared with the public API (tests/unseen.py)."""

from __future__ import annotations

import itertools
import math
import numpy as np

import pytest

import phasemap

import oracles
import unseen

PI = math.pi
#: velocities on every edge: at rest, and moving either way
W = (0.0, 1.5, -1.5)


def _grid(**axes):
    return [dict(zip(axes, v)) for v in itertools.product(*axes.values())]


def _leaning_states():
    for beta in (0.0, 0.2, 0.5):
        for phi in (beta, PI / 2, PI / 2 - 1e-6, 0.5 * (beta + PI / 2)):
            for omega in W:
                for f1, f2 in ((0.0, 0.0), (0.4, 0.4), (1.2, 1.2), (0.3, 2.0)):
                    yield dict(phi=phi, omega=omega, f1=f1, f2=f2, beta=beta)


#: name -> (the model, or a declaration's builder; the oracle; the edge states)
CASES = {
    "ladder": ("ladder",
               lambda v: oracles.ladder(v["phi"], v["omega"], v["f"], 1.0, 9.81, 1.0),
               _grid(phi=(0.0, PI / 2, 0.7), omega=W + (-3.12,),
                     f=(0.0, 0.3, 1.0, 1.2, 1.5, 3.0))),
    "painleve_rod": ("painleve_rod",
                     lambda v: oracles.painleve_rod(v["theta"], v["omega"], v["xdot"], v["f"],
                                                    1.0, 9.81, 1.0),
                     _grid(theta=(0.0, PI, 1.0), omega=W, xdot=W, f=(0.0, 0.5, 2.0))),
    "gyration_rod": (unseen.gyration_rod,
                     lambda v: oracles.painleve_rod(v["theta"], v["omega"], v["xdot"], v["f"],
                                                    1.0, 9.81, 1.0, k=v["k"]),
                     _grid(theta=(0.0, PI, 1.0), omega=W, xdot=W, f=(0.0, 0.5, 2.0),
                           k=(0.2, 0.6, 1.5))),
    "corner_block": (unseen.corner_block,
                     lambda v: oracles.corner_block(v["psi"], v["omega"], v["sdot"], v["f"],
                                                    0.5, 1.0, v["alpha"], 9.81, 1.0),
                     _grid(psi=(0.0, PI / 2, 0.5), omega=W, sdot=W, f=(0.0, 0.5, 2.0),
                           alpha=(0.0, 0.3, 1.2))),
    "leaning_ladder": (unseen.leaning_ladder,
                       lambda v: oracles.leaning_ladder(v["phi"], v["omega"], v["f1"], v["f2"],
                                                        v["beta"], 1.0, 9.81, 1.0),
                       list(_leaning_states())),
    "ledge_rod": (unseen.ledge_rod,
                  lambda v: oracles.ledge_rod(v["xdot"], v["f"], 1.0, v["h"], 9.81, 1.0),
                  _grid(xdot=W, f=(0.0, 0.3, 2.0), h=(0.5, 1.0, 1.9))),
    "incline": (unseen.incline_point,
                lambda v: oracles.incline_point(v["xdot"], v["f"], v["alpha"], 9.81, 1.0),
                _grid(xdot=W, f=(0.0, 0.3, 2.0), alpha=(0.0, 0.4, 1.5))),
}


def _model(x):
    return phasemap.get_model(x) if isinstance(x, str) else x().model


@pytest.mark.parametrize("name", sorted(CASES))
def test_every_edge_state_agrees_with_the_enumeration(name):
    """n_solutions on every edge state equals the enumeration's (a continuum counted as
    one answer, 3), and the stagnation flag too."""
    model, oracle, states = CASES[name]
    m = _model(model)
    wrong = []
    for v in states:
        got, want = phasemap.classify(m, **v), oracle(v)
        if (int(got.n_solutions), bool(got.stagnation)) != (want.n_solutions, want.stagnation):
            wrong.append((v, int(got.n_solutions), want.n_solutions,
                          [md.modes for md in want.modes]))
    assert not wrong, f"{len(wrong)} of {len(states)} edge states differ: {wrong[:3]}"


@pytest.mark.parametrize("phi, omega, f, n", [
    (PI / 2, 0.0, 0.3, 3),   # lying flat: the foot sticks, the top slides, pinched by any
    (PI / 2, 0.0, 0.0, 1),   # compression t (a continuum); frictionless, t = 0 only
    (PI / 2, 0.0, 1.2, 3),   # ... and the stick too (f^2 >= 1)
    (0.0, -3.12, 1.5, 1),    # upright, moving: both ends slide
    (0.0, 0.0, 0.0, 1),      # upright at rest, frictionless: stays (reactions indeterminate)
])
def test_the_ladder_lying_flat_and_standing_upright(phi, omega, f, n):
    """The issue's table, decided from the mechanics (tests/oracles.py): lying flat the
    foot's slip velocity 2 l cos(phi) omega vanishes whatever omega, so the foot can
    stick while the top slides; its compression between floor and wall is statically
    indeterminate and the wall's friction, f N_wall, moves the accelerations with it."""
    got = phasemap.classify("ladder", phi=phi, omega=omega, f=f)
    assert int(got.n_solutions) == n == oracles.ladder(phi, omega, f, 1.0, 9.81, 1.0).n_solutions
    names = {b.name for b in got.branches}
    if phi == PI / 2 and omega == 0.0:
        assert any(nm.startswith("floor_stick_wall_slip") for nm in names), names


def test_contacts_that_fix_an_angle_take_the_configuration_of_the_defaults():
    """A block lying flat on an incline on two corners: closing the contacts fixes its
    angle twice (theta = alpha, or upside down); the declared default picks the first, and
    it stays at rest exactly where f >= tan(alpha).  A rod from floor to ledge whose
    default angle is as near both closures (pi/2) is refused with the way to choose."""
    m = unseen.flat_block().model
    for f in (0.25, 0.35):
        got = phasemap.classify(m, sdot=0.0, f=f, alpha=0.3)
        assert got.stagnation == (f >= math.tan(0.3))
        assert int(got.n_solutions) == 1
    with pytest.raises(ValueError, match="ledge_rod: contacts: closing the contacts fixes "
                       "theta, y in 2 ways at the parameters' defaults .*: give the "
                       "coordinates defaults nearest"):
        unseen.ledge_rod(theta=PI / 2).model


def test_a_system_whose_only_state_is_a_velocity_maps_and_simulates():
    """A point block on a rough incline: its equations depend on xdot only (x is
    integrated, not an input).  Its layers, a map with a fate layer and a motion: it
    slides up, stops where the incline is rough enough (f >= tan alpha), and rests
    (the map used to end in KeyError: 'x')."""
    import numpy as np

    m = unseen.incline_point().model
    layers = phasemap.layers_for(m)
    assert {"n_solutions", "fate", "x_rest"} <= set(layers)
    assert layers["x_rest"].units == "m"
    ds = phasemap.Scene(m, axes={"xdot": np.array([0.0, 1.0]), "f": np.array([0.2, 0.6])},
                        fixed={"alpha": 0.4}, layers=["n_solutions", "stagnation", "fate"],
                        options={"t_end": 5.0}).compute()
    rough = ds.f.values >= math.tan(0.4)
    assert (ds.stagnation.sel(xdot=0.0).values.astype(bool) == rough).all()
    assert (ds.n_solutions.values == 1).all()
    run = phasemap.simulate(m, t_end=5.0, xdot=1.0, f=0.6, alpha=0.4)
    assert run.attrs["end_reason"] == "rest"


def test_a_declared_system_without_default_axes_maps_its_classes():
    """The README's own rod (docs/examples/own_system.py, no default_axes): the friction
    axis reaches f = 2, past the paradox of the rod sliding back (f > 4/3), so that
    `phasemap atlas my_rod.py --set xdot=-1` draws it; it used to map f in [0, 1], where
    every cell is unique."""
    import numpy as np
    from pathlib import Path

    m = phasemap.get_model(Path(__file__).resolve().parents[1] / "docs" / "examples"
                           / "own_system.py")
    axes = dict(m.default_axes)
    assert axes == {"theta": (0.0, PI, 512), "f": (0.0, 2.0, 512)}
    ds = phasemap.Scene(m, axes={k: np.linspace(lo, hi, 48) for k, (lo, hi, _) in axes.items()},
                        fixed={"xdot": -1.0, "omega": 0.0}, layers=["n_solutions"]).compute()
    assert set(np.unique(ds.n_solutions.values)) == {0, 1}


@pytest.mark.parametrize("name, values", [
    ("painleve_rod", dict(theta=1.0, omega=0.0, xdot=-1.0, f=0.3, l=1.0, g=9.81, m=0.0)),
    ("elliptic_pendulum", dict(phi=0.7, omega=0.5, xdot=1.0, f=0.3, l=0.0, g=9.81, m=1.0)),
])
def test_a_non_finite_acceleration_or_reaction_is_never_a_solution(name, values):
    """Past the input checks (a zero mass, a zero length: the kernels' own rule, declared
    and hand-written alike), a row whose accelerations or reactions are not finite is
    not counted: no solution here, where a NaN acceleration used to count as one."""
    import numpy as np

    from phasemap.core import numerics as nx

    m = phasemap.get_model(name)
    out = np.full((len(m.branches), m.n_fields), np.nan)
    m.point(m.input_vector(values), out)
    counted = np.isin(out[:, nx.STATUS], (nx.ADMISSIBLE, nx.SEPARATION, nx.CONTINUUM))
    assert np.isfinite(out[counted, nx.FIRST_ACC:]).all()
    assert nx.summarize(out, m.stick_branch)[0] == 0


# ------------------------------------------------ motions that reach a closed bound -----
def test_edge_rows_say_which_closed_bound_they_exist_on():
    """The rows of an edge that is a declared bound carry it (Candidate.bound), and the
    integrator's constant maps them to the integrated state's index and side: what its
    'on the bound, moving out' rule reads.  The Painleve rod's bounds are no edges."""
    from phasemap.core.compile import contract_constants

    bounds = {name: {b.bound for b in phasemap.get_model(name).candidates}
              for name in ("ladder", "rod_on_step", "painleve_rod")}
    assert bounds == {"ladder": {None, ("phi", 0), ("phi", 1)},
                      "rod_on_step": {None, ("theta", 1)}, "painleve_rod": {None}}
    m = phasemap.get_model("ladder")
    rows = contract_constants(m)["BOUND_ROW"]
    assert [int(k) for k in rows] == [-1 if b.bound is None else b.bound[1]
                                      for b in m.candidates]


#: The rod on a step above its centre of mass (h > l), tipping over the vertical.
TIPPING = dict(theta=1.5, omega=1.5, f=0.6, h=1.6)


def test_the_rod_on_a_step_tipping_over_the_vertical_leaves_the_domain():
    """A second system whose edge is a closed bound: the rod's slip over the step's
    edge, h omega cos(theta) / sin^2(theta), vanishes at theta = pi/2, where the edge
    rows apply (within the tie tolerance) and find the edge sliding back.  Reaching
    the vertical with omega > 0 the rod leaves the domain there, with no event in the
    tie band before it; simulate, phase_curve (another integrator) and the fate map
    agree on the ending, and on omega there."""
    ds = phasemap.simulate("rod_on_step", t_end=3.0, **TIPPING)
    kinds = [phasemap.Event(int(k)) for k in ds.event_kind.values]
    assert kinds == [phasemap.Event.START, phasemap.Event.LEFT_DOMAIN]
    assert float(ds.event_theta[-1]) == PI / 2 and float(ds.event_omega[-1]) > 0.0
    assert ds.attrs["end_message"].endswith("theta reached 1.5708 rad")
    curve = phasemap.phase_curve("rod_on_step", **TIPPING)
    assert curve.attrs["end_reason"] == "left_domain"
    assert curve.attrs["end_message"] == ds.attrs["end_message"]
    assert float(curve.stage_end_phi[-1]) == PI / 2
    assert float(curve.stage_end_omega[-1]) == pytest.approx(float(ds.event_omega[-1]),
                                                             rel=1e-6)
    fates = phasemap.Scene("rod_on_step", axes={"theta": [TIPPING["theta"]]},
                           fixed={k: v for k, v in TIPPING.items() if k != "theta"},
                           layers=["fate"]).compute()
    assert int(fates.fate[0]) == phasemap.Event.LEFT_DOMAIN


@pytest.mark.parametrize("model, start, end", [
    ("ladder", dict(phi=PI / 2, omega=1.0, f=1.0), "left_domain"),   # lying flat, falling on
    ("ladder", dict(phi=PI / 2, omega=-1.0, f=1.0), "contact_lost"),  # ... rising: classified
    ("ladder", dict(phi=PI / 2, omega=0.0, f=0.3), "continuum"),      # ... at rest: class 3
    ("rod_on_step", dict(theta=PI / 2, omega=1.0, f=0.6, h=1.6), "left_domain"),
])
def test_a_motion_started_on_a_bound_leaves_only_moving_out(model, start, end):
    """Started on a closed bound, a motion moving out leaves the domain at once, and
    says which edge; moving in, or at rest, the state's classification decides.
    simulate and phase_curve agree."""
    ds = phasemap.simulate(model, t_end=1.0, through_contacts=False, **start)
    curve = phasemap.phase_curve(model, **start)
    assert ds.attrs["end_reason"] == curve.attrs["end_reason"] == end
    assert ds.attrs["end_message"] == curve.attrs["end_message"]
    if end == "left_domain":
        assert float(ds.event_t[-1]) == 0.0 and "reached 1.5708 rad" in ds.attrs["end_message"]


def test_a_separated_corner_flies_freely():
    """Issue 37: the printer once dropped the parentheses of 1/(A + B), and the block on
    its corner (tests/unseen.py) reported the wrong accelerations for its separated mode.
    Flying free, the body falls with g and turns uniformly, so the corner P = C - d,
    d = R(alpha + psi) (a, b), accelerates as (0, -g) + omega^2 d: along the incline
    s'' = -g sin(alpha) + omega^2 d.t, with psi'' = 0 (closed form, checked at random
    states, whatever the mode's admissibility)."""
    m = _model(unseen.corner_block)
    rng = np.random.default_rng(37)
    a, b, g = 0.5, 1.0, 9.81
    for _ in range(200):
        psi, alpha = rng.uniform(0.0, PI / 2), rng.uniform(0.0, 1.2)
        omega, sdot, f = rng.uniform(-4, 4), rng.uniform(-3, 3), rng.uniform(0, 2)
        c = phasemap.classify(m, psi=psi, omega=omega, sdot=sdot, f=f, alpha=alpha)
        flying = [br for br in c.candidates if br.name.startswith("corner_separated")]
        assert flying, [br.name for br in c.candidates]
        th = alpha + psi
        d = (a * math.cos(th) - b * math.sin(th), a * math.sin(th) + b * math.cos(th))
        s_dd = -g * math.sin(alpha) + omega ** 2 * (d[0] * math.cos(alpha)
                                                     + d[1] * math.sin(alpha))
        for br in flying:
            assert br.accelerations["psi_ddot"] == pytest.approx(0.0, abs=1e-12)
            assert br.accelerations["s_ddot"] == pytest.approx(s_dd, rel=1e-10, abs=1e-10), \
                (psi, omega, sdot, f, alpha, br.name)
