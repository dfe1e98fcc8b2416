r"""Phase curves omega(phi) of every one-degree-of-freedom model: :func:`phase_curve`.

A model whose :class:`phasemap.Dynamics` has one coordinate triple
``(phi, omega, phi_ddot)`` has a phase plane.  On a *stage* one branch b of
the friction law is active and the sign sigma of omega is fixed; with
u = omega^2 and phi'' = (1/2) du/dphi the motion equation becomes a
first-order equation for u(phi),

    du/dphi = 2 F_b(phi, u),

where F_b is the senior derivative phi'' read from the model's own branch row
(``branch_row_inline`` of the generated contract, evaluated at omega =
sigma sqrt(u)): the same physics as :func:`phasemap.classify`, the grid and
the integrator.  :func:`phase_curve` follows u stage by stage in phi, with no
time stepping and no per-system code, and ends every stage at an exactly
located event.  Like the integrator it is compiled once per model
(:func:`phasemap._compile.specialize`) and cached on disk.

Method: exponential Gauss collocation in phi
--------------------------------------------
For the seed systems F_b is affine in u (the ladder with a constant slope,
the wheel with slope -l (r sin phi + delta sigma cos phi)/bracket) or
piecewise affine (the hinge pendulum, through |Q_n|), and the slope can be
huge: the ladder's is 3 sigma f/(2 - f^2), unbounded as f -> sqrt 2.  So
each panel [phi_k, phi_k + sigma h] (s = sigma (phi - phi_k) in [0, h]) splits
the right-hand side f = 2 sigma F_b into a frozen linear part and a remainder,

    du/ds = beta u + N(s, u),   beta = df/du at the panel start,

and solves it by variation of constants, u(s) = e^{beta s} u_k +
int_0^s e^{beta (s - t)} N(t) dt, with N replaced by its polynomial
interpolant at the :data:`NODES` Gauss-Legendre points of the panel
(collocation: the stage values U_i solve the same formula at the nodes, by
Newton's method with the slopes dF/du taken from two evaluations of the
branch row per node; for an affine F_b one step is exact).  The iteration
stops where its correction (relative to |u| + u_ref) is below 1e-14 or, at a
loose rtol, below :data:`NEWTON` rtol times 1 - its contraction (measured
between two corrections, 1/2 before).  N is evaluated at the iterate before
the last correction, about correction / (1 - contraction) from the solution,
which moves u at the panel's end by h |dN/du| (below about 1) times that: a
thousandth of what the panel may err.  The weights
int e^{z (theta - t)} t^k dt are the phi-functions of exponential integrators,
z = beta h, computed without cancellation for every z (Taylor series and a
downward recurrence for |z| < 6, the upward recurrence beyond), so that

* for a moderate slope the method is Gauss collocation: **order 2 NODES = 12**
  in the panel width (the test suite measures it);
* for a huge slope it is exact for the linear part: a boundary layer of width
  1/|beta| is resolved by the exponential, not by panels, and a decaying
  exponential (f just above sqrt 2) puts u on its slow curve in one panel;
  a growing one is followed at most :data:`Z_GROW` e-folds per panel.

The panel width adapts: the error estimate is the tail of the Legendre
expansion of the interpolated N, extrapolated to the degree the collocation
actually errs at (see ``_panel``), against ``rtol (|u| + u_ref)`` with u_ref
the square of the model's velocity scale.  The interpolant is also the dense
output: u at any phi of a panel with the same accuracy, which the event
location and the output points use (where |z| <= 1 evaluated by its Taylor
series in the panel's variable, with no phi-functions per point).  The next
width heeds the last panel's estimate (scaled as h^11) as well as this one's,
so that a tail coefficient passing near zero does not suggest a panel that
fails.

Where a reaction the model names in ``Model.kinks`` changes sign inside a panel
(the hinge's R_n = m Q_n, where |Q_n| has its kink), the panel is redone to end
at that sign change, so that no panel straddles a kink of F_b; the next one
resumes the width chosen before.  A reaction that enters F_b without a kink
(the wheel's contact force F) is not split at: a declared system's modes fix
every sign their laws depend on, so its kinks are empty, and a model that does
not say splits at every reaction.

Events (the codes of :class:`phasemap.Event`)
---------------------------------------------
After every panel the end state is classified with the model's ``point``
function, exactly as :func:`phasemap.classify` does (and as the integrator
does after every step).  The stage goes on while u > 0 and the classification
is unique, on the stage's branch, with the coefficient of the senior
derivative keeping its sign.  Otherwise the first state where that stops is
located on the dense output to double precision in phi and classified there.
A zero of u, of a reaction or of the coefficient is found by Newton's method
(a few Gauss passes; for u with the slope the equation gives, one or two); a
change of classification by bisection, on the
straight line u is within 1e-8 of such a zero, or on Gauss passes where there
is none:

* u = 0 (or an omega the model counts as zero): the rest state (phi, 0) is
  classified: a unique solution on the stick branch is ``rest``; a unique
  solution on a slip (roll, turn) branch is ``reversal`` and the next stage
  starts from rest in that branch's direction; no solution is
  ``no_solution`` (``singular`` if a coefficient of the senior derivative
  vanishes, ``contact_lost`` if a branch needs a one-sided contact to pull);
  two or more solutions are ``indeterminate`` (a continuum at a vanishing
  coefficient is ``singular``).  The tracer never picks a branch.
* the stage's branch needs a one-sided contact to pull: ``contact_lost``, at
  the crossing N = 0 (the ladder's floor or wall, the wheel's bounce (12)).
* the coefficient of the senior derivative vanishes or changes sign
  (the wheel's bracket): ``singular``; a state with no solution or several:
  ``no_solution``, ``indeterminate``, ``continuum`` as the integrator names
  them; another branch of the same direction takes over: ``switch``, and a
  new stage starts there.
* phi leaves ``phi_range``: ``horizon``, at the boundary; where that boundary
  is the model's own domain edge (the ladder lying flat at pi/2),
  ``left_domain``.
* the stage count runs out: the last stage's reason becomes ``max_events``.
* u would exceed :data:`U_MAX` = 1e300 rad2 s-2, or the panel width falls
  below double-precision resolution: ``step_failure`` (``singular`` when the
  active coefficient has fallen below 1e-6 of its value at the stage start).

Ties: at a stage start, the model's ``point`` decides (a grazing N = 0 is
kept); along a stage a state counts as leaving the stage where its
classification does.

Dataset
-------
Dimension ``point``: ``phi``, ``omega`` (signed: the sign of the stage, 0 at
rest), ``omega_squared`` and ``point_stage`` (the index of the stage each
point belongs to; the stage coordinate is called ``stage``, so the per-point
index cannot be).  Each stage contributes ``points_per_stage`` points evenly
spaced in phi from its start to its exact end point (one point for a stage
that ends where it starts); consecutive stages share their reversal point.
Dimension ``stage``: ``stage_sign``, ``stage_start_phi``,
``stage_start_omega``, ``stage_end_reason`` (int8 CF flags of
:class:`phasemap.Event`), ``stage_end_phi`` and ``stage_end_omega``.
Global attributes: ``phasemap_kind = "phase_curve"``, the model, the version,
``phasemap_initial_<state>``, ``phasemap_fixed_<param>``, ``phasemap_phi_range``,
``end_reason`` and ``end_message``.

For developers
--------------
Nothing: any model with one coordinate triple in its ``dynamics`` gets phase
curves from its branch functions.  A hand-written model whose law bends where a
reaction changes sign within one branch names that reaction in ``Model.kinks``
(declared systems need not: their modes fix those signs).  The names of the coordinate and its
velocity are read from the declaration.
"""

