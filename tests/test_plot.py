"""Figures and the ``ds.phasemap`` accessor.

Map and profile atlases are computed by ``Scene`` on tiny grids and read
back from netCDF, as a study would; fate maps, phase curves and trajectories
are synthetic datasets in the formats their producers write.  Every figure is
drawn and saved as PNG and PDF with warnings turned into errors.
"""

from __future__ import annotations

import pathlib
import warnings

import matplotlib
import matplotlib.colors as mcolors

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import QuadMesh
from matplotlib.contour import ContourSet

import figure_review

import phasemap
import phasemap.accessor  # registers ds.phasemap
from phasemap.core import events
from phasemap import plot as pplot


ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


# --------------------------------------------------------------------------- data


def _roundtrip(ds: xr.Dataset, path) -> xr.Dataset:
    phasemap.write_atlas(ds, path)
    with xr.open_dataset(path) as opened:
        return opened.load()


@pytest.fixture(scope="module")
def elliptic_map(tmp_path_factory) -> xr.Dataset:
    """n_solutions over (phi, f) with the slider moving left: none, unique and two."""
    ds = phasemap.Scene("elliptic_pendulum",
                        axes={"phi": np.linspace(-3.14, 3.14, 60), "f": np.linspace(0, 6, 40)},
                        fixed={"xdot": -1.0},
                        layers=["n_solutions", "singular", "phi_ddot_slide_neg_Npos"]).compute()
    return _roundtrip(ds, tmp_path_factory.mktemp("atlas") / "elliptic.nc")


@pytest.fixture(scope="module")
def ladder_map(tmp_path_factory) -> xr.Dataset:
    """The ladder at rest over (phi, f): a stagnation zone phi <= 2 arctan f."""
    ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 50),
                                        "f": np.linspace(0, 1.2, 30)},
                        fixed={"omega": 0.0}).compute()
    return _roundtrip(ds, tmp_path_factory.mktemp("atlas") / "ladder.nc")


@pytest.fixture(scope="module")
def wheel_map(tmp_path_factory) -> xr.Dataset:
    """The wheel over (phi, omega): contact lost at high speed, stagnation at omega = 0."""
    ds = phasemap.Scene("wheel", axes={"phi": np.linspace(-3.14, 3.14, 61),
                                       "omega": np.linspace(-8, 8, 41)},
                        layers=["n_solutions", "stagnation", "contact_lost"]).compute()
    return _roundtrip(ds, tmp_path_factory.mktemp("atlas") / "wheel.nc")


@pytest.fixture(scope="module")
def hinge_profile(tmp_path_factory) -> xr.Dataset:
    """The hinge pendulum at rest along phi: a 1-D atlas with a stagnation zone."""
    ds = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3.14, 3.14, 81)},
                        fixed={"omega": 0.0, "delta": 0.3}).compute()
    return _roundtrip(ds, tmp_path_factory.mktemp("atlas") / "hinge.nc")


def fate_dataset() -> xr.Dataset:
    """A synthetic fate map of the hinge pendulum over (phi, omega)."""
    phi = np.linspace(-np.pi, np.pi, 48)
    omega = np.linspace(-6.0, 6.0, 36)
    P, W = np.meshgrid(phi, omega, indexing="ij")
    energy = W ** 2 / 2 + 9.81 * (1 - np.cos(P))
    fate = np.full(P.shape, events.HORIZON, np.int8)
    fate[energy < 25.0] = events.REST
    fate[(energy >= 25.0) & (energy < 27.0)] = events.NO_SOLUTION
    fate[np.abs(W) > 5.5] = events.CONTACT_LOST
    rest = fate == events.REST
    phi_rest = np.where(rest, 0.3 * np.tanh(P + 0.2 * W), np.nan)
    n_rev = np.where(rest, np.floor(energy / 5.0), 0).astype(np.int32)
    t_rest = np.where(rest, 0.5 + energy / 10.0, np.nan)
    dims = ("phi", "omega")
    return xr.Dataset(
        {
            "fate": (dims, fate, {"long_name": "how the motion ends",
                                  "flag_values": np.array(events.FATE_VALUES, np.int8),
                                  "flag_meanings": events.FATE_MEANINGS}),
            "phi_rest": (dims, phi_rest, {"long_name": "angle at rest", "units": "rad"}),
            "n_reversals": (dims, n_rev, {"long_name": "number of reversals", "units": "1"}),
            "t_rest": (dims, t_rest, {"long_name": "time to rest", "units": "s"}),
        },
        coords={"phi": ("phi", phi, {"units": "rad", "long_name": "angle of the rod"}),
                "omega": ("omega", omega, {"units": "rad s-1",
                                           "long_name": "angular velocity of the rod"})},
        attrs={"Conventions": "CF-1.8", "phasemap_model": "hinge_pendulum",
               "phasemap_fixed_delta": 0.1},
    )


def phase_curve_dataset(terminal=events.REST, stage_name="point_stage") -> xr.Dataset:
    """A synthetic phase curve in the format of ``phasemap.phase_curve``.

    Half-ellipses of decaying amplitude joined at reversals, then rest.  The
    brief's older format names the per-point stage index ``stage``
    (``stage_name="stage"``), with no stage coordinate.
    """
    amplitudes = [2.0, 1.5, 1.0, 0.6]
    phis, omegas, stages = [], [], []
    end_reason, end_phi, end_omega = [], [], []
    for k, (a, b) in enumerate(zip(amplitudes[:-1], amplitudes[1:])):
        sign = 1 if k % 2 == 0 else -1
        s = np.linspace(0, np.pi, 40)
        centre, half = sign * (a - b) / 2, (a + b) / 2
        phi = centre + sign * half * np.cos(s)
        omega = -sign * 3.0 * half * np.sin(s)
        phis.append(phi)
        omegas.append(omega)
        stages.append(np.full(s.size, k, np.int32))
        end_reason.append(events.REVERSAL if k < len(amplitudes) - 2 else terminal)
        end_phi.append(phi[-1])
        end_omega.append(omega[-1])
    omega = np.concatenate(omegas)
    ds = xr.Dataset(
        {
            "phi": ("point", np.concatenate(phis), {"units": "rad", "long_name": "angle"}),
            "omega": ("point", omega, {"units": "rad s-1", "long_name": "angular velocity"}),
            "omega_squared": ("point", omega ** 2, {"units": "rad2 s-2"}),
            stage_name: ("point", np.concatenate(stages), {"long_name": "stage index"}),
            "stage_end_reason": ("stage", np.array(end_reason, np.int8),
                                 {"long_name": "why the stage ends",
                                  "flag_values": np.array(events.EVENT_VALUES, np.int8),
                                  "flag_meanings": events.EVENT_MEANINGS}),
            "stage_end_phi": ("stage", np.array(end_phi), {"units": "rad"}),
            "stage_end_omega": ("stage", np.array(end_omega), {"units": "rad s-1"}),
        },
        attrs={"phasemap_kind": "phase_curve", "phasemap_model": "hinge_pendulum"},
    )
    if stage_name != "stage":
        ds = ds.assign_coords(stage=("stage", np.arange(len(end_reason), dtype=np.int32)))
    return ds


