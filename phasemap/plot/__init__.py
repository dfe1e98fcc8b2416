r"""Figures in one publication style: atlas maps, profiles, fate maps, phase curves,
trajectories and work-precision diagrams.

Every figure function draws inside :func:`style`, an rc context (the global
``matplotlib.rcParams`` are never changed), and returns the
:class:`matplotlib.figure.Figure`.  Given ``ax=`` (an Axes, or a list of Axes
for a figure of several panels) it draws there instead and returns that
Axes' figure.  :func:`plot` (and the accessor ``ds.phasemap.plot()``, see
:mod:`phasemap.accessor`) picks the right function from the data:

===============  ===========================================  ============================
kind             how it is recognised                         figure
===============  ===========================================  ============================
``map``          a 2-D atlas from ``Scene.compute()``         :func:`map_figure`
``profile``      a 1-D atlas                                  :func:`profile_figure`
``fate``         a ``fate`` layer                             :func:`fate_figure`
``phase_curve``  global attribute ``phasemap_kind``           :func:`phase_curve_figure`
``trajectory``   global attribute ``phasemap_kind``           :func:`trajectory_figure`
``boundaries``   global attribute ``phasemap_kind``           :func:`curves_figure`
``threshold``    global attribute ``phasemap_kind``           :func:`curves_figure`
===============  ===========================================  ============================

Periodic orbits, their branches and orbit diagrams (``phasemap_kind`` ``periodic_orbit``,
``orbit_branch``, ``orbit_diagram``) are drawn by :mod:`phasemap.plot.orbits`.

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
The package has one room per concern, as xarray's ``plot/`` has:

==================  ==========================================================
:mod:`.style`       the rc parameters and one look per meaning (colours,
                    hatches, markers)
:mod:`.labels`      axis labels, units and fixed values, from the Dataset
:mod:`.layout`      widths, panels, legends above, panel letters, keys, saving
:mod:`.maps`        maps, profiles and fate maps of an atlas
:mod:`.motion`      phase curves and trajectories
:mod:`.benchmark`   the work-precision figure
:mod:`.command`     ``phasemap plot FILE.nc``: the figure of any file
==================  ==========================================================

What a Dataset is (its kind) is decided in :mod:`phasemap.atlas.dataset`, without
matplotlib.  A new kind of figure needs: a ``<kind>_figure(ds, ..., ax=None,
size=...)`` function that opens ``with style():``, gets its axes from
:func:`.layout._axes` and its labels from :func:`axis_label`, takes category
colours from :func:`category_colour` and puts legends above with
:func:`.layout.legend_above`; a rule in
:func:`phasemap.atlas.dataset.dataset_kind`; and a line in :func:`plot`.
"""

from __future__ import annotations

from typing import Sequence

import xarray as xr
from matplotlib.figure import Figure

from phasemap.atlas.dataset import KINDS, dataset_kind as atlas_kind
from phasemap.core.args import describe as _describe
from phasemap.plot.benchmark import METHOD_NAMES, SYSTEM_NAMES, work_precision_figure
from phasemap.plot.curves import curves_figure
from phasemap.plot.labels import (axis_label, fixed_values, fixed_values_text, format_number, format_units,
                     wrap)
from phasemap.plot.layout import (WIDE, angle_ticks, define_symbols, figure_legend, figure_texts, label_panels,
                     legend_above, legend_columns, outer_labels, panels, save_figure, width_of)
from phasemap.plot.layout import _panel_width  # noqa: F401  (the tests measure a panel with it)
from phasemap.plot.maps import (draw_boundaries, fate_figure, fate_grid_note, map_figure,
                   mark_inverted_rests, profile_figure)
