r"""Ladder: a homogeneous bar against a rough wall and a rough floor (Lapshin 2021, Fig. 1).

A test reference, not a system: ``ladder`` runs the declaration
phasemap.systems.seeds.ladder, which also counts leaving a contact.  This module keeps
the paper's equations, errata and closed forms, and checks the declaration in the tests
(``MODEL`` is a full Model).  The first integral below runs as
phasemap.systems.seeds.closed_forms.ladder_omega_squared.

Setup
-----
Bar of length 2l and mass m, inertia m l^2/3 about its centre C.  Floor y = 0,
wall x = 0, phi the angle from the vertical, phi in [0, pi/2]:
C = (l sin phi, l cos phi), bottom end on the floor at (2l sin phi, 0), top end
on the wall at (0, 2l cos phi).  The counter-clockwise rotation rate is phi_dot.
Both contacts are one-sided (N_floor >= 0, N_wall >= 0), with the same friction
coefficient f.

Derivation (cross-referenced to the paper's equations)
------------------------------------------------------
Let s = sgn(phi_dot).  For s = +1 the bottom end slides away from the wall and
the top end slides down, so friction acts in -x at the floor and +y at the
wall; s = -1 reverses both.  Momentum of C and angular momentum about C:

    m xc'' = N_wall - s f N_floor,        m yc'' = -m g + N_floor + s f N_wall,
    (m l^2/3) phi'' = (N_floor - s f N_wall) l sin phi - (N_wall + s f N_floor) l cos phi,

with the twice-differentiated constraints (7)
xc'' = l cos phi phi'' - l sin phi phi'^2, yc'' = -l sin phi phi'' - l cos phi phi'^2.
Solving the first two for the reactions (as printed after (7)) and using the
identities (g + yc'') sin phi - xc'' cos phi = g sin phi - l phi'' and
xc'' sin phi + (g + yc'') cos phi = g cos phi - l phi'^2 gives

    2 l (2 - f^2) phi'' = 3 [2 s f l phi'^2 - 2 s f g cos phi + (1 - f^2) g sin phi].   (8)

The paper prints (8) and the line above it without the length l (erratum).
The coefficient 2 - f^2 vanishes at f = sqrt 2: there (8) has no solution unless
its right side vanishes too (a continuum).

First integral.  With u = omega^2 and phi'' = u'/2, on a stage of constant s,
u' - lam u = A sin phi + B cos phi with lam = 6 s f/(2 - f^2), so
u = c e^{lam phi} + a sin phi + b cos phi with

    a = -6 s f g (5 - 4 f^2) / (l (4 + 32 f^2 + f^4)),
    b = -3 g (2 - 15 f^2 + f^4) / (l (4 + 32 f^2 + f^4)).

The paper prints b with -7 f^2 instead of -15 f^2 and omits l (errata).

Rest (the stick branch, phi' = phi'' = 0).  The static problem has four
reactions and three equations; it is solvable with |F| <= f N at both ends iff

    2 f cos phi - (1 - f^2) sin phi >= 0,   i.e.  phi <= 2 arctan f,

(the classical tan phi <= 2f/(1 - f^2) for f < 1; the whole range for f >= 1).
Ties go to rest.  The reactions at rest are statically indeterminate; phasemap
reports the ones at which both ends are equally close to slipping (friction
ratio tan(phi/2) at both): N_floor = m g cos^2(phi/2), N_wall = m g sin(phi)/2.

Branches: ``slide_pos`` (phi increasing), ``slide_neg`` and ``stick``.  At phi' = 0 a
slide branch starting in direction s needs s phi'' > 0 strictly.  At phi = 0 or
pi/2 one end has zero sliding velocity; phasemap keeps s = sgn(phi') there (the
limit from inside the range).
"""

from __future__ import annotations

import math

from numba import njit

from phasemap.core.numerics import (ADMISSIBLE, CONTACT_LOST, CONTINUUM, INADMISSIBLE, NAN,
                                NO_SOLUTION, TOL, is_zero, restrict_affine, start_interval)
from phasemap.core.model import Model, Variable, angle_state, gravity_and_mass, one_angle
from phasemap.systems.seeds import citation


