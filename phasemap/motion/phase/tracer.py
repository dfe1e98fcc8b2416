r"""The phase-curve tracer's numba templates, compiled per model (:func:`phasemap.motion.phase.kernel`).

A stage (:func:`_stage_template`) is a loop over panels, each a short sequence
of named pieces inlined into it: the collocation solve
(:func:`_collocate_template`), its error estimate
(:func:`_panel_error_template`), the check that the stage goes on at the
panel's end (:func:`_still_template`) and the end of a panel at a kink of the
law (:func:`_kink_template`); where the stage stops inside a panel, the first
state off it (:func:`_end_template`, rooting with :func:`_root_template`), what
happens there (:func:`_end_reason_template`) and, for a contact lost, the end
moved to N = 0 (:func:`_contact_end_template`).  :func:`_curve_template` runs
the stages of a curve and collects its output points
(:func:`_stage_points_template`).  The method is described in
:mod:`phasemap.motion.phase`; the maths of a panel is in
:mod:`phasemap.motion.phase.collocation`.
"""

from __future__ import annotations

import math

import numpy as np

from phasemap.core import numerics as nx
from phasemap.core import events as ev
from phasemap.core.compile import grow
from phasemap.motion.phase import collocation
from phasemap.motion.phase.collocation import (LANES, NODES, OUT_NODES, OUT_TERMS, OUT_THETA, SERIES, THETA, Z_OUT,
                          dense, dense_at, expand, factor, legendre_many, lu_solve, series,
                          solve_legendre, weights)

#: Modules compiled into these kernels besides this one (see phasemap.core.compile).
SOURCES = (collocation,)

#: The collocation's Newton iteration stops where its correction, relative to |u| +
#: u_ref and divided by 1 - the measured contraction, is below NEWTON rtol (or 1e-14).
NEWTON = 1e-3
#: Largest growth exponent beta h of one panel (a growing exponential).
Z_GROW = 4.0
#: Largest omega^2 a stage may reach (rad2 s-2); beyond it, step_failure.
U_MAX = 1e300
#: Internal marker: the stage ended at omega = 0 (classified afterwards).
_ZERO = -1
#: Columns of a stored panel: s0, h, z, u0, theta_end, then a (Legendre), c (monomial).
_PANEL_COLS = 5 + 2 * NODES
EPS = float(np.finfo(float).eps)

# Compile-time structure of the model being compiled (see phasemap.core.compile).
POINT = None
BRANCH_ROW = None
DERIVE = None
DOMAIN = None
PHI = 0
OMEGA = 1
ACC = 3
OMEGA_DERIVED = False
STICK = -1
N_BRANCHES = 0
DIRECTIONS = np.zeros(1)
REACTIONS = np.zeros(1, dtype=np.int64)
LOWER = np.zeros(2)
UPPER = np.zeros(2)
BOUND_ROW = np.zeros(0, dtype=np.int64)
#: Indices into REACTIONS of the reactions whose sign change bends the law (Model.kinks).
KINKS = np.zeros(0, dtype=np.int64)
ROW = None
RATE = None
STILL = None
REFINE = None
ROOT = None
STAGE_POINTS = None
FLUSH = None
VALUE = None
CLASSIFY = None
AT_REST = None
STAGE = None
STAGE_START = None
COLLOCATE = None
PANEL_ERROR = None
KINK = None
STORE_PANEL = None
END = None
END_REASON = None
LEAVE = None
CONTACT_END = None
N_FIELDS = 0


def _row_template(v, x, u, sigma, branch):
    """The row of ``branch`` at phi = x, omega = sigma sqrt(u) (u below 0 read as 0)."""
    v[PHI] = x
    v[OMEGA] = sigma * math.sqrt(max(u, 0.0))
    DERIVE(v)
    return BRANCH_ROW(v, branch)


def _rate_template(v, x, u, sigma, branch, u_ref):
    """(F, dF/du): phi'' of ``branch`` at (x, u = omega^2) and its slope in u.

    Two evaluations of the branch row, at u and a little above (an affine F is
    exact); below u = 0 the row is continued linearly from u = 0.
    """
    ua = u if u > 0.0 else 0.0
    d = 1e-4 * (ua + u_ref)
    fa = ROW(v, x, ua, sigma, branch)[ACC]
    v[OMEGA] = sigma * math.sqrt(ua + d)
    if OMEGA_DERIVED:
        DERIVE(v)
    fb = BRANCH_ROW(v, branch)[ACC]
    s = (fb - fa) / d
    return fa + s * (u - ua), s


def _value_template(v, x, u, sigma, branch, u_ref):
    """phi'' of ``branch`` at (x, u = omega^2) (continued linearly below u = 0)."""
    if u >= 0.0:
        return ROW(v, x, u, sigma, branch)[ACC]
    return RATE(v, x, u, sigma, branch, u_ref)[0]


def _classify_template(v, x, omega, out):
    """Classify (x, omega) with the model's point function: (n, first admissible, lost, singular)."""
    v[PHI] = x
    v[OMEGA] = omega
    DERIVE(v)
    POINT(v, out)
    return ev.summary(out, STICK)


def _still_template(v, out, x, u, sigma, branch, coef_sign):
    """The state (x, u) is still on the stage of ``branch``: u > 0, unique, same branch,
    same sign of the coefficient, and an omega the model does not count as zero."""
    if not (u > 0.0):
        return False
    n, adm, lost, sing = CLASSIFY(v, x, sigma * math.sqrt(u), out)
    if n != 1 or adm != branch or not DOMAIN(v):  # (v holds the state: its own domain)
        return False
    if STICK >= 0 and out[STICK, nx.STATUS] != nx.ABSENT:
        return False
    return coef_sign == 0.0 or out[branch, nx.COEF] * coef_sign > 0.0


