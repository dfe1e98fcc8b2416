r"""The collocation maths of the phase-curve tracer: exponential Gauss collocation.

A panel of width h solves du/ds = beta u + N(s, u) (see :mod:`phasemap.motion.phase`)
by variation of constants with N replaced by its polynomial interpolant at the
:data:`NODES` Gauss-Legendre points of the panel.  This module holds what does
not depend on a model: the node tables, the phi-functions of exponential
integrators (:func:`phis`), the collocation matrix (:func:`weights`), the
interpolant's expansions (:func:`expand`), the dense output (:func:`dense`, and
its Taylor series :func:`series` where |z| <= :data:`Z_SERIES`) and a small LU
solver (:func:`factor`, :func:`lu_solve`) for the Newton iteration.
"""

from __future__ import annotations

import math

import numpy as np

from phasemap.core.jit import njit

#: Gauss-Legendre collocation nodes per panel (order 2 NODES for moderate slopes).
NODES = 6
#: Terms of the Taylor series in theta of a panel's dense output, used where |z| <= Z_SERIES.
SERIES = 22
Z_SERIES = 1.0
EPS = float(np.finfo(float).eps)


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
#: Gauss-Legendre nodes of a panel's output pass (:func:`solve_legendre`): the remainder
#: N sampled there once per panel, and its interpolant of degree 2 NODES - 1 integrated
#: exactly at every output point, errs like the NODES-point Gauss rule of a pass per
#: point (both O(h^(2 NODES + 1))).
OUT_NODES = 2 * NODES
OUT_THETA, _, OUT_LEG, _, _ = _tables(OUT_NODES)
#: The output pass solves in Legendre coefficients where |z| <= Z_OUT, in at most
#: OUT_PICARD iterations (|z|^k / k! is below 1e-18 at k = 20), so with at most
#: OUT_TERMS terms.
Z_OUT = 1.0
OUT_PICARD = 20
OUT_TERMS = OUT_NODES + OUT_PICARD + 1
#: Legendre recurrence (2k+1)/(k+1), k/(k+1) and the integral weight 1/(2 (2k+1)).
LEG_A = np.array([(2 * k + 1) / (k + 1) for k in range(OUT_TERMS + 1)])
LEG_B = np.array([k / (k + 1) for k in range(OUT_TERMS + 1)])
LEG_W = np.array([1.0 / (2.0 * (2 * k + 1)) for k in range(OUT_TERMS + 1)])


@njit(cache=True, error_model="numpy")
def phis(w, out):
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
def dense(theta, z, u0, h, a, c, buf):
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
        phis(w, buf)
        corr = 0.0
        tp = theta
        for k in range(n):
            corr += c[k] * tp * FACT[k] * buf[k + 2]
            tp *= theta
        acc += w * corr
        e = buf[0]
    return e * u0 + h * acc


