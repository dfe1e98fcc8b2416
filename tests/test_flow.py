"""The compiled flow of a phase in full coordinates (phasemap.motion.hybrid.flow): its
accelerations against an independent NumPy solve of the same phase, its interpreted twin
against its machine code bit for bit, and the rewritten declaration functions against
the generated ones."""

import math

import numpy as np
import pytest

from phasemap.core import tiers
from phasemap.declare.full import mechanics
from phasemap.motion import hybrid
from phasemap.motion.hybrid import binding, flow
from phasemap.motion.hybrid.phases import OPEN, SLIP_NEG, SLIP_POS, SMOOTH, STICK, TOL
from phasemap.systems.oscillators import BELT, DEN_HARTOG, STRIBECK_BELT
from phasemap.systems.painleve_rod import SYSTEM as ROD
from phasemap.systems.rod_on_step import SYSTEM as STEP
from phasemap.systems.seeds.ladder import SYSTEM as LADDER
from phasemap.systems.seeds.wheel import SYSTEM as WHEEL

SYSTEMS = {"rod": ROD, "ladder": LADDER, "wheel": WHEEL, "rod_on_step": STEP, "belt": BELT,
           "stribeck_belt": STRIBECK_BELT, "den_hartog": DEN_HARTOG}


def _motion(S, **values):
    mech = mechanics(S)
    d = dict(mech.defaults, **values)
    return hybrid.Motion(mech, [d[p] for p in mech.parameters], hybrid.Options(t_end=1.0))


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_phase_accelerations_agree_with_a_numpy_solve(name):
    """Random states and every mode of every contact: the compiled solve (its own LU)
    against phasemap's NumPy solve of the same phase (LAPACK), to 1e-9 of the scales, and
    the same None where a phase has no finite solution.  The slip coefficients of the
    belts are their kinetic ones at the sliding speed, static where a slip starts."""
    m = _motion(SYSTEMS[name])
    rng = np.random.default_rng(7)
    modes_of = (OPEN, SMOOTH, STICK, SLIP_POS, SLIP_NEG)
    checked = 0
    for _ in range(40):
        q = rng.normal(size=m.n) * 0.5 + np.where(np.isfinite(m.bounds[:, 0]),
                                                   m.bounds[:, 0] + 0.6, 0.0)
        q = np.clip(q, m.bounds[:, 0] + 1e-3, m.bounds[:, 1] - 1e-3)
        u = rng.normal(size=m.n)
        t = float(rng.uniform(0.0, 3.0))
        modes = tuple(int(rng.choice(modes_of)) for _ in range(m.k))
        rho = np.where(rng.random(m.k) < 0.5, 1.0, -1.0)
        start = tuple(c for c in range(m.k) if rng.random() < 0.5)
        got, det = m._solve(q, u, modes, rho, t, start, True)
        want, det_want = m._solve_redundant(q, u, modes, rho, t, start, True)
        assert (got is None) == (want is None)
        if got is None:
            continue
        for a, b in zip(got[:4], want[:4]):
            scale = 1.0 + np.abs(b).max()
            assert np.abs(a - b).max() <= 1e-9 * scale, (modes, a, b)
        for a, b in zip(got[4], want[4]):
            assert np.allclose(a, b, rtol=1e-13, atol=1e-13)
        assert abs(det - det_want) <= 1e-9
        checked += 1
    assert checked >= 20


@pytest.mark.parametrize("S, start", [
    (ROD, dict(q=[0.7, 0.0, 0.3], u=[0.0, 0.5, 0.0])),                 # flight, impacts
    (STRIBECK_BELT, dict(q=[0.5, 0.0], u=[0.0, 0.0])),                   # stick-slip
])
def test_the_twin_steps_as_the_machine_code_does(S, start):
    """A motion through flight, impacts and stick-slip switches on the interpreted twins
    (``PHASEMAP_JIT=off``) and on the machine code: the same bits in every saved point and
    event."""
    mech = mechanics(S)
    p = [mech.defaults[n] for n in mech.parameters]
    recs = []
    for how in ("off", "eager"):
        with tiers.forced(how):
            m = hybrid.Motion(mech, p, hybrid.Options(t_end=1.0 if S is ROD else 12.0))
            assert m.flow.twin == (how == "off")
            recs.append(m.run(np.array(start["q"]), np.array(start["u"])))
    a, b = recs
    assert len(a.ev_kind) >= 3 and a.ev_kind == b.ev_kind
    assert np.array_equal(np.array(a.t), np.array(b.t))
    assert np.array_equal(np.array(a.y), np.array(b.y))
    assert np.array_equal(np.array(a.ev_t), np.array(b.ev_t))


