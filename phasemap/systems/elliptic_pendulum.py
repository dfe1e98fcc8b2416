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

from phasemap.core.numerics import ADMISSIBLE, CONTINUUM, INADMISSIBLE, NAN, NO_SOLUTION, TOL, is_zero
from phasemap.core.model import (SIN_COS_PHI, Candidate, Dynamics, Model, Variable, angle_state,
                     angular_acceleration, gravity_and_mass)
from phasemap.systems.seeds import citation


@njit(cache=True, error_model="numpy", forceinline=True)
def slide(sigma, rho, rest, omega, f, l, g, m, sin_phi, cos_phi):
    """The slide branch with slider direction sigma and assumed sgn N = rho.

    Row: (status, singular, lambda_k, x'', phi'', N, F).
    """
    sp, cp = sin_phi, cos_phi
    k = sigma * rho
    w2 = omega * omega
    lam = 1.0 + sp * sp - k * f * sp * cp
    q = g + l * cp * w2
    q_zero = is_zero(q, g + l * w2)
    singular = is_zero(lam, 2.0 + f)
    # Singular: every N with sgn N = rho solves (23) when Q = 0.  From rest x''(N)
    # must also have the sign sigma: from (17) and (19), with sin phi != 0 here,
    # x'' = -(N/(m sin phi) - 2 Q/sin phi + g sin phi)/cos phi is affine in N;
    # sigma x'' > 0 for some N with rho N >= 0 (N > 0 for rho = -1)?
    x0 = (2.0 * q / sp - g * sp) / cp  # x'' at N = 0
    dx = -1.0 / (m * sp * cp)
    family = (not rest) | (sigma * x0 > 0.0) | (sigma * rho * dx > 0.0)
    st_singular = (CONTINUUM if family else INADMISSIBLE) if q_zero else NO_SOLUTION
    n = 2.0 * m * q / lam
    xdd = (2.0 * l * w2 * (sp - k * f * cp) - k * f * g * (1.0 + cp * cp) + g * sp * cp) / lam
    pdd = q * (k * f * cp - sp) / (lam * l)
    sign_ok = (q_zero | (q * lam > 0.0)) if rho > 0.0 else ((not q_zero) & (q * lam < 0.0))
    x_scale = (2.0 * l * w2 * (1.0 + f) + 2.0 * f * g + g) / abs(lam)
    start_ok = (not rest) | (sigma * xdd > TOL * x_scale)
    # a non-finite acceleration or reaction is never a solution
    finite = np.isfinite(xdd) & np.isfinite(pdd) & np.isfinite(n)
    st = (ADMISSIBLE if (sign_ok & start_ok) else INADMISSIBLE) if finite else NO_SOLUTION
    return (st_singular if singular else st, 1.0 if singular else 0.0, lam,
            NAN if singular else xdd, NAN if singular else pdd,
            NAN if singular else n, NAN if singular else -k * f * n)


@njit(cache=True, error_model="numpy", forceinline=True)
def stick(omega, f, l, g, m, sin_phi, cos_phi):
    """The stick branch of the slider (x' = x'' = 0): (status, 0, NaN, x'', phi'', N, F)."""
    sp, cp = sin_phi, cos_phi
    w2 = omega * omega
    n = m * (g * (1.0 + cp * cp) + 2.0 * l * cp * w2)
    fr = -m * sp * (g * cp + 2.0 * l * w2)
    scale = m * (1.0 + f) * (2.0 * g + 2.0 * l * w2)
    ok = abs(fr) <= f * abs(n) + TOL * scale
    pdd = -0.5 * g * sp / l
    st = (ADMISSIBLE if ok else INADMISSIBLE) if np.isfinite(pdd) & np.isfinite(n) & \
        np.isfinite(fr) else NO_SOLUTION
    return (st, 0.0, NAN, 0.0, pdd, n, fr)


@njit(cache=True, error_model="numpy", forceinline=True)
def velocity_scale(omega, l, g):
    """The slider's natural speed: xdot is zero below 1e-12 of it."""
    return math.sqrt(g * l) + l * abs(omega)


MODEL = Model(
    name="elliptic_pendulum",
    twin="phasemap.systems.seeds.elliptic_pendulum",
    title="Painleve's elliptic pendulum: slider on a rough two-sided guide with a pendulum",
    citation="Painleve P. (1895), Lecons sur le frottement; "
    + citation("Fig. 3, eq. (16)-(28)"),
    state=(
        *angle_state("bar", "angle of the bar from the downward vertical"),
        Variable("xdot", "m s-1", "velocity of the slider", "\\dot x", 0.0),
    ),
    params=(
        Variable("f", "1", "sliding friction coefficient of the guide", "f", 0.3, 0.0),
        Variable("l", "m", "half length of the bar", "l", 1.0, 0.0, lower_open=True),
        *gravity_and_mass("mass of the slider and of the end mass (each)"),
    ),
    derived=SIN_COS_PHI,
    candidates=(
        Candidate("slide_pos_Npos", 1.0, slide, (1.0, 1.0)),
        Candidate("slide_pos_Nneg", 1.0, slide, (1.0, -1.0)),
        Candidate("slide_neg_Npos", -1.0, slide, (-1.0, 1.0)),
        Candidate("slide_neg_Nneg", -1.0, slide, (-1.0, -1.0)),
        Candidate("stick", 0.0, stick),
    ),
    accelerations=(
        Variable("x_ddot", "m s-2", "acceleration of the slider", "\\ddot x"),
        angular_acceleration("bar"),
    ),
    reactions=(
        Variable("N", "N", "normal reaction of the guide", "N"),
        Variable("F", "N", "friction force on the slider", "F"),
    ),
    coefficient=Variable("coef", "1",
                         "coefficient lambda = 1 + sin^2(phi) - k f sin(phi) cos(phi) of (23)-(25)",
                         "\\lambda"),
    velocity="xdot",
    velocity_scale=velocity_scale,
    dynamics=Dynamics(
        coordinates=(("x", "xdot", "x_ddot"), ("phi", "omega", "phi_ddot")),
        positions=(Variable("x", "m", "position of the slider along the guide", "x", 0.0),),
        stick_is_rest=False),
    default_axes={"phi": (-math.pi, math.pi, 512), "f": (0.0, 6.0, 512)},
)
