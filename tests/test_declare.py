"""Declared systems (phasemap.declare): derived equations agree with the hand derivations
and with an independent numpy solve; malformed declarations get clear errors."""

from __future__ import annotations

import dataclasses
import doctest
import importlib
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import phasemap
from phasemap.core import numerics as nx
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

import oracles

ROOT = Path(__file__).resolve().parents[1]
SEEDS = ROOT / "phasemap" / "systems" / "seeds"


def _rows(m, values, checked=True):
    v = m.input_vector(m.complete(values) if checked else values)
    out = np.full((len(m.branches), m.n_fields), np.nan)
    m.point(v, out)
    return out


def _sample(m, rng, zero_velocity):
    values = {}
    for var in m.state + m.params:
        lo = var.lower if math.isfinite(var.lower) else -3.0
        hi = var.upper if math.isfinite(var.upper) else 3.0
        if var.name in ("l", "r", "rho", "m", "g"):
            lo, hi = 0.3, 2.0
        elif var.name == "f":
            lo, hi = 0.0, 3.0
        elif var.name == "delta":
            lo, hi = 0.0, 1.5
        values[var.name] = rng.uniform(lo, hi)
    if "r" in values:
        values["l"] = min(values["l"], values["r"])
    if zero_velocity:
        values[m.velocity] = 0.0
    return values


#: the hand derivations: the pendulums run; the ladder's and the wheel's are test references
HAND_MODULES = {"ladder": "references.ladder", "wheel": "references.wheel",
                "elliptic_pendulum": "phasemap.systems.elliptic_pendulum",
                "hinge_pendulum": "phasemap.systems.hinge_pendulum"}
#: declared accelerations (coordinates with a rate, in declared order) -> hand columns
ACC = {"ladder": ["phi_ddot"], "wheel": ["phi_ddot"],
       "elliptic_pendulum": ["phi_ddot", "x_ddot"], "hinge_pendulum": ["phi_ddot"]}


@pytest.mark.slow
@pytest.mark.parametrize("seed", sorted(ACC))
def test_declared_seed_agrees_with_the_hand_derivation(seed):
    """10,000 random states (a third at zero velocity): wherever the hand module keeps
    its contacts, the declared system's kept solutions are the hand module's, with the
    same accelerations and stagnation; it differs only by admissible separations."""
    hand = importlib.import_module(HAND_MODULES[seed]).MODEL
    decl = phasemap.get_model(SEEDS / f"{seed}.py")
    if seed in ("ladder", "wheel"):
        assert decl is not hand and phasemap.get_model(seed).declaration is not None
    hand_cols = [nx.FIRST_ACC + [a.name for a in hand.accelerations].index(n) for n in ACC[seed]]
    decl_cols = [nx.FIRST_ACC + [a.name for a in decl.accelerations].index(n) for n in ACC[seed]]
    rng = np.random.default_rng(12)
    compared = separations = 0
    for i in range(10_000):
        values = _sample(hand, rng, i % 3 == 0)
        h, d = _rows(hand, values, False), _rows(decl, values, False)  # in the domain
        n_h, stag_h, lost_h, sing_h = nx.summarize(h, hand.stick_branch)
        n_d, stag_d, lost_d, sing_d = nx.summarize(d, decl.stick_branch)
        if lost_h or sing_h or sing_d:
            continue
        compared += 1
        kept_h = sorted(tuple(h[b, hand_cols]) for b in range(len(h)) if h[b, 0] == nx.ADMISSIBLE)
        kept_d = sorted(tuple(d[b, decl_cols]) for b in range(len(d)) if d[b, 0] == nx.ADMISSIBLE)
        n_sep = int(np.sum(d[:, 0] == nx.SEPARATION))
        separations += n_sep
        assert len(kept_h) == len(kept_d), (values, kept_h, kept_d)
        np.testing.assert_allclose(kept_d, kept_h, rtol=1e-7, atol=1e-9, err_msg=str(values))
        assert stag_d == stag_h, values
        assert n_d == min(n_h + n_sep, nx.N_THREE_OR_MORE) or n_h == nx.N_CONTINUUM, values
    assert compared > 3000  # the ladder leaves its contacts on two thirds of these states


def _rod_values(rng, zero):
    return dict(theta=rng.uniform(0.02, math.pi - 0.02), omega=rng.uniform(-4, 4),
                xdot=0.0 if zero else rng.uniform(-3, 3), f=rng.uniform(0, 3),
                l=rng.uniform(0.3, 2), g=rng.uniform(0.5, 12), m=rng.uniform(0.3, 3))