@pytest.mark.parametrize("twin", [True, False], ids=["twins", "machine"])
@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_rewritten_functions_give_the_generated_pieces(name, twin):
    """pieces_into, domain_into, surface_into and kinetic_into (what the kernels call at
    the addresses binding.functions gives: their machine code, or at the handles of the
    twins' tier their interpreted twins) against the generated functions they were
    rewritten from, at random states."""
    mech = mechanics(SYSTEMS[name])
    at = binding.functions(mech, twin)
    assert all((a < 0) == twin for a in at)      # (a handle is never an address)
    PC, SF, KN, DM = (tiers.callable_at(a) for a in at)
    p = np.array([mech.defaults[n] for n in mech.parameters], dtype=float)
    n, k = mech.n, len(mech.contacts)
    rng = np.random.default_rng(3)
    for _ in range(5):
        y = rng.normal(size=2 * n)
        t = float(rng.uniform(0.0, 5.0))
        flat = np.zeros(flow.sizes(n, k)[0])
        PC(flat, y, p, t)
        want = np.array(mech._pieces(*y, *p, t), dtype=float)
        assert np.allclose(flat, want, rtol=1e-14, atol=1e-14)
        if mech.n_domain:
            dom = np.zeros(mech.n_domain)
            DM(dom, y, p, t)
            assert np.allclose(dom, mech.domain(*y[:n], *p), rtol=1e-14, atol=1e-14)
        s = np.zeros(2 * k)
        SF(s, y, p, t)
        assert np.allclose(s, np.concatenate(mech.surface(p, t)), rtol=1e-14, atol=1e-14)
        speed = np.abs(rng.normal(size=k))
        kin = speed.copy()
        KN(kin, y, p, t)
        if mech._kinetic is not None:
            want = mech.kinetic(y[:n], y[n:], p, t, speed, None)
            assert np.allclose(kin, want, rtol=1e-14, atol=1e-14)
        else:
            assert np.array_equal(kin, speed)      # left as it is: plain Coulomb


def test_a_motion_goes_on_in_machine_code_once_it_is_compiled():
    """A motion started on the interpreted twins (the machine code not compiled yet, or
    ``PHASEMAP_JIT=off``) takes the machine code at its next phase once it is there."""
    mech = mechanics(ROD)
    p = [mech.defaults[n] for n in mech.parameters]
    with tiers.forced("off"):
        m = hybrid.Motion(mech, p, hybrid.Options(t_end=1.0))
        m.flow.refresh()
    assert m.flow.twin and m.flow.accel is not flow.accel
    with tiers.forced("eager"):
        m.flow.refresh()
    assert not m.flow.twin and m.flow.accel is flow.accel and m.flow.advance_fn is flow.advance


@pytest.mark.parametrize("S, q, u, opts", [
    (ROD, [0.7, 0.0, 0.3], [1.0, 0.5, 0.0], dict(restitution=0.5)),   # flights, bounces
    (WHEEL, [2.5591, 2.5591, 1.0], [8.2805, 8.2805, 0.0], {}),              # a hop, a landing
    (STRIBECK_BELT, [0.5, 0.0], [0.0, 0.0], {}),                          # stick-slip
])
def test_events_are_located_where_the_python_locator_finds_them(S, q, u, opts):
    """Every event step of a motion: the compiled locator (flow.locate) against the
    Python one (Motion._first_event, scipy's brentq over the same dense output and event
    functions), the same function and the same time to 1e-13 of the step."""
    mech = mechanics(S)
    p = [mech.defaults[n] for n in mech.parameters]
    m = hybrid.Motion(mech, p, hybrid.Options(t_end=2.0 if S is not STRIBECK_BELT else 12.0,
                                              **opts))
    compiled, pairs = m.flow.locate, []

    def both(Fd, t_old, t1, h, y_old, w0, w1, modes, rho, jam):
        got = compiled(Fd, t_old, t1, h, y_old, w0, w1, modes, rho, jam)
        want = m._first_event(lambda s: m.flow.dense(Fd, t_old, h, y_old, s), t_old, t1,
                              w0, w1, tuple(int(x) for x in modes), rho, None, jam)
        pairs.append((got, want, t1 - t_old))
        return got

    m.flow.locate = both
    rec = m.run(np.array(q, dtype=float), np.array(u, dtype=float))
    assert len(rec.ev_kind) >= 3 and len(pairs) >= 2
    for got, want, h in pairs:
        assert (got is None) == (want is None)
        if got is not None:
            assert got[1] == want[1] and abs(got[0] - want[0]) <= 1e-13 * h


