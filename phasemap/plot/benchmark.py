"""The benchmark figure: error against run time (work-precision), as in DiffEqDevTools."""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from phasemap.plot.labels import _visible_length, format_number, format_units, wrap
from phasemap.plot.layout import (WIDE, _axes, legend_above, _legend_fits, _legend_height, define_symbols,
                     label_panels, legend_columns, width_of)
from phasemap.plot.style import CYCLE, MARKERS, _FONT, _OI, style

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

#: One look per method: the colour and marker name the method's order (Dormand-Prince
#: 5(4) blue circles, 8(5,3) orange squares), a filled marker and a solid line
#: phasemap's implementation, a hollow marker and a dashed line SciPy's, so that each
#: phasemap method stands beside its SciPy counterpart, in greyscale too.
METHOD_LOOKS = {
    "phasemap": (_OI["blue"], "o", True),
    "RK45": (_OI["blue"], "o", False),
    "phasemap_DOP853": (_OI["orange"], "s", True),
    "DOP853": (_OI["orange"], "s", False),
    "simulate": (_OI["sky_blue"], "D", True),
    "phase_curve": (_OI["black"], "^", True),  # green is the fate "rest"
    "Radau": (_OI["reddish_purple"], "v", False),
    "LSODA": (_OI["black"], "X", False),
}


#: Methods whose points are not joined: the first-integral tracer's rtol is not a knob of
#: its work (its run time hardly changes with it) nor, measured, monotone in its error.
UNJOINED = frozenset({"phase_curve"})


def _method_look(method: str, j: int) -> dict:
    colour, marker, own = METHOD_LOOKS.get(method, (CYCLE[j % len(CYCLE)],
                                                    MARKERS[j % len(MARKERS)], True))
    ls = "none" if method in UNJOINED else "solid" if own else (0, (3.0, 1.5))
    return {"color": colour, "marker": marker, "ms": 4.0 if method in UNJOINED else 3.5,
            "lw": 1.0, "ls": ls, "mfc": colour if own else "white", "mec": colour, "mew": 0.9}
#: The built-in work-precision problems as panel headings.
SYSTEM_NAMES = {
    "hinge_weightless": r"hinge pendulum, $g$ = 0 m s$^{-2}$",
    "hinge_pendulum": r"hinge pendulum, $g$ = 9.81 m s$^{-2}$",
    "ladder": "ladder",
    "wheel": "wheel",
    "elliptic_pendulum": "elliptic pendulum",
}


#: The errors a work-precision table carries, and the label of each (its definition).
ERROR_LABELS = {
    "error_final": r"Final-state error $\|\Delta y\|_\infty$ (SI)",
    "error_l2": r"$L_2$ error along the motion (SI)",
    "error_scaled_final": r"Final-state error $\max_i|\Delta y_i|/\hat y_i$ (dimensionless)",
    "error_scaled_l2": r"$L_2$ error of $\Delta y_i/\hat y_i$ (dimensionless)",
}


def _symbol(name: str, symbol: str) -> str:
    sym = symbol or name
    return sym if len(sym) == 1 or sym.startswith("\\") else rf"\mathrm{{{sym}}}"