from __future__ import annotations

import inspect
import math

import numpy as np
import xarray as xr
from numba import njit

from . import _numerics as nx
from . import events as ev
from ._compile import specialize
from .integrate import _grow
from ._dataset import cf_header, squared_units
from .model import Model
from .models import get_model

__all__ = ["NODES", "RTOL", "U_MAX", "Z_GROW", "phase_curve"]

#: Gauss-Legendre collocation nodes per panel (order 2 NODES for moderate slopes).
NODES = 6
#: Relative accuracy asked of every panel (of |u| + u_ref).
RTOL = 1e-14
#: Widest panel (rad).
H_MAX = 0.5
#: The collocation's Newton iteration stops where its correction, relative to |u| +
#: u_ref and divided by 1 - the measured contraction, is below NEWTON rtol (or 1e-14).
NEWTON = 1e-3
#: Largest growth exponent beta h of one panel (a growing exponential).
Z_GROW = 4.0
#: Terms of the Taylor series in theta of a panel's dense output, used where |z| <= Z_SERIES.
SERIES = 22
Z_SERIES = 1.0
#: Largest omega^2 a stage may reach (rad2 s-2); beyond it, step_failure.
U_MAX = 1e300
#: Default half width of the phi range of the unbounded models.
_DEFAULT_SPAN = 4.0 * math.pi
#: Internal marker: the stage ended at omega = 0 (classified afterwards).
_ZERO = -1
#: Columns of a stored panel: s0, h, z, u0, theta_end, then a (Legendre), c (monomial).
_PANEL_COLS = 5 + 2 * NODES
EPS = float(np.finfo(float).eps)


# ---------------------------------------------------------------- collocation tables


def _tables(n: int):
    """Nodes, weights and the maps from node values of N to its expansions.

    ``LEG[k, j]``: Legendre coefficient a_k of the interpolant (shifted to
    [0, 1]) per node value; ``MON[m, j]``: its monomial coefficient of t^m;
    ``A0[i, j]``: int_0^{theta_i} of the j-th Lagrange polynomial.
    """
    from numpy.polynomial import legendre as L
    from numpy.polynomial import polynomial as P

    x, w = L.leggauss(n)
    theta, gw = (x + 1.0) / 2.0, w / 2.0
    leg = np.empty((n, n))
    for k in range(n):
        e = np.zeros(k + 1)
        e[k] = 1.0
        leg[k] = (2 * k + 1) * gw * L.legval(x, e)
    # shifted Legendre P_k(2t - 1) in monomials of t (exact small integers)
    shift = np.zeros((n, n))
    for k in range(n):
        e = np.zeros(k + 1)
        e[k] = 1.0
        c = L.leg2poly(e)
        poly = np.zeros(1)
        for m, cm in enumerate(c):  # sum cm (2t - 1)^m
            poly = P.polyadd(poly, cm * P.polypow([-1.0, 2.0], m))
        shift[:len(poly), k] = poly[:n]
    mon = shift @ leg
    a0 = np.empty((n, n))
    for i in range(n):
        a0[i] = _legendre_integrals(theta[i], n) @ leg
    return theta, gw, leg, mon, a0


def _legendre_integrals(theta: float, n: int) -> np.ndarray:
    """int_0^theta P_k(2t - 1) dt for k < n (numpy, for the tables)."""
    xx = 2.0 * theta - 1.0
    p = [1.0, xx]
    for k in range(1, n + 1):
        p.append(((2 * k + 1) * xx * p[k] - k * p[k - 1]) / (k + 1))
    out = np.empty(n)
    out[0] = theta
    for k in range(1, n):
        out[k] = (p[k + 1] - p[k - 1]) / (2.0 * (2 * k + 1))
    return out


THETA, GLW, LEG, MON, A0 = _tables(NODES)
FACT = np.array([math.factorial(k) for k in range(NODES + 3)], dtype=float)
INV_FACT = 1.0 / FACT
#: 1/k for the Taylor series of the phi-functions (a multiply, not a divide, per term).
INV_INT = np.array([0.0] + [1.0 / k for k in range(1, 100)])
#: Legendre recurrence (2k+1)/(k+1), k/(k+1) and the integral weight 1/(2 (2k+1)).
LEG_A = np.array([(2 * k + 1) / (k + 1) for k in range(NODES)])
LEG_B = np.array([k / (k + 1) for k in range(NODES)])
LEG_W = np.array([1.0 / (2.0 * (2 * k + 1)) for k in range(NODES)])


@njit(cache=True, error_model="numpy")
def _phis(w, out):
    """phi_k(w) = int_0^1 e^{(1 - t) w} t^{k-1}/(k-1)! dt for k < len(out) (phi_0 = e^w).

    |w| < 6: the top one by its Taylor series, the others by the downward
    recurrence phi_k = w phi_{k+1} + 1/k! (stable there); beyond, the upward
    recurrence phi_{k+1} = (phi_k - 1/k!)/w from expm1 (no cancellation).
    """
    top = out.shape[0] - 1
    if abs(w) < 6.0:
        term = INV_FACT[top]
        acc = term
        for j in range(1, 80):
            term *= w * INV_INT[j + top]
            acc += term
            if abs(term) <= 1e-17 * abs(acc):
                break
        out[top] = acc
        for k in range(top - 1, 0, -1):
            out[k] = w * out[k + 1] + INV_FACT[k]
        out[0] = math.exp(w)
    else:
        out[0] = math.exp(w)
        out[1] = math.expm1(w) / w
        for k in range(1, top):
            out[k + 1] = (out[k] - INV_FACT[k]) / w


@njit(cache=True, error_model="numpy")
def _dense(theta, z, u0, h, a, c, buf):
    """u at theta in [0, 1] of a panel: e^{z theta} u0 + h int_0^theta e^{z (theta - t)} p(t) dt.

    ``a``, ``c``: Legendre and monomial coefficients of the interpolant p of N.
    The plain integral comes from the Legendre form (no cancellation), the
    exponential's correction from the monomials times phi-functions.
    """
    n = a.shape[0]
    x = 2.0 * theta - 1.0
    acc = a[0] * theta
    pm, pk = 1.0, x
    for k in range(1, n):
        pp = LEG_A[k] * x * pk - LEG_B[k] * pm
        acc += a[k] * (pp - pm) * LEG_W[k]
        pm, pk = pk, pp
    e = 1.0
    if z != 0.0:
        w = z * theta
        _phis(w, buf)
        corr = 0.0
        tp = theta
        for k in range(n):
            corr += c[k] * tp * FACT[k] * buf[k + 2]
            tp *= theta
        acc += w * corr
        e = buf[0]
    return e * u0 + h * acc