@pytest.mark.parametrize("name", ["belt", "den_hartog", "rod", "wheel"])
def test_the_compiled_jacobian_is_the_loop_of_differences(name):
    """The field's Jacobian of the variational equations (periodic orbits' Floquet
    multipliers): the compiled one against floquet's loop of central differences of the
    phase's accelerations, bit for bit, at random states of every mode."""
    from phasemap.motion.periodic import floquet

    m = _motion(SYSTEMS[name])
    rng = np.random.default_rng(11)
    n = m.n
    checked = 0
    for _ in range(20):
        X = np.concatenate([rng.normal(size=2 * n) * 0.5, [rng.uniform(0.0, 3.0)]])
        X[:n] = np.clip(X[:n], m.bounds[:, 0] + 0.1, m.bounds[:, 1] - 0.1)
        modes = tuple(int(rng.choice([OPEN, STICK, SLIP_POS, SLIP_NEG])) for _ in range(m.k))
        got = m.flow.jacobian(X, modes, np.ones(m.k), floquet.STEP)
        if got is None:
            continue
        want = np.zeros_like(got)
        want[:n, n:2 * n] = np.eye(n)
        for j in range(2 * n + 1):
            want[n:2 * n, j] = floquet.difference(
                lambda Y: floquet.accelerations(m, Y, modes, np.ones(m.k)), X, j)
        assert np.array_equal(got, want)
        checked += 1
    assert checked >= 10


@pytest.mark.parametrize("name, z, modes", [
    ("belt", [0.3, 0.0, 0.1, 0.0], (SLIP_NEG,)),
    ("den_hartog", [0.3, 0.0, 0.5, 0.0], (SLIP_POS,)),
    ("stribeck_belt", [-0.2, 0.0, 0.6, 0.0], (SLIP_POS,)),
])
def test_a_segment_ends_where_solve_ivp_ends_it(name, z, modes):
    """A periodic orbit's segment of known length on the compiled flow (no events) against
    scipy's solve_ivp with DOP853 at the same tolerances over the same phase (the same
    method: their step sequences part by rounding, so they agree to the tolerance), and
    both against a tight solve_ivp."""
    from types import SimpleNamespace

    from phasemap.motion.periodic import segments

    m = _motion(SYSTEMS[name])
    z = np.array(z)
    seg = SimpleNamespace(modes=modes, rho=np.ones(m.k))
    scale = 1.0 + np.abs(z).max()
    got = m.flow.segment(z, 0.3, 2.0, modes, None, 1e-10, 1e-10 * scale)
    want = segments.flow(m, z, 0.3, 2.0, seg, 1e-10).y[:, -1]
    tight = segments.flow(m, z, 0.3, 2.0, seg, 1e-13).y[:, -1]
    assert np.abs(got - want).max() <= 1e-9 * scale
    assert np.abs(got - tight).max() <= 1e-9 * scale
    assert np.abs(want - tight).max() <= 1e-9 * scale


def test_an_event_seen_at_a_steps_end_is_not_lost_to_rounding():
    """An event function negative at the step's end as the step saw it, but not on the
    dense output there (an ulp apart): the event falls at the step's end (scipy's brentq
    would raise; returning no event would leave the function unwatched for the rest of
    the phase).  And an empty step's dense output is its state, as scipy's."""
    m = _motion(ROD)
    q, u = np.array([0.7, 0.0, 0.3]), np.array([0.0, 0.5, 0.0])
    modes, rho = np.zeros(1, dtype=np.int64), np.ones(1)
    y = np.concatenate([q, u])
    Fd = np.zeros((7, 6))                       # a step that does not move: dense(t) = y
    w0 = m.watch(q, u, modes, rho, None, 0.0, 0.0)
    w1 = w0.copy()
    j = int(np.flatnonzero(np.isfinite(w0) & (w0 > 0.0))[0])
    w1[j] = -1e-300
    assert m.flow.locate(Fd, 0.0, 0.01, 0.01, y, w0, w1, modes, rho, 0.0) == (0.01, j)
    assert np.array_equal(m.flow.dense(Fd, 0.5, 0.0, y, 0.5), y)


def test_the_rod_in_flight_lands_where_its_parabola_says():
    """The Painleve rod (half-length l = 1) let go at theta = 0.7 with its end 0.3 above
    the floor and a spin of 1 rad/s: in flight its centre falls freely from its first
    rate l cos 0.7 upwards and it spins uniformly, so its end reaches the floor where
    0.3 + l sin 0.7 + l cos 0.7 t - g t^2 / 2 - l sin(0.7 + t) = 0."""
    import math

    from scipy.optimize import brentq

    mech = mechanics(ROD)
    d = mech.defaults
    g, l = d["g"], d["l"]
    m = hybrid.Motion(mech, [d[n] for n in mech.parameters], hybrid.Options(t_end=0.6))
    assert not m.flow.twin
    rec = m.run(np.array([0.7, 0.0, 0.3]), np.array([1.0, 0.0, 0.0]))
    land = brentq(lambda t: 0.3 + l * math.sin(0.7) + l * math.cos(0.7) * t
                  - 0.5 * g * t * t - l * math.sin(0.7 + t), 1e-6, 0.6, xtol=1e-15)
    assert rec.ev_t[1] == pytest.approx(land, abs=1e-9)


