r"""Motion figures: phase curves and trajectories, their events marked by kind."""

from __future__ import annotations

import warnings
from typing import Sequence

import matplotlib.colors as mcolors
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
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

#: The times at which a trajectory figure samples its motion's dense output.
DENSE_POINTS = 600


def dense_motion(ds: xr.Dataset, times) -> xr.Dataset | None:
    """The motion of ``ds`` again, saved at ``times`` from the integrator's dense output.

    A trajectory saved at its steps (``simulate`` without ``t_eval``) holds only the
    points where the integrator stopped; drawn through them, a curve has kinks between
    steps (a rod's fall: 20 points over 0.53 s).  The motion is run again from the
    model, initial state, parameters and options its attributes record, with
    ``t_eval=times``; the run is deterministic, so it is the same motion, and the
    re-run is accepted only where its steps, fate and events are those of ``ds``
    (bit for bit).  None where that cannot be done: a batch, a model its name no longer
    finds (a declaration file), or a re-run that differs.  ``ds`` is not changed.
    """
    a = ds.attrs
    if a.get("phasemap_kind") != "trajectory" or "phasemap_model" not in a \
            or ds["t"].dims != ("t",) or any(d not in ("t", "event") for d in ds.dims):
        return None
    import dataclasses

    from phasemap.motion.hybrid.results import DEFAULTS
    from phasemap.motion.simulate import Options, simulate

    # the options a trajectory records (phasemap_<option>): the integrator's settings and
    # the contact options, as simulate writes them
    names = [f.name for f in dataclasses.fields(Options)] + list(DEFAULTS)
    options = {k: a[f"phasemap_{k}"] for k in names if f"phasemap_{k}" in a}
    if a.get("phasemap_through_contacts") == "false":   # ended where the reduced model ends
        options["through_contacts"] = False
    try:
        values = {k.split("_", 2)[2]: float(v) for k, v in a.items()
                  if k.startswith(("phasemap_initial_", "phasemap_fixed_"))}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            again = simulate(str(a["phasemap_model"]), t_eval=np.asarray(times, float),
                             **options, **values)
    except (ValueError, TypeError, LookupError, ArithmeticError, MemoryError):
        return None     # what simulate refuses in one line: the saved points are drawn
    same = all(again.attrs.get(k) == a.get(k) for k in ("n_steps", "end_reason")) and all(
        k in again and again[k].shape == ds[k].shape
        and np.array_equal(again[k].values, ds[k].values, equal_nan=True)
        for k in ("event_t", "event_kind") if k in ds)
    return again if same else None


def _through_saved(ds: xr.Dataset, again: xr.Dataset, t: np.ndarray, names) -> dict:
    """Per name, ``(times, values)``: the dense re-run's samples at the times that are not
    saved, and every saved point itself (an event's state is exact there, and an impact
    is saved twice at its time, before and after: the curve jumps there), in time
    order.  A name the re-run does not give as the Dataset holds it at its saved steps
    (a variable added or converted after the run) keeps its saved points."""
    ta = np.asarray(again.t.values, float)
    fresh = ~np.isin(ta, t)
    order = np.argsort(np.concatenate([ta[fresh], t]), kind="stable")
    once = np.flatnonzero(np.r_[True, np.diff(t) > 0] & np.r_[np.diff(t) > 0, True])
    at = np.minimum(np.searchsorted(ta, t[once]), ta.size - 1)
    ok = ta[at] == t[once]
    out = {}
    for name in names:
        if name not in again or again[name].dims != ("t",):
            continue
        saved = np.asarray(ds[name].values, float)
        y = np.asarray(again[name].values, float)
        # the re-run's values at the steps saved once must be the Dataset's there (to
        # rounding: the dense output at a step's end is its state)
        a, b = y[at[ok]], saved[once[ok]]
        both = np.isfinite(a) & np.isfinite(b)
        scale = np.max(np.abs(b[both]), initial=0.0) + 1e-300
        if not (np.array_equal(np.isfinite(a), np.isfinite(b))
                and np.all(np.abs(a[both] - b[both]) <= 1e-9 * scale)):
            continue
        out[name] = (np.concatenate([ta[fresh], t])[order],
                     np.concatenate([y[fresh], saved])[order])
    return out


