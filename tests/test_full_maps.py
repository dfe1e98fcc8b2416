"""Maps and classify of the friction oscillators, which have no reduced model (issue 39:
"maps, events and stagnation read the relative velocity"; "maps take the forcing phase as
an axis or a fixed value"): each layer against a closed form derived here, the map
against classify and simulate, dask against eager, the atlas through netCDF."""

import math

import numpy as np
import pytest

import phasemap
from phasemap.maps.full import FullModel, map_model


def _belt_closed_form(x, xdot, m, k, g, v, f_s, f_k):
    """The block on the belt, by hand: at the belt's speed it sticks (x'' = 0, F = k x)
    while |k x| <= f_s m g, else starts to slip against the static limit; off it, it slips
    with m x'' = -k x - f_k m g sgn(x' - v)."""
    rel = xdot - v
    N = m * g
    if rel == 0.0:
        if abs(k * x) <= f_s * N:
            return True, 0.0, N, k * x
        s = -math.copysign(1.0, k * x)     # the spring drags it off the belt's speed
        return False, (-k * x - s * f_s * N) / m, N, -s * f_s * N
    s = math.copysign(1.0, rel)
    return False, (-k * x - s * f_k * N) / m, N, -s * f_k * N


def test_belt_classify_matches_its_closed_form_at_random_states():
    rng = np.random.default_rng(39)
    for _ in range(60):
        m, k, g = rng.uniform(0.3, 3.0, 3)
        f_k = rng.uniform(0.0, 1.0)
        f_s = f_k + rng.uniform(0.0, 1.0)
        v = rng.uniform(-1.0, 1.0)
        x = rng.uniform(-3.0, 3.0)
        xdot = v if rng.random() < 0.5 else rng.uniform(-2.0, 2.0)
        stuck, xdd, N, F = _belt_closed_form(x, xdot, m, k, g, v, f_s, f_k)
        c = phasemap.classify("belt", x=x, xdot=xdot, m=m, k=k, g=g, v=v, f_s=f_s, f_k=f_k)
        assert c.n_solutions == 1 and not c.contact_lost and not c.singular
        assert c.stagnation == stuck
        (b,) = c.branches
        assert b.name == ("belt_stick" if stuck else "belt_slip_" + (
            "pos" if xdd * m + k * x < 0 else "neg"))
        assert b.accelerations["x_ddot"] == pytest.approx(xdd, abs=1e-12)
        assert b.reactions["N_belt"] == pytest.approx(N, rel=1e-12)
        assert b.reactions["F_belt"] == pytest.approx(F, abs=1e-12)


def test_the_stick_zone_is_exact_at_its_edges():
    """|k x| = f_s m g sticks (the limit is inside the cone), and so does what is within
    the engine's tie tolerance (1e-9 of the forces' scale) beyond; a little more slips."""
    edge = 1.0     # k = m = g = f_s = 1
    assert phasemap.classify("belt", x=edge, xdot=0.2).stagnation
    assert phasemap.classify("belt", x=-edge, xdot=0.2).stagnation
    assert phasemap.classify("belt", x=edge * (1 + 1e-10), xdot=0.2).stagnation
    assert not phasemap.classify("belt", x=edge * (1 + 1e-8), xdot=0.2).stagnation
    # off the belt's speed by a hair more than the tie tolerance: slipping, no stagnation
    assert not phasemap.classify("belt", x=0.0, xdot=0.2 + 1e-6).stagnation


def test_den_hartog_map_over_the_forcing_phase():
    """At x' = 0 the forced block stays put where |F0 cos(Omega t) - k x| <= f m g, and
    elsewhere starts with m x'' = F0 cos(Omega t) - k x - f m g sgn(...)."""
    Omega, f = 0.8, 0.2
    xs = np.linspace(-1.5, 1.5, 13)
    ts = np.linspace(0.0, 2 * np.pi / Omega, 9)
    ds = phasemap.Scene("den_hartog", axes={"x": xs, "t": ts}, fixed={"xdot": 0.0},
                        layers=["n_solutions", "stagnation", "contact_lost", "x_ddot",
                                "F_floor"]).compute()
    assert ds.n_solutions.dims == ("x", "t") and ds.t.attrs["units"] == "s"
    push = np.cos(Omega * ts)[None, :] - xs[:, None]
    clear = np.abs(np.abs(push) - f) > 1e-9          # away from the tie
    assert np.array_equal(ds.stagnation.values[clear], (np.abs(push) <= f)[clear])
    assert (ds.n_solutions == 1).all() and not ds.contact_lost.any()
    want = np.where(np.abs(push) <= f, 0.0, push - f * np.sign(push))
    assert np.allclose(ds.x_ddot.values[clear], want[clear], atol=1e-12)
    assert np.allclose(ds.F_floor.values[clear],
                       np.where(np.abs(push) <= f, -push, -f * np.sign(push))[clear],
                       atol=1e-12)


