"""Record what every figure a study saves says, and review its layout, for issue 11.

``recording()`` swaps :func:`phasemap.study.save_figure` for one that first
notes the figure's headings, legend texts and labels (``plot.figure_texts``),
its width and the problems :func:`layout_problems` finds, by file name, so a
test can check that each figure states what was held fixed, letters its
panels and is laid out cleanly at its printed width.  A study loaded inside
the block picks the recorder up whether it imported ``save_figure`` by name
or calls ``study.save_figure``.

The layout review is geometric, on the drawn figure at its printed size:

* every text is at least :data:`MIN_POINTS` pt and inside the figure;
* no two texts (headings, axis and tick labels, legends, colour-bar labels,
  annotations) overlap;
* no text or legend lies over another panel's plotting area; an inset's
  texts may lie over its parent panel but must not cross its lines;
* panel letters (a), (b), ... sit above their panels, at one offset (across
  and up) from each panel's top left corner;
* a colour bar's range holds the data drawn (beyond it only behind an arrow,
  and only a tail of at most :data:`TAIL` of the cells);
* the entries of a legend are told apart in greyscale by their style (dash,
  marker, hatch, fill or a grey level at least :data:`GREY_STEP` apart), not
  by colour alone;
* no label box or legend lies over plotted data (lines, markers, meshes,
  filled regions) inside a panel;
* every axis and every stated value ("$\\omega$ = 0 rad s$^{-1}$") has its
  unit, unless the quantity is dimensionless (:func:`dimensionless`);
* every legend entry is drawn where a reader can see it (:data:`MIN_SEEN_MM2` of
  its colour in a panel the legend speaks for, or a line, marker or hatch of its
  look), and every filled region a reader can see is named by a legend entry or
  read on a colour bar (:func:`legend_drawn_problems`);
* the classes of one categorical map differ in grey level by at least
  :data:`GREY_STEP`, hatched or not (:func:`class_contrast_problems`);
* one label, one look: two curves or markers with the same label in two panels
  are drawn alike, and a class of one layer has one colour in every panel
  (:func:`drawn_two_ways_problems`).

Across the figures of one study (:func:`check`): one meaning, one look.  A
legend label has one look (colour, hatch, dashes, marker) in every figure; a
filled class or a marker's look names one label; a colour that fills a
class is not the colour of a curve or marker that means something else; and one
layer has one label on every colour bar (:func:`layer_label_problems`).
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import re

import matplotlib.colors as mcolors
import numpy as np
import xarray as xr
from matplotlib.collections import Collection
from matplotlib.image import AxesImage
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.markers import MarkerStyle
from matplotlib.patches import Patch

import phasemap
from phasemap import plot as pplot
from phasemap import study

#: The smallest font a journal prints legibly (pt).
MIN_POINTS = 7.0
#: Slack in pixels (at the figure's dpi) for boxes that merely touch.
SLACK = 1.0
#: The largest share of a colour map's cells that may lie beyond its colour bar (behind
#: an arrow): the tail that a robust range (2nd-98th percentile) leaves out on one side.
TAIL = 0.02
#: The least difference in grey level (0 black .. 1 white) that tells two colours apart
#: in a greyscale print.
GREY_STEP = 0.1


@contextlib.contextmanager
def recording():
    seen: dict[str, dict] = {}
    original = study.save_figure

    def save(fig, out, name):
        panels = [a for a in fig.axes if a.get_label() != "<colorbar>" and a.axison
                  and a.get_position().height > 0.2 and a.get_position().width > 0.15]
        seen[name] = {"texts": pplot.figure_texts(fig), "panels": len(panels),
                      "width": fig.get_figwidth(), "problems": layout_problems(fig),
                      "looks": legend_looks(fig), "layers": layer_labels(fig)}
        return original(fig, out, name)

    study.save_figure = save
    try:
        yield seen
    finally:
        study.save_figure = original


def check_atlases(name: str, stems, printed: str, out) -> None:
    """Each atlas ``out/name_stem.nc`` is listed in the study's ``printed`` output and
    records the model, the version and the study that wrote it."""
    for stem in stems:
        path = out / f"{name}_{stem}.nc"
        assert str(path) in printed
        with xr.open_dataset(path) as ds:
            assert ds.attrs["phasemap_model"] == name
            assert ds.attrs["phasemap_version"] == phasemap.__version__
            assert ds.attrs["phasemap_study"] == name


def check(seen: dict[str, dict], exempt_fixed=()) -> None:
    """Every figure states g (so its fixed values), every multi-panel figure is lettered,
    and its layout has no problems."""
    assert seen
    for name, what in seen.items():
        text = " ".join(what["texts"])
        if name not in exempt_fixed:
            assert "$g$ = " in text, (name, what["texts"])
        if what["panels"] > 1:
            assert "(a)" in text and "(b)" in text, (name, what["texts"])
        assert "φ" not in text and "²" not in text, (name, "upright symbol outside mathtext")
        plain = " ".join(text.split("$")[::2])  # what lies outside mathtext
        spelled = _SPELLED.search(plain)
        assert spelled is None, (name, f"{spelled and spelled.group(0)!r}: a symbol spelled out")
        assert not what["problems"], (name, what["problems"])
    problems = look_problems({name: what["looks"] for name, what in seen.items()})
    problems += layer_label_problems({name: what["layers"] for name, what in seen.items()})
    assert not problems, problems


#: A Greek letter's name given a value outside mathtext ("rho = 0.5 m"): a missing symbol.
_SPELLED = re.compile(r"\b(alpha|beta|gamma|delta|epsilon|zeta|eta|theta|kappa|lambda|mu|nu|xi"
                      r"|rho|sigma|tau|phi|chi|psi|omega)\s*=", re.IGNORECASE)


# --------------------------------------------------------------------------- layout


def _shrunk(box):
    return box.padded(-SLACK)


def _texts(fig, renderer):
    """(what, bbox, owner axes or None, font size) of every visible text and legend."""
    out = []

    def add(what, artist, owner):
        if artist is None or not artist.get_visible():
            return
        if isinstance(artist, Legend):
            out.append((what, artist.get_window_extent(renderer), owner, min(
                [t.get_fontsize() for t in artist.get_texts()]
                + [artist.get_title().get_fontsize()])))
        elif artist.get_text().strip():
            out.append((f"{what} {artist.get_text()[:40]!r}",
                        artist.get_window_extent(renderer), owner, artist.get_fontsize()))

    for f in [fig, *fig.subfigs]:
        add("figure title", getattr(f, "_suptitle", None), None)
        add("figure key", getattr(f, "_supxlabel", None), None)
        for leg in f.legends:
            add("figure legend", leg, None)
    for ax in _all_axes(fig):
        if not ax.get_visible():
            continue
        for loc in ("left", "center", "right"):
            add(f"title of {_name(ax)}", ax._left_title if loc == "left" else
                ax.title if loc == "center" else ax._right_title, ax)
        add(f"legend of {_name(ax)}", ax.get_legend(), ax)
        for t in ax.texts:
            add(f"text in {_name(ax)}", t, ax)
        if not ax.axison:
            continue
        add(f"x label of {_name(ax)}", ax.xaxis.label, ax)
        add(f"y label of {_name(ax)}", ax.yaxis.label, ax)
        for axis in (ax.xaxis, ax.yaxis):
            # the ticks matplotlib draws: those within the view limits (private, but the
            # public tick lists also hold ticks outside the view with stale positions)
            for tick in axis._update_ticks():
                if tick.get_visible():
                    for label in (tick.label1, tick.label2):
                        if label.get_visible():
                            add(f"tick label of {_name(ax)}", label, ax)
    return out


def _name(ax) -> str:
    label = ax.get_label()
    return "colour bar" if label == "<colorbar>" else f"panel at ({ax.get_position().x0:.2f}, " \
        f"{ax.get_position().y0:.2f})"


def _all_axes(fig) -> list:
    """The figure's axes and their insets (``Axes.inset_axes``, not in ``fig.axes``)."""
    out = []
    for ax in fig.axes:
        out += [ax, *ax.child_axes]
    return out


