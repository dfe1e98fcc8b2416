"""The layout kit: widths, panels, legends above, panel letters, keys, and saving.

Figure functions and the studies build their figures from these pieces, so
that every figure of a paper has its legends above the panels, its letters
at the top left of each panel and its symbols defined in a key below.
"""

from __future__ import annotations

import math
import os
import pathlib
from typing import Sequence

import matplotlib as mpl
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, MultipleLocator
from matplotlib.transforms import offset_copy

from phasemap.core.args import describe

from phasemap._version import __version__
from phasemap.atlas.atomic import destination, no_partial_file
from phasemap.plot.labels import _units, _visible_length, axis_label, wrap
from phasemap.plot.style import _FONT, SIZES, TITLE_PAD, style

def _annotate(axes: Sequence[Axes], text: str, own_figure: bool) -> None:
    """Put ``text`` (what was held fixed) above the figure.

    On a figure of one panel, and wherever the caller gave the axes, it is
    the title of the legend above the first panel (or that panel's title
    when it has no legend), left-aligned; on a figure of several panels that
    this module made (or one whose panel has a title already), a left-aligned
    figure title.
    """
    if not text:
        return
    if own_figure and (len(axes) > 1 or axes[0].get_title(loc="left")):
        axes[0].get_figure(root=False).suptitle(text, x=0.01, ha="left",
                                                fontsize=_FONT, linespacing=1.3)
        return
    legend = axes[0].get_legend()
    if legend is not None and getattr(legend, "_phasemap_above", False):
        legend.set_title(text)
        legend.get_title().set_fontsize(_FONT)
        return
    _title(axes[0], text)


def _title(ax: Axes, text: str, prepend: bool = False) -> None:
    """Set (or with ``prepend``, prefix) the panel's heading: its left-aligned title.

    The heading sits :data:`TITLE_PAD` above the panel, and a legend above the
    panel (:func:`legend_above`) moves up to clear it.
    """
    old = ax.get_title(loc="left")
    ax.set_title(f"{text} {old}".rstrip() if prepend else text, loc="left")
    _clear_heading(ax)


def label_panels(axes: Sequence[Axes], start: int = 0) -> None:
    """Letter the panels (a), (b), ... at the start of each one's heading.

    The letter opens the panel's left-aligned title, so that every letter
    sits at one offset from the top left corner of its own panel, in every
    figure, whatever legend stands above the panel (it stands above the
    letter).
    """
    for i, ax in enumerate(axes):
        _title(ax, f"({chr(ord('a') + start + i)})", prepend=True)


def figure_legend(fig: Figure, handles: Sequence, labels: Sequence[str] | None = None, *,
                  title: str | None = None, ncols: int | None = None):
    """One legend above all panels of ``fig``, headed by ``title`` (what was held fixed).

    The heading is the legend's own title, left-aligned, so that it never
    overlaps the entries (a figure title and an ``outside`` legend would).
    ``ncols`` defaults to as many columns as fit the figure's width.
    """
    handles = list(handles)
    labels = [h.get_label() for h in handles] if labels is None else list(labels)
    if ncols is None:
        ncols = legend_columns(labels, fig.get_figwidth() * 0.95)
    legend = fig.legend(handles, labels, loc="outside upper center", ncols=ncols,
                        title=title or None, alignment="left")
    legend.get_title().set_fontsize(_FONT)
    return legend


def figure_texts(fig: Figure) -> list[str]:
    """Every heading of ``fig``: figure titles, axes titles, legend titles and labels.

    For tests and reviews: what a reader sees written on the figure apart
    from tick labels.
    """
    out = []
    for f in [fig, *fig.subfigs]:
        if getattr(f, "_suptitle", None) is not None:
            out.append(f._suptitle.get_text())
        if getattr(f, "_supxlabel", None) is not None:
            out.append(f._supxlabel.get_text())
        for leg in f.legends:
            out.append(leg.get_title().get_text())
            out += [t.get_text() for t in leg.get_texts()]
    for ax in fig.get_axes():
        out += [ax.get_title(loc=loc) for loc in ("left", "center", "right")]
        out += [ax.get_xlabel(), ax.get_ylabel()]
        out += [t.get_text() for t in ax.texts]
        leg = ax.get_legend()
        if leg is not None:
            out.append(leg.get_title().get_text())
            out += [t.get_text() for t in leg.get_texts()]
    return [t for t in out if t]