@njit(cache=True, error_model="numpy")
def _series(z, u0, h, c, b):
    """Taylor coefficients b of a panel's u in theta (u = sum b_m theta^m), where
    |z| <= Z_SERIES; returns whether it computed them.

    u solves du/dtheta = z u + h p(theta) with p = sum c_k theta^k, so b_0 = u0 and
    (m + 1) b_{m+1} = z b_m + h c_m.  With |z| <= 1 the :data:`SERIES` terms reach
    1e-18 of the sum, which is as accurate as :func:`_dense` (a few ulp of |u0| + h |p|)
    and, evaluated by Horner's rule, a fifth of its cost (no phi-functions per point).
    """
    if not (abs(z) <= Z_SERIES):
        return False
    n = c.shape[0]
    b[0] = u0
    for m in range(SERIES - 1):
        bm = z * b[m]
        if m < n:
            bm += h * c[m]
        b[m + 1] = bm * INV_INT[m + 1]
    return True


@njit(cache=True, error_model="numpy")
def _dense_at(theta, series, b, z, u0, h, a, c, buf):
    """u at theta of a panel: its Taylor sum ``b`` where ``series`` (see :func:`_series`),
    else :func:`_dense`."""
    if series:
        acc = b[SERIES - 1]
        for m in range(SERIES - 2, -1, -1):
            acc = acc * theta + b[m]
        return acc
    return _dense(theta, z, u0, h, a, c, buf)


@njit(cache=True, error_model="numpy")
def _expand(nv, a, c):
    """Legendre (``a``) and monomial (``c``) coefficients of the interpolant of node values nv."""
    n = nv.shape[0]
    for k in range(n):
        ak = 0.0
        ck = 0.0
        for j in range(n):
            ak += LEG[k, j] * nv[j]
            ck += MON[k, j] * nv[j]
        a[k] = ak
        c[k] = ck


@njit(cache=True, error_model="numpy")
def _weights(z, A, buf, E, P1):
    """A[i, j] = int_0^{theta_i} e^{z (theta_i - t)} L_j(t) dt (the collocation matrix),
    and E[i] = e^{z theta_i}, P1[i] = phi_1(z theta_i) (the start of the Newton solve)."""
    n = A.shape[0]
    for i in range(n):
        E[i] = 1.0
        P1[i] = 1.0
        for j in range(n):
            A[i, j] = A0[i, j]
    if z == 0.0:
        return
    for i in range(n):
        th = THETA[i]
        w = z * th
        _phis(w, buf)
        E[i] = buf[0]
        P1[i] = buf[1]
        tp = th
        for k in range(n):
            f = w * tp * FACT[k] * buf[k + 2]
            tp *= th
            for j in range(n):
                A[i, j] += f * MON[k, j]


@njit(cache=True, error_model="numpy")
def _factor(M, piv):
    """LU factors of M in place, by Gaussian elimination with partial pivoting (rows
    swapped whole, multipliers below the diagonal, the pivot rows in ``piv``)."""
    n = M.shape[0]
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(M[i, k]) > abs(M[p, k]):
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                M[k, j], M[p, j] = M[p, j], M[k, j]
        for i in range(k + 1, n):
            f = M[i, k] / M[k, k]
            for j in range(k + 1, n):
                M[i, j] -= f * M[k, j]
            M[i, k] = f


@njit(cache=True, error_model="numpy")
def _lu_solve(M, piv, r):
    """Solve M x = r in place (r becomes x) with the factors of :func:`_factor`."""
    n = r.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            r[k], r[p] = r[p], r[k]
    for k in range(n):
        for i in range(k + 1, n):
            r[i] -= M[i, k] * r[k]
    for k in range(n - 1, -1, -1):
        acc = r[k]
        for j in range(k + 1, n):
            acc -= M[k, j] * r[j]
        r[k] = acc / M[k, k]


# ---------------------------------------------------------------- per-model templates

# Compile-time structure of the model being compiled (see phasemap._compile).
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
#: Indices into REACTIONS of the reactions whose sign change bends the law (Model.kinks).
KINKS = np.zeros(0, dtype=np.int64)
ROW = None
RATE = None
STILL = None
REFINE = None
ROOT = None
STAGE_POINTS = None
VALUE = None
CLASSIFY = None
AT_REST = None
STAGE = None
N_FIELDS = 0


def _row_template(v, x, u, sigma, mode):
    """The row of branch ``mode`` at phi = x, omega = sigma sqrt(u) (u below 0 read as 0)."""
    v[PHI] = x
    v[OMEGA] = sigma * math.sqrt(max(u, 0.0))
    DERIVE(v)
    return BRANCH_ROW(v, mode)


def _rate_template(v, x, u, sigma, mode, u_ref):
    """(F, dF/du): phi'' of branch ``mode`` at (x, u = omega^2) and its slope in u.

    Two evaluations of the branch row, at u and a little above (an affine F is
    exact); below u = 0 the row is continued linearly from u = 0.
    """
    ua = u if u > 0.0 else 0.0
    d = 1e-4 * (ua + u_ref)
    fa = ROW(v, x, ua, sigma, mode)[ACC]
    v[OMEGA] = sigma * math.sqrt(ua + d)
    if OMEGA_DERIVED:
        DERIVE(v)
    fb = BRANCH_ROW(v, mode)[ACC]
    s = (fb - fa) / d
    return fa + s * (u - ua), s


def _value_template(v, x, u, sigma, mode, u_ref):
    """phi'' of branch ``mode`` at (x, u = omega^2) (continued linearly below u = 0)."""
    if u >= 0.0:
        return ROW(v, x, u, sigma, mode)[ACC]
    return RATE(v, x, u, sigma, mode, u_ref)[0]


def _classify_template(v, x, omega, out):
    """Classify (x, omega) with the model's point function: (n, first admissible, lost, singular)."""
    v[PHI] = x
    v[OMEGA] = omega
    DERIVE(v)
    POINT(v, out)
    n, stag, lost, sing = nx.summarize(out, STICK)
    adm = -1
    for b in range(N_BRANCHES):
        st = out[b, nx.STATUS]
        if st == nx.ADMISSIBLE or st == nx.SEPARATION:
            adm = b
            break
    return n, adm, lost, sing


def _still_template(v, out, x, u, sigma, mode, coef_sign):
    """The state (x, u) is still on the stage of ``mode``: u > 0, unique, same branch,
    same sign of the coefficient, and an omega the model does not count as zero."""
    if not (u > 0.0):
        return False
    n, adm, lost, sing = CLASSIFY(v, x, sigma * math.sqrt(u), out)
    if n != 1 or adm != mode or not DOMAIN(v):  # (v holds the state: its own domain)
        return False
    if STICK >= 0 and out[STICK, nx.STATUS] != nx.ABSENT:
        return False
    return coef_sign == 0.0 or out[mode, nx.COEF] * coef_sign > 0.0


def _refine_template(v, theta, x_p, hh, z, u_p, a, c, sigma, mode, u_ref, buf, tb, nv, a2, c2):
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
    series = _series(z, u_p, hh, c, tb)
    for j in range(n):
        uj = _dense_at(theta * THETA[j], series, tb, z, u_p, hh, a, c, buf)
        fj = VALUE(v, x_p + sigma * hs * THETA[j], uj, sigma, mode, u_ref)
        nv[j] = 2.0 * sigma * fj - beta * uj
    _expand(nv, a2, c2)
    return _dense(1.0, z * theta, u_p, hs, a2, c2, buf)