def _parent(ax, axes):
    """The panel an inset lies in, or None."""
    for other in axes:
        if ax in other.child_axes:
            return other
    return None


def _crosses_lines(box, ax) -> list[str]:
    hits = []
    for line in ax.get_lines():
        if not line.get_visible() or line.get_linestyle() in ("None", "none", " ", ""):
            continue
        path = line.get_transform().transform_path(line.get_path())
        if path.intersects_bbox(_shrunk(box), filled=False):
            hits.append(line.get_label() or "a line")
    return hits


def layout_problems(fig) -> list[str]:
    """What a referee would flag in the layout of ``fig`` at its printed size (see above)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    problems = []
    texts = _texts(fig, renderer)
    page = fig.bbox.padded(SLACK)
    areas = [ax for ax in _all_axes(fig) if ax.get_visible() and ax.axison
             and ax.get_label() != "<colorbar>"]
    parents = {ax: _parent(ax, areas) for ax in areas}
    for what, box, owner, size in texts:
        if size < MIN_POINTS - 1e-9:
            problems.append(f"{what}: {size:g} pt is below {MIN_POINTS:g} pt")
        if not (page.contains(box.x0, box.y0) and page.contains(box.x1, box.y1)):
            problems.append(f"{what}: cut off by the figure's edge")
        for ax in areas:
            if ax is owner:
                continue
            if parents.get(owner) is ax:
                problems += [f"{what} crosses {hit} of its parent panel"
                             for hit in _crosses_lines(box, ax)]
            elif parents.get(ax) is owner and owner is not None:
                continue  # a panel's own text over its inset: caught the other way round
            elif _shrunk(box).overlaps(ax.bbox):
                problems.append(f"{what} lies over {_name(ax)}")
    for (w1, b1, o1, _), (w2, b2, o2, _) in itertools.combinations(texts, 2):
        if _shrunk(b1).overlaps(_shrunk(b2)):
            problems.append(f"{w1} overlaps {w2}")
    problems += _letter_problems(fig, renderer)
    problems += colour_bar_problems(fig)
    problems += greyscale_problems(fig)
    problems += covering_problems(fig, renderer, texts)
    problems += unit_problems(fig)
    problems += legend_drawn_problems(fig, renderer)
    problems += class_contrast_problems(fig)
    problems += drawn_two_ways_problems(fig)
    return problems


_LETTER = re.compile(r"\(([a-z])\)")


def _letter_problems(fig, renderer) -> list[str]:
    """Panel letters above their panels, at one offset (across and up) from each panel's
    top left corner: wherever a letter is (a panel's title, a legend's title, a text)."""
    found = []
    for ax in fig.axes:
        candidates = [ax._left_title, *ax.texts]
        if ax.get_legend() is not None:
            candidates.append(ax.get_legend().get_title())
        for t in candidates:
            if t.get_visible() and _LETTER.match(t.get_text()):
                found.append((t.get_text()[:3], t.get_window_extent(renderer), ax))
    problems = []
    offsets = []
    for letter, box, ax in found:
        if box.y0 < ax.bbox.y1 - SLACK:
            problems.append(f"panel letter {letter} is not above its panel")
        offsets.append((letter, box.x0 - ax.bbox.x0, box.y0 - ax.bbox.y1))
    for i, what in ((1, "across"), (2, "up")):
        if offsets:
            values = [o[i] for o in offsets]
            if max(values) - min(values) > 2.0 * SLACK + 1.0:
                problems.append(f"panel letters at different offsets {what} from their panels: "
                                + ", ".join(f"{o[0]} {o[i]:.0f} px" for o in offsets))
    return problems


# --------------------------------------------------------------------------- colour bars


def colour_bar_problems(fig) -> list[str]:
    """Colour bars whose range does not hold the data they colour.

    Values beyond a colour bar's end are allowed only behind an arrow at that
    end (``extend``) and only as a tail of at most :data:`TAIL` of the cells.
    """
    problems = []
    for ax in _all_axes(fig):
        bar = getattr(ax, "_colorbar", None)
        if bar is None or bar.mappable is None:
            continue
        data = np.ma.masked_invalid(np.ma.asarray(bar.mappable.get_array(), dtype=float))
        values = data.compressed()
        if not values.size:
            continue
        norm = bar.mappable.norm
        lo, hi = (norm.boundaries[0], norm.boundaries[-1]) if hasattr(norm, "boundaries") \
            else (norm.vmin, norm.vmax)
        label = bar.ax.get_ylabel() or bar.ax.get_xlabel() or "a colour bar"
        for side, beyond, arrow in (("below", values < lo, bar.extend in ("min", "both")),
                                    ("above", values > hi, bar.extend in ("max", "both"))):
            share = float(beyond.mean())
            if share and not (arrow and share <= TAIL):
                problems.append(f"colour bar {label[:40]!r}: {beyond.sum()} of {values.size} "
                                f"cells ({100 * share:.1f} %) lie {side} its range "
                                f"[{lo:.4g}, {hi:.4g}]" + ("" if arrow else ", with no arrow"))
    return problems


# --------------------------------------------------------------------------- greyscale


def grey(colour) -> float:
    """The grey level of ``colour`` printed in greyscale (0 black, 1 white), composited on
    white; 1 for no colour."""
    if colour is None or (isinstance(colour, str) and colour.lower() == "none"):
        return 1.0
    r, g, b, a = mcolors.to_rgba(colour)
    level = 0.299 * r + 0.587 * g + 0.114 * b
    return a * level + (1.0 - a)


def _dashes(line) -> tuple:
    style = line.get_linestyle()
    if style in ("None", "none", " ", ""):
        return ()
    offset, pattern = line._unscaled_dash_pattern
    return tuple(round(x, 1) for x in (pattern or ()))


def _grey_look(handle) -> tuple | None:
    """What of a legend handle's look survives greyscale: (style, grey levels)."""
    if isinstance(handle, Line2D):
        marker = handle.get_marker()
        marker = None if marker in ("None", "none", "", " ", None) else str(marker)
        line = bool(_dashes(handle)) or handle.get_linestyle() not in ("None", "none", " ", "")
        style = ("line", _dashes(handle) if line else None, round(handle.get_linewidth(), 1)
                 if line else None, marker, round(handle.get_markersize()) if marker else None)
        greys = ([grey(handle.get_color())] if line else []) + \
            ([grey(handle.get_markerfacecolor()), grey(handle.get_markeredgecolor())]
             if marker else [])
        return style, greys
    if isinstance(handle, Patch):
        hatch = handle.get_hatch() or None
        greys = [grey(handle.get_facecolor())]
        if hatch:
            greys.append(grey(handle.get_hatchcolor()))
        return ("patch", hatch, handle.get_linestyle()), greys
    return None


