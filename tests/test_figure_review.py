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


# --------------------------------------------------------------------------- what the legend names


def _class_map(colours, legend_colours, codes=None, bar=False, hide_row=False):
    """A categorical map of ``colours`` (classes 0, 1, ...) and a legend naming
    ``legend_colours``; ``hide_row`` draws a thick line over the one row of class 2."""
    import matplotlib.colors as mcolors

    fig, (ax,) = _figure()
    if codes is None:
        codes = np.zeros((30, 30))
        codes[:, 15:] = 1
        if len(colours) > 2:
            codes[14, :] = 2  # one row
    n = len(colours)
    mesh = ax.pcolormesh(codes, cmap=mcolors.ListedColormap(colours),
                         norm=mcolors.BoundaryNorm(np.arange(n + 1) - 0.5, n))
    if bar:
        fig.colorbar(mesh, ax=ax, label="$v$ (m s$^{-1}$)")
    if hide_row:
        ax.axhline(14.5, color="black", lw=6)
    ax.set_xlabel("$x$ (m)")
    ax.set_ylabel("$y$ (m)")
    if legend_colours:
        pplot.legend_above(ax, [Patch(facecolor=c, label=f"class {c}") for c in legend_colours])
    fig.canvas.draw()
    return fig


def test_a_legend_entry_with_nothing_drawn_is_caught():
    """The referee's case: the ladder's legend listed "continuum", whose one row of cells
    lay under the singular line."""
    grey, red, pink = pplot.PALE_GREY, OI["vermillion"], OI["reddish_purple"]
    problems = fr.legend_drawn_problems(_class_map([grey, red], [grey, red, pink]))
    assert problems == [f"legend entry 'class {pink}': nothing drawn shows it"]
    hidden = fr.legend_drawn_problems(_class_map([grey, red, pink], [grey, red, pink],
                                                 hide_row=True))
    assert hidden == [f"legend entry 'class {pink}': nothing drawn shows it"]
    assert fr.legend_drawn_problems(_class_map([grey, red, pink], [grey, red, pink])) == []
    # a legend inside its panel is not seen in its own swatches
    fig = _class_map([grey, red], [])
    fig.axes[0].legend([Patch(facecolor=c, label=c) for c in (grey, red, pink)],
                       [grey, red, pink], loc="center")
    fig.canvas.draw()
    assert fr.legend_drawn_problems(fig) == [f"legend entry '{pink}': nothing drawn shows it"]
    # a curve in the legend that no panel draws
    fig, (ax,) = _figure()
    ax.plot([0, 1], [0, 1], color="black", label="drawn")
    pplot.legend_above(ax, [*ax.get_lines(), Line2D([], [], color=OI["blue"], ls="--",
                                                    label="never drawn")])
    fig.canvas.draw()
    assert fr.legend_drawn_problems(fig) == ["legend entry 'never drawn': nothing drawn "
                                             "shows it"]


def test_a_region_with_no_legend_entry_is_caught():
    """The referee's case: the wheel's map at rest drew its plain class grey, unnamed."""
    grey, red = pplot.PALE_GREY, OI["vermillion"]
    problems = fr.legend_drawn_problems(_class_map([grey, red], [red]))
    assert len(problems) == 1 and "in #ddddddff" in problems[0] \
        and "has no legend entry" in problems[0], problems
    assert fr.legend_drawn_problems(_class_map([grey, red], [grey, red])) == []
    # a colour bar names its colours
    assert fr.legend_drawn_problems(_class_map([grey, red], [], bar=True)) == []


def test_classes_alike_in_grey_are_caught_hatched_or_not():
    """The referee's case: rest (Okabe and Ito's bluish green) beside no solution
    (vermillion, hatched): 0.05 apart in grey."""
    import xarray as xr

    codes = np.ones((30, 30), np.int8)
    codes[:, 15:] = 2
    ds = xr.Dataset({"fate": (("omega", "phi"), codes,
                              {"flag_values": np.array([1, 2], np.int8),
                               "flag_meanings": "rest no_solution"})},
                    coords={"phi": np.linspace(0, 1, 30), "omega": np.linspace(0, 1, 30)})
    old = pplot.CATEGORY_COLOURS["rest"]
    try:
        pplot.CATEGORY_COLOURS["rest"] = OI["bluish_green"]
        fig = pplot.map_figure(ds, "fate", x="phi")
        problems = fr.class_contrast_problems(fig)
        assert len(problems) == 1 and "'rest' and 'no_solution'" in problems[0], problems
    finally:
        pplot.CATEGORY_COLOURS["rest"] = old
    assert fr.class_contrast_problems(pplot.map_figure(ds, "fate", x="phi")) == []


def test_one_label_drawn_two_ways_is_caught():
    """The referee's case: a phase curve dotted in (a) and dashed in its zoom (b)."""
    def draw(second):
        fig, axes = _figure(2, 7.2)
        x = np.linspace(0, 1, 20)
        axes[0].plot(x, x, color="black", ls=pplot.DASHES[2], label="swing 2")
        axes[1].plot(x, x, color="black", label="swing 2", **second)
        return fig
    problems = fr.drawn_two_ways_problems(draw({"ls": "--"}))
    assert len(problems) == 1 and "'swing 2' is drawn one way" in problems[0]
    assert fr.drawn_two_ways_problems(draw({"ls": pplot.DASHES[2]})) == []


def test_one_layer_with_two_labels_is_caught():
    """The referee's case: n_reversals was "Reversals before rest" in a fate figure and
    its long name in a map; both now read it the same."""
    assert fr.layer_label_problems({"fates": [("n_reversals", "Reversals before rest")],
                                    "map": [("n_reversals", "Number of reversals")]})
    import xarray as xr

    import phasemap

    fate = np.full((20, 20), int(phasemap.Event.REST), np.int8)
    ds = xr.Dataset({"fate": (("omega", "phi"), fate,
                              {"flag_values": np.array([int(phasemap.Event.REST)], np.int8),
                               "flag_meanings": "rest"}),
                     "n_reversals": (("omega", "phi"), np.arange(400).reshape(20, 20) % 5,
                                     {"long_name": "number of reversals", "units": "1"})},
                    coords={"phi": np.linspace(0, 1, 20), "omega": np.linspace(0, 1, 20)},
                    attrs={"phasemap_model": "wheel"})
    labels = {"fates": fr.layer_labels(pplot.fate_figure(ds, extra="n_reversals")),
              "map": fr.layer_labels(pplot.map_figure(ds, "n_reversals", x="phi"))}
    assert labels["fates"] and labels["map"]
    assert fr.layer_label_problems(labels) == []