def _root_template(v, field, sg, lo, hi, glo, ghi, tol, x, hh, z, u, a, c, sigma, mode, u_ref,
                   buf, tb, nv, a2, c2, fine):
    """The zero of g(theta) = sg u (``field`` < 0) or sg (``field`` of the row of ``mode``)
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
    series = _series(z, u, hh, c, tb)  # (REFINE recomputes the same)
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
                ut = REFINE(v, t, x, hh, z, u, a, c, sigma, mode, u_ref, buf, tb, nv, a2, c2)
                st = 2.0 * sigma * hh * VALUE(v, x + sigma * t * hh, ut, sigma, mode, u_ref)
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
                gp = _dense_at(t + dt, series, tb, z, u, hh, a, c, buf)
                gm = _dense_at(t - dt, series, tb, z, u, hh, a, c, buf)
                if field >= 0:
                    gp = ROW(v, x + sigma * (t + dt) * hh, gp, sigma, mode)[field]
                    gm = ROW(v, x + sigma * (t - dt) * hh, gm, sigma, mode)[field]
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
                ut = REFINE(v, t, x, hh, z, u, a, c, sigma, mode, u_ref, buf, tb, nv, a2, c2)
            else:
                ut = _dense_at(t, series, tb, z, u, hh, a, c, buf)
            if field < 0:
                gt = sg * ut
            else:
                gt = sg * ROW(v, x + sigma * t * hh, ut, sigma, mode)[field]
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
    if n == nx.N_NONE:
        return (ev.CONTACT_LOST if lost else ev.NO_SOLUTION), -1
    return ev.INDETERMINATE, -1


def _stage_template(v, out, mode, sigma, x0, u0, stop, u_ref, rtol, h_max, h, panels, mats,
                    vecs, buf, tb, react, piv):
    """Follow one stage (branch ``mode``, sign ``sigma``) from (x0, u0) towards ``stop``.

    Returns ``(reason, x_end, u_end, n_panels, panels, next_mode, h)``: an Event
    code or _ZERO, the end state, the panels (rows s0, h, z, u0, theta_end, a,
    c: the dense output), the branch after a switch, and the last panel width.
    ``mats``, ``vecs``, ``buf``, ``tb``, ``react``, ``piv``: scratch of the curve (no heap
    per stage).
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
    a = vecs[6]
    c = vecs[7]
    nv = vecs[8]
    a2 = vecs[9]
    c2 = vecs[10]
    nr = REACTIONS.shape[0]
    v[PHI] = x0
    v[OMEGA] = sigma * math.sqrt(u0)
    DERIVE(v)
    r0 = BRANCH_ROW(v, mode)
    coef0 = r0[nx.COEF]
    coef_sign = 1.0 if coef0 > 0.0 else (-1.0 if coef0 < 0.0 else 0.0)
    for q in range(nr):
        react[q] = r0[REACTIONS[q]]
    coef_prev = coef0
    x, u, s = x0, u0, 0.0
    n_pan = 0
    # (rtol >= 1, the measurements' accept-every-panel, still converges to 1e-14)
    tol_newton = NEWTON * rtol if rtol < 1.0 else 0.0
    truncated = False
    h_resume = 0.0  # the width the controller chose before a panel was ended at a kink
    ratio_prev, h_prev = 0.0, 1.0  # est / tol of the last panel accepted whole, its width
    for _ in range(10_000_000):
        remaining = sigma * (stop - x)
        if remaining <= 0.0:
            return ev.HORIZON, x, u, n_pan, panels, mode, h
        hh = min(h, h_max, remaining)
        f0, s0 = RATE(v, x, u, sigma, mode, u_ref)
        beta = 2.0 * sigma * s0
        if beta > 0.0 and beta * hh > Z_GROW:
            hh = Z_GROW / beta
        if not (hh > 16.0 * EPS * max(abs(x), 1.0)) or not (beta == beta):
            n2, adm2, lost2, sing2 = CLASSIFY(v, x, sigma * math.sqrt(max(u, 0.0)), out)
            small = abs(out[mode, nx.COEF]) < 1e-6 * abs(coef0)
            return (ev.SINGULAR if (sing2 or small) else ev.STEP_FAILURE), x, u, n_pan, \
                panels, mode, h
        last = hh == remaining
        z = beta * hh
        _weights(z, A, buf, E, P1)
        n0 = 2.0 * sigma * f0 - beta * u
        for i in range(n):
            U[i] = E[i] * u + hh * THETA[i] * P1[i] * n0
        # collocation: U = E u + hh A N(U), by Newton with the slopes of the first pass
        converged = False
        worst_prev = math.inf
        for it in range(10):
            for j in range(n):
                xj = x + sigma * hh * THETA[j]
                if it == 0:
                    fj, sj = RATE(v, xj, U[j], sigma, mode, u_ref)
                    Jd[j] = 2.0 * sigma * sj - beta
                else:
                    fj = VALUE(v, xj, U[j], sigma, mode, u_ref)
                Nv[j] = 2.0 * sigma * fj - beta * U[j]
            for i in range(n):
                acc = 0.0
                for j in range(n):
                    acc += A[i, j] * Nv[j]
                R[i] = U[i] - E[i] * u - hh * acc
            if it == 0:  # the Newton matrix (slopes of the first pass) is factored once
                for i in range(n):
                    for j in range(n):
                        M[i, j] = -hh * A[i, j] * Jd[j]
                    M[i, i] += 1.0
                _factor(M, piv)
            _lu_solve(M, piv, R)
            worst = 0.0
            for i in range(n):
                U[i] -= R[i]
                worst = max(worst, abs(R[i]) / (abs(U[i]) + u_ref))
            if not (worst == worst):
                break
            # N was evaluated at U before this correction, about (1 + rate / (1 - rate))
            # times its size from the solution (rate: the contraction, 1/2 until measured)
            rate = worst / worst_prev if it > 0 else 0.5
            if worst <= 1e-14 or (rate < 1.0 and worst <= (1.0 - rate) * tol_newton):
                converged = True
                break
            worst_prev = worst
        if not converged:
            h = 0.25 * hh
            truncated = False
            continue
        _expand(Nv, a, c)
        u1 = _dense(1.0, z, u, hh, a, c, buf)
        # error: the Legendre tail of N (degrees n-2, n-1), extrapolated by its
        # decay over two degrees (rho) to about degree n + 5, near where the
        # order-2n collocation errs; the exponent is measured to be on the safe
        # side for the wheel, whose bracket has complex zeros near the real axis
        tail = abs(a[n - 1]) + abs(a[n - 2])
        head = abs(a[n - 3]) + abs(a[n - 4])
        rho = 1.0 if tail >= head else tail / head
        grow = math.exp(z) if z > 0.0 else 1.0
        est = hh * grow * tail * rho ** 3
        tol = rtol * (max(abs(u), abs(u1)) + u_ref)
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
            return ev.STEP_FAILURE, x, u, n_pan, panels, mode, h
        x1 = stop if last else x + sigma * hh
        if STILL(v, out, x1, u1, sigma, mode, coef_sign):
            if not truncated and KINKS.shape[0] > 0:
                # a reaction with a kink in the law changes sign inside: end the panel there
                first = 2.0
                for q in KINKS:
                    if react[q] * out[mode, REACTIONS[q]] < 0.0:
                        sg = 1.0 if react[q] > 0.0 else -1.0
                        lo, hi, _ul, _uh = ROOT(v, REACTIONS[q], sg, 0.0, 1.0, sg * react[q],
                                          sg * out[mode, REACTIONS[q]],
                                          4.0 * EPS * max(abs(x), hh) / hh, x, hh, z, u, a, c,
                                          sigma, mode, u_ref, buf, tb, nv, a2, c2, False)
                        first = min(first, hi)
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
            panels = _grow(panels, n_pan + 1)
            row = panels[n_pan]
            row[0], row[1], row[2], row[3], row[4] = s, hh, z, u, 1.0
            row[5:5 + n] = a
            row[5 + n:5 + 2 * n] = c
            n_pan += 1
            for q in range(nr):
                react[q] = out[mode, REACTIONS[q]]
            coef_prev = out[mode, nx.COEF]
            s += hh
            x, u, h = x1, u1, h_next
            if last:
                return ev.HORIZON, x, u, n_pan, panels, mode, h
            continue
        # -- the stage ends inside this panel: locate the first state off it --
        th_hi = 1.0
        reason = -100
        th_e = 1.0
        if u1 <= 0.0:
            # the zero of u (u > 0 at the panel start, where the stage goes on)
            lo, hi, u_lo, u_hi = ROOT(v, -1, 1.0, 0.0, 1.0, u, u1,
                                      4.0 * EPS * max(abs(x), hh) / hh, x, hh, z, u, a, c,
                                      sigma, mode, u_ref, buf, tb, nv, a2, c2, True)
            if lo == 0.0 or STILL(v, out, x + sigma * lo * hh, u_lo, sigma, mode, coef_sign):
                reason = _ZERO
                th_e = hi
            else:
                th_hi = lo
        c_fld, c_th, c_u = -1, 2.0, math.nan
        guided = False
        slope = 0.0
        dd = 0.0
        if reason != _ZERO:
            lo, hi = 0.0, th_hi
            tol_b = 2.0 * EPS * max(abs(x), hh) / hh
            # Where a reaction or the coefficient of the stage's branch has changed
            # sign by th_hi, the state leaves the stage at or just past (by the
            # tolerance of the sign test) the first such zero: find it, bracket the
            # change of classification within +-1e-11 (else +-1e-8) of it, where u is a
            # straight line to rounding, and bisect on that line instead of a Gauss
            # pass per step.  Otherwise (or if the bracket fails) plain bisection.
            c_lo, c_ulo = 0.0, math.nan
            for q in range(nr + 1):
                fld = REACTIONS[q] if q < nr else nx.COEF
                g0 = react[q] if q < nr else coef_prev
                g1 = out[mode, fld]
                if g0 * g1 < 0.0:
                    sg = 1.0 if g0 > 0.0 else -1.0
                    g1 = sg * g1
                    top = th_hi
                    if c_lo > 0.0:  # a zero found: this one matters only before it
                        g1 = sg * ROW(v, x + sigma * c_lo * hh, c_ulo, sigma, mode)[fld]
                        top = c_lo
                        if g1 > 0.0:
                            continue  # its first zero is not before c_lo: not earlier
                    l_c, h_c, ul_c, u_c = ROOT(v, fld, sg, 0.0, top, sg * g0, g1, tol_b, x, hh,
                                               z, u, a, c, sigma, mode, u_ref, buf, tb, nv, a2, c2,
                                               True)
                    if h_c < c_th and u_c == u_c and ul_c == ul_c:
                        c_fld, c_th, c_u, c_lo, c_ulo = fld, h_c, u_c, l_c, ul_c
            for d_try in (1e-11, 1e-8):  # the narrow bracket first: ten bisections fewer
                if guided or not (c_th - d_try > 0.0 and c_th + d_try < th_hi):
                    break
                u_d = REFINE(v, c_th + d_try, x, hh, z, u, a, c, sigma, mode, u_ref, buf, tb,
                             nv, a2, c2)
                slope = (u_d - c_u) / d_try
                if STILL(v, out, x + sigma * (c_th - d_try) * hh, c_u - slope * d_try, sigma,
                         mode, coef_sign) and not STILL(v, out, x + sigma * (c_th + d_try) * hh,
                                                        u_d, sigma, mode, coef_sign):
                    lo, hi, guided, dd = c_th - d_try, c_th + d_try, True, d_try
            for _b in range(200):
                if (hi - lo) * hh <= 2.0 * EPS * max(abs(x), hh):
                    break
                mid = 0.5 * (lo + hi)
                if guided:
                    um = c_u + slope * (mid - c_th)
                else:
                    um = REFINE(v, mid, x, hh, z, u, a, c, sigma, mode, u_ref, buf, tb, nv, a2, c2)
                if STILL(v, out, x + sigma * mid * hh, um, sigma, mode, coef_sign):
                    lo = mid
                else:
                    hi = mid
            th_e = hi
        x_e = stop if (last and th_e == 1.0) else x + sigma * th_e * hh
        u_e = 0.0
        if reason != _ZERO:  # (at a zero of u the end is the rest state)
            if th_e == 1.0:
                u_e = u1
            elif guided:
                u_e = c_u + slope * (th_e - c_th)
            else:
                u_e = REFINE(v, th_e, x, hh, z, u, a, c, sigma, mode, u_ref, buf, tb, nv, a2, c2)
        next_mode = mode
        if reason != _ZERO:
            n2, adm2, lost2, sing2 = CLASSIFY(v, x_e, sigma * math.sqrt(max(u_e, 0.0)), out)
            if n2 == nx.N_TWO and u_e > 0.0 and th_e < 1.0 and DOMAIN(v):
                # Within 1e-12 of a boundary the tie rules can admit two rows (a
                # contact kept with N = 0 to tolerance, and the same contact
                # leaving).  A genuine indeterminacy persists past the boundary;
                # a tie does not: probe just beyond it on this panel's dense
                # output for the first state decided by another row.
                for k in range(1, 10):
                    th_p = th_e + 10.0 ** k * 2.0 * EPS * max(abs(x), hh) / hh
                    if th_p > 1.0:
                        break
                    if guided and abs(th_p - c_th) <= dd:
                        u_p = c_u + slope * (th_p - c_th)
                    else:
                        u_p = REFINE(v, th_p, x, hh, z, u, a, c, sigma, mode, u_ref, buf, tb,
                                     nv, a2, c2)
                    x_p = x + sigma * th_p * hh
                    n3, adm3, lost3, sing3 = CLASSIFY(v, x_p, sigma * math.sqrt(max(u_p, 0.0)),
                                                      out)
                    if n3 == 1 and u_p > 0.0 and adm3 != mode:
                        th_e, x_e, u_e = th_p, x_p, u_p
                        n2, adm2, lost2, sing2 = n3, adm3, lost3, sing3
                        break
                if n2 != 1:  # undecided: the event's own classification
                    n2, adm2, lost2, sing2 = CLASSIFY(v, x_e, sigma * math.sqrt(max(u_e, 0.0)),
                                                      out)
            if not DOMAIN(v):
                reason = ev.LEFT_DOMAIN  # the model's own domain (the rod leaves the step)
            elif not (u_e > 0.0) or (STICK >= 0 and out[STICK, nx.STATUS] != nx.ABSENT):
                reason = _ZERO
            elif n2 == 1:
                if out[adm2, nx.STATUS] == nx.SEPARATION:
                    reason = ev.CONTACT_LOST  # the only motion from here leaves a contact
                elif adm2 == mode:
                    reason = ev.SINGULAR  # same branch, its coefficient changed sign
                elif DIRECTIONS[adm2] == sigma:
                    reason = ev.SWITCH
                    next_mode = adm2
                else:
                    reason = ev.NO_SOLUTION
            else:
                reason = ev.fate_without_unique(n2, lost2, sing2)
        if reason == ev.CONTACT_LOST:
            # the classification flips where N < -1e-12 of its scale: end at N = 0
            best = -1.0
            u_best = math.nan
            for q in range(nr):
                if react[q] > 0.0 and out[mode, REACTIONS[q]] < 0.0:
                    if REACTIONS[q] == c_fld and c_th <= th_e:
                        hi, u_hi = c_th, c_u  # located above
                    else:
                        lo, hi, _ul, u_hi = ROOT(v, REACTIONS[q], 1.0, 0.0, th_e, react[q],
                                                 out[mode, REACTIONS[q]],
                                                 2.0 * EPS * max(abs(x), hh) / hh, x, hh, z, u,
                                                 a, c, sigma, mode, u_ref, buf, tb, nv, a2, c2,
                                                 True)
                    if hi > best:
                        best, u_best = hi, u_hi
            if best > 0.0:
                th_e = best
                x_e = x + sigma * th_e * hh
                u_e = u_best if u_best == u_best else REFINE(v, th_e, x, hh, z, u, a, c, sigma,
                                                             mode, u_ref, buf, tb, nv, a2, c2)
        if reason == _ZERO:
            u_e = 0.0
        panels = _grow(panels, n_pan + 1)
        row = panels[n_pan]
        row[0], row[1], row[2], row[3], row[4] = s, hh, z, u, th_e
        row[5:5 + n] = a
        row[5 + n:5 + 2 * n] = c
        n_pan += 1
        return reason, x_e, u_e, n_pan, panels, next_mode, hh
    return ev.STEP_FAILURE, x, u, n_pan, panels, mode, h