def _segment_case(name):
    """A phase of ``name`` and a start ``X = (q, u, t)`` in it, for a segment of 2 s."""
    z, modes = {"belt": ([0.3, 0.0, 0.1, 0.0], (SLIP_NEG,)),
                "den_hartog": ([0.3, 0.0, 0.5, 0.0], (SLIP_POS,)),
                "stribeck_belt": ([-0.2, 0.0, 0.6, 0.0], (SLIP_POS,)),
                "rod": ([0.7, 0.5, 0.3, 0.2, 0.5, -0.4], (OPEN,))}[name]
    return _motion(SYSTEMS[name]), np.array(z + [0.3]), modes


@pytest.mark.parametrize("name", ["belt", "den_hartog", "stribeck_belt", "rod"])
def test_the_compiled_transition_matrix_is_the_variational_flow(name):
    """A segment's transition matrix (periodic orbits' monodromy) on the compiled flow
    against the variational equations on solve_ivp (the same method and tolerances: they
    part by rounding), and both against central differences of the segment's end (the
    compiled flow at a tight tolerance), an independent derivative of the flow map."""
    from types import SimpleNamespace

    from phasemap.motion.periodic import floquet, segments

    m, X, modes = _segment_case(name)
    n2 = 2 * m.n
    tau = 2.0
    seg = SimpleNamespace(modes=modes, rho=np.ones(m.k))
    got = m.flow.transition(X, tau, modes, None, 1e-11, 1e-11 * (1.0 + np.abs(X).max()),
                            floquet.STEP)
    kernel = m.flow.transition
    m.flow.transition = lambda *a, **k: None     # segments.transition's solve_ivp path
    try:
        want = segments.transition(m, X, tau, seg, 1e-11)
    finally:
        m.flow.transition = kernel
    assert got.shape == (n2 + 1, n2 + 1)
    assert np.abs(got - want).max() <= 1e-8 * np.abs(want).max()

    def end(Y):
        return np.append(m.flow.segment(Y[:n2], Y[n2], tau, modes, None, 1e-13, 1e-13),
                         Y[n2] + tau)
    fd = np.column_stack([floquet.difference(end, X, j) for j in range(n2 + 1)])
    assert np.abs(got - fd).max() <= 1e-5 * np.abs(fd).max()
    assert np.array_equal(got[n2], np.eye(n2 + 1)[n2])     # the time row


@pytest.mark.parametrize("name", ["belt", "rod"])
def test_a_segments_samples_are_solve_ivps_dense_output(name):
    """The states of a segment at given times on the compiled flow's dense output, against
    solve_ivp's ``dense_output`` over the same phase, and asking for them leaves the
    segment's end as it was, bit for bit."""
    from types import SimpleNamespace

    from phasemap.motion.periodic import segments

    m, X, modes = _segment_case(name)
    n2 = 2 * m.n
    z, t, tau = X[:n2], X[n2], 2.0
    scale = 1.0 + np.abs(z).max()
    times = np.linspace(t, t + tau, 37)
    end, states = m.flow.segment(z, t, tau, modes, None, 1e-10, 1e-10 * scale, times=times)
    assert np.array_equal(end, m.flow.segment(z, t, tau, modes, None, 1e-10, 1e-10 * scale))
    assert states.shape == (times.size, n2)
    assert np.array_equal(states[0], z) and np.array_equal(states[-1], end)
    seg = SimpleNamespace(modes=modes, rho=np.ones(m.k))
    sol = segments.flow(m, z, t, tau, seg, 1e-10, dense=True)
    want = np.array([sol.sol(s) for s in times])
    assert np.abs(states - want).max() <= 1e-9 * scale
    # one time asked alone (a search between the samples) gets a sample's own bits there
    for i in (0, 5, 36):
        assert np.array_equal(segments.at(m, z, t, tau, seg, 1e-10, times[i]), states[i])


@pytest.mark.parametrize("name", ["belt", "rod", "wheel", "rod_on_step"])
def test_the_batch_of_reactions_is_each_states_solve(name):
    """The reactions a Dataset records, in one compiled call, against the engine's solve of
    each state alone: the same bits, and the same states without one."""
    m = _motion(SYSTEMS[name])
    rng = np.random.default_rng(5)
    n = m.n
    ts, ys, modes = [], [], []
    for _ in range(40):
        y = rng.normal(size=2 * n) * 0.5
        y[:n] = np.clip(y[:n], m.bounds[:, 0] + 0.1, m.bounds[:, 1] - 0.1)
        ts.append(rng.uniform(0.0, 3.0))
        ys.append(y)
        modes.append([int(rng.choice([OPEN, STICK, SLIP_POS, SLIP_NEG])) for _ in range(m.k)])
    N, F, status = m.flow.reactions(np.array(ts), np.array(ys), np.array(modes))
    solved = 0
    for i in range(len(ts)):
        sol = m.solve(ys[i][:n], ys[i][n:], tuple(modes[i]), None, ts[i])
        if status[i] == flow.OK:
            assert np.array_equal(N[i], sol[1]) and np.array_equal(F[i], sol[2])
            solved += 1
        else:
            assert np.isnan(N[i]).all() and np.isnan(F[i]).all()
            assert status[i] == flow.REDUNDANT or sol is None
    assert solved >= 20


