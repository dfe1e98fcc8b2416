"""The motion layers of a map in full coordinates (phasemap.maps.motions, issue 39): each
cell's motion to t_end (its fate, counts and end state) and its settled motion's section
points (the orbit diagram as a Scene layer), each checked against a closed form or a
scipy computation of the test's own, and against orbit_diagram's points bit for bit."""

import doctest
import importlib
import math

import numpy as np
import pytest

import phasemap
from phasemap.core import events as ev

#: the oscillators' compiled phase functions are test_periodic's: one worker builds them
XDIST_GROUP = "tests/test_periodic.py"

#: The belt of issue 39: m = k = g = 1, f_s N = 1, f_k N = 0.5, v = 0.2.
BELT = {"m": 1.0, "k": 1.0, "g": 1.0, "f_s": 1.0, "f_k": 0.5, "v": 0.2}


def _belt_from_stick(x0, t, v=0.2, fs=1.0, fk=0.5):
    """``(x, x', sticks)`` at ``t`` of the block that rides with the belt from ``x0`` at
    t = 0 (|x0| < fs): it slips where the spring's pull reaches fs (x = fs, at
    (fs - x0)/v), then x'' = -(x - fk) until x' = v again, a slip of pi + 2 arctan(v/d)
    (d = fs - fk) ending at x = 2 fk - fs, then rides to x = fs (2 d / v): the stick-slip
    orbit at once.  ``sticks`` counts the slips that ended in a stick."""
    t_slip = (fs - x0) / v
    if t < t_slip:
        return x0 + v * t, v, 0
    d = fs - fk
    slip = math.pi + 2.0 * math.atan(v / d)
    period = slip + 2.0 * d / v
    k, r = divmod(t - t_slip, period)
    if r < slip:
        return fk + d * math.cos(r) + v * math.sin(r), -d * math.sin(r) + v * math.cos(r), int(k)
    return 2 * fk - fs + v * (r - slip), v, int(k) + 1


def test_belt_fates_are_the_closed_form_stick_slip_motion():
    """Blocks that ride with the belt from x0 (|x0| < 1): at t_end each cell's end state
    and its count of sticks are the closed form's, every fate horizon (a belt never
    rests), t_rest NaN."""
    x0 = np.linspace(-0.9, 0.9, 5)
    layers = ["fate", "n_sticks", "n_reversals", "t_final", "t_rest", "x_final",
              "xdot_final", "y_final"]
    for t_end in (5.0, 12.0, 20.0):
        ds = phasemap.Scene("belt", axes={"x": x0}, fixed={"xdot": 0.2, **BELT},
                            layers=layers, options={"t_end": t_end, "rtol": 1e-10}).compute()
        assert (ds.fate.values == ev.HORIZON).all() and np.isnan(ds.t_rest.values).all()
        assert (ds.t_final.values == t_end).all() and (ds.n_reversals.values == 0).all()
        assert (ds.y_final.values == 0.0).all()       # on the belt all along
        for i, x in enumerate(x0):
            xe, ve, sticks = _belt_from_stick(x, t_end)
            assert abs(ds.x_final.values[i] - xe) < 1e-7, (t_end, x)
            assert abs(ds.xdot_final.values[i] - ve) < 1e-7, (t_end, x)
            assert ds.n_sticks.values[i] == sticks, (t_end, x)


def test_a_forced_cell_starts_at_its_own_time():
    """A map over the forcing's time t: each cell's motion starts at its t and runs
    t_end, as scipy's from that time (the end state to 1e-7, the reversals counted)."""
    t0 = np.array([0.0, 1.3, 4.0])
    ds = phasemap.Scene("den_hartog", axes={"t": t0}, fixed={"x": 2.0, "xdot": 1.0},
                        layers=["fate", "x_final", "xdot_final", "n_reversals", "t_final"],
                        options={"t_end": 12.0, "rtol": 1e-11}).compute()
    assert (ds.fate.values == ev.HORIZON).all() and (ds.t_final.values == 12.0).all()
    from references import duffing_fold as ref

    for i, t in enumerate(t0):
        # x'' + x = cos(0.8 t) - 0.2 sgn x' from t, by scipy alone (the sign of x' flipped
        # at each of its zeros; a stop raises)
        (x, xd), n = ref.flow([2.0, 1.0], t, t + 12.0, F=1.0, Omega=0.8, r=0.2, k1=1.0,
                              beta=0.0, c=0.0)
        assert abs(ds.x_final.values[i] - x) < 1e-7 and abs(ds.xdot_final.values[i] - xd) < 1e-7
        assert ds.n_reversals.values[i] == n


