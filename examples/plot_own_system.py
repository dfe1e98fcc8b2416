"""
A system of one's own: a bar on a rough slope, declared
=======================================================

Declare the mechanics (coordinates, parameters, a body, the potential and a
contact); phasemap derives Lagrange's equations, enumerates every contact
mode, solves each in closed form and generates numba kernels, cached on disk.
Here Painlevé's rod stands with its foot on a rough *slope* rather than a
floor. Its acceleration problem has no solution, pushed towards the bar, for
``f > 4/3``, as on a floor: the coefficient of the senior derivative depends on
the bar's angle to the surface only, so the first inconsistency sits at
``arctan 2`` from the slope, the floor's angle turned by the slope's.
"""

import math

import matplotlib.pyplot as plt
import numpy as np
import sympy as sp

import phasemap
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

SLOPE = 0.3                                    # inclination of the surface (rad), rising to +x
f = Parameter("f", "1", "friction coefficient on the slope", default=0.5, lower=0.0)
a = Parameter("a", "m", "half length of the bar", default=1.0, lower=0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
m = Parameter("m", "kg", "mass of the bar", default=1.0, lower=0.0, lower_open=True)
phi = Coordinate("phi", "rad", "angle of the bar to the horizontal", default=1.0, lower=0.0,
                 upper=float(sp.pi), symbol="\\varphi",
                 rate=Rate("omega", "rad s-1", "angular velocity", symbol="\\omega",
                           scale=sp.sqrt(g / a)))
s = Coordinate("s", "m", "horizontal position of the foot",
               rate=Rate("sdot", "m s-1", "horizontal velocity of the foot", symbol="\\dot s",
                         scale=sp.sqrt(g * a)))
h = Coordinate("h", "m", "height of the foot")      # no rate: the slope fixes it

SYSTEM = System(
    "bar_on_slope", "A bar with its foot on a rough slope", "after Painleve (1895)",
    coordinates=(phi, s, h), parameters=(f, a, g, m),
    bodies=(Body(m, (s + a * sp.cos(phi), h + a * sp.sin(phi)), inertia=m * a**2 / 3,
                 angle=phi),),
    potential=m * g * (h + a * sp.sin(phi)),
    contacts=(PointContact("foot", point=(s, h), normal=(-math.sin(SLOPE), math.cos(SLOPE)),
                           friction=f),),
)

model = SYSTEM.model                 # derived once, then loaded from the kernel cache
atlas = phasemap.Scene(model, axes={"phi": np.linspace(0.02, 3.12, 300),
                                    "f": np.linspace(0.0, 2.5, 300)},
                       fixed={"sdot": -1.0, "omega": 0.0}).compute()
none = atlas.n_solutions == 0
least = float(atlas.f.where(none.any("phi")).min())
print(f"least f with no solution on this grid: {least:.3f} (exactly 4/3 = {4 / 3:.3f}, "
      f"grid step {float(atlas.f[1] - atlas.f[0]):.3f})")
print(f"there, phi = {atlas.phi.where(none.sel(f=least)).min().item():.3f} to "
      f"{atlas.phi.where(none.sel(f=least)).max().item():.3f} rad; "
      f"arctan 2 + slope = {math.atan(2.0) + SLOPE:.3f} rad")

fig = atlas.phasemap.plot(size="two_column")
ax = fig.axes[0]
ax.axhline(4 / 3, color="black", lw=0.8, ls=(0, (4, 2)))
ax.axvline(math.atan(2.0) + SLOPE, color="black", lw=0.8, ls=(0, (1, 1.5)))
plt.show()
