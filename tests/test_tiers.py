"""The interpreter tier and ``$PHASEMAP_JIT`` (issue 40): a first answer without waiting
for numba, with the bits of the machine code, and the machine code after it."""

from __future__ import annotations

import importlib.util
import json
import math
import operator
import os
import pathlib
import random
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from numba import njit

import phasemap
from phasemap.core import interpret, tiers
from phasemap.core import numerics as nx
from phasemap.systems import get_model

#: awkward numbers for the arithmetic: signed zeros, the ends of the doubles, inf, nan
EDGES = [0.0, -0.0, 1.0, -1.0, 0.5, 3.0, -2.5, 1e-300, -1e-300, 5e-324, 1e308, -1e308,
         math.inf, -math.inf, math.nan, 0.1, 7.25, -3.75, 2.0 ** 60]


def same_bits(a, b) -> bool:
    """Equal as IEEE doubles: every NaN alike, but 0.0 and -0.0 apart."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    nan = np.isnan(a)
    if a.shape != b.shape or not np.array_equal(nan, np.isnan(b)):
        return False
    return np.array_equal(np.where(nan, 0.0, a).view(np.int64),
                          np.where(nan, 0.0, b).view(np.int64))


@njit(cache=True, error_model="numpy")
def _arithmetic(x, y):
    """Every operation the twin rewrites, and the elementary functions it wraps."""
    return (x / y, x // y, x % y, x ** 2, x ** 3, x ** 7, x ** -3, y ** 0.5, x ** y,
            x ** 2.0, x ** -1.0, x ** 1.0, x ** 0.0, y ** 1.5, math.pow(x, 3),
            math.sqrt(x), math.log(x), math.exp(x), math.sin(x), math.cos(y),
            math.atan2(x, y), math.hypot(x, y), math.pow(x, y), abs(x), max(x, y),
            min(x, y), np.sin(y), np.sqrt(y), np.isfinite(x), ~(x > y))


def _pairs():
    """The awkward numbers against each other, and random doubles of every magnitude
    (a last-bit difference, such as CPython's own hypot against the C library's, shows
    only there)."""
    rng = np.random.default_rng(40)
    mags = 10.0 ** rng.uniform(-8, 8, size=(3000, 2))
    randoms = rng.choice([-1.0, 1.0], size=(3000, 2)) * rng.uniform(0.5, 1.0, (3000, 2)) * mags
    return [(x, y) for x in EDGES for y in EDGES] + [tuple(map(float, p)) for p in randoms]


def test_the_twin_computes_numbas_numbers_on_every_awkward_pair():
    twin = interpret.interpreted(_arithmetic)
    with np.errstate(all="ignore"):
        for x, y in _pairs():
            try:
                want = _arithmetic(x, y)
            except ZeroDivisionError:  # numba's 0.0 ** -3, as Python's
                with pytest.raises(ZeroDivisionError):
                    twin(x, y)
                continue
            got = twin(x, y)
            for k, (g, w) in enumerate(zip(got, want)):
                assert same_bits(g, w), (x, y, k, g, w)


@njit(cache=True, error_model="numpy")
def _in_place(a, x):
    a /= x
    a[0] **= 3
    return a


@njit(cache=True, error_model="numpy")
def _erf(x):
    return math.erf(x)


@njit(cache=True, error_model="numpy")
def _floor(x):
    return math.floor(x)


def test_in_place_arithmetic_changes_the_callers_array_and_the_unreproduced_is_refused():
    a, b = np.array([3.0, -2.0, 0.5]), np.array([3.0, -2.0, 0.5])
    _in_place(a, 0.0)
    interpret.interpreted(_in_place)(b, 0.0)
    assert same_bits(a, b) and np.isinf(b[1])
    with pytest.raises(interpret.Unsupported, match="math.erf"):
        interpret.interpreted(_erf)      # when the twin is made, not in a call


def test_floor_is_numbas_int64_on_every_awkward_number():
    """``math.floor`` gives an int64 in machine code: NaN, the infinities and floats beyond
    int64 are x86's 'integer indefinite', where Python raises or grows its int."""
    twin = interpret.interpreted(_floor)
    for x in EDGES + [2.0 ** 63, -2.0 ** 63, -2.0 ** 63 - 2048.0, 4.5e18, -0.5]:
        assert twin(x) == _floor(x), x


_RECORD = np.dtype([("u", np.float64), ("k", np.int64)])