def _stage_points_template(v, panels, n_pan, sigma, mode, u_ref, x0, u0, x_e, u_e, points, pts,
                           npts, stage, vecs, buf, tb):
    """Append the stage's output points (phi, u, stage): evenly spaced in phi."""
    n = NODES
    nv = vecs[8]
    a2 = vecs[9]
    c2 = vecs[10]
    length = sigma * (x_e - x0)
    count = points if (length > 0.0 and n_pan > 0) else 1
    pts = _grow(pts, npts + count)
    p = 0
    for k in range(count):
        sk = length * k / (count - 1) if count > 1 else 0.0
        while p < n_pan - 1 and sk > panels[p, 0] + panels[p, 4] * panels[p, 1]:
            p += 1
        uk = u0
        if k > 0 and k < count - 1:  # (the last point is the end state)
            row = panels[p]
            theta = min(max((sk - row[0]) / row[1], 0.0), row[4])
            uk = REFINE(v, theta, x0 + sigma * row[0], row[1], row[2], row[3], row[5:5 + n],
                        row[5 + n:5 + 2 * n], sigma, mode, u_ref, buf, tb, nv, a2, c2)
        pts[npts + k, 0] = x0 + sigma * sk
        pts[npts + k, 1] = uk
        pts[npts + k, 2] = stage
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
    npts = 0
    stg = np.empty((8, 6))
    nst = 0
    panels = np.empty((64, _PANEL_COLS))
    mats = np.empty((2, NODES, NODES))
    vecs = np.empty((11, NODES))
    buf = np.empty(NODES + 2)
    tb = np.empty(SERIES)
    react = np.empty(REACTIONS.shape[0])
    piv = np.empty(NODES, dtype=np.int64)
    code = -1
    mode = -1
    if omega0 != 0.0:
        n, adm, lost, sing = CLASSIFY(v, phi0, omega0, out)
        if STICK >= 0 and out[STICK, nx.STATUS] != nx.ABSENT:
            omega0 = 0.0  # an omega the model counts as zero: a rest state
        elif sing and (n == nx.N_NONE or n == nx.N_CONTINUUM):
            code = ev.SINGULAR
        elif n == nx.N_UNIQUE:
            if out[adm, nx.STATUS] == nx.SEPARATION:
                code = ev.CONTACT_LOST  # the only motion leaves a contact
            else:
                mode = adm
        else:
            code = ev.fate_without_unique(n, lost, sing)
    if omega0 == 0.0:
        code, mode = AT_REST(v, phi0, out)
    if code >= 0:
        sign = 0.0 if omega0 == 0.0 else (1.0 if omega0 > 0.0 else -1.0)
        pts[0, 0], pts[0, 1], pts[0, 2] = phi0, omega0 * omega0, 0.0
        stg[0, 0], stg[0, 1], stg[0, 2] = sign, phi0, omega0 * omega0
        stg[0, 3], stg[0, 4], stg[0, 5] = code, phi0, omega0 * omega0
        return pts[:1], stg[:1]
    sigma = DIRECTIONS[mode]
    x, u = phi0, omega0 * omega0
    h = h_first
    while True:
        stop = hi if sigma > 0.0 else lo
        reason, x_e, u_e, n_pan, panels, next_mode, h = STAGE(
            v, out, mode, sigma, x, u, stop, u_ref, rtol, h_max, h, panels, mats, vecs, buf, tb,
            react, piv)
        pts, npts = STAGE_POINTS(v, panels, n_pan, sigma, mode, u_ref, x, u, x_e, u_e, points,
                                 pts, npts, float(nst), vecs, buf, tb)
        go = False
        new_mode = mode
        if reason == _ZERO:
            code, m2 = AT_REST(v, x_e, out)
            if code < 0:
                reason, new_mode, go = ev.REVERSAL, m2, True
            else:
                reason = code
        elif reason == ev.SWITCH:
            new_mode, go = next_mode, True
        stg = _grow(stg, nst + 1)
        stg[nst, 0], stg[nst, 1], stg[nst, 2] = sigma, x, u
        stg[nst, 3], stg[nst, 4], stg[nst, 5] = reason, x_e, u_e
        nst += 1
        if not go:
            break
        if nst >= max_stages:
            stg[nst - 1, 3] = ev.MAX_EVENTS
            break
        x, u = x_e, (0.0 if reason == ev.REVERSAL else u_e)
        mode = new_mode
        sigma = DIRECTIONS[mode]
        h = max(h, 1e-3 * h_max)
    return pts[:npts], stg[:nst]