def test_simulate_starts_at_t0_as_a_maps_cell_does():
    """simulate(t0=...) of a forced oscillator: the state at t_end is scipy's flow from
    t0, the map's cell at t = t0 ends where it does (one motion), t_eval lies in
    [t0, t_end], and t0 is recorded; a reduced model's motion refuses it in one line."""
    from references import duffing_fold as ref

    ds = phasemap.simulate("den_hartog", 13.3, t0=1.3, rtol=1e-11, x=2.0, xdot=1.0,
                           t_eval=[1.3, 5.0, 13.3])
    assert ds.t.values.tolist() == [1.3, 5.0, 13.3] and ds.attrs["phasemap_t0"] == 1.3
    assert ds.event_t.values[0] == 1.3 and ds.x.values[0] == 2.0
    (x, xd), n = ref.flow([2.0, 1.0], 1.3, 13.3, F=1.0, Omega=0.8, r=0.2, k1=1.0,
                          beta=0.0, c=0.0)
    assert abs(ds.x.values[-1] - x) < 1e-7 and abs(ds.xdot.values[-1] - xd) < 1e-7
    assert int(np.count_nonzero(ds.event_kind.values == ev.REVERSAL)) == n
    cell = phasemap.Scene("den_hartog", axes={"t": [1.3]}, fixed={"x": 2.0, "xdot": 1.0},
                          layers=["x_final"], options={"t_end": 12.0, "rtol": 1e-11}).compute()
    assert abs(cell.x_final.values[0] - ds.x.values[-1]) < 1e-9
    assert "phasemap_t0" not in phasemap.simulate("den_hartog", 1.0, x=2.0).attrs
    for kw, match in (({"t0": 20.0}, "t_end must come after t0"),
                      ({"t0": 2.0, "t_eval": [1.0]}, r"t_eval must be .* in \[t0 = 2"),
                      ({"t": 1.0}, "a motion's start time is t0=")):
        with pytest.raises(ValueError, match=match):
            phasemap.simulate("den_hartog", 13.3, **kw)
    with pytest.raises(ValueError, match="leave t0 out"):
        phasemap.simulate("hinge_pendulum", 5.0, t0=1.0)


@pytest.fixture(scope="module")
def diagram():
    return phasemap.Scene("den_hartog", axes={"f": [0.3, 0.5]},
                          layers=["multiple", "section_x", "section_xdot", "fate"],
                          options={"periods": 3, "settle": 100, "t_end": 5.0}).compute()


def test_section_points_are_the_fixed_point_of_scipys_return_map(diagram):
    """Den Hartog's non-stop orbits: one point per forcing period (multiple 1), the fixed
    point of the return map of tests/references/duffing_fold.py (scipy alone), and
    orbit_diagram's own points bit for bit (one computation)."""
    from references import duffing_fold as ref
    from scipy.optimize import root

    d = diagram
    assert d.section_x.dims == ("f", "cycle") and d.sizes["cycle"] == 3
    assert d.multiple.values.tolist() == [1, 1]
    assert d.cycle.values.tolist() == [1, 2, 3]
    for j, f in enumerate(d.f.values):
        at = {"F": 1.0, "Omega": 0.8, "k1": 1.0, "beta": 0.0, "c": 0.0, "r": f}
        z = root(lambda z: ref.return_map(z, **at) - z,
                 [d.section_x.values[j, -1], d.section_xdot.values[j, -1]], tol=1e-13).x
        assert np.abs(d.section_x.values[j] - z[0]).max() < 1e-6
        assert np.abs(d.section_xdot.values[j] - z[1]).max() < 1e-6
    od = phasemap.orbit_diagram("den_hartog", "f", [0.3, 0.5], periods=3, settle=100)
    assert np.array_equal(od.x.values, d.section_x.values)
    assert np.array_equal(od.xdot.values, d.section_xdot.values)


def test_an_autonomous_section_is_the_stick_slip_orbits_maximum():
    """The belt's orbit layers keep each maximum of x: on the stick-slip orbit the slip's
    top, x = f_k N / k + sqrt(d^2 + v^2) (d = (f_s - f_k) N / k), one point per cycle."""
    v = np.array([0.2, 0.3])
    ds = phasemap.Scene("belt", axes={"v": v}, fixed={"x": 0.0, "xdot": 0.2},
                        layers=["multiple", "section_x"],
                        options={"periods": 3, "settle": 2}).compute()
    assert ds.multiple.values.tolist() == [1, 1]
    top = 0.5 + np.sqrt(0.25 + v ** 2)
    assert np.abs(ds.section_x.values - top[:, None]).max() < 1e-6


