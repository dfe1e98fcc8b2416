r"""Painleve's elliptic pendulum on a rough horizontal guide (Lapshin 2021, Fig. 3).

Setup
-----
Slider A (mass m, position x) on a rough horizontal guide y = 0, which is
two-sided: N may have either sign.  A weightless bar of length 2l, hinged
without friction at A, carries a point mass m at B = (x + 2l sin phi, -2l cos phi);
phi is measured from the downward vertical and increases counter-clockwise.
The centre of mass C is the bar's midpoint.  Friction on the slider (20):
F = -f |N| sgn(x').

Derivation (cross-referenced to the paper's equations)
------------------------------------------------------
Momentum of C (16), (17) and angular momentum about C, L_C = 2 m l^2 phi' (18):

    2 m (x'' + l cos phi phi'' - l sin phi phi'^2) = F,
    2 m l (sin phi phi'' + cos phi phi'^2) = N - 2 m g,
    2 m l^2 phi'' = -N l sin phi - F l cos phi.

Substituting the first two into the third:

    2 l phi'' + x'' cos phi + g sin phi = 0.                                   (19)

The paper prints 2 l phi' (a dropped derivative; erratum).  (19) is also the
angular momentum of the end mass about A.  With F = -k f N, k = sgn(N x') (21),
the three equations are linear in (x'', phi'', N); with
Q = g + l cos phi phi'^2 and lambda_k = 1 + sin^2 phi - k f sin phi cos phi (26):

    lambda_k N = 2 m Q,                                                        (23)
    lambda_k x'' = 2 l phi'^2 (sin phi - k f cos phi) - k f g (1 + cos^2 phi) + g sin phi cos phi,   (24)
    lambda_k l phi'' = Q (k f cos phi - sin phi).                              (25)

The paper prints (23) without m and (24) with a stray factor "g sin phi" after
k f g (1 + cos^2 phi) (errata); (25) and (26) are right.

Branches.  For x' != 0 with sigma = sgn x', the branch ``slide_pos_Npos`` (or
``slide_neg_Npos``) assumes N > 0, so k = sigma, and ``slide_pos_Nneg`` (or
``slide_neg_Nneg``) assumes N < 0, so k = -sigma; each is admissible iff its N has the
assumed sign.  N = 0 (Q = 0: no friction) is counted once, in the N > 0 branch.
At x' = 0 the stick branch (x'' = 0) gives l phi'' = -g sin phi / 2,
N = m (g (1 + cos^2 phi) + 2 l cos phi phi'^2), F = -m sin phi (g cos phi + 2 l phi'^2),
admissible iff |F| <= f |N| (ties to stick); a slide branch starting in
direction sigma needs sigma x'' > 0 strictly.

lambda_k = 0 is singular: (23) has no solution unless Q = 0, when every N of the
assumed sign solves it (a continuum).

Sharp threshold.  min over phi of lambda_k = (3 - sqrt(1 + f^2))/2, so lambda_k
can be negative, and the no-solution (x' > 0) and two-solution (x' < 0)
regions of phi in (0, pi/2) exist, iff f > 2 sqrt 2; the paper proves only
that they do not exist for f <= 2.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._numerics import (
    ADMISSIBLE,
    COEF,
    CONTINUUM,
    FIRST_ACC,
    INADMISSIBLE,
    NO_SOLUTION,
    SINGULAR,
    STATUS,
    TOL,
    clear,
    is_zero,
)
from ..model import Derived, Dynamics, Model, Variable

SLIDE_POS_NPOS, SLIDE_POS_NNEG, SLIDE_NEG_NPOS, SLIDE_NEG_NNEG, STICK = 0, 1, 2, 3, 4
X_DDOT = FIRST_ACC
PHI_DDOT = FIRST_ACC + 1
N_NORMAL = FIRST_ACC + 2
F_FRICTION = FIRST_ACC + 3


@njit(cache=True, error_model="numpy")
def _slide(row, sigma, rho, from_rest, omega, f, l, g, m, sp, cp):
    """Fill the slide branch with slider direction sigma and assumed sgn N = rho."""
    k = sigma * rho
    w2 = omega * omega
    lam = 1.0 + sp * sp - k * f * sp * cp
    row[COEF] = lam
    q = g + l * cp * w2
    q_scale = g + l * w2
    q_zero = is_zero(q, q_scale)
    if is_zero(lam, 2.0 + f):
        row[SINGULAR] = 1.0
        if not q_zero:
            row[STATUS] = NO_SOLUTION
            return
        # Every N with sgn N = rho solves the equations.  From rest x''(N) must
        # also have the sign sigma: from (17) and (19), with sin phi != 0 here,
        # x'' = -(N/(m sin phi) - 2 Q/sin phi + g sin phi)/cos phi is affine in N.
        if from_rest:
            x0 = (2.0 * q / sp - g * sp) / cp  # x'' at N = 0
            dx = -1.0 / (m * sp * cp)
            # sigma x'' > 0 for some N with rho N >= 0 (N > 0 for rho = -1)?
            ok = sigma * x0 > 0.0 or sigma * rho * dx > 0.0
            row[STATUS] = CONTINUUM if ok else INADMISSIBLE
        else:
            row[STATUS] = CONTINUUM
        return
    n = 2.0 * m * q / lam
    xdd = (2.0 * l * w2 * (sp - k * f * cp) - k * f * g * (1.0 + cp * cp) + g * sp * cp) / lam
    row[X_DDOT] = xdd
    row[PHI_DDOT] = q * (k * f * cp - sp) / (lam * l)
    row[N_NORMAL] = n
    row[F_FRICTION] = -k * f * n
    if rho > 0.0:
        sign_ok = q_zero or q * lam > 0.0
    else:
        sign_ok = (not q_zero) and q * lam < 0.0
    if not sign_ok:
        row[STATUS] = INADMISSIBLE
        return
    if from_rest:
        x_scale = (2.0 * l * w2 * (1.0 + f) + 2.0 * f * g + g) / abs(lam)
        if not (sigma * xdd > TOL * x_scale):
            row[STATUS] = INADMISSIBLE
            return
    row[STATUS] = ADMISSIBLE


@njit(cache=True, error_model="numpy")
def _stick(row, omega, f, l, g, m, sp, cp):
    """Fill the stick branch of the slider (x' = x'' = 0)."""
    w2 = omega * omega
    n = m * (g * (1.0 + cp * cp) + 2.0 * l * cp * w2)
    fr = -m * sp * (g * cp + 2.0 * l * w2)
    scale = m * (1.0 + f) * (2.0 * g + 2.0 * l * w2)
    row[X_DDOT] = 0.0
    row[PHI_DDOT] = -0.5 * g * sp / l
    row[N_NORMAL] = n
    row[F_FRICTION] = fr
    if abs(fr) <= f * abs(n) + TOL * scale:
        row[STATUS] = ADMISSIBLE
    else:
        row[STATUS] = INADMISSIBLE


@njit(cache=True, error_model="numpy")
def point(v, out):
    """Classify one state. ``v`` = (phi, omega, xdot, f, l, g, m, sin phi, cos phi)."""
    omega, xdot, f, l, g, m, sp, cp = v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]
    clear(out)
    if is_zero(xdot, math.sqrt(g * l) + l * abs(omega)):
        _slide(out[SLIDE_POS_NPOS], 1.0, 1.0, True, omega, f, l, g, m, sp, cp)
        _slide(out[SLIDE_POS_NNEG], 1.0, -1.0, True, omega, f, l, g, m, sp, cp)
        _slide(out[SLIDE_NEG_NPOS], -1.0, 1.0, True, omega, f, l, g, m, sp, cp)
        _slide(out[SLIDE_NEG_NNEG], -1.0, -1.0, True, omega, f, l, g, m, sp, cp)
        _stick(out[STICK], omega, f, l, g, m, sp, cp)
    elif xdot > 0.0:
        _slide(out[SLIDE_POS_NPOS], 1.0, 1.0, False, omega, f, l, g, m, sp, cp)
        _slide(out[SLIDE_POS_NNEG], 1.0, -1.0, False, omega, f, l, g, m, sp, cp)
    else:
        _slide(out[SLIDE_NEG_NPOS], -1.0, 1.0, False, omega, f, l, g, m, sp, cp)
        _slide(out[SLIDE_NEG_NNEG], -1.0, -1.0, False, omega, f, l, g, m, sp, cp)



