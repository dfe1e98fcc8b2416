"""The wheel of Lapshin (2021), declared: a disc with a displaced centre of mass rolling
with rolling friction.  The hand derivation (phasemap.models.wheel) runs; this checks it."""

import sympy as sp

from phasemap.declare import Body, Coordinate, Parameter, Rate, RollingContact, System

delta = Parameter("delta", "m", "rolling friction coefficient", 0.05, 0.0)
r = Parameter("r", "m", "radius of the disc", 1.0, 0.0, lower_open=True)
l = Parameter("l", "m", "distance from the disc centre to the centre of mass", 0.5, 0.0)
rho = Parameter("rho", "m", "radius of gyration about the centre of mass", 0.5, 0.0,
                lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
m = Parameter("m", "kg", "mass of the disc", 1.0, 0.0, lower_open=True)
phi = Coordinate("phi", "rad", "clockwise rotation angle of the disc", 0.0, symbol="\\varphi",
                 rate=Rate("omega", "rad s-1", "angular velocity of the disc",
                           symbol="\\omega", scale=sp.sqrt(g / r)))
xa = Coordinate("xa", "m", "horizontal position of the disc centre")
ya = Coordinate("ya", "m", "height of the disc centre")
C = (xa - l * sp.sin(phi), ya - l * sp.cos(phi))

SYSTEM = System(
    "wheel_declared", "Wheel (declared): a disc with a displaced centre of mass",
    "Lapshin V.V. (2021), Herald of the Bauman Moscow State Technical University, Series "
    "Natural Sciences, no. 6 (99), pp. 4-16, Fig. 2",
    coordinates=(phi, xa, ya), parameters=(delta, r, l, rho, g, m),
    bodies=(Body(m, C, inertia=m * rho**2, angle=-phi),),
    potential=m * g * C[1],
    contacts=(RollingContact("floor", (xa, ya), radius=r, angle=-phi, normal=(0, 1),
                             rolling_friction=delta),),
    default_axes={"phi": (-float(sp.pi), float(sp.pi), 512), "delta": (0.0, 1.0, 512)},
)
