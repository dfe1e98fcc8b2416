"""The linearised return map of a hybrid periodic orbit: variational equations along each
segment, a saltation matrix at every event, the product restricted to the contacts'
manifold (see :mod:`phasemap.motion.periodic`).

The state of a segment is ``X = (q, u, t)`` (the time joins the state, so that a forced
system's segments are autonomous).  Along a segment of fixed contact modes,
``X' = F(X) = (u, u'(q, u, t), 1)`` and ``dX' = A dX`` with ``A = dF/dX`` (its
acceleration rows by central differences of the phase's accelerations, which are smooth
inside a segment).  At the event ``h(X) = 0`` that ends the segment, where the jump
``X+ = J(X-)`` (the projection onto the next phase's closed contacts) follows, the
perturbation maps by the saltation matrix

    S = DJ + (F+ - DJ F-) grad h^T / (grad h . F-)

(Aizerman and Gantmacher 1958; Leine and Nijmeijer 2004, section 7.2): ``F-`` and ``F+``
the vector fields before and after.  The velocity part of ``DJ`` is the projector of the
velocity projection, exact, so a stick segment's collapse (the relative velocity set to
the surface's) is an exact zero row, and its Floquet multiplier an exact 0.
"""

from __future__ import annotations

import numpy as np

#: Relative step of the central differences of the phase's accelerations.
STEP = 1e-6
#: The same along a direction of the variational equations (each coordinate moved at most
#: this relative step): a step along a direction is rounded in every coordinate it moves,
#: where a coordinate's own step is exact in floating point, so it is longer.  Measured on
#: Ueda's period doubling against the variational equations with the exact Jacobian
#: (rtol 1e-13): the multipliers err 2e-9 to 5e-9 at 1e-6, 5e-10 to 1e-9 at 4e-6, as
#: the coordinates' steps of :data:`STEP` do, and 5e-8 at 6.4e-5 (truncation).
DIRECTIONAL_STEP = 4e-6


def accelerations(motion, X, modes, rho):
    """The phase's accelerations at ``X``; a one-line ValueError where its linear system is
    singular."""
    n = motion.n
    sol = motion.solve(X[:n], X[n:2 * n], modes, rho, X[2 * n])
    if sol is None:
        raise ValueError(f"{motion.mech.name}: the phase has no accelerations at "
                         f"t = {X[2 * n]:.6g} (its linear system is singular there)")
    return sol[0]


def field(motion, X, modes, rho):
    """``F(X) = (u, u', 1)`` of the phase ``modes``."""
    n = motion.n
    return np.concatenate([X[n:2 * n], accelerations(motion, X, modes, rho), [1.0]])


def difference(fn, x, j):
    """The central difference of ``fn`` (of an array) along ``x[j]``, its step relative
    (:data:`STEP`) and exact in floating point."""
    h = STEP * (1.0 + abs(x[j]))
    xp, xm = x.copy(), x.copy()
    xp[j] += h
    xm[j] -= h
    return (np.asarray(fn(xp)) - np.asarray(fn(xm))) / (xp[j] - xm[j])


def differences(fn_rows, x, cols):
    """:func:`difference` along each ``x[j]`` of ``cols``, a row each, with ``fn_rows``
    evaluated once on all the shifted points (a row of them each, two a column): the
    same bits as :func:`difference` column by column."""
    cols = list(cols)
    states = np.repeat(x[None, :], 2 * len(cols), axis=0)
    for i, j in enumerate(cols):
        h = STEP * (1.0 + abs(x[j]))
        states[2 * i, j] += h
        states[2 * i + 1, j] -= h
    values = np.asarray(fn_rows(states))
    steps = states[0::2, cols].diagonal() - states[1::2, cols].diagonal()
    return (values[0::2] - values[1::2]) / steps.reshape((-1,) + (1,) * (values.ndim - 1))


def jacobian(motion, X, modes, rho):
    """``A = dF/dX`` at ``X`` (central differences of the accelerations): in one call of
    the compiled flow, the same bits as the loop below, which serves where a solve on the
    way is not the plain one (redundant contacts; no solution, its one-line error)."""
    A = motion.flow.jacobian(X, modes, rho, STEP)
    if A is not None:
        return A
    n = motion.n
    m = 2 * n + 1
    A = np.zeros((m, m))
    A[:n, n:2 * n] = np.eye(n)

    for j in range(m):
        A[n:2 * n, j] = difference(lambda Y: accelerations(motion, Y, modes, rho), X, j)
    return A


