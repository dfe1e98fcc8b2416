"""Systems phasemap has never seen, declared with the public API (issue 23)."""
import sympy as sp
from phasemap.declare import (Body, Coordinate, EdgeContact, Parameter, PointContact, Rate,
                              RollingContact, System)

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

def drawer():
    """A drawer tilted in a slot (issue 37): a rectangle of half length a and half width c
    at the tilt psi (a parameter), its corner (a, c) against the upper guide y = w and its
    corner (-a, -c) against the lower guide y = -w, w = a sin psi + c cos psi, both rough
    and one-sided; pushed into the slot (along -x) with the force p at the handle, the
    point (a, -d) of the drawer (d below its centre line).  ``phi`` is the drawer's turn
    from the tilt, fixed (0) while both corners touch."""
    f, _, g, m = _common()
    a = Parameter("a", "m", "half length", 0.5, 0.0, lower_open=True)
    c = Parameter("c", "m", "half width", 0.25, 0.0, lower_open=True)
    psi = Parameter("psi", "rad", "tilt", 0.3, 0.0, 1.2, lower_open=True)
    d = Parameter("d", "m", "handle below the centre line", 0.1, -1.0, 1.0)
    p = Parameter("p", "N", "push on the handle", 10.0, 0.0)
    x = Coordinate("x", "m", "centre along the slot",
                   rate=Rate("xdot", "m s-1", "velocity along the slot", scale=sp.sqrt(g * a)))
    y = Coordinate("y", "m", "centre across the slot")
    phi = Coordinate("phi", "rad", "turn from the tilt", 0.0)
    th = psi + phi
    # cos and sin of th written out, so that closing the guides solves for phi's
    cth = sp.cos(psi) * sp.cos(phi) - sp.sin(psi) * sp.sin(phi)
    sth = sp.sin(psi) * sp.cos(phi) + sp.cos(psi) * sp.sin(phi)
    w = a * sp.sin(psi) + c * sp.cos(psi)
    ux, uy = a * cth - c * sth, a * sth + c * cth
    return System("drawer", "a drawer tilted in a slot, pushed at its handle", "test",
                  coordinates=(x, y, phi), parameters=(f, a, c, psi, d, p, g, m),
                  bodies=(Body(m, (x, y), inertia=m * (a**2 + c**2) / 3, angle=th),),
                  potential=m * g * y,
                  forces={x: -p, phi: p * (a * sth - d * cth)},
                  contacts=(PointContact("upper", (x + ux, y + uy), normal=(0, -1), offset=-w,
                                         friction=f),
                            PointContact("lower", (x - ux, y - uy), normal=(0, 1), offset=-w,
                                         friction=f)))


def peg_rod():
    """A rod (half length l) with its end A against a rough wall x = 0, lying on a rough
    peg, the fixed corner (p, 0) (issue 37): A = (0, -p tan theta), theta the rod's angle
    above the horizontal; the peg must lie on the rod (p / cos theta <= 2 l)."""
    f, l, g, m = _common()
    p = Parameter("p", "m", "distance of the peg from the wall", 0.8, 0.0, lower_open=True)
    th = Coordinate("theta", "rad", "angle of the rod above the horizontal", 0.5, 0.0, 1.0,
                    rate=Rate("omega", "rad s-1", "angular velocity", scale=sp.sqrt(g / l)))
    xa = Coordinate("xa", "m", "end A across the wall")
    ya = Coordinate("ya", "m", "end A along the wall")
    return System("peg_rod", "rod against a rough wall lying on a rough peg", "test",
                  coordinates=(th, xa, ya), parameters=(f, l, p, g, m),
                  bodies=(Body(m, (xa + l * sp.cos(th), ya + l * sp.sin(th)),
                               inertia=m * l**2 / 3, angle=th),),
                  potential=m * g * (ya + l * sp.sin(th)),
                  contacts=(PointContact("wall", (xa, ya), normal=(1, 0), friction=f),
                            EdgeContact("peg", (xa, ya), corner=(p, 0), angle=th, friction=f,
                                        extent=(0, 2 * l))))


def barrow(seed: int):
    """A wheelbarrow resting on its handles, of random structure (issue 37: two contacts,
    one of them rolling): a disc (radius r, mass m, its centre of mass l_w from its centre A,
    radius of gyration k) rolls with rolling friction delta on a rough floor; a uniform
    rod (length L, mass mu m) hinged at A trails behind it with its end B sliding on the
    floor with friction f, at the fixed angle asin(r / L) while both contacts hold; a
    motor torque tau turns the wheel.  Both contacts kept leave one degree of freedom, the
    wheel's clockwise angle phi; B slides at r phi'.  Returns the System and its random
    structure, for :func:`oracles.barrow`."""
    import numpy as np

    rng = np.random.default_rng(seed)
    lw = sp.Rational(int(rng.integers(0, 80)), 100)          # in r
    k2 = sp.Rational(int(rng.integers(20, 100)), 100)        # in r^2
    mu = sp.Rational(int(rng.integers(20, 200)), 100)        # rod mass, in m
    # in r, with sin theta = 1 / L rational and cos theta too (a Pythagorean triple), so
    # that sympy's closure of the handles' angle is a rational number
    L = sp.Rational(*[(5, 3), (13, 5), (25, 7), (17, 8), (29, 20), (41, 9)][rng.integers(6)])
    tau = sp.Rational(int(rng.integers(-50, 50)), 100)       # in m g r
    f = Parameter("f", "1", "friction coefficient of the handles", 0.5, 0.0)
    delta = Parameter("delta", "m", "rolling friction coefficient", 0.05, 0.0)
    r = Parameter("r", "m", "radius of the wheel", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", 9.81, 0.0)
    m = Parameter("m", "kg", "mass of the wheel", 1.0, 0.0, lower_open=True)
    phi = Coordinate("phi", "rad", "clockwise angle of the wheel", 0.0,
                     rate=Rate("omega", "rad s-1", "angular velocity of the wheel",
                               scale=sp.sqrt(g / r)))
    xa, ya = Coordinate("xa", "m", "wheel centre, x"), Coordinate("ya", "m", "wheel centre, y")
    th = Coordinate("theta", "rad", "angle of the handles to the floor", 0.5, 0.0, PI / 2,
                    lower_open=True)
    Cw = (xa - lw * r * sp.sin(phi), ya - lw * r * sp.cos(phi))
    Cr = (xa - L * r / 2 * sp.cos(th), ya - L * r / 2 * sp.sin(th))
    B = (xa - L * r * sp.cos(th), ya - L * r * sp.sin(th))
    system = System(
        f"barrow_{seed}", "a random wheelbarrow on its handles", "test",
        coordinates=(phi, xa, ya, th), parameters=(f, delta, r, g, m),
        bodies=(Body(m, Cw, inertia=m * k2 * r**2, angle=-phi),
                Body(mu * m, Cr, inertia=mu * m * (L * r) ** 2 / 12, angle=th)),
        potential=m * g * Cw[1] + mu * m * g * Cr[1], forces={phi: tau * m * g * r},
        contacts=(RollingContact("wheel", (xa, ya), radius=r, angle=-phi, normal=(0, 1),
                                 rolling_friction=delta),
                  PointContact("handles", B, normal=(0, 1), friction=f)))
    structure = {"lw": float(lw), "k": float(sp.sqrt(k2)), "mu": float(mu), "L": float(L),
                 "tau": float(tau)}
    return system, structure
