"""The figure review can fail: for each rule, a deliberately broken figure it catches, and
the same figure mended, which it passes (issue 26)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

import figure_review as fr

from phasemap import plot as pplot
from phasemap.plot.style import _patch

OI = pplot.OKABE_ITO


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _figure(n=1, width=3.5):
    with pplot.style():
        fig, axes = plt.subplots(1, n, figsize=(width, 2.8), layout="constrained",
                                 squeeze=False)
    return fig, list(axes[0])


def _problems(fig, rule: str) -> list[str]:
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    return {"colour bar": fr.colour_bar_problems,
            "greyscale": fr.greyscale_problems,
            "letters": lambda f: fr._letter_problems(f, renderer),
            "covering": lambda f: fr.covering_problems(f, renderer),
            "units": fr.unit_problems}[rule](fig)


# --------------------------------------------------------------------------- colour bars


def _mesh_with_bar(vmax, extend="neither", tail=0.0):
    fig, (ax,) = _figure()
    data = np.linspace(0.0, 10.0, 400).reshape(20, 20)
    if tail:  # a few cells far out: a long tail
        data.ravel()[:int(tail * data.size)] = 50.0
    mesh = ax.pcolormesh(data, vmin=0.0, vmax=vmax)
    fig.colorbar(mesh, ax=ax, extend=extend, label="$v$ (m s$^{-1}$)")
    return fig


def test_a_colour_bar_that_cuts_the_data_off_is_caught():
    problems = _problems(_mesh_with_bar(5.0), "colour bar")
    assert len(problems) == 1 and "lie above its range" in problems[0]
    assert "no arrow" in problems[0]
    # an arrow does not excuse half of the cells
    assert _problems(_mesh_with_bar(5.0, extend="max"), "colour bar")
    assert _problems(_mesh_with_bar(10.0), "colour bar") == []
    # a tail of 1 % behind an arrow is what a robust range leaves out: allowed
    assert _problems(_mesh_with_bar(10.0, extend="max", tail=0.01), "colour bar") == []
    assert _problems(_mesh_with_bar(10.0, extend="max", tail=0.05), "colour bar")


def test_the_angle_maps_colour_bar_holds_every_turn():
    """The referee's case: rest angles out to 4 pi were drawn on a bar to about 2 pi."""
    import xarray as xr

    phi = np.linspace(-np.pi, np.pi, 40)
    omega = np.linspace(-9.0, 9.0, 30)
    rest = 0.05 * np.sin(phi)[:, None] + np.pi * np.round(omega / 2.5)[None, :]
    ds = xr.Dataset({"phi_rest": (("phi", "omega"), rest, {"units": "rad",
                                                           "long_name": "angle at rest"})},
                    coords={"phi": ("phi", phi, {"units": "rad"}),
                            "omega": ("omega", omega, {"units": "rad s-1"})},
                    attrs={"phasemap_model": "hinge_pendulum"})
    assert np.abs(rest).max() > 3 * np.pi
    fig = pplot.map_figure(ds, "phi_rest")
    assert _problems(fig, "colour bar") == []
    assert fr.layout_problems(fig) == []
    # and the same data on a clipped diverging bar, as before, is caught
    fig, (ax,) = _figure()
    mesh = ax.pcolormesh(rest.T, cmap=pplot.SUNSET, vmin=-6.5, vmax=6.5)
    fig.colorbar(mesh, ax=ax, extend="both", label=r"$\varphi$ (rad)")
    assert _problems(fig, "colour bar")


# --------------------------------------------------------------------------- greyscale


def _two_lines(second: dict):
    fig, (ax,) = _figure()
    x = np.linspace(0, 1, 20)
    ax.plot(x, x, color=OI["vermillion"], label="printed")
    ax.plot(x, x ** 2, label="corrected", **second)
    ax.set_xlabel("$t$ (s)")
    ax.set_ylabel("$x$ (m)")
    pplot.legend_above(ax, ax.get_lines())
    return fig


def test_lines_told_apart_by_colour_alone_are_caught():
    # vermillion and bluish green print as nearly the same grey
    problems = _problems(_two_lines({"color": OI["bluish_green"]}), "greyscale")
    assert problems == ["'printed' and 'corrected' differ by colour alone (greyscale alike)"]
    assert _problems(_two_lines({"color": OI["bluish_green"], "ls": "--"}), "greyscale") == []
    assert _problems(_two_lines({"color": OI["black"]}), "greyscale") == []  # grey levels apart


def test_markers_and_classes_told_apart_by_colour_alone_are_caught():
    fig, (ax,) = _figure()
    handles = [Line2D([], [], ls="none", marker="s", mfc=OI["vermillion"], mec="black",
                      label="stick"),
               Line2D([], [], ls="none", marker="s", mfc=OI["bluish_green"], mec="black",
                      label="rest"),
               Patch(facecolor=OI["vermillion"], label="none"),
               Patch(facecolor=OI["bluish_green"], label="stagnation")]
    pplot.legend_above(ax, handles)
    problems = _problems(fig, "greyscale")
    assert len(problems) == 2 and "'stick' and 'rest'" in problems[0]
    assert "'none' and 'stagnation'" in problems[1]
    # phasemap's own classes stay apart: a hatch or a grey step between each two
    for meanings in (["none", "unique", "two", "continuum", "three_or_more", "contact_lost"],
                     ["rest", "contact_lost", "no_solution", "indeterminate", "horizon"]):
        fig, (ax,) = _figure()
        pplot.legend_above(ax, [_patch(pplot.category_colour(m), m, m)
                                for m in meanings])
        assert _problems(fig, "greyscale") == []


# --------------------------------------------------------------------------- panel letters