@njit(cache=True, error_model="numpy")
def _records(n, stable):
    """Record arrays made in the function, their fields written as attributes, and a sort."""
    out = np.empty(n, dtype=_RECORD)
    for i in range(n):
        q = out[i]
        q.u, q.k = (i * 7) % 3 * 0.5, i
    keys = np.empty(n)
    for i in range(n):
        keys[i] = out[i].u
    order = np.argsort(keys, kind="mergesort") if stable else np.argsort(keys)
    return out, order, np.flatnonzero(keys), np.zeros(2, dtype=np.int8)


def test_records_stable_sorts_and_integer_arrays_as_numba_has_them():
    """A record array's elements take their fields as attributes (numba's records), a
    stable argsort orders equal keys alike (numba's quicksort has its own order: refused),
    and the result is a plain structured array, as the machine code returns."""
    want = _records(9, True)
    got = tiers.twin(_records)(9, True)
    assert type(got[0]) is np.ndarray and got[0].dtype == want[0].dtype
    assert all(np.array_equal(a, b) and a.dtype == b.dtype for a, b in zip(got, want))
    with pytest.raises(interpret.Unsupported, match="argsort"):
        tiers.twin(_records)(9, False)


@njit(cache=True)
def _python_errors(x, y):
    return x / y


@njit(cache=True, error_model="numpy")
def _integer_powers(a, b):
    return a ** b, a ** -3, a ** 3, a // b, a % b


def test_the_python_error_model_raises_in_both_tiers_and_integer_arithmetic_agrees():
    with pytest.raises(ZeroDivisionError):
        _python_errors(1.0, 0.0)
    with pytest.raises(ZeroDivisionError):
        interpret.interpreted(_python_errors)(1.0, 0.0)
    twin = interpret.interpreted(_integer_powers)
    for a in (-3, -1, 0, 1, 2, 7):
        for b in (-2, -1, 0, 1, 5):
            assert twin(a, b) == _integer_powers(a, b), (a, b)


def _plain(x):
    return x + 1.0


@njit(cache=True)
def _calls_python(x):
    return _plain(x)


@njit(cache=True, parallel=True)
def _parallel(x):
    return x


def test_what_the_twin_cannot_reproduce_is_compiled_instead(monkeypatch):
    for f in (_calls_python, _parallel):
        with pytest.raises(interpret.Unsupported):
            interpret.interpreted(f)
    with pytest.raises(interpret.Unsupported, match="not a numba-jitted"):
        interpret.interpreted(_plain)
    monkeypatch.setenv("PHASEMAP_JIT", "off")
    assert tiers.runner(_parallel, (1.0,)) is _parallel   # no twin: the dispatcher


def test_a_bad_mode_is_one_clear_error(monkeypatch):
    monkeypatch.setenv("PHASEMAP_JIT", "sometimes")
    with pytest.raises(ValueError, match="PHASEMAP_JIT='sometimes' is not one of background, "
                                         "eager, off"):
        phasemap.classify("hinge_pendulum")
    for value, expected in (("", "background"), (" Eager ", "eager"), ("off", "off")):
        monkeypatch.setenv("PHASEMAP_JIT", value)
        assert tiers.mode() == expected


def _sample(var, rng):
    lo, hi = var.lower, var.upper
    d = var.default if var.default is not None else 1.0
    lo = lo if math.isfinite(lo) else min(d, 0.0) - 3.0 * max(abs(d), 1.0)
    hi = hi if math.isfinite(hi) else max(d, 0.0) + 3.0 * max(abs(d), 1.0)
    r = rng.random()
    x = lo if r < 0.1 else hi if r < 0.2 else 0.0 if r < 0.3 else rng.uniform(lo, hi)
    if (x == lo and var.lower_open) or (x == hi and var.upper_open) or not var._fine(x):
        x = rng.uniform(lo, hi)
    return x if var._fine(x) else d


@pytest.mark.parametrize("name", list(phasemap.MODELS))
def test_both_tiers_give_the_same_bits_on_every_model_and_layer(name):
    """Random states and parameters (a third of them at rest, a tenth on each end of every
    domain, a tenth at zero): every candidate row and every layer, bit for bit."""
    m = get_model(name)
    point = interpret.interpreted(m.point)
    summarize = interpret.interpreted(nx.summarize)
    with tiers.forced("off"):  # and it is what classify runs under PHASEMAP_JIT=off
        v = m.input_vector(m.complete({}))
        out = np.empty((len(m.branches), m.n_fields))
        assert tiers.is_twin(tiers.runner(m.point, (v, out)))
    rng = random.Random(f"tiers {name}")
    checked = 0
    while checked < 300:
        values = {k: _sample(var, rng) for k, var in m.variables.items()}
        if rng.random() < 0.35:
            values[m.velocity] = 0.0
        try:
            full = m.complete(values)
        except ValueError:  # outside the model's joint domain
            continue
        v = m.input_vector(full)
        compiled = np.full((len(m.branches), m.n_fields), np.nan)
        twin = compiled.copy()
        m.point(v, compiled)
        with np.errstate(all="ignore"):
            point(v, twin)
            layers = summarize(twin, m.stick_branch)
        assert same_bits(twin, compiled), (name, full)
        assert tuple(map(int, layers)) == tuple(map(int, nx.summarize(compiled,
                                                                      m.stick_branch)))
        checked += 1


