"""The brute-force orbit diagram (issue 39): the settled motion's stroboscopic points over
a parameter, each checked against the return map of the test's own (scipy alone,
tests/references/duffing_fold.py), and against the branches continue_orbit follows."""

import numpy as np
import pytest

import phasemap
from phasemap.core import events as ev

#: the oscillators' compiled phase functions are test_periodic's: one worker builds them
XDIST_GROUP = "tests/test_periodic.py"

#: Den Hartog's oscillator x'' + x = cos(0.8 t) - f sgn x' in the reference's names.
_DEN_HARTOG = {"F": 1.0, "Omega": 0.8, "k1": 1.0, "beta": 0.0, "c": 0.0}
#: Ueda's oscillator with dry friction (the reference's DOUBLING) in the model's names.
_UEDA = {"Omega": 1.0, "f": 0.01, "k": 0.0, "beta": 1.0, "c": 0.05}


def _fixed_point(z0, **at):
    """The period-one orbit's point at phase 0 near ``z0``: z = P(z), P the reference's
    time-T map of the flow from t = 0 (solve_ivp, the sign of x' flipped at each
    reversal), solved by scipy's root."""
    from references import duffing_fold as ref
    from scipy.optimize import root

    z = root(lambda z: ref.return_map(z, **at) - z, z0, tol=1e-13).x
    assert np.max(np.abs(ref.return_map(z, **at) - z)) < 1e-10
    return z


@pytest.fixture(scope="module")
def den_hartog():
    return phasemap.orbit_diagram("den_hartog", "f", [0.3, 0.5], periods=3, settle=100)


def test_den_hartog_points_are_the_fixed_point_of_the_return_map(den_hartog):
    """Each non-stop orbit is one point per forcing period, the fixed point of the
    reference's return map (1e-7 apart at rtol 1e-8 after 100 periods), and every motion
    ran through."""
    d = den_hartog
    assert d.x.dims == ("f", "cycle") and d.sizes["cycle"] == 3
    assert d.multiple.values.tolist() == [1, 1]
    assert set(d.fate.values.tolist()) == {ev.HORIZON}
    for j, f in enumerate(d.f.values):
        z = _fixed_point([d.x.values[j, -1], d.xdot.values[j, -1]], r=f, **_DEN_HARTOG)
        assert np.abs(d.x.values[j] - z[0]).max() < 1e-6
        assert np.abs(d.xdot.values[j] - z[1]).max() < 1e-6
    assert np.all(d.y.values == 0.0)        # on the floor all along


def test_diagram_dataset_is_self_describing_and_writes_a_cf_file(den_hartog, tmp_path):
    """Units and long names from the declaration, the fate's flags, the settings as
    attributes; a netCDF file that xarray reads back identical and that passes the CF
    checker."""
    import xarray as xr

    from conftest import require_tool
    from phasemap.atlas.cfcheck import cfcheck

    d = den_hartog
    assert d.f.attrs["units"] == "1" and d.x.attrs["units"] == "m"
    assert d.xdot.attrs["units"] == "m s-1"
    assert d.fate.attrs["flag_meanings"] == ev.EVENT_MEANINGS
    assert d.attrs["phasemap_kind"] == "orbit_diagram" and d.attrs["phasemap_parameter"] == "f"
    assert phasemap.plot.atlas_kind(d) == "orbit_diagram"
    path = tmp_path / "diagram.nc"
    d.to_netcdf(path)
    back = xr.open_dataset(path)
    xr.testing.assert_identical(back.load(), d)
    require_tool("cfchecks", "pip install cfchecker; needs libudunits2-0")
    report, passed = cfcheck(path)
    assert passed and "WARNINGS given: 0" in report, report


def test_a_chunked_diagram_is_the_eager_one(den_hartog):
    """chunks= gives dask-backed arrays whose values are the eager diagram's, bit for
    bit (each value's motion is the same whichever block runs it)."""
    lazy = phasemap.orbit_diagram("den_hartog", "f", [0.3, 0.5], periods=3, settle=100,
                                  chunks=1)
    assert lazy.x.chunks == ((1, 1), (3,))
    for name in ("x", "xdot", "fate", "multiple"):
        assert np.array_equal(lazy[name].values, den_hartog[name].values, equal_nan=True)


