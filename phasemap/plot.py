r"""Figures in one publication style: atlas maps, profiles, fate maps, phase curves,
trajectories and work-precision diagrams.

Every figure function draws inside :func:`style`, an rc context (the global
``matplotlib.rcParams`` are never changed), and returns the
:class:`matplotlib.figure.Figure`.  Given ``ax=`` (an Axes, or a list of Axes
for a figure of several panels) it draws there instead and returns that
Axes' figure.  :func:`plot` (and the accessor ``ds.phasemap.plot()``, see
:mod:`phasemap.accessor`) picks the right function from the data:

==============  ===========================================  ============================
kind            how it is recognised                         figure
==============  ===========================================  ============================
``map``         a 2-D atlas from ``Scene.compute()``         :func:`map_figure`
``profile``     a 1-D atlas                                  :func:`profile_figure`
``fate``        a ``fate`` layer                             :func:`fate_figure`
``phase_curve`` global attribute ``phasemap_kind``           :func:`phase_curve_figure`
``trajectory``  global attribute ``phasemap_kind``           :func:`trajectory_figure`
==============  ===========================================  ============================

:func:`work_precision_figure` draws a benchmark table, and :func:`save_figure`
writes a figure as vector PDF and 300 dpi PNG.

>>> import numpy as np, phasemap
>>> ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 30),
...                                     "f": np.linspace(0, 1, 20)}, fixed={"omega": 0.0}).compute()
>>> phasemap.plot.atlas_kind(ds)
'map'
>>> fig = phasemap.plot.plot(ds)             # n_solutions, stagnation hatched
>>> fig.axes[0].get_xlabel()
'$\\varphi$ (rad)'

The style
---------
* Widths for papers: ``size="one_column"`` (3.5 in) or ``"two_column"``
  (7.2 in), or a width in inches; each kind chooses its height.
* 8 pt DejaVu Sans with matching mathtext, embedded as TrueType in PDFs.
* No top or right spines, no grid, no titles inside the axes; frameless
  legends outside the axes, above them.
* Categories: the Okabe-Ito palette (:data:`OKABE_ITO`), one colour per
  meaning in every figure (:data:`CATEGORY_COLOURS`): a Painleve
  inconsistency is vermillion whether it is ``none`` in an ``n_solutions``
  map or ``no_solution`` in a fate map, indeterminacy is blue, rest is green;
  the ordinary class (``unique``, ``no``) is pale grey.  Only the categories
  present are drawn and listed.
* Overlays on a map: ``stagnation`` hatched ``////`` with a solid outline,
  ``contact_lost`` hatched ``\\\\`` in blue with a dashed outline,
  ``singular`` cells as black dots.
* Continuous layers: Paul Tol's *sunset* (:data:`SUNSET`; diverging,
  centred on zero) when the data has both signs, viridis otherwise, with a
  colour bar limited to the 2nd-98th percentiles (``robust=True``; arrows
  mark data beyond, such as an acceleration that grows without bound near a
  singular state); NaN (an inadmissible branch, a motion that did not come
  to rest) is left blank.  Counts (``n_reversals``) get one colour per value.
* Motions: black curves; events marked by kind (:data:`EVENT_MARKERS`, fates
  in the colours of the fate map), the terminal one larger and edged.
* Axis labels from the model's symbols and UDUNITS units, as mathtext:
  ``$\varphi$ (rad)``, ``$\omega$ (rad s$^{-1}$)``, ``$f$`` for a
  dimensionless quantity; angles in rad spanning at least pi are ticked in
  multiples of pi.  Names the model does not know fall back to
  ``long_name (units)`` (a one- or two-letter name is taken as a symbol).

For developers
--------------
A new kind of figure needs: a ``<kind>_figure(ds, ..., ax=None, size=...)``
function that opens ``with style():``, gets its axes from :func:`_axes` and
its labels from :func:`axis_label`, takes category colours from
:func:`category_colour` and puts legends above with :func:`_legend_above`; a
rule in :func:`atlas_kind`; and a line in :func:`plot`.
"""

from __future__ import annotations

import contextlib
import math
import os
import pathlib
import re
from typing import Mapping, Sequence

import matplotlib as mpl
import matplotlib.colors as mcolors
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import FuncFormatter, MaxNLocator, MultipleLocator

from . import events as _events
from ._version import __version__
from .atlas import atomic_path, destination
from .model import Model
from .models import get_model

__all__ = [
    "CATEGORY_COLOURS",
    "CATEGORY_HATCHES",
    "EVENT_MARKERS",
    "KINDS",
    "METHOD_NAMES",
    "OKABE_ITO",
    "SIZES",
    "STYLE",
    "SUNSET",
    "atlas_kind",
    "axis_label",
    "category_colour",
    "category_hatch",
    "fate_figure",
    "define_symbols",
    "figure_legend",
    "figure_texts",
    "fixed_values",
    "fixed_values_text",
    "format_units",
    "label_panels",
    "legend_columns",
    "map_figure",
    "mark_inverted_rests",
    "outer_labels",
    "panels",
    "phase_curve_figure",
    "plot",
    "profile_figure",
    "save_figure",
    "style",
    "trajectory_figure",
    "width_of",
    "work_precision_figure",
    "wrap",
]

# --------------------------------------------------------------------------- style

#: Figure widths in inches for a journal's one-column and two-column figures.
SIZES = {"one_column": 3.5, "two_column": 7.2}

#: Okabe & Ito (2008), "Color Universal Design": distinguishable with any
#: common colour-vision deficiency.
OKABE_ITO = {
    "black": "#000000",
    "orange": "#E69F00",
    "sky_blue": "#56B4E9",
    "bluish_green": "#009E73",
    "yellow": "#F0E442",
    "blue": "#0072B2",
    "vermillion": "#D55E00",
    "reddish_purple": "#CC79A7",
}
_OI = OKABE_ITO
#: The ordinary class (a unique solution, a flag that is off): out of the way.
PALE_GREY = "#DDDDDD"
GREY = "#999999"

#: One colour per category meaning, the same in every figure.
CATEGORY_COLOURS = {
    # n_solutions
    "none": _OI["vermillion"],
    "unique": PALE_GREY,
    "two": _OI["blue"],
    "continuum": _OI["reddish_purple"],
    "three_or_more": _OI["orange"],
    # yes/no flags
    "no": PALE_GREY,
    # fates (the terminal events)
    "rest": _OI["bluish_green"],
    "contact_lost": _OI["sky_blue"],
    "no_solution": _OI["vermillion"],
    "indeterminate": _OI["blue"],
    "singular": _OI["black"],
    "horizon": _OI["yellow"],
    "left_domain": _OI["reddish_purple"],
    "max_events": GREY,
    "max_steps": GREY,
    "step_failure": _OI["orange"],
    "stiff": GREY,
}

#: The colour of ``yes`` in a yes/no layer, by layer.
FLAG_COLOURS = {
    "stagnation": _OI["bluish_green"],
    "contact_lost": _OI["sky_blue"],
    "singular": _OI["black"],
}

#: A hatch per category meaning, so that classes whose colours are close in
#: greyscale print (vermillion and bluish green, sky blue and orange) stay
#: apart: the ordinary classes and rest are solid, the paradoxes hatched.  The
#: hatch is drawn in :data:`HATCH_COLOURS` (white on dark fills).
CATEGORY_HATCHES = {
    "none": "xx",
    "no_solution": "xx",
    "two": "....",
    "indeterminate": "....",
    "continuum": "||||",
    "three_or_more": "++++",
    "contact_lost": "\\\\\\\\",
    "max_events": "----",
    "max_steps": "////",
    "step_failure": "OO",
    "stiff": "++++",
}
#: The colour of a category's hatch lines, by meaning (default white).
HATCH_COLOURS = {"contact_lost": _OI["blue"], "three_or_more": _OI["black"]}

#: Colours for anything else, in order (methods of a benchmark, unknown categories).
CYCLE = [_OI[k] for k in ("blue", "orange", "bluish_green", "vermillion", "reddish_purple",
                          "sky_blue", "black", "yellow")]

#: Paul Tol's diverging *sunset* scheme (https://personal.sron.nl/~pault/); NaN blank.
SUNSET = mcolors.LinearSegmentedColormap.from_list("phasemap_sunset", [
    "#364B9A", "#4A7BB7", "#6EA6CD", "#98CAE1", "#C2E4EF", "#EAECCC",
    "#FEDA8B", "#FDB366", "#F67E4B", "#DD3D2D", "#A50026"])
SEQUENTIAL = "viridis"

#: Event markers, by event name: (marker, face colour).  Events that end a
#: motion are filled, larger and edged in black; the others are small.
EVENT_MARKERS = {
    "start": ("o", "white"),
    "reversal": ("o", _OI["black"]),
    "stick": ("s", _OI["bluish_green"]),
    "slip": ("^", _OI["orange"]),
    "switch": ("d", _OI["reddish_purple"]),
    "rest": ("s", _OI["bluish_green"]),
    "contact_lost": ("^", _OI["sky_blue"]),
    "no_solution": ("X", _OI["vermillion"]),
    "indeterminate": ("P", _OI["blue"]),
    "continuum": ("*", _OI["reddish_purple"]),
    "singular": ("D", _OI["black"]),
    "horizon": (">", _OI["yellow"]),
    "left_domain": ("<", _OI["reddish_purple"]),
    "max_events": ("h", GREY),
    "max_steps": ("h", GREY),
    "step_failure": ("v", _OI["orange"]),
}
_TERMINAL = {e.name.lower() for e in _events.Event if e.terminal}

#: Markers for the lines of a work-precision diagram, in order.
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*"]