# ---------------------------------------------------------------- the per-model kernel

_KERNELS: dict = {}


def _coordinate(m: Model) -> tuple[str, str, str]:
    """The model's one coordinate triple, or a ValueError that says why there is none."""
    dyn = m.dynamics
    if dyn is None:
        raise ValueError(f"{m.name}: phase_curve needs a model that moves (Model.dynamics is "
                         f"None); {m.name} can be classified and mapped only")
    if len(dyn.coordinates) != 1:
        names = ", ".join(c[0] for c in dyn.coordinates)
        raise ValueError(
            f"{m.name}: phase_curve follows one-degree-of-freedom models only, and {m.name} "
            f"has {len(dyn.coordinates)} coordinates ({names}); use phasemap.simulate for "
            f"{m.name}")
    pos, vel, acc = dyn.coordinates[0]
    if vel != m.velocity:
        raise ValueError(f"{m.name}: phase_curve needs the velocity of the coordinate {pos!r} "
                         f"to be the model's relative velocity {m.velocity!r}, got {vel!r}")
    return pos, vel, acc


def _kernel(m: Model):
    """The model's compiled curve function (specialised once per model, cached on disk)."""
    curve = _KERNELS.get(m.name)
    if curve is not None and curve[0] is m:
        return curve[1]
    pos, vel, acc = _coordinate(m)
    slot = {n: i for i, n in enumerate(m.inputs)}
    acc_names = [a.name for a in m.accelerations]
    contract = m.contract
    consts = dict(
        POINT=contract.point, BRANCH_ROW=contract.branch_row_inline,
        DERIVE=contract.derive_inline, DOMAIN=contract.domain_inline, PHI=slot[pos],
        OMEGA=slot[vel],
        ACC=nx.FIRST_ACC + acc_names.index(acc),
        OMEGA_DERIVED=any(d.source == vel for d in m.derived),
        STICK=m.stick_branch, N_BRANCHES=len(m.branches), N_FIELDS=m.n_fields,
        DIRECTIONS=np.array(m.directions, dtype=np.float64),
        REACTIONS=np.arange(m.first_reaction, m.n_fields, dtype=np.int64),
        KINKS=np.array([q for q, r in enumerate(m.reactions)
                        if m.kinks is None or r.name in m.kinks], dtype=np.int64),
    )
    # RATE and VALUE (the branch row, per collocation node) are LLVM-inlined;
    # CLASSIFY, STILL, REFINE and ROOT (once per panel or event) are called, which
    # cuts the cold compile by a sixth (43.7 -> 36.2 s for the 17-row rod on a
    # step, 22.7 -> 17.6 s for the hinge) for curves 7-11 % slower.
    for name, template, inline in (("ROW", _row_template, True),
                                   ("RATE", _rate_template, True),
                                   ("VALUE", _value_template, True),
                                   ("CLASSIFY", _classify_template, False),
                                   ("STILL", _still_template, False),
                                   ("REFINE", _refine_template, False),
                                   ("ROOT", _root_template, False),
                                   ("STAGE_POINTS", _stage_points_template, False),
                                   ("AT_REST", _at_rest_template, False),
                                   ("STAGE", _stage_template, False)):
        consts[name] = specialize(template, m, f"phase_{name.lower()}", inline=inline, **consts)
    curve = specialize(_curve_template, m, "phase_curve", **consts)
    _KERNELS[m.name] = (m, curve)
    return curve