def trajectory_dataset() -> xr.Dataset:
    """A synthetic elliptic-pendulum trajectory: the slider sticks, slips, then no solution."""
    t = np.linspace(0.0, 4.0, 400)
    phi = 0.8 * np.cos(3.0 * t) * np.exp(-0.2 * t)
    omega = np.gradient(phi, t)
    xdot = np.where(t < 1.0, 1.0 - t, np.where(t < 2.0, 0.0, -0.5 * (t - 2.0)))
    x = np.concatenate([[0.0], np.cumsum(0.5 * (xdot[1:] + xdot[:-1]) * np.diff(t))])
    ev_t = np.array([0.0, 1.0, 2.0, 1.05, 3.3])
    ev_kind = np.array([events.START, events.STICK, events.SLIP, events.REVERSAL,
                        events.NO_SOLUTION], np.int8)
    order = np.argsort(ev_t)
    ev_t, ev_kind = ev_t[order], ev_kind[order]
    state = {"phi": phi, "omega": omega, "x": x, "xdot": xdot}
    units = {"phi": "rad", "omega": "rad s-1", "x": "m", "xdot": "m s-1"}
    names = {"phi": "angle of the bar", "omega": "angular velocity of the bar",
             "x": "position of the slider", "xdot": "velocity of the slider"}
    data = {k: ("t", v, {"units": units[k], "long_name": names[k]}) for k, v in state.items()}
    data["branch"] = ("t", np.where(xdot > 0, 0, np.where(xdot < 0, 2, 4)).astype(np.int8),
                      {"long_name": "active branch of the friction law",
                       "flag_values": np.arange(-1, 5, dtype=np.int8),
                       "flag_meanings": "none slide_pos_Npos slide_pos_Nneg slide_neg_Npos "
                                        "slide_neg_Nneg stick"})
    data["event_t"] = ("event", ev_t, {"units": "s", "long_name": "time of the event"})
    data["event_kind"] = ("event", ev_kind, {"long_name": "kind of event",
                                             "flag_values": np.array(events.EVENT_VALUES, np.int8),
                                             "flag_meanings": events.EVENT_MEANINGS})
    for k, v in state.items():
        data[f"event_{k}"] = ("event", np.interp(ev_t, t, v), {"units": units[k]})
    return xr.Dataset(data, coords={"t": ("t", t, {"units": "s", "long_name": "time"})},
                      attrs={"phasemap_kind": "trajectory", "phasemap_model": "elliptic_pendulum"})


def work_precision_table() -> list[dict]:
    rows = []
    for system in ("ladder", "hinge_pendulum", "elliptic_pendulum"):
        for j, method in enumerate(("phasemap", "solve_ivp RK45", "solve_ivp DOP853")):
            for tol in (1e-4, 1e-6, 1e-8, 1e-10):
                err = tol * (10.0 ** j) * 3
                rows.append({"method": method, "system": system, "tol": tol,
                             "error_final": err, "error_l2": err / 3,
                             "seconds": 1e-3 * (1 + j) * (1e-4 / tol) ** (0.2 / (1 + j))})
    rows.append({"method": "phasemap", "system": "ladder", "tol": 1e-12, "error_final": 0.0,
                 "error_l2": 0.0, "seconds": 0.01})  # exact: cannot be drawn on log axes
    return rows


def _roundtrip_plain(ds: xr.Dataset, path) -> xr.Dataset:
    ds.to_netcdf(path)
    with xr.open_dataset(path) as opened:
        return opened.load()


# --------------------------------------------------------------------------- helpers


def render(fig, tmp_path, name="fig"):
    """Draw and save as PNG and PDF with every warning an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig.canvas.draw()
        pdf, png = pplot.save_figure(fig, tmp_path / name)
    assert pdf.suffix == ".pdf" and png.suffix == ".png"
    assert pdf.stat().st_size > 0 and png.stat().st_size > 0
    assert pdf.read_bytes()[:5] == b"%PDF-"
    return pdf, png


def quiet(func, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return func(*args, **kw)


def legend_texts(ax) -> list[str]:
    """The entries of the legend that serves ``ax``: its own, or its figure's (a figure of
    several panels that share one legend)."""
    legend = ax.get_legend() or (ax.figure.legends[0] if ax.figure.legends else None)
    assert legend is not None, "no legend"
    return [t.get_text() for t in legend.get_texts()]


def present_meanings(var: xr.DataArray) -> list[str]:
    values = np.asarray(var.attrs["flag_values"]).tolist()
    meanings = var.attrs["flag_meanings"].split()
    here = set(np.unique(var.values).tolist())
    return [m.replace("_", " ") for v, m in zip(values, meanings) if v in here]


def assert_legend_outside(fig, ax):
    """The legend sits above the axes and inside the figure, clear of the data."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legend = ax.get_legend().get_window_extent(renderer)
    axes = ax.get_window_extent(renderer)
    assert legend.y0 >= axes.y1 - 1.0, "the legend overlaps the axes"
    assert legend.x0 >= -1.0 and legend.x1 <= fig.bbox.width + 1.0, "the legend is cut off"
    assert legend.y1 <= fig.bbox.height + 1.0, "the legend is cut off"


# --------------------------------------------------------------------------- kinds


def test_the_accessor_picks_the_kind_of_each_dataset(elliptic_map, hinge_profile, tmp_path):
    fate = _roundtrip_plain(fate_dataset(), tmp_path / "fate.nc")
    curve = _roundtrip_plain(phase_curve_dataset(), tmp_path / "curve.nc")
    traj = _roundtrip_plain(trajectory_dataset(), tmp_path / "traj.nc")
    assert elliptic_map.phasemap.kind == "map"
    assert hinge_profile.phasemap.kind == "profile"
    assert fate.phasemap.kind == "fate"
    assert curve.phasemap.kind == "phase_curve"
    assert traj.phasemap.kind == "trajectory"
    assert elliptic_map.phasemap.model is phasemap.get_model("elliptic_pendulum")
    assert fate.phasemap.model.name == "hinge_pendulum"
    # a slice of a 2-D atlas is a profile; a float-only atlas is judged by its first layer
    assert elliptic_map.isel(f=5).phasemap.kind == "profile"
    assert elliptic_map[["phi_ddot_slide_neg_Npos"]].phasemap.kind == "map"


def test_the_accessor_draws_the_figure_of_each_kind(elliptic_map, hinge_profile):
    fig = elliptic_map.phasemap.plot()  # map: categorical mesh and legend
    assert legend_texts(fig.axes[0]) == present_meanings(elliptic_map.n_solutions)
    fig = hinge_profile.phasemap.plot()  # profile: one step panel per categorical layer
    assert len(fig.axes) == 2
    assert [t.get_text() for t in fig.axes[0].get_yticklabels()] == \
        ["none", "unique", "two", "continuum", "three or more"]
    fig = fate_dataset().phasemap.plot()  # the fate map and each fate layer it was given
    fates = present_meanings(fate_dataset().fate)
    assert legend_texts(fig.axes[0])[:len(fates)] == fates
    assert len([a for a in fig.axes if a.get_label() != "<colorbar>"]) == 4
    fig = phase_curve_dataset().phasemap.plot()
    assert legend_texts(fig.axes[0]) == ["start", "reversal", "rest"]
    fig = trajectory_dataset().phasemap.plot()
    assert len(fig.axes) == 4
    assert legend_texts(fig.axes[0]) == ["reversal", "stick", "slip", "end of the motion",
                                        "no solution"]


# --------------------------------------------------------------------------- maps


def test_map_legend_lists_the_categories_present_above_the_axes(elliptic_map, tmp_path):
    fig = quiet(elliptic_map.phasemap.plot, overlays=False)
    ax = fig.axes[0]
    assert set(np.unique(elliptic_map.n_solutions.values)) == {0, 1, 2}
    assert legend_texts(ax) == ["none", "unique", "two"]
    colours = [matplotlib.colors.to_hex(p.get_facecolor())
               for p in ax.get_legend().get_patches()]
    assert colours == [pplot.CATEGORY_COLOURS[m].lower() for m in ("none", "unique", "two")]
    assert_legend_outside(fig, ax)
    assert ax.get_title() == "" and not ax.xaxis.get_gridlines()[0].get_visible()
    assert not ax.spines["top"].get_visible() and not ax.spines["right"].get_visible()
    render(fig, tmp_path)


def test_map_axis_labels_carry_symbols_and_units(elliptic_map):
    ax = elliptic_map.phasemap.plot().axes[0]
    assert ax.get_xlabel() == r"$\varphi$ (rad)"
    assert ax.get_ylabel() == "$f$"  # dimensionless: no units
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    assert r"$\pi$" in ticks and r"$-\pi/2$" in ticks


def test_stagnation_is_hatched_and_outlined(ladder_map, tmp_path):
    fig = ladder_map.phasemap.plot()
    ax = fig.axes[0]
    contours = [c for c in ax.collections if isinstance(c, ContourSet)]
    assert [c.hatches for c in contours if c.filled] == [["////"]]
    assert [c.levels.tolist() for c in contours if not c.filled] == [[0.5]], \
        "no outline around the stagnation zone"
    assert legend_texts(ax) == ["unique", "stagnation"]
    assert ax.get_legend().get_patches()[-1].get_hatch() == "////"
    render(fig, tmp_path)