def _dense_times(ds: xr.Dataset, t: np.ndarray) -> np.ndarray:
    """Times to draw a motion at: ``DENSE_POINTS`` evenly spaced over its span, with its
    saved times (steps and events, where a curve has its corners)."""
    extra = [t]
    if "event_t" in ds:
        ev = np.asarray(ds.event_t.values, float)
        extra.append(ev[np.isfinite(ev) & (ev >= t.min()) & (ev <= t.max())])
    return np.unique(np.concatenate([np.linspace(t.min(), t.max(), DENSE_POINTS), *extra]))


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
                      size: str | float = "one_column", dense: bool = True) -> Figure:
    r"""A trajectory: each state against time, one panel per state, events marked.

    Each event after the start is marked on every state's curve by its kind
    (reversal, stick, rest...), the terminal event larger and edged, with a
    dashed vertical line at its time across the panels; the legend above
    lists the kinds present.  ``states`` picks and orders the states
    (default: every state variable on dimension ``t``; for a motion in full
    coordinates, which also carries their rates, each contact's reactions, gaps
    and points, the coordinates alone: name the others to draw them).  With
    ``phase_plane=True``, one panel of :math:`\omega` against
    :math:`\varphi` (the model's first coordinate and its velocity, from the
    attribute ``phasemap_phase_plane``; or ``states=(x, y)``) instead, where
    the start is marked too.

    The curves follow the integrator's dense output, not straight lines between
    the saved steps: with ``dense`` (the default) the motion is run again at
    :data:`DENSE_POINTS` times and its saved ones (:func:`dense_motion`); where it
    cannot be (a batch, a declaration file's model, a Dataset not made by
    :func:`phasemap.simulate`), or with ``dense=False``, the saved points are drawn.
    For a figure of a motion you keep, ``simulate(..., t_eval=...)`` saves it densely
    once.

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
        if not phase_plane and ds.attrs.get("phasemap_coordinates") == "full":
            # the coordinates: saved at every event too, and not rates (units ... s-1)
            states = [n for n in available if f"event_{n}" in ds.data_vars
                      and not str(ds[n].attrs.get("units", "")).endswith("s-1")] or states
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
    curve = {name: (t, np.asarray(ds[name].values, float)) for name in states}
    if dense and t.size > 1:
        times = _dense_times(ds, t)
        again = dense_motion(ds, times)
        if again is not None:
            for name, merged in _through_saved(ds, again, t, states).items():
                curve[name] = merged
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
            (tx, xs), (ty, ys) = (curve[s] for s in states)
            if tx.shape != ty.shape or np.any(tx != ty):  # one state dense, one not
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
                tc, values = curve[name]
                a.plot(tc, values, color=_OI["black"], lw=1.0, zorder=3)
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
        handles = _event_handles(shown)
        if not phase_plane and any(k in _TERMINAL for k in kinds):
            # the dashed line drawn at the end across the panels says what it is
            # (before the terminal event's marker, which stays last and says why)
            handles.insert(max(len(handles) - 1, 0), Line2D(
                [], [], color=GREY, lw=0.6, ls="--", label="end of the motion"))
        legend_above(axes[0], handles)
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




# ------------------------------------------------------------------- outline strips

#: The events whose times an outline strip draws by default, beside evenly spaced ones.
STRIP_EVENTS = ("liftoff", "impact", "iwc", "recontact", "zeno", "stick", "rest",
                "left_domain")


def _outline(centre: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The outline drawn for a body: the convex hull of its contact points and their
    reflections through its centre of mass (exact for a uniform rod or a box), closed."""
    cloud = np.concatenate([points, 2.0 * centre - points, centre[None, :]])
    cloud = cloud[np.all(np.isfinite(cloud), axis=1)]
    if len(cloud) < 3 or np.ptp(cloud, axis=0).max() == 0.0:
        return cloud
    # Andrew's monotone chain
    pts = sorted(map(tuple, np.unique(np.round(cloud, 12), axis=0)))
    if len(pts) < 3:
        return np.array(pts)

    def half(seq):
        out = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out
    hull = half(pts)[:-1] + half(pts[::-1])[:-1]
    return np.array(hull + hull[:1])


