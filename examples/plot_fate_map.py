"""
A fate map: where each initial state ends
=========================================

The dry-friction counterpart of a basin of attraction. Every cell of the scene
is an initial state ``(phi, omega)`` of the hinge pendulum (hinge friction
moment ``delta |R|``); the compiled integrator runs from each, in parallel, and
records how the motion ends (``fate``), how often it reversed
(``n_reversals``) and where it came to rest (``phi_rest``). Rest is only
possible inside the stagnation zones ``l |sin phi| <= delta``.
"""

import matplotlib.pyplot as plt
import numpy as np

import phasemap

fates = phasemap.Scene(
    "hinge_pendulum",
    axes={"phi": np.linspace(-3.0, 3.0, 121), "omega": np.linspace(-6.0, 6.0, 121)},
    fixed={"delta": 0.1},
    layers=["fate", "n_reversals", "phi_rest"],
    options={"t_end": 30.0},
).compute()

rest = fates.fate == phasemap.Event.REST
print(f"{int(rest.sum())} of {fates.fate.size} states come to rest within 30 s")
print("largest |sin phi_rest|:", float(np.abs(np.sin(fates.phi_rest)).max()))

fig = fates.phasemap.plot(size="two_column")
plt.show()
