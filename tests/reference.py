"""Independent reference implementation of the unreduced Newton-Euler equations
of the four dry-friction systems of Lapshin (2021).

Used only by the tests, to cross-check the closed-form formulas of `phasemap`.
This module deliberately does NOT import `phasemap`: every quantity is obtained
by a numerical linear solve (or root search / LP) of the *unreduced* equations
(linear momentum, angular momentum, kinematic constraints, friction laws), not
from reduced closed forms.

Conventions: SI units, x to the right, y up, gravity (0, -g). Planar moments
are z-components (counter-clockwise positive), cross(r, F) = r_x F_y - r_y F_x.
Masses keep an explicit ``m`` argument.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq, linprog

__all__ = [
    "ladder_slip",
    "ladder_can_rest",
    "wheel_roll",
    "wheel_rest_moment",
    "elliptic_slip",
    "elliptic_stick",
    "hinge_roots",
    "hinge_rest",
]


def _cross(r, F):
    """z-component of the planar cross product r x F."""
    return r[0] * F[1] - r[1] * F[0]


# ----------------------------------------------------------------------------
# 1. Ladder
# ----------------------------------------------------------------------------

def ladder_slip(phi, omega, f, l, g, m, s):
    """Sliding ladder: solve the full Newton-Euler system for one sign branch.

    Geometry: C = (l sin phi, l cos phi); bottom end P1 = (2l sin phi, 0) on the
    floor, top end P2 = (0, 2l cos phi) on the wall.  Increasing phi rotates the
    bar counter-clockwise, so I*phi_ddot equals the ccw moment about C,
    I = m l^2 / 3.

    Velocities: P1_x' = 2l cos(phi) phi', P2_y' = -2l sin(phi) phi'.  With
    s = sgn(phi') the Coulomb forces (opposing sliding, magnitude f*N) give
        floor force on bar  F1 = (-s f N1, N1),
        wall  force on bar  F2 = (N2, s f N2).
    Equations (unknowns [xc'', yc'', phi'', N1, N2]):
        m xc'' = -s f N1 + N2
        m yc'' = N1 + s f N2 - m g
        I phi'' = (P1 - C) x F1 + (P2 - C) x F2
        xc'' = l cos(phi) phi'' - l sin(phi) omega^2      (xc = l sin phi)
        yc'' = -l sin(phi) phi'' - l cos(phi) omega^2     (yc = l cos phi)
    Reduced result: 2(2 - f^2) l phi'' = 3[(1-f^2) g sin phi
                                            + 2 s f (l omega^2 - g cos phi)].
    Returns dict(phi_ddot, N_floor, N_wall, xc_ddot, yc_ddot); normals signed,
    not clipped.  The matrix is singular at f = sqrt(2) (det ~ 2 - f^2): in
    floating point expect huge values or numpy.linalg.LinAlgError there.
    """
    S, C = math.sin(phi), math.cos(phi)
    I = m * l * l / 3.0
    r1 = (l * S, -l * C)          # P1 - C
    r2 = (-l * S, l * C)          # P2 - C
    dF1_dN1 = (-s * f, 1.0)       # floor force per unit N1
    dF2_dN2 = (1.0, s * f)        # wall force per unit N2
    A = np.array([
        # xc''  yc''  phi''   N1                    N2
        [m,    0.0,  0.0,    -dF1_dN1[0],          -dF2_dN2[0]],
        [0.0,  m,    0.0,    -dF1_dN1[1],          -dF2_dN2[1]],
        [0.0,  0.0,  I,      -_cross(r1, dF1_dN1), -_cross(r2, dF2_dN2)],
        [1.0,  0.0,  -l * C, 0.0,                  0.0],
        [0.0,  1.0,  l * S,  0.0,                  0.0],
    ])
    b = np.array([
        0.0,
        -m * g,
        0.0,
        -l * S * omega ** 2,
        -l * C * omega ** 2,
    ])
    xdd, ydd, phdd, N1, N2 = np.linalg.solve(A, b)
    return {"phi_ddot": float(phdd), "N_floor": float(N1), "N_wall": float(N2),
            "xc_ddot": float(xdd), "yc_ddot": float(ydd)}


def ladder_can_rest(phi, f, l, g, m):
    """Can the ladder stay at rest (phi' = 0, phi'' = 0)?

    At rest xc'' = yc'' = 0.  Unknown reactions: floor (F1, N1) acting at P1,
    wall (N2, F2) acting at P2 (F1 along x, F2 along y).  Equilibrium:
        F1 + N2 = 0,  N1 + F2 - m g = 0,
        (P1 - C) x (F1, N1) + (P2 - C) x (N2, F2) = 0.
    Statically indeterminate -> LP feasibility (scipy linprog, zero objective)
    with N1, N2 >= 0, |F1| <= f N1, |F2| <= f N2.  Variables are scaled by m g.
    Analytically: rest iff f >= 1 or tan(phi) <= 2f / (1 - f^2).
    """
    S, C = math.sin(phi), math.cos(phi)
    r1 = (l * S, -l * C)
    r2 = (-l * S, l * C)
    # variables z = [N1, F1, N2, F2] / (m g); moment equation divided by l
    A_eq = np.array([
        [0.0, 1.0, 1.0, 0.0],
        [1.0, 0.0, 0.0, 1.0],
        [_cross(r1, (0.0, 1.0)) / l, _cross(r1, (1.0, 0.0)) / l,
         _cross(r2, (1.0, 0.0)) / l, _cross(r2, (0.0, 1.0)) / l],
    ])
    b_eq = np.array([0.0, 1.0, 0.0])
    A_ub = np.array([
        [-f, 1.0, 0.0, 0.0],   # F1 <= f N1
        [-f, -1.0, 0.0, 0.0],  # -F1 <= f N1
        [0.0, 0.0, -f, 1.0],   # F2 <= f N2
        [0.0, 0.0, -f, -1.0],  # -F2 <= f N2
    ])
    b_ub = np.zeros(4)
    bounds = [(0.0, None), (None, None), (0.0, None), (None, None)]
    res = linprog(np.zeros(4), A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq,
                  bounds=bounds, method="highs")
    return bool(res.status == 0)


# ----------------------------------------------------------------------------
# 2. Wheel with displaced centre of mass
# ----------------------------------------------------------------------------

def _wheel_geometry(phi, r, l):
    S, C = math.sin(phi), math.cos(phi)
    rP = (l * S, -(r - l * C))    # contact point (x, 0) minus C
    return S, C, rP


def wheel_roll(phi, omega, delta, r, l, rho, g, m, sigma):
    """Disc rolling without slip, rolling-friction couple delta*N.

    A = (r phi, r), C = (r phi - l sin phi, r - l cos phi); phi is the
    clockwise rotation angle, so the ccw angular velocity is -phi'.
    Contact point P = (r phi, 0) receives the force (F, N) and a couple of
    magnitude delta*N opposing the rotation: ccw couple = +sigma*delta*N
    (sigma = sgn phi').  Equations (unknowns [xc'', yc'', phi'', F, N]):
        m xc'' = F
        m yc'' = N - m g
        m rho^2 (-phi'') = (P - C) x (F, N) + sigma delta N
        xc'' = (r - l cos phi) phi'' + l sin(phi) omega^2
        yc'' = l sin(phi) phi'' + l cos(phi) omega^2
    Reduced result:
        (rho^2 + r^2 + l^2 - 2 r l cos phi + sigma delta l sin phi) phi''
            = -l (r sin phi + sigma delta cos phi) omega^2
              - g l sin phi - sigma delta g.
    Returns dict(phi_ddot, N, F, xc_ddot, yc_ddot).  N is signed (floor is
    one-sided: the branch is admissible only if N >= 0); F is unlimited.
    """
    S, C, rP = _wheel_geometry(phi, r, l)
    J = m * rho * rho
    A = np.array([
        # xc''  yc''  phi''            F                      N
        [m,    0.0,  0.0,             -1.0,                  0.0],
        [0.0,  m,    0.0,             0.0,                   -1.0],
        [0.0,  0.0,  -J,              -_cross(rP, (1.0, 0.0)),
         -_cross(rP, (0.0, 1.0)) - sigma * delta],
        [1.0,  0.0,  -(r - l * C),    0.0,                   0.0],
        [0.0,  1.0,  -l * S,          0.0,                   0.0],
    ])
    b = np.array([0.0, -m * g, 0.0, l * S * omega ** 2, l * C * omega ** 2])
    xdd, ydd, phdd, F, N = np.linalg.solve(A, b)
    return {"phi_ddot": float(phdd), "N": float(N), "F": float(F),
            "xc_ddot": float(xdd), "yc_ddot": float(ydd)}


def wheel_rest_moment(phi, delta, r, l, rho, g, m):
    """Couple needed to hold the disc at rest (phi' = 0, phi'' = 0).

    Same equations as `wheel_roll` with phi' = phi'' = 0 and the rolling couple
    replaced by an unknown ccw couple M (same sign convention as
    sigma*delta*N in motion, i.e. M > 0 opposes increasing phi).
    Unknowns [xc'', yc'', F, N, M].  Result: F = 0, N = m g,
    M = -m g l sin phi.  The disc can rest iff |M| <= delta*N
    (i.e. |sin phi| <= delta/l).  `delta` is not used by the solve.
    Returns dict(M, N, F).
    """
    S, C, rP = _wheel_geometry(phi, r, l)
    A = np.array([
        # xc''  yc''  F                         N                         M
        [m,    0.0,  -1.0,                     0.0,                      0.0],
        [0.0,  m,    0.0,                      -1.0,                     0.0],
        [0.0,  0.0,  -_cross(rP, (1.0, 0.0)),  -_cross(rP, (0.0, 1.0)),  -1.0],
        [1.0,  0.0,  0.0,                      0.0,                      0.0],
        [0.0,  1.0,  0.0,                      0.0,                      0.0],
    ])
    b = np.array([0.0, -m * g, 0.0, 0.0, 0.0])
    xdd, ydd, F, N, M = np.linalg.solve(A, b)
    return {"M": float(M), "N": float(N), "F": float(F)}


# ----------------------------------------------------------------------------
# 3. Elliptic pendulum (two-particle formulation with bar tension T)
# ----------------------------------------------------------------------------

def _elliptic_system(phi, omega, l, g, m):
    """Rows common to slip and stick.

    Unknowns z = [x'', phi'', N, F, T, xB'', yB''].  Bar AB is massless, so it
    transmits a force along itself: tension T pulls B toward A with unit vector
    e = (A - B)/(2l) = (-sin phi, cos phi); the slider gets -T e.
        slider x:  m x''  = F + T sin phi
        slider y:  m * 0  = N - T cos phi - m g          (guide: y_A = 0)
        mass B x:  m xB'' = -T sin phi
        mass B y:  m yB'' = T cos phi - m g
        xB'' = x'' + 2l cos(phi) phi'' - 2l sin(phi) omega^2
        yB'' = 2l sin(phi) phi'' + 2l cos(phi) omega^2
    """
    S, C = math.sin(phi), math.cos(phi)
    A = np.array([
        # x''  phi''       N     F     T     xB''  yB''
        [m,   0.0,        0.0,  -1.0, -S,   0.0,  0.0],
        [0.0, 0.0,        1.0,  0.0,  -C,   0.0,  0.0],
        [0.0, 0.0,        0.0,  0.0,  S,    m,    0.0],
        [0.0, 0.0,        0.0,  0.0,  -C,   0.0,  m],
        [1.0, 2 * l * C,  0.0,  0.0,  0.0,  -1.0, 0.0],
        [0.0, 2 * l * S,  0.0,  0.0,  0.0,  0.0,  -1.0],
    ])
    b = np.array([
        0.0,
        m * g,
        0.0,
        -m * g,
        2 * l * S * omega ** 2,
        -2 * l * C * omega ** 2,
    ])
    return A, b


def _elliptic_out(z):
    x_dd, ph_dd, N, F, T, xB_dd, yB_dd = (float(v) for v in z)
    return {"x_ddot": x_dd, "phi_ddot": ph_dd, "N": N, "F": F, "T": T,
            "xB_ddot": xB_dd, "yB_ddot": yB_dd}


def elliptic_slip(phi, omega, xdot, f, l, g, m, sigma, rho):
    """Elliptic pendulum, slider sliding in direction sigma, sgn N = rho.

    Coulomb: F = -f |N| sgn(x') = -f rho sigma N (one more linear row added to
    `_elliptic_system`).  `xdot` does not enter the equations (only its sign,
    passed as sigma); it is accepted for interface symmetry.
    Reduced result with k = sigma*rho, lam = 1 + sin^2 phi - k f sin phi cos phi:
        lam N      = 2 m (g + l cos(phi) omega^2)
        lam x''    = 2 l omega^2 (sin phi - k f cos phi)
                     - k f g (1 + cos^2 phi) + g sin phi cos phi
        lam l phi'' = (g + l cos(phi) omega^2)(k f cos phi - sin phi)
        and 2 l phi'' + x'' cos phi + g sin phi = 0.
    The branch is consistent iff sgn N = rho (and, from x' = 0,
    sgn x'' = sigma).  Singular (LinAlgError) when lam = 0.
    Returns dict(x_ddot, phi_ddot, N, F, T, xB_ddot, yB_ddot).
    """
    del xdot  # only its sign (sigma) matters
    A, b = _elliptic_system(phi, omega, l, g, m)
    row = np.array([[0.0, 0.0, f * rho * sigma, 1.0, 0.0, 0.0, 0.0]])
    A = np.vstack([A, row])
    b = np.append(b, 0.0)
    return _elliptic_out(np.linalg.solve(A, b))


def elliptic_stick(phi, omega, f, l, g, m):
    """Elliptic pendulum with the slider stuck: x' = 0 and x'' = 0 imposed.

    F becomes an unknown static friction force (row x'' = 0 replaces the
    Coulomb law).  Reduced result: 2 l phi'' = -g sin phi,
    T = m (2 l omega^2 + g cos phi), N = m g + T cos phi, F = -T sin phi.
    The stick branch is admissible iff |F| <= f |N|.  `f` is not used by the
    solve.  Returns dict(x_ddot, phi_ddot, N, F, T, xB_ddot, yB_ddot).
    """
    A, b = _elliptic_system(phi, omega, l, g, m)
    row = np.array([[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    A = np.vstack([A, row])
    b = np.append(b, 0.0)
    out = _elliptic_out(np.linalg.solve(A, b))
    out["x_ddot"] = 0.0
    return out


# ----------------------------------------------------------------------------
# 4. Pendulum with hinge friction
# ----------------------------------------------------------------------------

def _hinge_reaction(phi, omega, phi_ddot, l, g, m):
    """Hinge reaction R = m a - m g_vec for the mass at (l sin phi, -l cos phi).

    a = l phi'' e_t + l omega^2 e_n, with e_t = (cos phi, sin phi) and
    e_n = (-sin phi, cos phi) (toward O); g_vec = (0, -g).
    """
    S, C = math.sin(phi), math.cos(phi)
    ax = l * phi_ddot * C - l * omega ** 2 * S
    ay = l * phi_ddot * S + l * omega ** 2 * C
    return np.array([m * ax, m * (ay + g)])


def _hinge_residual(phi, omega, phi_ddot, delta, l, g, m, sigma):
    """m l^2 phi'' + m g l sin phi + sigma delta |R(phi'')| (root <=> motion)."""
    R = _hinge_reaction(phi, omega, phi_ddot, l, g, m)
    return (m * l * l * phi_ddot + m * g * l * math.sin(phi)
            + sigma * delta * math.hypot(R[0], R[1]))


def _golden_min(fun, lo, hi, iters=200):
    """Golden-section minimisation of a unimodal fun on [lo, hi]."""
    invphi = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = lo, hi
    c, d = b - invphi * (b - a), a + invphi * (b - a)
    fc, fd = fun(c), fun(d)
    for _ in range(iters):
        if b - a <= 4e-16 * max(1.0, abs(a), abs(b)):
            break
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - invphi * (b - a)
            fc = fun(c)
        else:
            a, c, fc = c, d, fd
            d = a + invphi * (b - a)
            fd = fun(d)
    return c if fc <= fd else d


def hinge_roots(phi, omega, delta, l, g, m, sigma):
    """All real roots phi'' of  m l^2 phi'' = -m g l sin phi - sigma delta |R|.

    |R| from Newton's law for the mass (see `_hinge_reaction`), not squared.
    Method: the whole real line is scanned through phi'' = L tan(theta),
    theta in (-pi/2, pi/2), with L = (g/l + omega^2)(1 + delta/l)
    (the scan reaches |phi''| ~ 1e9 L); every sign change is refined with
    brentq; local minima of |residual| without a sign change are refined by a
    golden-section search and accepted as tangential (double) roots when the
    residual there is ~0 (relative 1e-9).  Duplicates are merged.
    Expected (delta < l): l phi'' = -g sin phi
        - sigma delta |l omega^2 + g cos phi| / sqrt(l^2 - delta^2);
    for delta > l there is no root unless l omega^2 + g cos phi = 0 (then
    the single tangential root l phi'' = -g sin phi).
    The degenerate case delta == l with l omega^2 + g cos phi == 0 (a
    half-line of roots) is not meaningfully represented.
    Returns a sorted list of floats ([] if none).
    """
    S, C = math.sin(phi), math.cos(phi)

    def h(a):
        return _hinge_residual(phi, omega, a, delta, l, g, m, sigma)

    L = (abs(g) / l + omega ** 2) * (1.0 + delta / l)
    if L == 0.0:
        L = 1.0
    eps = 1e-9
    theta = np.linspace(-0.5 * math.pi + eps, 0.5 * math.pi - eps, 20001)
    a_grid = L * np.tan(theta)
    # vectorised copy of _hinge_residual (same formulas)
    Rx = m * (l * a_grid * C - l * omega ** 2 * S)
    Ry = m * (l * a_grid * S + l * omega ** 2 * C + g)
    h_grid = (m * l * l * a_grid + m * g * l * S
              + sigma * delta * np.hypot(Rx, Ry))
    tol = 1e-9 * m * l * (abs(g) + l * omega ** 2) * (1.0 + delta / l) + 1e-300

    roots = []
    zero = np.flatnonzero(h_grid == 0.0)
    roots.extend(float(a_grid[i]) for i in zero)
    change = np.flatnonzero(h_grid[:-1] * h_grid[1:] < 0.0)
    for i in change:
        roots.append(float(brentq(h, a_grid[i], a_grid[i + 1],
                                  xtol=1e-300, rtol=4 * np.finfo(float).eps,
                                  maxiter=1000)))

    absh = np.abs(h_grid)
    mid = np.arange(1, len(a_grid) - 1)
    cand = mid[(absh[mid] <= absh[mid - 1]) & (absh[mid] <= absh[mid + 1])
               & (h_grid[mid - 1] * h_grid[mid] > 0.0)
               & (h_grid[mid] * h_grid[mid + 1] > 0.0)]
    for i in cand:
        x = _golden_min(lambda a: abs(h(a)), a_grid[i - 1], a_grid[i + 1])
        if abs(h(x)) <= tol + 1e-9 * m * l * l * abs(x):
            roots.append(float(x))

    roots.sort()
    merged = []
    for x in roots:
        if merged and abs(x - merged[-1]) <= 1e-9 * (L + abs(x)):
            continue
        merged.append(x)
    return merged


def hinge_rest(phi, delta, l, g, m):
    """Can the pendulum stay at rest (phi' = 0, phi'' = 0)?

    At rest the hinge must supply the moment M with 0 = -m g l sin phi + M,
    and R = m a - m g_vec = (0, m g).  Rest iff |M| <= delta |R|, i.e.
    |sin phi| <= delta / l.  A relative tolerance of 1e-12 is applied.
    """
    M = m * g * l * math.sin(phi)          # ml^2 * 0 + m g l sin phi
    R = _hinge_reaction(phi, 0.0, 0.0, l, g, m)
    Rn = math.hypot(R[0], R[1])
    return bool(abs(M) <= delta * Rn + 1e-12 * (abs(M) + delta * Rn))