def _refine_template(v, theta, x_p, hh, z, u_p, a, c, sigma, branch, u_ref, buf, tb, nv, a2, c2):
    """u at theta of a panel to the panel's own order: one Gauss pass on [0, theta].

    The collocation polynomial is accurate to O(h^(n+1)) inside a panel (its stage
    order); the sub-panel's Gauss quadrature of the remainder N, evaluated on it,
    is of order 2n where N does not depend on u (beta is the exact slope: the
    ladder, the hinge on a piece of sgn Q_n) and O(h^(n+3)) otherwise.
    """
    if theta <= 0.0:
        return u_p
    n = NODES
    beta = z / hh
    hs = theta * hh
    use_series = series(z, u_p, hh, c, tb)
    for j in range(n):
        uj = dense_at(theta * THETA[j], use_series, tb, z, u_p, hh, a, c, buf)
        fj = VALUE(v, x_p + sigma * hs * THETA[j], uj, sigma, branch, u_ref)
        nv[j] = 2.0 * sigma * fj - beta * uj
    expand(nv, a2, c2)
    return dense(1.0, z * theta, u_p, hs, a2, c2, buf)


def _root_template(v, field, sg, lo, hi, glo, ghi, tol, x, hh, z, u, a, c, sigma, branch, u_ref,
                   buf, tb, nv, a2, c2, fine):
    """The zero of g(theta) = sg u (``field`` < 0) or sg (``field`` of the row of ``branch``)
    on a panel.

    ``g(lo) = glo > 0 >= ghi = g(hi)``; returns ``(lo, hi, u_lo, u_hi)`` with
    the bracket closed to ``hi - lo <= tol`` and the u at its ends (NaN where
    an end was not evaluated).  u is the dense output (``fine`` False) or :func:`REFINE`
    (``fine`` True, after a first solve on the dense output for the start and
    its slope).  Newton with secant slopes; a step d below tol/2 is lengthened
    to max(2 |d|, tol/16), so that a converged iterate is bracketed closely by
    the next evaluation;
    bisection wherever |g| does not halve.  Few evaluations where the
    bisection of the bracket takes 50.  A zero of u on :func:`REFINE` takes the
    slope from the equation itself (one branch row) and ends on the straight line
    u is within 1e-8 of the zero: one or two passes where the secant takes four.
    """
    sl = (ghi - glo) / (hi - lo)
    t = lo - glo / sl
    use_series = series(z, u, hh, c, tb)  # (REFINE recomputes the same)
    lo0, hi0, glo0, ghi0 = lo, hi, glo, ghi
    u_lo = u_hi = math.nan
    for pss in range(2 if fine else 1):
        on_refine = fine and pss == 1
        if on_refine and field < 0:
            # a zero of u: Newton from the dense output's zero with the equation's own slope,
            # du/dtheta = 2 sigma F hh at the refined u; once the step is below 1e-8, u is a
            # straight line to rounding there (as for the classification in STAGE), and the
            # bracket closes on that line without more passes
            t = 0.5 * (lo + hi)
            for _it in range(6):
                ut = REFINE(v, t, x, hh, z, u, a, c, sigma, branch, u_ref, buf, tb, nv, a2, c2)
                st = 2.0 * sigma * hh * VALUE(v, x + sigma * t * hh, ut, sigma, branch, u_ref)
                if not (sg * st < 0.0):
                    break
                d = -ut / st
                tz = t + d
                if not (lo0 < tz < hi0):
                    break
                if abs(d) <= 1e-8:
                    q = max(0.25 * tol, 2.0 * EPS * abs(tz))
                    if lo0 <= tz - q and tz + q <= hi0:
                        return tz - q, tz + q, ut - st * (t - tz + q), ut - st * (t - tz - q)
                    break
                t = tz
        if pss == 1:  # from the dense output's zero, on the refined u, with its local slope
            t = 0.5 * (lo + hi)
            dt = min(1e-6, 0.5 * (t - lo0), 0.5 * (hi0 - t))
            if dt > 0.0:
                gp = dense_at(t + dt, use_series, tb, z, u, hh, a, c, buf)
                gm = dense_at(t - dt, use_series, tb, z, u, hh, a, c, buf)
                if field >= 0:
                    gp = ROW(v, x + sigma * (t + dt) * hh, gp, sigma, branch)[field]
                    gm = ROW(v, x + sigma * (t - dt) * hh, gm, sigma, branch)[field]
                s2 = sg * (gp - gm) / (2.0 * dt)
                if s2 < 0.0:
                    sl = s2
            lo, hi, glo, ghi = lo0, hi0, glo0, ghi0
        t_prev, g_prev = math.nan, math.nan
        g_best = math.inf
        stall = 0
        for _it in range(200):
            if not (hi - lo > tol):
                break
            if not (lo < t < hi) or stall >= 2:
                t = 0.5 * (lo + hi)
                stall = 0
            if on_refine:
                ut = REFINE(v, t, x, hh, z, u, a, c, sigma, branch, u_ref, buf, tb, nv, a2, c2)
            else:
                ut = dense_at(t, use_series, tb, z, u, hh, a, c, buf)
            if field < 0:
                gt = sg * ut
            else:
                gt = sg * ROW(v, x + sigma * t * hh, ut, sigma, branch)[field]
            if gt > 0.0:
                lo, glo = t, gt
                u_lo = ut if on_refine else math.nan
            else:
                hi, ghi = t, gt
                u_hi = ut if on_refine else math.nan
            stall = stall + 1 if abs(gt) > 0.5 * g_best else 0
            g_best = min(g_best, abs(gt))
            if abs(t - t_prev) > 64.0 * tol:
                s2 = (gt - g_prev) / (t - t_prev)
                if s2 < 0.0:
                    sl = s2
            t_prev, g_prev = t, gt
            d = -gt / sl if sl < 0.0 else math.nan
            if not (abs(d) >= 0.5 * tol):  # converged: bracket the zero tightly
                step = max(2.0 * abs(d), 0.0625 * tol, 2.0 * EPS * abs(t)) if d == d \
                    else 0.5 * tol  # (at least an ulp of t)
                d = step if gt > 0.0 else -step
            t = t + d
    return lo, hi, u_lo, u_hi