def _step_values(rng, zero):
    l, theta = rng.uniform(0.3, 2), rng.uniform(0.05, math.pi / 2 - 0.02)
    return dict(theta=theta, omega=0.0 if zero else rng.uniform(-4, 4), f=rng.uniform(0, 2),
                l=l, h=rng.uniform(0.05, 1.0) * 2 * l * math.sin(theta),
                g=rng.uniform(0.5, 12), m=rng.uniform(0.3, 3))


@pytest.mark.slow
@pytest.mark.parametrize("name, sample", [("painleve_rod", _rod_values),
                                          ("rod_on_step", _step_values)])
def test_declared_rods_agree_with_an_independent_full_coordinate_solve(name, sample):
    """1000 random states, a third at zero slip velocity: n_solutions, stagnation and
    the accelerations of every solution (separations included) agree with the numpy
    oracle, which solves every mode combination on the full unknown vector by SVD."""
    m = phasemap.MODELS[name]
    rng = np.random.default_rng(3)
    checked = 0
    for i in range(1000):
        values = sample(rng, i % 3 == 0)
        ref = getattr(oracles, name)(**values)
        if ref.margin < 1e-7:
            continue
        checked += 1
        out = _rows(m, values)
        n, stag, lost, sing = nx.summarize(out, m.stick_branch)
        assert (n, stag) == (ref.n_solutions, ref.stagnation), values
        sols = out[(out[:, 0] == nx.ADMISSIBLE) | (out[:, 0] == nx.SEPARATION)]
        got = sorted(tuple(r[nx.FIRST_ACC:nx.FIRST_ACC + 1]) for r in sols)  # theta''
        want = sorted((md.qdd[2],) for md in ref.modes)
        np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-8, err_msg=str(values))
        assert lost == any(not all(md.keeps) for md in ref.modes), values
    assert checked > 900


def test_painleve_rod_paradox_threshold_is_four_thirds_at_arctan_two():
    """From an atlas of the rod sliding with A pushed towards the rod (xdot < 0, omega = 0):
    no solution appears first just above f = 4/3, around theta = arctan 2 (Genot and
    Brogliato 1999; tests/oracles.painleve_rod_threshold)."""
    f_min, theta_star = oracles.painleve_rod_threshold()
    assert f_min == pytest.approx(4 / 3) and theta_star == pytest.approx(math.atan(2.0))
    theta = np.linspace(0.05, math.pi / 2 - 0.05, 301)
    ds = phasemap.Scene("painleve_rod", axes={"theta": theta,
                                              "f": np.linspace(1.2, 1.5, 301)},
                        fixed={"xdot": -1.0, "omega": 0.0}, layers=["n_solutions"]).compute()
    n = ds.n_solutions.transpose("f", "theta").values
    f = ds.f.values
    none_f = f[(n == 0).any(axis=1)]
    assert none_f.min() > 4 / 3 and none_f.min() < 4 / 3 + 0.002
    first = np.flatnonzero(n[np.searchsorted(f, none_f.min())] == 0)
    assert abs(theta[first].mean() - math.atan(2.0)) < 0.02
    # sliding the other way the coefficient stays positive: never a paradox at rest omega
    ds = phasemap.Scene("painleve_rod", axes={"theta": theta, "f": np.linspace(0, 3, 61)},
                        fixed={"xdot": 1.0, "omega": 0.0}, layers=["n_solutions"]).compute()
    assert (ds.n_solutions.values == 1).all()


def test_separation_is_a_solution_not_a_paradox():
    """A fast-spinning rod whose end would have to pull leaves the floor: one solution,
    the separation, flagged contact_lost, and classify says so."""
    c = phasemap.classify("painleve_rod", theta=1.2, omega=6.0, xdot=1.0, f=0.3)
    assert c.n_solutions == phasemap.Solvability.UNIQUE and c.contact_lost
    (b,) = c.branches
    assert b.status == phasemap.BranchStatus.SEPARATION and b.name == "A_separated"
    assert "leaves" in b.status.message