def test_classify_answers_alike_in_every_mode(monkeypatch):
    answers = []
    for how in ("eager", "off"):
        monkeypatch.setenv("PHASEMAP_JIT", how)
        c = phasemap.classify("elliptic_pendulum", phi=0.8, xdot=0.0, f=4.0)
        answers.append((c.n_solutions, c.stagnation, c.contact_lost, c.singular,
                        [(b.name, b.status, b.accelerations, b.reactions)
                         for b in c.candidates]))
    assert answers[0] == answers[1]


def _child(tmp_path, jit: str, code: str) -> dict:
    """Run ``code`` in a fresh process with empty kernel caches of its own; it prints JSON."""
    env = dict(os.environ, PHASEMAP_JIT=jit, PHASEMAP_CACHE_DIR=str(tmp_path / "kernels"),
               NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=env,
                         capture_output=True, text=True, timeout=600, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


_CLASSIFY = textwrap.dedent("""
    import json, time
    import phasemap
    from phasemap.core import compiletime
    from phasemap.systems import get_model
    start = time.perf_counter()
    c = phasemap.classify("hinge_pendulum", phi=0.05, omega=0.0)
    from phasemap.core import tiers as _tiers
    result = {"n": c.n_solutions, "stagnation": c.stagnation, "jobs": len(_tiers._JOBS),
              "rows": [[b.name, b.accelerations, b.reactions] for b in c.candidates],
              "compiles": compiletime.count(),
              "machine": bool(get_model("hinge_pendulum").point.signatures)}
    if WAIT:  # for the background compile, then load its machine code
        import numpy as np
        from phasemap.core import tiers
        m = get_model("hinge_pendulum")
        v = m.input_vector(m.complete({"phi": 0.05, "omega": 0.0}))
        out = np.empty((len(m.branches), m.n_fields))
        sig = tuple(m.point.typeof_pyval(a) for a in (v, out))
        result.update(waited=tiers.wait_for(m.point, sig), compiles_after=compiletime.count())
    print(json.dumps(result))
""")


def test_off_never_compiles_and_background_compiles_elsewhere(tmp_path):
    off = _child(tmp_path, "off", "WAIT = False\n" + _CLASSIFY)
    assert off["compiles"] == 0 and not off["machine"]
    assert not (tmp_path / "kernels" / "compiling").exists()   # nothing in the background
    first = _child(tmp_path, "background", "WAIT = True\n" + _CLASSIFY)
    assert first["compiles"] == 0 and not first["machine"]     # answered by the twin
    assert off["jobs"] == 0 and first["jobs"] == 1   # one child for point and summarize
    assert first["waited"] and first["compiles_after"] == 0    # then loaded, not compiled
    markers = tmp_path / "kernels" / "compiling"
    deadline = time.monotonic() + 300
    while any(markers.iterdir()) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not any(markers.iterdir()), "the background compile did not finish"
    second = _child(tmp_path, "background", "WAIT = False\n" + _CLASSIFY)
    assert second["machine"] and second["compiles"] == 0        # loaded, not compiled
    assert first["rows"] == second["rows"] == off["rows"]
    assert first["n"] == second["n"] == off["n"] == 1 and second["stagnation"]


def test_the_process_loads_the_machine_code_once_the_background_has_built_it(tmp_path):
    code = """
        import json, pathlib, time
        import numpy as np
        import phasemap
        from phasemap.core import compiletime, tiers
        from phasemap.systems import get_model
        m = get_model("painleve_rod")
        seen = []
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            c = phasemap.classify(m, theta=0.6, xdot=-1.0)
            machine = bool(m.point.signatures)
            if not seen or seen[-1] != machine:
                seen.append(machine)
            if machine:
                break
            time.sleep(0.2)
        print(json.dumps({"seen": seen, "compiles": compiletime.count(),
                          "n": c.n_solutions}))
    """
    got = _child(tmp_path, "background", code)
    assert got["seen"] == [False, True] and got["compiles"] == 0


def test_a_marker_of_a_live_process_is_respected_and_a_dead_ones_taken(tmp_path):
    marker = tmp_path / "compiling" / "k"
    assert tiers._claim(marker) and marker.read_text() == str(os.getpid())
    assert not tiers._claim(marker)                  # ours, alive: another waits
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    marker.write_text(gone)
    assert tiers._claim(marker)                      # its process is gone: taken over
    old = time.time() - tiers.STALE - 10
    os.utime(marker, (old, old))
    assert tiers._claim(marker)                      # too old, whoever wrote it


def test_a_failed_background_compile_falls_back_to_compiling_here(tmp_path, monkeypatch,
                                                                   capsys):
    (tmp_path / "square_module.py").write_text(textwrap.dedent("""
        from numba import njit

        @njit(cache=True, error_model="numpy")
        def square(x):
            return x * x
    """))
    spec = importlib.util.spec_from_file_location("square_module", tmp_path / "square_module.py")
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "square_module", module)  # numba's cache finds it
    spec.loader.exec_module(module)
    square = module.square                    # a fresh file: nothing in any cache

    monkeypatch.setenv("PHASEMAP_JIT", "background")
    monkeypatch.setenv("PHASEMAP_CACHE_DIR", str(tmp_path / "kernels"))
    warm = (operator.truediv, (1, 0), {})                     # raises in the child
    assert type(tiers.runner(square, (3.0,), warm)).__name__ == "_Twin"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        f = tiers.runner(square, (3.0,), warm)
        if f is square:
            break
        time.sleep(0.2)
    assert f is square and not square.signatures
    assert not tiers.wait_for(square, (square.typeof_pyval(2.0),))  # nothing came of it
    assert f(3.0) == 9.0                                           # compiled here
    err = capsys.readouterr().err
    assert "the background compile of square failed (exit 1; its output is in " in err
    assert "ZeroDivisionError" in pathlib.Path(err.split("its output is in ")[1].split(")")[0]
                                               ).read_text()


