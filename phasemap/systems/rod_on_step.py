r"""A rod on a step: a uniform rod with its end A on a rough floor, lying across the rough
edge of a step.  Two frictional contacts, one degree of freedom while both are kept.

The rod (length 2l, mass m, inertia m l^2/3) makes the angle theta with the
floor; the step's edge is the corner K = (0, h).  Both contacts are one-sided
with the friction coefficient f: A slides on the floor, the rod slides over
the edge, and either may lift off.  With both kept, A = (-h cot theta, 0) and
both slip velocities are h omega / sin^2 theta times 1 and cos theta: one sign.

Planar bodies with two frictional contacts: Champneys A.R., Varkonyi P.L.
(2016), The Painleve paradox in contact mechanics, IMA J. Appl. Math. 81(3),
538-568 (section on two-point contact); Varkonyi P.L. (2017), Dynamics of
mechanical systems with two sliding contacts: new facets of Painleve's paradox,
Arch. Appl. Mech. 87, 785-799.  docs/systems/rod_on_step.md has the derivation
of its singular set (the kept-kept coefficient first vanishes at
f = 2/sqrt 3) and what the full enumeration shows.
"""

import sympy as sp

from phasemap.declare import Body, Coordinate, EdgeContact, Parameter, PointContact, Rate, System

f = Parameter("f", "1", "friction coefficient at the floor and at the edge", 0.5, 0.0)
l = Parameter("l", "m", "half length of the rod", 1.0, 0.0, lower_open=True)
h = Parameter("h", "m", "height of the step's edge", 0.8, 0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
m = Parameter("m", "kg", "mass of the rod", 1.0, 0.0, lower_open=True)
theta = Coordinate("theta", "rad", "angle of the rod to the floor", 1.0, 0.0, float(sp.pi) / 2,
                   lower_open=True, symbol="\\theta",
                   rate=Rate("omega", "rad s-1", "angular velocity of the rod", symbol="\\omega",
                             scale=sp.sqrt(g / l)))
xa = Coordinate("xa", "m", "position of end A along the floor")
ya = Coordinate("ya", "m", "height of end A")


SYSTEM = System(
    "rod_on_step", "A rod on a step: end on a rough floor, lying across a rough edge",
    "Champneys A.R., Varkonyi P.L. (2016), IMA J. Appl. Math. 81(3), 538-568; Varkonyi P.L. "
    "(2017), Arch. Appl. Mech. 87, 785-799",
    coordinates=(theta, xa, ya), parameters=(f, l, h, g, m),
    bodies=(Body(m, (xa + l * sp.cos(theta), ya + l * sp.sin(theta)), inertia=m * l**2 / 3,
                 angle=theta),),
    potential=m * g * (ya + l * sp.sin(theta)),
    contacts=(PointContact("floor", (xa, ya), normal=(0, 1), friction=f),
              EdgeContact("edge", (xa, ya), corner=(0, h), angle=theta, friction=f,
                          extent=(0, 2 * l))),
    default_axes={"theta": (0.45, 1.55, 512), "f": (0.0, 2.0, 512)},
)
