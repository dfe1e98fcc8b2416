"""Your own system in 30 lines: the classic Painleve rod, declared, mapped and moved.

The parameters and coordinates are those of the built-in rod, declared one a
line in ``phasemap/systems/painleve_rod.py`` (``Parameter("f", "1", "friction
coefficient at the floor", default=0.5, lower=0.0)``, ``Coordinate("theta", ...,
rate=Rate("omega", ...))``; the user guide's "Declaring a system" writes them
all out); this file declares a system of its own with them: the body, its
potential and the floor contact.

With its other end B declared as a second contact (open at the start), the same rod
falls, lands on B and comes to rest on the floor: the motion goes on through the
contact change in full coordinates (the user guide's "Motion through contact changes").

Run:  python docs/examples/own_system.py   (writes own_system_map.png,
own_system_motion.png and own_system_rest.png)
"""

import dataclasses
import math

import numpy as np
import sympy as sp

import phasemap
from phasemap.declare import Body, PointContact, System
from phasemap.systems.painleve_rod import f, g, l, m, theta, x, y

SYSTEM = System(
    "my_rod", "A uniform rod with one end on a rough floor", "Painleve (1895)",
    coordinates=(theta, x, y), parameters=(f, l, g, m),
    bodies=(Body(m, (x + l * sp.cos(theta), y + l * sp.sin(theta)),
                 inertia=m * l**2 / 3, angle=theta),),
    potential=m * g * (y + l * sp.sin(theta)),
    contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f),),
)

if __name__ == "__main__":
    model = SYSTEM.model                       # derived once, then loaded from the cache
    scene = phasemap.Scene(model, axes={"theta": np.linspace(0.02, 1.55, 400),
                                        "f": np.linspace(0.0, 2.5, 400)},
                           fixed={"xdot": -1.0, "omega": 0.0})
    atlas = scene.compute()
    fig = atlas.phasemap.plot()
    fig.savefig("own_system_map.png", dpi=300)
    motion = phasemap.simulate(model, theta=1.0, omega=0.0, xdot=1.0, f=0.3, t_end=2.0)
    fig = motion.phasemap.plot(phase_plane=True)   # theta against omega, events marked
    fig.savefig("own_system_motion.png", dpi=300)
    print(atlas.n_solutions.attrs["long_name"], "and", motion.attrs["end_reason"])
    # the rod with both ends declared: it lands on B and comes to rest on the floor
    end_b = PointContact("B", point=(x + 2 * l * sp.cos(theta), y + 2 * l * sp.sin(theta)),
                         normal=(0, 1), friction=f)
    both = dataclasses.replace(SYSTEM, name="my_rod_both_ends",
                               contacts=SYSTEM.contacts + (end_b,),
                               coordinates=(dataclasses.replace(theta, lower=-math.inf), x, y))
    rest = phasemap.simulate(both, theta=1.0, omega=0.0, xdot=1.0, f=0.3, t_end=2.0,
                             t_eval=np.linspace(0.0, 2.0, 401))
    fig = rest.phasemap.strip()                # outlines in time, reactions and impulse
    fig.savefig("own_system_rest.png", dpi=300)
    print("with end B:", [phasemap.Event(int(k)).name.lower() for k in rest.event_kind.values])