def test_stagnation_everywhere_draws_hatching_without_an_outline(tmp_path):
    ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 12),
                                        "f": np.linspace(1.0, 2.0, 8)},
                        fixed={"omega": 0.0}).compute()
    assert int(ds.stagnation.min()) == 1
    fig = quiet(pplot.map_figure, ds)
    contours = [c for c in fig.axes[0].collections if isinstance(c, ContourSet)]
    assert [(c.filled, c.hatches) for c in contours] == [(True, ["////"])]
    render(fig, tmp_path)


def test_contact_lost_is_a_class_of_its_own_not_none(wheel_map, tmp_path):
    """A model that keeps its contacts (the hand wheel): where a contact would pull,
    n_solutions is 0; the map shows 'contact lost' there, in its own colour and hatch, so
    that 'none' is left for a Painleve inconsistency.  The running wheel counts the hop
    instead where the hop is consistent: those cells are 'unique' and flagged contact_lost."""
    n_run = wheel_map.n_solutions.values
    assert (n_run[wheel_map.contact_lost.values == 1] == 1).all()
    from references import wheel as hand_wheel

    hand_map = phasemap.Scene(hand_wheel.MODEL, axes={"phi": wheel_map.phi.values,
                                                      "omega": wheel_map.omega.values},
                              layers=["n_solutions", "stagnation", "contact_lost"]).compute()
    hand_map = _roundtrip(hand_map, tmp_path / "hand_wheel.nc")
    n = hand_map.n_solutions.values
    lost = hand_map.contact_lost.values == 1
    assert (n[lost] == 0).all() and lost.any()
    # where the hand wheel's contact would pull, the running wheel either lifts off (one
    # motion, flagged contact lost) or finds lifting off inconsistent too (the gap would
    # not open: no motion, a unilateral-contact paradox); both occur on this map
    flagged = wheel_map.contact_lost.values[lost] == 1
    assert ((n_run[lost] == 1) == flagged).all() and (n_run[lost] <= 1).all()
    assert flagged.any() and not flagged.all()
    fig = quiet(hand_map.phasemap.plot, size="two_column")
    ax = fig.axes[0]
    assert fig.get_figwidth() == pytest.approx(7.2)
    texts = legend_texts(ax)
    assert "none" not in texts  # every none cell of this atlas is a contact loss
    assert texts == ["contact lost", "unique", "stagnation"]
    patches = dict(zip(texts, ax.get_legend().get_patches()))
    assert matplotlib.colors.to_hex(patches["contact lost"].get_facecolor()) == \
        pplot.CATEGORY_COLOURS["contact_lost"].lower()
    assert patches["contact lost"].get_hatch() == pplot.CATEGORY_HATCHES["contact_lost"]
    assert patches["contact lost"].get_hatch() != patches["stagnation"].get_hatch()
    assert ax.get_ylabel() == r"$\omega$ (rad s$^{-1}$)"
    assert_legend_outside(fig, ax)
    render(fig, tmp_path)


def test_a_row_of_singular_cells_is_drawn_as_a_line(tmp_path):
    ds = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 30),
                                                "delta": np.linspace(0, 1.5, 31)},
                        fixed={"omega": 1.0}, layers=["n_solutions", "singular"]).compute()
    ds = _roundtrip(ds, tmp_path / "hinge.nc")
    assert int(ds.singular.sum()) == 30  # the row delta = l
    fig = quiet(ds.phasemap.plot)
    ax = fig.axes[0]
    assert legend_texts(ax) == ["none", "unique", r"singular ($l^2-\delta^2 = 0$)"]
    handle = ax.get_legend().legend_handles[-1]
    # a line in the singular set's own dashes (a class boundary is solid)
    assert handle.get_linestyle() == "--" and handle.get_marker() in ("None", "", None)
    assert handle._unscaled_dash_pattern[1] == pplot.DASHES[4][1]
    assert not [l for l in ax.lines if l.get_marker() == "o"], "dots where a line belongs"
    rows = [l for l in ax.lines if np.ptp(l.get_ydata()) == 0 and len(l.get_ydata()) == 2]
    assert len(rows) == 1 and rows[0].get_ydata()[0] == pytest.approx(1.0)
    render(fig, tmp_path)


def test_singular_set_is_the_zero_contour_of_the_coefficient(elliptic_map, tmp_path):
    """lambda = 0 hits only a few cells of a grid; with the coefficient layer it is a curve."""
    ds = phasemap.Scene("elliptic_pendulum",
                        axes={"phi": np.linspace(-3.14, 3.14, 60), "f": np.linspace(0, 6, 40)},
                        fixed={"xdot": -1.0},
                        layers=["n_solutions", "singular", "coef_slide_neg_Npos"]).compute()
    fig = quiet(ds.phasemap.plot)
    ax = fig.axes[0]
    lines = [c for c in ax.collections if isinstance(c, ContourSet) and not c.filled]
    assert len(lines) == 1 and lines[0].levels.tolist() == [0.0]
    # the contour follows lambda = 0: f = (1 + sin^2 phi) / (-sin phi cos phi) for k = -1
    path = np.concatenate([p.vertices for p in lines[0].get_paths()])
    s, c = np.sin(path[:, 0]), np.cos(path[:, 0])
    np.testing.assert_allclose(path[:, 1] * (-s * c), 1 + s * s, atol=0.15)
    assert legend_texts(ax)[-1] == r"singular ($\lambda = 0$)"
    assert not [l for l in ax.lines if l.get_marker() == "o"]
    render(fig, tmp_path)


def test_isolated_singular_cells_stay_dots(tmp_path):
    ds = phasemap.Scene("elliptic_pendulum",
                        axes={"phi": np.linspace(-3.14, 3.14, 60), "f": np.linspace(0, 6, 40)},
                        fixed={"xdot": -1.0}, layers=["n_solutions", "singular"]).compute()
    mask = ds.singular.values == 1
    if not mask.any():  # make one, as a grid that happens to hit lambda = 0 would
        ds["singular"] = ds.singular.copy(data=np.zeros_like(ds.singular.values))
        ds["singular"][10, 20] = 1
    fig = quiet(ds.phasemap.plot)
    dots = [l for l in fig.axes[0].lines if l.get_marker() == "o"]
    assert len(dots) == 1 and len(dots[0].get_xdata()) == int((ds.singular == 1).sum())
    assert fig.axes[0].get_legend().legend_handles[-1].get_marker() == "o"


def test_float_layer_gets_a_diverging_colour_bar(elliptic_map, tmp_path):
    data = elliptic_map.phi_ddot_slide_neg_Npos.values
    assert np.nanmin(data) < 0 < np.nanmax(data) and np.isnan(data).any()
    fig = quiet(elliptic_map.phasemap.plot, "phi_ddot_slide_neg_Npos")
    ax, cbar_ax = fig.axes
    mesh = ax.collections[0]
    assert mesh.cmap.name == "phasemap_sunset"
    assert mesh.norm.vmin == pytest.approx(-mesh.norm.vmax)
    assert r"\ddot\varphi" in cbar_ax.get_ylabel() and "rad s$^{-2}$" in cbar_ax.get_ylabel()
    render(fig, tmp_path)


def test_one_column_size_and_legible_fonts(elliptic_map):
    fig = elliptic_map.phasemap.plot()
    assert fig.get_figwidth() == pytest.approx(3.5)
    ax = fig.axes[0]
    sizes = [ax.xaxis.label.get_fontsize(), ax.yaxis.label.get_fontsize()]
    sizes += [t.get_fontsize() for t in ax.get_xticklabels() + ax.get_legend().get_texts()]
    assert all(8 <= s <= 9 for s in sizes)


def test_style_is_local_to_the_figure(elliptic_map):
    before = dict(matplotlib.rcParams)
    elliptic_map.phasemap.plot()
    assert dict(matplotlib.rcParams) == before


def test_map_into_a_given_axes(elliptic_map):
    fig, ax = plt.subplots()
    out = elliptic_map.phasemap.plot(ax=ax)
    assert out is fig and ax.get_xlabel() == r"$\varphi$ (rad)"
    with pytest.raises(ValueError, match="draws 2 panels"):
        trajectory_dataset().phasemap.plot(["phi", "omega"], ax=ax)