def test_stribeck_slip_reads_the_relative_speed():
    rng = np.random.default_rng(1998)
    for _ in range(20):
        v, xdot, x = rng.uniform(-1, 1), rng.uniform(-2, 2), rng.uniform(-2, 2)
        f_s, delta = rng.uniform(0.2, 1.5), rng.uniform(0.0, 5.0)
        rel = xdot - v
        c = phasemap.classify("stribeck_belt", x=x, xdot=xdot, v=v, f_s=f_s, delta=delta)
        want = -x - np.sign(rel) * f_s / (1 + delta * abs(rel))
        assert c.branches[0].accelerations["x_ddot"] == pytest.approx(want, abs=1e-12)


def test_a_map_agrees_with_classify_and_with_the_motion():
    """One truth: a cell of the map, classify at its values, and simulate from them (a
    motion that starts stuck stays with the belt) say the same."""
    axes = {"x": np.array([-1.2, -0.3, 0.9, 1.4]), "f_s": np.array([0.8, 1.3])}
    scene = phasemap.Scene("belt", axes=axes, fixed={"xdot": 0.2},
                           layers=["n_solutions", "stagnation", "x_ddot", "F_belt"])
    ds = scene.compute()
    for i, x in enumerate(axes["x"]):
        for j, fs in enumerate(axes["f_s"]):
            c = phasemap.classify("belt", x=x, xdot=0.2, f_s=fs)
            assert ds.stagnation.values[i, j] == c.stagnation
            assert ds.x_ddot.values[i, j] == c.branches[0].accelerations["x_ddot"]
            assert ds.F_belt.values[i, j] == c.branches[0].reactions["F_belt"]
    motion = phasemap.simulate("belt", 0.5, x=-0.3, xdot=0.2, f_s=0.8)
    assert np.allclose(np.diff(motion.x.values) / np.diff(motion.t.values), 0.2)


def test_dask_chunks_spec_and_netcdf_keep_every_value(tmp_path):
    scene = phasemap.Scene("den_hartog", axes={"x": np.linspace(-1, 1, 6),
                                               "t": np.linspace(0, 7, 5)},
                           fixed={"xdot": 0.3}, layers=["n_solutions", "stagnation",
                                                        "x_ddot"])
    eager = scene.compute()
    lazy = scene.compute(chunks=2)
    assert lazy.x_ddot.chunks == ((2, 2, 2), (2, 2, 1))
    done = lazy.compute()
    for v in eager.data_vars:
        assert done[v].dtype == eager[v].dtype
        assert np.array_equal(done[v].values, eager[v].values, equal_nan=True)
    again = phasemap.Scene.from_spec(scene.spec())
    assert again.spec() == scene.spec() and isinstance(again.model, FullModel)
    from phasemap.plot.labels import axis_label

    assert axis_label(eager, "x_ddot") == r"$\ddot{x}$ (m s$^{-2}$)"
    path = tmp_path / "den_hartog.nc"
    phasemap.write_atlas(eager, path)
    back = phasemap.open_atlas(path)
    assert np.array_equal(back.x_ddot.values, eager.x_ddot.values)
    assert back.attrs["phasemap_model"] == "den_hartog"


def test_full_maps_refuse_bad_input_in_one_line():
    with pytest.raises(ValueError, match="unknown variable"):
        phasemap.classify("belt", y=0.0)               # the contact fixes y
    with pytest.raises(ValueError, match="unknown variable"):
        phasemap.classify("belt", t=1.0)               # the belt is not forced in time
    with pytest.raises(ValueError, match="use a Scene"):
        phasemap.classify("belt", x=[0.0, 1.0])
    with pytest.raises(ValueError, match="m = -1 is outside its domain"):
        phasemap.classify("belt", m=-1.0)
    with pytest.raises(ValueError, match="unknown layer 'phi_rest'"):
        phasemap.Scene("belt", axes={"x": [0.0, 1.0]}, layers=["phi_rest"])
    # the survey's layers, then the motion layers (tests/test_full_motions.py)
    state = ["x", "y", "xdot", "y_dot"]
    assert list(phasemap.layers_for("belt")) == [
        "n_solutions", "stagnation", "contact_lost", "singular", "x_ddot", "N_belt",
        "F_belt", "fate", "n_reversals", "n_sticks", "t_final", "t_rest",
        *(f"{n}_final" for n in state), *(f"section_{n}" for n in state), "multiple"]
    assert map_model("ladder") is phasemap.get_model("ladder")


