"""Systems phasemap has never seen, declared with the public API (issue 23)."""
import math
import sympy as sp
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

PI = float(sp.pi)

def _common():
    f = Parameter("f", "1", "friction coefficient", 0.5, 0.0)
    l = Parameter("l", "m", "half length", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    return f, l, g, m

def gyration_rod():
    f, l, g, m = _common()
    k = Parameter("k", "m", "radius of gyration about the centre", 0.6, 0.0, lower_open=True)
    th = Coordinate("theta", "rad", "angle of the rod to the floor", 1.0, 0.0, PI,
                    rate=Rate("omega", "rad s-1", "angular velocity", scale=sp.sqrt(g / l)))
    x = Coordinate("x", "m", "end A along the floor",
                   rate=Rate("xdot", "m s-1", "velocity of end A", scale=sp.sqrt(g * l)))
    y = Coordinate("y", "m", "height of end A")
    return System("gyration_rod", "rod with a radius of gyration", "test",
                  coordinates=(th, x, y), parameters=(f, l, k, g, m),
                  bodies=(Body(m, (x + l * sp.cos(th), y + l * sp.sin(th)), inertia=m * k**2,
                               angle=th),),
                  potential=m * g * (y + l * sp.sin(th)),
                  contacts=(PointContact("A", (x, y), normal=(0, 1), friction=f),))

def corner_block():
    f, _, g, m = _common()
    a = Parameter("a", "m", "half width", 0.5, 0.0, lower_open=True)
    b = Parameter("b", "m", "half height", 1.0, 0.0, lower_open=True)
    al = Parameter("alpha", "rad", "incline angle", 0.3, 0.0, 1.2)
    psi = Coordinate("psi", "rad", "tilt of the block's bottom to the incline", 0.5, 0.0, PI / 2,
                     rate=Rate("omega", "rad s-1", "angular velocity", scale=sp.sqrt(g / b)))
    s = Coordinate("s", "m", "corner along the incline",
                   rate=Rate("sdot", "m s-1", "corner velocity", scale=sp.sqrt(g * b)))
    h = Coordinate("h", "m", "corner above the incline")
    t, n = (sp.cos(al), sp.sin(al)), (-sp.sin(al), sp.cos(al))
    P = (s * t[0] + h * n[0], s * t[1] + h * n[1])
    th = al + psi
    C = (P[0] + a * sp.cos(th) - b * sp.sin(th), P[1] + a * sp.sin(th) + b * sp.cos(th))
    return System("corner_block", "block on its corner on a rough incline", "test",
                  coordinates=(psi, s, h), parameters=(f, a, b, al, g, m),
                  bodies=(Body(m, C, inertia=m * (a**2 + b**2) / 3, angle=th),),
                  potential=m * g * C[1],
                  contacts=(PointContact("corner", P, normal=n, friction=f),))

def leaning_ladder(lower=None):
    _, l, g, m = _common()
    f1 = Parameter("f1", "1", "friction at the floor", 0.4, 0.0)
    f2 = Parameter("f2", "1", "friction at the wall", 0.4, 0.0)
    be = Parameter("beta", "rad", "lean of the wall back from the vertical", 0.2, 0.0, 0.5)
    phi = Coordinate("phi", "rad", "angle of the ladder from the vertical", 0.7,
                     be if lower is None else lower, PI / 2,
                     rate=Rate("omega", "rad s-1", "angular velocity", scale=sp.sqrt(g / l)))
    xc = Coordinate("xc", "m", "centre x")
    yc = Coordinate("yc", "m", "centre y")
    s, c = sp.sin(phi), sp.cos(phi)
    return System("leaning_ladder", "ladder against a wall leaning back", "test",
                  coordinates=(phi, xc, yc), parameters=(f1, f2, be, l, g, m),
                  bodies=(Body(m, (xc, yc), inertia=m * l**2 / 3, angle=phi),),
                  potential=m * g * yc,
                  contacts=(PointContact("floor", (xc + l * s, yc - l * c), normal=(0, 1),
                                         friction=f1),
                            PointContact("wall", (xc - l * s, yc + l * c),
                                         normal=(sp.cos(be), sp.sin(be)), friction=f2)))

def ledge_rod(theta=0.5):
    f, l, g, m = _common()
    h = Parameter("h", "m", "height of the ledge", 1.0, 0.0, 2.0)
    th = Coordinate("theta", "rad", "angle of the rod to the floor", theta)
    x = Coordinate("x", "m", "end A along the floor",
                   rate=Rate("xdot", "m s-1", "velocity of the rod", scale=sp.sqrt(g * l)))
    y = Coordinate("y", "m", "height of end A")
    B = (x + 2 * l * sp.cos(th), y + 2 * l * sp.sin(th))
    return System("ledge_rod", "rod from floor to ledge", "test",
                  coordinates=(th, x, y), parameters=(f, l, h, g, m),
                  bodies=(Body(m, (x + l * sp.cos(th), y + l * sp.sin(th)), inertia=m * l**2 / 3,
                               angle=th),),
                  potential=m * g * (y + l * sp.sin(th)),
                  contacts=(PointContact("A", (x, y), normal=(0, 1), friction=f),
                            PointContact("B", B, normal=(0, 1), offset=h, friction=f)))

def flat_block():
    f, _, g, m = _common()
    a = Parameter("a", "m", "half width", 0.5, 0.0, lower_open=True)
    b = Parameter("b", "m", "half height", 0.3, 0.0, lower_open=True)
    al = Parameter("alpha", "rad", "incline angle", 0.3, 0.0, 1.2)
    th = Coordinate("theta", "rad", "angle of the block", 0.3)
    s = Coordinate("s", "m", "centre along the incline",
                   rate=Rate("sdot", "m s-1", "velocity along the incline"))
    hh = Coordinate("h", "m", "centre above the incline")
    t, n = (sp.cos(al), sp.sin(al)), (-sp.sin(al), sp.cos(al))
    C = (s * t[0] + hh * n[0], s * t[1] + hh * n[1])
    def corner(u, v):
        return (C[0] + u * sp.cos(th) - v * sp.sin(th), C[1] + u * sp.sin(th) + v * sp.cos(th))
    return System("flat_block", "block lying flat on an incline", "test",
                  coordinates=(th, s, hh), parameters=(f, a, b, al, g, m),
                  bodies=(Body(m, C, inertia=m * (a**2 + b**2) / 3, angle=th),),
                  potential=m * g * C[1],
                  contacts=(PointContact("left", corner(-a, -b), normal=n, friction=f),
                            PointContact("right", corner(a, -b), normal=n, friction=f)))

def incline_point():
    f, _, g, m = _common()
    al = Parameter("alpha", "rad", "incline angle", 0.4, 0.0, 1.5)
    x = Coordinate("x", "m", "position", rate=Rate("xdot", "m s-1", "velocity"))
    y = Coordinate("y", "m", "height")
    return System("incline", "point block on an incline", "test",
                  coordinates=(x, y), parameters=(f, al, g, m),
                  bodies=(Body(m, (x, y)),), potential=m * g * y,
                  contacts=(PointContact("P", (x, y), normal=(-sp.sin(al), sp.cos(al)), friction=f),))
