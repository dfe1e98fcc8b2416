"""Solving one mode combination: each contact law's unknowns, then a closed form.

:func:`problem` asks every contact law for its mode's unknowns and
requirements (:mod:`phasemap.declare.law`); :func:`solve` picks the solver:

* :func:`solve_regular`: an invertible mass matrix, reactions by Cramer's rule
  on the contact problem ``K L = rhs`` (``K = C M^-1 W``);
* :func:`solve_saddle`: a singular mass matrix (a massless rod), accelerations
  and reactions together from the saddle-point system;
* :func:`solve_indeterminate`: a singular ``K`` (statically indeterminate
  reactions): a one-parameter family;
* :func:`solve_joint`: the joint's squared friction law, on top of either of the
  first two (the reactions are affine in the friction moment).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .algebra import cramer, pythagorean, reduced, scale_of
from .law import STICK, LinearProblem, Mode
from .validation import fail


@dataclass
class Solution:
    """One mode combination solved: what its branch function computes.

    ``D`` is the determinant of the contact problem (the coefficient of the
    senior derivative), ``nums`` the reactions' numerators over ``D`` (affine in
    the squared law's moment, if any), ``qnums`` the accelerations' numerators
    over ``D`` where they are solved together with the reactions (saddle point;
    otherwise the accelerations are ``aM (hx + W L) / dM``), and ``family`` the
    statically indeterminate parametrisations ``(D, P, Dd)``: ``L = (P + Dd t) / D``.
    """

    problem: LinearProblem
    aM: object
    dM: object
    hx: list
    W: object
    D: object = 1
    nums: list | None = None
    qnums: list | None = None
    family: list | None = None


def problem(eqs, kinds: tuple, fname: str) -> LinearProblem:
    """The linear problem of the mode kinds ``kinds`` (one per contact)."""
    import sympy as sp

    zero = {eqs.velocity: sp.Integer(0)} if STICK in kinds else {}
    p = LinearProblem(kinds, fname, eqs.n, zero, extra=[sp.Integer(0)] * eqs.n)
    for c, kind in zip(eqs.S.contacts, kinds):
        mode = Mode(kind)
        reactions = c.unknowns(mode, eqs.channels[c.name], p)
        p.reactions += reactions
        p.requirements += c.requirements(mode, reactions)
    return p


def solve(eqs, p: LinearProblem) -> Solution:
    """The closed-form solution of ``p`` (see the module docstring for the solvers)."""
    import sympy as sp

    n, k = p.n, len(p.unknowns)
    M = eqs.M
    aM = M.adjugate() if n > 1 else sp.Matrix([[1]])
    dM = M.det(method="berkowitz") if n > 1 else M[0, 0]
    hx = [eqs.h[j].xreplace(p.zero) + p.extra[j] for j in range(n)]
    W = sp.Matrix(n, k, lambda i, j: p.columns[j][i]) if k else sp.zeros(n, 0)
    C = sp.Matrix(k, n, lambda i, j: p.constraints[i][0][j]) if k else sp.zeros(0, n)
    cb = sp.Matrix(k, 1, lambda i, j: p.constraints[i][1]) if k else sp.zeros(0, 1)
    hv = sp.Matrix(n, 1, lambda i, j: hx[i])
    sol = Solution(p, aM, dM, hx, W)
    if not eqs.regular:
        sol.D, sol.qnums, sol.nums = solve_saddle(eqs, p, M, W, C, hv, cb)
        return sol
    if k == 0:
        sol.D, sol.nums = sp.Integer(1), []
        return sol
    K = (C * aM * W).applyfunc(sp.expand)
    rhs = (-(C * aM * hv) - dM * cb).applyfunc(sp.expand)
    regular = solve_regular(eqs, p, K, rhs)
    if regular is not None:
        sol.D, sol.nums = regular
        return sol
    sol.family = solve_indeterminate(eqs, p, K, rhs, aM * W)
    sol.D = sol.family[0][0]
    return sol


def solve_regular(eqs, p: LinearProblem, K, rhs):
    """``(D, numerators)`` of ``K L = rhs`` by Cramer's rule, or None where ``K`` is
    singular on the whole domain (statically indeterminate)."""
    D = K.det(method="berkowitz")
    if not np.max(np.abs(eqs.numeric(D / scale_of(D), 12))) > 1e-9:
        return None
    D, *nums = reduced([D] + [cramer(K, rhs, i) for i in range(len(p.unknowns))])
    return one_direction(eqs, p, D, nums)


def one_direction(eqs, p: LinearProblem, D, nums):
    """The determinant and numerators with the one slip direction that every contact
    shares when all of them slip; the determinant also reduced and factored
    (:func:`phasemap.declare.algebra.pythagorean`).

    When every contact slips, contact c slips with sign kappa_c s (the rows
    where they would not share s are never generated, see
    :func:`phasemap.declare.modes.candidates`): sigma_c = kappa_c kappa_1 sigma_1.
    Substituted, terms such as the sliding ladder's 3 f sin(phi) cos(phi)
    (sigma_floor - sigma_wall) vanish in the algebra instead of cancelling in
    rounding, and its determinant becomes 2 (2 - f^2) / 9, whose rounding does
    not change along the motion.  The numerators are left expanded: reduced,
    their zero-test scales no longer matched the separated row's at a contact's
    release (the frictionless ladder leaving the wall ended ``no_solution``
    instead of ``contact_lost``).
    """
    if len(p.signs) < 2 or any(k not in ("slip", "roll") for k in p.kinds):
        return D, nums
    first, *others = p.signs
    sub = {p.signs[nm]: eqs.kappa[nm] * eqs.kappa[first] * p.signs[first] for nm in others}
    return pythagorean(D.xreplace(sub), eqs.q), [e.xreplace(sub) for e in nums]


def solve_saddle(eqs, p: LinearProblem, M, W, C, hv, cb):
    """``(D, acceleration numerators, reaction numerators)`` of the saddle-point system
    ``[[M, -W], [C, 0]] (q'', L) = (h, -c)``."""
    import sympy as sp

    n, k = p.n, len(p.unknowns)
    A = sp.zeros(n + k, n + k)
    A[:n, :n] = M
    if k:
        A[:n, n:] = -W
        A[n:, :n] = C
    rhs = sp.Matrix.vstack(hv, -cb) if k else hv
    D = sp.expand(A.det(method="berkowitz"))
    if D == 0 or np.max(np.abs(eqs.numeric(D / scale_of(D), 12))) < 1e-9:
        fail(eqs.S, "bodies", "the mass matrix is singular on the motions the "
             f"contacts allow (modes {', '.join(p.kinds)}): some coordinate has no "
             "inertia (a missing mass or inertia term)")
    D, *nums = reduced([D] + [sp.expand(cramer(A, rhs, i)) for i in range(n + k)])
    return D, nums[:n], nums[n:]


def solve_indeterminate(eqs, p: LinearProblem, K, rhs, aMW):
    """The one-parameter family of reactions where ``K`` is singular: a list of one or
    two parametrisations ``(Dp, P, Dd)``, ``L = (P + Dd t) / Dp``.

    The family is parametrised by one reaction j0 with equation i0 dropped, by
    Cramer on the minor Dp that is left.  Every minor may vanish somewhere in
    the domain (the ladder: one at phi = 0, where the floor's normal is the
    wall's tangent, another at phi = pi/2): then two parametrisations are
    generated and the one with the larger |Dp| is taken at run time.  The
    reported reactions, the middle of the admissible segment, do not depend on
    the parametrisation.
    """
    S, k = eqs.S, len(p.unknowns)
    if p.squared is not None:
        fail(S, f"mode {p.fname}", "a joint with statically indeterminate reactions "
             "is not supported")
    choices = _minors(eqs, K, k)
    if not choices:
        fail(S, f"mode {p.fname}", "the reactions are indeterminate with a family of "
             "more than one parameter: not supported")
    best = max(range(len(choices)), key=lambda a: (np.min(choices[a][4]), -a))
    picked = [best]
    if np.min(choices[best][4]) < 1e-6:
        pair = max(itertools.combinations(range(len(choices)), 2), key=lambda ab: (
            np.min(np.maximum(choices[ab[0]][4], choices[ab[1]][4])), -ab[0], -ab[1]))
        picked = list(pair)
    return [_parametrisation(eqs, p, K, rhs, aMW, *choices[a][:4]) for a in picked]


def _minors(eqs, K, k):
    """The (k-1)-minors of ``K`` that do not vanish identically, with their sizes at the
    sample points (relative to their scales)."""
    pts = eqs.points()
    choices = []
    for I in itertools.combinations(range(k), k - 1):
        for J in itertools.combinations(range(k), k - 1):
            sub = K.extract(list(I), list(J))
            Dp = sub.det(method="berkowitz")
            if Dp == 0:
                continue
            size = np.abs(eqs.at(Dp / scale_of(Dp), pts))
            if np.max(size) >= 1e-9:
                choices.append((I, J, sub, Dp, size))
    return choices


def _parametrisation(eqs, p, K, rhs, aMW, I, J, sub, Dp):
    """The family on the minor ``sub`` (rows I, columns J of K): ``(Dp, P, Dd)``."""
    import sympy as sp

    k = len(p.unknowns)
    (i0,) = set(range(k)) - set(I)
    (j0,) = set(range(k)) - set(J)
    P0 = [cramer(sub, rhs.extract(list(I), [0]), a) for a in range(k - 1)]
    dcol = -K.extract(list(I), [j0])
    d = [cramer(sub, dcol, a) for a in range(k - 1)]
    # the dropped equation must hold for the whole family, and the
    # accelerations must not depend on the family's parameter
    lam_d = [sp.Integer(0)] * k
    lam_p = [sp.Integer(0)] * k
    for a, j in enumerate(J):
        lam_d[j], lam_p[j] = d[a], P0[a]
    lam_d[j0] = Dp
    row_p = sum(K[i0, j] * lam_p[j] for j in range(k)) - rhs[i0] * Dp
    row_d = sum(K[i0, j] * lam_d[j] for j in range(k))
    acc_d = aMW * sp.Matrix(lam_d)
    checks = [row_p, row_d, *acc_d]
    bad = [e for e in checks if e != 0 and np.max(np.abs(
        eqs.numeric(e / (scale_of(e) + 1), 8))) > 1e-9]
    if bad:
        fail(eqs.S, f"mode {p.fname}", "the reactions are indeterminate and the "
             "accelerations depend on them (a continuum of motions): not supported")
    Dp, *pd = reduced([Dp, *P0, *d])
    P, Dd = [sp.Integer(0)] * k, [sp.Integer(0)] * k
    for a, j in enumerate(J):
        P[j], Dd[j] = pd[a], pd[k - 1 + a]
    Dd[j0] = Dp
    return Dp, P, Dd


@dataclass
class JointRoots:
    """The squared friction law of a turning joint, ``M = -sigma delta |R|``, over the
    common denominator of its linear solution.

    The reaction components are ``X = (a_X + b_X M) / D``, ``Y`` likewise; squaring
    ``M^2 = delta^2 (X^2 + Y^2)`` gives ``A M^2 + B M + C = 0`` with
    ``A = A_n / D^2``, ``B = B_n / D^2``, ``C = C_n / D^2`` below, and the row keeps
    the root ``M = (-B_n + root sqrt(disc_n)) / (2 A_n)`` when ``sigma M <= 0``
    (the generated code evaluates the same quantities divided by ``D``).
    ``scales`` holds the magnitudes of their terms, as the generated code
    computes them (times the same powers of ``|D|``).
    """

    A: object
    B: object
    C: object
    disc: object
    moment: object
    scales: dict


def joint_parts(sol: Solution):
    """The squared law's linear parts: per reaction numerator ``(a, b)`` with
    ``n = a + b M``, and the indices of the law's X and Y unknowns."""
    import sympy as sp

    sq = sol.problem.squared
    a = [e.subs(sq.moment, 0) for e in sol.nums]
    b = [sp.diff(e, sq.moment) for e in sol.nums]
    X, Y = [i for i, u in enumerate(sol.problem.unknowns) if u[0] == sq.contact]
    return a, b, X, Y


def solve_joint(sol: Solution, root) -> JointRoots:
    """The quadratic of the squared friction law, its discriminant and the kept root
    (``root`` = -1 or +1), as numerators over powers of ``D`` (no poles)."""
    import sympy as sp

    a, b, X, Y = joint_parts(sol)
    d2 = sol.problem.squared.coefficient ** 2
    D = sol.D
    A = D * D - d2 * (b[X] ** 2 + b[Y] ** 2)
    B = -2 * d2 * (a[X] * b[X] + a[Y] * b[Y])
    C = -d2 * (a[X] ** 2 + a[Y] ** 2)
    disc = B * B - 4 * A * C
    moment = -B + root * sp.sqrt(disc)
    sX, sY = scale_of(a[X]), scale_of(a[Y])
    As = D * D + d2 * (b[X] ** 2 + b[Y] ** 2)
    Bs = 2 * d2 * (sX * sp.Abs(b[X]) + sY * sp.Abs(b[Y]))
    Cs = d2 * (sX * sX + sY * sY)
    scales = {"A": As, "disc": Bs * Bs + 4 * As * Cs,
              "moment_terms": sol.problem.squared.coefficient * sp.sqrt(sX * sX + sY * sY)}
    return JointRoots(A, B, C, disc, moment, scales)