_FONT = 8.0
#: The rcParams every figure is drawn with (applied with :func:`style`).
STYLE: dict = {
    "font.family": "sans-serif",
    "font.sans-serif": ["DejaVu Sans"],
    "mathtext.fontset": "dejavusans",
    "font.size": _FONT,
    "axes.labelsize": _FONT,
    "axes.titlesize": _FONT,
    "axes.titlelocation": "left",
    "axes.titlepad": 3.0,
    "xtick.labelsize": _FONT,
    "ytick.labelsize": _FONT,
    "legend.fontsize": _FONT,
    "legend.title_fontsize": _FONT,
    "figure.titlesize": _FONT,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.grid": False,
    "axes.linewidth": 0.6,
    "axes.labelpad": 2.0,
    "axes.unicode_minus": True,
    "axes.formatter.use_mathtext": True,
    "axes.formatter.limits": (-3, 4),
    "axes.prop_cycle": mpl.cycler(color=CYCLE),
    "xtick.direction": "out",
    "ytick.direction": "out",
    "xtick.major.size": 3.0,
    "ytick.major.size": 3.0,
    "xtick.minor.size": 1.5,
    "ytick.minor.size": 1.5,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "xtick.minor.width": 0.5,
    "ytick.minor.width": 0.5,
    "xtick.major.pad": 2.0,
    "ytick.major.pad": 2.0,
    "lines.linewidth": 1.0,
    "lines.markersize": 4.0,
    "patch.linewidth": 0.5,
    "hatch.linewidth": 0.5,
    "hatch.color": _OI["black"],
    "legend.frameon": False,
    "legend.handlelength": 1.2,
    "legend.handleheight": 0.8,
    "legend.handletextpad": 0.4,
    "legend.columnspacing": 1.0,
    "legend.borderaxespad": 0.2,
    "legend.borderpad": 0.0,
    "legend.labelspacing": 0.3,
    "image.cmap": SEQUENTIAL,
    "figure.dpi": 150,
    "figure.facecolor": "white",
    "figure.constrained_layout.use": True,
    "figure.constrained_layout.h_pad": 0.02,
    "figure.constrained_layout.w_pad": 0.02,
    "figure.constrained_layout.hspace": 0.03,
    "figure.constrained_layout.wspace": 0.03,
    "savefig.dpi": 300,
    "savefig.facecolor": "white",
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
    "svg.fonttype": "none",
}

KINDS = ("map", "profile", "fate", "phase_curve", "trajectory")

#: Layers drawn over a map rather than as the map itself.
OVERLAYS = ("stagnation", "contact_lost", "singular")


def style() -> contextlib.AbstractContextManager:
    """The rc context every figure function draws in: ``with phasemap.plot.style(): ...``."""
    return mpl.rc_context(STYLE)


# --------------------------------------------------------------------------- labels


def format_units(units: str | None) -> str:
    """UDUNITS units as mathtext: ``"rad s-1"`` -> ``"rad s$^{-1}$"``; ``"1"`` -> ``""``."""
    if units is None:
        return ""
    units = str(units).strip()
    if units in ("", "1"):
        return ""
    out = []
    for token in units.split():
        m = re.fullmatch(r"([A-Za-z]+)(-?\d+)", token)
        if m and m.group(2) != "1":
            out.append(f"{m.group(1)}$^{{{m.group(2)}}}$")
        else:
            out.append(m.group(1) if m else token)
    return " ".join(out)


def _square_units(units: str | None) -> str | None:
    """``"rad s-1"`` -> ``"rad2 s-2"``."""
    if units is None or str(units).strip() in ("", "1"):
        return units
    out = []
    for token in str(units).split():
        m = re.fullmatch(r"([A-Za-z]+)(-?\d+)?", token)
        if not m:
            return f"({units})2"
        out.append(f"{m.group(1)}{2 * int(m.group(2) or 1)}")
    return " ".join(out)


def _with_units(text: str, units: str | None) -> str:
    u = format_units(units)
    return f"{text} ({u})" if u else text


def _model_or_none(ds: xr.Dataset) -> Model | None:
    try:
        return get_model(ds.attrs.get("phasemap_model"))
    except ValueError:
        return None


def _symbol_and_units(ds: xr.Dataset, name: str) -> tuple[str, str | None] | None:
    """The mathtext symbol (without $) and units of ``name``, if the model knows it."""
    model = _model_or_none(ds)
    if model is None:
        return None
    if name in model.variables:
        v = model.variables[name]
        return v.symbol or v.name, v.units
    for var in model.accelerations + model.reactions:
        for branch in model.branches:
            if name == f"{var.name}_{branch}":
                return rf"{var.symbol}\ [\mathrm{{{_math_words(branch)}}}]", var.units
    for branch in model.branches:
        if name == f"coef_{branch}":
            c = model.coefficient
            return rf"{c.symbol}\ [\mathrm{{{_math_words(branch)}}}]", c.units
    head, _, moment = name.rpartition("_")  # phi_rest, omega_end: the value at a moment
    if head in model.variables and moment in _MOMENTS:
        v = model.variables[head]
        return rf"{v.symbol}_{{\mathrm{{{moment}}}}}", v.units
    return None


#: Suffixes that name a variable's value at a moment of a motion (``phi_rest``).
_MOMENTS = ("rest", "start", "end", "final", "initial", "min", "max")


def _math_words(text: str) -> str:
    return text.replace("_", r"\ ")


def axis_label(ds: xr.Dataset, name: str) -> str:
    r"""The axis label of variable or coordinate ``name`` of ``ds``, as mathtext.

    From the model's :class:`~phasemap.Variable` when it knows the name
    (``"$\varphi$ (rad)"``, ``"$f$"`` for units ``1``), including a branch's
    fields (``"$\ddot\varphi\ [\mathrm{slide\ pos}]$ (rad s$^{-2}$)"``) and a
    variable at a moment (``phi_rest``: ``"$\varphi_{\mathrm{rest}}$ (rad)"``);
    otherwise from the variable's attributes: ``"$t$ (s)"`` for a one- or
    two-letter name, else ``"Long name (units)"``.
    """
    known = _symbol_and_units(ds, name)
    if known is not None:
        symbol, units = known
        return _with_units(f"${symbol}$", units)
    attrs = ds[name].attrs if name in ds.variables else {}
    units = attrs.get("units")
    if attrs.get("phasemap_symbol"):  # a phase curve of a model whose coordinate is not phi
        return _with_units(f"${attrs['phasemap_symbol']}$", units)
    if re.fullmatch(r"[A-Za-z]{1,2}", name):
        return _with_units(f"${name}$", units)
    text = str(attrs.get("long_name", name.replace("_", " ")))
    return _with_units(text[:1].upper() + text[1:], units)


def _squared_label(ds: xr.Dataset, name: str) -> str:
    known = _symbol_and_units(ds, name)
    if known is not None:
        symbol, units = known
    else:
        symbol, units = name, ds[name].attrs.get("units")
    return _with_units(f"${symbol}^2$", _square_units(units))


def _meaning_text(meaning: str) -> str:
    return meaning.replace("_", " ")


# --------------------------------------------------------------------------- what was held fixed


def _number(value: float) -> str:
    """A value for a label: 4 significant digits, a typographic minus."""
    text = f"{float(value):.4g}"
    if "e" in text:
        mant, exp = text.split("e")
        text = rf"{mant}\times10^{{{int(exp)}}}"
        text = f"${text}$"
    return text.replace("-", "\u2212")


def _value_text(ds: xr.Dataset, name: str, value: float, initial: bool = False) -> str:
    known = _symbol_and_units(ds, name)
    symbol, units = known if known is not None else (name, None)
    if initial:
        symbol = rf"{symbol}_0" if "_" not in symbol and "^" not in symbol else \
            rf"{{{symbol}}}_0"
    u = format_units(units)
    return f"${symbol}$ = {_number(value)}" + (f" {u}" if u else "")


def _fixed_items(ds: xr.Dataset) -> tuple[list[str], list[str]]:
    model = _model_or_none(ds)
    order = list(model.variables) if model is not None else []
    out: tuple[list[str], list[str]] = ([], [])
    for items, prefix, initial in ((out[0], "phasemap_initial_", True),
                                   (out[1], "phasemap_fixed_", False)):
        names = [k[len(prefix):] for k in ds.attrs if k.startswith(prefix)]
        names.sort(key=lambda n: order.index(n) if n in order else len(order))
        for name in names:
            if name in ds.coords or name in ds.dims:
                continue
            try:
                value = float(np.asarray(ds.attrs[prefix + name]).ravel()[0])
            except (TypeError, ValueError, IndexError):
                continue
            if initial and name == "x" and "xdot" in names:
                continue  # the slider's position does not enter the equations
            items.append(_value_text(ds, name, value, initial))
    return out


def fixed_values(ds: xr.Dataset) -> list[str]:
    r"""The initial state and the fixed values of ``ds``, one label each, as mathtext.

    Read from the global attributes ``phasemap_initial_<name>`` (a trajectory
    or a phase curve: ``$\varphi_0$ = 1 rad``) and ``phasemap_fixed_<name>``
    (``$\omega$ = 0.5 rad s$^{-1}$``), in the order of the model's variables;
    a name that is a coordinate of ``ds`` is not fixed and is left out.
    """
    initial, fixed = _fixed_items(ds)
    return initial + fixed


def _visible_length(text: str) -> float:
    """Roughly how many characters wide ``text`` renders (mathtext markup dropped)."""
    plain = re.sub(r"\\[A-Za-z]+", "x", text)
    plain = re.sub(r"[${}^_]", "", plain)
    return len(plain)


def wrap(items: Sequence[str], width: float, sep: str = ", ") -> str:
    """Join ``items`` with ``sep`` in lines no wider than ``width`` inches at the house font."""
    per_line = max(10, int(width / (0.5 * _FONT / 72.0)))
    lines, line = [], ""
    for item in items:
        candidate = f"{line}{sep}{item}" if line else item
        if line and _visible_length(candidate) > per_line:
            lines.append(line + sep.rstrip())
            line = item
        else:
            line = candidate
    if line:
        lines.append(line)
    return "\n".join(lines)


