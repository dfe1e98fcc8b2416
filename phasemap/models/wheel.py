r"""Wheel: a disc with a displaced centre of mass and rolling friction (Lapshin 2021, Fig. 2).

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

from .._numerics import (
    ADMISSIBLE,
    COEF,
    CONTACT_LOST,
    CONTINUUM,
    FIRST_ACC,
    INADMISSIBLE,
    NO_SOLUTION,
    SINGULAR,
    STATUS,
    TOL,
    clear,
    is_zero,
    restrict_affine,
    start_interval,
)
from ..model import Derived, Dynamics, Model, Variable

ROLL_POS, ROLL_NEG, STICK = 0, 1, 2
PHI_DDOT = FIRST_ACC
N_NORMAL = FIRST_ACC + 1
F_TANGENT = FIRST_ACC + 2


@njit(cache=True, error_model="numpy")
def _roll(row, sigma, from_rest, omega, delta, r, l, rho, g, m, sp, cp):
    """Fill one rolling branch (direction sigma) from (13) and the no-bounce condition."""
    w2 = omega * omega
    coef = rho * rho + r * r + l * l - 2.0 * r * l * cp + delta * sigma * l * sp
    coef_scale = rho * rho + r * r + l * l + 2.0 * r * l + delta * l
    row[COEF] = coef
    rhs = -l * (r * sp + delta * sigma * cp) * w2 - g * l * sp - delta * sigma * g
    rhs_scale = l * (r + delta) * w2 + g * l + delta * g
    n0, dn = m * (g + l * cp * w2), m * l * sp
    if is_zero(coef, coef_scale):
        row[SINGULAR] = 1.0
        if not is_zero(rhs, rhs_scale):
            row[STATUS] = NO_SOLUTION
            return
        lo, hi = start_interval(from_rest, sigma)
        lo, hi = restrict_affine(n0, dn, lo, hi)
        row[STATUS] = CONTINUUM if lo < hi else CONTACT_LOST
        return
    a = rhs / coef
    n = n0 + dn * a
    row[PHI_DDOT] = a
    row[N_NORMAL] = n
    row[F_TANGENT] = m * ((r - l * cp) * a + l * sp * w2)
    if from_rest and not (sigma * a > TOL * rhs_scale / abs(coef)):
        row[STATUS] = INADMISSIBLE
        return
    if n < -TOL * m * (g + l * w2 + l * abs(a)):
        row[STATUS] = CONTACT_LOST
    else:
        row[STATUS] = ADMISSIBLE


@njit(cache=True, error_model="numpy")
def _stick(row, delta, l, g, m, sp):
    """Fill the stick branch: rest is possible iff l |sin phi| <= delta (15)."""
    if g * (delta - l * abs(sp)) >= -TOL * g * (delta + l):
        row[STATUS] = ADMISSIBLE
        row[PHI_DDOT] = 0.0
        row[N_NORMAL] = m * g
        row[F_TANGENT] = 0.0
    else:
        row[STATUS] = INADMISSIBLE


@njit(cache=True, error_model="numpy")
def point(v, out):
    """Classify one state. ``v`` = (phi, omega, delta, r, l, rho, g, m, sin phi, cos phi)."""
    omega, delta, r, l, rho, g, m = v[1], v[2], v[3], v[4], v[5], v[6], v[7]
    sp, cp = v[8], v[9]
    clear(out)
    if is_zero(omega, math.sqrt(g / r)):
        _roll(out[ROLL_POS], 1.0, True, 0.0, delta, r, l, rho, g, m, sp, cp)
        _roll(out[ROLL_NEG], -1.0, True, 0.0, delta, r, l, rho, g, m, sp, cp)
        _stick(out[STICK], delta, l, g, m, sp)
    elif omega > 0.0:
        _roll(out[ROLL_POS], 1.0, False, omega, delta, r, l, rho, g, m, sp, cp)
    else:
        _roll(out[ROLL_NEG], -1.0, False, omega, delta, r, l, rho, g, m, sp, cp)


def _check(values) -> None:
    l, r = np.asarray(values["l"], float), np.asarray(values["r"], float)
    if np.any(l > r):
        raise ValueError(
            "wheel: l (offset of the centre of mass) must not exceed r (radius): "
            f"got l = {np.max(l):g}, r = {np.min(r):g}; the centre of mass lies in the disc"
        )



@njit(cache=True, error_model="numpy")
def branch(v, b, row):
    """Fill branch ``b`` along its stage: rolling direction +1, -1, or stick."""
    omega, delta, r, l, rho, g, m = v[1], v[2], v[3], v[4], v[5], v[6], v[7]
    sp, cp = v[8], v[9]
    if b == STICK:
        _stick(row, delta, l, g, m, sp)
    else:
        _roll(row, 1.0 if b == ROLL_POS else -1.0, False, omega, delta, r, l, rho, g, m, sp, cp)


@njit(cache=True, error_model="numpy")
def derive(v):
    """Fill sin phi and cos phi."""
    v[8] = math.sin(v[0])
    v[9] = math.cos(v[0])


MODEL = Model(
    name="wheel",
    title="Disc with a displaced centre of mass, rolling with rolling friction",
    citation="Lapshin V.V. (2021), Herald of the Bauman Moscow State Technical University, "
    "Series Natural Sciences, no. 6 (99), pp. 4-16, Fig. 2, eq. (10)-(15). "
    "doi:10.18698/1812-3368-2021-6-4-16",
    state=(
        Variable("phi", "rad", "rotation angle of the disc (phi = 0: centre of mass lowest)",
                 "\\varphi", 0.0),
        Variable("omega", "rad s-1", "angular velocity of the disc", "\\omega", 0.0),
    ),
    params=(
        Variable("delta", "m", "rolling friction coefficient", "\\delta", 0.05, 0.0),
        Variable("r", "m", "radius of the disc", "r", 1.0, 0.0, lower_open=True),
        Variable("l", "m", "distance from the disc centre to the centre of mass", "l", 0.5,
                 0.0),
        Variable("rho", "m", "radius of gyration about the centre of mass", "\\rho", 0.5, 0.0,
                 lower_open=True),
        Variable("g", "m s-2", "gravitational acceleration", "g", 9.81, 0.0),
        Variable("m", "kg", "mass of the disc", "m", 1.0, 0.0, lower_open=True),
    ),
    derived=(Derived("sin_phi", "phi", np.sin), Derived("cos_phi", "phi", np.cos)),
    branches=("roll_pos", "roll_neg", "stick"),
    stick_branch=STICK,
    accelerations=(
        Variable("phi_ddot", "rad s-2", "angular acceleration of the disc", "\\ddot\\varphi"),
    ),
    reactions=(
        Variable("N", "N", "normal reaction of the floor", "N"),
        Variable("F", "N", "horizontal contact force on the disc", "F"),
    ),
    coefficient=Variable("coef", "m2",
                         "coefficient rho^2 + r^2 + l^2 - 2 r l cos(phi) + delta l sin(phi) sgn(omega)"
                         " of the angular acceleration", "J"),
    velocity="omega",
    point=point,
    dynamics=Dynamics(coordinates=(("phi", "omega", "phi_ddot"),), branch=branch,
                      derive=derive, directions=(1.0, -1.0, 0.0)),
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