def outline_figure(ds: xr.Dataset, *, times: Sequence[float] | None = None, ax=None,
                   forces: bool = True, size: str | float = "one_column") -> Figure:
    """A body's motion as a strip of its outlines at chosen times, in the plane: the
    figure a paper on the ladder or the rod prints.

    Needs a motion in full coordinates (:func:`phasemap.simulate` through contact
    changes: ``centre_x``, ``centre_y`` and ``point_x_<contact>``, ``point_y_<contact>``
    on ``t``).  Each outline is the convex hull of the contact points and their
    reflections through the centre of mass (a uniform rod, a box), shaded from light to
    dark with time, its centre of mass dotted.  ``times`` default to seven evenly spaced
    times and those of the events that change a contact (lift-off, impact...).  With
    ``forces``, each closed contact's reaction (``N_<c>``, ``F_<c>``) is an arrow at its
    point, and each impact's impulse a vermillion arrow; the surfaces of the point
    contacts (``phasemap_surface_<c>``) are drawn, hatched on the obstacle's side, and an
    edge contact's corner as a grey wedge.  A rolling disc (``phasemap_radius_<c>``) is
    drawn as its rim and a spoke to its centre of mass.
    """
    import matplotlib as mpl

    _require(ds, ("t", "centre_x", "centre_y"), "outline strip")
    contacts = [str(v)[len("point_x_"):] for v in ds.data_vars if str(v).startswith("point_x_")]
    t = np.asarray(ds.t.values, float)
    if times is None:
        times = list(np.linspace(t.min(), t.max(), 7))
        if "event_kind" in ds:
            flags = _event_flags(ds.event_kind)
            times += [float(tt) for tt, k in zip(ds.event_t.values, ds.event_kind.values)
                      if flags.get(int(k)) in STRIP_EVENTS]
        times = sorted({float(x) for x in np.round(times, 12) if t.min() <= x <= t.max()})
    times = np.asarray(times, float)
    if times.ndim != 1 or not times.size or np.any(~np.isfinite(times)) or (
            times.min() < t.min() or times.max() > t.max()):
        raise ValueError(f"times must be a 1-D sequence of times in [{t.min():g}, "
                         f"{t.max():g}], the motion's")

    # the outlines at their times from the dense output (dense_motion), not interpolated
    # straight between steps, which shortens a turning rod; at a saved time (an event's)
    # the saved point after it, as before (the reactions of a contact an impact closed)
    dense_t = np.unique(times)
    again = dense_motion(ds, dense_t)

    def at(name, tt):
        if again is not None and not np.any(t == tt):   # a saved time: its saved point
            ta = again.t.values
            i = np.searchsorted(ta, tt)
            if i < ta.size and ta[i] == tt and np.isfinite(again[name].values[i]):
                return float(again[name].values[i])
        return np.interp(tt, t, np.asarray(ds[name].values, float))

    width = width_of(size)
    with style():
        (a,) = _axes(ax, 1, (width, width * 0.75), "outline_figure")
        a.set_aspect("equal")
        cmap = mpl.colormaps["Greys"]
        span = max(times.max() - times.min(), 1e-300)
        xs_all, ys_all, drawn = [], [], []
        discs = {k: (float(ds.attrs[f"phasemap_radius_{k}"]),
                     np.asarray(ds.attrs[f"phasemap_surface_{k}"], float)[:2])
                 for k in contacts if f"phasemap_radius_{k}" in ds.attrs
                 and f"phasemap_surface_{k}" in ds.attrs}
        ring = np.linspace(0.0, 2.0 * np.pi, 97)
        for tt in times:
            c = np.array([at("centre_x", tt), at("centre_y", tt)])
            pts = np.array([[at(f"point_x_{k}", tt), at(f"point_y_{k}", tt)] for k in contacts])
            hull = _outline(c, np.array([p_ for k, p_ in zip(contacts, pts) if k not in discs]
                                        ).reshape(-1, 2))
            shade = cmap(0.35 + 0.65 * (tt - times.min()) / span)
            if len(hull) >= 2:
                a.plot(hull[:, 0], hull[:, 1], color=shade, lw=1.4, solid_capstyle="round",
                       zorder=3)
            for k, (r, n) in discs.items():     # a rolling disc: its rim, and a spoke to
                o = pts[contacts.index(k)] + r * n          # its centre of mass
                rim = o[None, :] + r * np.c_[np.cos(ring), np.sin(ring)]
                a.plot(rim[:, 0], rim[:, 1], color=shade, lw=1.2, zorder=3)
                a.plot([o[0], c[0]], [o[1], c[1]], color=shade, lw=1.0, zorder=3)
                hull = np.vstack([hull.reshape(-1, 2), rim])
            a.plot([c[0]], [c[1]], "o", ms=2.5, color=shade, zorder=4)
            xs_all += list(hull[:, 0]) + [c[0]]
            ys_all += list(hull[:, 1]) + [c[1]]
            drawn.append((tt, c, pts))
        xs_all, ys_all = np.array(xs_all), np.array(ys_all)
        ext = max(np.ptp(xs_all), np.ptp(ys_all), 1e-9)
        lo_x, hi_x = xs_all.min() - 0.15 * ext, xs_all.max() + 0.15 * ext
        lo_y, hi_y = ys_all.min() - 0.15 * ext, ys_all.max() + 0.15 * ext
        surfaces = {}     # each surface once (a floor under two contacts)
        for k in contacts:
            s = ds.attrs.get(f"phasemap_surface_{k}")
            if s is not None:
                surfaces[tuple(np.round(np.asarray(s, float), 12))] = None
        for (nx, ny, off) in surfaces:
            tx, ty = ny, -nx
            p0 = np.array([nx * off, ny * off])
            ts_ = np.linspace(-3 * ext, 3 * ext, 2)
            line = p0[None, :] + ts_[:, None] * np.array([tx, ty])[None, :]
            a.plot(line[:, 0], line[:, 1], color=GREY, lw=0.8, zorder=1)
            # the hatch on the obstacle's side: one collection, not an artist per stroke
            starts = p0 + np.linspace(-3 * ext, 3 * ext, 121)[:, None] * np.array([tx, ty])
            ends = starts - 0.04 * ext * np.array([nx, ny]) + 0.03 * ext * np.array([tx, ty])
            a.add_collection(LineCollection(np.stack([starts, ends], axis=1), colors=GREY,
                                            linewidths=0.5, zorder=1))
        for k in contacts:      # an edge contact's obstacle is a fixed corner
            if ds.attrs.get(f"phasemap_surface_{k}") is None:
                a.plot([at(f"point_x_{k}", times[0])], [at(f"point_y_{k}", times[0])],
                       marker="^", ms=7, color=GREY, ls="none", zorder=2)
        if forces:
            _force_arrows(a, ds, contacts, drawn, at, ext)
        a.set_xlim(lo_x, hi_x)
        a.set_ylim(lo_y, hi_y)
        a.set_xlabel("x (m)")
        a.set_ylabel("y (m)")
        norm = mpl.colors.Normalize(times.min(), times.max())
        sm = mpl.cm.ScalarMappable(norm=norm, cmap=mpl.colors.LinearSegmentedColormap.from_list(
            "strip", [cmap(0.35), cmap(1.0)]))
        bar = a.figure.colorbar(sm, ax=a, fraction=0.05, pad=0.02)
        bar.set_label("t (s)")
        _annotate([a], fixed_values_text(ds, _panel_width(a)), ax is None)
    return a.figure


