"""``phasemap plot FILE.nc [-o STEM] [--size one|two]``: the figure of any file phasemap wrote.

The command line's ``plot`` subcommand calls :func:`plot_file`, which opens
an atlas, a fate map, a trajectory, a phase curve, or the boundaries or threshold
curve of the bifurcation set, draws the figure the
accessor draws (``ds.phasemap.plot()``) and writes it as PDF and PNG.  An atlas of
three dimensions is drawn as one map per value of its shortest axis (up to
:data:`MAX_PANELS`), side by side, as the studies draw the ladder at three
angular velocities.

>>> import numpy as np, phasemap, tempfile, pathlib
>>> from phasemap.plot.command import plot_file
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 20),
...                                     "f": np.linspace(0, 1, 10)}, fixed={"omega": 0.0})
>>> path = phasemap.write_atlas(ds.compute(), folder / "ladder.nc")
>>> [p.name for p in plot_file(path)]
['ladder.pdf', 'ladder.png']
"""

from __future__ import annotations

import os
import pathlib

import xarray as xr
from matplotlib.figure import Figure

from phasemap.atlas.dataset import curve_kind, dataset_kind, first_layer, motion_kind
from phasemap.plot.labels import _value_text, fixed_values_text
from phasemap.plot.layout import WIDE, figure_legend, label_panels, outer_labels, panels, save_figure, \
    width_of
from phasemap.plot.maps import fate_figure, map_figure
from phasemap.plot.style import style

__all__ = ["MAX_PANELS", "SIZES", "figure_of", "plot_file"]

#: ``--size`` choices: a journal's one column (3.5 in) or two columns (7.2 in).
SIZES = {"one": "one_column", "two": "two_column"}
#: The most maps a three-dimensional atlas is drawn as (one per value of its shortest axis).
MAX_PANELS = 6
#: The most values of a map's axis that a figure draws (a figure is a few million pixels):
#: a longer axis of an atlas file is read at every k-th value, and the figure says so.
MAX_DRAWN = 2048


def plot_file(path: str | os.PathLike, stem: str | os.PathLike | None = None,
              size: str = "one") -> tuple[pathlib.Path, pathlib.Path]:
    """Draw the file at ``path`` and write ``<stem>.pdf`` and ``<stem>.png`` (300 dpi).

    ``stem`` defaults to ``path`` without its suffix; ``size`` is ``"one"``
    (3.5 in) or ``"two"`` (7.2 in).  Returns the two paths, PDF first.

    Raises
    ------
    ValueError
        with one line if the file is missing, not netCDF or not phasemap's, if
        ``size`` is unknown, or if the atlas has no single figure (four or more
        dimensions, or a third axis longer than :data:`MAX_PANELS`).
    """
    import matplotlib.pyplot as plt

    from phasemap.atlas.read import open_atlas

    if size not in SIZES:
        raise ValueError(f"size must be one of {', '.join(SIZES)}, got {size!r}")
    path = pathlib.Path(os.path.expanduser(os.fspath(path)))
    stem = path.with_suffix("") if stem is None else stem
    with open_atlas(path) as ds:
        ds, note = reduced(ds)
        ds = ds.load()  # only what is drawn is read: memory stays bounded
    try:
        fig = figure_of(ds, SIZES[size])
    except (ValueError, TypeError) as e:  # what is wrong with the file, and which file
        raise type(e)(f"{path}: {e}") from None
    if note:
        fig.text(0.005, 0.003, note, fontsize=5, color="0.35", ha="left", va="bottom")
    try:
        return save_figure(fig, stem)
    finally:
        plt.close(fig)


def reduced(ds: xr.Dataset) -> tuple[xr.Dataset, str]:
    """``ds`` (a map or fate map, read lazily) at every k-th value of each axis longer than
    :data:`MAX_DRAWN`, and the note that says so ("" when nothing is left out).  Classes
    are categories: they are sampled, never averaged.  Motions are drawn whole."""
    if motion_kind(ds) is not None or curve_kind(ds) is not None:
        return ds, ""
    step = {d: -(-n // MAX_DRAWN) for d, n in ds.sizes.items() if n > MAX_DRAWN}
    if not step:
        return ds, ""
    note = "drawn from " + ", ".join(f"1 in {k} values of {d} ({ds.sizes[d]} in the file)"
                                     for d, k in step.items())
    return ds.isel({d: slice(None, None, k) for d, k in step.items()}), note


def figure_of(ds: xr.Dataset, size: str | float = "one_column") -> Figure:
    """The figure of ``ds`` at ``size``: the accessor's, or for a three-dimensional atlas
    one map per value of its shortest axis."""
    if motion_kind(ds) is not None or curve_kind(ds) is not None or first_layer(ds).ndim < 3:
        return ds.phasemap.plot(size=size)
    var = first_layer(ds)
    if var.ndim > 3:
        dataset_kind(ds)  # its message: select a slice first
    along = min(var.dims, key=lambda d: ds.sizes[d])
    n = ds.sizes[along]
    if n > MAX_PANELS:
        raise ValueError(f"a 3-D atlas ({', '.join(map(str, var.dims))}) is drawn as one map "
                         f"per value of its shortest axis, but {along!r} has {n} values "
                         f"(at most {MAX_PANELS}); select a slice first, e.g. "
                         f"ds.isel({along}=0)")
    layer = "fate" if "fate" in ds.data_vars else None
    width = width_of(size)
    with style():
        fig, axes = panels(n, size, height=3.0 if width >= WIDE else 0.0, panel_height=2.2,
                           extra=1.4, sharex=True, sharey=True)
        handles: dict[str, object] = {}
        for i, ax in enumerate(axes):
            part = ds.isel({along: i})
            if layer == "fate":
                fate_figure(part, extra=[], ax=ax)
            else:
                map_figure(part, layer, ax=ax)
            legend = ax.get_legend()
            if legend is not None:
                for h, t in zip(legend.legend_handles, legend.get_texts()):
                    handles.setdefault(t.get_text(), h)
                legend.remove()
            value = float(ds[along].values[i]) if along in ds.coords else float(i)
            ax.set_title(_value_text(ds, str(along), value), loc="left")
        outer_labels(axes)
        label_panels(axes)
        figure_legend(fig, list(handles.values()), list(handles),
                      title=fixed_values_text(ds, 0.95 * width) or None)
    return fig