def test_coordinate_unknown_to_the_model_falls_back_to_long_name_and_units(tmp_path):
    ds = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 20),
                                                "delta": np.linspace(0, 1.4, 15)},
                        fixed={"omega": 0.0}).compute()
    ratio = (ds.delta / ds.attrs["phasemap_fixed_l"]).values
    attrs = {"units": "1", "long_name": "friction length over rod length"}
    ds = ds.assign_coords(delta_l=("delta", ratio, attrs))
    ds = ds.swap_dims(delta="delta_l").drop_vars("delta")
    ax = quiet(pplot.map_figure, ds).axes[0]
    assert ax.get_ylabel() == "Friction length over rod length"
    ds["delta_l"].attrs["units"] = "m m-1"
    assert pplot.axis_label(ds, "delta_l") == "Friction length over rod length (m m$^{-1}$)"


def test_units_as_mathtext():
    assert pplot.format_units("rad s-1") == "rad s$^{-1}$"
    assert pplot.format_units("m2") == "m$^{2}$"
    assert pplot.format_units("1") == "" and pplot.format_units(None) == ""
    assert pplot.format_units("kg m s-2") == "kg m s$^{-2}$"


# --------------------------------------------------------------------------- profiles


def test_profile_is_a_step_plot_per_categorical_layer(hinge_profile, tmp_path):
    fig = quiet(hinge_profile.phasemap.plot)
    top, bottom = fig.axes
    assert [t.get_text() for t in bottom.get_yticklabels()] == ["no", "yes"]
    line = bottom.lines[0]
    assert line.get_drawstyle() == "steps-mid"
    np.testing.assert_array_equal(line.get_ydata(), hinge_profile.stagnation.values)
    assert bottom.get_xlabel() == r"$\varphi$ (rad)"
    assert top.get_xlabel() == ""
    render(fig, tmp_path)


def test_profile_of_one_float_layer(tmp_path):
    ds = phasemap.Scene("ladder", axes={"f": np.linspace(0.0, 1.0, 25)},
                        fixed={"phi": 0.7, "omega": 0.5},
                        layers=["n_solutions", "phi_ddot_slide_pos"]).compute()
    fig = quiet(ds.phasemap.plot, "phi_ddot_slide_pos")
    assert fig.axes[0].get_title(loc="left") == \
        r"$\ddot{\varphi}\ [\mathrm{slide\ pos}]$ (rad s$^{-2}$)"
    assert fig._suptitle.get_text().startswith(r"$\varphi$ = 0.7 rad, $\omega$ = 0.5 rad s$^{-1}$")
    assert fig.axes[0].get_xlabel() == "$f$"
    render(fig, tmp_path)


# --------------------------------------------------------------------------- fate maps


