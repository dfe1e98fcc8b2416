"""
Where a forced friction oscillator settles: two stable orbits and their basins
===============================================================================

The hardening ``duffing`` oscillator with dry friction, x'' + c x' + x + beta x^3 =
F0 cos(Omega t) - f sgn x', has a large and a small stable period-one orbit over a range
of the forcing frequency (its resonance curve folds). A :class:`phasemap.Scene` with the
orbit layers runs the motion from every cell, lets it settle and keeps its state once per
forcing period (``section_x``, on a ``cycle`` dimension) and its period (``multiple``),
as :func:`phasemap.orbit_diagram` does (:mod:`phasemap.maps.motions`).

Left: over the start (x, x') at Omega = 1.5, the settled orbit's x at the forcing's
phase 0, one colour per orbit: the basins of attraction of the two orbits.

Right: the same layer over Omega from rest, the orbit diagram as an atlas. The motion
from rest settles on the large orbit up to Omega = 1.4 and on the small one beyond,
though the large orbit lives on to its fold near Omega = 1.573: at Omega = 1.5 the rest
state (0, 0) lies in the small orbit's basin (left).
"""

import matplotlib.pyplot as plt
import numpy as np

import phasemap
from phasemap.plot.style import style

basins = phasemap.Scene("duffing", axes={"x": np.linspace(-2, 2, 15),
                                         "xdot": np.linspace(-2, 2, 15)},
                        fixed={"Omega": 1.5}, layers=["multiple", "section_x"],
                        options={"periods": 2, "settle": 40}).compute()
sweep = phasemap.Scene("duffing", axes={"Omega": np.linspace(1.2, 1.8, 25)},
                       layers=["multiple", "section_x"],
                       options={"periods": 4, "settle": 60}).compute()
settled = basins.multiple.values == 1
points = np.unique(basins.section_x.values[..., -1][settled].round(3))
print(f"{int(settled.sum())} of {settled.size} starts settled on a period-one orbit within "
      f"40 periods, at x = {points.tolist()} (phase 0); from rest, x = "
      f"{sweep.section_x.values[[0, -1], -1].round(3).tolist()} at Omega = 1.2 and 1.8")

with style():
    fig, (left, right) = plt.subplots(1, 2, figsize=(7.2, 3.2), layout="constrained")
basins.isel(cycle=-1).phasemap.plot("section_x", ax=left)
sweep.phasemap.plot(ax=right)
plt.show()