def fixed_values_text(ds: xr.Dataset, width: float | None = None) -> str:
    r"""What was held fixed, as one annotation: ``"$\omega$ = 0.5 rad s$^{-1}$, $f$ = 0.3, ..."``.

    :func:`fixed_values`, joined and wrapped to ``width`` inches (no wrapping
    when None); the initial state of a motion comes first, separated from
    the parameters by a semicolon.  Empty when nothing was fixed.
    """
    initial, fixed = _fixed_items(ds)
    if initial and fixed:
        initial[-1] += ";"
    items = initial + fixed
    if not items:
        return ""
    text = ", ".join(items) if width is None else wrap(items, width)
    return text.replace(";,", ";")


def _annotate(axes: Sequence[Axes], text: str, own_figure: bool) -> None:
    """Put ``text`` (what was held fixed) above the figure.

    On a figure of one panel, and wherever the caller gave the axes, it is
    the title of the legend above the first panel (or that panel's title
    when it has no legend), left-aligned; on a figure of several panels that
    this module made (or one whose panel has a title already), a left-aligned
    figure title.
    """
    if not text:
        return
    if own_figure and (len(axes) > 1 or axes[0].get_title(loc="left")):
        axes[0].get_figure(root=False).suptitle(text, x=0.01, ha="left",
                                                fontsize=_FONT, linespacing=1.3)
        return
    _title(axes[0], text)


def _title(ax: Axes, text: str, prepend: bool = False) -> None:
    """Set (or with ``prepend``, prefix) the left-aligned heading of ``ax``.

    The heading is the title of the legend above ``ax`` when there is one,
    so that legend and heading never overlap; otherwise the axes' title.
    """
    legend = ax.get_legend()
    if legend is not None and getattr(legend, "_phasemap_above", False):
        old = legend.get_title().get_text()
        legend.set_title(f"{text} {old}".rstrip() if prepend else text)
        legend.get_title().set_fontsize(_FONT)
        return
    old = ax.get_title(loc="left")
    ax.set_title(f"{text} {old}".rstrip() if prepend else text, loc="left")


def label_panels(axes: Sequence[Axes], start: int = 0) -> None:
    """Letter the panels (a), (b), ... at the start of each one's left-aligned heading.

    The letter goes where :func:`_title` puts a heading: into the title of a
    legend above the panel, else into the panel's title, so that letters sit
    at the top left of every panel in every figure.
    """
    for i, ax in enumerate(axes):
        _title(ax, f"({chr(ord('a') + start + i)})", prepend=True)


def figure_legend(fig: Figure, handles: Sequence, labels: Sequence[str] | None = None, *,
                  title: str | None = None, ncols: int | None = None):
    """One legend above all panels of ``fig``, headed by ``title`` (what was held fixed).

    The heading is the legend's own title, left-aligned, so that it never
    overlaps the entries (a figure title and an ``outside`` legend would).
    ``ncols`` defaults to as many columns as fit the figure's width.
    """
    handles = list(handles)
    labels = [h.get_label() for h in handles] if labels is None else list(labels)
    if ncols is None:
        ncols = legend_columns(labels, fig.get_figwidth() * 0.95)
    legend = fig.legend(handles, labels, loc="outside upper center", ncols=ncols,
                        title=title or None, alignment="left")
    legend.get_title().set_fontsize(_FONT)
    return legend


def figure_texts(fig: Figure) -> list[str]:
    """Every heading of ``fig``: figure titles, axes titles, legend titles and labels.

    For tests and reviews: what a reader sees written on the figure apart
    from tick labels.
    """
    out = []
    for f in [fig, *fig.subfigs]:
        if getattr(f, "_suptitle", None) is not None:
            out.append(f._suptitle.get_text())
        if getattr(f, "_supxlabel", None) is not None:
            out.append(f._supxlabel.get_text())
        for leg in f.legends:
            out.append(leg.get_title().get_text())
            out += [t.get_text() for t in leg.get_texts()]
    for ax in fig.get_axes():
        out += [ax.get_title(loc=loc) for loc in ("left", "center", "right")]
        out += [ax.get_xlabel(), ax.get_ylabel()]
        out += [t.get_text() for t in ax.texts]
        leg = ax.get_legend()
        if leg is not None:
            out.append(leg.get_title().get_text())
            out += [t.get_text() for t in leg.get_texts()]
    return [t for t in out if t]


def define_symbols(fig: Figure, definitions: Sequence[str], width: float | None = None) -> None:
    r"""A key below the panels that defines the symbols a legend or title uses.

    ``definitions`` such as ``r"$\lambda_k = 1 + \sin^2\varphi - kf\sin\varphi\cos\varphi$"``
    are joined with semicolons, wrapped to the figure width, and set
    left-aligned as the figure's bottom label (constrained layout makes room).
    """
    width = width or fig.get_figwidth() * 0.97
    fig.supxlabel(wrap(list(definitions), width, sep="; "), x=0.01, ha="left",
                  fontsize=_FONT, linespacing=1.3)


# --------------------------------------------------------------------------- kinds


def _is_categorical(var: xr.DataArray) -> bool:
    return "flag_values" in var.attrs and "flag_meanings" in var.attrs


def _flags(var: xr.DataArray) -> tuple[list[int], list[str]]:
    values = [int(v) for v in np.atleast_1d(np.asarray(var.attrs["flag_values"])).ravel()]
    meanings = str(var.attrs["flag_meanings"]).split()
    if len(values) != len(meanings):
        raise ValueError(f"layer {var.name!r}: {len(values)} flag_values but "
                         f"{len(meanings)} flag_meanings")
    return values, meanings


def atlas_kind(ds: xr.Dataset) -> str:
    """Which figure suits ``ds``: one of :data:`KINDS`.

    The global attribute ``phasemap_kind`` decides first (``"atlas"`` there
    means: decide from the dimensions); then a ``fate`` layer makes a fate
    map; otherwise the dimensions of the first categorical layer (or of the
    first layer, if none is categorical) make a ``profile`` (1-D) or a
    ``map`` (2-D).

    Raises
    ------
    ValueError
        if ``ds`` is not a Dataset, carries neither ``phasemap_kind`` nor
        ``phasemap_model``, has no layers, names an unknown kind, or is an
        atlas of 3 or more dimensions (select a 2-D slice first).
    """
    if not isinstance(ds, xr.Dataset):
        raise ValueError(f"not a phasemap atlas: expected an xarray.Dataset, "
                         f"got {type(ds).__name__}")
    kind = ds.attrs.get("phasemap_kind")
    if kind is not None and kind != "atlas":
        if kind not in KINDS:
            raise ValueError(f"unknown phasemap_kind {kind!r}; known kinds: {', '.join(KINDS)}")
        return str(kind)
    if kind is None and "phasemap_model" not in ds.attrs:
        raise ValueError("not a phasemap atlas: no phasemap_model or phasemap_kind "
                         "global attribute")
    if not ds.data_vars:
        raise ValueError("not a phasemap atlas: it has no layers (data variables)")
    if "fate" in ds.data_vars:
        return "fate"
    var = _first_layer(ds)
    if var.ndim == 1:
        return "profile"
    if var.ndim == 2:
        return "map"
    dims = ", ".join(map(str, var.dims))
    raise ValueError(f"a {var.ndim}-D atlas ({dims}) has no single figure: select a 1-D or 2-D "
                     f"slice first, e.g. ds.isel({var.dims[-1]}=0)")


def _first_layer(ds: xr.Dataset) -> xr.DataArray:
    for var in ds.data_vars.values():
        if _is_categorical(var):
            return var
    return next(iter(ds.data_vars.values()))


def _layer(ds: xr.Dataset, name: str) -> xr.DataArray:
    if not isinstance(name, str) or name not in ds.data_vars:
        raise ValueError(f"unknown layer {name!r}; this dataset has: "
                         f"{', '.join(map(str, ds.data_vars))}")
    return ds[name]


def _require(ds: xr.Dataset, names: Sequence[str], kind: str) -> None:
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise ValueError(f"not a {kind} dataset: missing {', '.join(missing)}")


# --------------------------------------------------------------------------- dispatch


def plot(ds: xr.Dataset, layer: str | Sequence[str] | None = None, *, ax=None,
         size: str | float = "one_column", **kw) -> Figure:
    """The right figure for ``ds`` (see :func:`atlas_kind`); returns the Figure.

    ``layer`` picks what is drawn: for a map, the layer (default
    ``n_solutions``); for a profile, one layer or a list (default: every
    categorical layer); for a fate dataset, ``fate`` (the default) draws
    :func:`fate_figure`, any other layer a plain :func:`map_figure` (a
    1-D fate dataset is drawn as a profile); for a trajectory, the states
    to draw.  Phase curves take no layer.  Other
    keywords go to the figure function.
    """
    kind = atlas_kind(ds)
    if kind == "map":
        return map_figure(ds, layer, ax=ax, size=size, **kw)
    if kind == "profile":
        return profile_figure(ds, layer, ax=ax, size=size, **kw)
    if kind == "fate":
        if ds["fate"].ndim == 1:  # fates along one line of initial states
            return profile_figure(ds, layer or "fate", ax=ax, size=size, **kw)
        if layer in (None, "fate"):
            return fate_figure(ds, ax=ax, size=size, **kw)
        return map_figure(ds, layer, ax=ax, size=size, **kw)
    if kind == "phase_curve":
        if layer is not None:
            raise ValueError(f"a phase curve has no layers to choose; got layer={layer!r}")
        return phase_curve_figure(ds, ax=ax, size=size, **kw)
    return trajectory_figure(ds, states=layer, ax=ax, size=size, **kw)


