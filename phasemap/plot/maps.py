"""Maps, profiles and fate maps of an atlas.

A categorical layer is drawn in its category colours (:mod:`.style`), a
float layer with a colour bar that holds the data, and the overlays
(``stagnation``, ``contact_lost``, ``singular``) over either.
"""

from __future__ import annotations

import math
from typing import Sequence

import matplotlib as mpl
import matplotlib.colors as mcolors
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from phasemap.core import events as _events
from phasemap.atlas.dataset import dataset_kind as atlas_kind, first_layer, is_categorical, vocabulary
from phasemap.plot.labels import _coord, _flags, _layer, _meaning_text, _units, axis_label, fixed_values_text
from phasemap.plot.layout import (_angle_ticks, _annotate, _axes, _label_axis, _panel_width, _pi_text,
                     define_symbols, figure_legend, label_panels, legend_above, outer_labels,
                     width_of)
from phasemap.plot.style import (COUNTS, DARK_GREY, DASHES, GREY, HALO, OVERLAYS, SEQUENTIAL, SUNSET,
                    _OI, category_colour, category_hatch, grey_level, _patch, overlay_patch,
                    style)


#: Layers drawn over a map rather than as the map itself.
OVERLAY_LAYERS = ("stagnation", "contact_lost", "singular")

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
                      ) -> tuple[list[Patch], np.ndarray]:
    """A categorical layer (rows y, columns x) in its category colours; the legend handles,
    and the cells whose class is dark in a greyscale print (a hatch over them is white).

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
    layer = str(var.name)
    # the gid names the layer and its classes in colour order, for a review of the figure
    ax.pcolormesh(_edges(xc), _edges(yc), np.ma.masked_less(index, 0), cmap=cmap, norm=norm,
                  shading="flat", rasterized=True, linewidth=0,
                  gid=f"phasemap:{layer}:{','.join(m for m, _ in present)}")
    for m, mask in present:
        hatch, hatch_colour = category_hatch(m, layer)
        if hatch and mask.any():
            _hatch_cells(ax, xc, yc, mask, hatch, hatch_colour)
    dark = np.zeros(codes.shape, dtype=bool)
    for c, (_, mask) in zip(colours, present):
        if grey_level(c) < 0.5:
            dark |= mask
    # a flag hatched as its overlay is elsewhere (stagnation) is listed as the overlay is;
    # every class, the plain one too ("no stagnation"), has an entry: every region is named
    return [overlay_patch(layer) if m == "yes" and layer in OVERLAYS
            and category_hatch(m, layer)[0] == OVERLAYS[layer].hatch else
            _patch(c, _category_label(layer, m, meanings), m, layer)
            for c, (m, _) in zip(colours, present)], dark


def _category_label(layer: str, meaning: str, meanings: Sequence[str]) -> str:
    """The legend text of a category: its meaning, or for a yes/no layer the layer's own
    name ("stagnation", "no stagnation"), so that a class reads as it does as an overlay."""
    if sorted(meanings) != ["no", "yes"]:
        return _meaning_text(meaning)
    name = OVERLAYS[layer].label if layer in OVERLAYS else _meaning_text(layer)
    if meaning == "yes":
        return name
    # "a contact would pull" -> "no contact would pull"; "stagnation" -> "no stagnation"
    return f"no {name[2:]}" if name.startswith("a ") else f"no {name}"


def _draw_continuous(ax: Axes, xc, yc, data: np.ndarray, label: str, *, robust: bool = True,
                     location: str = "right", units: str | None = None):
    """A float or count layer (rows y, columns x) with a colour bar; NaN left blank.

    The colour bar holds the data: its range is the data's, except with
    ``robust`` where a long tail (a branch's acceleration growing without
    bound near a singular state) would squash the rest; then the limits are
    the 2nd and 98th percentiles and arrows on the colour bar mark the few
    cells beyond.  An angle (``units`` rad) is never clipped and keeps its
    sign in greyscale (see :func:`_draw_angle`); a count gets one colour per
    value; a signed quantity a diverging map centred on zero with its zero
    contour drawn, so that the sign boundary shows in greyscale too.
    """
    data = np.asarray(data)
    finite = data[np.isfinite(data)] if data.dtype.kind == "f" else data.ravel()
    if units == "rad" and data.dtype.kind == "f" and finite.size:
        return _draw_angle(ax, xc, yc, data, label, location)
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    integer = data.dtype.kind in "iu" or (finite.size and np.all(finite == np.round(finite))
                                          and hi - lo <= 16 and units == "1")
    vlo, vhi = lo, hi
    if robust and not integer and finite.size >= 50:
        p2, p98 = (float(v) for v in np.percentile(finite, [2.0, 98.0]))
        spread = max(p98 - p2, np.finfo(float).tiny)
        vlo = p2 if p2 - lo > spread else lo
        vhi = p98 if hi - p98 > spread else hi
    signed = lo < 0 < hi
    if integer and hi - lo <= 16:
        cmap = COUNTS.resampled(int(hi - lo) + 1)
        norm = mcolors.BoundaryNorm(np.arange(lo, hi + 2) - 0.5, cmap.N)
    elif signed:
        cmap, m = SUNSET, max(-vlo, vhi, np.finfo(float).tiny)
        norm = mcolors.Normalize(-m, m)
    else:
        cmap = mpl.colormaps[SEQUENTIAL]
        norm = mcolors.Normalize(vlo, vhi if vhi > vlo else vlo + 1.0)
    mesh = _mesh(ax, xc, yc, data.astype(float), cmap, norm)
    if signed and not integer:
        _zero_contour(ax, xc, yc, data)
    cbar = _colour_bar(ax, mesh, label, location, lo, hi)
    if integer:
        cbar.locator = MaxNLocator(integer=True)
        cbar.update_ticks()
    return cbar


def _mesh(ax: Axes, xc, yc, data: np.ndarray, cmap, norm):
    cmap = cmap.with_extremes(bad=(0, 0, 0, 0))
    return ax.pcolormesh(_edges(xc), _edges(yc), np.ma.masked_invalid(data), cmap=cmap,
                         norm=norm, shading="flat", rasterized=True, linewidth=0)


def _colour_bar(ax: Axes, mesh, label: str, location: str, lo: float, hi: float):
    """A colour bar for ``mesh``, with an arrow at an end where the data (``lo``..``hi``)
    goes beyond it."""
    norm = mesh.norm
    below, above = lo < norm.vmin, hi > norm.vmax
    extend = "both" if below and above else "min" if below else "max" if above else "neither"
    cbar = ax.figure.colorbar(mesh, ax=ax, location=location, aspect=30, pad=0.02,
                              fraction=0.05, extend=extend, extendfrac=0.04)
    cbar.outline.set_linewidth(0.5)
    cbar.ax.tick_params(width=0.6, length=2.5)
    cbar.set_label(label)
    return cbar


def _zero_contour(ax: Axes, xc, yc, data: np.ndarray) -> None:
    """The zero level of a signed layer, thin and black."""
    z = np.ma.masked_invalid(np.asarray(data, float))
    if z.count() and z.min() < 0 < z.max() and min(z.shape) > 1:
        ax.contour(xc, yc, z, levels=[0.0], colors=[_OI["black"]], linewidths=0.5, zorder=3)


#: The largest distance (rad) from a multiple of pi at which an angle layer is drawn as
#: classes of that multiple (rest angles cluster about the rest positions k pi).
_NEAR_PI = math.pi / 4


def _draw_angle(ax: Axes, xc, yc, data: np.ndarray, label: str, location: str):
    """An angle layer whose colour bar holds every value and whose sign survives greyscale.

    The colours run in lightness from the most negative angle to the most
    positive (viridis), never alike for +a and -a as a diverging map would
    be.  Where every angle lies within pi/4 of a multiple of pi (rest angles
    sit in the zones about the rest positions k pi), the map shows the
    multiple as discrete classes ("-2pi", "-pi", "0", "pi", ... : the turns)
    and the colour bar's label states the largest remainder; otherwise the
    colours are continuous, ticked at multiples of pi.
    """
    finite = data[np.isfinite(data)]
    k = np.round(finite / math.pi)
    rest = np.abs(finite - k * math.pi)
    kmin, kmax = int(k.min()), int(k.max())
    if rest.max() <= _NEAR_PI and 0 < kmax - kmin <= 16:
        classes = np.round(data / math.pi)
        n = kmax - kmin + 1
        cmap = mpl.colormaps[SEQUENTIAL].resampled(n)
        norm = mcolors.BoundaryNorm(np.arange(kmin, kmax + 2) - 0.5, n)
        mesh = _mesh(ax, xc, yc, classes, cmap, norm)
        cbar = _colour_bar(ax, mesh, f"{label}, nearest\nmultiple of $\\pi$ "
                           f"(\u00b1{rest.max():.2g} rad)", location, kmin, kmax)
        step = max(1, math.ceil(n / 9))
        ticks = np.arange(kmin, kmax + 1)[::step]
        cbar.set_ticks(ticks, labels=[_pi_text(int(t), 1) for t in ticks])
        cbar.minorticks_off()
        return cbar
    lo, hi = float(finite.min()), float(finite.max())
    norm = mcolors.Normalize(lo, hi if hi > lo else lo + 1.0)
    mesh = _mesh(ax, xc, yc, data.astype(float), mpl.colormaps[SEQUENTIAL], norm)
    cbar = _colour_bar(ax, mesh, label, location, lo, hi)
    _angle_ticks(cbar.ax, "y" if location in ("left", "right") else "x", lo, hi)
    return cbar


def _mask_overlay(ax: Axes, xc, yc, mask: np.ndarray, name: str,
                  dark: np.ndarray | None = None) -> Patch | None:
    """Hatch the cells where ``mask`` (rows y, columns x) holds, and outline them; over
    ``dark`` cells the hatch is white, so that it shows on a dark class."""
    if not mask.any():
        return None
    look = OVERLAYS[name]
    xp, yp, z = _padded(xc, yc, mask)
    dark = np.zeros_like(mask) if dark is None else dark
    for cells, colour in ((mask & ~dark, look.colour), (mask & dark, "white")):
        if cells.any():
            _hatch_cells(ax, xc, yc, cells, look.hatch, colour)
    if not mask.all():
        ax.contour(xp, yp, z, levels=[0.5], colors=[look.colour], linewidths=0.6,
                   linestyles=look.linestyle)
    return overlay_patch(name)


def _overlays(ax: Axes, ds: xr.Dataset, main: str, x: str, y: str, xc, yc,
              shown: np.ndarray | None = None, dark: np.ndarray | None = None) -> list:
    """Hatch ``stagnation`` and ``contact_lost`` and draw the ``singular`` set over a map.

    Each in its one look (:data:`~phasemap.plot.style.OVERLAYS`).  ``shown``
    marks cells the map itself already draws as ``contact lost`` (see
    :func:`_draw_categorical`); they are not hatched twice.  Over any other
    class the blue hatch says that a branch would need a contact to pull
    while another branch holds (the contact opens, or the motion goes on
    without it).  ``dark`` marks the cells of a class map that print dark: the
    stagnation hatch is white over them.
    """
    handles = []
    for name in OVERLAYS:
        if name == main or name not in ds.data_vars or set(ds[name].dims) != {x, y}:
            continue
        mask = np.asarray(ds[name].transpose(y, x).values) == 1
        if name == "contact_lost" and shown is not None:
            mask = mask & ~shown
        h = _mask_overlay(ax, xc, yc, mask, name, dark=dark if name == "stagnation" else None)
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
    coefficient = vocabulary(ds).coefficient
    symbol = coefficient[1] if coefficient else None
    label = f"singular (${symbol} = 0$)" if symbol else "singular"
    coefs = [n for n in ds.data_vars if str(n).startswith("coef_")
             and set(ds[n].dims) == {x, y}]
    if not mask.any() and not coefs:
        return handles
    drawn = np.zeros_like(mask)
    # dash-dot-dot, not solid: a class boundary is a solid black line (draw_boundaries)
    line = {"color": _OI["black"], "lw": 1.2, "zorder": 4}
    styles = [DASHES[4], "dashed", "dashdot", "dotted"]
    for i, name in enumerate(coefs):
        z = np.asarray(ds[name].transpose(y, x).values, float)
        if np.nanmin(z) < 0 < np.nanmax(z):
            ax.contour(xc, yc, z, levels=[0.0], colors=[_OI["black"]], linewidths=1.2,
                       linestyles=[styles[i % len(styles)]], zorder=4)
            branch = str(name)[len("coef_"):]
            handles.append(Line2D([], [], ls=styles[i % len(styles)], label=(
                f"{label}, {_meaning_text(branch)}" if len(coefs) > 1 else label), **line))
            drawn[:] = True
    if not drawn.all():
        rows = np.flatnonzero(mask.all(axis=1))
        cols = np.flatnonzero(mask.all(axis=0))
        for j in rows:
            ax.axhline(yc[j], ls=styles[0], **line)
            drawn[j, :] = True
        for i in cols:
            ax.axvline(xc[i], ls=styles[0], **line)
            drawn[:, i] = True
        if rows.size or cols.size:
            handles.append(Line2D([], [], ls=styles[0], label=label, **line))
    rest = mask & ~drawn
    if rest.any():
        jj, ii = np.nonzero(rest)
        ax.plot(xc[ii], yc[jj], ls="none", marker="o", ms=1.5, mew=0, color=_OI["black"],
                rasterized=True, zorder=4)
        handles.append(Line2D([], [], ls="none", marker="o", ms=2.5, mew=0,
                              color=_OI["black"], label=label if not handles else
                              "singular (isolated cells)"))
    return handles


def draw_boundaries(ax: Axes, pieces: xr.Dataset, x: str, y: str,
                    label: str = "class boundary") -> list:
    """Draw exact class boundaries over a map: one black curve per piece.

    ``pieces`` is an :class:`xarray.Dataset` on a dimension ``vertex``: the
    vertex coordinates, as variables named after the map's axes ``x`` and
    ``y``, and ``piece``, the index of the piece each vertex belongs to (as
    the bifurcation-set tracer returns them).  Returns the legend handle (none
    when there are no vertices).

    Raises
    ------
    ValueError
        if ``pieces`` lacks ``x``, ``y`` or ``piece`` on dimension ``vertex``.
    """
    missing = [n for n in (x, y, "piece") if n not in pieces.variables
               or pieces[n].dims != ("vertex",)]
    if missing:
        raise ValueError(f"boundaries need {', '.join(missing)} on dimension 'vertex' "
                         f"(the vertices of each piece, and the piece of each vertex)")
    px = np.asarray(pieces[x].values, float)
    py = np.asarray(pieces[y].values, float)
    piece = np.asarray(pieces["piece"].values)
    if not px.size:
        return []
    look = {"color": _OI["black"], "lw": 0.8, "zorder": 5, "path_effects": HALO}
    for k in dict.fromkeys(piece.tolist()):
        sel = piece == k
        ax.plot(px[sel], py[sel], **look)
    return [Line2D([], [], label=label, **look)]


def _default_map_layer(ds: xr.Dataset) -> str:
    if "n_solutions" in ds.data_vars:
        return "n_solutions"
    for name, var in ds.data_vars.items():
        if is_categorical(var) and name not in OVERLAY_LAYERS:
            return str(name)
    return str(first_layer(ds).name)


def map_figure(ds: xr.Dataset, layer: str | None = None, *, x: str | None = None, ax=None,
               size: str | float = "one_column", overlays: bool = True,
               all_categories: bool = False, robust: bool = True,
               colorbar: str = "right", boundaries: xr.Dataset | bool | None = None) -> Figure:
    """A 2-D map of one layer of an atlas.

    A categorical layer (``flag_values``/``flag_meanings``; default
    ``n_solutions``) is drawn in its category colours with a legend above
    the axes listing the categories present (all of them with
    ``all_categories=True``).  A float layer gets a colour map and a colour
    bar that holds the data (see :func:`_draw_continuous`: an angle keeps its
    sign in greyscale, a signed layer is diverging with its zero contour, a
    long tail is cut at the 2nd-98th percentiles with ``robust`` and marked by
    arrows); NaN cells are left blank.  With ``overlays`` the ``stagnation``
    cells are hatched and outlined, ``contact_lost`` cells hatched the other
    way in blue with a dashed outline, and ``singular`` cells dotted, when the
    atlas has those layers.  ``x`` names the dimension along the x axis
    (default: the layer's first); ``colorbar`` places a float layer's colour
    bar (``"right"``, or ``"bottom"`` under a stack of panels that share x).

    ``boundaries`` draws exact class boundaries over the cells (see
    :func:`draw_boundaries`): the pieces the bifurcation-set tracer returns,
    so that a boundary is a curve, not the stair of the grid's cells;
    ``boundaries=True`` traces them for this map's slice
    (:func:`phasemap.bifurcation.overlay.map_boundaries`).
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
        handles, dark = [], None
        lost = None
        if overlays and "contact_lost" in ds.data_vars and layer != "contact_lost" \
                and set(ds.contact_lost.dims) == {xdim, ydim}:
            lost = np.asarray(ds.contact_lost.transpose(ydim, xdim).values) == 1
        shown = None
        if is_categorical(var):
            handles, dark = _draw_categorical(a, xc, yc, data, var, all_categories, lost=lost)
            if lost is not None and str(var.name) == "n_solutions":
                none = dict(zip(_flags(var)[1], _flags(var)[0])).get("none")
                shown = lost & (data == none)
        else:
            fate = ds.get("fate")
            codes = np.asarray(fate.transpose(ydim, xdim).values) if fate is not None \
                and set(fate.dims) == {xdim, ydim} else None
            data, label = _at_rest(ds, layer, data, codes)
            bar = _draw_continuous(a, xc, yc, data, label, robust=robust,
                                   location=colorbar, units=_units(ds, layer))
            bar.mappable.set_gid(f"phasemap:{layer}")
        if overlays:
            handles += _overlays(a, ds, layer, xdim, ydim, xc, yc, shown=shown, dark=dark)
        if boundaries is True:
            from phasemap.bifurcation.overlay import map_boundaries

            boundaries = map_boundaries(ds, layer, xdim, ydim)
        if boundaries is not None and boundaries is not False:
            handles += draw_boundaries(a, boundaries, xdim, ydim)
        _label_axis(a, ds, "x", xdim, _edges(xc))
        _label_axis(a, ds, "y", ydim, _edges(yc))
        xe, ye = _edges(xc), _edges(yc)
        a.set_xlim(xe[0], xe[-1])
        a.set_ylim(ye[0], ye[-1])
        legend_above(a, handles, title=fixed_values_text(ds, _panel_width(a)) or None)
    return a.figure


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
        layers = [str(n) for n, v in ds.data_vars.items() if is_categorical(v)] or \
            [str(first_layer(ds).name)]
    elif isinstance(layers, str):
        layers = [layers]
    variables = [_layer(ds, n) for n in layers]
    for var in variables:
        if var.ndim != 1:
            raise ValueError(f"layer {var.name!r} has {var.ndim} dimensions; a profile needs 1")
    dim = str(variables[0].dims[0])
    if any(str(v.dims[0]) != dim for v in variables):
        raise ValueError("a profile's layers must share one dimension")
    rows = [len(_flags(v)[0]) if is_categorical(v) else 5 for v in variables]
    heights = [0.12 + 0.15 * r for r in rows]
    width = width_of(size)
    with style():
        axes = _axes(ax, len(variables), (width, 0.4 + sum(h + 0.2 for h in heights)),
                     "profile_figure", sharex=True, gridspec_kw={"height_ratios": heights})
        xc = _coord(ds, dim)
        for a, var in zip(axes, variables):
            data = np.asarray(var.values)
            if is_categorical(var):
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


#: The colour-bar labels of counts drawn where the motion came to rest.
_AT_REST = {"n_reversals": "Reversals before rest"}


def _at_rest(ds: xr.Dataset, name: str, data: np.ndarray, codes: np.ndarray | None
             ) -> tuple[np.ndarray, str]:
    """A layer's values to draw and its colour-bar label, the same in a map and in a fate
    figure: a count (an integer layer) where the motion came to rest (``codes``: the
    fate on the same cells) is drawn there only, NaN elsewhere, so that no blank class
    reads as "0", under its :data:`_AT_REST` label; any other layer as it is."""
    if data.dtype.kind in "iu" and codes is not None:
        return (np.where(codes == _events.REST, data.astype(float), np.nan),
                _AT_REST.get(name, axis_label(ds, name)))
    return data, axis_label(ds, name)


def fate_figure(ds: xr.Dataset, *, extra: str | Sequence[str] | None = None,
                x: str | None = None, ax=None, size: str | float = "one_column",
                robust: bool = True) -> Figure:
    """A fate map: what becomes of each initial state, in the fate colours, and its layers.

    The categories present in ``fate`` (rest, contact lost, no solution...)
    are listed above the map.  ``extra`` names the layers drawn beside it, one
    panel each with its colour bar: by default every other layer on the fate
    map's axes (all the fate layers it was given: ``phi_rest``,
    ``n_reversals``, ``t_rest``...), a name or a list for those, ``[]`` for
    the fate map alone.  A count (``n_reversals``) is drawn only where the
    motion came to rest, as a rest angle is, so that no blank class reads as
    "0"; the legend says what blank means.  Panels stand side by side at
    two-column width (a 2 x 2 grid for four), colour bars on the right;
    stacked at one-column width, colour bars underneath.  The heading states
    what was held fixed and the horizon ``t_end``; the key below says that the
    class edges are the grid's cells (:func:`fate_grid_note`).
    """
    atlas_kind(ds)
    fate = _layer(ds, "fate")
    if not is_categorical(fate):
        raise ValueError("layer 'fate' needs flag_values and flag_meanings")
    xdim, ydim = _grid(ds, fate, x)
    if extra is None:
        extras = [str(n) for n, v in ds.data_vars.items()
                  if n != "fate" and set(v.dims) == set(fate.dims)]
    else:
        extras = [extra] if isinstance(extra, str) else list(extra)
    for name in extras:
        _grid(ds, _layer(ds, name), xdim)
    width = width_of(size)
    wide = width >= 5
    n = 1 + len(extras)
    if n == 1:
        figsize, grid, share = (width, width * (0.86 if not wide else 0.55)), (1, 1), {}
    elif wide and n <= 3:
        figsize, grid, share = (width, width * (0.5 if n == 2 else 0.4)), (1, n), \
            {"sharey": True}
    elif wide:
        rows = -(-n // 2)
        figsize, grid, share = (width, width * 0.42 * rows), (rows, 2), \
            {"sharex": True, "sharey": True}
    else:
        figsize, grid, share = (width, width * (0.1 + 0.83 * n)), (n, 1), {"sharex": True}
    with style():
        axes = _axes(ax, grid[0] * grid[1], figsize, "fate_figure", grid=grid, **share)
        xc, yc = _coord(ds, xdim), _coord(ds, ydim)
        xe, ye = _edges(xc), _edges(yc)
        codes = np.asarray(fate.transpose(ydim, xdim).values)
        handles, _ = _draw_categorical(axes[0], xc, yc, codes, fate)
        blank = False
        for a, name in zip(axes[1:], extras):
            data, label = _at_rest(ds, name, np.asarray(ds[name].transpose(ydim, xdim).values),
                                   codes)
            if data.dtype.kind == "f":
                blank = blank or bool(np.isnan(data).any())
            bar = _draw_continuous(a, xc, yc, data, label, robust=robust,
                                   location="right" if wide else "bottom",
                                   units=_units(ds, name))
            bar.mappable.set_gid(f"phasemap:{name}")
        for a in axes:
            _label_axis(a, ds, "x", xdim, xe)
            _label_axis(a, ds, "y", ydim, ye)
            a.set_xlim(xe[0], xe[-1])
            a.set_ylim(ye[0], ye[-1])
        if len(axes) > 1 and ax is None:
            outer_labels(axes)
        handles += mark_inverted_rests(axes, ds, xdim, ydim, xc, yc)
        if blank:
            handles.append(Patch(facecolor="white", edgecolor=GREY, linewidth=0.4,
                                 label="blank: did not come to rest"))
        if len(axes) > 1:
            label_panels(axes)
        if ax is None and len(axes) > 1:  # one legend over the panels, headed by the values
            figure_legend(axes[0].get_figure(root=False), handles,
                          title=fixed_values_text(ds, 0.95 * width) or None)
        else:
            legend_above(axes[0], handles)
            _annotate(axes, fixed_values_text(ds, _panel_width(axes[0])), ax is None)
        if ax is None:
            define_symbols(axes[0].get_figure(root=False), [fate_grid_note(ds, xdim)])
    return axes[0].figure


def fate_grid_note(ds: xr.Dataset, x: str | None = None) -> str:
    """What a fate map's class edges are: the cells of its grid, not exact curves.

    A fate follows from the whole motion (its rests, reversals and events), so
    no one condition on the initial state decides it and the bifurcation-set
    tracer (:func:`phasemap.boundaries`) has nothing to trace; the map's
    resolution is what draws its edges.  ``x`` names the horizontal axis
    (default: as :func:`fate_figure` chooses it).

    >>> import numpy as np, xarray as xr
    >>> ds = xr.Dataset({"fate": (("omega", "phi"), np.zeros((3, 4), np.int8))},
    ...                 coords={"phi": [0.0, 1.0, 2.0, 3.0], "omega": [0.0, 1.0, 2.0]})
    >>> fate_grid_note(ds, "phi")
    'fate edges: cells of the 4 × 3 grid, not exact curves (a fate follows the whole motion)'
    """
    fate = _layer(ds, "fate")
    xdim, ydim = _grid(ds, fate, x)
    return (f"fate edges: cells of the {ds.sizes[xdim]} × {ds.sizes[ydim]} grid, "
            "not exact curves (a fate follows the whole motion)")


def mark_inverted_rests(axes: Sequence[Axes], ds: xr.Dataset, x: str, y: str, xc, yc
                        ) -> list:
    """Fill, in the first of ``axes``, the cells whose motion came to rest in an inverted
    zone (cos phi_rest < 0), in dark grey; return their legend entry.

    Such rests are rare and isolated (the motion has just the energy to creep
    into the zone about the upper position, often with no reversal), and a
    reader would take them for noise; the fill and its legend entry say what
    they are.  The cells themselves are filled, not ringed: on a fine map they
    lie along curves, where rings hid the classes around them.  Needs
    ``phi_rest`` on the map's axes.
    """
    if "phi_rest" not in ds.data_vars or set(ds.phi_rest.dims) != {x, y}:
        return []
    phi_rest = np.asarray(ds.phi_rest.transpose(y, x).values, float)
    with np.errstate(invalid="ignore"):
        inverted = np.cos(phi_rest) < 0
    if not inverted.any():
        return []
    axes[0].pcolormesh(_edges(xc), _edges(yc), np.ma.masked_where(~inverted, inverted),
                       cmap=mcolors.ListedColormap([DARK_GREY]), vmin=0.5, vmax=1.5,
                       shading="flat", rasterized=True, linewidth=0, zorder=2.5)
    return [Patch(facecolor=DARK_GREY, edgecolor=DARK_GREY, linewidth=0.4,
                  label=r"rest inverted ($\cos\varphi_\mathrm{rest} < 0$)")]
