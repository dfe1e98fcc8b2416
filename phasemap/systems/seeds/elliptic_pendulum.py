"""Painleve's elliptic pendulum, declared: a slider on a rough two-sided guide carrying a
pendulum.  The hand derivation (phasemap.systems.elliptic_pendulum) runs; this is its twin,
with its branch and reaction names (``slide_pos_Npos``..., ``N``, ``F``)."""

import sympy as sp

from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

f = Parameter("f", "1", "sliding friction coefficient of the guide", 0.3, 0.0)
l = Parameter("l", "m", "half length of the bar", 1.0, 0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
m = Parameter("m", "kg", "mass of the slider and of the end mass (each)", 1.0, 0.0,
              lower_open=True)
phi = Coordinate("phi", "rad", "angle of the bar from the downward vertical", 0.0,
                 symbol="\\varphi", rate=Rate("omega", "rad s-1", "angular velocity of the bar",
                                              symbol="\\omega", scale=sp.sqrt(g / l)))
omega = phi.rate
x = Coordinate("x", "m", "position of the slider",
               rate=Rate("xdot", "m s-1", "velocity of the slider", symbol="\\dot x",
                         scale=sp.sqrt(g * l) + l * sp.Abs(omega)))
y = Coordinate("y", "m", "height of the slider")
B = (x + 2 * l * sp.sin(phi), y - 2 * l * sp.cos(phi))

SYSTEM = System(
    "elliptic_pendulum_declared", "Painleve's elliptic pendulum (declared)",
    "Painleve P. (1895); Lapshin V.V. (2021), Herald of the Bauman Moscow State Technical "
    "University, Series Natural Sciences, no. 6 (99), pp. 4-16, Fig. 3",
    coordinates=(phi, x, y), parameters=(f, l, g, m),
    bodies=(Body(m, (x, y)), Body(m, B)),
    potential=m * g * y + m * g * B[1],
    contacts=(PointContact("guide", (x, y), normal=(0, 1), friction=f, sided="two"),),
    names={"guide_slip_pos_Npos": "slide_pos_Npos", "guide_slip_pos_Nneg": "slide_pos_Nneg",
           "guide_slip_neg_Npos": "slide_neg_Npos", "guide_slip_neg_Nneg": "slide_neg_Nneg",
           "N_guide": "N", "F_guide": "F"},
)