# --------------------------------------------------------------------------- figure plumbing


def width_of(size: str | float) -> float:
    """The width in inches of ``size``: ``"one_column"`` (3.5), ``"two_column"`` (7.2) or a
    positive number of inches; ValueError otherwise."""
    if isinstance(size, str):
        if size not in SIZES:
            raise ValueError(f"unknown size {size!r}; use one of {', '.join(SIZES)} "
                             "or a width in inches")
        return SIZES[size]
    try:
        width = float(size)
    except (TypeError, ValueError):
        raise ValueError(f"size must be one of {', '.join(SIZES)} or a width in inches, "
                         f"got {size!r}") from None
    if not math.isfinite(width) or width <= 0:
        raise ValueError(f"size must be a positive width in inches, got {size!r}")
    return width


def _axes(ax, n: int, figsize: tuple[float, float], what: str, **subplots) -> list[Axes]:
    """``n`` axes: new ones in a new figure, or the caller's ``ax`` (one Axes or a list)."""
    if ax is None:
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=figsize, layout="constrained")
        grid = subplots.pop("grid", (n, 1))
        axes = fig.subplots(*grid, squeeze=False, **subplots).ravel().tolist()
        return axes[:n]
    axes = [ax] if isinstance(ax, Axes) else list(ax)
    if len(axes) != n or not all(isinstance(a, Axes) for a in axes):
        raise ValueError(f"{what} draws {n} panel{'s' if n > 1 else ''}: pass "
                         f"{'one Axes' if n == 1 else f'a list of {n} Axes'} as ax, or ax=None")
    return axes


#: Widths (inches) from which panels stand side by side rather than stacked.
WIDE = 5.0


def panels(n: int, size: str | float = "two_column", *, height: float, panel_height: float,
           extra: float = 1.0, sharex: bool = False, sharey: bool = False,
           **subplots) -> tuple[Figure, list[Axes]]:
    """A new figure of ``n`` panels laid out for the width of ``size``.

    At two-column width (:data:`WIDE` inches or more) the panels stand side by
    side in one row, ``height`` inches high in all; narrower, they are stacked
    in one column, each ``panel_height`` inches high, plus ``extra`` inches
    for the legend above and the key below, so that no panel is squeezed to a
    third of a 3.5 in column.  ``sharex``/``sharey`` and other keywords go to
    ``Figure.subplots``; call :func:`outer_labels` once the panels are drawn.
    Draw inside :func:`style`.
    """
    import matplotlib.pyplot as plt

    width = width_of(size)
    wide = width >= WIDE
    rows, cols = (1, n) if wide else (n, 1)
    fig = plt.figure(figsize=(width, height if wide else extra + n * panel_height),
                     layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False, sharex=sharex, sharey=sharey,
                        **subplots).ravel().tolist()
    return fig, axes


def outer_labels(axes: Sequence[Axes]) -> None:
    """Label a shared axis only once: x on the bottom panels, y on the left ones.

    Where panels of a grid share an axis, the inner panels lose that axis's
    label and tick labels (their ticks stay); an axis that is not shared keeps
    its labels everywhere.
    """
    for ax in axes:
        spec = ax.get_subplotspec()
        if spec is None:
            continue
        if len(ax.get_shared_x_axes().get_siblings(ax)) > 1 and not spec.is_last_row():
            ax.set_xlabel("")
            ax.tick_params(axis="x", labelbottom=False)
        if len(ax.get_shared_y_axes().get_siblings(ax)) > 1 and not spec.is_first_col():
            ax.set_ylabel("")
            ax.tick_params(axis="y", labelleft=False)