def _at_rest_template(v, x, out):
    """Classify the rest state (x, 0): (-1, branch) to go on it, or (Event code, -1)."""
    n, adm, lost, sing = CLASSIFY(v, x, 0.0, out)
    if n == nx.N_UNIQUE:
        if adm == STICK:
            return ev.REST, -1
        if out[adm, nx.STATUS] == nx.SEPARATION:
            return ev.CONTACT_LOST, -1  # the only motion leaves a contact
        return -1, adm
    if sing and (n == nx.N_NONE or n == nx.N_CONTINUUM):
        return ev.SINGULAR, -1
    return ev.fate_without_unique(n, lost, sing), -1  # (a continuum is not two solutions)


def _stage_start_template(v, branch, sigma, x0, u0, react):
    """The branch row of ``branch`` at the stage start (x0, u0): its reactions into
    ``react``; returns (coefficient, its sign)."""
    v[PHI] = x0
    v[OMEGA] = sigma * math.sqrt(u0)
    DERIVE(v)
    r0 = BRANCH_ROW(v, branch)
    coef0 = r0[nx.COEF]
    for q in range(REACTIONS.shape[0]):
        react[q] = r0[REACTIONS[q]]
    return coef0, 1.0 if coef0 > 0.0 else (-1.0 if coef0 < 0.0 else 0.0)


def _collocate_template(v, x, u, hh, z, beta, f0, sigma, branch, u_ref, tol_newton, mats, vecs,
                        buf, piv):
    """Solve a panel's collocation equations U = E u + hh A N(U): whether Newton's
    method converged (N at the nodes in ``vecs[3]``).

    The Newton matrix takes the slopes of the first pass and is factored once.  The
    iteration stops where its correction, relative to |U| + u_ref, is below 1e-14,
    or below ``tol_newton`` times 1 - its contraction (measured between two
    corrections, 1/2 before): N was evaluated at U before this correction, about
    (1 + rate / (1 - rate)) times its size from the solution.
    """
    n = NODES
    A = mats[0]
    M = mats[1]
    U = vecs[0]
    E = vecs[1]
    P1 = vecs[2]
    Nv = vecs[3]
    Jd = vecs[4]
    R = vecs[5]
    weights(z, A, buf, E, P1)
    n0 = 2.0 * sigma * f0 - beta * u
    for i in range(n):
        U[i] = E[i] * u + hh * THETA[i] * P1[i] * n0
    worst_prev = math.inf
    for it in range(10):
        for j in range(n):
            xj = x + sigma * hh * THETA[j]
            if it == 0:
                fj, sj = RATE(v, xj, U[j], sigma, branch, u_ref)
                Jd[j] = 2.0 * sigma * sj - beta
            else:
                fj = VALUE(v, xj, U[j], sigma, branch, u_ref)
            Nv[j] = 2.0 * sigma * fj - beta * U[j]
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += A[i, j] * Nv[j]
            R[i] = U[i] - E[i] * u - hh * acc
        if it == 0:
            for i in range(n):
                for j in range(n):
                    M[i, j] = -hh * A[i, j] * Jd[j]
                M[i, i] += 1.0
            factor(M, piv)
        lu_solve(M, piv, R)
        worst = 0.0
        for i in range(n):
            U[i] -= R[i]
            worst = max(worst, abs(R[i]) / (abs(U[i]) + u_ref))
        if not (worst == worst):
            return False
        rate = worst / worst_prev if it > 0 else 0.5
        if worst <= 1e-14 or (rate < 1.0 and worst <= (1.0 - rate) * tol_newton):
            return True
        worst_prev = worst
    return False


def _panel_error_template(a, hh, z, u, u1, rtol, u_ref):
    """(estimate, tolerance) of a panel's error in u.

    The estimate is the Legendre tail of N (degrees n-2, n-1), extrapolated by its
    decay over two degrees (rho) to about degree n + 5, near where the order-2n
    collocation errs; the exponent is measured to be on the safe side for the
    wheel, whose bracket has complex zeros near the real axis.
    """
    n = NODES
    tail = abs(a[n - 1]) + abs(a[n - 2])
    head = abs(a[n - 3]) + abs(a[n - 4])
    rho = 1.0 if tail >= head else tail / head
    grow_z = math.exp(z) if z > 0.0 else 1.0
    return hh * grow_z * tail * rho ** 3, rtol * (max(abs(u), abs(u1)) + u_ref)


