"""Your own system in 30 lines: the classic Painleve rod, declared, mapped and moved.

The parameters and coordinates are those of the built-in rod, declared one a
line in ``phasemap/systems/painleve_rod.py`` (``Parameter("f", "1", "friction
coefficient at the floor", default=0.5, lower=0.0)``, ``Coordinate("theta", ...,
rate=Rate("omega", ...))``; the user guide's "Declaring a system" writes them
all out); this file declares a system of its own with them: the body, its
potential and the floor contact.

Run:  python docs/examples/own_system.py   (writes own_system_map.png, own_system_motion.png)
"""

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
    print(atlas.n_solutions.attrs["long_name"], "and", motion.attrs.get("fate", ""))
