r"""Wheel: a disc with a displaced centre of mass and rolling friction (Lapshin 2021, Fig. 2).

A test reference, not a system: ``wheel`` runs the declaration
phasemap.systems.seeds.wheel, which also counts leaving a contact.  This module keeps the paper's equations, errata and
closed forms, and checks the declaration in the tests (``MODEL`` is a full Model).

Setup
-----
Disc of radius r and mass m rolling without slip on the floor y = 0.  Its
geometric centre is A = (r phi, r); phi is the clockwise rotation angle, so the
disc rolls to the right for phi' > 0.  The centre of mass is
C = (r phi - l sin phi, r - l cos phi) (phi = 0: C straight below A), and
J_c = m rho^2.  The rolling-friction couple has magnitude delta N and opposes
the rotation; the floor is one-sided (N >= 0).  phasemap requires
0 <= l <= r (the centre of mass lies in the disc) and rho > 0.

Derivation (cross-referenced to the paper's equations)
------------------------------------------------------
Kinematics (10): xc'' = (r - l cos phi) phi'' + l sin phi phi'^2,
yc'' = l sin phi phi'' + l cos phi phi'^2.  With F the horizontal contact force
on the disc, N the normal reaction and sigma = sgn(phi'), momentum of C and the
clockwise angular momentum about C give (11)

    m xc'' = F,   m yc'' = N - m g,
    m rho^2 phi'' = -delta N sigma - F (r - l cos phi) - N l sin phi.

Eliminating F and N:

    (rho^2 + r^2 + l^2 - 2 r l cos phi + delta sigma l sin phi) phi''
        = -l (r sin phi + delta sigma cos phi) phi'^2 - g l sin phi - delta sigma g.   (13)

The paper prints (13) with +l (r sin phi + ...) phi'^2 (sign erratum); its own
line before (13) and its first-integral equation have the right sign.  The
bracket (the coefficient of phi'') can vanish only when delta l |sin phi|
reaches rho^2 + (r - l)^2; there the branch is singular.

No bounce (12): N = m (g + l (sin phi phi'' + cos phi phi'^2)) >= 0.

Rest (stick branch, phi' = phi'' = 0): N = m g and the couple needed to hold
the disc is m g l sin phi, so rest is possible iff l |sin phi| <= delta (15),
ties to rest.  For delta >= l this holds at every angle.

First integral.  With u = omega^2 and phi'' = u'/2 on a stage of constant sigma:
bracket(phi) u' + 2 l (r sin phi + delta sigma cos phi) u = -2 g l sin phi - 2 delta sigma g.

Branches: ``roll_pos``, ``roll_neg`` and ``stick``.  From rest a roll branch in
direction sigma needs sigma phi'' > 0 strictly.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from phasemap.core.numerics import (ADMISSIBLE, CONTACT_LOST, CONTINUUM, INADMISSIBLE, NAN,
                                NO_SOLUTION, TOL, is_zero, restrict_affine, start_interval)
from phasemap.core.model import Model, Variable, angle_state, gravity_and_mass, one_angle
from phasemap.systems.seeds import citation


@njit(cache=True, error_model="numpy", forceinline=True)
def roll(sigma, rest, omega, delta, r, l, rho, g, m, sin_phi, cos_phi):
    """One rolling branch (direction sigma) from (13) and the no-bounce condition.

    Row: (status, singular, J, phi'', N, F).
    """
    sp, cp = sin_phi, cos_phi
    w2 = omega * omega
    coef = rho * rho + r * r + l * l - 2.0 * r * l * cp + delta * sigma * l * sp
    coef_scale = rho * rho + r * r + l * l + 2.0 * r * l + delta * l
    rhs = -l * (r * sp + delta * sigma * cp) * w2 - g * l * sp - delta * sigma * g
    rhs_scale = l * (r + delta) * w2 + g * l + delta * g
    n0, dn = m * (g + l * cp * w2), m * l * sp
    singular = is_zero(coef, coef_scale)
    lo, hi = start_interval(rest, sigma)
    lo, hi = restrict_affine(n0, dn, lo, hi)
    family = CONTINUUM if lo < hi else CONTACT_LOST
    st_singular = family if is_zero(rhs, rhs_scale) else NO_SOLUTION
    a = rhs / coef
    n = n0 + dn * a
    start_ok = (not rest) | (sigma * a > TOL * rhs_scale / abs(coef))
    lost = n < -TOL * m * (g + l * w2 + l * abs(a))
    st = (CONTACT_LOST if lost else ADMISSIBLE) if start_ok else INADMISSIBLE
    return (st_singular if singular else st, 1.0 if singular else 0.0, coef,
            NAN if singular else a, NAN if singular else n,
            NAN if singular else m * ((r - l * cp) * a + l * sp * w2))


@njit(cache=True, error_model="numpy", forceinline=True)
def stick(delta, l, g, m, sin_phi):
    """The stick branch: rest is possible iff l |sin phi| <= delta (15)."""
    ok = g * (delta - l * abs(sin_phi)) >= -TOL * g * (delta + l)
    return (ADMISSIBLE if ok else INADMISSIBLE, 0.0, NAN, 0.0 if ok else NAN,
            m * g if ok else NAN, 0.0 if ok else NAN)


@njit(cache=True, error_model="numpy", forceinline=True)
def velocity_scale(g, r):
    """The disc's natural rate sqrt(g / r): omega is zero below 1e-12 of it."""
    return math.sqrt(g / r)