def _legends(fig) -> list:
    legends = []
    for f in [fig, *fig.subfigs]:
        legends += list(f.legends)
    legends += [ax.get_legend() for ax in _all_axes(fig) if ax.get_legend() is not None]
    return legends


def greyscale_problems(fig) -> list[str]:
    """Legend entries of one figure that only colour tells apart: same dashes, marker,
    hatch and size, and every grey level within :data:`GREY_STEP`."""
    entries = {}
    for legend in _legends(fig):
        for handle, text in zip(legend.legend_handles, legend.get_texts()):
            look = _grey_look(handle)
            if look is not None and text.get_text():
                entries.setdefault(text.get_text(), look)
    problems = []
    for (a, (sa, ga)), (b, (sb, gb)) in itertools.combinations(entries.items(), 2):
        if sa == sb and len(ga) == len(gb) and \
                all(abs(x - y) < GREY_STEP for x, y in zip(ga, gb)):
            problems.append(f"{a!r} and {b!r} differ by colour alone (greyscale alike)")
    return problems


# --------------------------------------------------------------------------- labels over data


def _data_boxes(ax, renderer):
    """(what, test) of each plotted artist of ``ax``: ``test(box)`` tells whether a
    display-space box covers some of it."""
    out = []
    for line in ax.get_lines():
        if not line.get_visible() or not len(line.get_xdata()):
            continue
        path = line.get_transform().transform_path(line.get_path())
        has_line = line.get_linestyle() not in ("None", "none", " ", "")
        has_marker = line.get_marker() not in ("None", "none", "", " ", None)
        clip = ax.bbox

        def test(box, path=path, has_line=has_line, has_marker=has_marker, clip=clip):
            inner = _shrunk(box)
            if has_line and path.intersects_bbox(inner, filled=False):
                return True
            if has_marker or not has_line:
                v = path.vertices
                inside = (v[:, 0] > inner.x0) & (v[:, 0] < inner.x1) & \
                    (v[:, 1] > inner.y0) & (v[:, 1] < inner.y1)
                return bool(inside.any())
            return False
        out.append((line.get_label() if not line.get_label().startswith("_") else "a line",
                    test))
    for artist in [*ax.collections, *ax.images]:
        if not artist.get_visible() or not isinstance(artist, (Collection, AxesImage)):
            continue
        try:
            extent = artist.get_window_extent(renderer)
        except (RuntimeError, ValueError):
            continue
        if not np.all(np.isfinite([extent.x0, extent.y0, extent.x1, extent.y1])):
            continue
        extent = extent.intersection(extent, ax.bbox) or extent

        def test(box, extent=extent):
            return _shrunk(box).overlaps(extent)
        out.append((type(artist).__name__, test))
    return out