def test_the_twin_computes_a_transition_matrix_and_reactions_as_the_machine_code():
    """The periodic orbits' transition matrix and a Dataset's reactions on the interpreted
    twins (``PHASEMAP_JIT=off``) and on the machine code: the same bits."""
    from phasemap.motion.periodic import floquet

    mech = mechanics(STRIBECK_BELT)
    p = [mech.defaults[n] for n in mech.parameters]
    X = np.array([-0.2, 0.0, 0.6, 0.0, 0.3])
    out = []
    for how in ("off", "eager"):
        with tiers.forced(how):
            m = hybrid.Motion(mech, p, hybrid.Options(t_end=1.0))
            assert m.flow.twin == (how == "off")
            out.append((m.flow.transition(X, 0.5, (SLIP_POS,), None, 1e-9, 1e-9,
                                          floquet.STEP),
                        *m.flow.reactions(np.array([0.3, 0.4]), np.array([X[:4], X[:4] * 2]),
                                          np.array([[SLIP_POS], [STICK]]))))
    for a, b in zip(*out):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("name", ["belt", "den_hartog", "rod"])
def test_a_segments_kept_steps_give_its_samples_bits(name):
    """A segment integrated once with every step's dense output kept (what an orbit's
    checks share, ``Phase.steps``): its end and its states at any times are the bits of
    the segment stepped again for each of them (``Phase.segment``), the interpreted twin's
    the machine code's, and a segment too long for the first arrays grows them."""
    from types import SimpleNamespace

    from phasemap.motion.periodic import segments

    m, X, modes = _segment_case(name)
    n2 = 2 * m.n
    z, t, tau = X[:n2], X[n2], 2.0
    atol = 1e-10 * (1.0 + np.abs(z).max())
    times = np.sort(np.concatenate([np.linspace(t, t + tau, 11),
                                    np.random.default_rng(3).uniform(t, t + tau, 20)]))
    kept = m.flow.steps(z, t, tau, modes, None, 1e-10, atol)
    end, states = m.flow.segment(z, t, tau, modes, None, 1e-10, atol, times=times)
    assert np.array_equal(kept.end, end)
    assert np.array_equal(kept.at(times), states)
    assert np.array_equal(kept.at(times[::-1]), states[::-1])     # in any order
    assert kept.count > 1                           # (the times fall in several steps)
    for s in (t, t + 0.37 * tau, t + tau):          # one at a time, as a search asks
        assert np.array_equal(kept.at(s)[0], segments.at(
            m, z, t, tau, SimpleNamespace(modes=modes, rho=np.ones(m.k)), 1e-10, s))
    with tiers.forced("off"):
        twin = _motion(SYSTEMS[name])
        assert twin.flow.twin
        got = twin.flow.steps(z, t, tau, modes, None, 1e-10, atol)
    assert np.array_equal(got.end, end) and np.array_equal(got.at(times), states)
    if name != "rod":       # (an oscillator's long segment: more steps than 64)
        long = m.flow.steps(z, t, 60.0, modes, None, 1e-14, 1e-14)
        assert long.count > 64
        assert np.array_equal(long.end, m.flow.segment(z, t, 60.0, modes, None, 1e-14, 1e-14))
    assert m.flow.steps(z, t, 0.0, modes, None, 1e-10, atol).at([t])[0].tolist() == z.tolist()
    # a time outside the segment has no state on its steps
    assert np.isnan(kept.at([t - 1e-3, t + tau + 1e-3])).all()


@pytest.mark.parametrize("name", ["belt", "den_hartog", "stribeck_belt", "rod"])
def test_directions_carried_alone_are_the_transition_matrix_applied_to_them(name):
    """The variational equations of a few directions alone (each ``A d`` by central
    differences along ``d``: what the Floquet multipliers carry) against the whole
    transition matrix applied to them, and the batch of event functions against each
    state's."""
    from phasemap.motion.periodic import floquet

    m, X, modes = _segment_case(name)
    n2 = 2 * m.n
    tau = 2.0
    atol = 1e-11 * (1.0 + np.abs(X).max())
    Phi = m.flow.transition(X, tau, modes, None, 1e-11, atol, floquet.STEP)
    D = np.random.default_rng(5).normal(size=(n2 + 1, 3))
    D[n2] = 0.0                     # (the time's component: none, as the orbits' are)
    D[:, 2] = 0.0                   # (a zero direction stays zero)
    got = m.flow.transition(X, tau, modes, None, 1e-11, atol, floquet.DIRECTIONAL_STEP,
                            directions=D)
    want = Phi @ D
    assert got.shape == (n2 + 1, 3)
    assert np.abs(got - want).max() <= 1e-7 * np.abs(want).max()
    assert np.array_equal(got[n2], np.zeros(3)) and not got[:, 2].any()
    # the phase's event functions at states along it, in one call and one at a time
    ts = X[n2] + np.linspace(0.0, tau, 9)
    ys = m.flow.segment(X[:n2], X[n2], tau, modes, None, 1e-10, atol, times=ts)[1]
    sc = m.scales_at(X[:m.n], X[m.n:n2], X[n2])
    many = m.watch_many(ts, ys, modes, None, sc)
    for i in range(ts.size):
        assert np.array_equal(many[i], m.watch(ys[i, :m.n], ys[i, m.n:], modes, None, sc,
                                               ts[i]))


