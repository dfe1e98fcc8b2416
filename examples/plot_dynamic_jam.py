"""
Painlevé's rod jams: a slip that runs into its singular point
=============================================================

The rod of the seed (m = 1, half-length l = 1) slides back with its end A on a rough
floor, f = 2. Along this slip the coefficient of its normal acceleration,
B = 1 + 3 cos²θ − 3 f sinθ cosθ, and the free normal acceleration −g + l ω² sinθ
reach zero together: the Génot–Brogliato singular point. On the way the normal force
grows without bound while A still slides, though its impulse stays bounded. At the
point an impulse at zero normal velocity stops the slip (a dynamic jam):
P_n = −v_t / (W_tn − s f W_tt) and P_t = −s f P_n. The impulse spins the rod up so
that it leaves the floor. It flies with a constant spin until it lies flat.
"""

import math

import matplotlib.pyplot as plt

import phasemap

f = 2.0
motion = phasemap.simulate("painleve_rod", t_end=0.6, rtol=1e-10, theta=0.55, omega=3.6,
                           xdot=-4.0, f=f)
print([phasemap.Event(int(k)).name.lower() for k in motion.event_kind.values])
jam = 1                                    # the event holds the state before the impulse
th, xdot = float(motion.event_theta[jam]), float(motion.event_xdot[jam])
s, c = math.sin(th), math.cos(th)
print(f"jam at t = {float(motion.event_t[jam]):.6f} s, B = {1 + 3 * c * c - 3 * f * s * c:.1e}")
# W of the rod at A (m = l = 1): W_tn = -3 s c, W_tt = 1 + 3 s^2; the slip is s_t = -1
print(f"P_n = {float(motion.event_impulse_n[jam]):.9f}, by hand "
      f"{-xdot / (-3 * s * c + f * (1 + 3 * s * s)):.9f}; P_t = "
      f"{float(motion.event_impulse_t[jam]):.9f} = f P_n")

fig = motion.phasemap.strip()
plt.show()
