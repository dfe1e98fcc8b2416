"""
A system of one's own: Painlevé's rod on a rough slope, declared
================================================================

Declare the mechanics (coordinates, parameters, a body, the potential and a
contact); phasemap derives Lagrange's equations, enumerates every contact
mode, solves each in closed form and generates numba kernels, cached on disk.
Here the built-in declaration of Painlevé's rod
(``phasemap/systems/painleve_rod.py``: its parameters, coordinates, body and
potential) stands with its end on a rough *slope* rather than a floor: only
its contact's normal changes. Its acceleration problem has no
solution, pushed towards the rod, for ``f > 4/3``, as on a floor: the
coefficient of the senior derivative depends on the rod's angle to the surface
only, so the first inconsistency sits at ``arctan 2`` from the slope, the
floor's angle turned by the slope's.
"""

import dataclasses
import math

import matplotlib.pyplot as plt
import numpy as np

import phasemap
from phasemap.systems import painleve_rod

SLOPE = 0.3                                    # inclination of the surface (rad), rising to +x
rod = painleve_rod.SYSTEM                      # the rod with its end A on the floor y = 0
(floor,) = rod.contacts
slope = dataclasses.replace(floor, normal=(-math.sin(SLOPE), math.cos(SLOPE)),
                            long_name="end A on the slope")
SYSTEM = dataclasses.replace(rod, name="rod_on_slope", contacts=(slope,),
                             title="Painleve's rod with its end on a rough slope",
                             citation="after Painleve (1895)")

model = SYSTEM.model                 # derived once, then loaded from the kernel cache
atlas = phasemap.Scene(model, axes={"theta": np.linspace(0.02, 3.12, 300),
                                    "f": np.linspace(0.0, 2.5, 300)},
                       fixed={"xdot": -1.0, "omega": 0.0}).compute()
none = atlas.n_solutions == 0
least = float(atlas.f.where(none.any("theta")).min())
print(f"least f with no solution on this grid: {least:.3f} (exactly 4/3 = {4 / 3:.3f}, "
      f"grid step {float(atlas.f[1] - atlas.f[0]):.3f})")
print(f"there, theta = {atlas.theta.where(none.sel(f=least)).min().item():.3f} to "
      f"{atlas.theta.where(none.sel(f=least)).max().item():.3f} rad; "
      f"arctan 2 + slope = {math.atan(2.0) + SLOPE:.3f} rad")

fig = atlas.phasemap.plot(size="two_column")
ax = fig.axes[0]
ax.axhline(4 / 3, color="black", lw=0.8, ls=(0, (4, 2)))
ax.axvline(math.atan(2.0) + SLOPE, color="black", lw=0.8, ls=(0, (1, 1.5)))
plt.show()