def _random_values(m, rng):
    """A state of ``m`` with every contact closed: positions inside their bounds, rates
    at relative rest half of the time (zero; the belt's speed ``v`` where there is one),
    parameters at their defaults."""
    values = {}
    for v in m.state:
        lo, hi = max(v.lower, -2.0), min(v.upper, 2.0)
        values[v.name] = float(rng.uniform(lo + 1e-3, hi - 1e-3))
    for name in m.names[len(m.state) // 2:len(m.state)]:
        if name != "t" and rng.random() < 0.5:
            values[name] = m.defaults.get("v", 0.0)
    return m.complete(values)


@pytest.mark.parametrize("name", ["ladder", "wheel", "rod_on_step", "belt", "den_hartog"])
def test_a_compiled_cell_is_the_motions_own_survey(name):
    """The map's compiled cell (flow.survey_cells) against the engine's survey in Python
    (Motion.survey, with the summary written out in maps.full.python_cell): the same
    count, flags and unique motion, bit for bit, on random states of systems with one
    and two contacts, where they stick, slip and leave a contact."""
    from phasemap.maps import full
    from phasemap.systems.oscillators import OSCILLATORS

    S = OSCILLATORS.get(name) or phasemap.get_model(name).declaration
    m = FullModel(getattr(S, "system", S))
    rng = np.random.default_rng(7)
    seen = set()
    for _ in range(60):
        q, u, p, t = m.state_of(_random_values(m, rng))
        motion = m.motion(p)
        n, flags, row = full.cell(m, motion, q, u, t)
        want = full.python_cell(m, motion, q, u, t, True)
        assert (n, flags) == want[:2]
        assert np.array_equal(row, want[2], equal_nan=True)
        seen |= {("n", n)} | {b for b, bit in full.BITS.items() if flags & bit}
    assert ("n", 1) in seen and "stagnation" in seen, seen
    assert name != "ladder" or "contact_lost" in seen, seen      # it leaves the wall


def test_each_cell_holds_its_own_full_state():
    """A map's full states, computed once per value of the names each of the closure's
    functions reads, against the closure called at every cell: the rolling wheel's
    x' = r omega reads a parameter and a rate together, with the axes in another order
    than the closure's arguments."""
    from phasemap.maps import full

    S = phasemap.get_model("wheel").declaration
    m = FullModel(getattr(S, "system", S))
    axes = {"r": np.array([1.0, 1.5]), "omega": np.array([-1.0, 0.0, 2.0]),
            "phi": np.array([0.1, 0.2, 0.4, 0.9])}
    fixed = {k: v for k, v in m.defaults.items() if k not in axes}
    Y, P, T = full._cells(m, axes, fixed, (2, 3, 4))
    for i, index in enumerate(np.ndindex(2, 3, 4)):
        values = {**fixed, **{n: float(a[j]) for (n, a), j in zip(axes.items(), index)}}
        q, u = m.closure(values)
        assert np.array_equal(Y[i], np.concatenate([q, u]))
        assert np.array_equal(P[i], [values[p] for p in m.mech.parameters])
    assert not T.any()


def test_a_survey_grows_its_rows_to_the_states_candidates():
    """The outputs of a survey hold 16 candidate phases at first (the most, 4 ** k, would
    take 0.5 GB for ten contacts) and grow where a state has more: started from one row,
    the engine's survey and the map's cells give what they give from sixteen, on the
    ladder's states at rest against the wall and the floor (up to sixteen phases)."""
    S = phasemap.get_model("ladder").declaration
    m = FullModel(getattr(S, "system", S))
    rng = np.random.default_rng(3)
    states = [m.state_of(_random_values(m, rng)) for _ in range(30)]
    P = np.array([p for _, _, p, _ in states])
    Y = np.array([np.concatenate([q, u]) for q, u, _, _ in states])
    T = np.zeros(len(states))
    motion = m.motion(P[0])
    want = motion.flow.cells(P, Y, T, m.moving, True)
    surveys = [motion.survey(q, u, t=t) for q, u, _, t in states]
    motion.flow.rows = 1
    got = motion.flow.cells(P, Y, T, m.moving, True)
    for a, b in zip(got, want):
        assert np.array_equal(a, b, equal_nan=True)
    for (q, u, _, t), (groups, cand) in zip(states, surveys):
        again, cand2 = motion.survey(q, u, t=t)
        assert cand2 == cand and [[x[0] for x in g] for g in again] == \
            [[x[0] for x in g] for g in groups]
    assert max(math.prod(len(c) for c in cand) for _, cand in surveys) > 1