def _velocity_reference(m: Model, full: dict) -> float:
    """u_ref: the square of the model's natural velocity scale at these values."""
    names = list(inspect.signature(m.velocity_scale.py_func).parameters)
    scale = float(m.velocity_scale.py_func(*(full[n] for n in names)))
    return scale * scale if scale > 0.0 and math.isfinite(scale) else 1.0


def first_width(rtol: float, h_max: float) -> float:
    """The first panel's width: h_max where rtol >= 1e-10, else h_max / 20.

    A panel's error grows as its width to the 12th power, so at a loose rtol the
    widest panel is accepted from the start; growing to it from h_max / 20 cost the
    ladder's curve a fifth and the wheel's and the hinge's 7-12 % at rtol 1e-6 to
    1e-10 (benchmarks/phase_curve.py's curves).  At tighter rtol a wide first panel
    is rejected about as often as it saves growth, and the default curves (rtol
    1e-14) keep their panels.
    """
    return h_max if rtol >= 1e-10 else 0.05 * h_max


def _trace(m: Model, full: dict, phi_range, max_stages: int, points: int,
           rtol: float = RTOL, h_max: float = H_MAX, h_first: float | None = None):
    """Run the compiled tracer: (points (phi, u, stage), stages (sign, phi0, u0, reason,
    phi_end, u_end)).

    ``rtol``, ``h_max`` and ``h_first`` (the first panel's width, default
    :func:`first_width`) are for measurements: ``rtol = inf`` accepts every panel (and
    converges each one's Newton iteration to 1e-14), so that panels of width h_max
    measure the order of the method.
    """
    pos, vel, _ = _coordinate(m)
    v = m.input_vector(full)
    return _kernel(m)(v, float(full[pos]), float(full[vel]), float(phi_range[0]),
                      float(phi_range[1]), int(max_stages), int(points),
                      _velocity_reference(m, full), float(rtol), float(h_max),
                      float(first_width(rtol, h_max) if h_first is None else h_first))


# ---------------------------------------------------------------- public API


def phase_curve(model: str | Model, *, phi: float | None = None, omega: float | None = None,
                phi_range: tuple[float, float] | None = None, max_stages: int = 50,
                points_per_stage: int = 200, rtol: float = RTOL,
                **params: float) -> xr.Dataset:
    """The phase curve omega(phi) from (phi, omega), stage by stage, to its fate.

    Parameters
    ----------
    model:
        any one-degree-of-freedom model (``"ladder"``, ``"wheel"``,
        ``"hinge_pendulum"``, or a :class:`phasemap.Model` whose dynamics has
        one coordinate); the two-degree-of-freedom elliptic pendulum has no
        phase curve of this kind (use :func:`phasemap.simulate`).
    phi, omega:
        the initial state: the model's coordinate and its velocity (rad,
        rad s-1 for the built-in ones).  They may also be given by the model's
        own names (``theta=..., omega=...`` for ``rod_on_step``).  An omega
        the model counts as zero (``|omega| <= 1e-12`` times its velocity
        scale) is a rest state.
    phi_range:
        ``(low, high)`` containing ``phi``: the curve ends with ``horizon``
        where it leaves this range.  Default: the domain of ``phi`` where it is
        bounded (the ladder's [0, pi/2]), else ``(phi - 4 pi, phi + 4 pi)``.
    max_stages:
        the largest number of stages; a curve still reversing after that many
        ends with ``max_events``.
    points_per_stage:
        points evenly spaced in phi on each stage, its ends included.
    rtol:
        the error of omega^2 allowed per panel, relative to ``|omega^2| +
        u_ref`` (u_ref the square of the model's velocity scale), in
        [1e-14, 1e-3].  The default, 1e-14, traces to about machine precision;
        a looser one takes fewer, longer panels (the method is of order 12) and
        stops each panel's Newton iteration earlier (at :data:`NEWTON` rtol), for
        portraits of many curves.
    **params:
        the model's parameters by name; missing ones take the defaults.

    Returns
    -------
    xarray.Dataset
        dimension ``point``: ``phi``, ``omega`` (signed), ``omega_squared``,
        ``point_stage``; dimension ``stage`` (coordinate ``stage``):
        ``stage_sign``, ``stage_start_phi``, ``stage_start_omega``,
        ``stage_end_reason`` (flags of :class:`phasemap.Event`),
        ``stage_end_phi``, ``stage_end_omega``.  ``attrs["end_reason"]`` names the
        last stage's reason.  See the module docstring for the method and the
        events.

    Raises
    ------
    ValueError
        for a model without exactly one degree of freedom, an unknown or
        out-of-domain variable, a non-scalar value, a ``phi_range`` that does
        not contain ``phi`` or leaves the model's domain, or bad
        ``max_stages``/``points_per_stage``.

    Examples
    --------
    >>> from phasemap.phase import phase_curve
    >>> ds = phase_curve("hinge_pendulum", phi=0.2, omega=0.0, delta=0.02)
    >>> ds.attrs["end_reason"], int(ds.sizes["stage"])
    ('rest', 5)
    >>> abs(float(ds.stage_end_phi[-1])) <= 0.02      # rest needs l |sin phi| <= delta
    True
    """
    m = get_model(model)
    pos, vel, _ = _coordinate(m)
    for name, given in ((pos, phi), (vel, omega)):
        if given is not None and name in params and name not in ("phi", "omega"):
            raise ValueError(f"{m.name}: {name} is given twice")
    phi = params.pop(pos, phi) if pos != "phi" else phi
    omega = params.pop(vel, omega) if vel != "omega" else omega
    if phi is None or omega is None:
        raise ValueError(f"{m.name}: phase_curve needs the initial {pos} and {vel}")
    values = {pos: phi, vel: omega, **params}
    for k, val in values.items():
        if np.ndim(val) != 0:
            raise ValueError(f"{m.name}: {k} must be a scalar for phase_curve()")
    full = {k: float(v) for k, v in m.complete(values).items()}
    lo, hi = _checked_range(m, pos, full[pos], phi_range)
    max_stages = _positive_int(m, "max_stages", max_stages, 1)
    points = _positive_int(m, "points_per_stage", points_per_stage, 2)
    try:
        rtol = float(rtol)
    except (TypeError, ValueError):
        raise ValueError(f"{m.name}: rtol must be a number, got {rtol!r}") from None
    if not RTOL <= rtol <= 1e-3:
        raise ValueError(f"{m.name}: rtol must be in [1e-14, 1e-3], got {rtol!r}")
    pts, stages = _trace(m, full, (lo, hi), max_stages, points, rtol=rtol)
    stages = stages.copy()
    var = m.variables[pos]
    if stages[-1, 3] == ev.HORIZON and stages[-1, 4] in (var.lower, var.upper):
        stages[-1, 3] = ev.LEFT_DOMAIN  # the model's own edge (the ladder lies flat)
    return _dataset(m, full, (lo, hi), max_stages, points, pts, stages, rtol)


