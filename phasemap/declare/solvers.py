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

from phasemap.declare.algebra import (count_ops, cramer, determinant, expanded, pythagorean,
                                      reduced, scale_of)
from phasemap.declare.law import STICK, LinearProblem, Mode
from phasemap.declare.validation import fail


@dataclass
class Solution:
    """One mode combination solved: what its branch function computes.

    ``D`` is the determinant of the contact problem (the coefficient of the
    senior derivative), ``nums`` the reactions' numerators over ``D`` (affine in
    the squared law's moment, if any), ``qnums`` the accelerations' numerators
    over ``D`` where they are solved together with the reactions (saddle point;
    otherwise the accelerations are ``aM (hx + W L) / dM``), and ``family`` the
    statically indeterminate parametrisations (:class:`Family`), of which the
    generated code takes the best conditioned at each state; ``moves``: the
    accelerations depend on the family's parameter (on an edge only, where a
    member of the family that satisfies every condition is one of a continuum);
    ``consistency``: where the family exists only at some states (on an edge
    where two constraints coincide, and agree only at some velocities), the
    numerators of Cramer's rule on the whole singular problem, ``adj(K) rhs``,
    which vanish together exactly there (None: it exists at every state).
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
    moves: bool = False
    consistency: list | None = None


@dataclass
class Family:
    """One parametrisation of a one-parameter family of reactions: ``L = (P + Dd t) / D``,
    ``D`` the minor of the contact problem it solves with (rows I, columns J)."""

    D: object
    P: list
    Dd: list


def problem(eqs, kinds: tuple, fname: str, at_rest: bool = True) -> LinearProblem:
    """The linear problem of the mode kinds ``kinds`` (one per contact).

    ``at_rest``: a sticking contact means the state is at rest (the velocity is
    set to zero); not so on an edge, where a contact sticks while the system
    moves (:mod:`phasemap.declare.edges`).
    """
    import sympy as sp

    zero = {eqs.velocity: sp.Integer(0)} if STICK in kinds and at_rest else {}
    p = LinearProblem(kinds, fname, eqs.n, zero, extra=[sp.Integer(0)] * eqs.n)
    for c, kind in zip(eqs.S.contacts, kinds):
        mode = Mode(kind)
        reactions = c.unknowns(mode, eqs.channels[c.name], p)
        p.reactions += reactions
        p.requirements += c.requirements(mode, reactions)
    return p


def solve(eqs, p: LinearProblem, edge: bool = False) -> Solution:
    """The closed-form solution of ``p`` (see the module docstring for the solvers);
    ``edge``: a row of an edge (:mod:`phasemap.declare.edges`), whose contacts need not
    share one slip direction, and whose family of reactions may be inconsistent at some
    states or move the accelerations."""
    import sympy as sp

    n, k = p.n, len(p.unknowns)
    M = eqs.M
    aM = M.adjugate() if n > 1 else sp.Matrix([[1]])
    dM = determinant(M) if n > 1 else M[0, 0]
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
    regular = solve_regular(eqs, p, K, rhs, shared=not edge)
    if regular is not None:
        sol.D, sol.nums = regular
        return sol
    sol.family, sol.moves, consistent = solve_indeterminate(eqs, p, K, rhs, aM * W, edge)
    sol.D = sol.family[0].D
    if not consistent:
        # not reduced: a common factor (omega**2) is the condition itself
        sol.consistency = [sp.expand(cramer(K, rhs, i)) for i in range(k)]
    return sol


def solve_regular(eqs, p: LinearProblem, K, rhs, shared: bool = True):
    """``(D, numerators)`` of ``K L = rhs`` by Cramer's rule, or None where ``K`` is
    singular on the whole domain (statically indeterminate).  ``shared``: the contacts
    that slip share one direction (:func:`one_direction`)."""
    D = determinant(K)
    if _vanishes(eqs, D):
        return None
    D, *nums = reduced([D] + [cramer(K, rhs, i) for i in range(len(p.unknowns))])
    return one_direction(eqs, p, D, nums) if shared else (D, nums)


def _vanishes(eqs, e) -> bool:
    """Whether ``e`` vanishes identically (relative to its scale, at random samples: a
    nonzero function of the state does not vanish at random points)."""
    return _vanish(eqs, [e])[0]


def _vanish(eqs, exprs) -> list[bool]:
    """:func:`_vanishes` of each of ``exprs``, evaluated together at the same samples
    (:meth:`phasemap.declare.equations.Equations.numeric_all`)."""
    import sympy as sp

    exprs = [sp.sympify(e) for e in exprs]
    live = [i for i, e in enumerate(exprs) if e != 0]
    out = [True] * len(exprs)
    if live:
        vals = eqs.numeric_all([exprs[i] / (scale_of(exprs[i]) + 1e-300) for i in live], 12)
        for i, v in zip(live, vals):
            out[i] = not np.max(np.abs(v)) > 1e-9
    return out


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
    D = sp.expand(determinant(A))
    if D == 0 or np.max(np.abs(eqs.numeric(D / scale_of(D), 12))) < 1e-9:
        fail(eqs.S, "bodies", "the mass matrix is singular on the motions the "
             f"contacts allow (modes {', '.join(p.kinds)}): some coordinate has no "
             "inertia (a missing mass or inertia term)")
    D, *nums = reduced([D] + [sp.expand(cramer(A, rhs, i)) for i in range(n + k)])
    return D, nums[:n], nums[n:]


def solve_indeterminate(eqs, p: LinearProblem, K, rhs, aMW, edge: bool = False):
    """The one-parameter family of reactions where ``K`` is singular: its
    parametrisations (:class:`Family`) and whether it moves the accelerations.

    The family is parametrised by one reaction j0 with equation i0 dropped, by
    Cramer on the minor that is left.  Each minor may vanish somewhere in the
    domain (the ladder: one at phi = 0, where the floor's normal is the wall's
    tangent, another at phi = pi/2), so the choice is left to the state: every
    minor that does not vanish identically is kept (one of each set of minors
    equal up to a constant factor; for a symmetric ``K``, the principal minors
    suffice, which are the others' largest), and the generated code takes the
    one that is largest relative to the magnitude of its terms.  Where ``K`` has
    rank k - 1 some minor is nonzero, so every state is decided.  The reported
    reactions, the middle of the admissible segment, do not depend on the
    parametrisation.
    """
    S, k = eqs.S, len(p.unknowns)
    if p.squared is not None:
        fail(S, f"mode {p.fname}", "a joint with statically indeterminate reactions "
             "is not supported")
    choices = _minors(eqs, K, k)
    if not choices:
        fail(S, f"mode {p.fname}", "the reactions are indeterminate with a family of "
             "more than one parameter: not supported")
    families, moves, consistent = [], False, True
    for I, J, sub, Dp in choices:
        fam, moving, holds = _parametrisation(eqs, p, K, rhs, aMW, I, J, sub, Dp)
        if (moving or not holds) and not edge:
            fail(S, f"mode {p.fname}", "the reactions are indeterminate and the "
                 "accelerations depend on them (a continuum of motions): not supported")
        families.append(fam)
        moves |= moving
        consistent &= holds
    return families, moves, consistent


def _minors(eqs, K, k):
    """The (k-1)-minors of ``K`` a family is parametrised by: ``(I, J, sub, D)``, none of
    them identically zero nor a constant multiple of another (principal minors only
    for a symmetric ``K``)."""
    import sympy as sp

    rows = list(itertools.combinations(range(k), k - 1))
    symmetric = (K - K.T).applyfunc(sp.expand) == sp.zeros(k, k)
    pairs = [(I, I) for I in rows] if symmetric else [(I, J) for I in rows for J in rows]
    choices = []
    for I, J in pairs:
        sub = K.extract(list(I), list(J))
        Dp = determinant(sub)
        if _vanishes(eqs, Dp):
            continue
        if any(_proportional(eqs, Dp, other[3]) for other in choices):
            continue
        choices.append((I, J, sub, Dp))
    return choices


def _proportional(eqs, a, b) -> bool:
    """Whether ``a / b`` is a constant (the same number at random samples; exactly, where
    sympy cancels it to a number): two such minors vanish together."""
    import sympy as sp

    # numerically first: a ratio that is far from constant at the samples is not one, and
    # one constant to rounding is (sympy's cancel of two minors took seconds); a ratio in
    # between, or not finite at some sample, is decided exactly as before
    a, b = sp.sympify(a), sp.sympify(b)
    signs = [x for x in a.free_symbols | b.free_symbols
             if x.name.startswith(("_k_sig", "_k_rho"))]
    spreads = []
    for sign in itertools.product((1, -1), repeat=len(signs)):
        sub = dict(zip(signs, sign))
        va, vb = eqs.numeric_all([a.xreplace(sub), b.xreplace(sub)], 6)
        with np.errstate(all="ignore"):
            r = va / vb
        if not np.all(np.isfinite(r)) or np.max(np.abs(r)) == 0.0:
            spreads = None
            break
        spreads.append(np.ptp(r) / np.max(np.abs(r)))
    if spreads is not None and max(spreads) > 1e-3:
        return False
    if spreads is not None and max(spreads) <= 1e-12:
        return True
    ratio = sp.cancel(a / b)
    if not ratio.free_symbols:
        return True
    signs = [x for x in ratio.free_symbols if x.name.startswith(("_k_sig", "_k_rho"))]
    for sign in itertools.product((1, -1), repeat=len(signs)):
        r = eqs.numeric(ratio.xreplace(dict(zip(signs, sign))), 6)
        if not (np.all(np.isfinite(r)) and np.ptp(r) <= 1e-9 * np.max(np.abs(r))):
            return False
    return True


def _parametrisation(eqs, p, K, rhs, aMW, I, J, sub, Dp):
    """The family on the minor ``sub`` (rows I, columns J of K), whether the accelerations
    depend on its parameter, and whether the equation it drops holds at every state."""
    import sympy as sp

    k = len(p.unknowns)
    (i0,) = set(range(k)) - set(I)
    (j0,) = set(range(k)) - set(J)
    P0 = [cramer(sub, rhs.extract(list(I), [0]), a) for a in range(k - 1)]
    dcol = -K.extract(list(I), [j0])
    d = [cramer(sub, dcol, a) for a in range(k - 1)]
    lam_d = [sp.Integer(0)] * k
    lam_p = [sp.Integer(0)] * k
    for a, j in enumerate(J):
        lam_d[j], lam_p[j] = d[a], P0[a]
    lam_d[j0] = Dp
    # the dropped equation: for the direction it holds (K is singular); for the particular
    # member it may not (then the family exists only where the residual vanishes)
    row_p = sum(K[i0, j] * lam_p[j] for j in range(k)) - rhs[i0] * Dp
    row_d = sum(K[i0, j] * lam_d[j] for j in range(k))
    # (the three tests at once: they share the family's Cramer numerators)
    moved = list(aMW * sp.Matrix(lam_d))
    direction, holds, *still = _vanish(eqs, [row_d, row_p, *moved])
    if not direction:
        raise AssertionError(f"{p.fname}: the family's direction leaves the dropped equation")
    moves = not all(still)
    Dp, *pd = reduced([Dp, *P0, *d])
    P, Dd = [sp.Integer(0)] * k, [sp.Integer(0)] * k
    for a, j in enumerate(J):
        P[j], Dd[j] = pd[a], pd[k - 1 + a]
    Dd[j0] = Dp
    return Family(Dp, P, Dd), moves, holds


def short_determinant(sol: Solution, angles):
    """The row's determinant ``D`` as the generated code computes it: reduced modulo
    sin^2 + cos^2 = 1 for the ``angles`` where that is shorter (the wheel's
    ``l^2 sin^2 + l^2 cos^2`` is ``l^2``).  Its tie scale stays that of ``D`` as
    derived (:func:`phasemap.declare.algebra.scale_of`), so that every tie is kept."""
    import sympy as sp

    D = sp.sympify(sol.D)
    if not D.free_symbols & set(angles):
        return D
    short = pythagorean(D, angles)
    return short if count_ops([short]) < count_ops([D]) else D


def quotients(sol: Solution, rows, angles):
    """The accelerations ``rows`` (indices of coordinates) as one quotient each over the
    row's determinant: ``(numerators, c)`` with ``q''_j = numerators[j] / (c D)``,
    where ``D`` is the row's determinant and ``c`` what is left of the mass matrix's
    determinant ``dM`` (reduced modulo sin^2 + cos^2 = 1 for the ``angles``; 1 where it
    divides out), or None for a row solved otherwise (saddle point, indeterminate).

    ``q'' = aM (hx + W L) / dM`` with ``L = nums / D`` is ``aM (D hx + W nums) / (dM D)``:
    expanded and divided by the monomial it shares with ``dM``, a rolling wheel's phi''
    is the paper's right-hand side over its bracket (19 operations where the path
    through the reactions takes about 150, and no reaction is needed).  None also where
    the expanded numerators would cost more than the reactions they spare.
    """
    import sympy as sp

    if sol.qnums is not None or sol.family is not None or sol.nums is None:
        return None
    p = sol.problem
    n, k = p.n, len(p.unknowns)
    gen = [sol.D * sol.hx[a] + sum((sol.W[a, i] * sol.nums[i] for i in range(k)),
                                   sp.Integer(0)) for a in range(n)]
    nums = expanded([sum((sol.aM[j, a] * gen[a] for a in range(n)), sp.Integer(0))
                     for j in rows])
    via = count_ops(sol.nums) + sum(count_ops([sol.aM[j, a] * (sol.hx[a] + sum(
        (sol.W[a, i] for i in range(k)), sp.Integer(0))) for a in range(n)]) for j in rows)
    if count_ops(nums) > via:
        return None
    dM, *nums = reduced([sp.expand(sol.dM)] + nums)
    if dM.free_symbols & set(angles):
        dM = pythagorean(dM, angles)
    if dM.is_Number:
        return [sp.expand(e / dM) for e in nums], sp.Integer(1)
    return nums, dM


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
