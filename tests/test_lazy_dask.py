"""xarray asks whether an array is a dask array without importing dask.array
(phasemap/core/lazy.py: dask_checked_lazily): a process's first Dataset no longer imports
it, and dask arrays are still dask arrays once dask is imported."""

from __future__ import annotations

import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]

CHILD = r"""
import sys
{first}
import numpy as np
import xarray as xr
import phasemap

ds = xr.Dataset({{"a": ("x", np.arange(4.0))}})
atlas = phasemap.Scene("hinge_pendulum", axes={{"phi": np.linspace(-3, 3, 4),
                       "omega": np.linspace(-1, 1, 3)}}, layers=["n_solutions"]).compute()
print("dask imported by the first Datasets:", "dask.array" in sys.modules)

import dask.array as da
lazy = xr.Dataset({{"a": ("x", da.arange(4.0, chunks=2))}})
print("a dask array stays one:", type(lazy.a.data).__module__.startswith("dask"),
      dict(lazy.chunks), float(lazy.a.sum().compute()))
chunked = phasemap.Scene("hinge_pendulum", axes={{"phi": np.linspace(-3, 3, 4),
                         "omega": np.linspace(-1, 1, 3)}},
                         layers=["n_solutions"]).compute(chunks=2)
print("a chunked scene:", type(chunked.n_solutions.data).__module__.startswith("dask"),
      bool((chunked.n_solutions.compute() == atlas.n_solutions).all()))
from xarray.namedarray import pycompat
print("xarray's own record:", type(pycompat._cached_duck_array_modules["dask"]).__name__)
"""


def _run(first: str) -> list[str]:
    done = subprocess.run([sys.executable, "-c", CHILD.format(first=first)], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()


def test_the_first_datasets_do_not_import_dask_and_dask_arrays_stay_dask():
    # phasemap imported first, and xarray imported by the user before phasemap
    for first in ("import phasemap", "import xarray"):
        lines = _run(first)
        assert lines == ["dask imported by the first Datasets: False",
                         "a dask array stays one: True {'x': (2, 2)} 6.0",
                         "a chunked scene: True True",
                         "xarray's own record: DuckArrayModule"], (first, lines)


def test_nothing_is_changed_where_xarray_has_its_record_already():
    import xarray as xr
    from xarray.namedarray import pycompat

    from phasemap.core.lazy import dask_checked_lazily

    xr.Dataset({"a": ("x", [1.0])})        # xarray's record made (or ours, if first)
    before = pycompat._cached_duck_array_modules.get("dask")
    assert before is not None
    assert dask_checked_lazily() is False
    assert pycompat._cached_duck_array_modules["dask"] is before
