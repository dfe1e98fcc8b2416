"""What every study script in ``studies/`` shares: arguments, outputs, the claims table.

A study composes the library into files (atlases, figures) and ends by
printing the claims it checked, the measured value beside the paper's.  This
module only defines; the scripts in ``studies/`` produce (DrWatson's rule).

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
from dataclasses import dataclass
from typing import Sequence

import xarray as xr

from ._version import __version__

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


def claims_table(claims: Sequence[Claim]) -> str:
    """The claims as an aligned plain-text table."""
    rows = [("claim", "paper", "measured", "verdict")]
    rows += [(c.claim, c.paper, c.measured, c.verdict) for c in claims]
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    lines = ["  ".join(x.ljust(w) for x, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def arguments(doc: str, argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Parse a study's ``[--quick] [--out DIR]``; the output folder is created."""
    ap = argparse.ArgumentParser(description=doc.strip().split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse grids, seconds not minutes")
    ap.add_argument("--out", default="phasemap-out", help="folder for atlases and figures "
                    "(default %(default)s)")
    args = ap.parse_args(argv)
    args.out = pathlib.Path(args.out)
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def save_atlas(ds: xr.Dataset, out: pathlib.Path, name: str, study: str) -> pathlib.Path:
    """Write ``ds`` as ``out/name.nc``, stamped with the study that made it."""
    from .atlas import write_atlas

    ds = ds.assign_attrs(phasemap_study=study, phasemap_version=__version__)
    return write_atlas(ds, out / f"{name}.nc")


def save_figure(fig, out: pathlib.Path, name: str) -> list[pathlib.Path]:
    """Write ``fig`` as ``out/name.pdf`` (vector) and ``.png``, then close it."""
    import matplotlib.pyplot as plt

    from .plot import save_figure as _save

    paths = list(_save(fig, out / name))
    plt.close(fig)
    return paths


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
