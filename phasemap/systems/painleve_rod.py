r"""The classic Painleve rod: a uniform rod with one end on a rough floor.

A rod of length 2l and mass m (inertia m l^2/3 about its centre) touches the
floor y = 0 with its end A; theta is the angle of the rod to the floor, x the
position of A along the floor.  The floor is one-sided with Coulomb friction
f: A slips, sticks, or lifts off.  Declared, not derived by hand: phasemap
derives the equations and the modes (see :mod:`phasemap.declare`).

Painleve P. (1895), Sur les lois du frottement de glissement, C. R. Acad. Sci.
Paris 121, 112-115; Genot F., Brogliato B. (1999), New results on Painleve
paradoxes, Eur. J. Mech. A/Solids 18, 653-677.
"""

import sympy as sp

from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

f = Parameter("f", "1", "friction coefficient at the floor", default=0.5, lower=0.0)
l = Parameter("l", "m", "half length of the rod", default=1.0, lower=0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
m = Parameter("m", "kg", "mass of the rod", default=1.0, lower=0.0, lower_open=True)
theta = Coordinate("theta", "rad", "angle of the rod to the floor", default=1.0, lower=0.0,
                   upper=float(sp.pi), symbol="\\theta",
                   rate=Rate("omega", "rad s-1", "angular velocity of the rod",
                             symbol="\\omega", scale=sp.sqrt(g / l)))
x = Coordinate("x", "m", "position of end A along the floor",
               rate=Rate("xdot", "m s-1", "velocity of end A along the floor",
                         symbol="\\dot x", scale=sp.sqrt(g * l)))
y = Coordinate("y", "m", "height of end A above the floor")

SYSTEM = System(
    "painleve_rod", "Painleve's rod: a uniform rod with one end on a rough floor",
    "Painleve P. (1895), C. R. Acad. Sci. Paris 121, 112-115; Genot F., Brogliato B. "
    "(1999), Eur. J. Mech. A/Solids 18, 653-677",
    coordinates=(theta, x, y), parameters=(f, l, g, m),
    bodies=(Body(m, (x + l * sp.cos(theta), y + l * sp.sin(theta)), inertia=m * l**2 / 3,
                 angle=theta),),
    potential=m * g * (y + l * sp.sin(theta)),
    contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f,
                           long_name="end A on the floor"),),
    default_axes={"theta": (0.0, float(sp.pi) / 2, 512), "f": (0.0, 3.0, 512)},
)