def _force_arrows(a, ds, contacts, drawn, at, ext) -> None:
    """The reactions at the drawn times and the impulses of the impacts, as arrows."""
    normals = {}
    for k in contacts:
        s = ds.attrs.get(f"phasemap_surface_{k}")
        if s is not None:
            normals[k] = np.asarray(s, float)[:2]
    forces = []
    for tt, c, pts in drawn:
        for j, k in enumerate(contacts):
            if k not in normals or f"N_{k}" not in ds:
                continue
            N = at(f"N_{k}", tt)    # (a rolling disc's F is its moment: not an arrow)
            F = 0.0 if f"phasemap_radius_{k}" in ds.attrs else at(f"F_{k}", tt)
            if np.isfinite(N) and np.isfinite(F) and (N != 0.0 or F != 0.0):
                n = normals[k]
                forces.append((pts[j], N * n + F * np.array([n[1], -n[0]])))
    _arrows(a, forces, 0.25 * ext, _OI["blue"], 0.8, 5)
    if "event_impulse_n" not in ds or "event_contact" not in ds:
        return
    names = _flags(ds.event_contact)[1] if is_categorical(ds.event_contact) else []
    hits = []
    for i in np.flatnonzero(np.isfinite(np.asarray(ds.event_impulse_n.values, float))):
        c = int(ds.event_contact.values[i])
        name = names[c + 1] if 0 <= c + 1 < len(names) else None
        if name not in normals:
            continue
        tt = float(ds.event_t.values[i])
        p = np.array([at(f"point_x_{name}", tt), at(f"point_y_{name}", tt)])
        n = normals[name]
        P = (float(ds.event_impulse_n.values[i]) * n
             + float(ds.event_impulse_t.values[i]) * np.array([n[1], -n[0]]))
        hits.append((p, P))
    _arrows(a, hits, 0.3 * ext, _OI["vermillion"], 1.2, 6)


def _arrows(a, items, length, colour, lw, zorder) -> None:
    """Arrows ``(point, vector)``, the largest ``length`` long, the others in proportion."""
    if not items:
        return
    big = max(np.hypot(*v) for _, v in items) or 1.0
    for p, v in items:
        a.annotate("", xy=p + length * v / big, xytext=p,
                   arrowprops={"arrowstyle": "-|>", "color": colour, "lw": lw}, zorder=zorder)
