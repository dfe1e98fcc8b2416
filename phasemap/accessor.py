"""The ``ds.phasemap`` accessor: what an atlas is, its model, and its figure.

Importing this module (``import phasemap`` does it) registers the accessor on every
:class:`xarray.Dataset` as soon as xarray is imported, by phasemap's first Dataset or by
the user's own ``import xarray`` (:mod:`phasemap.core.lazy`: ``import phasemap`` does
not import xarray itself).  phasemap never subclasses ``Dataset``:

>>> import numpy as np, phasemap, phasemap.accessor
>>> ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 30)},
...                     fixed={"omega": 0.0}).compute()
>>> ds.phasemap.kind, ds.phasemap.model.name
('profile', 'ladder')
>>> fig = ds.phasemap.plot()                 # a matplotlib Figure

The figures, their style and how a kind is recognised are described in
:mod:`phasemap.plot`, which is imported (with matplotlib) on first use, so
registering the accessor costs nothing.
"""

from __future__ import annotations

import os
import pathlib
from typing import TYPE_CHECKING, Sequence

from phasemap.atlas.dataset import dataset_kind, recorded_model
from phasemap.core.lazy import when_imported
from phasemap.core.model import Model

if TYPE_CHECKING:
    from xarray import Dataset
    from matplotlib.figure import Figure

__all__ = ["PhasemapAccessor"]


class PhasemapAccessor:
    """``ds.phasemap``: the atlas's kind, its model, and the figure that suits it."""

    def __init__(self, ds: Dataset):
        self._ds = ds

    @property
    def kind(self) -> str:
        """``"map"``, ``"profile"``, ``"fate"``, ``"phase_curve"`` or ``"trajectory"``.

        See :func:`phasemap.atlas.dataset.dataset_kind` (no matplotlib needed);
        ValueError for a Dataset that is not a phasemap atlas.
        """
        return dataset_kind(self._ds)

    @property
    def model(self) -> Model:
        """The built-in :class:`phasemap.Model` named by the ``phasemap_model`` global attribute.

        A Dataset is data: the name is looked up among the built-in models and
        nothing it names is loaded (see :func:`phasemap.atlas.dataset.recorded_model`).
        Raises ValueError if there is no such attribute, it names no built-in
        model, or the built-in model was declared otherwise than the Dataset records.
        """
        return recorded_model(self._ds)

    def plot(self, layer: str | Sequence[str] | None = None, ax=None,
             size: str | float = "one_column", **kw) -> Figure:
        """Draw the figure that suits this dataset's kind and return the Figure.

        ``layer``, ``ax`` (an Axes, or a list for several panels), ``size``
        (``"one_column"``, ``"two_column"`` or a width in inches) and other
        keywords are those of :func:`phasemap.plot.plot`.
        """
        from phasemap.plot import plot

        return plot(self._ds, layer, ax=ax, size=size, **kw)

    def strip(self, times: Sequence[float] | None = None, ax=None, *, forces: bool = True,
              size: str | float = "one_column") -> Figure:
        """A motion in full coordinates as a strip of the body's outlines at ``times``, its
        contact forces and impulses marked (:func:`phasemap.plot.motion.outline_figure`).

        >>> import phasemap
        >>> ds = phasemap.simulate("ladder", t_end=1.0, phi=0.5, omega=0.0, f=0.0)
        >>> fig = ds.phasemap.strip()                # the ladder leaves the wall, falls flat
        >>> len(fig.axes)                            # the strip and its time scale
        2
        """
        from phasemap.plot.motion import outline_figure

        return outline_figure(self._ds, times=times, ax=ax, forces=forces, size=size)

    def savefig(self, path_stem: str | os.PathLike, layer: str | Sequence[str] | None = None,
                *, dpi: int = 300, **kw) -> tuple[pathlib.Path, pathlib.Path]:
        """Draw :meth:`plot` and write it as ``<stem>.pdf`` and ``<stem>.png``; return both paths.

        The figure is closed afterwards.  Keywords other than ``dpi`` go to :meth:`plot`.
        """
        import matplotlib.pyplot as plt

        from phasemap.plot import save_figure

        fig = self.plot(layer, **kw)
        try:
            return save_figure(fig, path_stem, dpi=dpi)
        finally:
            plt.close(fig)


def _register(xarray) -> None:
    xarray.register_dataset_accessor("phasemap")(PhasemapAccessor)


# registered the moment xarray is imported, by phasemap or by anyone: import phasemap does
# not import xarray itself (phasemap.core.lazy)
when_imported("xarray", _register)
