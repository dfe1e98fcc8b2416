"""The README's bifurcation figure: the Painleve rod's first paradox, exactly.

A coarse 96^2 map of n_solutions of the rod sliding back (xdot < 0) from rest
in (theta, f), with the exact boundary traced over it (``boundaries=True``) and
the threshold ``phasemap.threshold`` finds (f = 4/3 at theta = arctan 2) marked.

    python docs/bifurcation/rod_first_paradox.py     # writes rod_first_paradox.{pdf,png}
"""

import math
import pathlib

import numpy as np

import phasemap
from phasemap.plot import save_figure

HERE = pathlib.Path(__file__).resolve().parent
FIXED = {"xdot": -1.0, "omega": 0.0}

t = phasemap.threshold("painleve_rod", "f", value=0, over={"theta": (0.2, 1.5), "f": (0, 3)},
                       fixed=FIXED)
print(t)
print(f"4/3 - f* = {4 / 3 - t.value:.1e}, arctan 2 - theta* = {math.atan(2) - t.at['theta']:.1e}")
ds = phasemap.Scene("painleve_rod", axes={"theta": np.linspace(0.2, 1.5, 96),
                                          "f": np.linspace(0.0, 3.0, 96)},
                    fixed=FIXED, layers=["n_solutions"]).compute()
fig = ds.phasemap.plot("n_solutions", x="theta", boundaries=True)
ax = fig.axes[0]
ax.plot([t.at["theta"]], [t.value], marker="o", ms=4, color="black", zorder=6)
ax.annotate(r"$f^* = 4/3$ at $\theta = \arctan 2$", (t.at["theta"], t.value),
            xytext=(0, -16), textcoords="offset points", ha="center", fontsize=7)
print("wrote", *save_figure(fig, HERE / "rod_first_paradox"))
