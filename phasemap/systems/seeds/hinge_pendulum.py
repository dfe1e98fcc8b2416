"""The pendulum with dry friction in its hinge (Lapshin 2021), declared: a point mass on a
weightless rod whose hinge has a friction moment delta |R|.  The hand derivation
(phasemap.systems.hinge_pendulum) runs; this is its twin.  The pivot (xp, yp) is a
coordinate of the weightless rod, fixed by the joint.

Its branches carry the hand module's names: the squared friction law has two roots
per direction, and the one that can satisfy the unsquared law (``M`` opposing the
rotation) is the hand module's ``turn_pos`` (the first root) or ``turn_neg`` (the
second); the other root of each is ``turn_pos_other_root``, ``turn_neg_other_root``,
admissible only where the hinge's reaction vanishes.  The reactions stay the joint's
(``Rx_hinge``, ``Ry_hinge`` in the fixed frame, and the moment ``M_hinge``): the hand
module's ``R_n``, ``R_t`` are components along and across the rod, not a renaming."""

import sympy as sp

from phasemap.declare import Body, Coordinate, Joint, Parameter, Rate, System

delta = Parameter("delta", "m", "hinge friction coefficient (a length)", 0.1, 0.0)
l = Parameter("l", "m", "length of the rod", 1.0, 0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
m = Parameter("m", "kg", "mass of the bob", 1.0, 0.0, lower_open=True)
phi = Coordinate("phi", "rad", "angle of the rod from the downward vertical", 0.0,
                 symbol="\\varphi", rate=Rate("omega", "rad s-1", "angular velocity of the rod",
                                              symbol="\\omega", scale=sp.sqrt(g / l)))
xp = Coordinate("xp", "m", "horizontal position of the rod's pivot end")
yp = Coordinate("yp", "m", "height of the rod's pivot end")
bob = (xp + l * sp.sin(phi), yp - l * sp.cos(phi))

SYSTEM = System(
    "hinge_pendulum_declared", "Pendulum with dry friction in its hinge (declared)",
    "Lapshin V.V. (2021), Herald of the Bauman Moscow State Technical University, Series "
    "Natural Sciences, no. 6 (99), pp. 4-16, Fig. 4",
    coordinates=(phi, xp, yp), parameters=(delta, l, g, m),
    bodies=(Body(m, bob),),
    potential=m * g * bob[1],
    contacts=(Joint("hinge", (xp, yp), angle=phi, friction_radius=delta),),
    names={"hinge_turn_pos": "turn_pos", "hinge_turn_neg_root2": "turn_neg",
           "hinge_turn_pos_root2": "turn_pos_other_root",
           "hinge_turn_neg": "turn_neg_other_root"},
    default_axes={"phi": (-float(sp.pi), float(sp.pi), 512), "delta": (0.0, 1.5, 512)},
)
