"""
The ladder that leaves the wall: lift-off, flight and a plastic landing
=======================================================================

A frictionless ladder (length 2l = 1 m) released at rest 60° from the floor slides
down the wall until the wall's reaction vanishes. That happens at
sin θ = (2/3) sin 60°, θ = 35.2644°. From there it falls on with its foot on the
floor, and its top lands flat.

Declared with a third contact, its top end on the floor, the system has no reduced
model: three contacts cannot all close at once. ``simulate`` takes the declaration and
moves it in full coordinates through the lift-off and the landing. The landing is
plastic, so the top stays down and the ladder slides on. The strip shows the outlines
at evenly spaced times and at the events, with the reactions in blue and the landing's
impulse in vermillion.
"""

import dataclasses
import math

import matplotlib.pyplot as plt
import numpy as np
import sympy as sp

import phasemap
from phasemap.declare import PointContact
from phasemap.systems.seeds.ladder import SYSTEM as LADDER

phi, xc, yc = LADDER.coordinates
f, l = LADDER.parameters[:2]
top = PointContact("top", (xc - l * sp.sin(phi), yc + l * sp.cos(phi)), friction=f,
                   long_name="top end on the floor")
SYSTEM = dataclasses.replace(LADDER, name="ladder_three", contacts=LADDER.contacts + (top,),
                             coordinates=(dataclasses.replace(phi, upper=math.inf), xc, yc))

phi0 = math.radians(30.0)                       # 60 degrees from the floor
motion = phasemap.simulate(SYSTEM, t_end=0.6, rtol=1e-10, phi=phi0, omega=0.0,
                           xc=0.5 * math.sin(phi0), yc=0.5 * math.cos(phi0), f=0.0, l=0.5,
                           t_eval=np.linspace(0.0, 0.6, 241))
for t, kind, dke in zip(motion.event_t.values, motion.event_kind.values,
                        motion.event_dKE.values):
    print(f"t = {t:.6f} s  {phasemap.Event(int(kind)).name.lower():10s}"
          + ("" if np.isnan(dke) else f"  dKE = {dke:.6f} J"))
release = [int(k) for k in motion.event_kind.values].index(phasemap.Event.LIFTOFF)
print("leaves the wall at theta =",
      round(90 - math.degrees(float(motion.event_phi[release])), 6), "degrees; exact",
      round(math.degrees(math.asin(2 / 3 * math.sin(math.radians(60)))), 6))

fig = motion.phasemap.strip()
plt.show()