def covering_problems(fig, renderer, texts=None) -> list[str]:
    """A text or legend inside a panel that lies over what the panel plots."""
    problems = []
    texts = _texts(fig, renderer) if texts is None else texts
    for what, box, owner, _ in texts:
        if owner is None or not (what.startswith("text in") or what.startswith("legend of")):
            continue
        if not _shrunk(box).overlaps(owner.bbox):
            continue
        for name, covers in _data_boxes(owner, renderer):
            if covers(box):
                problems.append(f"{what} lies over plotted data ({name})")
                break
    return problems


# --------------------------------------------------------------------------- units


@functools.lru_cache(maxsize=1)
def _dimensionless_symbols() -> frozenset:
    from phasemap.models import MODELS

    out = set()
    for m in MODELS.values():
        for v in m.variables.values():
            if str(v.units).strip() in ("1", ""):
                out.add(v.symbol or v.name)
    return frozenset(out)


def dimensionless(symbol: str) -> bool:
    """Whether the mathtext ``symbol`` (without ``$``) names a dimensionless quantity: a
    model variable with units 1 (``f``), a ratio of like quantities (``\\delta/l``), or
    one of those with a subscript."""
    symbol = symbol.strip()
    if "/" in symbol:
        return True
    base = re.sub(r"_(\{[^}]*\}|.)$", "", symbol).strip("{} ")
    return symbol in _dimensionless_symbols() or base in _dimensionless_symbols()


#: A value stated in a text: "$symbol$ = number", and what follows it.
_STATED = re.compile(r"\$([^$]+)\$ = (\$?[\u2212\-]?[\d.]+(?:\\times10\^\{[\u2212\-]?\d+\})?\$?)"
                     r"(?P<after>[^,;\n)]*)")
#: Words of an axis label that are counts or categories (no unit).
_COUNTS = re.compile(r"^(number|count|reversals|number of)\b", re.IGNORECASE)


def _axis_has_unit(label: str) -> bool:
    if re.search(r"\([^()]*[A-Za-z][^()]*\)\s*$", label.replace("$", "")):
        return True  # "... (rad s^{-1})"
    head = label.split("(")[0].strip()
    symbols = re.findall(r"\$([^$]+)\$", head)
    if symbols and all(dimensionless(s) for s in symbols) and \
            not head.replace("$", "").strip(" ,").split()[len(symbols):]:
        return True  # "$f$", "$\\delta/l$"
    return bool(_COUNTS.match(head.replace("$", "").strip()))


