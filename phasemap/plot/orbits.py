"""Figures of periodic orbits: an orbit in its phase plane with its segments by contact
mode (:func:`orbit_figure`), a branch followed in a parameter with its stability and
special points (:func:`branch_figure`), and the orbit diagram of a sweep by simulation
with branches overlaid (:func:`diagram_figure`); what ``ds.phasemap.plot()`` draws of a
:func:`phasemap.periodic_orbit`, :func:`phasemap.continue_orbit` or
:func:`phasemap.orbit_diagram` Dataset."""

from __future__ import annotations

import json

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from phasemap.plot.layout import _axes, legend_above, width_of
from phasemap.plot.style import OKABE_ITO as _OI
from phasemap.plot.style import style

#: The look of each contact mode along an orbit (stick thick: where the block rides).
_MODES = {"stick": (_OI["vermillion"], 2.6), "slip_pos": (_OI["blue"], 1.2),
          "slip_neg": (_OI["bluish_green"], 1.2), "smooth": (_OI["black"], 1.2),
          "open": (_OI["orange"], 1.2)}
#: Special points of a branch: marker and colour by kind.
_KINDS = {"crossing_sliding": ("o", _OI["vermillion"]), "grazing_sliding": ("D", _OI["blue"]),
          "adding_sliding": ("v", _OI["blue"]), "switching_sliding": ("<", _OI["vermillion"]),
          "sequence_change": ("^", _OI["reddish_purple"]),
          "period_doubling": ("s", _OI["orange"]), "torus": ("*", _OI["orange"]),
          "fold": ("P", _OI["black"]), "continuum": ("h", _OI["bluish_green"]),
          "no_convergence": ("x", _OI["black"]), "max_points": ("x", _OI["sky_blue"]),
          "end": ("|", _OI["black"])}