def test_fate_map_lists_only_the_fates_present(tmp_path):
    ds = _roundtrip_plain(fate_dataset(), tmp_path / "fate.nc")
    fig = quiet(ds.phasemap.plot, extra=[])
    assert legend_texts(fig.axes[0]) == ["rest", "contact lost", "no solution", "horizon"]
    assert_legend_outside(fig, fig.axes[0])
    render(fig, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("extra, size", [("phi_rest", "one_column"), ("phi_rest", "two_column"),
                                         ("n_reversals", "one_column"), ("t_rest", "two_column")])
def test_fate_map_with_a_second_panel(extra, size, tmp_path):
    fig = quiet(fate_dataset().phasemap.plot, extra=extra, size=size)
    _, extra_ax, cbar_ax = fig.axes
    assert extra_ax.get_xlabel() == r"$\varphi$ (rad)"
    # the colour bar stays clear of the legend above the fate map: on the right of the
    # second panel at two-column width, under it at one-column width
    wide = size == "two_column"
    label = cbar_ax.get_ylabel() if wide else cbar_ax.get_xlabel()
    assert label == ("Reversals before rest" if extra == "n_reversals"  # drawn at rest only
                     else pplot.axis_label(fate_dataset(), extra))
    fig.canvas.draw()
    bar, panel = cbar_ax.get_window_extent(), extra_ax.get_window_extent()
    assert bar.x0 >= panel.x1 if wide else bar.y1 <= panel.y0
    if extra == "phi_rest":
        assert label == r"$\varphi_{\mathrm{rest}}$ (rad)"
    if extra == "n_reversals":
        ticks = cbar_ax.get_yticks() if wide else cbar_ax.get_xticks()
        assert np.allclose(ticks, np.round(ticks))
    assert figure_review.layout_problems(fig) == []
    render(fig, tmp_path)


def test_fates_along_a_line_are_a_profile(tmp_path):
    ds = fate_dataset().isel(omega=3)
    assert ds.phasemap.kind == "fate"
    fig = quiet(ds.phasemap.plot)
    (ax,) = fig.axes
    assert ax.lines[0].get_drawstyle() == "steps-mid"
    assert [t.get_text() for t in ax.get_yticklabels()] == \
        [m.replace("_", " ") for m in events.FATE_MEANINGS.split()]
    render(fig, tmp_path)


def test_other_layer_of_a_fate_dataset_is_a_plain_map():
    fig = fate_dataset().phasemap.plot("t_rest")
    assert len(fig.axes) == 2 and fig.axes[1].get_ylabel() == "Time to rest (s)"


# --------------------------------------------------------------------------- motions


@pytest.mark.parametrize("squared, stage_name", [(False, "point_stage"), (True, "point_stage"),
                                                (False, "stage")])
def test_phase_curve_marks_stage_ends_by_reason(squared, stage_name, tmp_path):
    ds = _roundtrip_plain(phase_curve_dataset(stage_name=stage_name), tmp_path / "curve.nc")
    fig = quiet(ds.phasemap.plot, squared=squared)
    ax = fig.axes[0]
    curves = [l for l in ax.lines if l.get_marker() == "None" and l.get_color() == "#000000"]
    assert len(curves) == ds.sizes["stage"]  # one line per stage: no joins across stages
    assert ax.get_xlabel() == r"$\varphi$ (rad)"
    assert ax.get_ylabel() == (r"$\omega^2$ (rad$^{2}$ s$^{-2}$)" if squared
                               else r"$\omega$ (rad s$^{-1}$)")
    markers = {l.get_label(): l for l in ax.get_legend().legend_handles}
    assert markers["rest"].get_markersize() > markers["reversal"].get_markersize()
    assert_legend_outside(fig, ax)
    render(fig, tmp_path)


def test_trajectory_marks_events_and_the_terminal_one(tmp_path):
    ds = _roundtrip_plain(trajectory_dataset(), tmp_path / "traj.nc")
    fig = quiet(ds.phasemap.plot)
    axes = fig.axes
    assert [a.get_ylabel() for a in axes] == [
        r"$\varphi$ (rad)", r"$\omega$ (rad s$^{-1}$)", "$x$ (m)", r"$\dot x$ (m s$^{-1}$)"]
    assert axes[-1].get_xlabel() == "$t$ (s)"
    for a in axes:  # the terminal event (no solution at t = 3.3) as a dashed line in every panel
        dashed = [l for l in a.lines if l.get_linestyle() == "--"]
        assert len(dashed) == 1 and dashed[0].get_xdata()[0] == pytest.approx(3.3)
    markers = {l.get_label(): l for l in axes[0].get_legend().legend_handles}
    assert markers["no solution"].get_markersize() > markers["stick"].get_markersize()
    # the dashed line has its legend entry (issue 41, the third referee pass)
    assert markers["end of the motion"].get_linestyle() == "--"
    assert_legend_outside(fig, axes[0])
    render(fig, tmp_path)


def test_trajectory_phase_plane(tmp_path):
    fig = quiet(trajectory_dataset().phasemap.plot, phase_plane=True)
    ax = fig.axes[0]
    assert ax.get_xlabel() == r"$\varphi$ (rad)" and ax.get_ylabel() == r"$\omega$ (rad s$^{-1}$)"
    assert legend_texts(ax) == ["start", "reversal", "stick", "slip", "no solution"]
    render(fig, tmp_path)
    fig = quiet(trajectory_dataset().phasemap.plot, ["xdot", "x"], phase_plane=True)
    assert fig.axes[0].get_xlabel() == r"$\dot x$ (m s$^{-1}$)"


def test_figures_of_the_real_producers(tmp_path):
    """phasemap.phase_curve and phasemap.simulate write what these figures read."""
    import phasemap.motion.phase as phase
    import phasemap.motion.simulate as simulate
    curve = _roundtrip(phase.phase_curve("hinge_pendulum", phi=2.5, omega=0.0, delta=0.1),
                       tmp_path / "curve.nc")
    assert curve.phasemap.kind == "phase_curve"
    fig = quiet(curve.phasemap.plot)
    texts = legend_texts(fig.axes[0])
    assert texts[0] == "start" and texts[-1] == curve.attrs["end_reason"].replace("_", " ")
    render(fig, tmp_path, "curve")
    motion = _roundtrip(simulate.simulate("elliptic_pendulum", t_end=3.0, phi=1.0, omega=0.0,
                                          xdot=1.0, f=0.5), tmp_path / "motion.nc")
    assert motion.phasemap.kind == "trajectory"
    fig = quiet(motion.phasemap.plot)
    assert sorted(a.get_ylabel() for a in fig.axes) == sorted(
        [r"$\varphi$ (rad)", r"$\omega$ (rad s$^{-1}$)", "$x$ (m)", r"$\dot x$ (m s$^{-1}$)"])
    assert legend_texts(fig.axes[0])[-1] == motion.attrs["end_reason"].replace("_", " ")
    render(fig, tmp_path, "motion")


def test_a_trajectory_is_drawn_through_its_dense_output(tmp_path):
    """Issue 41 item 13: a rod's fall saved at its 20 steps was drawn as a polyline with
    kinks.  The figure runs the motion again from what its attributes record and draws
    the integrator's dense output (plot.motion.dense_motion), through the saved points:
    at the steps' midpoints it is within 1.1e-7 of a run 10^4 times tighter, where the
    straight lines between steps were up to 8.6e-3 off."""
    import phasemap.motion.simulate as simulate
    from phasemap.plot.motion import DENSE_POINTS, dense_motion

    start = dict(theta=1.0, omega=0.0, xdot=1.0, f=0.3, t_end=2.0)
    motion = _roundtrip(simulate.simulate("painleve_rod", **start), tmp_path / "rod.nc")
    t = motion.t.values
    assert t.size < 40
    fig = quiet(motion.phasemap.plot)
    for a, name in zip(fig.axes, ("theta", "x", "omega", "xdot")):
        x, y = max(((l.get_xdata(), l.get_ydata()) for l in a.lines), key=lambda c: len(c[0]))
        assert len(x) >= DENSE_POINTS and np.all(np.isin(t, x)), name
        assert np.allclose(y[np.searchsorted(x, t)], motion[name].values, rtol=0,
                           atol=1e-14), name
    mid = 0.5 * (t[1:] + t[:-1])
    fine = simulate.simulate("painleve_rod", rtol=1e-12, t_eval=mid, **start)
    dense = dense_motion(motion, mid)
    for name in ("theta", "omega", "x", "xdot"):
        err = np.max(np.abs(dense[name].values - fine[name].values))
        straight = np.max(np.abs(np.interp(mid, t, motion[name].values) - fine[name].values))
        assert err < 1e-6 and straight > 100 * err, (name, err, straight)
    # with dense=False, and where the motion cannot be run again, the saved points
    lines = [len(l.get_xdata()) for l in quiet(motion.phasemap.plot, dense=False).axes[0].lines]
    assert max(lines) == t.size
    for key, value in (("phasemap_model", "no_such_model"), ("phasemap_rtol", 1e-6)):
        other = motion.copy()
        other.attrs[key] = value        # not found, or a re-run that is another motion
        assert dense_motion(other, mid) is None
        assert max(len(l.get_xdata()) for l in quiet(other.phasemap.plot).axes[0].lines) \
            == t.size
    render(fig, tmp_path, "dense")


def test_the_dense_curve_keeps_every_saved_point_and_its_jumps():
    """An impact is saved twice at its time (before, after), the dense re-run once: the
    drawn curve holds both, so it jumps there, with the re-run's samples between; a
    variable the re-run does not give as the Dataset holds it (converted after the run)
    keeps its saved points."""
    from phasemap.plot.motion import _through_saved

    t = np.array([0.0, 1.0, 1.0, 2.0])
    ds = xr.Dataset({"v": ("t", [0.0, -1.0, 0.5, 0.0]), "deg": ("t", [0.0, 57.0, 57.0, 90.0])},
                    coords={"t": t})
    again = xr.Dataset({"v": ("t", [0.0, -0.5, -1.0, 0.3, 0.0]),
                        "deg": ("t", [0.0, 0.5, 1.0, 1.2, 1.5])},
                       coords={"t": [0.0, 0.5, 1.0, 1.5, 2.0]})
    got = _through_saved(ds, again, t, ["v", "deg"])
    assert list(got) == ["v"]
    tt, v = got["v"]
    assert tt.tolist() == [0.0, 0.5, 1.0, 1.0, 1.5, 2.0]
    assert v.tolist() == [0.0, -0.5, -1.0, 0.5, 0.3, 0.0]


# --------------------------------------------------------------------------- benchmarks


@pytest.mark.parametrize("size", ["one_column", "two_column"])
def test_work_precision_one_panel_per_system_one_line_per_method(size, tmp_path):
    fig = quiet(pplot.work_precision_figure, work_precision_table(), size=size)
    axes = [a for a in fig.axes if a.axison]
    # each panel states what its problem holds fixed beyond the model's own (g)
    assert [" ".join(a.get_title(loc="left").split()) for a in axes] == \
        ["(a) ladder", r"(b) hinge pendulum, $g$ = 9.81 m s$^{-2}$", "(c) elliptic pendulum"]
    names = ["phasemap, Dormand–Prince 5(4)", "solve_ivp RK45", "solve_ivp DOP853"]
    for a in axes:
        assert a.get_xscale() == "log" and a.get_yscale() == "log"
        assert [l.get_label() for l in a.lines] == names
        assert len(a.lines[0].get_xdata()) == 4  # the zero-error row is left out
        assert a.get_xlabel() in ("", "Run time per trajectory (s)" if size == "two_column"
                                  else "Run time (s)")
        assert a.get_ylabel() in ("", r"Final-state error $\|\Delta y\|_\infty$ (SI)")
    # one legend above the panels: the method names are too long for the free fourth slot
    # of the one-column grid, which is removed
    legend = fig.legends[0]
    assert len(fig.axes) == 3
    assert [t.get_text() for t in legend.get_texts()] == names
    assert "$y$: the state (rad, rad s$^{-1}$" in fig._supxlabel.get_text()  # y is defined
    assert ("per trajectory" in fig._supxlabel.get_text()) == (size == "one_column")
    assert figure_review.layout_problems(fig) == []
    render(fig, tmp_path)
    fig = quiet(pplot.work_precision_figure, work_precision_table(), error="error_l2")
    assert fig.axes[0].get_ylabel() == "$L_2$ error along the motion (SI)"


@pytest.mark.slow
@pytest.mark.parametrize("size", ["one_column", "two_column"])
def test_work_precision_of_every_builtin_problem_and_method_lays_out(size, tmp_path):
    """The benchmark's figure: five systems, eight methods, at both widths."""
    rows = []
    systems = list(pplot.SYSTEM_NAMES)
    methods = list(pplot.METHOD_NAMES)
    for system in systems:
        for j, method in enumerate(methods):
            for tol in (1e-4, 1e-8):
                rows.append({"method": method, "system": system, "tol": tol,
                             "error_final": tol * (j + 1), "error_l2": tol,
                             "seconds": 1e-4 * (j + 1) / tol ** 0.1})
    fig = quiet(pplot.work_precision_figure, rows, size=size)
    panels = [a for a in fig.axes if a.axison]
    assert len(panels) == len(systems)
    legends = fig.legends + [a.get_legend() for a in fig.axes if a.get_legend()]
    assert len(legends) == 1
    assert [t.get_text() for t in legends[0].get_texts()] == [pplot.METHOD_NAMES[m]
                                                              for m in methods]
    assert figure_review.layout_problems(fig) == []
    render(fig, tmp_path)


def test_work_precision_points_at_the_fastest_round_with_a_bar_to_the_slowest(tmp_path):
    rows = work_precision_table()
    for r in rows:
        r.update(seconds_min=r["seconds"] * 0.9, seconds_max=r["seconds"] * 1.5, n_samples=5)
    fig = quiet(pplot.work_precision_figure, rows)
    a = fig.axes[0]
    first = [r for r in rows if r["system"] == "ladder" and r["method"] == "phasemap"
             and r["error_final"] > 0]
    first.sort(key=lambda r: -r["tol"])
    np.testing.assert_allclose(a.lines[0].get_xdata(), [r["seconds_min"] for r in first])
    bars = [c for c in a.collections if isinstance(c, matplotlib.collections.LineCollection)]
    assert len(bars) == 3  # one spread per method
    spans = [seg[:, 0] for seg in bars[0].get_segments()]
    np.testing.assert_allclose([s.max() for s in spans], [r["seconds_max"] for r in first])
    assert "fastest of 5 timing rounds" in fig._supxlabel.get_text()
    render(fig, tmp_path)


def test_work_precision_bad_table():
    with pytest.raises(ValueError, match="empty"):
        pplot.work_precision_figure([])
    with pytest.raises(ValueError, match="row 0 lacks seconds"):
        pplot.work_precision_figure([{"method": "a", "system": "b", "tol": 1.0,
                                      "error_final": 1.0, "error_l2": 1.0}])
    with pytest.raises(ValueError, match="error must be"):
        pplot.work_precision_figure(work_precision_table(), error="error_max")


# --------------------------------------------------------------------------- files


def test_savefig_writes_pdf_and_png(elliptic_map, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pdf, png = elliptic_map.phasemap.savefig(tmp_path / "elliptic.pdf")
    assert (pdf.name, png.name) == ("elliptic.pdf", "elliptic.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from matplotlib.image import imread
    width = imread(png).shape[1]
    assert width == pytest.approx(3.5 * 300, abs=2)
    assert not plt.get_fignums()  # savefig closes the figure it made
    assert not list(tmp_path.glob(".*.part"))


def test_save_figure_into_a_missing_folder(tmp_path):
    fig = phase_curve_dataset().phasemap.plot()
    with pytest.raises(ValueError, match="does not exist"):
        pplot.save_figure(fig, tmp_path / "missing" / "fig")


# --------------------------------------------------------------------------- docs


@pytest.mark.parametrize("module", ["phasemap.plot", "phasemap.accessor", "phasemap.atlas.dataset",
                                    "phasemap.plot.command"])
def test_docstring_examples(module):
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted >= 2 and result.failed == 0


# --------------------------------------------------------------------------- bad input


def test_a_dataset_that_is_not_an_atlas():
    ds = xr.Dataset({"a": ("x", np.arange(3))})
    with pytest.raises(ValueError, match="not a phasemap atlas"):
        _ = ds.phasemap.kind
    with pytest.raises(ValueError, match="not a phasemap atlas"):
        ds.phasemap.plot()
    with pytest.raises(ValueError, match="no phasemap_model"):
        _ = ds.phasemap.model
    with pytest.raises(ValueError, match="not a phasemap atlas"):
        pplot.plot(np.zeros(3))
    with pytest.raises(ValueError, match="no layers"):
        _ = xr.Dataset(attrs={"phasemap_model": "ladder"}).phasemap.kind


def test_bad_layer_kind_size_and_shape(elliptic_map):
    with pytest.raises(ValueError, match="unknown layer 'N_nope'; this dataset has: n_solutions"):
        elliptic_map.phasemap.plot("N_nope")
    with pytest.raises(ValueError, match="unknown phasemap_kind 'movie'"):
        _ = elliptic_map.assign_attrs(phasemap_kind="movie").phasemap.kind
    with pytest.raises(ValueError, match="unknown size 'poster'"):
        elliptic_map.phasemap.plot(size="poster")
    with pytest.raises(ValueError, match="positive width"):
        elliptic_map.phasemap.plot(size=-1.0)
    cube = elliptic_map.expand_dims(omega=[0.0, 1.0], axis=2)
    with pytest.raises(ValueError, match=r"3-D atlas .* select a 1-D or 2-D slice"):
        cube.phasemap.plot()
    with pytest.raises(ValueError, match="not a phase curve dataset: missing point_stage"):
        phase_curve_dataset().drop_vars("point_stage").phasemap.plot()
    with pytest.raises(ValueError, match="not a phase curve dataset: missing stage_end_phi"):
        phase_curve_dataset().drop_vars("stage_end_phi").phasemap.plot()
    with pytest.raises(ValueError, match="phase curve has no layers"):
        phase_curve_dataset().phasemap.plot("phi")
    with pytest.raises(ValueError, match="unknown state 'y'"):
        trajectory_dataset().phasemap.plot("y")
    with pytest.raises(ValueError, match="x='omega' is not a dimension"):
        elliptic_map.phasemap.plot(x="omega")


def test_figures_draw_into_subfigures():
    import matplotlib.pyplot as plt

    ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 20),
                                        "f": np.linspace(0, 1, 10)}, fixed={"omega": 0.0}).compute()
    root = plt.figure(figsize=(7.2, 3))
    left, right = root.subfigures(1, 2)
    phasemap.plot.map_figure(ds, ax=left.subplots())
    phasemap.plot.profile_figure(ds.isel(f=0), "n_solutions", ax=right.subplots())
    root.canvas.draw()
    assert root.legends or any(a.get_legend() for sub in (left, right) for a in sub.axes)
    plt.close(root)