def _check(values) -> None:
    l, r = np.asarray(values["l"], float), np.asarray(values["r"], float)
    if np.any(l > r):
        raise ValueError(
            "wheel: l (offset of the centre of mass) must not exceed r (radius): "
            f"got l = {np.max(l):g}, r = {np.min(r):g}; the centre of mass lies in the disc"
        )



MODEL = Model(
    name="wheel",
    title="Disc with a displaced centre of mass, rolling with rolling friction",
    citation=citation("Fig. 2, eq. (10)-(15)"),
    state=angle_state("disc", "rotation angle of the disc (phi = 0: centre of mass lowest)"),
    params=(
        Variable("delta", "m", "rolling friction coefficient", "\\delta", 0.05, 0.0),
        Variable("r", "m", "radius of the disc", "r", 1.0, 0.0, lower_open=True),
        Variable("l", "m", "distance from the disc centre to the centre of mass", "l", 0.5,
                 0.0),
        Variable("rho", "m", "radius of gyration about the centre of mass", "\\rho", 0.5, 0.0,
                 lower_open=True),
        *gravity_and_mass("mass of the disc"),
    ),
    **one_angle("disc", "roll", roll, stick, velocity_scale),
    reactions=(
        Variable("N", "N", "normal reaction of the floor", "N"),
        Variable("F", "N", "horizontal contact force on the disc", "F"),
    ),
    coefficient=Variable("coef", "m2",
                         "coefficient rho^2 + r^2 + l^2 - 2 r l cos(phi) + delta l sin(phi) sgn(omega)"
                         " of the angular acceleration", "J"),
    default_axes={"phi": (-math.pi, math.pi, 512), "delta": (0.0, 1.0, 512)},
    check=_check,
)


@njit(cache=True, error_model="numpy")
def omega_squared_slope(phi, u, sigma, delta, r, l, rho, g):
    """d(omega^2)/d(phi) at (phi, u = omega^2) on a rolling stage of sign sigma.

    The paper's first-integral equation, solved for the derivative:
    bracket u' = -2 l (r sin phi + delta sigma cos phi) u - 2 g l sin phi - 2 delta sigma g.
    """
    sp, cp = math.sin(phi), math.cos(phi)
    bracket = rho * rho + r * r + l * l - 2.0 * r * l * cp + delta * sigma * l * sp
    return (-2.0 * l * (r * sp + delta * sigma * cp) * u - 2.0 * g * l * sp
            - 2.0 * delta * sigma * g) / bracket


def random_state(rng):
    """A random state and parameters, as the tests draw them (a third at rest): a dict
    in the order ``phi, omega, delta, r, l, rho, g, m``."""
    r = rng.uniform(0.3, 2)
    l, rho, delta = rng.uniform(0, r), rng.uniform(0.1, 1.5), rng.uniform(0, 1.5) * r
    g, m = rng.uniform(0.5, 20), rng.uniform(0.1, 5)
    phi = rng.uniform(-2 * math.pi, 2 * math.pi)
    omega = 0.0 if rng.random() < 1 / 3 else rng.normal() * 3 * math.sqrt(g / r)
    return dict(phi=phi, omega=omega, delta=delta, r=r, l=l, rho=rho, g=g, m=m)