def define_symbols(fig: Figure, definitions: Sequence[str], width: float | None = None) -> None:
    r"""A key below the panels that defines the symbols a legend or title uses.

    ``definitions`` such as ``r"$\lambda_k = 1 + \sin^2\varphi - kf\sin\varphi\cos\varphi$"``
    are joined with semicolons, wrapped to the figure width, and set
    left-aligned as the figure's bottom label (constrained layout makes room).
    """
    width = width or fig.get_figwidth() * 0.97
    fig.supxlabel(wrap(list(definitions), width, sep="; "), x=0.01, ha="left",
                  fontsize=_FONT, linespacing=1.3)


# --------------------------------------------------------------------------- figure plumbing


#: The widest figure, in inches (a poster's; at 300 dpi, 15 000 pixels).
MAX_WIDTH = 50.0


def width_of(size: str | float) -> float:
    """The width in inches of ``size``: ``"one_column"`` (3.5), ``"two_column"`` (7.2) or a
    positive number of inches; ValueError otherwise."""
    if isinstance(size, str):
        if size not in SIZES:
            raise ValueError(f"unknown size {size!r}; use one of {', '.join(SIZES)} "
                             "or a width in inches")
        return SIZES[size]
    try:
        if isinstance(size, (bool, bytes)):
            raise TypeError
        width = float(size)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"size must be one of {', '.join(SIZES)} or a width in inches, "
                         f"got {describe(size)}") from None
    if not math.isfinite(width) or not 0 < width <= MAX_WIDTH:
        raise ValueError(f"size must be a positive width in inches, at most {MAX_WIDTH:g}, "
                         f"got {describe(size)}")
    return width


def _axes(ax, n: int, figsize: tuple[float, float], what: str, **subplots) -> list[Axes]:
    """``n`` axes: new ones in a new figure, or the caller's ``ax`` (one Axes or a list)."""
    if ax is None:
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=figsize, layout="constrained")
        grid = subplots.pop("grid", (n, 1))
        axes = fig.subplots(*grid, squeeze=False, **subplots).ravel().tolist()
        return axes[:n]
    axes = [ax] if isinstance(ax, Axes) else list(ax)
    if len(axes) != n or not all(isinstance(a, Axes) for a in axes):
        raise ValueError(f"{what} draws {n} panel{'s' if n > 1 else ''}: pass "
                         f"{'one Axes' if n == 1 else f'a list of {n} Axes'} as ax, or ax=None")
    return axes


#: Widths (inches) from which panels stand side by side rather than stacked.
WIDE = 5.0


def panels(n: int, size: str | float = "two_column", *, height: float, panel_height: float,
           extra: float = 1.0, sharex: bool = False, sharey: bool = False,
           **subplots) -> tuple[Figure, list[Axes]]:
    """A new figure of ``n`` panels laid out for the width of ``size``.

    At two-column width (:data:`WIDE` inches or more) the panels stand side by
    side in one row, ``height`` inches high in all; narrower, they are stacked
    in one column, each ``panel_height`` inches high, plus ``extra`` inches
    for the legend above and the key below, so that no panel is squeezed to a
    third of a 3.5 in column.  ``sharex``/``sharey`` and other keywords go to
    ``Figure.subplots``; call :func:`outer_labels` once the panels are drawn.
    Draw inside :func:`style`.
    """
    import matplotlib.pyplot as plt

    width = width_of(size)
    wide = width >= WIDE
    rows, cols = (1, n) if wide else (n, 1)
    fig = plt.figure(figsize=(width, height if wide else extra + n * panel_height),
                     layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False, sharex=sharex, sharey=sharey,
                        **subplots).ravel().tolist()
    return fig, axes