def test_the_flows_dop853_tables_are_scipys_and_importing_phasemap_leaves_scipy_integrate():
    """The compiled flow's DOP853 tables are scipy's own, bit for bit, read from their file
    without importing scipy.integrate: a process that imports phasemap (to classify, to
    map) does not pay for scipy.integrate (0.4 s)."""
    import subprocess
    import sys

    from scipy.integrate._ivp import dop853_coefficients as dc

    for name in ("A", "C", "B", "E3", "E5", "D"):
        assert np.array_equal(getattr(flow, f"_{name}"), getattr(dc, name)), name
    code = "import sys, phasemap; print('scipy.integrate' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and r.stdout.split() == ["False"], r.stderr


def _scales(q, u, P):
    """The scales of a state, by NumPy (LAPACK's solve): the oracle of flow.scales."""
    M, h, g, J, b, mu = P
    ud0 = np.linalg.solve(M, h)
    k = len(g)
    acc = float(np.abs(J @ ud0).max() + np.abs(b).max()) if k else 1.0
    force = float(np.abs(h).max() + np.abs(M).max() * np.abs(ud0).max())
    vel = float(np.abs(J @ u).max()) if k else 0.0
    length = float(1.0 + np.abs(q).max())
    return (max(vel, math.sqrt(acc * length), 1e-300), max(force, 1e-300),
            max(acc, 1e-300), length)


def _candidates(m, q, u, t, P, sc):
    """Each contact's candidate modes, by the rules written out here: the oracle of the
    compiled survey's."""
    M, h, g, J, b, mu = P
    v = J[:, :2, :] @ u - np.column_stack([np.zeros(m.k), m.surf(t)])
    out = []
    for c in range(m.k):
        vn, vt = v[c]
        if m.one_sided[c] and (g[c] > TOL * sc[3] or vn > TOL * sc[0]):
            out.append((OPEN,))
            continue
        ms = (OPEN,) if m.one_sided[c] else ()
        if mu[c] == 0.0:
            ms += (SMOOTH,)
        elif abs(vt) > TOL * sc[0]:
            ms += (SLIP_POS if vt > 0 else SLIP_NEG,)
        else:
            ms += (STICK, SLIP_POS, SLIP_NEG)
        out.append(ms)
    return out


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_the_admissible_phases_in_one_call_are_those_of_each_phase_alone(name):
    """flow.survey (the scales, the candidate modes and every admissible phase at a
    state, in one compiled call) against the engine's per-phase path (Motion.each_phase:
    Motion.admissible of each phase, whose tests are flow.admits; what the engine runs
    for redundant contacts): the same phases in the same order, the same signs of N and
    the same bits, on states put on every contact, some at relative rest, with events'
    preferences and flipped signs.  Its scales agree with NumPy's to 1e-12 and its
    candidate modes with the rules written out here; its groups are numpy's allclose."""
    m = _motion(SYSTEMS[name])
    rng = np.random.default_rng(11)
    compared = several = 0
    for _ in range(200):
        if compared >= 20:
            break
        q = rng.normal(size=m.n) * 0.3 + np.where(np.isfinite(m.bounds[:, 0]),
                                                   m.bounds[:, 0] + 0.6, 0.0)
        q = np.clip(q, m.bounds[:, 0] + 1e-3, m.bounds[:, 1] - 1e-3)
        u = rng.normal(size=m.n) * 0.5
        t = float(rng.uniform(0.0, 3.0))
        held = [c for c in range(m.k) if rng.random() < 0.6]
        try:
            q, u = m.project(q, u, list(range(m.k)), held, t=t)
        except np.linalg.LinAlgError:
            continue
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(u))):
            continue
        P = m.mech.pieces(q, u, m.p, t)
        prefer = {c: int(rng.choice([SLIP_POS, SLIP_NEG, OPEN])) for c in range(m.k)
                  if rng.random() < 0.3}
        flip = tuple(c for c in range(m.k) if rng.random() < 0.3)
        sc, cand, got = m.flow.survey(np.concatenate([q, u]), t, flip, prefer, m.mech.plain)
        assert np.allclose(sc, m.scales(q, u, P), rtol=1e-13, atol=0)   # (its own pieces)
        assert np.allclose(sc, _scales(q, u, P), rtol=1e-12, atol=0)
        assert cand == _candidates(m, q, u, t, P, sc)
        if got is None:     # redundant contacts: the engine's own pick
            continue
        want = m.each_phase(q, u, cand, sc, prefer, t, flip)
        assert [x[0] for x in got] == [x[0] for x in want]
        for (_, a, _), (_, b) in zip(got, want):
            for x, y in zip(a, b):
                assert np.array_equal(x, y)
        firsts, ids = [], []     # groups by numpy's allclose with each group's first
        for _, a, _ in got:
            same = [i for i, f in enumerate(firsts)
                    if np.allclose(f, a[0], rtol=1e-7, atol=1e-7 * sc[2])]
            ids.append(same[0] if same else len(firsts))
            if not same:
                firsts.append(a[0])
        assert [x[2] for x in got] == ids
        compared += 1
        several += len(got) > 1 or any(len(ms) > 1 for ms in cand)
    assert compared >= 20 and several >= 5, (compared, several)


