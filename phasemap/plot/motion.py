r"""Motion figures: phase curves and trajectories, their events marked by kind."""

from __future__ import annotations

from typing import Sequence

import matplotlib.colors as mcolors
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from phasemap.core import events as _events
from phasemap.atlas.dataset import is_categorical
from phasemap.plot.labels import _coord, _flags, _require, _squared_label, _meaning_text, axis_label, \
    fixed_values_text
from phasemap.plot.layout import (_annotate, _axes, _label_axis, legend_above, _panel_width, label_panels,
                     width_of)
from phasemap.plot.style import EVENT_MARKERS, GREY, PALE_GREY, _OI, _TERMINAL, style

# --------------------------------------------------------------------------- motions


def _event_flags(var: xr.DataArray) -> dict[int, str]:
    if is_categorical(var):
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
    # the events along a motion are told apart by shape, not colour: black edges, hollow
    # but for the reversal dot; the start a ring wider than a dot, drawn over one
    start = name == "start"
    return {"marker": marker, "ms": 5.0 if start else 3.0 if name == "reversal" else 3.5,
            "mfc": colour, "mec": _OI["black"], "mew": 0.8, "ls": "none",
            "zorder": 7 if start else 6, "clip_on": False}


def event_handle(name: str, label: str | None = None) -> Line2D:
    """The legend entry of an event of kind ``name`` (``"rest"``, ``"reversal"``...), in its
    one look; ``label`` defaults to the kind."""
    return Line2D([], [], label=_meaning_text(name) if label is None else label,
                  **_event_style(name))


def mark_event(ax: Axes, name: str, x, y) -> None:
    """Mark events of kind ``name`` at ``x``, ``y`` on ``ax`` in their one look."""
    ax.plot(np.atleast_1d(x), np.atleast_1d(y), **_event_style(name))


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
        legend_above(a, _event_handles(names),
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
                 if v.dims == ("t",) and not is_categorical(v)]
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
                # a short panel: at least three labelled ticks (angles spanning pi or more
                # get multiples of pi from _label_axis)
                a.yaxis.set_major_locator(MaxNLocator(nbins=4, min_n_ticks=3))
                _mark_events(a, ds, kinds, "t", name)
                for tt in terminal:
                    a.axvline(tt, color=GREY, lw=0.6, ls="--", zorder=1)
                _label_axis(a, ds, "y", name, values)
                if a is not axes[-1]:
                    a.tick_params(axis="x", labelbottom=False)
            _label_axis(axes[-1], ds, "x", "t")
            if t.size > 1:
                # room at the right for a terminal event's marker at the last time
                end = t.max() + (0.025 * (t.max() - t.min()) if terminal else 0.0)
                axes[-1].set_xlim(t.min(), end)
            if len(axes) > 1:
                axes[0].figure.align_ylabels(axes)
        shown = [k for k in kinds if phase_plane or k != "start"]
        legend_above(axes[0], _event_handles(shown))
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