def outer_labels(axes: Sequence[Axes]) -> None:
    """Label a shared axis only once: x on the bottom panels, y on the left ones.

    Where panels of a grid share an axis, the inner panels lose that axis's
    label and tick labels (their ticks stay); an axis that is not shared keeps
    its labels everywhere.
    """
    for ax in axes:
        spec = ax.get_subplotspec()
        if spec is None:
            continue
        if len(ax.get_shared_x_axes().get_siblings(ax)) > 1 and not spec.is_last_row():
            ax.set_xlabel("")
            ax.tick_params(axis="x", labelbottom=False)
        if len(ax.get_shared_y_axes().get_siblings(ax)) > 1 and not spec.is_first_col():
            ax.set_ylabel("")
            ax.tick_params(axis="y", labelleft=False)


def legend_columns(labels: Sequence[str], width: float) -> int:
    """How many legend columns of ``labels`` fit in ``width`` inches at the house font,
    rows balanced."""
    column = _legend_size(labels, 1)[0]
    ncols = max(1, min(len(labels), int(width // column)))
    rows = -(-len(labels) // ncols)
    return -(-len(labels) // rows)


def _legend_size(labels: Sequence[str], ncols: int) -> tuple[float, float]:
    """Roughly the (width, height) in inches of a frameless legend of ``labels`` in
    ``ncols`` columns at the house font (the estimate :func:`legend_columns` uses)."""
    em = _FONT / 72.0
    rc = mpl.rcParams
    column = (rc["legend.handlelength"] + rc["legend.handletextpad"] + rc["legend.columnspacing"]
              + 0.58 * max(_visible_length(s) for s in labels)) * em
    rows = -(-len(labels) // ncols)
    return ncols * column, rows * (1.0 + rc["legend.labelspacing"]) * em * 1.2


def _legend_fits(labels: Sequence[str], width: float, height: float) -> bool:
    """Whether a one-column legend of ``labels`` fits a ``width`` x ``height`` inch slot."""
    w, h = _legend_size(labels, 1)
    return w <= 0.95 * width and h <= 0.9 * height


def _legend_height(labels: Sequence[str], width: float) -> float:
    """The height (inches) a legend of ``labels`` above ``width`` inches of panels needs."""
    return 0.1 + _legend_size(labels, legend_columns(labels, width))[1]


def legend_above(ax: Axes, handles: Sequence, labels: Sequence[str] | None = None, *,
                 title: str | None = None, ncols: int | None = None):
    """A frameless legend above ``ax``, left-aligned with it, in as many columns as fit.

    ``title`` (what was held fixed) heads the legend, so that heading and
    entries never overlap; the panel's own heading (its letter) stays between
    the legend and the panel, at one offset from the panel.  ``ncols``
    defaults to as many columns as fit the panel's width.  With no handles the
    title becomes the panel's heading.  Any legend already on ``ax`` is
    replaced.
    """
    handles = list(handles)
    labels = [h.get_label() for h in handles] if labels is None else list(labels)
    if ax.get_legend() is not None:
        ax.get_legend().remove()
    if not handles:
        if title:
            _title(ax, title)
        return None
    if ncols is None:
        width = ax.get_figure(root=True).get_figwidth() * ax.get_position().width * 0.95
        ncols = legend_columns(labels, width)
    legend = ax.legend(handles, labels, loc="lower left", ncols=ncols, borderaxespad=0.0,
                       title=title, alignment="left")
    legend.get_title().set_fontsize(_FONT)
    legend._phasemap_above = True
    _clear_heading(ax)
    return legend



#: The height (points) of one line of a panel's heading: the house font with a sub- or
#: superscript.
_LINE = 1.45 * _FONT


def _clear_heading(ax: Axes) -> None:
    """Anchor the legend above ``ax`` (if any) just above the panel's heading."""
    legend = ax.get_legend()
    if legend is None or not getattr(legend, "_phasemap_above", False):
        return
    heading = ax.get_title(loc="left")
    lines = heading.count("\n") + 1 if heading else 0
    rise = TITLE_PAD + lines * _LINE if lines else 2.0
    fig = ax.get_figure(root=True)
    legend.set_bbox_to_anchor((0.0, 1.0), transform=offset_copy(ax.transAxes, fig=fig, x=0.0,
                                                                y=rise, units="points"))


def _pi_text(k: int, den: int = 4) -> str:
    """``k`` pi / ``den`` as mathtext, reduced: ``"0"``, ``"$\\pi/2$"``, ``"$-2\\pi$"``."""
    if k == 0:
        return "0"
    sign = "-" if k < 0 else ""
    k = abs(k)
    g = math.gcd(k, den)
    num, den = k // g, den // g
    head = r"\pi" if num == 1 else rf"{num}\pi"
    return f"${sign}{head}$" if den == 1 else f"${sign}{head}/{den}$"


def _angle_ticks(ax: Axes, axis: str, lo: float, hi: float) -> None:
    """Tick an angle axis in rad at multiples of pi/4, pi/2, pi, 2 pi... when it spans pi or
    more, with at most about eight ticks."""
    span = hi - lo
    if not (math.isfinite(span) and span >= math.pi * 0.99):
        return
    # quarter turns of pi at the finest; doubled until at most 8 ticks fit the span
    quarters = 1 if span < 1.5 * math.pi else 2 if span <= 4.5 * math.pi else 4
    while span / (quarters * math.pi / 4) > 8:
        quarters *= 2
    target = ax.xaxis if axis == "x" else ax.yaxis
    target.set_major_locator(MultipleLocator(quarters * math.pi / 4))
    target.set_major_formatter(FuncFormatter(lambda x, _pos: _pi_text(round(x / (math.pi / 4)))))


def angle_ticks(ax: Axes, axis: str = "x") -> None:
    """Tick an angle axis of ``ax`` at multiples of pi over its present limits (when they
    span pi or more), so that one quantity is ticked alike in every panel."""
    lo, hi = sorted(ax.get_xlim() if axis == "x" else ax.get_ylim())
    _angle_ticks(ax, axis, lo, hi)


def _label_axis(ax: Axes, ds: xr.Dataset, axis: str, name: str, values=None) -> None:
    (ax.set_xlabel if axis == "x" else ax.set_ylabel)(axis_label(ds, name))
    units = _units(ds, name)
    if units == "rad" and values is not None and np.size(values):
        finite = np.asarray(values, dtype=float)
        finite = finite[np.isfinite(finite)]
        if finite.size:
            _angle_ticks(ax, axis, float(finite.min()), float(finite.max()))


def _panel_width(ax: Axes) -> float:
    """The width of ``ax`` in inches (before layout: its share of the figure)."""
    return ax.get_figure(root=True).get_figwidth() * ax.get_position().width


# --------------------------------------------------------------------------- files


def save_figure(fig: Figure, stem: str | os.PathLike, *, dpi: int = 300
                ) -> tuple[pathlib.Path, pathlib.Path]:
    """Write ``fig`` as ``<stem>.pdf`` (vector, fonts embedded) and ``<stem>.png`` (``dpi``).

    A ``.pdf`` or ``.png`` suffix on ``stem`` is dropped.  Each file is
    written atomically (see :func:`phasemap.atlas.atomic.atomic_path`).  Returns the
    two paths, PDF first.

    Raises
    ------
    ValueError
        if the folder does not exist; as :class:`phasemap.atlas.atomic.WriteError` (one
        line) when writing fails, a full disk say, with no file left.
    """
    stem = pathlib.Path(os.path.expanduser(os.fspath(stem)))
    if stem.suffix.lower() in (".pdf", ".png"):
        stem = stem.with_suffix("")
    paths = []
    with style():
        for fmt in ("pdf", "png"):
            path = destination(stem.with_name(stem.name + "." + fmt))
            meta = ({"Creator": f"phasemap {__version__}"} if fmt == "pdf"
                    else {"Software": f"phasemap {__version__}"})
            with no_partial_file(path) as tmp:  # a full disk: one line, no file left
                fig.savefig(tmp, format=fmt, dpi=dpi, metadata=meta)
            paths.append(path)
    return paths[0], paths[1]

