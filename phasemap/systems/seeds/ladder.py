"""The ladder of Lapshin (2021), declared: a bar against a rough wall and a rough floor.

The hand derivation (phasemap.models.ladder) is what runs; this declaration
checks it (tests/test_declare.py) and counts what it cannot: the ladder
leaving the wall or the floor.
"""

import sympy as sp

from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

f = Parameter("f", "1", "sliding friction coefficient at the floor and the wall", 0.3, 0.0)
l = Parameter("l", "m", "half length of the bar", 1.0, 0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
m = Parameter("m", "kg", "mass of the bar", 1.0, 0.0, lower_open=True)
phi = Coordinate("phi", "rad", "angle of the bar from the vertical", float(sp.pi) / 4, 0.0,
                 float(sp.pi) / 2, symbol="\\varphi",
                 rate=Rate("omega", "rad s-1", "angular velocity of the bar", symbol="\\omega",
                           scale=sp.sqrt(g / l)))
xc = Coordinate("xc", "m", "horizontal position of the centre of the bar")
yc = Coordinate("yc", "m", "height of the centre of the bar")
s, c = sp.sin(phi), sp.cos(phi)

SYSTEM = System(
    "ladder_declared", "Ladder (declared): a bar against a rough wall and a rough floor",
    "Lapshin V.V. (2021), Herald of the Bauman Moscow State Technical University, Series "
    "Natural Sciences, no. 6 (99), pp. 4-16, Fig. 1",
    coordinates=(phi, xc, yc), parameters=(f, l, g, m),
    bodies=(Body(m, (xc, yc), inertia=m * l**2 / 3, angle=phi),),
    potential=m * g * yc,
    contacts=(PointContact("floor", (xc + l * s, yc - l * c), normal=(0, 1), friction=f),
              PointContact("wall", (xc - l * s, yc + l * c), normal=(1, 0), friction=f)),
    default_axes={"phi": (0.0, float(sp.pi) / 2, 512), "f": (0.0, 3.0, 512)},
)
