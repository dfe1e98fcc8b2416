"""The figure of the bifurcation set on its own: the pieces a :func:`phasemap.boundaries`
or ``threshold(..., along=)`` Dataset holds, with their special points.

Over a map, ``ds.phasemap.plot(boundaries=True)`` draws the same pieces
(:func:`phasemap.plot.maps.draw_boundaries`); this figure is what ``phasemap plot``
makes of a file written by ``phasemap boundaries`` or ``phasemap threshold --along``.
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from phasemap.atlas.dataset import curve_axes, curve_kind
from phasemap.plot.labels import fixed_values_text
from phasemap.plot.layout import _axes, _label_axis, _panel_width, legend_above, width_of
from phasemap.plot.maps import draw_boundaries
from phasemap.plot.style import OKABE_ITO as _OI
from phasemap.plot.style import style

#: How each kind of special point is drawn (an unknown kind gets the last).
_POINTS = {"crossing": ("o", _OI["vermillion"]), "tangency": ("D", _OI["blue"]),
           "end": ("s", _OI["black"]), "switch": ("^", _OI["bluish_green"]),
           "edge": ("v", _OI["black"]), "fold": ("P", _OI["orange"]),
           "other": ("X", _OI["reddish_purple"])}


def _point_style(kind: str) -> tuple[str, str]:
    if kind.startswith("fold"):
        return _POINTS["fold"]
    return _POINTS.get(kind, _POINTS["other"])


def _ranges(ds: xr.Dataset, x: str, y: str) -> dict:
    """The ranges the file records for its axes (the slice's; the followed parameter's)."""
    out = {}
    for attr in ("phasemap_axes", "phasemap_along"):
        try:
            given = json.loads(str(ds.attrs[attr]))
            out |= {n: (float(given[n][0]), float(given[n][1])) for n in (x, y) if n in given}
        except (KeyError, TypeError, ValueError, IndexError, RecursionError):
            continue
    return {n: r for n, r in out.items() if all(np.isfinite(r)) and r[0] < r[1]}


def curves_figure(ds: xr.Dataset, *, ax=None, size: str | float = "one_column") -> Figure:
    """The pieces of a boundaries or threshold-curve Dataset, one black curve each, with
    their special points (crossings, folds, ends, switches) marked by kind."""
    kind = curve_kind(ds)
    if kind is None:
        raise ValueError("not a boundaries or threshold file (phasemap_kind)")
    x, y = curve_axes(ds)
    width = width_of(size)
    with style():
        (a,) = _axes(ax, 1, (width, width * (0.8 if width < 5 else 0.45)), "curves_figure")
        label = "class boundary" if kind == "boundaries" else "threshold"
        handles = draw_boundaries(a, ds, x, y, label=label)
        kinds = (np.asarray(ds["point_kind"].values).astype(str)
                 if "point_kind" in ds.variables else np.array([], str))
        px = ds.get(f"point_{x}")
        py = ds.get(f"point_{y}")
        if px is not None and py is not None and kinds.size:
            px, py = np.asarray(px.values, float), np.asarray(py.values, float)
            for name in dict.fromkeys(kinds.tolist()):
                marker, colour = _point_style(name)
                sel = (kinds == name) & np.isfinite(px) & np.isfinite(py)
                if not sel.any():
                    continue
                look = {"ls": "none", "marker": marker, "ms": 5, "mfc": colour,
                        "mec": "white", "mew": 0.5}
                a.plot(px[sel], py[sel], zorder=6, clip_on=False, **look)
                handles.append(Line2D([], [], label=name.replace("_", " "), **look))
        ranges = _ranges(ds, x, y)
        _label_axis(a, ds, "x", x, ranges.get(x, ds[x].values))
        _label_axis(a, ds, "y", y, ranges.get(y, ds[y].values))
        for name, set_lim in ((x, a.set_xlim), (y, a.set_ylim)):
            if name in ranges:  # the slice or the range the curve was followed over
                set_lim(*ranges[name])
        if not ds.sizes.get("vertex", 0):
            a.text(0.5, 0.5, f"no {label} in the range", transform=a.transAxes,
                   ha="center", va="center")
        legend_above(a, handles, title=fixed_values_text(ds, _panel_width(a)) or None)
    return a.figure