@njit(cache=True, error_model="numpy")
def series(z, u0, h, c, b):
    """Taylor coefficients b of a panel's u in theta (u = sum b_m theta^m), where
    |z| <= Z_SERIES; returns whether it computed them.

    u solves du/dtheta = z u + h p(theta) with p = sum c_k theta^k, so b_0 = u0 and
    (m + 1) b_{m+1} = z b_m + h c_m.  With |z| <= 1 the :data:`SERIES` terms reach
    1e-18 of the sum, which is as accurate as :func:`dense` (a few ulp of |u0| + h |p|)
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
def dense_at(theta, series, b, z, u0, h, a, c, buf):
    """u at theta of a panel: its Taylor sum ``b`` where ``series`` (see :func:`series`),
    else :func:`dense`."""
    if series:
        acc = b[SERIES - 1]
        for m in range(SERIES - 2, -1, -1):
            acc = acc * theta + b[m]
        return acc
    return dense(theta, z, u0, h, a, c, buf)


@njit(cache=True, error_model="numpy")
def expand(nv, a, c):
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
def solve_legendre(z, u0, h, nv, u, w, r):
    """The Legendre coefficients ``u`` (in tau on [0, 1]) of the solution of
    du/dtau = z u + h p(tau), u(0) = u0, where p interpolates ``nv``, the values at the
    :data:`OUT_NODES` nodes :data:`OUT_THETA`; |z| <= :data:`Z_OUT`.  Returns the
    number of terms (``w``: scratch of :data:`OUT_TERMS` + 1, ``r``: of OUT_NODES).

    Picard's iteration u <- u0 + int_0^tau (z u + h p), each integral exact in the
    Legendre basis, int_0^tau P_k = (P_{k+1} - P_{k-1}) / (2 (2k + 1)) (P_0: (P_1 +
    P_0) / 2), until a pass changes no coefficient by more than 1e-17 of their sum (the
    trailing coefficients below that are dropped): no monomials, whose coefficients for
    12 nodes carry the node values' rounding times 6e7 (the dense output's
    :func:`dense` uses them for NODES = 6 terms, times 2e3).
    """
    n = nv.shape[0]
    for k in range(n):  # h p in Legendre coefficients
        acc = 0.0
        for j in range(n):
            acc += OUT_LEG[k, j] * nv[j]
        r[k] = h * acc
    nt = 1
    u[0] = u0
    for _ in range(OUT_PICARD):
        m = max(nt, n)
        for k in range(m + 1):
            w[k] = 0.0
        w[0] = u0
        for k in range(m):
            rk = (z * u[k] if k < nt else 0.0) + (r[k] if k < n else 0.0)
            if k == 0:
                w[0] += 0.5 * rk
                w[1] += 0.5 * rk
            else:
                ck = rk * LEG_W[k]
                w[k + 1] += ck
                w[k - 1] -= ck
        change = 0.0
        size = 0.0
        for k in range(m + 1):
            old = u[k] if k < nt else 0.0
            change = max(change, abs(w[k] - old))
            size += abs(w[k])
            u[k] = w[k]
        nt = m + 1
        if change <= 1e-17 * size:
            break
    while nt > 1 and abs(u[nt - 1]) <= 1e-17 * size:  # terms below rounding: each point
        nt -= 1                                        # sums only the rest
    return nt


#: Output points a panel's Legendre sum is evaluated at together (:func:`legendre_many`).
LANES = 64


@njit(cache=True, error_model="numpy")
def legendre_many(lanes, nb, u, nt):
    """:func:`legendre_at` at the ``nb`` values of tau in ``lanes[0]``, into ``lanes[1]``
    (``lanes[2:4]``: scratch).

    The points' recurrences are independent, so the loop over the points runs inside
    the loop over the terms: the pipeline and the vector registers take several points
    at once where one point's recurrence waits on its previous term.  Each point's
    arithmetic is :func:`legendre_at`'s, in the same order, so the sums are identical.
    """
    x, acc, pm, pk = lanes[0, :nb], lanes[1, :nb], lanes[2, :nb], lanes[3, :nb]
    for i in range(nb):
        xi = 2.0 * x[i] - 1.0
        x[i] = xi
        acc[i] = u[0] + u[1] * xi if nt > 1 else u[0]
        pm[i] = 1.0
        pk[i] = xi
    for k in range(1, nt - 1):
        a, b, c = LEG_A[k], LEG_B[k], u[k + 1]
        for i in range(nb):
            pp = a * x[i] * pk[i] - b * pm[i]
            acc[i] += c * pp
            pm[i] = pk[i]
            pk[i] = pp


@njit(cache=True, error_model="numpy")
def legendre_at(tau, u, nt):
    """sum_k u_k P_k(2 tau - 1) over the first ``nt`` terms."""
    x = 2.0 * tau - 1.0
    acc = u[0]
    if nt > 1:
        acc += u[1] * x
    pm, pk = 1.0, x
    for k in range(1, nt - 1):
        pp = LEG_A[k] * x * pk - LEG_B[k] * pm
        acc += u[k + 1] * pp
        pm, pk = pk, pp
    return acc


@njit(cache=True, error_model="numpy")
def weights(z, A, buf, E, P1):
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
        phis(w, buf)
        E[i] = buf[0]
        P1[i] = buf[1]
        tp = th
        for k in range(n):
            f = w * tp * FACT[k] * buf[k + 2]
            tp *= th
            for j in range(n):
                A[i, j] += f * MON[k, j]


@njit(cache=True, error_model="numpy")
def factor(M, piv):
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
def lu_solve(M, piv, r):
    """Solve M x = r in place (r becomes x) with the factors of :func:`factor`."""
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
