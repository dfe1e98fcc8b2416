"""
A phase portrait from the first integrals
=========================================

``phasemap.phase_curve`` follows omega(phi) stage by stage, with no time
stepping: on each stage the branch and the sign of omega are fixed and
``u = omega**2`` obeys ``du/dphi = 2 phi''(phi, u)``, solved by exponential
Gauss collocation. Each stage ends at a reversal, at rest inside a stagnation
zone, or where the classification changes. Here the hinge pendulum swings down
from several angles and comes to rest inside the zones ``l |sin phi| <= delta``.
"""

import matplotlib.pyplot as plt

import phasemap

with phasemap.plot.style():
    fig, ax = plt.subplots(figsize=(7.2, 3.2), layout="constrained")
    starts = (0.8, 1.6, 2.4, 3.0)
    for phi0 in starts:
        curve = phasemap.phase_curve("hinge_pendulum", phi=phi0, omega=0.0, delta=0.1)
        phasemap.plot.phase_curve_figure(curve, ax=ax)
        print(f"phi0 = {phi0}: {curve.attrs['end_reason']} after "
              f"{int(curve.attrs['n_reversals'])} reversals")
    # each call titles the legend with its own start; name all four instead
    ax.get_legend().set_title(r"$\varphi_0$ = " + ", ".join(f"{s:g}" for s in starts)
                              + r" rad, $\omega_0$ = 0; $\delta$ = 0.1 m, $l$ = 1 m")
plt.show()