def unit_problems(fig) -> list[str]:
    """Axis labels without a unit and stated values without one (see :func:`dimensionless`).

    An axis whose ticks are words (categories) needs none; neither does a
    count ("Number of ...").
    """
    problems = []
    for ax in _all_axes(fig):
        if not ax.get_visible() or not ax.axison:
            continue
        for axis, label in ((ax.xaxis, ax.get_xlabel()), (ax.yaxis, ax.get_ylabel())):
            if not label.strip():
                continue
            words = [t.get_text() for t in axis.get_ticklabels()
                     if re.search(r"[A-Za-z]{2,}", re.sub(r"\\[A-Za-z]+", "", t.get_text()))]
            if words:
                continue  # categories
            if not _axis_has_unit(label.split("\n")[0] if ax.get_label() != "<colorbar>"
                                  else label.replace("\n", " ")):
                problems.append(f"axis label '{label}' has no unit")
    for text in pplot.figure_texts(fig):
        for m in _STATED.finditer(text):
            symbol, after = m.group(1), m.group("after")
            if "=" in symbol or dimensionless(symbol):
                continue
            if not re.match(r"\s*(\$?\^|[A-Za-z$\\])", after):
                problems.append(f"the value ${symbol}$ = {m.group(2)} has no unit")
    return problems


# --------------------------------------------------------------------------- one look per meaning


def _hex(colour) -> str:
    if colour is None or (isinstance(colour, str) and colour.lower() == "none"):
        return "none"
    rgba = mcolors.to_rgba(colour)
    return "none" if rgba[3] == 0 else mcolors.to_hex(rgba, keep_alpha=rgba[3] < 1)


def _look(handle) -> tuple | None:
    """(kind, look) of a legend handle: what a reader sees of it, colours included."""
    if isinstance(handle, Line2D):
        marker = handle.get_marker()
        marker = None if marker in ("None", "none", "", " ", None) else str(marker)
        line = handle.get_linestyle() not in ("None", "none", " ", "")
        if marker and not line:
            return "marker", (marker, _hex(handle.get_markerfacecolor()),
                              _hex(handle.get_markeredgecolor()))
        return "line", (_hex(handle.get_color()), _dashes(handle), marker,
                        _hex(handle.get_markerfacecolor()) if marker else None)
    if isinstance(handle, Patch):
        hatch = handle.get_hatch() or None
        return "patch", (_hex(handle.get_facecolor()), hatch,
                         _hex(handle.get_hatchcolor()) if hatch else None)
    return None


def legend_looks(fig) -> dict[tuple[str, str], tuple]:
    """{(kind, label): look} of every legend entry of ``fig`` (see :func:`_look`)."""
    out = {}
    for legend in _legends(fig):
        for handle, text in zip(legend.legend_handles, legend.get_texts()):
            look = _look(handle)
            if look is not None and text.get_text().strip():
                out[(look[0], text.get_text().strip())] = look[1]
    return out


_NEUTRAL = {"none", "#000000", "#ffffff", "#999999", "#dddddd", "#555555"}

#: Names of one meaning in two layers: a Painleve inconsistency is ``none`` in an
#: n_solutions map and ``no solution`` in a fate map; indeterminacy ``two`` and
#: ``indeterminate``.
SYNONYMS = {"no solution": "none", "indeterminate": "two"}


def meaning(label: str) -> str:
    """What a legend label names: its head, before a colon or a parenthesis that qualifies
    it ("none: $N < 0$, no hop" names "none"), synonyms made one."""
    head = re.split(r":|\s\(", label, maxsplit=1)[0].strip()
    return SYNONYMS.get(head, head)


def look_problems(looks_by_figure: dict[str, dict]) -> list[str]:
    """Across the figures of a study: a label with two looks, a filled class or a marker
    look with two labels, or a class's fill colour on a curve or marker that means
    something else (a colour means one thing)."""
    problems = []
    seen: dict[tuple[str, str], tuple[tuple, str]] = {}
    names: dict[tuple[str, tuple], tuple[str, str]] = {}
    fills: dict[str, tuple[str, str]] = {}
    for figure, looks in looks_by_figure.items():
        for (kind, label), look in looks.items():
            first = seen.setdefault((kind, label), (look, figure))
            if first[0] != look:
                problems.append(f"{label!r} looks different in {first[1]} and {figure}")
            if kind in ("patch", "marker"):
                other = names.setdefault((kind, look), (label, figure))
                if meaning(other[0]) != meaning(label):
                    problems.append(f"one look, two meanings: {other[0]!r} ({other[1]}) and "
                                    f"{label!r} ({figure})")
            if kind == "patch" and look[0] not in _NEUTRAL:
                fills.setdefault(look[0], (label, figure))
    for figure, looks in looks_by_figure.items():
        for (kind, label), look in looks.items():
            if kind == "patch":
                continue
            colours = {look[0]} if kind == "line" else {look[1]}
            for colour in colours - _NEUTRAL:
                if colour in fills and meaning(fills[colour][0]) != meaning(label):
                    problems.append(f"{label!r} ({figure}) is drawn in the colour of the class "
                                    f"{fills[colour][0]!r} ({fills[colour][1]})")
    return problems