def _kink_template(v, out, x, hh, z, u, a, c, sigma, branch, u_ref, react, buf, tb, nv, a2, c2):
    """theta of the first sign change inside the panel of a reaction the model names as
    a kink of its law (2 where none changes sign); ``out`` holds the panel's end."""
    first = 2.0
    for q in KINKS:
        if react[q] * out[branch, REACTIONS[q]] < 0.0:
            sg = 1.0 if react[q] > 0.0 else -1.0
            lo, hi, _ul, _uh = ROOT(v, REACTIONS[q], sg, 0.0, 1.0, sg * react[q],
                                    sg * out[branch, REACTIONS[q]],
                                    4.0 * EPS * max(abs(x), hh) / hh, x, hh, z, u, a, c,
                                    sigma, branch, u_ref, buf, tb, nv, a2, c2, bool(False))
            first = min(first, hi)
    return first


def _store_panel_template(panels, n_pan, s, hh, z, u, theta_end, a, c):
    """Append a panel (s0, h, z, u0, theta_end, a, c: its dense output) to ``panels``."""
    n = NODES
    panels = grow(panels, n_pan + 1)
    row = panels[n_pan]
    row[0], row[1], row[2], row[3], row[4] = s, hh, z, u, theta_end
    row[5:5 + n] = a
    row[5 + n:5 + 2 * n] = c
    return panels, n_pan + 1


def _end_template(v, out, x, hh, z, u, u1, a, c, sigma, branch, u_ref, coef_sign, coef_prev,
                  react, buf, tb, nv, a2, c2):
    """The first theta of a panel where the stage stops, to double precision in phi.

    Returns ``(zero, th_e, guided, c_fld, c_th, c_u, slope, dd)``: ``zero`` where
    the stage ends at a zero of u (the rest state, classified afterwards), the end
    ``th_e``, and, where the end was bracketed next to a zero of a reaction or the
    coefficient (field ``c_fld`` at ``c_th``, u there ``c_u``), the straight line
    ``u = c_u + slope (theta - c_th)`` that u is to rounding within ``dd`` of it.

    Where a reaction or the coefficient of the stage's branch has changed sign by
    the panel's end, the state leaves the stage at or just past (by the tolerance
    of the sign test) the first such zero: find it, bracket the change of
    classification within +-1e-11 (else +-1e-8) of it, where u is a straight line
    to rounding, and bisect on that line instead of a Gauss pass per step.
    Otherwise (or if the bracket fails) plain bisection on Gauss passes.
    """
    nr = REACTIONS.shape[0]
    th_hi = 1.0
    if u1 <= 0.0:
        # the zero of u (u > 0 at the panel start, where the stage goes on)
        lo, hi, u_lo, u_hi = ROOT(v, int(-1), 1.0, 0.0, 1.0, u, u1,
                                  4.0 * EPS * max(abs(x), hh) / hh, x, hh, z, u, a, c,
                                  sigma, branch, u_ref, buf, tb, nv, a2, c2, bool(True))
        if lo == 0.0 or STILL(v, out, x + sigma * lo * hh, u_lo, sigma, branch, coef_sign):
            return True, hi, False, -1, 2.0, math.nan, 0.0, 0.0
        th_hi = lo
    c_fld, c_th, c_u = -1, 2.0, math.nan
    guided = False
    slope = 0.0
    dd = 0.0
    lo, hi = 0.0, th_hi
    tol_b = 2.0 * EPS * max(abs(x), hh) / hh
    c_lo, c_ulo = 0.0, math.nan
    for q in range(nr + 1):
        fld = REACTIONS[q] if q < nr else nx.COEF
        g0 = react[q] if q < nr else coef_prev
        g1 = out[branch, fld]
        if g0 * g1 < 0.0:
            sg = 1.0 if g0 > 0.0 else -1.0
            g1 = sg * g1
            top = th_hi
            if c_lo > 0.0:  # a zero found: this one matters only before it
                g1 = sg * ROW(v, x + sigma * c_lo * hh, c_ulo, sigma, branch)[fld]
                top = c_lo
                if g1 > 0.0:
                    continue  # its first zero is not before c_lo: not earlier
            l_c, h_c, ul_c, u_c = ROOT(v, fld, sg, 0.0, top, sg * g0, g1, tol_b, x, hh,
                                       z, u, a, c, sigma, branch, u_ref, buf, tb, nv, a2, c2,
                                       bool(True))
            if h_c < c_th and u_c == u_c and ul_c == ul_c:
                c_fld, c_th, c_u, c_lo, c_ulo = fld, h_c, u_c, l_c, ul_c
    for d_try in (1e-11, 1e-8):  # the narrow bracket first: ten bisections fewer
        if guided or not (c_th - d_try > 0.0 and c_th + d_try < th_hi):
            break
        u_d = REFINE(v, c_th + d_try, x, hh, z, u, a, c, sigma, branch, u_ref, buf, tb,
                     nv, a2, c2)
        slope = (u_d - c_u) / d_try
        if STILL(v, out, x + sigma * (c_th - d_try) * hh, c_u - slope * d_try, sigma,
                 branch, coef_sign) and not STILL(v, out, x + sigma * (c_th + d_try) * hh,
                                                u_d, sigma, branch, coef_sign):
            lo, hi, guided, dd = c_th - d_try, c_th + d_try, True, d_try
    for _b in range(200):
        if (hi - lo) * hh <= 2.0 * EPS * max(abs(x), hh):
            break
        mid = 0.5 * (lo + hi)
        if guided:
            um = c_u + slope * (mid - c_th)
        else:
            um = REFINE(v, mid, x, hh, z, u, a, c, sigma, branch, u_ref, buf, tb, nv, a2, c2)
        if STILL(v, out, x + sigma * mid * hh, um, sigma, branch, coef_sign):
            lo = mid
        else:
            hi = mid
    return False, hi, guided, c_fld, c_th, c_u, slope, dd


