"""The exact boundaries of a map's slice, for the map figure to draw over its cells.

:func:`phasemap.plot.map_figure` (and so ``ds.phasemap.plot(boundaries=True)``)
calls :func:`map_boundaries`: the atlas names its model, its two axes give the
slice's ranges, its ``phasemap_fixed_*`` attributes and scalar coordinates the
fixed values.
"""

from __future__ import annotations

import xarray as xr

from phasemap.bifurcation.tracing import LAYERS, boundaries


def map_boundaries(ds: xr.Dataset, layer: str, x: str, y: str, tol: float = 1e-10) -> xr.Dataset:
    """The exact class boundaries (:func:`phasemap.boundaries`) of the map of ``layer``
    over the axes ``x`` and ``y`` of the atlas ``ds``.

    A layer that does not fill regions (a float layer, ``fate``) is bounded by
    its ``n_solutions`` classes.

    Examples
    --------
    >>> import numpy as np, phasemap
    >>> ds = phasemap.Scene("painleve_rod", axes={"theta": np.linspace(0.2, 1.5, 64),
    ...                     "f": np.linspace(0, 3, 64)}, fixed={"xdot": -1.0, "omega": 0.0},
    ...                     layers=["n_solutions"]).compute()         # doctest: +SKIP
    >>> b = map_boundaries(ds, "n_solutions", "theta", "f")        # doctest: +SKIP
    >>> str(b.condition.values[0])                                  # doctest: +SKIP
    'coef_A_slip_neg'
    """
    model = ds.attrs.get("phasemap_model")
    if model is None:
        raise ValueError("boundaries=True needs a phasemap atlas (no phasemap_model attribute)")
    axes = {n: (float(ds[n].min()), float(ds[n].max())) for n in (x, y)}
    fixed = {k[len("phasemap_fixed_"):]: float(v) for k, v in ds.attrs.items()
             if k.startswith("phasemap_fixed_")}
    fixed |= {str(n): float(c) for n, c in ds.coords.items() if c.ndim == 0}
    for n in axes:
        fixed.pop(n, None)
    return boundaries(model, axes, fixed=fixed, layer=layer if layer in LAYERS else "n_solutions",
                      tol=tol)