def orbit_figure(ds: xr.Dataset, x: str | None = None, y: str | None = None, *, ax=None,
                 size: str | float = "one_column") -> Figure:
    """The orbit in the plane ``(x, y)`` (default: the first coordinate that moves and its
    rate), each segment drawn in its contact mode's colour (a stick segment thick), the
    events that end the segments marked."""
    contacts = [str(v)[len("segment_mode_"):] for v in ds.data_vars
                if str(v).startswith("segment_mode_")]
    if x is None or y is None:
        moving = [str(v) for v in ds.data_vars if ds[v].dims == ("t",)
                  and str(v) in _state_names(ds) and np.ptp(ds[v].values) > 0]
        if len(moving) < 2:
            raise ValueError("the orbit has fewer than two moving variables to draw")
        x, y = (x or moving[0]), (y or moving[len(moving) // 2])
    names = ds[f"mode_{contacts[0]}"].attrs["flag_meanings"].split()
    width = width_of(size)
    with style():
        (a,) = _axes(ax, 1, (width, width * 0.8), "orbit_figure")
        modes = ds[f"mode_{contacts[0]}"].values
        xs, ys = ds[x].values, ds[y].values
        start = 0
        seen = {}
        for i in range(1, len(modes) + 1):
            if i == len(modes) or modes[i] != modes[start]:
                name = names[int(modes[start]) + 1]
                colour, lw = _MODES.get(name, (_OI["black"], 1.2))
                stop = min(i + 1, len(modes))
                line, = a.plot(xs[start:stop], ys[start:stop], color=colour, lw=lw,
                               solid_capstyle="butt",
                               label=f"{contacts[0]} {name.replace('_', ' ')}")
                seen.setdefault(name, line)
                start = i
        a.plot(ds[f"event_{x}"].values, ds[f"event_{y}"].values, "o", ms=3.5,
               mfc="white", mec=_OI["black"], mew=0.8, zorder=3)
        a.set_xlabel(_label(ds, x))
        a.set_ylabel(_label(ds, y))
        handles = list(seen.values()) + [Line2D([], [], ls="none", marker="o", ms=3.5,
                                                mfc="white", mec=_OI["black"],
                                                label="event ending a segment")]
        legend_above(a, handles, title=f"period {float(ds.period):.6g} s")
    return a.figure


def _state_names(ds):
    """The orbit's coordinates and rates (those with a start per segment)."""
    return [str(v)[len("segment_"):] for v in ds.data_vars
            if str(v).startswith("segment_") and ds[v].dims == ("segment",)
            and not str(v).startswith(("segment_mode_", "segment_duration", "segment_start",
                                       "segment_end", "segment_event_index"))]


def _label(ds, name):
    """``name (units)``; a dimensionless name in math type (``$f$``, ``$f_s$``), as the
    maps write a variable."""
    units = ds[name].attrs.get("units", "")
    if units and units != "1":
        return f"{name} ({units})"
    return f"${name}$" if units == "1" and name.isidentifier() else name


def branch_figure(ds: xr.Dataset, y: str | None = None, *, ax=None,
                  size: str | float = "one_column") -> Figure:
    """The branch: ``y`` (default the first amplitude) against the parameter, stable
    solid, unstable dashed, special points marked and labelled by kind."""
    param = str(ds.attrs["phasemap_parameter"])
    if y is None:
        y = next((str(v) for v in ds.data_vars if str(v).startswith("amplitude_")), "period")
    if y not in ds.data_vars or ds[y].dims != ("vertex",):
        raise ValueError(f"{y!r} is not a quantity of the branch; choose one of "
                         + ", ".join(str(v) for v in ds.data_vars if ds[v].dims == ("vertex",)))
    width = width_of(size)
    p, v, stable = ds[param].values, ds[y].values, ds.stable.values
    with style():
        (a,) = _axes(ax, 1, (width, width * 0.7), "branch_figure")
        kinds = set()
        for run, ls in _runs(stable):
            kinds.add(ls)
            a.plot(p[run], v[run], color=_OI["black"], lw=1.3, ls=ls)
        handles = [Line2D([], [], color=_OI["black"], lw=1.3, ls=ls, label=label)
                   for ls, label in (("-", "stable"), ("--", "unstable")) if ls in kinds]
        done = set()
        for i in range(ds.sizes["point"]):
            kind = str(ds.point_kind.values[i])
            if kind == "end":
                continue
            at = float(ds[f"point_{param}"][i])
            val = _at_point(ds, i, y, at, p, v)
            marker, colour = _KINDS.get(kind, ("X", _OI["reddish_purple"]))
            a.plot([at], [val], marker=marker, color=colour, ms=6, ls="none", zorder=3)
            if kind not in done:
                handles.append(Line2D([], [], ls="none", marker=marker, color=colour, ms=6,
                                      label=kind.replace("_", "-")))
                done.add(kind)
        a.set_xlabel(_label(ds, param))
        a.set_ylabel(_label(ds, y))
        legend_above(a, handles)
    return a.figure


def _runs(stable):
    """A branch's runs of stable (``"-"``) or unstable (``"--"``) points, as ``(slice,
    line style)``: each run from the last point of the one before, so the line goes on."""
    stable = np.asarray(stable).astype(bool)
    edges = [i for i in range(1, len(stable)) if stable[i] != stable[i - 1]]
    return [(slice(max(lo - 1, 0), hi), "-" if stable[lo] else "--")
            for lo, hi in zip([0, *edges], [*edges, len(stable)])]


def _at_point(ds, i, y, at, p, v) -> float:
    """The value of ``y`` at the special point ``i`` (parameter ``at``): its own where the
    branch Dataset stores it (``point_<y>``), else a vertex's at exactly ``at`` (a fold,
    a period doubling and a torus point are vertices of the branch), else interpolated on
    the first piece of the branch whose ends hold ``at`` (the branch may turn, so it is not
    a function of the parameter), else the nearest point's.  Where the branch passes
    ``at`` at several vertices, the one whose period is the point's."""
    if f"point_{y}" in ds:
        return float(ds[f"point_{y}"][i])
    exact = np.flatnonzero(p == at)
    if exact.size > 1 and "point_period" in ds:     # on which arm: the point's own period
        exact = exact[np.argsort(np.abs(ds.period.values[exact]
                                        - float(ds.point_period[i])), kind="stable")]
    if exact.size:
        return float(v[exact[0]])
    for k in range(len(p) - 1):
        if (p[k] - at) * (p[k + 1] - at) <= 0 and p[k] != p[k + 1]:
            return float(v[k] + (v[k + 1] - v[k]) * (at - p[k]) / (p[k + 1] - p[k]))
    return float(v[int(np.argmin(np.abs(p - at)))])


def diagram_figure(ds: xr.Dataset, y: str | None = None, *, branches=(), ax=None,
                   size: str | float = "one_column") -> Figure:
    """The orbit diagram: the stroboscopic points of ``y`` (default the first coordinate
    that moves; an autonomous system's: its points at the maxima of its section) against
    the parameter, one dot each; each of ``branches`` (Datasets of
    :func:`phasemap.continue_orbit` in the same parameter) overlaid where its orbits cross
    the forcing's phase 0, stable solid, unstable dashed, its special points marked.

    >>> import phasemap
    >>> d = phasemap.orbit_diagram("den_hartog", "f", [0.2, 0.4], periods=2, settle=30)
    >>> len(phasemap.plot.orbits.diagram_figure(d).axes)
    1
    """
    # (a Scene's section points, phasemap.maps.motions: the parameter is the scene's axis,
    # the points are section_x..., the settings are the scene's options)
    param = str(ds.attrs.get("phasemap_parameter") or next(
        v.dims[0] for v in ds.data_vars.values() if v.dims[1:] == ("cycle",)))
    points = [str(v) for v in ds.data_vars if ds[v].dims == (param, "cycle")]
    if y is None:
        moving = [v for v in points if np.nanmax(ds[v].values, initial=-np.inf)
                  > np.nanmin(ds[v].values, initial=np.inf)]
        y = (moving or points)[0]
    if y not in points:
        raise ValueError(f"{y!r} is not a variable of the diagram; choose one of "
                         + ", ".join(points))
    if isinstance(branches, xr.Dataset):
        branches = [branches]
    coordinate = y.removeprefix("section_") if "phasemap_parameter" not in ds.attrs else y
    for b in branches:
        if not isinstance(b, xr.Dataset) or b.attrs.get("phasemap_kind") != "orbit_branch" \
                or b.attrs.get("phasemap_parameter") != param \
                or f"section_{coordinate}" not in b:
            raise ValueError(f"branches= takes Datasets of phasemap.continue_orbit in {param} "
                             f"of a forced system (with section_{coordinate})")
    width = width_of(size)
    p = ds[param].values
    v = ds[y].values
    with style():
        (a,) = _axes(ax, 1, (width, width * 0.7), "diagram_figure")
        xs = np.broadcast_to(p[:, None], v.shape)
        a.plot(xs.ravel(), v.ravel(), ls="none", marker=".", mew=0,
               ms=2.0 if np.count_nonzero(~np.isnan(v)) > 2000 else 4.0,
               color=_OI["black"], alpha=0.7, rasterized=v.size > 5000, zorder=2.5)
        spec = json.loads(ds.attrs.get("phasemap_diagram") or json.dumps(
            json.loads(ds.attrs.get("phasemap_scene", "{}")).get("options", {})))
        each = ("once per period" if spec.get("section") is None
                else f"each maximum of {spec['section']}")
        handles = [Line2D([], [], ls="none", marker=".", ms=4, color=_OI["black"],
                          label=f"settled motion, {each}")]
        styles = set()
        for b in branches:
            bp, sec = b[param].values, b[f"section_{coordinate}"].values
            for run, ls in _runs(b.stable.values):
                styles.add(ls)
                a.plot(bp[run], sec[run], color=_OI["vermillion"], lw=1.2, ls=ls, zorder=2)
            for i in range(b.sizes["point"]):
                kind = str(b.point_kind.values[i])
                if kind == "end":
                    continue
                at = float(b[f"point_{param}"][i])
                marker, colour = _KINDS.get(kind, ("X", _OI["reddish_purple"]))
                for col in range(sec.shape[1]):
                    if np.isnan(sec[:, col]).all():
                        continue
                    val = _at_point(b.drop_vars([f"point_{coordinate}"], errors="ignore"),
                                    i, coordinate, at, bp, sec[:, col])
                    a.plot([at], [val], marker=marker, color=colour, ms=6, ls="none",
                           zorder=3)
                if kind.replace("_", "-") not in {h.get_label() for h in handles}:
                    handles.append(Line2D([], [], ls="none", marker=marker, color=colour,
                                          ms=6, label=kind.replace("_", "-")))
        handles += [Line2D([], [], color=_OI["vermillion"], lw=1.2, ls=ls, label=label)
                    for ls, label in (("-", "stable orbit"), ("--", "unstable orbit"))
                    if ls in styles]
        if coordinate != y:       # a scene's atlas: the model's symbols, as its maps
            from phasemap.plot.labels import _symbol_and_units, axis_label

            a.set_xlabel(axis_label(ds, param))
            # the coordinate's symbol where the model knows it (not y, which a contact
            # fixes): else the layer's own label
            known = _symbol_and_units(ds, coordinate) is not None
            a.set_ylabel(axis_label(ds, coordinate if known else y))
        else:
            a.set_xlabel(_label(ds, param))
            a.set_ylabel(_label(ds, y))
        legend_above(a, handles)
    return a.figure
