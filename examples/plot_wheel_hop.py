"""
The seed's wheel hops: lift-off, flight and a perfectly rough landing
=====================================================================

Lapshin's wheel is a disc (r = 1 m) whose centre of mass sits l = 0.5 m off its centre.
Rolling fast with its centre of mass high, it would need the floor to pull: it leaves
the floor at once. It flies, its centre of mass on a parabola and its spin constant,
until its rim meets the floor. The disc rolls without slip, so the landing is
perfectly rough. A tangential impulse first stops the slip of its lowest point, then
the normal impact follows. Every impulse acts at the point of contact, so without
rolling friction the angular momentum about that point is kept. A few milliseconds
later rolling on would need the floor to pull, while leaving it would take the disc
into the floor: the wheel's own Painlevé paradox, where the model ends
(``no_solution``). The strip draws the rim and a spoke to the centre of mass, the
reactions in blue and the landing's impulse in vermillion.
"""

import matplotlib.pyplot as plt

import phasemap

motion = phasemap.simulate("wheel", t_end=0.65, rtol=1e-12, phi=2.5591, omega=8.2805,
                           delta=0.0)
for t, kind, pn, pt, dke in zip(motion.event_t.values, motion.event_kind.values,
                                motion.event_impulse_n.values, motion.event_impulse_t.values,
                                motion.event_dKE.values):
    text = f"t = {t:.6f} s  {phasemap.Event(int(kind)).name.lower():12s}"
    if pn == pn:
        text += f"  P_n = {pn:.6f}, P_t = {pt:.6f}, dKE = {dke:.6f} J"
    print(text)
print("reduced model's end:", motion.attrs["phasemap_reduced_end"])

fig = motion.phasemap.strip()
plt.show()
