"""
Friction oscillators mapped: sticking over the forcing's phase, riding with a belt
==================================================================================

The friction oscillators have no reduced model (their relative velocity is the block's
less the belt's, and forcing makes the equations depend on the time), so
:class:`phasemap.Scene` maps them in full coordinates, with the survey of the
admissible phases that :func:`phasemap.simulate` decides its events with.

Left: Den Hartog's block at rest (x' = 0) over its position and the forcing's phase t.
It stays put (hatched) where the applied force less the spring's, cos(0.8 t) - x, is
within the friction f = 0.2; elsewhere the colours are its acceleration
cos(0.8 t) - x - f sgn(...).

Right: the block on the belt, moving with it (x' = v = 0.2), over its position and the
static coefficient f_s: it rides with the belt (stagnation relative to the belt) while
the spring's pull k x is within plus or minus f_s m g, the wedge -f_s <= x <= f_s.
"""

import matplotlib.pyplot as plt
import numpy as np

import phasemap
from phasemap.plot.style import style

forced = phasemap.Scene("den_hartog", axes={"x": np.linspace(-1.5, 1.5, 121),
                                            "t": np.linspace(0, 2 * np.pi / 0.8, 100)},
                        fixed={"xdot": 0.0}, layers=["stagnation", "x_ddot"]).compute()
belt = phasemap.Scene("belt", axes={"x": np.linspace(-1.5, 1.5, 121),
                                    "f_s": np.linspace(0.5, 1.5, 81)},
                      fixed={"xdot": 0.2}, layers=["n_solutions", "stagnation"]).compute()
print(f"den_hartog: stuck in {int(forced.stagnation.sum())} of {forced.stagnation.size} "
      f"cells; belt: riding with it in {int(belt.stagnation.sum())} of "
      f"{belt.stagnation.size}")

with style():
    fig, (left, right) = plt.subplots(1, 2, figsize=(7.2, 3.2), layout="constrained")
forced.phasemap.plot("x_ddot", ax=left)
belt.phasemap.plot("stagnation", ax=right)
plt.show()