# --------------------------------------------------------------------------- issue 11: what a referee asks


def test_a_map_states_what_was_held_fixed(tmp_path):
    """The ladder at omega = 0.5 says so, read from the atlas's metadata after a round trip."""
    ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 20), "f": np.linspace(0, 2, 15)},
                        fixed={"omega": 0.5, "l": 2.0}).compute()
    ds = _roundtrip(ds, tmp_path / "ladder.nc")
    for size in ("one_column", "two_column"):
        fig = quiet(ds.phasemap.plot, size=size)
        heading = fig.axes[0].get_legend().get_title().get_text()
        for text in (r"$\omega$ = 0.5 rad s$^{-1}$", "$l$ = 2 m", "$g$ = 9.81 m s$^{-2}$",
                     "$m$ = 1 kg"):
            assert text in heading, (text, heading)
        assert "$f$" not in heading and r"$\varphi$" not in heading  # the axes are not fixed
        assert_legend_outside(fig, fig.axes[0])
        render(fig, tmp_path, f"ladder_{size}")


def test_motions_state_their_initial_state_and_parameters(tmp_path):
    import phasemap.motion.phase as phase
    import phasemap.motion.simulate as simulate
    curve = phase.phase_curve("hinge_pendulum", phi=2.5, omega=0.0, delta=0.1)
    heading = quiet(curve.phasemap.plot).axes[0].get_legend().get_title().get_text()
    assert heading.startswith(r"$\varphi_0$ = 2.5 rad, $\omega_0$ = 0 rad s$^{-1}$;")
    assert r"$\delta$ = 0.1 m" in heading
    motion = simulate.simulate("elliptic_pendulum", t_end=1.0, phi=1.0, omega=0.0, xdot=-1.0,
                               f=0.5)
    fig = quiet(motion.phasemap.plot)
    heading = fig._suptitle.get_text().replace("\n", " ")
    assert r"$\dot x_0$ = −1 m s$^{-1}$;" in heading and "$f$ = 0.5" in heading
    assert "$x_0$" not in heading  # the slider's position does not enter the equations
    fig = quiet(motion.phasemap.plot, phase_plane=True)
    assert "$f$ = 0.5" in fig.axes[0].get_legend().get_title().get_text()
    render(fig, tmp_path)


def test_fate_map_states_its_parameters_and_fills_inverted_rests(tmp_path):
    ds = fate_dataset()
    ds["phi_rest"][0, 0] = 3.0  # a rest near the upper position
    fig = quiet(ds.phasemap.plot, extra="n_reversals", size="two_column")
    texts = pplot.figure_texts(fig)
    assert any(r"$\delta$ = 0.1 m" in t for t in texts)
    assert r"rest inverted ($\cos\varphi_\mathrm{rest} < 0$)" in legend_texts(fig.axes[0])
    # the one cell filled on the fate panel, in its own grey; nothing ringed or drawn over
    # the other panels
    fills = [c for c in fig.axes[0].collections if isinstance(c, QuadMesh)
             and np.ma.count(c.get_array()) == 1]
    assert len(fills) == 1
    assert mcolors.to_hex(fills[0].to_rgba(np.ma.compressed(fills[0].get_array()))[0]) == \
        pplot.DARK_GREY.lower()
    assert not [l for a in fig.axes for l in a.lines if l.get_marker() == "o"]
    render(fig, tmp_path)


