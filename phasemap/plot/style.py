"""The house style: the rc parameters, and one look (colour, hatch, marker) per meaning.

Every table here is read by every figure, so that rest, a Painleve
inconsistency or a lost contact looks the same wherever it is drawn.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Sequence

import matplotlib as mpl
import matplotlib.colors as mcolors
import numpy as np
from matplotlib import patheffects
from matplotlib.patches import Patch

from phasemap.core import events as _events
from phasemap.plot import mathcache as _mathcache

# a mathtext label is laid out once per process, not once per file saved
_mathcache.install()

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
#: A neutral colour for what is neither a class nor a curve of its own (a stopped motion).
GREY = "#999999"
#: Okabe and Ito's bluish green, 53 % of the way to white: grey level 0.73, 0.11 from
#: sky blue (contact lost) and from yellow (horizon), 0.26 from vermillion (no solution).
PALE_GREEN = "#88D2BD"
#: Stagnation's hatch: dark enough over every class, lighter than a black curve over it;
#: also the fill of the rare rests in an inverted zone on a fate map.
DARK_GREY = "#555555"

#: One colour per category meaning, the same in every figure.
CATEGORY_COLOURS = {
    # n_solutions
    "none": _OI["vermillion"],
    "unique": PALE_GREY,
    "two": _OI["blue"],
    "continuum": _OI["reddish_purple"],
    # rare, and often a strip a few cells wide: dark, to be seen beside every class
    "three_or_more": _OI["black"],
    # yes/no flags
    "no": PALE_GREY,
    # fates (the terminal events); rest in a pale bluish green: Okabe and Ito's own is
    # 0.05 in grey from no_solution's vermillion, and rest is the commonest fate
    "rest": PALE_GREEN,
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

#: The colour of ``yes`` in a yes/no layer, by layer: a stagnation map looks as the
#: stagnation overlay does on the ordinary class (pale grey, hatched ``////``).
FLAG_COLOURS = {
    "stagnation": PALE_GREY,
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
HATCH_COLOURS = {"contact_lost": _OI["blue"], "three_or_more": _OI["yellow"]}


@dataclass(frozen=True)
class Overlay:
    """The look of a yes/no layer drawn over a map: hatch, colour, outline, legend label."""

    hatch: str
    colour: str
    linestyle: str
    label: str


#: The overlays, one look and one name each in every figure: stagnation (rest is
#: possible) dark grey ``////``, a contact that would have to pull blue ``\\``.  The
#: 1-D form of stagnation (a zone along one axis, a stick phase in time) is the same
#: hatch (:func:`stagnation_span`).
OVERLAYS = {
    "stagnation": Overlay("////", DARK_GREY, "solid", "stagnation"),
    "contact_lost": Overlay("\\\\\\\\", _OI["blue"], "dashed", "a contact would pull"),
}

#: Reference curves (closed forms, thresholds, printed formulas) are black; they are
#: told apart by their dashes, in this order, never by colour, and a white halo
#: (:data:`HALO`) keeps them visible over any class colour and in greyscale.
DASHES = ["solid", (0, (4.0, 1.5)), (0, (1.0, 1.3)), (0, (6.0, 1.5, 1.0, 1.5)),
          (0, (2.5, 1.2, 1.0, 1.2, 1.0, 1.2))]
#: A white outline under a reference curve.
HALO = [patheffects.withStroke(linewidth=2.4, foreground="white"), patheffects.Normal()]

#: Colours for anything else, in order (methods of a benchmark, unknown categories).
CYCLE = [_OI[k] for k in ("blue", "orange", "bluish_green", "vermillion", "reddish_purple",
                          "sky_blue", "black", "yellow")]

#: Paul Tol's diverging *sunset* scheme (https://personal.sron.nl/~pault/); NaN blank.
SUNSET = mcolors.LinearSegmentedColormap.from_list("phasemap_sunset", [
    "#364B9A", "#4A7BB7", "#6EA6CD", "#98CAE1", "#C2E4EF", "#EAECCC",
    "#FEDA8B", "#FDB366", "#F67E4B", "#DD3D2D", "#A50026"])
SEQUENTIAL = "viridis"
#: Counts (reversals before rest): ColorBrewer's YlOrBr from its pale yellow on, one colour
#: per count (up to 17 counts; a wider range is drawn as a continuous layer), so that a
#: count beside a continuous layer (viridis) never reads as it.
COUNTS = mcolors.LinearSegmentedColormap.from_list(
    "phasemap_counts", mpl.colormaps["YlOrBr"](np.linspace(0.25, 1.0, 256)))

#: Event markers, by event name: (marker, face colour).  Events that end a
#: motion are filled, larger and edged in black; the others are small.
EVENT_MARKERS = {
    "start": ("o", "white"),
    "reversal": ("o", _OI["black"]),
    "stick": ("s", "white"),
    "slip": ("^", "white"),
    "switch": ("d", "white"),
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
    "iwc": ("*", _OI["vermillion"]),
    "liftoff": ("^", "white"),
    "impact": ("v", _OI["vermillion"]),
    "recontact": ("v", "white"),
    "zeno": ("p", _OI["orange"]),
}
_TERMINAL = {e.name.lower() for e in _events.Event if e.terminal}

#: Markers for the lines of a work-precision diagram, in order.
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*"]

_FONT = 8.0
#: The gap (points) between a panel and its heading.
TITLE_PAD = 3.0
#: The rcParams every figure is drawn with (applied with :func:`style`).
STYLE: dict = {
    "font.family": "sans-serif",
    "font.sans-serif": ["DejaVu Sans"],
    "mathtext.fontset": "dejavusans",
    "font.size": _FONT,
    "axes.labelsize": _FONT,
    "axes.titlesize": _FONT,
    "axes.titlelocation": "left",
    "axes.titlepad": TITLE_PAD,
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


def style() -> contextlib.AbstractContextManager:
    """The rc context every figure function draws in: ``with phasemap.plot.style(): ...``."""
    return mpl.rc_context(STYLE)


def stagnation_span(ax, lo: float, hi: float, axis: str = "x", **kw):
    """Hatch the band ``lo``..``hi`` along ``axis`` as stagnation (rest possible, or a
    stick phase): the look of the stagnation overlay in one dimension."""
    look = OVERLAYS["stagnation"]
    span = ax.axvspan if axis == "x" else ax.axhspan
    return span(lo, hi, facecolor="none", hatch=look.hatch, hatchcolor=look.colour,
                edgecolor="none", linewidth=0, zorder=0, **kw)


def overlay_patch(name: str, label: str | None = None) -> Patch:
    """The legend entry of overlay ``name`` (:data:`OVERLAYS`), on a map or as a span."""
    look = OVERLAYS[name]
    return Patch(facecolor="none", edgecolor=look.colour, hatch=look.hatch, linewidth=0.6,
                 linestyle=look.linestyle, label=look.label if label is None else label)


def stagnation_patch(label: str | None = None) -> Patch:
    """The legend entry of :func:`stagnation_span` (and of the stagnation overlay)."""
    return overlay_patch("stagnation", label)


def grey_level(colour) -> float:
    """The grey level of an opaque ``colour`` in a greyscale print (0 black, 1 white)."""
    r, g, b = mcolors.to_rgb(colour)
    return 0.299 * r + 0.587 * g + 0.114 * b


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


def category_hatch(meaning: str, layer: str | None = None) -> tuple[str | None, str]:
    """The hatch of category ``meaning`` of ``layer`` and its colour (None: solid).

    See :data:`CATEGORY_HATCHES`; ``yes`` in a layer that has an overlay look
    (:data:`OVERLAYS`) is hatched as that overlay.
    """
    if meaning == "yes" and layer in OVERLAYS and layer in FLAG_COLOURS \
            and FLAG_COLOURS[layer] == PALE_GREY:
        return OVERLAYS[layer].hatch, OVERLAYS[layer].colour
    return CATEGORY_HATCHES.get(meaning), HATCH_COLOURS.get(meaning, "white")


def _patch(colour: str, label: str, meaning: str | None = None, layer: str | None = None
           ) -> Patch:
    light = colour.upper() in (PALE_GREY, _OI["yellow"].upper(), "WHITE", "#FFFFFF")
    hatch, hatch_colour = category_hatch(meaning, layer) if meaning else (None, "white")
    return Patch(facecolor=colour, edgecolor=GREY if light else colour, linewidth=0.4,
                 hatch=hatch, hatchcolor=hatch_colour, label=label)