def test_a_period_map_is_the_same_eager_chunked_and_written(tmp_path):
    """Over two parameters: the chunked (dask) atlas, the atlas written block by block and
    Scene.compute() hold the same values; the file passes the CF checker, reads back,
    describes its cells and points, and its spec makes the same scene again."""
    import xarray as xr

    from conftest import assert_atlas_round_trip, cfchecks
    from phasemap.maps.blocks import write_scene

    scene = phasemap.Scene("den_hartog", axes={"f": [0.3, 0.45], "Omega": [0.7, 0.8]},
                           layers=["section_x", "multiple", "fate", "x_final"],
                           options={"periods": 2, "settle": 30, "t_end": 3.0})
    eager = scene.compute()
    assert eager.section_x.dims == ("f", "Omega", "cycle") and eager.x_final.dims == ("f", "Omega")
    lazy = scene.compute(chunks=1)
    assert lazy.section_x.chunks == ((1, 1), (1, 1), (2,))
    done = lazy.compute()
    # (identical but for the creation time each Dataset's history records)
    xr.testing.assert_identical(done.drop_attrs(deep=False), eager.drop_attrs(deep=False))
    when = ("history", "date_created")
    assert ({k: v for k, v in done.attrs.items() if k not in when}
            == {k: v for k, v in eager.attrs.items() if k not in when})
    path = write_scene(scene, tmp_path / "blocks.nc")
    with xr.open_dataset(path) as back:
        for name in eager.data_vars:
            np.testing.assert_array_equal(back[name].values, eager[name].values)
    report = cfchecks(path, tmp_path)
    assert "ERRORS detected: 0" in report and "WARNINGS given: 0" in report, report
    assert_atlas_round_trip(eager, tmp_path)
    # over two axes the atlas is a map: of its fates, or of the periods
    assert phasemap.plot.atlas_kind(eager) == "fate"
    assert phasemap.plot.atlas_kind(eager[["section_x", "multiple"]]) == "map"
    import matplotlib.pyplot as plt

    plt.close(eager.phasemap.plot("multiple"))
    text = phasemap.describe_atlas(path)
    assert "cells     4 = 2 f x 2 Omega" in text and "defined on 8 points" in text
    again = phasemap.Scene.from_spec(scene.spec())
    assert again.spec() == scene.spec() and again.orbit == scene.orbit
    assert scene.options.rtol == 1e-8         # the orbit layers' tolerance