def legend_columns(labels: Sequence[str], width: float) -> int:
    """How many legend columns of ``labels`` fit in ``width`` inches at the house font,
    rows balanced."""
    column = _legend_size(labels, 1)[0]
    ncols = max(1, min(len(labels), int(width // column)))
    rows = -(-len(labels) // ncols)
    return -(-len(labels) // rows)


def _legend_size(labels: Sequence[str], ncols: int) -> tuple[float, float]:
    """Roughly the (width, height) in inches of a frameless legend of ``labels`` in
    ``ncols`` columns at the house font (the estimate :func:`legend_columns` uses)."""
    em = _FONT / 72.0
    rc = mpl.rcParams
    column = (rc["legend.handlelength"] + rc["legend.handletextpad"] + rc["legend.columnspacing"]
              + 0.58 * max(_visible_length(s) for s in labels)) * em
    rows = -(-len(labels) // ncols)
    return ncols * column, rows * (1.0 + rc["legend.labelspacing"]) * em * 1.2


def _legend_fits(labels: Sequence[str], width: float, height: float) -> bool:
    """Whether a one-column legend of ``labels`` fits a ``width`` x ``height`` inch slot."""
    w, h = _legend_size(labels, 1)
    return w <= 0.95 * width and h <= 0.9 * height


def _legend_height(labels: Sequence[str], width: float) -> float:
    """The height (inches) a legend of ``labels`` above ``width`` inches of panels needs."""
    return 0.1 + _legend_size(labels, legend_columns(labels, width))[1]


def _legend_above(ax: Axes, handles: list, labels: list[str] | None = None,
                  title: str | None = None):
    """A frameless legend above ``ax``, left-aligned with it, in as many columns as fit.

    ``title`` (what was held fixed, a panel letter) heads the legend, so that
    heading and entries never overlap.  With no handles the title becomes the
    axes' left title.
    """
    if labels is None:
        labels = [h.get_label() for h in handles]
    if not handles:
        if title:
            ax.set_title(title, loc="left")
        return None
    width = ax.get_figure(root=True).get_figwidth() * ax.get_position().width * 0.95
    legend = ax.legend(handles, labels, loc="lower left", bbox_to_anchor=(0.0, 1.02),
                       ncols=legend_columns(labels, width), borderaxespad=0.0, title=title,
                       alignment="left")
    legend.get_title().set_fontsize(_FONT)
    legend._phasemap_above = True
    return legend


def _coord(ds: xr.Dataset, dim: str) -> np.ndarray:
    if dim in ds.coords:
        return np.asarray(ds[dim].values, dtype=float)
    return np.arange(ds.sizes[dim], dtype=float)


def _angle_ticks(ax: Axes, axis: str, lo: float, hi: float) -> None:
    """Tick an angle axis in rad at multiples of pi/4, pi/2 or pi when it spans pi or more."""
    span = hi - lo
    if not (math.isfinite(span) and span >= math.pi * 0.99):
        return
    quarters = 1 if span < 1.5 * math.pi else 2 if span <= 4.5 * math.pi else 4
    step = quarters * math.pi / 4

    def fmt(x, _pos):
        k = round(x / (math.pi / 4))
        if k == 0:
            return "0"
        sign = "-" if k < 0 else ""
        k = abs(k)
        g = math.gcd(k, 4)
        num, den = k // g, 4 // g
        head = r"\pi" if num == 1 else rf"{num}\pi"
        return f"${sign}{head}$" if den == 1 else f"${sign}{head}/{den}$"

    target = ax.xaxis if axis == "x" else ax.yaxis
    target.set_major_locator(MultipleLocator(step))
    target.set_major_formatter(FuncFormatter(fmt))


def _label_axis(ax: Axes, ds: xr.Dataset, axis: str, name: str, values=None) -> None:
    (ax.set_xlabel if axis == "x" else ax.set_ylabel)(axis_label(ds, name))
    units = ds[name].attrs.get("units") if name in ds.variables else None
    known = _symbol_and_units(ds, name)
    if known is not None:
        units = known[1]
    if units == "rad" and values is not None and np.size(values):
        finite = np.asarray(values, dtype=float)
        finite = finite[np.isfinite(finite)]
        if finite.size:
            _angle_ticks(ax, axis, float(finite.min()), float(finite.max()))


def category_colour(meaning: str, layer: str | None = None, used: Sequence[str] = ()) -> str:
    """The colour of category ``meaning`` of ``layer``: the same in every figure."""
    if meaning == "yes" and layer in FLAG_COLOURS:
        return FLAG_COLOURS[layer]
    if meaning in CATEGORY_COLOURS:
        return CATEGORY_COLOURS[meaning]
    for colour in CYCLE:
        if colour not in used:
            return colour
    return CYCLE[len(used) % len(CYCLE)]


def category_hatch(meaning: str) -> tuple[str | None, str]:
    """The hatch of category ``meaning`` and its colour (None: solid); see :data:`CATEGORY_HATCHES`."""
    return CATEGORY_HATCHES.get(meaning), HATCH_COLOURS.get(meaning, "white")


def _patch(colour: str, label: str, meaning: str | None = None) -> Patch:
    light = colour.upper() in (PALE_GREY, _OI["yellow"].upper(), "WHITE", "#FFFFFF")
    hatch, hatch_colour = category_hatch(meaning) if meaning else (None, "white")
    return Patch(facecolor=colour, edgecolor=GREY if light else colour, linewidth=0.4,
                 hatch=hatch, hatchcolor=hatch_colour, label=label)


# --------------------------------------------------------------------------- maps


def _grid(ds: xr.Dataset, var: xr.DataArray, x: str | None) -> tuple[str, str]:
    if var.ndim != 2:
        raise ValueError(f"layer {var.name!r} has {var.ndim} dimension(s) "
                         f"({', '.join(map(str, var.dims))}); a map needs 2")
    dims = [str(d) for d in var.dims]
    if x is None:
        x = dims[0]
    if x not in dims:
        raise ValueError(f"x={x!r} is not a dimension of {var.name!r} ({', '.join(dims)})")
    y = dims[1] if x == dims[0] else dims[0]
    return x, y


def _edges(c: np.ndarray) -> np.ndarray:
    """Cell edges around centres ``c`` (midpoints, half a cell beyond the ends)."""
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def _padded(xc, yc, mask: np.ndarray):
    """Centres padded to the cell edges, and ``mask`` padded to match: a contour at 0.5
    of it ends where the cells do."""
    xe, ye = _edges(xc), _edges(yc)
    xp = np.concatenate([[xe[0]], xc, [xe[-1]]])
    yp = np.concatenate([[ye[0]], yc, [ye[-1]]])
    return xp, yp, np.pad(mask.astype(float), 1, mode="edge")


def _hatch_cells(ax: Axes, xc, yc, mask: np.ndarray, hatch: str, colour: str):
    """Hatch the cells where ``mask`` (rows y, columns x) holds, with no outline."""
    xp, yp, z = _padded(xc, yc, mask)
    filled = ax.contourf(xp, yp, z, levels=[0.5, 1.5], colors="none", hatches=[hatch])
    filled.set_hatchcolor(colour)
    filled.set_edgecolor("none")
    return filled


def _draw_categorical(ax: Axes, xc, yc, codes: np.ndarray, var: xr.DataArray,
                      all_categories: bool = False, lost: np.ndarray | None = None
                      ) -> list[Patch]:
    """A categorical layer (rows y, columns x) in its category colours; the legend handles.

    Categories with a hatch (:data:`CATEGORY_HATCHES`) are hatched over their
    colour.  ``lost`` (rows y, columns x) marks where a one-sided contact
    would have to pull: in an ``n_solutions`` layer those cells are drawn as
    their own class, ``contact lost``, so that ``none`` means a Painleve
    inconsistency only.
    """
    values, meanings = _flags(var)
    masks = [(m, codes == v) for v, m in zip(values, meanings)]
    if lost is not None and str(var.name) == "n_solutions" and lost.any():
        none = dict(zip(meanings, values)).get("none")
        moved = lost & (codes == none)
        if moved.any():
            masks = [(m, mask & ~moved) for m, mask in masks]
            masks.insert(1, ("contact_lost", moved))
    present = [(m, mask) for m, mask in masks if all_categories or mask.any()]
    if not present:
        present = masks
    colours: list[str] = []
    for m, _ in present:
        colours.append(category_colour(m, str(var.name), used=colours))
    index = np.full(codes.shape, -1, dtype=np.int16)
    for i, (_, mask) in enumerate(present):
        index[mask] = i
    cmap = mcolors.ListedColormap(colours)
    norm = mcolors.BoundaryNorm(np.arange(len(present) + 1) - 0.5, len(present))
    ax.pcolormesh(_edges(xc), _edges(yc), np.ma.masked_less(index, 0), cmap=cmap, norm=norm,
                  shading="flat", rasterized=True, linewidth=0)
    for m, mask in present:
        hatch, hatch_colour = category_hatch(m)
        if hatch and mask.any():
            _hatch_cells(ax, xc, yc, mask, hatch, hatch_colour)
    return [_patch(c, _meaning_text(m), m) for c, (m, _) in zip(colours, present)]


def _draw_continuous(ax: Axes, xc, yc, data: np.ndarray, label: str, *, robust: bool = True,
                     location: str = "right"):
    """A float or count layer (rows y, columns x) with a colour bar; NaN left blank.

    With ``robust`` the colour limits are the 2nd and 98th percentiles (a
    branch's acceleration grows without bound near a singular state), and
    the colour bar's ends show arrows where the data goes beyond them.
    """
    data = np.asarray(data)
    finite = data[np.isfinite(data)] if data.dtype.kind == "f" else data.ravel()
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    integer = data.dtype.kind in "iu"
    vlo, vhi = lo, hi
    if robust and not integer and finite.size:
        vlo, vhi = (float(v) for v in np.percentile(finite, [2.0, 98.0]))
    if integer and hi - lo <= 16:
        cmap = mpl.colormaps[SEQUENTIAL].resampled(int(hi - lo) + 1)
        norm = mcolors.BoundaryNorm(np.arange(lo, hi + 2) - 0.5, cmap.N)
    elif lo < 0 < hi:
        cmap, m = SUNSET, max(-vlo, vhi, np.finfo(float).tiny)
        norm = mcolors.Normalize(-m, m)
    else:
        cmap = mpl.colormaps[SEQUENTIAL]
        norm = mcolors.Normalize(vlo, vhi if vhi > vlo else vlo + 1.0)
    below, above = lo < norm.vmin, hi > norm.vmax
    extend = "both" if below and above else "min" if below else "max" if above else "neither"
    cmap = cmap.with_extremes(bad=(0, 0, 0, 0))
    mesh = ax.pcolormesh(_edges(xc), _edges(yc), np.ma.masked_invalid(data.astype(float)),
                         cmap=cmap, norm=norm, shading="flat", rasterized=True, linewidth=0)
    cbar = ax.figure.colorbar(mesh, ax=ax, location=location, aspect=30, pad=0.02,
                              fraction=0.05, extend=extend, extendfrac=0.04)
    cbar.outline.set_linewidth(0.5)
    cbar.ax.tick_params(width=0.6, length=2.5)
    cbar.set_label(label)
    if integer:
        cbar.locator = MaxNLocator(integer=True)
        cbar.update_ticks()
    return cbar


def _mask_overlay(ax: Axes, xc, yc, mask: np.ndarray, *, hatch: str, colour: str,
                  linestyle: str, label: str) -> Patch | None:
    """Hatch the cells where ``mask`` (rows y, columns x) holds, and outline them."""
    if not mask.any():
        return None
    xp, yp, z = _padded(xc, yc, mask)
    _hatch_cells(ax, xc, yc, mask, hatch, colour)
    if not mask.all():
        ax.contour(xp, yp, z, levels=[0.5], colors=[colour], linewidths=0.6,
                   linestyles=linestyle)
    return Patch(facecolor="none", edgecolor=colour, hatch=hatch, linewidth=0.6,
                 linestyle=linestyle, label=label)


def _overlays(ax: Axes, ds: xr.Dataset, main: str, x: str, y: str, xc, yc,
              shown: np.ndarray | None = None) -> list:
    """Hatch ``stagnation`` and ``contact_lost`` and draw the ``singular`` set over a map.

    ``shown`` marks cells the map itself already draws as ``contact lost``
    (see :func:`_draw_categorical`); they are not hatched twice, and the
    hatch over any other class is listed as "a branch loses contact" (a
    slip branch would need a contact to pull while another branch holds).
    """
    handles = []
    styles = {"stagnation": ("////", _OI["black"], "solid"),
              "contact_lost": ("\\\\\\\\", _OI["blue"], "dashed")}
    for name, (hatch, colour, ls) in styles.items():
        if name == main or name not in ds.data_vars or set(ds[name].dims) != {x, y}:
            continue
        mask = np.asarray(ds[name].transpose(y, x).values) == 1
        if name == "contact_lost" and shown is not None:
            mask = mask & ~shown
        label = _meaning_text(name)
        if name == "contact_lost" and shown is not None:
            # over another class: some branch would need a contact to pull, another holds
            label = "a branch loses contact"
        h = _mask_overlay(ax, xc, yc, mask, hatch=hatch, colour=colour, linestyle=ls,
                          label=label)
        if h is not None:
            handles.append(h)
    if main != "singular" and "singular" in ds.data_vars and set(ds.singular.dims) == {x, y}:
        mask = np.asarray(ds.singular.transpose(y, x).values) == 1
        handles += _singular_set(ax, ds, mask, x, y, xc, yc)
    return handles


def _singular_set(ax: Axes, ds: xr.Dataset, mask: np.ndarray, x: str, y: str, xc, yc) -> list:
    """Draw the singular set as the curve it is, where the data allows, else as dots.

    A coefficient layer (``coef_<branch>``) on the same axes is contoured at
    zero (one line style per branch); a row or column of singular cells (the
    coefficient does not depend on the other axis, as 2 - f^2 or delta - l)
    is a straight line; singular cells off those are dots.  The legend shows
    a line for a line, a dot for dots.
    """
    handles = []
    model = _model_or_none(ds)
    symbol = model.coefficient.symbol if model is not None and model.coefficient else None
    label = f"singular (${symbol} = 0$)" if symbol else "singular"
    coefs = [n for n in ds.data_vars if str(n).startswith("coef_")
             and set(ds[n].dims) == {x, y}]
    if not mask.any() and not coefs:
        return handles
    drawn = np.zeros_like(mask)
    line = {"color": _OI["black"], "lw": 1.2, "zorder": 4}
    styles = ["solid", "dashed", "dashdot", "dotted"]
    for i, name in enumerate(coefs):
        z = np.asarray(ds[name].transpose(y, x).values, float)
        if np.nanmin(z) < 0 < np.nanmax(z):
            ax.contour(xc, yc, z, levels=[0.0], colors=[_OI["black"]], linewidths=1.2,
                       linestyles=styles[i % len(styles)], zorder=4)
            branch = str(name)[len("coef_"):]
            handles.append(Line2D([], [], ls=styles[i % len(styles)], label=(
                f"{label}, {_meaning_text(branch)}" if len(coefs) > 1 else label), **line))
            drawn[:] = True
    if not drawn.all():
        rows = np.flatnonzero(mask.all(axis=1))
        cols = np.flatnonzero(mask.all(axis=0))
        for j in rows:
            ax.axhline(yc[j], **line)
            drawn[j, :] = True
        for i in cols:
            ax.axvline(xc[i], **line)
            drawn[:, i] = True
        if rows.size or cols.size:
            handles.append(Line2D([], [], label=label, **line))
    rest = mask & ~drawn
    if rest.any():
        jj, ii = np.nonzero(rest)
        ax.plot(xc[ii], yc[jj], ls="none", marker="o", ms=1.5, mew=0, color=_OI["black"],
                rasterized=True, zorder=4)
        handles.append(Line2D([], [], ls="none", marker="o", ms=2.5, mew=0,
                              color=_OI["black"], label=label if not handles else
                              "singular (isolated cells)"))
    return handles


def _default_map_layer(ds: xr.Dataset) -> str:
    if "n_solutions" in ds.data_vars:
        return "n_solutions"
    for name, var in ds.data_vars.items():
        if _is_categorical(var) and name not in OVERLAYS:
            return str(name)
    return str(_first_layer(ds).name)


def map_figure(ds: xr.Dataset, layer: str | None = None, *, x: str | None = None, ax=None,
               size: str | float = "one_column", overlays: bool = True,
               all_categories: bool = False, robust: bool = True,
               colorbar: str = "right") -> Figure:
    """A 2-D map of one layer of an atlas.

    A categorical layer (``flag_values``/``flag_meanings``; default
    ``n_solutions``) is drawn in its category colours with a legend above
    the axes listing the categories present (all of them with
    ``all_categories=True``).  A float layer gets a colour map and a colour
    bar: diverging and centred on zero when the data has both signs, limited
    to the 2nd-98th percentiles with ``robust`` (arrows on the colour bar show
    data beyond); NaN cells are left blank.  With ``overlays`` the ``stagnation`` cells are
    hatched and outlined, ``contact_lost`` cells hatched the other way in
    blue with a dashed outline, and ``singular`` cells dotted, when the atlas
    has those layers.  ``x`` names the dimension along the x axis (default:
    the layer's first); ``colorbar`` places a float layer's colour bar
    (``"right"``, or ``"bottom"`` under a stack of panels that share x).
    """
    if layer is None:
        atlas_kind(ds)  # a clear error for what is not an atlas at all
        layer = _default_map_layer(ds)
    var = _layer(ds, layer)
    xdim, ydim = _grid(ds, var, x)
    width = width_of(size)
    height = width * (0.86 if width < 5 else 0.55)
    with style():
        (a,) = _axes(ax, 1, (width, height), "map_figure")
        xc, yc = _coord(ds, xdim), _coord(ds, ydim)
        data = np.asarray(var.transpose(ydim, xdim).values)
        handles = []
        lost = None
        if overlays and "contact_lost" in ds.data_vars and layer != "contact_lost" \
                and set(ds.contact_lost.dims) == {xdim, ydim}:
            lost = np.asarray(ds.contact_lost.transpose(ydim, xdim).values) == 1
        shown = None
        if _is_categorical(var):
            handles = _draw_categorical(a, xc, yc, data, var, all_categories, lost=lost)
            if lost is not None and str(var.name) == "n_solutions":
                none = dict(zip(_flags(var)[1], _flags(var)[0])).get("none")
                shown = lost & (data == none)
        else:
            _draw_continuous(a, xc, yc, data, axis_label(ds, layer), robust=robust,
                             location=colorbar)
        if overlays:
            handles += _overlays(a, ds, layer, xdim, ydim, xc, yc, shown=shown)
        _label_axis(a, ds, "x", xdim, _edges(xc))
        _label_axis(a, ds, "y", ydim, _edges(yc))
        xe, ye = _edges(xc), _edges(yc)
        a.set_xlim(xe[0], xe[-1])
        a.set_ylim(ye[0], ye[-1])
        _legend_above(a, handles, title=fixed_values_text(ds, _panel_width(a)) or None)
    return a.figure


def _panel_width(ax: Axes) -> float:
    """The width of ``ax`` in inches (before layout: its share of the figure)."""
    return ax.get_figure(root=True).get_figwidth() * ax.get_position().width


# --------------------------------------------------------------------------- profiles


def profile_figure(ds: xr.Dataset, layers: str | Sequence[str] | None = None, *, ax=None,
                   size: str | float = "one_column") -> Figure:
    """A 1-D atlas: each layer against the axis, one panel per layer, sharing x.

    A categorical layer is a step plot whose y ticks are its categories (all
    of them, so profiles of one layer read alike); a float layer is a line.
    Each panel is named above its top left corner (the layer, or the
    symbol and units of a float layer).  The default is every categorical
    layer, ``n_solutions`` first.
    """
    if layers is None:
        atlas_kind(ds)
        layers = [str(n) for n, v in ds.data_vars.items() if _is_categorical(v)] or \
            [str(_first_layer(ds).name)]
    elif isinstance(layers, str):
        layers = [layers]
    variables = [_layer(ds, n) for n in layers]
    for var in variables:
        if var.ndim != 1:
            raise ValueError(f"layer {var.name!r} has {var.ndim} dimensions; a profile needs 1")
    dim = str(variables[0].dims[0])
    if any(str(v.dims[0]) != dim for v in variables):
        raise ValueError("a profile's layers must share one dimension")
    rows = [len(_flags(v)[0]) if _is_categorical(v) else 5 for v in variables]
    heights = [0.12 + 0.15 * r for r in rows]
    width = width_of(size)
    with style():
        axes = _axes(ax, len(variables), (width, 0.4 + sum(h + 0.2 for h in heights)),
                     "profile_figure", sharex=True, gridspec_kw={"height_ratios": heights})
        xc = _coord(ds, dim)
        for a, var in zip(axes, variables):
            data = np.asarray(var.values)
            if _is_categorical(var):
                values, meanings = _flags(var)
                a.step(xc, data.astype(float), where="mid", color=_OI["black"], lw=1.0)
                a.set_yticks(values, [_meaning_text(m) for m in meanings])
                a.set_ylim(min(values) - 0.5, max(values) + 0.5)
                a.set_title(_layer_title(var))
            else:
                a.plot(xc, data, color=_OI["black"])
                a.set_title(axis_label(ds, str(var.name)))
            if a is not axes[-1]:
                a.tick_params(axis="x", labelbottom=False)
        _label_axis(axes[-1], ds, "x", dim, xc)
        if xc.size > 1:
            axes[-1].set_xlim(xc.min(), xc.max())
        if len(axes) > 1:
            label_panels(axes)
        _annotate(axes, fixed_values_text(ds, width * 0.97), ax is None)
    return axes[0].figure


def _layer_title(var: xr.DataArray) -> str:
    name = {"n_solutions": "number of solutions"}.get(str(var.name), str(var.name))
    name = name.replace("_", " ")
    return name[:1].upper() + name[1:]


# --------------------------------------------------------------------------- fate maps


def fate_figure(ds: xr.Dataset, *, extra: str | None = None, x: str | None = None, ax=None,
                size: str | float = "one_column", robust: bool = True) -> Figure:
    """A fate map: what becomes of each initial state, in the fate colours.

    The categories present in ``fate`` (rest, contact lost, no solution...)
    are listed above the map.  ``extra`` adds a second panel with another
    layer of the dataset, such as ``phi_rest`` (the rest angle, blank where
    the motion did not come to rest), ``n_reversals`` or ``t_rest``: beside
    the fate map at two-column width (sharing the y axis), with its colour
    bar on the right; below it at one-column width (sharing the x axis),
    with its colour bar underneath.  Either way the bar stays clear of the
    legend and heading above the fate map.
    """
    atlas_kind(ds)
    fate = _layer(ds, "fate")
    if not _is_categorical(fate):
        raise ValueError("layer 'fate' needs flag_values and flag_meanings")
    xdim, ydim = _grid(ds, fate, x)
    width = width_of(size)
    wide = width >= 5
    extra_var = None
    if extra is not None:
        extra_var = _layer(ds, extra)
        _grid(ds, extra_var, xdim)
    if extra_var is None:
        figsize, grid, share = (width, width * (0.86 if not wide else 0.55)), (1, 1), {}
    elif wide:
        figsize, grid, share = (width, width * 0.5), (1, 2), {"sharey": True}
    else:
        figsize, grid, share = (width, width * 1.75), (2, 1), {"sharex": True}
    with style():
        axes = _axes(ax, grid[0] * grid[1], figsize, "fate_figure", grid=grid,
                     **share)
        xc, yc = _coord(ds, xdim), _coord(ds, ydim)
        xe, ye = _edges(xc), _edges(yc)
        handles = _draw_categorical(axes[0], xc, yc,
                                    np.asarray(fate.transpose(ydim, xdim).values), fate)
        if extra_var is not None:
            data = np.asarray(extra_var.transpose(ydim, xdim).values)
            _draw_continuous(axes[1], xc, yc, data, axis_label(ds, extra), robust=robust,
                             location="right" if wide else "bottom")
        for i, a in enumerate(axes):
            if not (i == 0 and "sharex" in share):
                _label_axis(a, ds, "x", xdim, xe)
            else:
                a.tick_params(axis="x", labelbottom=False)
            if not (i == 1 and "sharey" in share):
                _label_axis(a, ds, "y", ydim, ye)
            else:
                a.tick_params(axis="y", labelleft=False)
            a.set_xlim(xe[0], xe[-1])
            a.set_ylim(ye[0], ye[-1])
        handles += mark_inverted_rests(axes, ds, xdim, ydim, xc, yc)
        _legend_above(axes[0], handles)
        if len(axes) > 1:
            label_panels(axes)
        _annotate(axes, fixed_values_text(ds, width * 0.97 if ax is None and len(axes) > 1
                                          else _panel_width(axes[0])), ax is None)
    return axes[0].figure


def mark_inverted_rests(axes: Sequence[Axes], ds: xr.Dataset, x: str, y: str, xc, yc
                        ) -> list:
    """Ring the cells whose motion came to rest in an inverted zone (cos phi_rest < 0).

    Such rests are rare and isolated (the motion has just the energy to creep
    into the zone about the upper position, often with no reversal), and a
    reader would take them for noise; the ring and its legend entry say what
    they are.  Needs ``phi_rest`` on the map's axes.
    """
    if "phi_rest" not in ds.data_vars or set(ds.phi_rest.dims) != {x, y}:
        return []
    phi_rest = np.asarray(ds.phi_rest.transpose(y, x).values, float)
    with np.errstate(invalid="ignore"):
        inverted = np.cos(phi_rest) < 0
    if not inverted.any():
        return []
    jj, ii = np.nonzero(inverted)
    # a ring a little wider than a cell on a coarse map; on a fine one (cells under 2 pt,
    # where such rests line up along curves) a dot a cell wide, which hides nothing
    cell = min(_panel_width(a) for a in axes) * 72.0 / max(len(xc), 1)
    ring = cell >= 2.0
    mark = {"ls": "none", "marker": "o", "mec": _OI["black"],
            "mfc": "none" if ring else _OI["black"], "mew": 0.7 if ring else 0.0}
    for a in axes:
        a.plot(xc[ii], yc[jj], ms=4.0 if ring else max(cell, 1.0), zorder=6, **mark)
    return [Line2D([], [], ms=4.0 if ring else 2.5,
                   label=r"rest inverted ($\cos\varphi_\mathrm{rest} < 0$)", **mark)]


# --------------------------------------------------------------------------- motions


def _event_flags(var: xr.DataArray) -> dict[int, str]:
    if _is_categorical(var):
        values, meanings = _flags(var)
    else:
        values, meanings = list(_events.EVENT_VALUES), _events.EVENT_MEANINGS.split()
    return dict(zip(values, meanings))


def _event_style(name: str) -> dict:
    marker, colour = EVENT_MARKERS.get(name, ("o", GREY))
    if name in _TERMINAL:
        # a translucent face: ends that coincide show as stacked edges, and the events
        # drawn above (reversals, the start) stay visible through it
        return {"marker": marker, "ms": 6.0 if marker != "*" else 8.0,
                "mfc": mcolors.to_rgba(colour, 0.75), "mec": _OI["black"], "mew": 0.6,
                "ls": "none", "zorder": 5, "clip_on": False}
    hollow = name in ("start", "stick", "slip", "switch")
    return {"marker": marker, "ms": 3.5 if name != "reversal" else 3.0,
            "mfc": "white" if hollow else colour,
            "mec": _OI["black"] if name == "start" else colour, "mew": 0.8, "ls": "none",
            "zorder": 6, "clip_on": False}


def _event_handles(names: Sequence[str]) -> list[Line2D]:
    order = {n: i for i, n in enumerate(EVENT_MARKERS)}
    return [Line2D([], [], label=_meaning_text(n), **_event_style(n))
            for n in sorted(set(names), key=lambda n: order.get(n, len(order)))]


def _zero_line(ax: Axes, values: np.ndarray) -> None:
    finite = values[np.isfinite(values)]
    if finite.size and finite.min() < 0 < finite.max():
        ax.axhline(0.0, color=PALE_GREY, lw=0.6, zorder=0)


def phase_curve_figure(ds: xr.Dataset, *, squared: bool = False, ax=None,
                       size: str | float = "one_column") -> Figure:
    r"""A phase curve: :math:`\omega` (:math:`\omega^2` with ``squared``) against :math:`\varphi`.

    Each stage is drawn separately (no line joins one stage's end to the next
    one's start); each stage end is marked by its reason (reversal, rest,
    contact lost...), the terminal one larger and edged; the start is an
    open circle.  The legend above lists the reasons present.

    Needs ``phi``, ``omega`` and the stage of each point (``point_stage``, as
    :func:`phasemap.phase_curve` writes it, or ``stage``) on dimension
    ``point``, and ``stage_end_reason`` (Event flags), ``stage_end_phi``,
    ``stage_end_omega`` on dimension ``stage``.  ``omega_squared`` is used for
    the squared plot when present.
    """
    _require(ds, ("phi", "omega", "stage_end_reason", "stage_end_phi", "stage_end_omega"),
             "phase curve")
    stage_of_point = next((n for n in ("point_stage", "stage") if n in ds.variables
                           and ds[n].dims == ds.phi.dims), None)
    if stage_of_point is None:
        raise ValueError("not a phase curve dataset: missing point_stage (the stage of "
                         "each point)")
    width = width_of(size)
    figsize = (width, width * (0.78 if width < 5 else 0.45))
    phi, omega = np.asarray(ds.phi.values, float), np.asarray(ds.omega.values, float)
    stage = np.asarray(ds[stage_of_point].values)
    if squared:
        y = (np.asarray(ds.omega_squared.values, float) if "omega_squared" in ds.variables
             else omega ** 2)
    else:
        y = omega
    with style():
        (a,) = _axes(ax, 1, figsize, "phase_curve_figure")
        for s in np.unique(stage):
            sel = stage == s
            a.plot(phi[sel], y[sel], color=_OI["black"], lw=1.0, zorder=3)
        if phi.size:
            a.plot(phi[:1], y[:1], **_event_style("start"))
        flags = _event_flags(ds.stage_end_reason)
        reasons = np.asarray(ds.stage_end_reason.values)
        end_phi = np.asarray(ds.stage_end_phi.values, float)
        end_y = np.asarray(ds.stage_end_omega.values, float)
        end_y = end_y ** 2 if squared else end_y
        names = ["start"] if phi.size else []
        for code in np.unique(reasons):
            name = flags.get(int(code), f"event {int(code)}")
            sel = reasons == code
            a.plot(end_phi[sel], end_y[sel], **_event_style(name))
            names.append(name)
        if not squared:
            _zero_line(a, y)
        _label_axis(a, ds, "x", "phi", phi)
        a.set_ylabel(_squared_label(ds, "omega") if squared else axis_label(ds, "omega"))
        _legend_above(a, _event_handles(names),
                      title=fixed_values_text(ds, _panel_width(a)) or None)
    return a.figure


def trajectory_figure(ds: xr.Dataset, *, states: str | Sequence[str] | None = None,
                      phase_plane: bool = False, ax=None,
                      size: str | float = "one_column") -> Figure:
    r"""A trajectory: each state against time, one panel per state, events marked.

    Each event after the start is marked on every state's curve by its kind
    (reversal, stick, rest...), the terminal event larger and edged, with a
    dashed vertical line at its time across the panels; the legend above
    lists the kinds present.  ``states`` picks and orders the states
    (default: every state variable on dimension ``t``).  With
    ``phase_plane=True``, one panel of :math:`\omega` against
    :math:`\varphi` (the model's first coordinate and its velocity, from the
    attribute ``phasemap_phase_plane``; or ``states=(x, y)``) instead, where
    the start is marked too.

    Needs a coordinate ``t`` and state variables on it (categorical
    variables such as the active ``branch`` are not states); events, when
    any, as ``event_t``, ``event_kind`` (Event flags) and ``event_<state>`` on
    dimension ``event``.
    """
    _require(ds, ("t",), "trajectory")
    available = [str(n) for n, v in ds.data_vars.items()
                 if v.dims == ("t",) and not _is_categorical(v)]
    if states is None:
        plane = str(ds.attrs.get("phasemap_phase_plane", "phi omega")).split()
        states = plane if phase_plane else available
    elif isinstance(states, str):
        states = [states]
    states = list(states)
    for name in states:
        if name not in available:
            raise ValueError(f"unknown state {name!r}; this trajectory has: "
                             f"{', '.join(available)}")
    if phase_plane and len(states) != 2:
        raise ValueError(f"a phase plane needs two states, got {states}")
    if not states:
        raise ValueError("this trajectory has no state variables on dimension 't'")
    t = _coord(ds, "t")
    has_events = "event_kind" in ds.variables and "event_t" in ds.variables
    if has_events:
        flags = _event_flags(ds.event_kind)
        kinds = [flags.get(int(k), f"event {int(k)}") for k in np.asarray(ds.event_kind.values)]
        t_ev = np.asarray(ds.event_t.values, float)
    else:
        kinds, t_ev = [], np.array([])
    width = width_of(size)
    with style():
        if phase_plane:
            (a,) = _axes(ax, 1, (width, width * (0.78 if width < 5 else 0.45)),
                         "trajectory_figure")
            xs, ys = (np.asarray(ds[s].values, float) for s in states)
            a.plot(xs, ys, color=_OI["black"], lw=1.0, zorder=3)
            _mark_events(a, ds, kinds, states[0], states[1], start=True)
            _zero_line(a, ys)
            _label_axis(a, ds, "x", states[0], xs)
            _label_axis(a, ds, "y", states[1], ys)
            axes = [a]
        else:
            per = 1.1
            axes = _axes(ax, len(states), (width, 0.55 + per * len(states)),
                         "trajectory_figure", sharex=True)
            terminal = [tt for tt, k in zip(t_ev, kinds) if k in _TERMINAL]
            for a, name in zip(axes, states):
                values = np.asarray(ds[name].values, float)
                a.plot(t, values, color=_OI["black"], lw=1.0, zorder=3)
                _mark_events(a, ds, kinds, "t", name)
                for tt in terminal:
                    a.axvline(tt, color=GREY, lw=0.6, ls="--", zorder=1)
                _label_axis(a, ds, "y", name, values)
                if a is not axes[-1]:
                    a.tick_params(axis="x", labelbottom=False)
            _label_axis(axes[-1], ds, "x", "t")
            if t.size > 1:
                axes[-1].set_xlim(t.min(), t.max())
            if len(axes) > 1:
                axes[0].figure.align_ylabels(axes)
        shown = [k for k in kinds if phase_plane or k != "start"]
        _legend_above(axes[0], _event_handles(shown))
        if len(axes) > 1:
            label_panels(axes)
        _annotate(axes, fixed_values_text(ds, width * 0.97 if ax is None and len(axes) > 1
                                          else _panel_width(axes[0])), ax is None)
    return axes[0].figure


def _mark_events(ax: Axes, ds: xr.Dataset, kinds: list[str], xname: str, yname: str,
                 start: bool = False) -> None:
    """Mark each event at its (x, y), styled by kind; ``start`` too if asked."""
    if not kinds:
        return
    xkey = "event_t" if xname == "t" else f"event_{xname}"
    ykey = f"event_{yname}"
    if xkey not in ds.variables or ykey not in ds.variables:
        return
    xs, ys = np.asarray(ds[xkey].values, float), np.asarray(ds[ykey].values, float)
    kinds_arr = np.asarray(kinds)
    for name in dict.fromkeys(kinds):
        if name == "start" and not start:
            continue
        sel = kinds_arr == name
        ax.plot(xs[sel], ys[sel], **_event_style(name))


# --------------------------------------------------------------------------- benchmarks

_WP_KEYS = ("method", "system", "tol", "error_final", "error_l2", "seconds")

#: The methods of a work-precision table as a reader knows them.
METHOD_NAMES = {
    "phasemap": "phasemap, Dormand–Prince 5(4)",
    "phasemap_DOP853": "phasemap, Dormand–Prince 8(5,3)",
    "simulate": "phasemap.simulate, Dormand–Prince 5(4)",
    "phase_curve": "phasemap first integrals",
    "RK45": "SciPy RK45, Dormand–Prince 5(4)",
    "DOP853": "SciPy DOP853, Dormand–Prince 8(5,3)",
    "Radau": "SciPy Radau IIA, order 5",
    "LSODA": "SciPy LSODA",
}
#: The built-in work-precision problems as panel headings.
SYSTEM_NAMES = {
    "hinge_weightless": r"hinge pendulum, $g$ = 0",
    "hinge_pendulum": "hinge pendulum",
    "ladder": "ladder",
    "wheel": "wheel",
    "elliptic_pendulum": "elliptic pendulum",
}


def _two_decades_shown(ax: Axes) -> None:
    """Widen each log axis of ``ax`` until two powers of ten lie on it: with fewer,
    matplotlib labels minor ticks (4x10^-4, 6x10^-4, ...), and they collide."""
    for get, put in ((ax.get_xlim, ax.set_xlim), (ax.get_ylim, ax.set_ylim)):
        lo, hi = get()
        if not 0 < lo < hi:
            continue
        a, b = math.log10(lo), math.log10(hi)
        while math.floor(b + 1e-9) - math.ceil(a - 1e-9) < 1:
            # extend the end nearer to its next power of ten, to it
            down, up = a - math.floor(a - 1e-9), math.ceil(b + 1e-9) - b
            if down <= up:
                a = math.floor(a - 1e-9) if down > 1e-9 else a - 1.0
            else:
                b = math.ceil(b + 1e-9) if up > 1e-9 else b + 1.0
        put(10.0 ** a, 10.0 ** b)


def work_precision_figure(table: Sequence[Mapping], *, error: str = "error_final", ax=None,
                          size: str | float = "two_column") -> Figure:
    r"""A work-precision diagram: error against run time, log-log, as in DiffEqDevTools.

    ``table`` is a list of dicts with keys ``method``, ``system``, ``tol``,
    ``error_final``, ``error_l2`` and ``seconds``, one per (method, system,
    tolerance), as :func:`phasemap.workprecision.work_precision` returns them.
    One panel per system (in order of appearance, lettered and named), one
    line per method (same colour and marker in every panel, named as in
    :data:`METHOD_NAMES`), points joined in order of tolerance.  When the rows
    carry ``seconds_min`` and ``seconds_max`` (the fastest and slowest of the
    timing rounds), each point sits at the fastest, which timing noise can
    only delay, and a bar reaches to the slowest.  ``error`` picks
    ``error_final`` (max norm of the state error at the final time) or
    ``error_l2``.  Points whose error or time is not positive and finite
    cannot be drawn on log axes and are left out.
    """
    if error not in ("error_final", "error_l2"):
        raise ValueError(f"error must be 'error_final' or 'error_l2', got {error!r}")
    rows = list(table)
    if not rows:
        raise ValueError("work_precision_figure: the table is empty")
    for i, row in enumerate(rows):
        missing = [k for k in _WP_KEYS if k not in row]
        if missing:
            raise ValueError(f"work_precision_figure: row {i} lacks {', '.join(missing)}")
    systems = list(dict.fromkeys(str(r["system"]) for r in rows))
    methods = list(dict.fromkeys(str(r["method"]) for r in rows))
    spread = all("seconds_min" in r and "seconds_max" in r for r in rows)
    rounds = max((int(r.get("n_samples", 0)) for r in rows), default=0)
    width = width_of(size)
    # three panels a row at two-column width, two at one column: narrower, the axis
    # labels and headings of neighbouring panels collide
    ncols = min(len(systems), 3 if width >= WIDE else 2)
    nrows = -(-len(systems) // ncols)
    panel_h = (width / ncols) * (0.8 if width >= 5 else 0.85)
    names = [METHOD_NAMES.get(m, m) for m in methods]
    long_x = ax is not None or width / ncols >= 2.2  # room for "Run time per trajectory (s)"
    # the key goes in a free panel slot when it fits there, else above the panels
    spare = (ax is None and nrows * ncols > len(systems)
             and _legend_fits(names, width / ncols, panel_h))
    top = 0.0 if spare or ax is not None else _legend_height(names, 0.95 * width)
    ylabel = (r"Final-state error $\|\Delta y\|_\infty$" if error == "error_final"
              else r"$L_2$ error along the motion")
    with style():
        axes = _axes(ax, nrows * ncols if spare else len(systems),
                     (width, top + 0.4 + panel_h * nrows), "work_precision_figure",
                     grid=(nrows, ncols))
        if spare:
            axes, spares = axes[:len(systems)], axes[len(systems):]
        handles = {}
        for i, (a, system) in enumerate(zip(axes, systems)):
            for j, method in enumerate(methods):
                pts = sorted(((float(r["tol"]),
                               float(r["seconds_min"] if spread else r["seconds"]),
                               float(r[error]),
                               float(r["seconds_max"] if spread else r["seconds"]))
                              for r in rows if str(r["system"]) == system
                              and str(r["method"]) == method), reverse=True)
                pts = [p for p in pts if all(math.isfinite(v) and v > 0 for v in p[1:3])]
                if not pts:
                    continue
                _, secs, errs, slow = (np.array(v) for v in zip(*pts))
                colour, marker = CYCLE[j % len(CYCLE)], MARKERS[j % len(MARKERS)]
                (line,) = a.plot(secs, errs, color=colour, marker=marker, ms=3.5, lw=1.0,
                                 label=METHOD_NAMES.get(method, method), zorder=3)
                if spread:
                    extra = np.where(np.isfinite(slow), np.maximum(slow - secs, 0.0), 0.0)
                    a.errorbar(secs, errs, xerr=[np.zeros_like(secs), extra], fmt="none",
                               ecolor=colour, elinewidth=0.8, capsize=1.5, capthick=0.6,
                               zorder=2)
                handles.setdefault(method, line)
            a.set_xscale("log")
            a.set_yscale("log")
            _two_decades_shown(a)
            title = SYSTEM_NAMES.get(system, system.replace("_", " "))
            # the heading may not reach over the next panel's tick labels: wrapped at its
            # commas to the axes' width (the slot less the tick labels), "(a) " included
            room = width / ncols - 0.55 - _visible_length("(a) ") * 0.5 * _FONT / 72.0
            a.set_title(wrap(title.split(", "), room), loc="left")
            if ax is not None or i % ncols == 0:
                a.set_ylabel(ylabel)
            if ax is not None or i + ncols >= len(systems):
                # a narrow panel has no room for the long label: the key says "per trajectory"
                a.set_xlabel("Run time per trajectory (s)" if long_x else "Run time (s)")
        if len(axes) > 1:
            label_panels(axes)
        fig = axes[0].get_figure(root=False)
        lines = [handles[m] for m in methods if m in handles]
        labels = [ln.get_label() for ln in lines]
        if ax is None and not spare:
            for extra in fig.axes[len(systems):]:
                extra.remove()
        if spare:
            for extra in spares[1:]:
                extra.remove()
            spares[0].set_axis_off()
            spares[0].legend(lines, labels, loc="center")
        elif ax is None:
            fig.legend(lines, labels, loc="outside upper center",
                       ncols=legend_columns(labels, width * 0.95))
        else:
            _legend_above(axes[0], lines)
        if ax is None:
            key = [r"$y$: the state in SI units (rad, rad s$^{-1}$, m, m s$^{-1}$)"]
            if not long_x:
                key.append("run time: per trajectory")
            if spread:
                key.append(f"points: the fastest of {rounds} timing rounds, bars: the slowest"
                           if rounds > 1 else "one timing round")
            define_symbols(fig, key)
    return axes[0].figure


# --------------------------------------------------------------------------- files


def save_figure(fig: Figure, stem: str | os.PathLike, *, dpi: int = 300
                ) -> tuple[pathlib.Path, pathlib.Path]:
    """Write ``fig`` as ``<stem>.pdf`` (vector, fonts embedded) and ``<stem>.png`` (``dpi``).

    A ``.pdf`` or ``.png`` suffix on ``stem`` is dropped.  Each file is
    written atomically (see :func:`phasemap.atlas.atomic_path`).  Returns the
    two paths, PDF first.

    Raises
    ------
    ValueError
        if the folder does not exist.
    """
    stem = pathlib.Path(os.path.expanduser(os.fspath(stem)))
    if stem.suffix.lower() in (".pdf", ".png"):
        stem = stem.with_suffix("")
    paths = []
    with style():
        for fmt in ("pdf", "png"):
            path = destination(stem.with_name(stem.name + "." + fmt))
            meta = ({"Creator": f"phasemap {__version__}"} if fmt == "pdf"
                    else {"Software": f"phasemap {__version__}"})
            with atomic_path(path) as tmp:
                fig.savefig(tmp, format=fmt, dpi=dpi, metadata=meta)
            paths.append(path)
    return paths[0], paths[1]