def _without_dates(ds):
    ds = ds.copy()
    for key in ("date_created", "history"):
        ds.attrs.pop(key, None)
    return ds


@pytest.mark.parametrize("name", list(phasemap.MODELS))
def test_simulate_gives_the_same_motion_in_both_tiers(name):
    """The integrator's twin: the same Dataset, bit for bit (but its creation time), from
    the model's default start, a random one at rest and a random one; and the twin
    compiles nothing."""
    from phasemap.core import compiletime

    from phasemap.motion.integrate import integrator

    m = get_model(name)
    assert interpret.interpreted(integrator(m))   # a twin is made: off runs it
    rng = random.Random(f"simulate {name}")
    checked = tries = longest = 0
    while checked < 3 and tries < 50:
        tries += 1
        values = {v.name: _sample(v, rng) for v in m.state}
        if checked == 0:    # the model's own start
            values = {}
        elif checked == 1:  # from rest
            values[m.velocity] = 0.0
        with tiers.forced("eager"):
            try:
                machine = phasemap.simulate(name, 2.0, **values)
            except ValueError:  # outside the model's joint domain
                continue
        before = compiletime.count()
        with tiers.forced("off"):
            twin = phasemap.simulate(name, 2.0, **values)
        assert compiletime.count() == before
        assert _without_dates(twin).identical(_without_dates(machine)), (name, values)
        checked += 1
        longest = max(longest, machine.sizes["t"])
    assert checked == 3 and longest >= 8    # and not only starts that end at once


def test_a_long_motion_goes_on_to_the_machine_code_after_the_twins_budget(monkeypatch):
    """A motion the twin has not finished within its budget runs again on the machine
    code (the background compile's, or compiled here): the same Dataset either way."""
    from phasemap.motion import simulate as sim

    values = dict(phi=2.5, omega=0.0, delta=0.0)
    with tiers.forced("eager"):
        machine = _without_dates(phasemap.simulate("hinge_pendulum", 50.0, **values))
    waited = []
    real_wait = tiers.wait_for
    monkeypatch.setattr(tiers, "wait_for", lambda *a, **k: waited.append(1) or real_wait(*a))
    monkeypatch.setattr(tiers, "runner", lambda d, args, warm=None:
                        tiers._Twin(interpret.interpreted(d)))
    for budget, went_on in ((1e-4, True), (600.0, False)):
        monkeypatch.setattr(sim, "TWIN_BUDGET", budget)
        waited.clear()
        with tiers.forced("background"):
            ds = _without_dates(phasemap.simulate("hinge_pendulum", 50.0, **values))
        assert bool(waited) is went_on and ds.identical(machine)