def _leave_template(out, sigma):
    """The bound of phi that a state classified into ``out``, moving in the direction
    ``sigma``, lies on and leaves through, else NaN: a row that exists only on that
    bound applies, and the state is not at rest (the integrator's rule,
    :func:`phasemap.motion.integrate.templates._leave_template`)."""
    if STICK >= 0 and out[STICK, nx.STATUS] != nx.ABSENT:
        return math.nan
    for b in range(BOUND_ROW.shape[0]):
        k = BOUND_ROW[b]
        if 0 <= k < 2 and out[b, nx.STATUS] != nx.ABSENT and (k == 1) == (sigma > 0.0):
            return UPPER[0] if k == 1 else LOWER[0]
    return math.nan


def _end_reason_template(v, out, x, hh, z, u, a, c, sigma, branch, u_ref, th_e, x_e, u_e,
                         guided, c_th, c_u, slope, dd, buf, tb, nv, a2, c2):
    """What ends the stage at (x_e, u_e), theta ``th_e`` of the panel, where u is not
    zero: ``(reason, th_e, x_e, u_e, next_branch)`` (an Event code or _ZERO; the end
    moves past a tie, see below).

    Within 1e-12 of a boundary the tie rules can admit two rows (a contact kept
    with N = 0 to tolerance, and the same contact leaving).  A genuine
    indeterminacy persists past the boundary; a tie does not: probe just beyond
    it on this panel's dense output for the first state decided by another row.
    """
    next_branch = branch
    n2, adm2, lost2, sing2 = CLASSIFY(v, x_e, sigma * math.sqrt(max(u_e, 0.0)), out)
    if n2 == nx.N_TWO and u_e > 0.0 and th_e < 1.0 and DOMAIN(v):
        for k in range(1, 10):
            th_p = th_e + 10.0 ** k * 2.0 * EPS * max(abs(x), hh) / hh
            if th_p > 1.0:
                break
            if guided and abs(th_p - c_th) <= dd:
                u_p = c_u + slope * (th_p - c_th)
            else:
                u_p = REFINE(v, th_p, x, hh, z, u, a, c, sigma, branch, u_ref, buf, tb,
                             nv, a2, c2)
            x_p = x + sigma * th_p * hh
            n3, adm3, lost3, sing3 = CLASSIFY(v, x_p, sigma * math.sqrt(max(u_p, 0.0)),
                                              out)
            if n3 == 1 and u_p > 0.0 and adm3 != branch:
                th_e, x_e, u_e = th_p, x_p, u_p
                n2, adm2, lost2, sing2 = n3, adm3, lost3, sing3
                break
        if n2 != 1:  # undecided: the event's own classification
            n2, adm2, lost2, sing2 = CLASSIFY(v, x_e, sigma * math.sqrt(max(u_e, 0.0)),
                                              out)
    bound = LEAVE(out, sigma) if u_e > 0.0 else math.nan
    if bound == bound:  # on a bound of phi, moving out
        reason = ev.LEFT_DOMAIN
        x_e = bound
    elif not DOMAIN(v):
        reason = ev.LEFT_DOMAIN  # the model's own domain (the rod leaves the step)
    elif not (u_e > 0.0) or (STICK >= 0 and out[STICK, nx.STATUS] != nx.ABSENT):
        reason = _ZERO
    elif n2 == 1:
        if out[adm2, nx.STATUS] == nx.SEPARATION:
            reason = ev.CONTACT_LOST  # the only motion from here leaves a contact
        elif adm2 == branch:
            reason = ev.SINGULAR  # same branch, its coefficient changed sign
        elif DIRECTIONS[adm2] == sigma:
            reason = ev.SWITCH
            next_branch = adm2
        else:
            reason = ev.NO_SOLUTION
    else:
        reason = ev.fate_without_unique(n2, lost2, sing2)
    return reason, th_e, x_e, u_e, next_branch


def _contact_end_template(v, out, x, hh, z, u, a, c, sigma, branch, u_ref, th_e, x_e, u_e,
                          react, c_fld, c_th, c_u, buf, tb, nv, a2, c2):
    """The end of a stage that loses a contact, moved to N = 0 (the classification flips
    where N < -1e-12 of its scale): ``(th_e, x_e, u_e)``."""
    best = -1.0
    u_best = math.nan
    for q in range(REACTIONS.shape[0]):
        if react[q] > 0.0 and out[branch, REACTIONS[q]] < 0.0:
            if REACTIONS[q] == c_fld and c_th <= th_e:
                hi, u_hi = c_th, c_u  # located above
            else:
                lo, hi, _ul, u_hi = ROOT(v, REACTIONS[q], 1.0, 0.0, th_e, react[q],
                                         out[branch, REACTIONS[q]],
                                         2.0 * EPS * max(abs(x), hh) / hh, x, hh, z, u,
                                         a, c, sigma, branch, u_ref, buf, tb, nv, a2, c2,
                                         bool(True))
            if hi > best:
                best, u_best = hi, u_hi
    if best > 0.0:
        th_e = best
        x_e = x + sigma * th_e * hh
        u_e = u_best if u_best == u_best else REFINE(v, th_e, x, hh, z, u, a, c, sigma,
                                                     branch, u_ref, buf, tb, nv, a2, c2)
    return th_e, x_e, u_e


