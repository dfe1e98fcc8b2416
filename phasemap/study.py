"""What every study script in ``studies/`` shares: arguments, outputs, the claims table.

A study composes the library into files (atlases, figures) and ends by
printing the claims it checked, the measured value beside the paper's.  This
module only defines; the scripts in ``studies/`` produce (DrWatson's rule).

``python studies/NAME.py [--quick] [--out DIR] [--size WIDTH]`` (:func:`arguments`)
writes the atlases and figures ``NAME_*`` into ``DIR`` and ends with the
claims table (:func:`finish`).

>>> from phasemap.study import Claim, claims_table
>>> print(claims_table([Claim("rest zone of the hinge pendulum", "|tan phi| <= 0.1005",
...                           "|tan phi| <= 0.1005", "agrees")]))
claim                            paper                measured             verdict
-------------------------------  -------------------  -------------------  -------
rest zone of the hinge pendulum  |tan phi| <= 0.1005  |tan phi| <= 0.1005  agrees
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import sys
import textwrap
from dataclasses import dataclass
from typing import Callable, Sequence

import xarray as xr

from phasemap._version import __version__

#: Verdicts a claim can get.  ``agrees``: the paper's statement holds as
#: printed.  ``erratum``: the paper's formula is wrong and the measured value
#: confirms the correction.  ``sharper``: the paper's statement holds, and the
#: measured one is sharp where the paper's was only sufficient (a finding).
#: ``finding``: beyond the paper.  ``DISAGREES``: the check failed.
VERDICTS = ("agrees", "erratum", "sharper", "finding", "DISAGREES")


@dataclass(frozen=True)
class Claim:
    """One checked statement: what the paper says, what was measured, the verdict."""

    claim: str
    paper: str
    measured: str
    verdict: str

    def __post_init__(self):
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict must be one of {VERDICTS}, got {self.verdict!r}")


def verdict(ok: bool, yes: str = "agrees") -> str:
    """``yes`` when ``ok``, else ``DISAGREES``."""
    return yes if ok else "DISAGREES"


def _to_terminal() -> bool:
    try:
        return sys.stdout.isatty()
    except (AttributeError, ValueError):  # replaced or closed stdout
        return False


def claims_table(claims: Sequence[Claim], width: int | None = None) -> str:
    """The claims as an aligned plain-text table, at most ``width`` columns wide.

    ``width`` defaults to the terminal's when standard output is one
    (``COLUMNS`` or the terminal size), and is unlimited when the output goes
    to a file, a pipe or a capture (one line per claim, for tools that read
    it).  The claim, paper and measured columns are wrapped, each to a share
    of the room its text needs.
    """
    rows = [("claim", "paper", "measured", "verdict")]
    rows += [(c.claim, c.paper, c.measured, c.verdict) for c in claims]
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    if width is None:
        width = shutil.get_terminal_size((0, 0)).columns if _to_terminal() else 0
    room = width - widths[3] - 6  # verdicts stay whole; three 2-space gaps
    if width > 0 and sum(widths[:3]) > room:
        widths[:3] = _shares(widths[:3], max(room, 3 * 12))
    lines = []
    for r in rows:
        cells = [textwrap.wrap(x, w, break_on_hyphens=False) or [""] if i < 3 else [x]
                 for i, (x, w) in enumerate(zip(r, widths))]
        for k in range(max(len(c) for c in cells)):
            parts = [(c[k] if k < len(c) else "").ljust(w) for c, w in zip(cells, widths)]
            lines.append("  ".join(parts).rstrip())
        if r is rows[0]:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _shares(natural: list[int], room: int) -> list[int]:
    """Split ``room`` columns: a column that needs less than an even share keeps its
    width, the rest share what is left evenly."""
    out = list(natural)
    free = list(range(len(natural)))
    while free:
        share = room // len(free)
        small = [i for i in free if natural[i] <= share]
        if not small:
            for i in free:
                out[i] = max(8, share)
            break
        for i in small:
            room -= natural[i]
            free.remove(i)
    return out


#: The figure widths a study can lay its figures out for (``--size``), by choice.
SIZE_CHOICES = {"two_column": ("two_column",), "one_column": ("one_column",),
                "both": ("two_column", "one_column")}


def arguments(doc: str, argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Parse a study's ``[--quick] [--out DIR] [--size WIDTH]``; the output folder is created.

    ``args.sizes`` is the tuple of widths to draw every figure at (see
    :func:`save_figures`).
    """
    ap = argparse.ArgumentParser(description=doc.strip().split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse grids, seconds not minutes")
    ap.add_argument("--out", default="phasemap-out", help="folder for atlases and figures "
                    "(default %(default)s)")
    ap.add_argument("--size", choices=list(SIZE_CHOICES), default="two_column",
                    help="figure width: a journal's two columns (7.2 in), one column (3.5 in) "
                    "or both (default %(default)s)")
    args = ap.parse_args(argv)
    args.out = pathlib.Path(args.out)
    args.out.mkdir(parents=True, exist_ok=True)
    args.sizes = SIZE_CHOICES[args.size]
    return args


def mesh(ds: xr.Dataset, x: str, y: str) -> tuple:
    """The coordinates ``x`` and ``y`` of an atlas as a column and a row, to broadcast
    against its ``(x, y)`` layers.

    >>> ds = xr.Dataset(coords={"phi": [0.0, 1.0], "f": [0.1, 0.2, 0.3]})
    >>> [a.shape for a in mesh(ds, "phi", "f")]
    [(2, 1), (1, 3)]
    """
    return ds[x].values[:, None], ds[y].values[None, :]


def save_atlas(ds: xr.Dataset, out: pathlib.Path, name: str, study: str) -> pathlib.Path:
    """Write ``ds`` as ``out/name.nc``, stamped with the study that made it."""
    from phasemap.atlas.write import write_atlas

    ds = ds.assign_attrs(phasemap_study=study, phasemap_version=__version__)
    return write_atlas(ds, out / f"{name}.nc")


def save_figure(fig, out: pathlib.Path, name: str) -> list[pathlib.Path]:
    """Write ``fig`` as ``out/name.pdf`` (vector) and ``.png``, then close it."""
    import matplotlib.pyplot as plt

    from phasemap.plot import save_figure as _save

    paths = list(_save(fig, out / name))
    plt.close(fig)
    return paths


def figure_name(name: str, size: str) -> str:
    """The file stem of figure ``name`` at ``size``: ``name`` at two-column width, else
    ``name_one_column``, so that both layouts can sit in one folder."""
    return name if size == "two_column" else f"{name}_{size}"


def save_figures(draw: Callable[[str], object], out: pathlib.Path, name: str,
                 sizes: Sequence[str] = ("two_column",)) -> list[pathlib.Path]:
    """Draw ``draw(size)`` at each of ``sizes`` and save it (:func:`save_figure`) under
    :func:`figure_name`; the files written."""
    files: list[pathlib.Path] = []
    for size in sizes:
        files += save_figure(draw(size), out, figure_name(name, size))
    return files


def collect_legend(ax, handles: dict) -> None:
    """Move the legend a figure function put above ``ax`` into ``handles`` (by label),
    so that a figure of several panels can show one legend for all."""
    legend = ax.get_legend()
    if legend is None:
        return
    for h, t in zip(legend.legend_handles, legend.get_texts()):
        handles.setdefault(t.get_text(), h)
    legend.remove()


def finish(title: str, claims: Sequence[Claim], files: Sequence[pathlib.Path]) -> None:
    """Print the files written and the claims table."""
    print(f"{title}: wrote {len(files)} files")
    for f in files:
        print(f"  {f}")
    print(claims_table(claims))