# --------------------------------------------------------------------------- legend and drawing

#: The least area (mm^2 of the printed page) of a colour that a reader sees: a legend
#: entry whose colour covers less of every panel it speaks for is not drawn, and a region
#: of less needs no entry.
MIN_SEEN_MM2 = 1.0
#: Two rendered colours within this many levels (of 255) in every channel are one colour.
COLOUR_TOL = 6


def _pixels(fig) -> np.ndarray:
    """The canvas drawn last, (rows top down, columns, RGB) in 0..255."""
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].astype(np.int16)


def _crop(pixels: np.ndarray, box) -> np.ndarray:
    """The pixels inside a display-space box (y up), a pixel in from its edges (spines)."""
    h, w = pixels.shape[:2]
    x0, x1 = max(int(np.ceil(box.x0)) + 1, 0), min(int(np.floor(box.x1)) - 1, w)
    y0, y1 = max(int(np.ceil(box.y0)) + 1, 0), min(int(np.floor(box.y1)) - 1, h)
    if x1 <= x0 or y1 <= y0:
        return np.zeros((0, 3), np.int16)
    return pixels[h - y1:h - y0, x0:x1].reshape(-1, 3)


def _on_white(colour) -> np.ndarray:
    """A colour as drawn on white, in 0..255."""
    r, g, b, a = mcolors.to_rgba(colour)
    return np.array([a * r + 1 - a, a * g + 1 - a, a * b + 1 - a]) * 255.0


def _seen_px(pixels: np.ndarray, colour) -> int:
    return int((np.abs(pixels - _on_white(colour)).max(axis=1) <= COLOUR_TOL).sum())


def _min_px(fig) -> float:
    return MIN_SEEN_MM2 * (fig.dpi / 25.4) ** 2


def _panels(fig) -> list:
    return [ax for ax in _all_axes(fig) if ax.get_visible() and ax.axison
            and ax.get_label() != "<colorbar>"]


def _legend_scope(legend, fig) -> list:
    """The panels a legend speaks for: its own panel (a legend above it), or every panel
    of the figure (or subfigure) it belongs to."""
    parent = legend.parent
    panels = _panels(fig)
    if parent in panels:
        # its insets, and a twin drawn on the same area (twinx)
        return [parent] + [ax for ax in panels if _parent(ax, panels) is parent
                           or (ax is not parent and ax.bbox.bounds == parent.bbox.bounds)]
    if hasattr(parent, "get_figure") and not hasattr(parent, "legends"):
        parent = parent.get_figure(root=False)   # a legend in a spare panel, axis off
    return [ax for ax in panels if ax.get_figure(root=False) is parent or parent is fig]


def _white(colour) -> bool:
    return bool(np.all(_on_white(colour) >= 255 - COLOUR_TOL))


def _region_artists(ax) -> list:
    """(artist, [face colours]) of what ``ax`` fills: a categorical mesh's class colours
    (the classes present), filled contours, filled polygons and patches.  A mesh read on a
    colour bar is left out (the colour bar names its colours)."""
    from matplotlib.collections import LineCollection, PathCollection, QuadMesh
    from matplotlib.contour import ContourSet

    out = []
    for artist in [*ax.collections, *ax.images, *ax.patches]:
        if not artist.get_visible() or getattr(artist, "colorbar", None) is not None:
            continue
        if isinstance(artist, (QuadMesh, AxesImage)):
            values = np.ma.masked_invalid(np.ma.asarray(artist.get_array(), dtype=float))
            values = np.unique(values.compressed())
            if values.size:
                out.append((artist, [mcolors.to_hex(c, keep_alpha=True) for c in
                                     artist.to_rgba(values, alpha=artist.get_alpha())]))
        elif isinstance(artist, (LineCollection, PathCollection)) and \
                not isinstance(artist, ContourSet):
            continue  # lines and markers
        elif isinstance(artist, ContourSet) and not artist.filled:
            continue
        elif isinstance(artist, Collection):
            faces = [c for c in artist.get_facecolor() if c[3] > 0]
            out.append((artist, sorted({mcolors.to_hex(c, keep_alpha=True) for c in faces})))
        elif isinstance(artist, Patch):
            face = artist.get_facecolor()
            if face[3] > 0:
                out.append((artist, [mcolors.to_hex(face, keep_alpha=True)]))
    return out


def _same_colour(a, b) -> bool:
    return bool(np.abs(_on_white(a) - _on_white(b)).max() <= COLOUR_TOL)