from phasemap.plot.motion import event_handle, mark_event, phase_curve_figure, trajectory_figure
from phasemap.plot.style import (CATEGORY_COLOURS, CATEGORY_HATCHES, CYCLE, DARK_GREY, DASHES,
                    EVENT_MARKERS, GREY, HALO, MARKERS, OKABE_ITO, OVERLAYS, PALE_GREEN, PALE_GREY, SIZES,
                    STYLE, SUNSET,
                    category_colour, category_hatch, overlay_patch, stagnation_patch,
                    stagnation_span, style)

__all__ = [
    "CATEGORY_COLOURS",
    "CATEGORY_HATCHES",
    "CYCLE",
    "DARK_GREY",
    "DASHES",
    "EVENT_MARKERS",
    "GREY",
    "HALO",
    "KINDS",
    "MARKERS",
    "METHOD_NAMES",
    "OKABE_ITO",
    "OVERLAYS",
    "PALE_GREEN",
    "PALE_GREY",
    "SIZES",
    "STYLE",
    "SUNSET",
    "SYSTEM_NAMES",
    "WIDE",
    "angle_ticks",
    "atlas_kind",
    "axis_label",
    "category_colour",
    "category_hatch",
    "curves_figure",
    "define_symbols",
    "draw_boundaries",
    "event_handle",
    "fate_figure",
    "fate_grid_note",
    "figure_legend",
    "figure_texts",
    "fixed_values",
    "fixed_values_text",
    "format_number",
    "format_units",
    "label_panels",
    "legend_above",
    "legend_columns",
    "map_figure",
    "mark_event",
    "mark_inverted_rests",
    "outer_labels",
    "overlay_patch",
    "panels",
    "phase_curve_figure",
    "plot",
    "profile_figure",
    "save_figure",
    "stagnation_patch",
    "stagnation_span",
    "style",
    "trajectory_figure",
    "width_of",
    "work_precision_figure",
    "wrap",
]


def plot(ds: xr.Dataset, layer: str | Sequence[str] | None = None, *, ax=None,
         size: str | float = "one_column", **kw) -> Figure:
    """The right figure for ``ds`` (see :func:`atlas_kind`); returns the Figure.

    ``layer`` picks what is drawn: for a map, the layer (default
    ``n_solutions``); for a profile, one layer or a list (default: every
    categorical layer); for a fate dataset, ``fate`` (the default) draws
    :func:`fate_figure`, any other layer a plain :func:`map_figure` (a
    1-D fate dataset is drawn as a profile); for a trajectory, the states
    to draw; for a periodic orbit, the two variables of its plane; for an orbit branch,
    the quantity drawn against the parameter; for an orbit diagram, the variable (its
    continued ``branches=`` overlaid).  Phase curves take no layer.  Other
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
            raise ValueError(f"a phase curve has no layers to choose; got layer={_describe(layer)}")
        return phase_curve_figure(ds, ax=ax, size=size, **kw)
    if kind in ("boundaries", "threshold"):
        if layer is not None:
            raise ValueError(f"a {kind} file has no layers to choose; got layer={_describe(layer)}")
        return curves_figure(ds, ax=ax, size=size, **kw)
    if kind == "periodic_orbit":        # layer: the plane's two variables, or none
        from phasemap.plot.orbits import orbit_figure

        x, y = (None, None) if layer is None else tuple(layer)
        return orbit_figure(ds, x, y, ax=ax, size=size, **kw)
    if kind == "orbit_branch":          # layer: the quantity drawn against the parameter
        from phasemap.plot.orbits import branch_figure

        return branch_figure(ds, layer, ax=ax, size=size, **kw)
    if kind == "orbit_diagram":         # layer: the variable drawn against the parameter
        from phasemap.plot.orbits import diagram_figure

        if isinstance(layer, str) and layer in ds.data_vars and "cycle" not in ds[layer].dims:
            # a scene's other layers over its axis (its fate, its period)
            return profile_figure(ds, layer, ax=ax, size=size, **kw)

        return diagram_figure(ds, layer, ax=ax, size=size, **kw)
    return trajectory_figure(ds, states=layer, ax=ax, size=size, **kw)
