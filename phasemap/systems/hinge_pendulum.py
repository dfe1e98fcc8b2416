r"""Pendulum with dry friction in its hinge (Lapshin 2021, Fig. 4).

Setup
-----
Point mass m on a weightless rod of length l, hinge O at the origin, phi from
the downward vertical.  The hinge friction moment is M = -delta |R| sgn(phi'),
with R the hinge reaction force and delta a length (29).  The hinge is
two-sided: it can push and pull.

Derivation (cross-referenced to the paper's equations)
------------------------------------------------------
Angular momentum about O (30): m l^2 phi'' = -m g l sin phi + M.  Newton's law
for the mass along the normal (towards O) and the tangent:

    m l phi'^2 = R_n - m g cos phi,   m l phi'' = R_t - m g sin phi.

The paper prints the tangential equation with -m g l sin phi (a spurious l;
erratum); (31) itself is right.  With Q_n = l phi'^2 + g cos phi and
u = l phi'' + g sin phi, |R| = m sqrt(Q_n^2 + u^2) and, for sigma = sgn(phi'),

    l u = -delta sigma sqrt(Q_n^2 + u^2).                                     (32)

Squaring gives (l^2 - delta^2) u^2 = delta^2 Q_n^2 (33), whose coefficient
l^2 - delta^2 is the coefficient of the senior derivative.  Every root of (33)
is tested against (32), which needs sgn u = -sigma:

* delta < l: u = -sigma delta |Q_n| / sqrt(l^2 - delta^2), one root (34); the
  other root of (33) is extraneous.
* delta = l (singular): (32) holds iff Q_n = 0, and then for every u with
  sigma u <= 0: a continuum.  Otherwise no solution.
* delta > l: (32) has the single solution u = 0 where Q_n = 0 (the hinge
  reaction vanishes, so does friction), and no solution anywhere else.  The
  paper says only "no solution for delta >= l".

Rest (stick branch, phi' = phi'' = 0): |R| = m g and the moment needed is
m g l sin phi, so rest is possible iff l |sin phi| <= delta, ties to rest.  For
delta < l this is the paper's |tan phi| <= delta / sqrt(l^2 - delta^2) (35);
for delta >= l it holds at every angle.

Weightless case g = 0: phi'' = -sigma k phi'^2, k = delta/sqrt(l^2 - delta^2)
(36), solved by omega = omega0/(1 + omega0 k t).

Branches: ``turn_pos``, ``turn_neg`` and ``stick``.  From rest a turn branch in
direction sigma needs sigma phi'' > 0 strictly.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from phasemap.core.numerics import ADMISSIBLE, CONTINUUM, INADMISSIBLE, NAN, NO_SOLUTION, TOL, is_zero
from phasemap.core.model import Model, Variable, angle_state, gravity_and_mass, one_angle
from phasemap.systems.seeds import citation


@njit(cache=True, error_model="numpy", forceinline=True)
def velocity_scale(g, l):
    """The pendulum's natural rate sqrt(g / l): omega is zero below 1e-12 of it."""
    return math.sqrt(g / l)


@njit(cache=True, error_model="numpy", forceinline=True)
def turn(sigma, rest, omega, delta, l, g, m, sin_phi, cos_phi):
    """One turning branch (direction sigma): the admissible root of (32).

    Row: (status, singular, l^2 - delta^2, phi'', R_n, R_t).
    """
    sp, cp = sin_phi, cos_phi
    w2 = omega * omega
    qn = l * w2 + g * cp
    qn_zero = is_zero(qn, l * w2 + g)
    coef = l * l - delta * delta
    singular = is_zero(coef, l * l + delta * delta)
    # Singular with qn = 0: every u with sigma u <= 0 solves (32); from rest
    # phi'' = (u - g sin phi)/l must also have the sign sigma, possible iff
    # sigma g sin phi < 0.
    family = (not rest) | (-sigma * g * sp > TOL * g)
    st_singular = (CONTINUUM if family else INADMISSIBLE) if qn_zero else NO_SOLUTION
    # Regular: for coef > 0 the root u of (32) with sigma u <= 0; for coef < 0
    # only qn = 0 (u = 0) solves it.
    solvable = (coef > 0.0) | qn_zero
    u = -sigma * delta * abs(qn) / math.sqrt(coef) if coef > 0.0 else 0.0
    a = (u - g * sp) / l
    start_ok = (not rest) | (sigma * a > TOL * (abs(u) + g) / l)
    # a non-finite acceleration or reaction is never a solution
    solvable = solvable & np.isfinite(a) & np.isfinite(m * qn) & np.isfinite(m * u)
    st = (ADMISSIBLE if start_ok else INADMISSIBLE) if solvable else NO_SOLUTION
    fields = (not singular) & solvable
    return (st_singular if singular else st, 1.0 if singular else 0.0, coef,
            a if fields else NAN, m * qn if fields else NAN, m * u if fields else NAN)


@njit(cache=True, error_model="numpy", forceinline=True)
def stick(delta, l, g, m, sin_phi, cos_phi):
    """The stick branch: rest is possible iff l |sin phi| <= delta (35)."""
    ok = g * (delta - l * abs(sin_phi)) >= -TOL * g * (delta + l)
    st = (ADMISSIBLE if ok else INADMISSIBLE) if np.isfinite(m * g) else NO_SOLUTION
    return (st, 0.0, NAN, 0.0 if ok else NAN,
            m * g * cos_phi if ok else NAN, m * g * sin_phi if ok else NAN)


MODEL = Model(
    name="hinge_pendulum",
    twin="phasemap.systems.seeds.hinge_pendulum",
    title="Mathematical pendulum with dry friction in its hinge",
    citation=citation("Fig. 4, eq. (29)-(36)"),
    state=angle_state("rod", "angle of the rod from the downward vertical"),
    params=(
        Variable("delta", "m", "hinge friction coefficient (a length)", "\\delta", 0.1, 0.0),
        Variable("l", "m", "length of the rod", "l", 1.0, 0.0, lower_open=True),
        *gravity_and_mass("mass of the bob"),
    ),
    **one_angle("rod", "turn", turn, stick, velocity_scale),
    reactions=(
        Variable("R_n", "N", "hinge reaction along the rod, towards the hinge", "R_n"),
        Variable("R_t", "N", "hinge reaction across the rod", "R_\\tau"),
    ),
    coefficient=Variable("coef", "m2", "coefficient l^2 - delta^2 of the squared equation (33)",
                         "l^2-\\delta^2"),
    kinks=("R_n",),  # R_n = m Q_n, and (34) holds |Q_n|
    default_axes={"phi": (-math.pi, math.pi, 512), "delta": (0.0, 1.5, 512)},
)


def weightless_motion(t, phi0, omega0, delta, l):
    """Exact motion of the weightless pendulum (g = 0), delta < l, from (36).

    Returns (phi, omega) at times ``t``: omega = omega0 / (1 + k |omega0| t) and
    phi = phi0 + sgn(omega0) ln(1 + k |omega0| t) / k, k = delta / sqrt(l^2 - delta^2);
    for delta = 0, uniform rotation.
    """
    t = np.asarray(t, dtype=float)
    k = delta / math.sqrt(l * l - delta * delta)
    if k == 0.0 or omega0 == 0.0:
        return phi0 + omega0 * t, np.full_like(t, omega0)
    grow = 1.0 + k * abs(omega0) * t
    return phi0 + math.copysign(1.0, omega0) * np.log(grow) / k, omega0 / grow