def test_panel_letters_at_different_heights_are_caught():
    """The first pass's layout: each letter heads the legend above its panel, so a panel
    with a taller legend has its letter further up."""
    fig, axes = _figure(2, width=7.2)
    for ax, n in zip(axes, (1, 4)):
        handles = [Patch(facecolor=c, label=f"class {c}") for c in pplot.CYCLE[:n]]
        legend = ax.legend(handles, [h.get_label() for h in handles], loc="lower left",
                           bbox_to_anchor=(0.0, 1.02), title=f"({'ab'[n == 4]})",
                           alignment="left")
        legend.get_title().set_fontsize(8)
    problems = _problems(fig, "letters")
    assert len(problems) == 1 and "different offsets up" in problems[0]
    fig, axes = _figure(2, width=7.2)
    for ax, n in zip(axes, (1, 4)):
        pplot.legend_above(ax, [Patch(facecolor=c, label=f"class {c}")
                                for c in pplot.CYCLE[:n]])
    pplot.label_panels(axes)
    assert _problems(fig, "letters") == []


# --------------------------------------------------------------------------- labels over data


def test_a_label_box_over_the_data_is_caught():
    fig, (ax,) = _figure()
    x = np.linspace(0, 2, 50)
    ax.plot(x, x)
    ax.annotate(r"$f = \sqrt{2}$", (1.0, 1.0), ha="center", va="center",
                bbox={"fc": "white", "ec": "none"})
    (problem,) = _problems(fig, "covering")
    assert problem.startswith("text in panel") and problem.endswith(
        "lies over plotted data (a line)")
    ax.texts[0].remove()
    ax.annotate(r"$f = \sqrt{2}$", (0.4, 1.7), ha="center", va="center")  # in the empty corner
    assert _problems(fig, "covering") == []


def test_a_legend_over_a_map_is_caught():
    fig, (ax,) = _figure()
    ax.pcolormesh(np.arange(20.0).reshape(4, 5))
    ax.legend([Patch(facecolor="k")], ["a class"], loc="upper right")
    assert "lies over plotted data (QuadMesh)" in _problems(fig, "covering")[0]
    pplot.legend_above(ax, [Patch(facecolor="k", label="a class")])
    assert _problems(fig, "covering") == []


# --------------------------------------------------------------------------- units


def test_an_axis_without_its_unit_is_caught():
    fig, (ax,) = _figure()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel(r"$\omega$")
    ax.set_ylabel(r"error $\epsilon$")
    assert _problems(fig, "units") == [r"axis label '$\omega$' has no unit",
                                       r"axis label 'error $\epsilon$' has no unit"]
    ax.set_xlabel(r"$\omega$ (rad s$^{-1}$)")
    ax.set_ylabel(r"$|\Delta\varphi|$ (rad)")
    assert _problems(fig, "units") == []
    ax.set_xlabel("$f$")  # the friction coefficient is a number
    ax.set_ylabel(r"$\delta/l$")  # a ratio of lengths
    assert _problems(fig, "units") == []


def test_a_stated_value_without_its_unit_is_caught():
    fig, (ax,) = _figure()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel("$t$ (s)")
    ax.set_ylabel(r"$\theta$ (rad)")
    ax.set_title(r"$\theta_0$ = 1 rad, $\omega_0$ = 0; $f$ = 0.2, $g$ = 0", loc="left")
    assert _problems(fig, "units") == [r"the value $\omega_0$ = 0 has no unit",
                                       "the value $g$ = 0 has no unit"]
    ax.set_title(r"$\theta_0$ = 1 rad, $\omega_0$ = 0 rad s$^{-1}$; $f$ = 0.2, "
                 r"$g$ = 0 m s$^{-2}$", loc="left")
    assert _problems(fig, "units") == []


# --------------------------------------------------------------------------- one look per meaning


def _legend_figure(handles):
    fig, (ax,) = _figure()
    pplot.legend_above(ax, handles)
    return fig


def test_one_meaning_one_look_across_a_study():
    none = Patch(facecolor=OI["vermillion"], hatch="xx", label="none")
    hatch = dict(facecolor="none", edgecolor=OI["blue"], hatch="\\\\\\\\")
    # the referee's three cases: one colour for a class and a curve, one hatch for two
    # meanings, one meaning in two looks
    looks = {"maps": fr.legend_looks(_legend_figure([
                 none, Line2D([], [], color=OI["vermillion"], ls="--", label="(13) as printed")])),
             "solvability": fr.legend_looks(_legend_figure([
                 Patch(label="a branch loses contact", **hatch),
                 Patch(facecolor=OI["bluish_green"], label="stagnation")])),
             "portraits": fr.legend_looks(_legend_figure([
                 Patch(label="a contact would pull", **hatch),
                 Patch(facecolor="none", hatch="////", label="stagnation")]))}
    problems = fr.look_problems(looks)
    assert any("'(13) as printed' (maps) is drawn in the colour of the class 'none'" in p
               for p in problems), problems
    assert any("one look, two meanings: 'a branch loses contact'" in p for p in problems)
    assert any("'stagnation' looks different in solvability and portraits" in p
               for p in problems)
    assert len(problems) == 3
    mended = {"maps": fr.legend_looks(_legend_figure([
                  none, Line2D([], [], color="black", ls="--", label="(13) as printed")])),
              "solvability": fr.legend_looks(_legend_figure([
                  Patch(label="a contact would pull", **hatch), pplot.stagnation_patch()])),
              "portraits": fr.legend_looks(_legend_figure([
                  Patch(label="a contact would pull", **hatch), pplot.stagnation_patch()]))}
    assert fr.look_problems(mended) == []