def _numpy_project(m, q, u, closed, held=(), fixed=(), moving=None, t=0.0):
    """Motion.project as NumPy computed it until 2026-12-02 (the engine's code of then):
    Newton on the gaps with LAPACK's ``solve``, then the velocities by ``lstsq``."""
    mech, p = m.mech, m.p
    closed = list(closed)
    moving = closed if moving is None else list(moving)
    if not closed:
        return q, u
    q0, q = q, q.copy()
    for _ in range(20):
        M, h, g, J, b, mu = mech.pieces(q, u, p, t)
        r = g[closed]
        if np.abs(r).max() <= 4e-16 * (1.0 + np.abs(q).max()):
            break
        G = J[closed, 0]
        if fixed:
            G = np.vstack([G, np.eye(m.n)[list(fixed)]])
            r = np.concatenate([r, np.zeros(len(fixed))])
        X = np.linalg.solve(M, G.T)
        q = q - X @ np.linalg.solve(G @ X, r)
        for j in fixed:
            q[j] = q0[j]
    return q, _numpy_project_velocity(m, q, u, moving, held, t)


def _numpy_project_velocity(m, q, u, moving, held=(), t=0.0):
    if not moving and not held:
        return u
    M, h, g, J, b, mu = m.mech.pieces(q, u, m.p, t)
    rolling = [c for c in moving if m.rolls[c]]
    A = np.array([J[c, 0] for c in moving] + [J[c, 2] for c in rolling]
                 + [J[c, 1] for c in held])
    X = np.linalg.solve(M, A.T)
    target = A @ u
    if held and not m.mech.plain:
        target[len(moving) + len(rolling):] -= m.surf(t)[list(held)]
    return u - X @ np.linalg.lstsq(A @ X, target, rcond=None)[0]


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_the_compiled_projection_is_numpys(name):
    """Random states off their contacts, random closed, moving (a landing contact keeps
    its approach), held (sticking: with the surface) and fixed sets, redundant rows among
    them: the compiled projection (pivoted Cholesky of the reduced matrix) against the
    NumPy code it replaced (LAPACK's solve and least squares), to 1e-10; where that
    refused the Newton step (dependent rows: a fixed coordinate that moves a gap alone),
    a LinAlgError too.  The projected state on its gaps' zero, its closed contacts'
    normal velocities zero and its held ones moving with their surface; the fixed
    coordinates unmoved; the velocities alone (project_velocity) as NumPy's; and the
    twin's bits the machine code's."""
    S = SYSTEMS[name]
    m = _motion(S)
    with tiers.forced("off"):
        twin = _motion(S)
    assert twin.flow.twin and not m.flow.twin
    rng = np.random.default_rng(11)
    k, n = m.k, m.n
    q_mid = np.array([m.mech.defaults[c] for c in m.mech.coordinates])
    redundant = refused = compared = 0
    for _ in range(80):
        q = q_mid + 0.05 * rng.standard_normal(n)
        u = rng.standard_normal(n)
        closed = [c for c in range(k) if rng.random() < 0.8] or [int(rng.integers(k))]
        held = tuple(c for c in closed if rng.random() < 0.6)
        fixed = tuple(j for j in range(n) if rng.random() < 0.2)
        moving = None if rng.random() < 0.7 else closed[:-1]
        t = float(rng.random())
        try:
            want = _numpy_project(m, q, u, closed, held, fixed, moving, t)
        except np.linalg.LinAlgError:
            want = None
        try:
            got = m.project(q, u, closed, held=held, fixed=fixed, moving=moving, t=t)
        except np.linalg.LinAlgError:
            with pytest.raises(np.linalg.LinAlgError):
                twin.project(q, u, closed, held=held, fixed=fixed, moving=moving, t=t)
            refused += 1
            M, h, g, J, b, mu = m.mech.pieces(q, u, m.p, t)
            G = np.vstack([J[closed, 0], np.eye(n)[list(fixed)]])
            assert want is None or np.linalg.matrix_rank(G) < len(G)
            continue
        assert np.array_equal(np.concatenate(got), np.concatenate(
            twin.project(q, u, closed, held=held, fixed=fixed, moving=moving, t=t)))
        assert want is not None
        compared += 1
        for a, b in zip(got, want):
            assert np.allclose(a, b, rtol=1e-10, atol=1e-10), (closed, held, fixed, a, b)
        qp, up = got
        assert np.all(qp[list(fixed)] == q[list(fixed)])
        M, h, g, J, b, mu = m.mech.pieces(qp, up, m.p, t)
        assert np.abs(g[closed]).max() <= 1e-12 * (1 + np.abs(qp).max())
        rows = closed if moving is None else moving
        A = np.vstack([J[rows, 0], J[[c for c in rows if m.rolls[c]], 2], J[list(held), 1]])
        if np.linalg.matrix_rank(A) < len(A):
            redundant += 1
            continue
        scale = 1 + np.abs(u).max()
        assert np.abs(A[:len(rows)] @ up).max(initial=0.0) <= 1e-12 * scale
        for c in held:
            assert abs(J[c, 1] @ up - m.surf(t)[c]) <= 1e-12 * scale
        assert np.allclose(m.project_velocity(q, u, (), held, t),
                           _numpy_project_velocity(m, q, u, [], held, t), rtol=1e-10,
                           atol=1e-10)
    assert compared >= 40
    assert redundant or 2 * k <= n      # (redundant rows met where there can be)
    a, b = m.project(q, u, [])
    assert a is q and b is u            # nothing closed: the state as it is