def _line_like(ax):
    """(colour, dashes or None, marker or None) of every line, marker or contour line of
    ``ax`` with some of it inside the view."""
    from matplotlib.collections import LineCollection, PathCollection
    from matplotlib.contour import ContourSet

    out = []
    box = ax.bbox
    for line in ax.get_lines():
        if not line.get_visible() or not len(line.get_xdata()):
            continue
        v = line.get_transform().transform(line.get_xydata())
        inside = (v[:, 0] >= box.x0 - 1) & (v[:, 0] <= box.x1 + 1) & \
            (v[:, 1] >= box.y0 - 1) & (v[:, 1] <= box.y1 + 1)
        if not inside.any():
            continue
        marker = line.get_marker()
        marker = None if marker in ("None", "none", "", " ", None) else str(marker)
        has_line = line.get_linestyle() not in ("None", "none", " ", "")
        out.append((line.get_color(), _dashes(line) if has_line else None, marker,
                    line.get_markerfacecolor() if marker else None))
    for artist in ax.collections:
        if not artist.get_visible():
            continue
        if isinstance(artist, PathCollection) and not isinstance(artist, ContourSet):
            for c in [*artist.get_facecolor(), *artist.get_edgecolor()]:  # hollow too
                out.append((mcolors.to_hex(c), None, "collection", mcolors.to_hex(c)))
        elif isinstance(artist, (LineCollection, ContourSet)) and \
                not getattr(artist, "filled", False):
            for c in artist.get_edgecolor():
                out.append((mcolors.to_hex(c), "collection", None, None))
    return out


def _hatches(ax) -> set[str]:
    out = set()
    for artist in [*ax.collections, *ax.patches]:
        if not artist.get_visible():
            continue
        hatch = artist.get_hatch() if hasattr(artist, "get_hatch") else None
        out.update(h for h in [hatch, *(getattr(artist, "hatches", None) or [])] if h)
    return out


def _entry_drawn(handle, scope, pixels, fig) -> bool:
    """Whether what legend entry ``handle`` shows is drawn in a panel of ``scope``."""
    if isinstance(handle, Patch):
        face = handle.get_facecolor()
        if face[3] > 0:
            return any(_seen_px(_crop(pixels, ax.bbox), face) >= _min_px(fig)
                       for ax in scope)
        hatch = handle.get_hatch()
        return not hatch or any(hatch in _hatches(ax) for ax in scope)
    if isinstance(handle, Line2D):
        marker = handle.get_marker()
        marker = None if marker in ("None", "none", "", " ", None) else str(marker)
        has_line = handle.get_linestyle() not in ("None", "none", " ", "")
        for ax in scope:
            for colour, dashes, mark, face in _line_like(ax):
                if marker and (mark == marker or mark == "collection") and \
                        (_same_colour(face or colour, handle.get_markerfacecolor())
                         or _same_colour(colour, handle.get_color())
                         or not MarkerStyle(marker).is_filled()):
                    return True
                if has_line and not marker and _same_colour(colour, handle.get_color()) \
                        and (dashes == "collection" or dashes == _dashes(handle)):
                    return True
        return False
    return True


def legend_drawn_problems(fig, renderer=None) -> list[str]:
    """A legend entry whose look no panel it speaks for shows (a class with no cells a
    reader can see, a curve never drawn), and a filled region a reader can see (at least
    :data:`MIN_SEEN_MM2`) whose colour no legend entry over its panel names and no colour
    bar reads."""
    if renderer is None:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
    pixels = _pixels(fig).copy()
    # a legend's swatches and the texts are not what a panel draws: blanked out, so that
    # an entry inside its panel is not seen in its own swatch
    h = pixels.shape[0]
    for _, box, _, _ in _texts(fig, renderer):
        x0, x1 = max(int(box.x0) - 1, 0), int(np.ceil(box.x1)) + 1
        y0, y1 = max(int(box.y0) - 1, 0), int(np.ceil(box.y1)) + 1
        pixels[max(h - y1, 0):max(h - y0, 0), x0:x1] = -1000
    problems = []
    named: dict = {}
    for legend in _legends(fig):
        scope = _legend_scope(legend, fig)
        for handle, text in zip(legend.legend_handles, legend.get_texts()):
            label = text.get_text()
            if not label.strip() or handle is None:
                continue
            if not _entry_drawn(handle, scope, pixels, fig):
                problems.append(f"legend entry {label!r}: nothing drawn shows it")
            if isinstance(handle, Patch) and handle.get_facecolor()[3] > 0:
                for ax in scope:
                    named.setdefault(ax, []).append(handle.get_facecolor())
    for ax in _panels(fig):
        crop = _crop(pixels, ax.bbox)
        told = set()
        for artist, colours in _region_artists(ax):
            for colour in colours:
                if colour in told or _white(colour) or \
                        any(_same_colour(colour, c) for c in named.get(ax, [])):
                    continue
                told.add(colour)
                seen = _seen_px(crop, colour)
                if seen >= _min_px(fig):
                    mm2 = seen / (fig.dpi / 25.4) ** 2
                    problems.append(f"a region of {_name(ax)} in {colour} ({mm2:.0f} mm^2) "
                                    "has no legend entry")
    return problems


