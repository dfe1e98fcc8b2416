"""
A system of one's own: the Painlevé rod, declared
=================================================

Declare the mechanics (coordinates, parameters, a body, the potential and a
contact); phasemap derives Lagrange's equations, enumerates every contact
mode, solves each in closed form and generates numba kernels, cached on disk.
The classic Painlevé rod has one end on a rough floor: pushed towards the rod,
its acceleration problem has no solution for ``f > 4/3`` around
``theta = arctan 2``.
"""

import matplotlib.pyplot as plt
import numpy as np
import sympy as sp

import phasemap
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

f = Parameter("f", "1", "friction coefficient at the floor", default=0.5, lower=0.0)
l = Parameter("l", "m", "half length of the rod", default=1.0, lower=0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
m = Parameter("m", "kg", "mass of the rod", default=1.0, lower=0.0, lower_open=True)
theta = Coordinate("theta", "rad", "angle of the rod to the floor", default=1.0, lower=0.0,
                   upper=float(sp.pi), symbol="\\theta",
                   rate=Rate("omega", "rad s-1", "angular velocity", symbol="\\omega",
                             scale=sp.sqrt(g / l)))
x = Coordinate("x", "m", "position of end A", rate=Rate("xdot", "m s-1", "velocity of end A",
                                                        symbol="\\dot x", scale=sp.sqrt(g * l)))
y = Coordinate("y", "m", "height of end A")          # no rate: the floor contact fixes it

SYSTEM = System(
    "my_rod", "A uniform rod with one end on a rough floor", "Painleve (1895)",
    coordinates=(theta, x, y), parameters=(f, l, g, m),
    bodies=(Body(m, (x + l * sp.cos(theta), y + l * sp.sin(theta)),
                 inertia=m * l**2 / 3, angle=theta),),
    potential=m * g * (y + l * sp.sin(theta)),
    contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f),),
)

model = SYSTEM.model                 # derived once, then loaded from the kernel cache
atlas = phasemap.Scene(model, axes={"theta": np.linspace(0.02, 1.55, 300),
                                    "f": np.linspace(0.0, 2.5, 300)},
                       fixed={"xdot": -1.0, "omega": 0.0}).compute()
none = atlas.n_solutions == 0
print(f"least f with no solution on this grid: {float(atlas.f.where(none.any('theta')).min()):.3f}"
      f" (exactly 4/3 = {4 / 3:.3f})")

fig = atlas.phasemap.plot(size="two_column")
ax = fig.axes[0]
ax.axhline(4 / 3, color="black", lw=0.8, ls=(0, (4, 2)))
ax.axvline(np.arctan(2.0), color="black", lw=0.8, ls=(0, (1, 1.5)))
plt.show()
