"""
Painlevé's rod: an impact without collision, then a landing and rest
====================================================================

The rod of Génot and Brogliato (1999) has m = 1, half-length l = 1 and f = 1.5. At
θ = arctan 2, with ω = 0 and its end sliding back at ẋ_A = −1, it is in a Painlevé
inconsistency: the accelerations have no solution. The motion goes on by an impact
without collision, an impulse at zero normal velocity that stops the slip. The impulse
is P_n = 0.3, P_t = 0.4, and the kinetic energy drops from 0.5 to 0.3. The rod then
sticks and turns about its end.

Declared with its other end B as a second, open contact, the rod falls, lands on B and
comes to rest lying on the floor. Every step runs in full coordinates.
"""

import dataclasses
import math

import matplotlib.pyplot as plt
import numpy as np
import sympy as sp

import phasemap
from phasemap.declare import PointContact
from phasemap.systems import painleve_rod

theta, x, y = painleve_rod.SYSTEM.coordinates
f, l = painleve_rod.SYSTEM.parameters[:2]
end_b = PointContact("B", (x + 2 * l * sp.cos(theta), y + 2 * l * sp.sin(theta)),
                     friction=f, long_name="end B on the floor")
SYSTEM = dataclasses.replace(painleve_rod.SYSTEM, name="rod_two_ends",
                             contacts=painleve_rod.SYSTEM.contacts + (end_b,),
                             coordinates=(dataclasses.replace(theta, lower=-math.inf), x, y))

motion = phasemap.simulate(SYSTEM, t_end=3.0, rtol=1e-10, theta=math.atan(2.0), omega=0.0,
                           xdot=-1.0, f=1.5, t_eval=np.linspace(0.0, 3.0, 601))
for t, kind, c, pn, pt, dke in zip(motion.event_t.values, motion.event_kind.values,
                                   motion.event_contact.values, motion.event_impulse_n.values,
                                   motion.event_impulse_t.values, motion.event_dKE.values):
    text = f"t = {t:.6f} s  {phasemap.Event(int(kind)).name.lower():10s}"
    if not np.isnan(pn):
        text += f"  at {'AB'[c]}: P_n = {pn:.6f}, P_t = {pt:.6f}, dKE = {dke:.6f} J"
    print(text)

fig = motion.phasemap.strip()
plt.show()
