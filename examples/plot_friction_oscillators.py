"""
Friction oscillators: a stick-slip orbit and a branch through a sliding bifurcation
===================================================================================

Left: the stick-slip orbit of a block on a spring riding on a belt (m = k = 1, static
friction 1, kinetic 0.5, belt speed 0.2), found by :func:`phasemap.periodic_orbit` on the
exact hybrid flow. The block rides with the belt (thick) until the spring's pull reaches
the static friction, then slips back and catches the belt again: period
2 delta / v + pi + 2 arctan(v / delta) = 8.902605 s, a stick segment of exactly 5 s.

Right: Den Hartog's forced oscillator x'' + x = cos(0.8 t) - f sgn x', its non-stop
orbit followed in the friction f by :func:`phasemap.continue_orbit`. At f = 0.8174064
its reversals reach the edge of the sticking region and stops appear (a
crossing-sliding bifurcation), found without the mode sequence being written by hand.
"""

import matplotlib.pyplot as plt

import phasemap
from phasemap.plot.style import style

belt = phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2})
print(f"belt: period {float(belt.period):.9f} s, segments "
      f"{belt.segment_duration.values.round(9).tolist()}, "
      f"multipliers {abs(belt.floquet.values).round(8).tolist()}")

orbit = phasemap.periodic_orbit("den_hartog", start={"f": 0.6})
branch = phasemap.continue_orbit(orbit, "f", (0.6, 0.84), steps=6)
for kind, at in zip(branch.point_kind.values, branch.point_f.values):
    print(f"den_hartog: {kind} at f = {float(at):.9f}")

with style():
    fig, (left, right) = plt.subplots(1, 2, figsize=(7.2, 3.0), layout="constrained")
belt.phasemap.plot(ax=left)
branch.phasemap.plot(ax=right)
plt.show()