def _stage_template(v, out, branch, sigma, x0, u0, stop, u_ref, rtol, h_max, h, panels, mats,
                    vecs, buf, tb, react, piv):
    """Follow one stage (``branch``, sign ``sigma``) from (x0, u0) towards ``stop``.

    Returns ``(reason, x_end, u_end, n_panels, panels, next_branch, h)``: an Event
    code or _ZERO, the end state, the panels (rows s0, h, z, u0, theta_end, a,
    c: the dense output), the branch after a switch, and the last panel width.
    ``mats``, ``vecs``, ``buf``, ``tb``, ``react``, ``piv``: scratch of the curve (no heap
    per stage).
    """
    a = vecs[6]
    c = vecs[7]
    nv = vecs[8]
    a2 = vecs[9]
    c2 = vecs[10]
    coef0, coef_sign = STAGE_START(v, branch, sigma, x0, u0, react)
    coef_prev = coef0
    x, u, s = x0, u0, 0.0
    n_pan = int(0)  # not a literal: see the note above PIECES
    # (rtol >= 1, the measurements' accept-every-panel, still converges to 1e-14)
    tol_newton = NEWTON * rtol if rtol < 1.0 else 0.0
    truncated = False
    h_resume = 0.0  # the width the controller chose before a panel was ended at a kink
    ratio_prev, h_prev = 0.0, 1.0  # est / tol of the last panel accepted whole, its width
    for _ in range(10_000_000):
        remaining = sigma * (stop - x)
        if remaining <= 0.0:
            return ev.HORIZON, x, u, n_pan, panels, branch, h
        hh = min(h, h_max, remaining)
        f0, s0 = RATE(v, x, u, sigma, branch, u_ref)
        beta = 2.0 * sigma * s0
        if beta > 0.0 and beta * hh > Z_GROW:
            hh = Z_GROW / beta
        if not (hh > 16.0 * EPS * max(abs(x), 1.0)) or not (beta == beta):
            n2, adm2, lost2, sing2 = CLASSIFY(v, x, sigma * math.sqrt(max(u, 0.0)), out)
            small = abs(out[branch, nx.COEF]) < 1e-6 * abs(coef0)
            return (ev.SINGULAR if (sing2 or small) else ev.STEP_FAILURE), x, u, n_pan, \
                panels, branch, h
        last = hh == remaining
        z = beta * hh
        if not COLLOCATE(v, x, u, hh, z, beta, f0, sigma, branch, u_ref, tol_newton, mats, vecs,
                         buf, piv):
            h = 0.25 * hh
            truncated = False
            continue
        expand(vecs[3], a, c)
        u1 = dense(1.0, z, u, hh, a, c, buf)
        est, tol = PANEL_ERROR(a, hh, z, u, u1, rtol, u_ref)
        if not (u1 == u1) or not (est <= tol):
            fac = 0.25 if not (est == est and u1 == u1) else \
                max(0.2, 0.9 * (tol / est) ** (1.0 / 11.0))
            h = hh * fac
            truncated = False
            continue
        # the next width: by this estimate, but not beyond what the last panel's, scaled
        # as h^11, allows (where a Legendre coefficient of the tail is near a zero, the
        # estimate can be 1e3 too small, and the wider panel it suggests is rejected)
        ratio = max(est / tol, ratio_prev * min(hh / h_prev, 4.0) ** 11)
        h_next = hh * (4.0 if ratio == 0.0 else min(4.0, max(0.2, 0.9 * ratio ** (-1.0 / 11.0))))
        if abs(u1) > U_MAX:
            return ev.STEP_FAILURE, x, u, n_pan, panels, branch, h
        x1 = stop if last else x + sigma * hh
        if STILL(v, out, x1, u1, sigma, branch, coef_sign):
            if not truncated and KINKS.shape[0] > 0:
                # a reaction with a kink in the law changes sign inside: end the panel there
                first = KINK(v, out, x, hh, z, u, a, c, sigma, branch, u_ref, react, buf, tb, nv,
                             a2, c2)
                if first < 1.0 and first * hh > 1e-9 * max(abs(x), 1.0):
                    h = first * hh
                    h_resume = h_next
                    truncated = True
                    continue
            if truncated:  # the panel ended at a kink, not for its error: go on as before
                h_next = max(h_next, h_resume)
            else:
                ratio_prev, h_prev = est / tol, hh
            truncated = False
            panels, n_pan = STORE_PANEL(panels, n_pan, s, hh, z, u, 1.0, a, c)
            for q in range(REACTIONS.shape[0]):
                react[q] = out[branch, REACTIONS[q]]
            coef_prev = out[branch, nx.COEF]
            s += hh
            x, u, h = x1, u1, h_next
            if last:
                return ev.HORIZON, x, u, n_pan, panels, branch, h
            continue
        # -- the stage ends inside this panel: locate the first state off it --
        zero, th_e, guided, c_fld, c_th, c_u, slope, dd = END(
            v, out, x, hh, z, u, u1, a, c, sigma, branch, u_ref, coef_sign, coef_prev, react, buf,
            tb, nv, a2, c2)
        x_e = stop if (last and th_e == 1.0) else x + sigma * th_e * hh
        reason = _ZERO
        u_e = 0.0
        next_branch = branch
        if not zero:  # (at a zero of u the end is the rest state)
            if th_e == 1.0:
                u_e = u1
            elif guided:
                u_e = c_u + slope * (th_e - c_th)
            else:
                u_e = REFINE(v, th_e, x, hh, z, u, a, c, sigma, branch, u_ref, buf, tb, nv, a2, c2)
            reason, th_e, x_e, u_e, next_branch = END_REASON(
                v, out, x, hh, z, u, a, c, sigma, branch, u_ref, th_e, x_e, u_e, guided, c_th, c_u,
                slope, dd, buf, tb, nv, a2, c2)
        if reason == ev.CONTACT_LOST:
            th_e, x_e, u_e = CONTACT_END(v, out, x, hh, z, u, a, c, sigma, branch, u_ref, th_e,
                                         x_e, u_e, react, c_fld, c_th, c_u, buf, tb, nv, a2, c2)
        if reason == _ZERO:
            u_e = 0.0
        panels, n_pan = STORE_PANEL(panels, n_pan, s, hh, z, u, th_e, a, c)
        return reason, x_e, u_e, n_pan, panels, next_branch, hh
    return ev.STEP_FAILURE, x, u, n_pan, panels, branch, h