def test_inverted_rests_on_a_fine_fate_map_fill_their_cells(tmp_path):
    """Rings covered a fine map (such rests line up along curves there): the cells
    themselves are filled, so that the classes around them stay in view."""
    ds = fate_dataset().interp(phi=np.linspace(-np.pi, np.pi, 400), method="nearest")
    ds["phi_rest"][:, 0] = 3.0
    fig = quiet(ds.phasemap.plot, extra="n_reversals", size="two_column")
    fills = [c for c in fig.axes[0].collections if isinstance(c, QuadMesh)
             and np.ma.count(c.get_array()) == int((np.cos(ds.phi_rest) < 0).sum())]
    assert len(fills) == 1
    assert r"rest inverted ($\cos\varphi_\mathrm{rest} < 0$)" in legend_texts(fig.axes[0])
    render(fig, tmp_path)


@pytest.mark.parametrize("kind", ["fate", "trajectory", "profile", "work_precision"])
def test_multi_panel_figures_letter_their_panels(kind, hinge_profile):
    fig = {"fate": lambda: fate_dataset().phasemap.plot(extra="phi_rest"),
           "trajectory": lambda: trajectory_dataset().phasemap.plot(),
           "profile": lambda: hinge_profile.phasemap.plot(),
           "work_precision": lambda: pplot.work_precision_figure(work_precision_table()),
           }[kind]()
    panels = [a for a in fig.axes if a.axison and a.get_label() != "<colorbar>"]
    panels = [a for a in panels if a.get_position().height > 0.15]
    headings = []
    for a in panels:
        leg = a.get_legend()
        title = leg.get_title().get_text() if leg is not None and \
            leg.get_title().get_text() else a.get_title(loc="left")
        headings.append(title)
    assert [h[:3] for h in headings] == [f"({c})" for c in "abcd"[:len(panels)]], headings


def _grey(colour) -> float:
    r, g, b = matplotlib.colors.to_rgb(colour)
    return 0.299 * r + 0.587 * g + 0.114 * b


@pytest.mark.parametrize("meanings", [events.FATE_MEANINGS.split(),
                                      ["none", "unique", "two", "continuum", "three_or_more",
                                       "contact_lost"]])
def test_classes_stay_apart_in_greyscale(meanings):
    """Two classes of one layer differ in grey level by 0.1 or more, or in hatch."""
    for i, a in enumerate(meanings):
        for b in meanings[i + 1:]:
            ca, cb = pplot.category_colour(a), pplot.category_colour(b)
            ha, hb = pplot.category_hatch(a)[0], pplot.category_hatch(b)[0]
            assert abs(_grey(ca) - _grey(cb)) >= 0.1 or ha != hb, (a, b)


def test_hatched_classes_are_hatched_on_the_map(elliptic_map):
    fig = quiet(elliptic_map.phasemap.plot, overlays=False)
    ax = fig.axes[0]
    hatches = [c.hatches for c in ax.collections if isinstance(c, ContourSet) and c.filled]
    assert sorted(h[0] for h in hatches) == sorted(pplot.CATEGORY_HATCHES[m]
                                                   for m in ("none", "two"))
    patches = dict(zip(legend_texts(ax), ax.get_legend().get_patches()))
    assert patches["two"].get_hatch() == pplot.CATEGORY_HATCHES["two"]
    assert patches["none"].get_hatch() == pplot.CATEGORY_HATCHES["none"]
    assert patches["unique"].get_hatch() is None


# --------------------------------------------------------------------------- issue 26: fate layers, boundaries, phasemap plot


@pytest.fixture(scope="module")
def wheel_fates(tmp_path_factory) -> xr.Dataset:
    """A small fate map of the wheel, written and read back: rest, hops, reversals."""
    ds = phasemap.Scene("wheel", axes={"phi": np.linspace(-3.1, 3.1, 24),
                                       "omega": np.linspace(-8.0, 8.0, 20)},
                        fixed={"delta": 0.05}, layers=["fate", "phi_rest", "n_reversals"],
                        options={"t_end": 5.0}).compute()
    return _roundtrip(ds, tmp_path_factory.mktemp("atlas") / "fates.nc")


def test_the_fate_map_draws_each_fate_layer_and_states_t_end(wheel_fates, tmp_path):
    fig = quiet(wheel_fates.phasemap.plot, size="two_column")
    panels = [a for a in fig.axes if a.get_label() != "<colorbar>"]
    bars = [a for a in fig.axes if a.get_label() == "<colorbar>"]
    assert len(panels) == 3 and len(bars) == 2  # fate, phi_rest, n_reversals
    assert [a.get_title(loc="left")[:3] for a in panels] == ["(a)", "(b)", "(c)"]
    legend = fig.legends[0]
    assert r"$t_\mathrm{end}$ = 5 s" in legend.get_title().get_text()
    # a count is drawn only where the motion came to rest: no hop reads as "0 reversals"
    fate = wheel_fates.fate.transpose("omega", "phi").values
    assert (fate != phasemap.Event.REST).any()
    counts = [c for c in panels[2].collections if c.get_array() is not None][0]
    shown = np.ma.getmaskarray(counts.get_array()).reshape(fate.shape)
    assert np.array_equal(shown, fate != phasemap.Event.REST)
    assert "blank: did not come to rest" in legend_texts(panels[0])
    assert figure_review.layout_problems(fig) == []
    render(fig, tmp_path)


def test_exact_boundaries_are_drawn_over_the_cells(ladder_map):
    """The hook for the bifurcation-set tracer: pieces with vertex coordinates, one curve
    each, over the stair of the cells."""
    f = np.linspace(0.0, 0.6, 40)
    pieces = xr.Dataset({"phi": ("vertex", np.r_[2 * np.arctan(f), [0.2, 0.4]]),
                         "f": ("vertex", np.r_[f, [1.0, 1.1]]),
                         "piece": ("vertex", np.r_[np.zeros(40, int), [1, 1]])})
    fig = quiet(pplot.map_figure, ladder_map, boundaries=pieces)
    ax = fig.axes[0]
    curves = [l for l in ax.lines if l.get_label() != "_nolegend_" and len(l.get_xdata()) > 1]
    assert sorted(len(l.get_xdata()) for l in curves) == [2, 40]
    np.testing.assert_allclose(curves[0].get_ydata() if len(curves[0].get_xdata()) == 40
                               else curves[1].get_ydata(), f)
    assert "class boundary" in legend_texts(ax)
    with pytest.raises(ValueError, match="boundaries need piece on dimension 'vertex'"):
        pplot.map_figure(ladder_map, boundaries=pieces.drop_vars("piece"))