@njit(cache=True, error_model="numpy")
def branch(v, b, row):
    """Fill branch ``b`` along its stage: the slider direction and sgn N are the branch's."""
    omega, f, l, g, m, sp, cp = v[1], v[3], v[4], v[5], v[6], v[7], v[8]
    if b == STICK:
        _stick(row, omega, f, l, g, m, sp, cp)
    else:
        sigma = 1.0 if b <= SLIDE_POS_NNEG else -1.0
        rho = 1.0 if b == SLIDE_POS_NPOS or b == SLIDE_NEG_NPOS else -1.0
        _slide(row, sigma, rho, False, omega, f, l, g, m, sp, cp)


@njit(cache=True, error_model="numpy")
def derive(v):
    """Fill sin phi and cos phi."""
    v[7] = math.sin(v[0])
    v[8] = math.cos(v[0])


MODEL = Model(
    name="elliptic_pendulum",
    title="Painleve's elliptic pendulum: slider on a rough two-sided guide with a pendulum",
    citation="Painleve P. (1895), Lecons sur le frottement; Lapshin V.V. (2021), Herald of the "
    "Bauman Moscow State Technical University, Series Natural Sciences, no. 6 (99), "
    "pp. 4-16, Fig. 3, eq. (16)-(28). doi:10.18698/1812-3368-2021-6-4-16",
    state=(
        Variable("phi", "rad", "angle of the bar from the downward vertical", "\\varphi", 0.0),
        Variable("omega", "rad s-1", "angular velocity of the bar", "\\omega", 0.0),
        Variable("xdot", "m s-1", "velocity of the slider", "\\dot x", 0.0),
    ),
    params=(
        Variable("f", "1", "sliding friction coefficient of the guide", "f", 0.3, 0.0),
        Variable("l", "m", "half length of the bar", "l", 1.0, 0.0, lower_open=True),
        Variable("g", "m s-2", "gravitational acceleration", "g", 9.81, 0.0),
        Variable("m", "kg", "mass of the slider and of the end mass (each)", "m", 1.0, 0.0,
                 lower_open=True),
    ),
    derived=(Derived("sin_phi", "phi", np.sin), Derived("cos_phi", "phi", np.cos)),
    branches=("slide_pos_Npos", "slide_pos_Nneg", "slide_neg_Npos", "slide_neg_Nneg", "stick"),
    stick_branch=STICK,
    accelerations=(
        Variable("x_ddot", "m s-2", "acceleration of the slider", "\\ddot x"),
        Variable("phi_ddot", "rad s-2", "angular acceleration of the bar", "\\ddot\\varphi"),
    ),
    reactions=(
        Variable("N", "N", "normal reaction of the guide", "N"),
        Variable("F", "N", "friction force on the slider", "F"),
    ),
    coefficient=Variable("coef", "1",
                         "coefficient lambda = 1 + sin^2(phi) - k f sin(phi) cos(phi) of (23)-(25)",
                         "\\lambda"),
    velocity="xdot",
    point=point,
    dynamics=Dynamics(
        coordinates=(("x", "xdot", "x_ddot"), ("phi", "omega", "phi_ddot")),
        branch=branch, derive=derive, directions=(1.0, 1.0, -1.0, -1.0, 0.0),
        positions=(Variable("x", "m", "position of the slider along the guide", "x", 0.0),),
        stick_is_rest=False),
    default_axes={"phi": (-math.pi, math.pi, 512), "f": (0.0, 6.0, 512)},
)