def _flush_template(pts, lanes, rows, nb, uo, nt):
    """The pending output points of a panel's Legendre sum: their u into ``pts``."""
    if nb > 0:
        legendre_many(lanes, nb, uo, nt)
        for i in range(nb):
            pts[rows[i], 1] = lanes[1, i]
    return 0


def _stage_points_template(v, panels, n_pan, sigma, branch, u_ref, x0, u0, x_e, u_e, points, pts,
                           npts, stage, vecs, outs, buf, tb, lanes, rows):
    """Append the stage's output points (phi, u, stage): evenly spaced in phi.

    Where a panel's part up to its end, theta_end, has |z theta_end| <= Z_OUT, one pass
    gives all of its points: the remainder N sampled on the panel's dense output at the
    :data:`OUT_NODES` Gauss nodes of that part (one branch row each), the solution with
    N's interpolant, of degree 2 NODES - 1, in Legendre coefficients
    (:func:`~phasemap.motion.phase.collocation.solve_legendre`), summed at each point.  That
    errs like the NODES-point Gauss rule of one pass per point, which a stiffer panel
    still takes (``_refine_template``): at 200 points per stage a twelfth of the rows.
    The sums wait in ``lanes`` (their tau) and ``rows`` (their row of ``pts``) and are
    evaluated :data:`LANES` at a time (:func:`~phasemap.motion.phase.collocation.legendre_many`).
    """
    n = NODES
    nv = vecs[8]
    a2 = vecs[9]
    c2 = vecs[10]
    nvo = outs[0, :OUT_NODES]
    uo = outs[1]
    wo = outs[2]
    ro = outs[3]
    length = sigma * (x_e - x0)
    count = points if (length > 0.0 and n_pan > 0) else 1
    pts = grow(pts, npts + count)
    p = 0
    ready = -1
    nt = 0
    nb = 0
    for k in range(count):
        sk = length * k / (count - 1) if count > 1 else 0.0
        while p < n_pan - 1 and sk > panels[p, 0] + panels[p, 4] * panels[p, 1]:
            p += 1
        uk = u0
        if k > 0 and k < count - 1:  # (the last point is the end state)
            row = panels[p]
            hh, z, up, te = row[1], row[2], row[3], row[4]
            theta = min(max((sk - row[0]) / row[1], 0.0), te)
            if theta <= 0.0:
                uk = up
            elif abs(z * te) <= Z_OUT:
                if ready != p:
                    nb = FLUSH(pts, lanes, rows, nb, uo, nt)
                    a = row[5:5 + n]
                    c = row[5 + n:5 + 2 * n]
                    beta = z / hh
                    hs = te * hh
                    xp = x0 + sigma * row[0]
                    on_series = series(z, up, hh, c, tb)
                    for j in range(OUT_NODES):
                        uj = dense_at(te * OUT_THETA[j], on_series, tb, z, up, hh, a, c, buf)
                        fj = VALUE(v, xp + sigma * hs * OUT_THETA[j], uj, sigma, branch, u_ref)
                        nvo[j] = 2.0 * sigma * fj - beta * uj
                    nt = solve_legendre(z * te, up, hs, nvo, uo, wo, ro)
                    ready = p
                if nb == LANES:
                    nb = FLUSH(pts, lanes, rows, nb, uo, nt)
                lanes[0, nb] = theta / te
                rows[nb] = npts + k
                nb += 1
                uk = math.nan  # the sum's, when the points are flushed
            else:
                uk = REFINE(v, theta, x0 + sigma * row[0], hh, z, up, row[5:5 + n],
                            row[5 + n:5 + 2 * n], sigma, branch, u_ref, buf, tb, nv, a2, c2)
        pts[npts + k, 0] = x0 + sigma * sk
        pts[npts + k, 1] = uk
        pts[npts + k, 2] = stage
    FLUSH(pts, lanes, rows, nb, uo, nt)
    if count > 1:
        pts[npts + count - 1, 0] = x_e
        pts[npts + count - 1, 1] = u_e
    return pts, npts + count


