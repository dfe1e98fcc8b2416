"""
Reading an atlas back with xarray
=================================

An atlas is a CF-1.8 netCDF file: ``phasemap.write_atlas`` writes it
atomically, and any netCDF reader opens it. With xarray, the layers come back
with their units, long names and flags; the provenance (model, fixed values,
the scene as JSON, the version) is in the global attributes, enough to
recompute the atlas; and the ``ds.phasemap`` accessor draws it again. Here we
read a ladder atlas back and take a profile along the friction coefficient.
"""

import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

import phasemap

scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0.0, 1.5, 200),
                                       "f": np.linspace(0.0, 2.0, 200)},
                       fixed={"omega": 0.0}, layers=["n_solutions", "stagnation", "singular"])
path = phasemap.write_atlas(scene.compute(), Path(tempfile.mkdtemp()) / "ladder.nc")

ds = xr.open_dataset(path)
print(ds.n_solutions.attrs["flag_meanings"], "|", ds.attrs["Conventions"])
print("model:", ds.attrs["phasemap_model"], " fixed omega:", ds.attrs["phasemap_fixed_omega"])
again = phasemap.Scene.from_spec(json.loads(ds.attrs["phasemap_scene"])).compute()
print("recomputed from its own metadata, identical:",
      bool((again.n_solutions == ds.n_solutions).all()))

# the static zone phi <= 2 arctan f, read off the stagnation layer at f = 0.3
row = ds.stagnation.sel(f=0.3, method="nearest")
print(f"rest possible up to phi = {float(ds.phi.where(row == 1).max()):.3f} rad "
      f"(2 arctan f = {2 * np.arctan(float(row.f)):.3f})")

fig = ds.sel(f=0.3, method="nearest").phasemap.plot(size="two_column")
plt.show()