def event_gradient(motion, X, modes, rho, index, sc):
    """``grad h`` of the event function ``index`` of the phase (central differences, as
    :func:`difference` takes them: the event functions at the 2 (2n + 1) states in one
    call, :meth:`phasemap.motion.hybrid.Motion.watch_many`)."""
    n = motion.n
    return differences(lambda S: motion.watch_many(S[:, 2 * n], S[:, :2 * n], modes, rho,
                                                   sc)[:, index], X, range(2 * n + 1))


def jump_derivative(motion, X, closed, held):
    """``DJ`` of the projection onto the contacts ``closed`` (velocities on ``J_n u = 0``)
    and ``held`` (``J_t u`` on the surface's velocity) at a state on them: the velocity
    block is the exact projector; the positions' blocks are the tangent projector and the
    projector's change with the positions (central differences)."""
    n = motion.n
    m = 2 * n + 1
    D = np.eye(m)
    if not closed and not held:
        return D
    q, u, t = X[:n], X[n:2 * n], X[2 * n]
    D[:n, :n] = _position_projector(motion, q, u, t, closed)
    D[n:2 * n, n:2 * n] = _velocity_projector(motion, q, u, t, closed, held)
    # d(projected u)/dq, and with a held contact d/dt (the surface's velocity moves with
    # the time): :func:`difference`'s quotients, their projections in one call
    cols = list(range(n)) + ([2 * n] if held else [])
    D[n:2 * n, cols] = differences(lambda S: motion.project_velocities(
        S[:, :n], S[:, n:2 * n], S[:, 2 * n], closed, held), X, cols).T
    return D


def _rows(motion, q, u, t, closed, held):
    M, h, g, J, b, mu = motion.mech.pieces(q, u, motion.p, t)
    A = np.array([J[c, 0] for c in closed] + [J[c, 1] for c in held])
    return M, A


def _velocity_projector(motion, q, u, t, closed, held):
    M, A = _rows(motion, q, u, t, closed, held)
    X = np.linalg.solve(M, A.T)
    return np.eye(motion.n) - X @ np.linalg.solve(A @ X, A)


def _position_projector(motion, q, u, t, closed):
    n = motion.n
    if not closed:
        return np.eye(n)
    M, A = _rows(motion, q, u, t, closed, ())
    X = np.linalg.solve(M, A.T)
    return np.eye(n) - X @ np.linalg.solve(A @ X, A)


def saltation(DJ, F_minus, F_plus, grad):
    """The saltation matrix of an event (module docstring); NaN where the flow meets the
    event tangentially (``grad h . F- = 0``: a grazing orbit, at a bifurcation, where the
    linearised map is not defined)."""
    across = float(grad @ F_minus)
    if not abs(across) > 1e-12 * float(np.abs(grad).max() * np.abs(F_minus).max()):
        return np.full_like(DJ, np.nan)
    return DJ + np.outer(F_plus - DJ @ F_minus, grad) / across


def tangent_basis(motion, X, closed):
    """An orthonormal basis (columns) of the state directions ``(dq, du)`` that keep the
    contacts ``closed`` closed: ``J_n dq = 0`` and ``d(J_n u) = 0``."""
    n = motion.n
    if not closed:
        return np.eye(2 * n)
    q, u, t = X[:n], X[n:2 * n], X[2 * n]
    J = motion.mech.pieces(q, u, motion.p, t)[3]
    rows = []
    for c in closed:
        Jn = J[c, 0]
        dJu = np.array([difference(lambda r: motion.mech.pieces(r, u, motion.p, t)[3][c, 0]
                                   @ u, q, j) for j in range(n)])
        rows.append(np.concatenate([Jn, np.zeros(n)]))
        rows.append(np.concatenate([dJu, Jn]))
    C = np.array(rows)
    _, s, Vt = np.linalg.svd(C)
    rank = int(np.sum(s > 1e-12 * max(s.max(), 1.0)))
    return Vt[rank:].T