def test_the_atlas_draws_as_an_orbit_diagram_with_a_branch(diagram, tmp_path):
    """ds.phasemap.plot() of section points over one axis is the orbit diagram (the
    coordinate's name on its axis), a continued branch overlaid; another layer of the
    scene draws as a profile."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from phasemap.plot import atlas_kind

    assert atlas_kind(diagram) == "orbit_diagram"
    fig = diagram.phasemap.plot()
    (ax,) = fig.axes
    dots = ax.lines[0]
    assert np.allclose(np.asarray(dots.get_ydata(), float),
                       diagram.section_x.values.ravel()) and ax.get_ylabel() == "$x$ (m)"
    assert ax.get_xlabel() == "$f$"                # the model's symbols, as its maps
    branch = phasemap.continue_orbit(phasemap.periodic_orbit("den_hartog", start={"f": 0.3}),
                                     "f", (0.3, 0.5))
    fig2 = diagram.phasemap.plot("section_x", branches=branch)
    assert len(fig2.axes[0].lines) >= 2           # the points and the branch
    fig3 = diagram.phasemap.plot("multiple")
    assert fig3.axes[0].get_xlabel().strip("$") == "f"
    from phasemap.plot.labels import axis_label

    assert axis_label(diagram, "section_x") == r"$x_{\mathrm{section}}$ (m)"
    assert axis_label(diagram, "section_xdot") == r"$\dot x_{\mathrm{section}}$ (m s$^{-1}$)"
    for f in (fig, fig2, fig3):
        plt.close(f)


@pytest.mark.parametrize("model, kw, match", [
    ("den_hartog", {"layers": ["fate"], "options": {"periods": 3}},
     "periods is an option of the orbit layers"),
    ("den_hartog", {"layers": ["fate"], "options": {"through_contacts": False}},
     "always moves through its contact changes"),
    ("den_hartog", {"layers": ["multiple"], "options": {"section": "x"}},
     "is forced: its points are taken once per forcing period"),
    ("belt", {"layers": ["multiple"], "options": {"phase": 0.5}}, "belt is autonomous"),
    ("belt", {"layers": ["section_x"], "options": {"section": "q"}}, "section must name"),
    ("den_hartog", {"layers": ["multiple"], "options": {"periods": 0}}, "periods must be"),
    ("den_hartog", {"layers": ["multiple"], "options": {"phase": 1.0}}, "phase is a fraction"),
    ("den_hartog", {"layers": ["multiple"], "options": {"settle": -1}}, "settle must be"),
    ("den_hartog", {"layers": ["multiple"], "options": {"periods": 10**12}},
     "one motion over 1,000,000,000,100 periods keeps about"),
    ("ladder", {"layers": ["fate"], "options": {"periods": 3}}, "unknown integrator option"),
])
def test_bad_motion_layer_settings_are_one_line_errors(model, kw, match):
    axis = {"f": [0.3]} if model != "belt" else {"v": [0.2]}
    with pytest.raises(ValueError, match=match) as err:
        phasemap.Scene(model, axes=axis, **kw)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("module", ["phasemap.maps.motions", "phasemap.motion.periodic.diagram"])
def test_docstring_examples(module):
    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted >= 2 and result.failed == 0


def test_section_points_that_cannot_fit_are_refused_before_any_work():
    """A million cells of 10^6 section points each (8 TB): compute() refuses in one line
    and names the ways that fit (dask chunks, or the atlas written block by block)."""
    scene = phasemap.Scene("den_hartog", axes={"f": np.linspace(0.2, 0.4, 10**6)},
                           layers=["section_x"], options={"periods": 10**6})
    assert scene.estimate(timed=False).bytes == 10**6 * 10**6 * 8      # 8 TB
    with pytest.raises(ValueError, match="more memory") as err:
        scene.compute()
    assert "\n" not in str(err.value) and "chunks=" in str(err.value)


def test_a_timed_estimate_samples_a_few_periods_and_scales_them():
    """Cells of 10^5 forcing periods are timed over SAMPLE_PERIODS of them (the same
    share kept), their time scaled by the periods, and the fate layers timed apart,
    unscaled: an estimate in seconds, not the minutes one such cell takes."""
    from phasemap.maps import motions

    scene = phasemap.Scene("den_hartog", axes={"f": [0.3, 0.4]},
                           layers=["section_x", "fate", "multiple"],
                           options={"periods": 75_000, "settle": 25_000})
    (short, factor), (rest, one) = motions.timed_parts(scene)
    assert factor == 100_000 / motions.SAMPLE_PERIODS and one == 1.0
    assert short.layers == ("section_x", "multiple") and rest.layers == ("fate",)
    assert short.orbit["periods"] + short.orbit["settle"] == motions.SAMPLE_PERIODS
    assert short.orbit["periods"] == 15 and scene.orbit["periods"] == 75_000
    assert short.evaluate()["section_x"].shape == (2, 15)
    assert scene.layers == ("section_x", "fate", "multiple")     # untouched
    small = phasemap.Scene("den_hartog", axes={"f": [0.3]}, layers=["multiple"],
                           options={"periods": 5, "settle": 5})
    assert motions.timed_parts(small) is None
    est = scene.estimate()
    assert est.seconds > 0 and math.isfinite(est.seconds)


def test_section_points_start_at_the_cells_own_time():
    """A scene over the forcing's time: a cell that starts on a phase point (t = 3 T,
    exactly) keeps that point first, so after the settling its points are those of the
    cell that starts at 0 (the same stable orbit); a cell just after it starts its
    count one period later and settles on the same points.  t_final is t_end exactly
    wherever the motion ran through."""
    T = 2 * math.pi / 0.8
    t = np.array([0.0, 1.1, 3 * T, 3 * T + 1e-3])
    ds = phasemap.Scene("den_hartog", axes={"t": t}, fixed={"f": 0.4, "x": 2.0},
                        layers=["section_x", "section_xdot", "multiple", "fate", "t_final"],
                        options={"periods": 3, "settle": 100, "t_end": 3.0}).compute()
    assert ds.multiple.values.tolist() == [1, 1, 1, 1]
    assert (ds.t_final.values == 3.0).all() and (ds.fate.values == ev.HORIZON).all()
    pts = np.stack([ds.section_x.values, ds.section_xdot.values], axis=-1)
    assert np.abs(pts - pts[0]).max() < 1e-6
    # the first point kept where a start lies on a phase point whose quotient rounds up
    from phasemap.motion.periodic.diagram import _first

    assert math.ceil(143 * T / T) == 144 and _first(143 * T, T, 0.0) == 143
    assert _first(143 * T + 1e-9, T, 0.0) == 144 and _first(1.0, T, 0.5) == 0


def test_the_command_line_writes_an_autonomous_section(tmp_path):
    """`phasemap atlas` takes the orbit layers' options, section= as a name."""
    import subprocess
    import sys

    import xarray as xr

    out = tmp_path / "belt.nc"
    r = subprocess.run([sys.executable, "-m", "phasemap.cli", "atlas", "belt", "--axis",
                        "v=0.2:0.3:2", "--set", "xdot=0.2", "--layers", "section_x,multiple",
                        "--option", "section=x", "--option", "periods=2", "--option",
                        "settle=2", "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as ds:
        assert ds.multiple.values.tolist() == [1, 1]
        top = 0.5 + np.sqrt(0.25 + ds.v.values ** 2)
        assert np.abs(ds.section_x.values - top[:, None]).max() < 1e-6
    bad = subprocess.run([sys.executable, "-m", "phasemap.cli", "atlas", "belt", "--layers",
                          "multiple", "--option", "section=q", "-o", str(tmp_path / "b.nc")],
                         capture_output=True, text=True)
    assert bad.returncode != 0 and "section must name a coordinate" in bad.stderr
    assert "Traceback" not in bad.stderr


def test_a_chunked_scene_runs_in_other_processes():
    """dask's processes scheduler: each block's scene is pickled into a worker that has
    imported none of the declaration's generated modules (the scene's model is made
    again there from its declaration); the map and motion layers equal the eager ones."""
    import dask

    scene = phasemap.Scene("den_hartog", axes={"f": [0.3, 0.4, 0.5]},
                           layers=["n_solutions", "section_x", "multiple", "fate"],
                           options={"periods": 2, "settle": 20, "t_end": 3.0})
    eager = scene.compute()
    with dask.config.set(scheduler="processes", num_workers=2):
        done = scene.compute(chunks=2).compute()
    for name in eager.data_vars:
        np.testing.assert_array_equal(done[name].values, eager[name].values)


def test_auto_chunks_count_a_cells_section_points():
    """chunks="auto" sizes the blocks by what a cell holds: with 1000 section points a
    cell, a block of the points stays within dask's chunk size (1 MiB here)."""
    import dask

    scene = phasemap.Scene("den_hartog", axes={"f": np.linspace(0.2, 0.4, 10_000)},
                           layers=["section_x", "multiple"], options={"periods": 1000})
    with dask.config.set({"array.chunk-size": "1MiB"}):
        lazy = scene.compute(chunks="auto")
    block = max(lazy.section_x.chunks[0])
    assert block * 1000 * 8 <= 2**20 and block >= 64
    assert lazy.section_x.chunks[0] == lazy.multiple.chunks[0]
    assert lazy.section_x.chunks[1] == (1000,)


def test_awkward_orbit_options_and_t0_answer_or_refuse_in_one_line():
    """Every awkward value of the fuzz (tests/fuzzing.py: NaN, huge, arrays, text, bools,
    objects...) as an orbit option of a Scene or as simulate's t0: an answer, or a
    ValueError or TypeError of phasemap's that names the argument, never a traceback's
    text or another library's error."""
    from fuzzing import AWKWARD, Tally, _judge

    tally = Tally()
    for name in ("periods", "settle", "phase", "section"):
        model, axes = ("belt", {"v": [0.2]}) if name == "section" else ("den_hartog",
                                                                        {"f": [0.3]})
        for value in AWKWARD:
            def call(name=name, value=value, model=model, axes=axes):
                return phasemap.Scene(model, axes=axes, layers=["multiple"],
                                      options={name: value}).spec()
            _judge(tally, "Scene", name, value, call)
    for value in AWKWARD:
        _judge(tally, "simulate", "t0", value, lambda value=value: phasemap.simulate(
            "den_hartog", 0.5, t0=value, max_steps=2000, t_eval=[0.5]))
    assert not tally.failures, "\n".join(tally.failures[:10])
    assert tally.refused["Scene"] > 100 and tally.answered["Scene"] >= 10
    assert tally.answered["simulate"] >= 5