def _checked_range(m: Model, pos: str, phi: float, phi_range) -> tuple[float, float]:
    var = m.variables[pos]
    if phi_range is None:
        lo = var.lower if math.isfinite(var.lower) else phi - _DEFAULT_SPAN
        hi = var.upper if math.isfinite(var.upper) else phi + _DEFAULT_SPAN
        return float(lo), float(hi)
    try:
        lo, hi = (float(x) for x in phi_range)
    except (TypeError, ValueError):
        raise ValueError(f"{m.name}: phi_range must be two numbers (low, high), "
                         f"got {phi_range!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"{m.name}: phi_range must be finite with low < high, "
                         f"got {phi_range!r}")
    if not lo <= phi <= hi:
        raise ValueError(f"{m.name}: phi_range {phi_range!r} must contain {pos} = {phi:g}")
    var.check(m.name, lo)
    var.check(m.name, hi)
    return lo, hi


def _positive_int(m: Model, name: str, value, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise ValueError(f"{m.name}: {name} must be an integer >= {least}, got {value!r}")
    return int(value)


def _signed_root(sign: float, u: float) -> float:
    return sign * math.sqrt(u) if u > 0.0 else 0.0


#: How the curves are computed (the Dataset's ``method`` attribute).
METHOD = (f"exponential Gauss collocation in phi ({NODES} nodes, order {2 * NODES}) of "
          "d(omega^2)/dphi = 2 phi'' from the model's branch rows; events by classification, "
          "located on the dense output")


def _dataset(m: Model, full: dict, phi_range, max_stages: int, points: int,
             pts: np.ndarray, stages: np.ndarray, rtol: float = RTOL) -> xr.Dataset:
    pos, vel, _ = _coordinate(m)
    var_phi, var_omega = m.variables[pos], m.variables[vel]
    index = pts[:, 2].astype(np.int32)
    signs = stages[:, 0].astype(np.int8)
    u = np.maximum(pts[:, 1], 0.0)
    omega = np.where(u > 0.0, signs[index] * np.sqrt(u), 0.0)
    reasons = stages[:, 3].astype(np.int8)
    start_omega = np.array([_signed_root(s, x) for s, x in zip(stages[:, 0], stages[:, 2])])
    end_omega = np.array([_signed_root(s, x) for s, x in zip(stages[:, 0], stages[:, 5])])
    flags = {"flag_values": np.array(ev.EVENT_VALUES, dtype=np.int8),
             "flag_meanings": ev.EVENT_MEANINGS}

    def angle(name, values, dim):
        return xr.Variable(dim, values, {"long_name": name, "units": var_phi.units})

    def rate(name, values, dim):
        return xr.Variable(dim, values, {"long_name": name, "units": var_omega.units})

    data = {
        "phi": angle(var_phi.long_name, pts[:, 0].copy(), "point"),
        "omega": rate(var_omega.long_name, omega, "point"),
    }
    # the model's own symbols, for plots of a model whose coordinate is not phi
    data["phi"].attrs["phasemap_symbol"] = var_phi.symbol or var_phi.name
    data["omega"].attrs["phasemap_symbol"] = var_omega.symbol or var_omega.name
    data |= {
        "omega_squared": xr.Variable("point", u, {
            "long_name": f"square of the {var_omega.long_name}",
            "units": squared_units(var_omega.units)}),
        "point_stage": xr.Variable("point", index, {
            "long_name": "index of the stage the point belongs to", "units": "1"}),
        "stage_sign": xr.Variable("stage", signs, {
            "long_name": f"sign of {vel} on the stage (0: no motion)", "units": "1"}),
        "stage_start_phi": angle(f"{var_phi.long_name} at the start of the stage",
                                 stages[:, 1].copy(), "stage"),
        "stage_start_omega": rate(f"{var_omega.long_name} at the start of the stage",
                                  start_omega, "stage"),
        "stage_end_reason": xr.Variable("stage", reasons, {
            "long_name": "event that ends the stage", **flags}),
        "stage_end_phi": angle(f"{var_phi.long_name} at the end of the stage",
                               stages[:, 4].copy(), "stage"),
        "stage_end_omega": rate(f"{var_omega.long_name} at the end of the stage", end_omega,
                                "stage"),
    }
    coords = {"stage": xr.Variable("stage", np.arange(len(stages), dtype=np.int32),
                                   {"long_name": f"stage index ({vel} keeps its sign on a "
                                                 "stage)", "units": "1"})}
    from .simulate import end_message

    last = ev.Event(int(reasons[-1]))
    attrs = {
        **cf_header(m, "phase_curve", "phasemap.phase_curve"),
        "method": METHOD,
        "end_reason": last.name.lower(),
        "end_message": end_message(m, last, (float(stages[-1, 4]),)),
        "n_reversals": np.int32(np.count_nonzero(reasons == ev.REVERSAL)),
        "phasemap_phi_range": np.array(phi_range, dtype=float),
        "phasemap_max_stages": np.int32(max_stages),
        "phasemap_points_per_stage": np.int32(points),
        "phasemap_rtol": float(rtol),
    }
    for v in m.state:
        attrs[f"phasemap_initial_{v.name}"] = float(full[v.name])
    for v in m.params:
        attrs[f"phasemap_fixed_{v.name}"] = float(full[v.name])
    return xr.Dataset(data, coords, attrs)