def test_a_declared_system_is_labelled_as_a_built_in_one(tmp_path):
    """Issue 23 item 6: symbols and units come from the atlas itself, so a system that is
    not registered (the README's rod) is drawn with them after a round trip."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "own_system", ROOT / "docs" / "examples" / "own_system.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    model = module.SYSTEM.model
    with pytest.raises(ValueError, match=f"unknown model '{model.name}'"):
        phasemap.get_model(model.name)  # not registered: the figure cannot ask the registry
    ds = phasemap.Scene(model, axes={"theta": np.linspace(0.05, 1.5, 30),
                                     "f": np.linspace(0.0, 2.0, 20)},
                        fixed={"xdot": -1.0, "omega": 0.0}).compute()
    ds = _roundtrip(ds, tmp_path / "rod.nc")
    assert ds.theta.attrs["phasemap_symbol"] == r"\theta"
    fig = quiet(ds.phasemap.plot)
    ax = fig.axes[0]
    assert ax.get_xlabel() == r"$\theta$ (rad)" and ax.get_ylabel() == "$f$"
    heading = ax.get_legend().get_title().get_text().replace("\n", " ")
    assert r"$\omega$ = 0 rad s$^{-1}$" in heading and r"$\dot x$ = −1 m s$^{-1}$" in heading
    assert "$g$ = 9.81 m s$^{-2}$" in heading
    assert figure_review.unit_problems(fig) == []
    motion = phasemap.simulate(model, theta=1.0, omega=0.0, xdot=1.0, f=0.3, t_end=0.5)
    fig = quiet(motion.phasemap.plot, phase_plane=True)
    assert fig.axes[0].get_xlabel() == r"$\theta$ (rad)"
    assert r"$\theta_0$ = 1 rad" in fig.axes[0].get_legend().get_title().get_text()


@pytest.mark.slow
def test_phasemap_plot_on_the_command_line(ladder_map, tmp_path):
    import subprocess
    import sys

    from matplotlib.image import imread

    run = [sys.executable, "-m", "phasemap.cli", "plot"]
    three = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 20),
                                           "f": np.linspace(0, 2, 15), "omega": [0.0, 1.0]}
                           ).compute()
    files = {"map.nc": ladder_map, "cube.nc": three,
             "curve.nc": phase_curve_dataset(), "motion.nc": trajectory_dataset()}
    for name, ds in files.items():
        phasemap.write_atlas(ds, tmp_path / name)
    done = subprocess.run(run + [str(tmp_path / "map.nc")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"wrote {tmp_path / 'map.pdf'}, {tmp_path / 'map.png'}"
    assert imread(tmp_path / "map.png").shape[1] == pytest.approx(3.5 * 300, abs=2)
    for name in ("cube", "curve", "motion"):
        done = subprocess.run(run + [str(tmp_path / f"{name}.nc"), "-o",
                                     str(tmp_path / f"{name}_wide"), "--size", "two"],
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        assert (tmp_path / f"{name}_wide.pdf").read_bytes()[:5] == b"%PDF-"
        assert imread(tmp_path / f"{name}_wide.png").shape[1] == pytest.approx(7.2 * 300,
                                                                             abs=2)
    (tmp_path / "notes.nc").write_text("not netCDF")
    for args, message in (([str(tmp_path / "notes.nc")], "not a readable netCDF file"),
                          ([str(tmp_path / "missing.nc")], "no such file"),
                          ([str(tmp_path / "map.nc"), "--size", "poster"], "invalid choice")):
        done = subprocess.run(run + args, capture_output=True, text=True)
        assert done.returncode == 2 and message in done.stderr, done.stderr
        assert "Traceback" not in done.stderr


def test_a_three_dimensional_atlas_is_one_map_per_value_of_its_shortest_axis():
    from phasemap.plot.command import figure_of

    cube = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 20),
                                          "f": np.linspace(0, 2, 15),
                                          "omega": [0.0, 1.0, 3.0]}).compute()
    fig = quiet(figure_of, cube, "two_column")
    panels = [a for a in fig.axes if a.axison]
    assert [a.get_title(loc="left") for a in panels] == [
        r"(a) $\omega$ = 0 rad s$^{-1}$", r"(b) $\omega$ = 1 rad s$^{-1}$",
        r"(c) $\omega$ = 3 rad s$^{-1}$"]
    assert figure_review.layout_problems(fig) == []
    long = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 12),
                                          "f": np.linspace(0, 2, 8),
                                          "omega": np.linspace(0, 3, 7)}).compute()
    with pytest.raises(ValueError, match="'omega' has 7 values \\(at most 6\\)"):
        figure_of(long)


@pytest.mark.parametrize("size", ["one_column", "two_column"])
def test_work_precision_scaled_error_states_its_definition_and_scales(size, tmp_path):
    """A dimensionless error is labelled with its definition, and the key states each
    panel's scales from the rows; two systems at one column are stacked, one label for
    the column; the tracer's markers are not joined."""
    scales = {"hinge_weightless": (("phi", 8.957, "rad", r"\varphi"),
                                   ("omega", 5.0, "rad s-1", r"\omega")),
              "hinge_pendulum": (("phi", 2.5, "rad", r"\varphi"),
                                 ("omega", 5.49, "rad s-1", r"\omega"))}
    rows = [dict(r, system=system, scales=scales[system], error_scaled_l2=r["error_l2"] / 5,
                 error_scaled_final=r["error_final"] / 5)
            for system in scales for r in work_precision_table() if r["system"] == "ladder"]
    rows += [dict(rows[0], method="phase_curve", tol=tol, error_scaled_l2=1e-12, seconds=2e-3)
             for tol in (1e-4, 1e-8)]
    fig = quiet(pplot.work_precision_figure, rows, size=size, error="error_scaled_l2")
    panels = [a for a in fig.axes if a.axison]
    label = r"$L_2$ error of $\Delta y_i/\hat y_i$ (dimensionless)"
    if size == "one_column":
        assert [a.get_ylabel() for a in panels] == ["", ""]
        assert fig._supylabel.get_text() == label
        assert panels[0].get_position().y0 > panels[1].get_position().y1  # stacked
    else:
        assert panels[0].get_ylabel() == label
    key = fig._supxlabel.get_text()
    assert r"$\hat y_i$: the largest $|y_i|$ along the reference motion" in key
    assert (r"(a) $\hat{\varphi}$ = 8.957 rad, $\hat{\omega}$ = 5 rad s$^{-1}$" in key
            and r"(b) $\hat{\varphi}$ = 2.5 rad" in key)
    tracer = [ln for ln in panels[0].lines if ln.get_label() == "phasemap first integrals"]
    assert len(tracer) == 1 and tracer[0].get_linestyle() == "None"
    assert len(tracer[0].get_xdata()) == 2
    assert figure_review.layout_problems(fig) == []
    assert figure_review.unit_problems(fig) == []
    render(fig, tmp_path)
    with pytest.raises(ValueError, match="lacks error_scaled_final"):
        pplot.work_precision_figure(work_precision_table(), error="error_scaled_final")


def test_a_file_with_more_cells_than_a_figure_is_read_at_its_resolution(tmp_path,
                                                                        monkeypatch):
    """``phasemap plot`` on a 2e9-cell atlas read it whole (11.9 GB); an axis longer than
    MAX_DRAWN is now read at every k-th value, lazily, and the figure says so."""
    from phasemap.plot import command

    ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 301),
                                        "f": np.linspace(0, 1, 7)},
                        fixed={"omega": 0.0}, layers=["n_solutions"]).compute()
    path = phasemap.write_atlas(ds, tmp_path / "long.nc")
    monkeypatch.setattr(command, "MAX_DRAWN", 100)
    with phasemap.open_atlas(path) as lazy:
        part, note = command.reduced(lazy)
        assert part.sizes == {"phi": 76, "f": 7}
        assert note == "drawn from 1 in 4 values of phi (301 in the file)"
        # sampled, never averaged: the classes drawn are the file's own
        assert (part.n_solutions.values == ds.n_solutions.values[::4]).all()
    drawn = []
    real = command.figure_of
    monkeypatch.setattr(command, "figure_of", lambda d, size: drawn.append(d.sizes) or
                        real(d, size))
    pdf, png = command.plot_file(path)
    assert png.exists() and drawn == [{"phi": 76, "f": 7}]
    small = command.reduced(ds.isel(phi=slice(0, 50)))
    assert small[1] == "" and small[0].sizes["phi"] == 50


def test_a_yes_no_map_names_both_classes_in_their_own_look(tmp_path):
    """A flag map's plain class has its entry too (the referee's grey region with none),
    and a flag not hatched as its overlay is listed as its cells look."""
    ds = phasemap.Scene("wheel", axes={"phi": np.linspace(-3, 3, 40),
                                       "omega": np.linspace(-8, 8, 30)},
                        layers=["contact_lost", "stagnation"]).compute()
    for layer, texts in (("contact_lost", ["no contact would pull", "a contact would pull"]),
                         ("stagnation", ["no stagnation", "stagnation"])):
        fig = quiet(pplot.map_figure, ds, layer, x="phi", overlays=False)
        present = {int(v) for v in np.unique(ds[layer].values)}
        assert sorted(legend_texts(fig.axes[0])) == sorted(
            t for t, v in zip(texts, (0, 1)) if v in present), layer
        assert not figure_review.legend_drawn_problems(fig), layer
        plt.close(fig)