@njit(cache=True, error_model="numpy", forceinline=True)
def slide(s, rest, omega, f, l, g, m, sin_phi, cos_phi):
    """One slide branch (direction s) from (8): (status, singular, 2 - f^2, phi'', N_floor, N_wall)."""
    sp, cp = sin_phi, cos_phi
    d = 2.0 - f * f
    w2 = omega * omega
    rhs = 3.0 * (2.0 * s * f * l * w2 - 2.0 * s * f * g * cp + (1.0 - f * f) * g * sp)
    rhs_scale = 3.0 * (2.0 * f * l * w2 + 2.0 * f * g + abs(1.0 - f * f) * g)
    # The reactions are affine in phi'': N = N0 + dN * phi''.
    inv = m / (1.0 + f * f)
    xdd0, dxdd = -l * sp * w2, l * cp
    ydd0, dydd = -l * cp * w2, -l * sp
    nf0, dnf = inv * (g + ydd0 - s * f * xdd0), inv * (dydd - s * f * dxdd)
    nw0, dnw = inv * (xdd0 + s * f * (g + ydd0)), inv * (dxdd + s * f * dydd)
    singular = is_zero(d, 2.0 + f * f)
    # Singular with a vanishing right side: the admissible family of phi''.
    lo, hi = start_interval(rest, s)
    lo, hi = restrict_affine(nf0, dnf, lo, hi)
    lo, hi = restrict_affine(nw0, dnw, lo, hi)
    family = CONTINUUM if lo < hi else CONTACT_LOST
    st_singular = family if is_zero(rhs, rhs_scale) else NO_SOLUTION
    a = rhs / (2.0 * l * d)
    nf = nf0 + dnf * a
    nw = nw0 + dnw * a
    start_ok = (not rest) | (s * a > TOL * rhs_scale / (2.0 * l * abs(d)))
    n_scale = inv * (g + l * w2 + l * abs(a)) * (1.0 + f)
    lost = (nf < -TOL * n_scale) | (nw < -TOL * n_scale)
    st = (CONTACT_LOST if lost else ADMISSIBLE) if start_ok else INADMISSIBLE
    return (st_singular if singular else st, 1.0 if singular else 0.0, d,
            NAN if singular else a, NAN if singular else nf, NAN if singular else nw)


@njit(cache=True, error_model="numpy", forceinline=True)
def stick(f, g, m, sin_phi, cos_phi):
    """The stick branch: rest is possible iff phi <= 2 arctan f."""
    sp, cp = sin_phi, cos_phi
    margin = g * (2.0 * f * cp - (1.0 - f * f) * sp)
    scale = g * (2.0 * f + abs(1.0 - f * f))
    ok = margin >= -TOL * scale
    return (ADMISSIBLE if ok else INADMISSIBLE, 0.0, NAN, 0.0 if ok else NAN,
            0.5 * m * g * (1.0 + cp) if ok else NAN, 0.5 * m * g * sp if ok else NAN)


@njit(cache=True, error_model="numpy", forceinline=True)
def velocity_scale(g, l):
    """The bar's natural rate sqrt(g / l): omega is zero below 1e-12 of it."""
    return math.sqrt(g / l)


MODEL = Model(
    name="ladder",
    title="Homogeneous bar (ladder) against a rough wall and a rough floor",
    citation=citation("Fig. 1, eq. (6)-(8)"),
    state=angle_state("bar", "angle of the bar from the vertical", math.pi / 4, 0.0,
                      math.pi / 2),
    params=(
        Variable("f", "1", "sliding friction coefficient at the floor and the wall", "f", 0.3,
                 0.0),
        Variable("l", "m", "half length of the bar", "l", 1.0, 0.0, lower_open=True),
        *gravity_and_mass("mass of the bar"),
    ),
    **one_angle("bar", "slide", slide, stick, velocity_scale,
                edges={"phi": ("the bar stands upright against the wall",
                               "the bar lies flat on the floor")}),
    reactions=(
        Variable("N_floor", "N", "normal reaction of the floor", "N_1"),
        Variable("N_wall", "N", "normal reaction of the wall", "N_2"),
    ),
    coefficient=Variable("coef", "1", "coefficient 2 - f^2 of the angular acceleration",
                         "2-f^2"),
    default_axes={"phi": (0.0, math.pi / 2, 512), "f": (0.0, 3.0, 512)},
)