def _curve_template(v, phi0, omega0, lo, hi, max_stages, points, u_ref, rtol, h_max,
                    h_first):
    """The whole phase curve from (phi0, omega0): (points, stages) as arrays.

    ``points`` rows: phi, u, stage; ``stages`` rows: sign, start phi, start u,
    reason, end phi, end u.
    """
    out = np.empty((N_BRANCHES, N_FIELDS))
    pts = np.empty((max(points, 16), 3))
    npts = int(0)  # not a literal: see the note above PIECES
    stg = np.empty((8, 6))
    nst = 0
    panels = np.empty((64, _PANEL_COLS))
    mats = np.empty((2, NODES, NODES))
    vecs = np.empty((11, NODES))
    buf = np.empty(NODES + 2)
    tb = np.empty(SERIES)
    outs = np.empty((4, OUT_TERMS + 1))
    lanes = np.empty((4, LANES))
    rows = np.empty(LANES, dtype=np.int64)
    react = np.empty(REACTIONS.shape[0])
    piv = np.empty(NODES, dtype=np.int64)
    code = -1
    branch = -1
    if omega0 != 0.0:
        n, adm, lost, sing = CLASSIFY(v, phi0, omega0, out)
        bound = LEAVE(out, omega0)
        if STICK >= 0 and out[STICK, nx.STATUS] != nx.ABSENT:
            omega0 = 0.0  # an omega the model counts as zero: a rest state
        elif bound == bound:  # on a bound of phi, moving out
            code, phi0 = ev.LEFT_DOMAIN, bound
        elif sing and (n == nx.N_NONE or n == nx.N_CONTINUUM):
            code = ev.SINGULAR
        elif n == nx.N_UNIQUE:
            if out[adm, nx.STATUS] == nx.SEPARATION:
                code = ev.CONTACT_LOST  # the only motion leaves a contact
            else:
                branch = adm
        else:
            code = ev.fate_without_unique(n, lost, sing)
    if omega0 == 0.0:
        code, branch = AT_REST(v, phi0, out)
    if code >= 0:
        sign = 0.0 if omega0 == 0.0 else (1.0 if omega0 > 0.0 else -1.0)
        pts[0, 0], pts[0, 1], pts[0, 2] = phi0, omega0 * omega0, 0.0
        stg[0, 0], stg[0, 1], stg[0, 2] = sign, phi0, omega0 * omega0
        stg[0, 3], stg[0, 4], stg[0, 5] = code, phi0, omega0 * omega0
        return pts[:1], stg[:1]
    sigma = DIRECTIONS[branch]
    x, u = phi0, omega0 * omega0
    h = h_first
    while True:
        stop = hi if sigma > 0.0 else lo
        reason, x_e, u_e, n_pan, panels, next_branch, h = STAGE(
            v, out, branch, sigma, x, u, stop, u_ref, rtol, h_max, h, panels, mats, vecs, buf, tb,
            react, piv)
        pts, npts = STAGE_POINTS(v, panels, n_pan, sigma, branch, u_ref, x, u, x_e, u_e, points,
                                 pts, npts, float(nst), vecs, outs, buf, tb, lanes, rows)
        new_branch = branch
        if reason == _ZERO:
            code, m2 = AT_REST(v, x_e, out)
            if code < 0:
                reason, new_branch = ev.REVERSAL, m2
            else:
                reason = code
        elif reason == ev.SWITCH:
            new_branch = next_branch
        stg = grow(stg, nst + 1)
        stg[nst, 0], stg[nst, 1], stg[nst, 2] = sigma, x, u
        stg[nst, 3], stg[nst, 4], stg[nst, 5] = reason, x_e, u_e
        nst += 1
        action, fate, _ = ev.after_event(reason, int(0), nst, max_stages)
        if action == ev.END:
            if fate == ev.MAX_EVENTS:  # the stages ran out: the last one says so
                stg[nst - 1, 3] = ev.MAX_EVENTS
            break
        x, u = x_e, (0.0 if reason == ev.REVERSAL else u_e)
        branch = new_branch
        sigma = DIRECTIONS[branch]
        h = max(h, 1e-3 * h_max)
    return pts[:npts], stg[:nst]


#: A constant argument of a called piece is written ``bool(True)``, ``int(-1)``: numba
#: compiles a function once more for each literal it is called with (ROOT was compiled
#: three times, 3.9 s of CPU).  A counter that starts at 0 and is passed in a loop is
#: started at ``int(0)``: numba's type inference sees the literal 0 first and compiled
#: the callee for it before the counter's type became int64 (STAGE_POINTS, 1.8 s).
#: STAGE is inlined into CURVE's numba IR ("ir", see
#: :func:`phasemap.core.compile.specialize`): compiled on its own, its code was optimised
#: and generated twice.  With the contract's rows called with ``bool(False)`` too
#: (:meth:`phasemap.core.codegen._Source.call`), the ladder's simulate, phase_curve and a
#: 16 x 16 scene compiled from cold in 98 s of CPU, against 127 s before.
#:
#: The tracer's pieces, compiled in this order: (name, template, inline); CURVE is the
#: whole curve.  RATE and VALUE (the branch row, per
#: collocation node) and the stage's named pieces are LLVM-inlined; CLASSIFY, STILL,
#: REFINE and ROOT (once per panel or event) are called, which cuts the cold compile
#: by a sixth (43.7 -> 36.2 s for the 17-row rod on a step, 22.7 -> 17.6 s for the
#: hinge) for curves 7-11 % slower.
PIECES = (("ROW", _row_template, True),
          ("RATE", _rate_template, True),
          ("VALUE", _value_template, True),
          ("CLASSIFY", _classify_template, False),
          ("STILL", _still_template, False),
          ("REFINE", _refine_template, False),
          ("ROOT", _root_template, False),
          ("FLUSH", _flush_template, True),
          ("STAGE_POINTS", _stage_points_template, False),
          ("AT_REST", _at_rest_template, False),
          ("STAGE_START", _stage_start_template, True),
          ("LEAVE", _leave_template, True),
          ("COLLOCATE", _collocate_template, True),
          ("PANEL_ERROR", _panel_error_template, True),
          ("KINK", _kink_template, True),
          ("STORE_PANEL", _store_panel_template, True),
          ("END", _end_template, True),
          ("END_REASON", _end_reason_template, True),
          ("CONTACT_END", _contact_end_template, True),
          ("STAGE", _stage_template, "ir"),
          ("CURVE", _curve_template, False))
#: The pieces that allocate arrays (or return one), compiled with numba's reference
#: counts; the others without (``specialize(counts=False)``).
COUNTED = ("CURVE", "STORE_PANEL")