# --------------------------------------------------------------------------- classes in grey


def _categories(artist) -> tuple[str, list[str]] | None:
    """(layer, meanings in colour-map order) of a categorical mesh drawn by
    phasemap.plot (its gid ``phasemap:LAYER:M1,M2,...``), else None."""
    gid = artist.get_gid() or ""
    parts = gid.split(":")
    if len(parts) == 3 and parts[0] == "phasemap" and parts[2]:
        return parts[1], parts[2].split(",")
    return None


def class_contrast_problems(fig) -> list[str]:
    """Two classes of one categorical map whose fills differ in grey level by less than
    :data:`GREY_STEP`: in a greyscale print only a hatch tells them apart, and a hatch
    is lost on a region a few cells wide."""
    from matplotlib.collections import QuadMesh

    problems = []
    for ax in _panels(fig):
        for artist in [*ax.collections, *ax.images]:
            if not isinstance(artist, (QuadMesh, AxesImage)) or \
                    getattr(artist, "colorbar", None) is not None:
                continue
            cats = _categories(artist)
            if cats is None:   # a class map phasemap.plot drew (its gid names the classes)
                continue
            values = np.unique(np.ma.masked_invalid(
                np.ma.asarray(artist.get_array(), dtype=float)).compressed())
            if values.size < 2:
                continue
            names = [cats[1][int(v)] if 0 <= int(v) < len(cats[1]) else f"{v:g}"
                     for v in values]
            colours = artist.to_rgba(values)
            flag = set(cats[1]) <= {"no", "yes"}
            for (a, ca), (b, cb) in itertools.combinations(zip(names, colours), 2):
                # a yes/no flag drawn as a hatch over one fill: its hatch tells them apart
                if flag and np.array_equal(ca, cb):
                    continue
                if abs(grey(ca) - grey(cb)) < GREY_STEP:
                    problems.append(f"classes {a!r} and {b!r} of {_name(ax)} are "
                                    f"{abs(grey(ca) - grey(cb)):.2f} apart in grey")
    return problems


# --------------------------------------------------------------------------- one label, one look


def drawn_two_ways_problems(fig) -> list[str]:
    """One label drawn two ways in one figure: curves or markers of one label (not
    ``_hidden``) with different colours, dashes or markers in two panels, and one class
    of one layer in two colours in two panels."""
    problems = []
    lines: dict[str, tuple] = {}
    classes: dict[tuple[str, str], str] = {}
    for ax in _panels(fig):
        for line in ax.get_lines():
            label = line.get_label()
            if not label or label.startswith("_") or not line.get_visible():
                continue
            look = (_hex(line.get_color()), _dashes(line), str(line.get_marker()),
                    _hex(line.get_markerfacecolor()))
            first = lines.setdefault(label, (look, ax))
            if first[0] != look and first[1] is not ax:
                problems.append(f"{label!r} is drawn one way in {_name(first[1])} and "
                                f"another in {_name(ax)}")
        for artist in ax.collections:
            cats = _categories(artist)
            if cats is None:
                continue
            layer, meanings = cats
            for i, m in enumerate(meanings):
                colour = mcolors.to_hex(artist.cmap(artist.norm(i)), keep_alpha=True)
                first = classes.setdefault((layer, m), colour)
                if first != colour:
                    problems.append(f"class {m!r} of {layer!r} is {first} in one panel "
                                    f"and {colour} in another")
    return problems


def _label_core(label: str) -> str:
    """A colour bar's label without what depends on the data drawn: an angle map drawn as
    the nearest multiples of pi says so after its label (", nearest multiple of pi
    (\u00b10.12 rad)"); spaces made one."""
    return " ".join(re.sub(r",\s*nearest\s+multiple of .*$", "", label, flags=re.S).split())


def layer_labels(fig) -> list[tuple[str, str]]:
    """(layer, colour bar label) of every mesh phasemap.plot drew with a colour bar (its
    gid ``phasemap:LAYER``)."""
    out = []
    for ax in _panels(fig):
        for artist in [*ax.collections, *ax.images]:
            gid = artist.get_gid() or ""
            bar = getattr(artist, "colorbar", None)
            if gid.startswith("phasemap:") and bar is not None:
                out.append((gid.split(":")[1], bar.ax.get_ylabel() or bar.ax.get_xlabel()))
    return out


def layer_label_problems(labels_by_figure: dict[str, list[tuple[str, str]]]) -> list[str]:
    """One layer under two labels on the colour bars of a study's figures (or of one)."""
    problems = []
    first: dict[str, tuple[str, str]] = {}
    for figure, labels in labels_by_figure.items():
        for layer, label in labels:
            seen = first.setdefault(layer, (label, figure))
            if _label_core(seen[0]) != _label_core(label):
                problems.append(f"layer {layer!r} is {seen[0]!r} in {seen[1]} and {label!r} "
                                f"in {figure}")
    return problems
