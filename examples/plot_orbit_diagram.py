"""
An orbit diagram by simulation, with the continued branch on it
===============================================================

Ueda's oscillator with dry friction, x'' + 0.05 x' + x^3 = F0 cos t - 0.01 sgn x',
swept down in the forcing amplitude F0 by :func:`phasemap.orbit_diagram`: at each value
the motion (through every stop and reversal, on the exact hybrid flow) settles for 60
forcing periods and its state is kept once per period, each value starting where the
previous one ended. Above F0 = 8.0115 it settles on one point per value, a period-one
orbit; below, the points spread.

The branch is that orbit followed in F0 by :func:`phasemap.continue_orbit`, drawn where
it crosses the forcing's phase 0: stable (solid) down to the period doubling it locates
at F0 = 8.0115330, where a Floquet multiplier passes -1, unstable (dashed) below, where
the swept motion has left it. Between F0 = 8.11245 and 8.11257 a short pair of
reversals turns into a stop and vanishes (grazing- and crossing-sliding); the
continuation goes through those changes of its mode sequence by itself.
"""

import matplotlib.pyplot as plt
import numpy as np

import phasemap
from phasemap.plot.style import style

ueda = {"k": 0.0, "beta": 1.0, "c": 0.05, "f": 0.01, "Omega": 1.0}
sweep = phasemap.orbit_diagram("duffing", "F0", np.linspace(8.3, 7.8, 16),
                               start={**ueda, "x": 2.4, "xdot": -0.32}, settle=60,
                               periods=25, follow=True)
print("period of the settled motion (forcing periods; 0: none):",
      sweep.multiple.values.tolist())

orbit = phasemap.periodic_orbit("duffing", start={**ueda, "F0": 8.05, "x": 2.39,
                                                  "xdot": -0.315}, period=2 * np.pi)
branch = phasemap.continue_orbit(orbit, "F0", (7.8, 8.3), steps=6)
for kind, at in zip(branch.point_kind.values, branch.point_F0.values):
    print(f"{kind} at F0 = {float(at):.9f}")

with style():
    fig, ax = plt.subplots(figsize=(3.5, 2.8), layout="constrained")
sweep.phasemap.plot(ax=ax, branches=branch)
plt.show()