def scales_key(rows: Sequence[Mapping]) -> list[str]:
    r"""What the scaled errors divide by, one item per system of ``rows`` (in order),
    read from the rows' ``scales`` (``(name, y_hat, units, symbol)`` per component):
    ``"(a) $\hat\varphi$ = 8.957 rad, $\hat\omega$ = 5 rad s$^{-1}$"``.  Empty when
    the rows carry no scales."""
    out = []
    systems = list(dict.fromkeys(str(r["system"]) for r in rows))
    for i, system in enumerate(systems):
        scales = next((r.get("scales") for r in rows if str(r["system"]) == system
                       and r.get("scales")), None)
        if not scales:
            continue
        items = [rf"$\hat{{{_symbol(name, symbol)}}}$ = "
                 + format_number(float(f"{value:.4g}"))
                 + (f" {format_units(units)}" if format_units(units) else "")
                 for name, value, units, symbol in scales]
        out.append((f"({chr(97 + i)}) " if len(systems) > 1 else "") + ", ".join(items))
    return out


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
                          size: str | float = "two_column", ylabel: str | None = None,
                          key: Sequence[str] | None = None) -> Figure:
    r"""A work-precision diagram: error against run time, log-log, as in DiffEqDevTools.

    ``table`` is a list of dicts with keys ``method``, ``system``, ``tol``,
    ``error_final``, ``error_l2`` and ``seconds``, one per (method, system,
    tolerance), as :func:`phasemap.motion.workprecision.work_precision` returns them.
    One panel per system (in order of appearance, lettered and named), one
    line per method (the same look in every panel, :data:`METHOD_LOOKS`: a
    phasemap method beside its SciPy counterpart; named as in
    :data:`METHOD_NAMES`), points joined in order of tolerance.  When the rows
    carry ``seconds_min`` and ``seconds_max`` (the fastest and slowest of the
    timing rounds), each point sits at the fastest, which timing noise can
    only delay, and a bar reaches to the slowest.  ``error`` picks
    ``error_final`` (max norm of the state error at the final time),
    ``error_l2``, or their dimensionless forms ``error_scaled_final`` and
    ``error_scaled_l2`` (each component divided by its scale, the largest
    magnitude it reaches along the reference motion; see
    :mod:`phasemap.motion.workprecision`).  ``ylabel`` names the error with its
    definition and unit (default: ``ERROR_LABELS``) and ``key`` defines
    the symbols it uses (default: :math:`y`); for a scaled error the key
    always ends with the definition of the scales and each panel's values
    (``scales_key``).  Points whose error or time is not
    positive and finite cannot be drawn on log axes and are left out.
    """
    if error not in ERROR_LABELS:
        raise ValueError(f"error must be one of {', '.join(map(repr, ERROR_LABELS))}, "
                         f"got {error!r}")
    rows = list(table)
    if not rows:
        raise ValueError("work_precision_figure: the table is empty")
    for i, row in enumerate(rows):
        missing = [k for k in (*_WP_KEYS, error) if k not in row]
        if missing:
            raise ValueError(f"work_precision_figure: row {i} lacks {', '.join(missing)}")
    systems = list(dict.fromkeys(str(r["system"]) for r in rows))
    methods = list(dict.fromkeys(str(r["method"]) for r in rows))
    spread = all("seconds_min" in r and "seconds_max" in r for r in rows)
    rounds = max((int(r.get("n_samples", 0)) for r in rows), default=0)
    width = width_of(size)
    # three panels a row at two-column width, two at one column: narrower, the axis
    # labels and headings of neighbouring panels collide; one or two systems at one
    # column are stacked, each panel the full width (side by side they are too small
    # for their key)
    ncols = min(len(systems), 3 if width >= WIDE else 1 if len(systems) <= 2 else 2)
    nrows = -(-len(systems) // ncols)
    stacked = ax is None and ncols == 1 and nrows > 1
    panel_h = (width / ncols) * (0.8 if width >= 5 else 0.55 if ncols == 1 else 0.85)
    names = [METHOD_NAMES.get(m, m) for m in methods]
    long_x = ax is not None or width / ncols >= 2.2  # room for "Run time per trajectory (s)"
    # the key goes in a free panel slot when it fits there, else above the panels
    spare = (ax is None and nrows * ncols > len(systems)
             and _legend_fits(names, width / ncols, panel_h))
    top = 0.0 if spare or ax is not None else _legend_height(names, 0.95 * width)
    if ylabel is None:
        ylabel = ERROR_LABELS[error]
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
                look = _method_look(method, j)
                colour = look["color"]
                (line,) = a.plot(secs, errs, label=METHOD_NAMES.get(method, method), zorder=3,
                                 **look)
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
            if ax is not None or (i % ncols == 0 and not stacked):
                a.set_ylabel(ylabel)
            if ax is not None or i + ncols >= len(systems):
                # a narrow panel has no room for the long label: the key says "per trajectory"
                a.set_xlabel("Run time per trajectory (s)" if long_x else "Run time (s)")
        if len(axes) > 1:
            label_panels(axes)
        fig = axes[0].get_figure(root=False)
        if stacked:  # one label for the column: per panel it is longer than a panel
            fig.supylabel(ylabel, fontsize=_FONT)
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
            legend_above(axes[0], lines)
        if ax is None:
            key = list(key) if key is not None else [
                r"$y$: the state (rad, rad s$^{-1}$, m, m s$^{-1}$)"]
            if error.startswith("error_scaled"):  # what the label divides by, stated
                key += [r"$\hat y_i$: the largest $|y_i|$ along the reference motion",
                        *scales_key(rows)]
            if not long_x:
                key.append("run time: per trajectory")
            if spread:
                loads = [float(r["load"]) for r in rows
                         if math.isfinite(float(r.get("load", math.nan)))]
                cores = max((int(r.get("cores", 0)) for r in rows), default=0)
                load = (f" (load average {max(loads):.1f}" +
                        (f" on {cores} cores" if cores else "") +
                        " as the rounds ended, this run included)") if loads else ""
                key.append((f"points: the fastest of {rounds} timing rounds, bars: the slowest"
                            if rounds > 1 else "one timing round") + load)
            define_symbols(fig, key)
    return axes[0].figure