@pytest.mark.parametrize("bad", ["mass", "state"])
def test_a_projection_without_a_finite_answer_is_refused(bad):
    """A singular mass matrix (the rod's m = 0: a LinAlgError, as NumPy's solve gave) or a
    state that is not finite: never the state handed back unprojected."""
    m = _motion(ROD, m=0.0) if bad == "mass" else _motion(ROD)
    q = np.array([m.mech.defaults[c] for c in m.mech.coordinates]) + 0.01
    u = np.array([0.1, -0.2, 0.3])
    if bad == "state":
        q[1] = np.nan
    with pytest.raises(np.linalg.LinAlgError, match="cannot be projected"):
        m.project(q, u, [0])
    if bad == "mass":
        with pytest.raises(np.linalg.LinAlgError):
            _numpy_project(m, q, u, [0])


def test_the_kernels_without_reference_counts_leave_no_array_behind():
    """The flow's kernels that allocate nothing run without numba's reference counts
    (``_nrt=False``; flow.ALLOCATING lists the others, and numba refuses an allocation
    in them, their callees' included).  A motion through a lift-off, a flight and a
    landing, a periodic orbit continued (segments, transition matrices, projections) and
    a full map, which pass arrays between both kinds and through the declaration's
    functions at their addresses, free every array numba allocated for them."""
    import phasemap
    from conftest import numba_arrays
    from numba.core.dispatcher import Dispatcher

    kernels = {name: fn for name, fn in vars(flow).items() if isinstance(fn, Dispatcher)
               and fn.targetoptions.get("inline") != "always"}    # (inlined: the caller's)
    assert set(flow.ALLOCATING) <= set(kernels)
    lean = {name for name, fn in kernels.items() if fn.targetoptions.get("_nrt") is False}
    assert lean == set(kernels) - set(flow.ALLOCATING)
    assert {"accel", "advance", "watch", "locate", "project"} <= lean

    def work():
        ds = phasemap.simulate("ladder", t_end=1.0, phi=math.radians(30.0), omega=0.0,
                               f=0.0, l=0.5)
        orbit = phasemap.periodic_orbit("den_hartog")
        branch = phasemap.continue_orbit(orbit, "f", (0.2, 0.5), steps=10, max_points=3)
        scene = phasemap.Scene("belt", axes={"x": np.linspace(-1.0, 1.0, 3),
                                             "xdot": np.linspace(-1.0, 1.0, 3)})
        return ds, branch, scene.compute()

    with tiers.forced("eager"):
        work()                       # compiled and loaded before counting
        with numba_arrays() as counted:
            ds, branch, maps = work()
            kinds = [int(k) for k in ds.event_kind.values]
            vertices, cells = branch.sizes["vertex"], int(maps["n_solutions"].count())
            del ds, branch, maps         # (arrays numba made may live in them)
    assert phasemap.Event.LIFTOFF in kinds and vertices >= 3 and cells >= 9
    assert counted["allocated"] > 0 and counted["allocated"] == counted["freed"]