def test_ueda_period_one_orbit_is_seen_only_where_it_is_stable():
    """Ueda's oscillator regains the stability of its period-one orbit through a period
    doubling at F = 8.0115 (the reference's F_DOUBLING).  Above it the settled motion
    from near the orbit is the fixed point of the reference's return map; below it the
    motion leaves the orbit (no period one)."""
    from references import duffing_fold as ref

    start = {**{k: v for k, v in _UEDA.items()}, "x": 2.38, "xdot": -0.31}
    d = phasemap.orbit_diagram("duffing", "F0", [7.9, 8.05, 8.1], start=start, periods=4,
                               settle=150)
    assert d.multiple.values[0] != 1
    assert d.multiple.values[1:].tolist() == [1, 1]
    at = {"Omega": 1.0, "r": 0.01, "k1": 0.0, "beta": 1.0, "c": 0.05}
    for j in (1, 2):
        F = float(d.F0[j])
        assert F > ref.F_DOUBLING
        z = _fixed_point([d.x.values[j, -1], d.xdot.values[j, -1]], F=F, **at)
        assert np.abs(d.x.values[j] - z[0]).max() < 1e-6
        assert np.abs(d.xdot.values[j] - z[1]).max() < 1e-6


@pytest.mark.slow
def test_a_followed_sweep_shows_the_hysteresis_of_the_fold():
    """The hardening oscillator of the reference's FOLD has two stable period-one orbits
    for Omega in (1.406, 1.573).  A sweep up that follows its attractor stays on the
    large orbit at Omega = 1.5, a sweep down on the small one: each is the fixed point of
    the reference's return map there, from its own guess."""
    from references import duffing_fold as ref

    fold = {"F0": ref.FOLD["F"], "f": ref.FOLD["r"], "k": ref.FOLD["k1"],
            "beta": ref.FOLD["beta"], "c": ref.FOLD["c"]}
    up = phasemap.orbit_diagram("duffing", "Omega", [1.3, 1.4, 1.5], start=fold, periods=3,
                                settle=120, follow=True)
    down = phasemap.orbit_diagram("duffing", "Omega", [1.7, 1.6, 1.5], start=fold,
                                  periods=3, settle=120, follow=True)
    at = {**ref.FOLD, "Omega": 1.5}
    large = _fixed_point([up.x.values[-1, -1], up.xdot.values[-1, -1]], **at)
    small = _fixed_point([down.x.values[-1, -1], down.xdot.values[-1, -1]], **at)
    assert np.hypot(*large) > np.hypot(*small) + 0.5      # two distinct orbits
    assert np.abs(up.x.values[-1] - large[0]).max() < 1e-6
    assert np.abs(down.x.values[-1] - small[0]).max() < 1e-6
    assert up.multiple.values[-1] == 1 == down.multiple.values[-1]


def test_the_diagram_figure_overlays_a_branch_where_its_orbits_cross_phase_zero(den_hartog):
    """ds.phasemap.plot() draws the points against the parameter; a branch of
    continue_orbit overlaid lies on them (its section_x where the orbit crosses the
    forcing's phase 0), and the figure passes the review."""
    import matplotlib.pyplot as plt

    import figure_review as fr

    o = phasemap.periodic_orbit("den_hartog", start={"f": 0.3})
    b = phasemap.continue_orbit(o, "f", (0.3, 0.5), steps=2)
    assert b.section_x.dims == ("vertex", "section") and b.sizes["section"] == 1
    for f, z in ((0.3, 0), (0.5, -1)):          # the branch's ends are the diagram's values
        i = int(np.flatnonzero(np.isclose(b.f.values, f, rtol=0, atol=1e-12))[z])
        j = int(np.flatnonzero(den_hartog.f.values == f)[0])
        assert abs(float(b.section_x[i, 0]) - float(den_hartog.x[j, -1])) < 1e-6
        assert abs(float(b.section_xdot[i, 0]) - float(den_hartog.xdot[j, -1])) < 1e-6
    fig = den_hartog.phasemap.plot(branches=b)
    a = fig.axes[0]
    assert a.get_xlabel() == "$f$" and a.get_ylabel() == "x (m)"
    labels = [t.get_text() for t in a.get_legend().get_texts()]
    assert "settled motion, once per period" in labels and "stable orbit" in labels
    dots = a.get_lines()[0]
    assert np.array_equal(dots.get_ydata(), den_hartog.x.values.ravel())
    for check in (fr.layout_problems, fr.unit_problems, fr.legend_drawn_problems):
        assert check(fig) == [], check.__name__
    plt.close(fig)
    with pytest.raises(ValueError, match=r"^branches= takes Datasets of "
                                         r"phasemap.continue_orbit in f[^\n]*$"):
        den_hartog.phasemap.plot(branches=o)


def test_an_autonomous_oscillator_is_sampled_at_its_maxima():
    """The belt's stick-slip orbit (m = k = g = 1, f_s = 1, f_k = 0.5) reaches up to
    x_max = f_k + sqrt(delta^2 + v^2), delta = f_s - f_k: the slip starts at the stick's
    end x = 1 with the belt's speed v and swings about f_k.  Each kept maximum is that,
    to 5e-7 (the cubic through the saved steps), with x' = 0 there."""
    v = np.array([0.1, 0.2, 0.4])
    d = phasemap.orbit_diagram("belt", "v", v, periods=4, settle=10)
    want = 0.5 + np.sqrt(0.25 + v**2)
    assert np.abs(d.x.values - want[:, None]).max() < 5e-7
    assert np.abs(d.xdot.values).max() < 1e-9
    assert d.multiple.values.tolist() == [1, 1, 1]
    assert d.x.attrs["long_name"] == "x at each maximum of x"
    assert d.cycle.attrs["long_name"] == "maxima of x after the settling ones"