def _good(**change):
    f = Parameter("f", "1", "friction", 0.5, 0.0)
    l = Parameter("l", "m", "half length", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravity", 9.81, 0.0)
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    th = Coordinate("theta", "rad", "angle", 1.0, 0.0, 3.0, rate=Rate("omega", "rad s-1", "rate"))
    x = Coordinate("x", "m", "end", rate=Rate("xdot", "m s-1", "end velocity"))
    y = Coordinate("y", "m", "height")
    parts = dict(
        coordinates=(th, x, y), parameters=(f, l, g, m),
        bodies=(Body(m, (x + l * sp.cos(th), y + l * sp.sin(th)), inertia=m * l**2 / 3,
                     angle=th),),
        potential=m * g * (y + l * sp.sin(th)),
        contacts=(PointContact("A", (x, y), friction=f),))
    env = dict(f=f, l=l, g=g, m=m, x=x, y=y, th=th)
    parts.update({k: (v(env) if callable(v) else v) for k, v in change.items()})
    return System("bad_rod", "a rod", "nobody", **parts)


@pytest.mark.parametrize("change, words", [
    (dict(bodies=lambda v: (Body(0, (v["x"], v["y"])),)), "bad_rod: body 0 mass: is zero"),
    (dict(contacts=lambda v: (PointContact("A", (v["x"], v["y"])),)),
     "bad_rod: contact 'A': has no friction law"),
    (dict(potential=sp.Symbol("k") * sp.Symbol("y")), "bad_rod: potential: unknown name 'k'"),
    (dict(bodies=lambda v: (Body(v["m"], (v["x"], v["y"])),)),
     "bad_rod: bodies: the mass matrix is singular"),
    (dict(contacts=()), "bad_rod: contacts: declare at least one contact"),
    (dict(contacts=lambda v: (PointContact("A", (v["x"], v["y"]), friction=v["f"],
                                           sided="three"),)), "sided must be 'one' or 'two'"),
    # accepted but wrong until issue 23: refused when declared, in one line
    (dict(parameters=lambda v: (v["f"], v["l"], v["g"],
                                Parameter("m", "kg", "mass", 0.0, 0.0))),
     "bad_rod: body 0 mass: is 0 at the defaults"),
    (dict(potential=lambda v: v["m"] * v["g"] * v["y"]
          + v["m"] * v["l"] ** 2 * v["th"].rate ** 2),
     "bad_rod: potential: depends on the rate 'omega'"),
    # sp.Symbol("omega") is not the declared rate (real=True): it would be a constant
    (dict(potential=lambda v: v["m"] * v["g"] * v["y"]
          + v["m"] * v["l"] ** 2 * sp.Symbol("omega") ** 2),
     "bad_rod: potential: the symbol 'omega' is not the declared one"),
    (dict(bodies=lambda v: (Body(-v["m"], (v["x"], v["y"]), inertia=v["m"] * v["l"] ** 2 / 3,
                                 angle=v["th"]),)), "bad_rod: body 0 mass: is -1 at the defaults"),
    (dict(bodies=lambda v: (Body(v["m"], (v["x"], v["y"]), inertia=-v["m"] * v["l"] ** 2 / 3,
                                 angle=v["th"]),)),
     "bad_rod: body 0 inertia: is -0.333333 at the defaults"),
    (dict(contacts=lambda v: (PointContact("A", (v["x"], v["y"]), friction=-v["f"]),)),
     "bad_rod: contact 'A' friction: is -0.5 at the defaults"),
    (dict(parameters=lambda v: (Parameter("abs", "1", "friction", 0.5, 0.0), v["l"], v["g"],
                                v["m"])), "bad_rod: parameter 'abs': the name is one the "
     "generated code uses"),
    (dict(parameters=lambda v: (Parameter("f", "1", "friction", math.nan, 0.0), v["l"], v["g"],
                                v["m"])), "bad_rod: parameter 'f': its default must be a finite"),
    (dict(parameters=lambda v: (Parameter("f", "1", "friction", -1.0, 0.0), v["l"], v["g"],
                                v["m"])), "bad_rod: parameter 'f': its default -1 is outside its "
     "domain"),
    (dict(parameters=lambda v: (Parameter("f", "1", "friction", 0.5, 1.0, 0.2), v["l"], v["g"],
                                v["m"])), "bad_rod: parameter 'f': its lower bound 1 is above"),
    (dict(parameters=lambda v: (Parameter("f", "1", "friction", 0.5, 0.0, v["l"]), v["l"],
                                v["g"], v["m"])), "bad_rod: parameter 'f': its upper bound "
     "must be a number, got"),
    (dict(parameters=lambda v: (v["f"], v["l"], v["g"],
                                Parameter("m", "kg", "mass", 1.0, 0.0))),
     "bad_rod: body 0 mass: the domain of 'm' includes masses <= 0"),
])
def test_a_malformed_declaration_names_the_system_and_the_part(change, words):
    with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
        _good(**change).model


def test_a_coordinate_bound_may_be_a_parameter_or_an_expression():
    """A bound that is a Parameter or an expression of the parameters is accepted, checked
    when values are given, and refused in one line naming the coordinate when it is
    neither (it used to reach the sampler: TypeError: must be real number)."""
    from unseen import leaning_ladder

    S = leaning_ladder()
    ok = _good(coordinates=lambda v: (
        Coordinate("theta", "rad", "angle", 1.0, v["f"] / 10, 3.0 - v["f"],
                   rate=Rate("omega", "rad s-1", "rate")), v["x"], v["y"]))
    from phasemap.declare.validation import validate

    validate(S)
    validate(ok)
    with pytest.raises(ValueError, match="bad_rod: coordinate 'theta': its lower bound must be "
                       "a number or an expression of the parameters, got 'k'"):
        _good(coordinates=lambda v: (
            Coordinate("theta", "rad", "angle", 1.0, "k", 3.0,
                       rate=Rate("omega", "rad s-1", "rate")), v["x"], v["y"])).model
    from phasemap.declare.build import _bounds_check

    check = _bounds_check(S)
    check({"phi": 0.3, "beta": 0.2})
    with pytest.raises(ValueError, match="leaning_ladder: phi is outside its domain: its "
                       "lower bound is beta"):
        check({"phi": 0.1, "beta": 0.2})


def test_the_slip_sign_is_read_where_check_accepts_the_state():
    """An overhanging wall (beta < 0): the floor's slip factor, 2 l cos(phi - beta) / cos(beta),
    changes sign at phi = pi/2 + beta inside the box of the bounds, but not where check=
    accepts the state (phi <= pi/2 + beta), so the slip sign is decided there, not refused
    with advice the user cannot follow (bounds cannot say it)."""
    import dataclasses as dc

    from unseen import leaning_ladder

    from phasemap.declare.equations import Equations
    from phasemap.declare.modes import slip_velocity

    S = leaning_ladder(lower=0.0)
    beta = dc.replace(S.parameters[2], default=-0.2, lower=-0.5, upper=0.0)

    def check(values):
        if np.any(np.asarray(values["phi"]) > math.pi / 2 + np.asarray(values["beta"])):
            raise ValueError("overhang: phi must be at most pi/2 + beta")

    S = dc.replace(S, parameters=S.parameters[:2] + (beta,) + S.parameters[3:])
    with pytest.raises(ValueError, match="leaning_ladder: contact 'floor': its slip velocity"):
        slip_velocity(Equations(S))
    _, kappa, _ = slip_velocity(Equations(dc.replace(S, check=check)))
    assert kappa == {"floor": 1, "wall": 1}


def test_a_declaration_file_works_wherever_a_model_name_does(tmp_path):
    """The CLI classifies a system given as the path of its declaration file."""
    src = (ROOT / "phasemap" / "systems" / "painleve_rod.py").read_text()
    path = tmp_path / "my_rod.py"
    path.write_text(src.replace('"painleve_rod", "Painleve', '"my_rod", "Painleve'))
    run = subprocess.run([sys.executable, "-m", "phasemap.cli", "classify", str(path),
                          "theta=1.1", "omega=0", "xdot=-1", "f=2"],
                         capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "my_rod(theta=1.1" in run.stdout and "no solution" in run.stdout
    bad = tmp_path / "nothing.py"
    bad.write_text("x = 1\n")
    with pytest.raises(ValueError, match="nothing.py: the file must define SYSTEM"):
        phasemap.get_model(bad)


def test_a_declared_model_travels_to_another_process():
    """A dask worker gets the declaration and rebuilds the model from the kernel cache."""
    import pickle

    m = phasemap.MODELS["painleve_rod"]
    code = ("import pickle, sys, phasemap; m = pickle.loads(sys.stdin.buffer.read()); "
            "print(int(phasemap.classify(m, theta=1.1, omega=0.0, xdot=-1.0, f=2.0).n_solutions))")
    run = subprocess.run([sys.executable, "-c", code], input=pickle.dumps(m),
                         capture_output=True, timeout=600)
    assert run.returncode == 0, run.stderr.decode()
    assert run.stdout.decode().strip() == "0"


def test_a_declared_trajectory_draws_its_own_phase_plane():
    """simulate names the first coordinate and its velocity; the plot uses them."""
    ds = phasemap.simulate("painleve_rod", theta=1.0, omega=0.0, xdot=1.0, f=0.3, t_end=2.0)
    assert ds.attrs["phasemap_phase_plane"] == "theta omega"
    assert ds.attrs["end_reason"] in ("left_domain", "contact_lost")
    fig = ds.phasemap.plot(phase_plane=True)
    ax = fig.axes[0]
    assert ax.get_xlabel().startswith(r"$\theta$") and ax.get_ylabel().startswith(r"$\omega$")


def test_branches_can_get_short_names():
    """names= renames generated branches (and their layers); an unknown one is refused."""
    from phasemap.systems.painleve_rod import SYSTEM

    short = dataclasses.replace(SYSTEM, name="rod_short",
                                names={"A_slip_pos": "slide_pos", "A_slip_neg": "slide_neg"})
    assert short.model.branches[:3] == ("stick", "slide_pos", "slide_neg")
    assert "A_slip_pos" in short.branch_names()
    assert "theta_ddot_slide_pos" in phasemap.layers_for(short.model)
    wrong = dataclasses.replace(SYSTEM, name="rod_wrong", names={"A_glide": "glide"})
    with pytest.raises(ValueError, match="rod_wrong: names: 'A_glide' is not a branch"):
        wrong.model


def test_a_motion_that_leaves_the_contact_region_ends_there():
    """The rod slides down the step until the step's edge reaches the rod's end
    (h = 2 l sin theta): there the edge contact no longer exists, and the motion ends
    with left_domain at that angle, located to the integrator's event precision."""
    ds = phasemap.simulate("rod_on_step", theta=1.2, omega=0.0, f=0.3, h=0.8, l=1.0, t_end=5)
    assert ds.attrs["end_reason"] == "left_domain"
    assert "leaves the body's edge" in ds.attrs["end_message"]
    assert float(ds.event_theta[-1]) == pytest.approx(math.asin(0.4), abs=1e-8)
    with pytest.raises(ValueError, match="rod_on_step: outside the domain"):
        phasemap.classify("rod_on_step", theta=0.3, h=0.8, l=1.0)


def test_phase_curve_and_simulate_agree_where_a_contact_is_left():
    """The rod sliding down the step lifts off the floor: the first-integral tracer and
    the time integrator both end with contact_lost, at the same state (a tie at the
    boundary, kept with N = 0 and leaving, is resolved just past it)."""
    curve = phasemap.phase_curve("rod_on_step", theta=1.2, omega=-1.0, f=0.3, h=0.8)
    motion = phasemap.simulate("rod_on_step", theta=1.2, omega=-1.0, f=0.3, h=0.8, rtol=1e-10,
                               atol=1e-12, through_contacts=False)
    assert curve.attrs["end_reason"] == motion.attrs["end_reason"] == "contact_lost"
    assert float(curve.stage_end_phi[-1]) == pytest.approx(float(motion.event_theta[-1]),
                                                           abs=1e-8)
    assert float(curve.stage_end_omega[-1]) == pytest.approx(float(motion.event_omega[-1]),
                                                             abs=1e-7)
    ax = curve.phasemap.plot().axes[0]  # labelled with the model's own symbols
    assert ax.get_xlabel() == r"$\theta$ (rad)" and ax.get_ylabel().startswith(r"$\omega$")


# -- the conditions the bifurcation tracer reads (phasemap.declare.admissibility) ----------

#: declared built-ins, the twins (as files) and the hand models they stand in for
CONDITION_MODELS = ["ladder", "wheel", "painleve_rod", "rod_on_step",
                    str(SEEDS / "elliptic_pendulum.py"), str(SEEDS / "hinge_pendulum.py"),
                    "elliptic_pendulum", "hinge_pendulum"]


def _states(m, rng, n):
    """``n`` random states of ``m`` (a third at rest), as arrays, and where it is at rest."""
    cols = {name: [] for name in m.names}
    for i in range(n):
        values = _sample(m, rng, i % 3 == 0)
        if m.name == "rod_on_step":
            values["h"] = rng.uniform(0.2, 0.8) * 2 * values["l"] * math.sin(values["theta"])
            values["theta"] = rng.uniform(0.05, math.pi / 2 - 0.02) if i % 7 else 0.02
        for k in cols:
            cols[k].append(values[k])
    cols = {k: np.array(v) for k, v in cols.items()}
    return cols, cols[m.velocity] == 0.0


@pytest.mark.parametrize("name", CONDITION_MODELS)
def test_conditions_decide_the_generated_branches(name):
    """2000 random states, a third at rest, ties included: wherever a branch applies, it is
    admissible (ADMISSIBLE or SEPARATION) exactly where all its conditions hold, and a
    state is in the model's domain exactly where the domain conditions hold."""
    from phasemap.declare import conditions

    m = phasemap.get_model(name)
    conds = conditions(m)
    values, rest = _states(m, np.random.default_rng(5), 2000)
    held = {c.name: c.holds(values, rest) for c in conds}
    by_branch = {b: [c for c in conds if c.branch == b] for b in m.branches}
    assert {c.branch for c in conds} <= set(m.branches) | {None}
    inside = np.ones(len(rest), bool)
    for c in conds:
        inside &= held[c.name] if c.branch is None else True
    out = np.full((len(m.branches), m.n_fields), np.nan)
    outcomes = {True: 0, False: 0}
    for i in range(len(rest)):
        v = m.input_vector({k: float(x[i]) for k, x in values.items()})
        m.derive(v)
        assert bool(m.contract.domain(v)) == bool(inside[i]), i
        if not inside[i]:
            continue
        m.point(v, out)
        for b, branch in enumerate(m.branches):
            if out[b, nx.STATUS] == nx.ABSENT:
                continue
            admissible = out[b, nx.STATUS] in (nx.ADMISSIBLE, nx.SEPARATION)
            assert admissible == all(held[c.name][i] for c in by_branch[branch]), \
                (branch, {k: float(x[i]) for k, x in values.items()})
            outcomes[admissible] += 1
    assert outcomes[True] > 1000 and outcomes[False] > 1000


@pytest.mark.parametrize("name", ["ladder", "wheel", "rod_on_step",
                                  str(SEEDS / "elliptic_pendulum.py")])
def test_a_condition_named_after_a_layer_has_the_layer_sign(name):
    """coef_<branch> and <reaction>_<branch> name the atlas layers: at 500 random states the
    condition's value has the sign of the layer's quantity (of -N for a two-sided contact's
    negative branch, whose condition is -N > 0)."""
    from phasemap.declare import conditions
    from phasemap.maps.layers import layers_for

    m = phasemap.get_model(name)
    layers = layers_for(m)
    named = [c for c in conditions(m) if c.name in layers]
    assert {c.kind for c in named} == {"coefficient", "normal"}
    values, rest = _states(m, np.random.default_rng(8), 500)
    out = np.full((len(m.branches), m.n_fields), np.nan)
    signs = {c.name: set() for c in named}
    for i in range(len(rest)):
        state = {k: float(x[i]) for k, x in values.items()}
        v = m.input_vector(state)
        m.derive(v)
        if not m.contract.domain(v):
            continue
        m.point(v, out)
        for c in named:
            layer = out[layers[c.name].branch, layers[c.name].column]
            mine = float(c.value({k: state[k] for k in c.symbols}))
            if np.isfinite(layer) and abs(layer) > 1e-9 and abs(mine) > 1e-9 * float(
                    c._evaluated(state)[1]):
                signs[c.name].add(np.sign(layer) * np.sign(mine))
    for c in named:
        want = {-1.0} if c.kind == "normal" and c.sense == "> 0" else {1.0}
        assert signs[c.name] == want, c.name


def test_the_painleve_rods_conditions_are_its_closed_forms():
    """The rod sliding with xdot < 0: its coefficient is (1 + 3 cos^2 - 3 f sin cos) / 3, whose
    zero set bounds the paradox, and its normal force vanishes where g = l sin(theta)
    omega^2 (Genot and Brogliato 1999); from rest the slide must start backwards."""
    from phasemap.declare import conditions
    from phasemap.systems.painleve_rod import SYSTEM

    c = {x.name: x for x in conditions(SYSTEM)}
    th, f, g, l, om = sp.symbols("theta f g l omega", real=True)
    coef = c["coef_A_slip_neg"]
    assert coef.kind == "coefficient" and coef.sense == "!= 0" and coef.branch == "A_slip_neg"
    assert sp.expand(coef.expr - (1 + 3 * sp.cos(th) ** 2 - 3 * f * sp.sin(th) * sp.cos(th))) == 0
    normal = c["N_A_A_slip_neg"]
    assert sp.cancel(normal.expr / (g - l * sp.sin(th) * om ** 2)).free_symbols == {
        sp.Symbol("m", real=True)}
    assert sp.cancel(normal.divisor / coef.expr).is_positive and normal.sense == ">= 0"
    start = c["start_A_A_slip_neg"]
    assert start.rest_only and start.strict and "xdot" not in start.symbols
    assert c["gap_A_A_separated_moving_neg"].branch == "A_separated_moving_neg"
    from phasemap.declare.admissibility import presence
    assert presence(SYSTEM)["A_separated_moving_neg"] == 2 and presence(SYSTEM)["stick"] == 1
    result = doctest.testmod(importlib.import_module("phasemap.declare.admissibility"))
    assert result.attempted >= 5 and result.failed == 0


def test_the_seed_systems_conditions_are_their_closed_forms():
    """The ladder's static zone phi = 2 arctan f is where two bounds of its family of
    reactions meet; the hinge's stagnation zone l |sin phi| = delta is its stick limit;
    the elliptic pendulum's coefficient is lambda_k = 1 + sin^2 - k f sin cos."""
    from phasemap.declare import conditions

    ladder = {c.name: c for c in conditions(phasemap.get_model("ladder"))}
    family = ladder["family_limit_neg_floor_limit_neg_wall_stick"]
    rng = np.random.default_rng(1)
    f = rng.uniform(0.05, 0.95, 200)
    at = dict(phi=2 * np.arctan(f), omega=0 * f, f=f, l=rng.uniform(0.3, 2, 200),
              g=rng.uniform(1, 12, 200), m=rng.uniform(0.3, 3, 200))
    expr, scale, _, where = family._evaluated(at)
    assert np.all(np.abs(expr) <= 1e-12 * scale) and np.all(where > 0)
    hinge = {c.name: c for c in conditions(phasemap.get_model("hinge_pendulum"))}
    d, l, phi = sp.symbols("delta l phi", real=True)
    assert sp.cancel(hinge["limit_hinge_stick"].expr / (d ** 2 - l ** 2 * sp.sin(phi) ** 2)) \
        .free_symbols == set(sp.symbols("g m", real=True))
    elliptic = {c.name: c for c in conditions(phasemap.get_model("elliptic_pendulum"))}
    f, k = sp.Symbol("f", real=True), 1  # slide_pos_Npos: k = sgn(N xdot) = 1
    lam = 1 + sp.sin(phi) ** 2 - k * f * sp.sin(phi) * sp.cos(phi)
    assert sp.simplify(elliptic["coef_slide_pos_Npos"].expr / lam).is_Number


def test_twins_name_their_branches_and_reactions_as_the_hand_models():
    """The elliptic and hinge twins carry the hand modules' branch names (and the elliptic
    one its reactions N, F): at 2000 random states each named branch is admissible in the
    twin exactly where it is in the hand module, with the same reactions."""
    for seed in ("elliptic_pendulum", "hinge_pendulum"):
        hand = phasemap.get_model(seed)
        twin = phasemap.get_model(SEEDS / f"{seed}.py")
        assert set(hand.branches) <= set(twin.branches)
        shared = [r.name for r in hand.reactions if r.name in {t.name for t in twin.reactions}]
        assert shared == (["N", "F"] if seed == "elliptic_pendulum" else [])
        rng = np.random.default_rng(4)
        for i in range(2000):
            values = _sample(hand, rng, i % 3 == 0)
            h, t = _rows(hand, values, False), _rows(twin, values, False)
            for b, name in enumerate(hand.branches):
                tb = twin.branches.index(name)
                assert (h[b, 0] == nx.ADMISSIBLE) == (t[tb, 0] == nx.ADMISSIBLE), (name, values)
                for r in shared:
                    hc = hand.first_reaction + [x.name for x in hand.reactions].index(r)
                    tc = twin.first_reaction + [x.name for x in twin.reactions].index(r)
                    if h[b, 0] == nx.ADMISSIBLE:
                        assert t[tb, tc] == pytest.approx(h[b, hc], rel=1e-7, abs=1e-9)


def test_conditions_need_a_declaration_or_a_twin():
    from phasemap.declare import conditions
    from references import ladder

    with pytest.raises(TypeError, match="'ladder' is not a declared system or model"):
        conditions(ladder.MODEL)


def test_a_classification_holds_branch_results_not_branch_definitions():
    """Two classes were named Branch: the result of classify is BranchResult (the old name
    kept as an alias), a candidate's definition is phasemap.core.model.Candidate."""
    from phasemap.core import model

    got = phasemap.classify("hinge_pendulum", phi=0.05, omega=0.0)
    assert got.candidates and all(type(b) is phasemap.BranchResult for b in got.candidates)
    assert phasemap.Branch is phasemap.BranchResult
    assert model.Candidate is not phasemap.BranchResult
    assert not hasattr(model, "Branch")  # one name per concept


def test_a_broken_declaration_names_every_problem_at_once():
    """declare.md's own broken example reported the missing rate but not the missing body
    (issue 41 item 10): every part a system cannot do without is named in one ValueError,
    and the checks that can run on what is there run too."""
    import sympy as sp

    from phasemap.declare import Coordinate, Parameter, System

    q = Coordinate("q", "m", "height")
    with pytest.raises(ValueError) as err:
        System("broken", "a height without a rate, and no body", "-", coordinates=(q,),
               parameters=(), bodies=(), contacts=()).model
    said = str(err.value)
    assert said.startswith("broken: ") and "\n" not in said
    for part in ("coordinates: at least one coordinate needs a Rate",
                 "bodies: declare at least one Body", "contacts: declare at least one contact"):
        assert part in said, said
    # a single problem reads as before
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    with pytest.raises(ValueError, match=r"^alone: bodies: declare at least one Body "
                                         r"\(the system has no mass\)$"):
        from phasemap.declare import PointContact, Rate

        x = Coordinate("x", "m", "position", rate=Rate("v", "m s-1", "velocity"))
        System("alone", "no body", "-", coordinates=(x,), parameters=(m,), bodies=(),
               contacts=(PointContact("A", (x, sp.Integer(0)), normal=(0, 1), friction=m),
                         )).model


def test_a_normal_that_depends_on_a_parameter():
    """Issue 41 item 11: a slope whose angle is a parameter. Unbounded, the slip factor
    1/cos(alpha) changes sign, and the error names alpha; bounded to (-1.2, 1.2) rad, the
    declaration derives."""
    import dataclasses

    import sympy as sp

    from phasemap.declare import Parameter
    from phasemap.declare.derivation import derive
    from phasemap.systems import painleve_rod

    rod = painleve_rod.SYSTEM
    (floor,) = rod.contacts
    for lo, hi in ((-math.inf, math.inf), (-1.2, 1.2)):
        alpha = Parameter("alpha", "rad", "inclination of the slope", 0.3, lo, hi)
        slope = dataclasses.replace(floor, normal=(-sp.sin(alpha), sp.cos(alpha)))
        S = dataclasses.replace(rod, name="rod_on_a_slope", contacts=(slope,),
                                parameters=rod.parameters + (alpha,))
        if math.isinf(hi):
            with pytest.raises(ValueError, match="depends on alpha"):
                derive(S)
        else:
            assert derive(S).kappa == {"A": 1}


def test_an_extreme_gravity_is_answered_at_once():
    """Issue 42 item 5: this call had not returned after 30 s.  It was rod_on_step's first
    compile; the call itself answers: two solutions, with finite reactions."""
    c = phasemap.classify("rod_on_step", omega=-8.17853977099021, f=4.187210838180927,
                          h=1.3312392722024802, g=1e-16, m=2.5041213288033703)
    assert c.n_solutions == 2
    assert all(math.isfinite(v) for b in c.branches for v in b.reactions.values())


def test_a_slip_velocity_that_is_a_parameter_times_a_rate():
    """A contact that slips at r w, r a parameter: its factor r is a bare symbol, and the
    derivation read its sign by substituting a number, which sympy hands back as a Python
    float (AttributeError: 'float' object has no attribute 'evalf').  Found by a
    wheelbarrow whose handles slide at r omega (issue 37, tests/unseen.py)."""
    from phasemap.declare.derivation import derive

    f = Parameter("f", "1", "friction coefficient", 0.5, 0.0)
    r = Parameter("r", "m", "length of the lever", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    s = Coordinate("s", "1", "turn of the lever", rate=Rate("w", "s-1", "its rate"))
    y = Coordinate("y", "m", "height")
    S = System("lever_block", "a block moved by a lever", "test", coordinates=(s, y),
               parameters=(f, r, g, m), bodies=(Body(m, (r * s, y)),), potential=m * g * y,
               contacts=(PointContact("A", (r * s, y), normal=(0, 1), friction=f),))
    d = derive(S)
    assert d.velocity.name == "w" and d.kappa == {"A": 1}
