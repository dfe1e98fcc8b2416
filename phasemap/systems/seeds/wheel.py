"""The wheel of Lapshin (2021, Fig. 2), as it runs: a disc with a displaced centre of mass
rolling with rolling friction.  The hand derivation with the paper's
equations (tests/references/wheel.py) checks it in the tests."""

import sympy as sp

from phasemap.declare import Body, Coordinate, Parameter, Rate, RollingContact, System
from phasemap.systems.seeds.checks import centre_of_mass_inside_the_disc

delta = Parameter("delta", "m", "rolling friction coefficient", 0.05, 0.0)
r = Parameter("r", "m", "radius of the disc", 1.0, 0.0, lower_open=True)
l = Parameter("l", "m", "distance from the disc centre to the centre of mass", 0.5, 0.0)
rho = Parameter("rho", "m", "radius of gyration about the centre of mass", 0.5, 0.0,
                lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
m = Parameter("m", "kg", "mass of the disc", 1.0, 0.0, lower_open=True)
omega = Rate("omega", "rad s-1", "angular velocity of the disc", symbol="\\omega",
             scale=sp.sqrt(g / r))
phi = Coordinate("phi", "rad", "rotation angle of the disc (phi = 0: centre of mass lowest)",
                 0.0, symbol="\\varphi", rate=omega)
xa, ya = Coordinate("xa", "m", "disc centre, x"), Coordinate("ya", "m", "disc centre, height")
C = (xa - l * sp.sin(phi), ya - l * sp.cos(phi))


SYSTEM = System(
    "wheel", "Disc with a displaced centre of mass, rolling with rolling friction",
    "Lapshin V.V. (2021), Herald of the Bauman Moscow State Technical University, Series "
    "Natural Sciences, no. 6 (99), pp. 4-16, Fig. 2, eq. (10)-(15). "
    "doi:10.18698/1812-3368-2021-6-4-16",
    coordinates=(phi, xa, ya), parameters=(delta, r, l, rho, g, m),
    bodies=(Body(m, C, inertia=m * rho**2, angle=-phi),),
    potential=m * g * C[1],
    contacts=(RollingContact("floor", (xa, ya), radius=r, angle=-phi, normal=(0, 1),
                             rolling_friction=delta),),
    default_axes={"phi": (-float(sp.pi), float(sp.pi), 512), "delta": (0.0, 1.0, 512)},
    check=centre_of_mass_inside_the_disc,
    names={"floor_roll_neg": "roll_pos", "floor_roll_pos": "roll_neg",
           "N_floor": "N", "F_floor": "F", "M_floor": "M"},
)