@pytest.mark.parametrize("model, args, kw, match", [
    ("belt", ("v", [0.1]), {"phase": 0.5}, r"belt is autonomous: its points are the maxima "
                                           r"of x, at no phase of a forcing; leave phase out"),
    ("belt", ("v", [0.1]), {"section": "z"}, r"section must name a coordinate whose maxima "
                                             r"are kept \(x, y\), got 'z'"),
    ("den_hartog", ("f", [0.3]), {"section": "x"}, r"den_hartog is forced: its points are "),
    ("den_hartog", ("g0", [1.0]), {}, r"unknown parameter 'g0'; the parameters are m, k"),
    ("den_hartog", ("f", [0.3, 0.2, 0.4]), {}, r"the values of f go back and forth"),
    ("den_hartog", ("f", [0.3, 0.3]), {}, r"the values of f repeat a value"),
    ("den_hartog", ("f", [0.3, np.nan]), {}, r"the values of f must be finite, got nan"),
    ("den_hartog", ("f", [[0.3]]), {}, r"must be a non-empty 1-D sequence"),
    ("den_hartog", ("m", [0.0, 1.0]), {}, r"m = 0 is outside its domain \(0, inf\]"),
    ("den_hartog", ("f", [0.3]), {"start": {"f": 0.2}}, r"'f' is on the diagram's axis"),
    ("den_hartog", ("f", [0.3]), {"start": [1]}, r"start must be a dict"),
    ("den_hartog", ("f", [0.3]), {"phase": 1.0}, r"phase is a fraction of the forcing "),
    ("den_hartog", ("f", [0.3]), {"periods": 0}, r"periods must be"),
    ("den_hartog", ("f", [0.3]), {"settle": -1}, r"settle must be"),
    ("den_hartog", ("f", [0.3]), {"rtol": 1e-2}, r"rtol must be in \[1e-12, 1e-4\]"),
    ("den_hartog", ("f", [0.3]), {"follow": "yes"}, r"follow must be True or False"),
    ("den_hartog", ("f", [0.3]), {"follow": True, "chunks": 1}, r"follow=True runs the "),
    ("den_hartog", ("f", [0.3]), {"chunks": 0}, r"chunks must be a positive whole number"),
    ("den_hartog", ("f", np.linspace(0.2, 0.4, 10**6)), {"periods": 10**5},
     r"the diagram's points take "),
    ("den_hartog", ("f", [0.3]), {"periods": 10**12, "chunks": 1},
     r"one motion over 1,000,000,000,100 periods keeps about "),
])
def test_orbit_diagram_errors_are_one_line(model, args, kw, match):
    with pytest.raises(ValueError, match=rf"^{model}: [^\n]*{match}[^\n]*$"
                       if not match.startswith(model) else rf"^{match}[^\n]*$"):
        phasemap.orbit_diagram(model, *args, **kw)


def test_cli_diagram_prints_the_settled_periods_and_writes_a_file_and_a_figure(capsys,
                                                                              tmp_path):
    """``phasemap diagram`` sweeps (down with --down), prints the runs of values by the
    settled motion's period, writes the netCDF file that ``phasemap info`` reads and the
    figure; a range written high end first is refused in one line."""
    import xarray as xr

    from phasemap.cli import main

    out, png = tmp_path / "dh.nc", tmp_path / "dh.png"
    code = main(["diagram", "den_hartog", "f=0.3:0.5:2", "--periods", "3", "--settle",
                 "100", "--down", "-o", str(out), "--png", str(png)])
    text = capsys.readouterr().out
    assert code == 0
    assert "2 value(s) of f from 0.5 to 0.3; 3 forcing period(s) kept after 100" in text
    assert "0.5  to 0.3  1" in text and f"wrote {out}" in text
    assert png.stat().st_size > 0 and (tmp_path / "dh.pdf").stat().st_size > 0
    with xr.open_dataset(out) as ds:
        assert ds.f.values.tolist() == [0.5, 0.3] and ds.multiple.values.tolist() == [1, 1]
    assert main(["info", str(out)]) == 0
    assert "phasemap orbit diagram" in capsys.readouterr().out
    assert main(["diagram", "den_hartog", "f=0.5:0.3:2"]) != 0
    err = capsys.readouterr().err.strip()
    assert err == ("phasemap: error: the sweep f: LO 0.5 is not below HI 0.3; every range on "
                   "the command line is written low end first: f=0.3:0.5:2 (--down sweeps "
                   "from HI)")
