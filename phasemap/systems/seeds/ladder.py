"""The ladder of Lapshin (2021, Fig. 1): a bar against a rough wall and a rough floor.

This declaration is what runs as ``ladder``; the hand derivation with the paper's
equations and errata (tests/references/ladder.py) checks it in the tests; its first
integral runs from closed_forms.py.
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
    "ladder", "Homogeneous bar (ladder) against a rough wall and a rough floor",
    "Lapshin V.V. (2021), Herald of the Bauman Moscow State Technical University, Series "
    "Natural Sciences, no. 6 (99), pp. 4-16, Fig. 1, eq. (6)-(8). "
    "doi:10.18698/1812-3368-2021-6-4-16",
    coordinates=(phi, xc, yc), parameters=(f, l, g, m),
    bodies=(Body(m, (xc, yc), inertia=m * l**2 / 3, angle=phi),),
    potential=m * g * yc,
    contacts=(PointContact("floor", (xc + l * s, yc - l * c), normal=(0, 1), friction=f),
              PointContact("wall", (xc - l * s, yc + l * c), normal=(1, 0), friction=f)),
    default_axes={"phi": (0.0, float(sp.pi) / 2, 512), "f": (0.0, 3.0, 512)},
    edges={"phi": ("the bar stands upright against the wall", "the bar lies flat on the floor")},
    names={"floor_slip_pos_wall_slip_pos": "slide_pos",
           "floor_slip_neg_wall_slip_neg": "slide_neg"},
)
