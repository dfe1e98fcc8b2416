r"""Dormand-Prince 5(4): one step and its dense output, for :mod:`phasemap.motion.integrate`.

Order 5 with an embedded order-4 error estimate, first-same-as-last, and
Hairer's order-4 continuous extension (Hairer, Norsett and Wanner, *Solving
ODE I*, II.5 and II.6; the coefficients of Hairer's ``dopri5`` and scipy's
``RK45``).

A method module gives the integrator template (see
:func:`phasemap.motion.integrate.kernels`) two templates with these contracts,
compiled per model with the model's right-hand side ``RHS`` as a global, and
the constants below.

``step_template(v, y, h, branch, K, yt, y1, rtol, atol) -> error norm``
    One step of size ``h`` from ``y`` with ``K[0] = f(y)``: the stages into
    ``K``, the solution into ``y1``, and the RMS error norm over
    ``atol + rtol max(|y|, |y1|)``.  When the norm is at most 1 (the step is
    accepted) ``K[FSAL] = f(y1)``, ``yt`` is the point of stage ``FSAL - 1``
    (so that ``h |K[FSAL] - K[FSAL-1]| / |y1 - yt|`` estimates h |lambda| for
    Hairer's stiffness test) and ``v`` holds ``y1`` and its derived inputs.
``dense_template(v, y, y1, h, branch, K, yt, r)``
    After an accepted step, the ``N_DENSE`` rows of the continuous extension
    into ``r``: ``y(t + theta h) = r0 + theta (r1 + (1 - theta) (r2 + theta
    (r3 + ...)))`` (:func:`phasemap.motion.integrate.templates.dense`).  It may call ``RHS``
    (``v`` and ``yt`` are then overwritten).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.extending import overload

#: The integrator's name for the method (``simulate(method=...)``).
NAME = "DOPRI5"
DESCRIPTION = "Dormand-Prince 5(4), dense output of order 4"
#: Rows of the stage array: 6 stages and f(y1).
N_STAGES = 7
#: The row of K that holds f(y1) after an accepted step.
FSAL = 6
#: Rows of the dense output.
N_DENSE = 5
#: Exponent of the step-size controller and of the initial step: 1 / (order of the
#: error estimate + 1).
EXPONENT = 1.0 / 5.0
#: Hairer's stiffness test: h |lambda| beyond this (the stability boundary along the
#: negative real axis) for 15 accepted steps.
STIFF_BOUND = 3.25

RHS = None  # the model's right-hand side, a compile-time global (phasemap.motion.integrate)

#: The first stage is ``y + (h A21) K[0]``, its product formed in that order (the
#: other stages multiply the sum by h, as :func:`combine` forms it).
A21 = 1.0 / 5.0
#: Stages 3..6: (the row of K each fills, the rows of K it combines, its a_ij).
STAGES = (
    (2, (0, 1), (3.0 / 40.0, 9.0 / 40.0)),
    (3, (0, 1, 2), (44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0)),
    (4, (0, 1, 2, 3), (19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0)),
    (5, (0, 1, 2, 3, 4), (9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0,
                          -5103.0 / 18656.0)),
)
#: The solution y1 (stage 7, whose f is row FSAL): the rows it combines and its weights.
B_ROWS = (0, 2, 3, 4, 5)
B = (35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0)
#: The error estimate (order 5 minus order 4) and the dense output's last row.
E_ROWS = (0, 2, 3, 4, 5, 6)
E = (71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0,
     -1.0 / 40.0)
D = (-12715105075.0 / 11282082432.0, 87487479700.0 / 32700410799.0,
     -10690763975.0 / 1880347072.0, 701980252875.0 / 199316789632.0,
     -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0)


@njit(inline="always")
def combine(K, i, rows, coefs):
    """``sum_j coefs[j] K[rows[j], i]``, summed from the left in the order given.

    The stage arithmetic of both Dormand-Prince methods (:mod:`phasemap.motion.integrate.dop853`
    too), inlined into the step: ``rows`` and ``coefs`` are compile-time tuples
    of a row of the tableau, and the sum is formed term by term from the left,
    as the written-out expression ``a1 * K[r1, i] + a2 * K[r2, i] + ...`` forms
    it, so that it rounds as that does.

    Examples
    --------
    >>> import numpy as np
    >>> K = np.array([[1.0, 2.0], [10.0, 20.0], [100.0, 200.0]])
    >>> float(combine(K, 1, (0, 2), (0.5, 0.25)))
    51.0
    """
    acc = coefs[0] * K[rows[0], i]
    for j in range(1, len(rows)):
        acc += coefs[j] * K[rows[j], i]
    return acc


def run_stages(rhs, v, y, h, branch, K, yt, table):
    """The explicit stages of ``table`` in order: for each (row, rows, coefs),
    ``yt = y + h combine(K, rows, coefs)``, then ``rhs`` fills row ``row`` of ``K``.

    In Python it loops over ``table``; in numba (:func:`_unrolled_stages`) the
    loop is written out once per table, so that every coefficient and row index is
    a compile-time constant of the step, as in a step written by hand.
    """
    for row, rows, coefs in table:
        for i in range(y.shape[0]):
            yt[i] = y[i] + h * combine(K, i, rows, coefs)
        rhs(v, yt, branch, K, row)


@overload(run_stages, inline="always")
def _unrolled_stages(rhs, v, y, h, branch, K, yt, table):
    lines = ["def stages(rhs, v, y, h, branch, K, yt, table):"]
    for k in range(len(table)):
        lines += ["    for i in range(y.shape[0]):",
                  f"        yt[i] = y[i] + h * combine(K, i, table[{k}][1], table[{k}][2])",
                  f"    rhs(v, yt, branch, K, table[{k}][0])"]
    scope = {"combine": combine}
    exec("\n".join(lines), scope)
    return scope["stages"]


def step_template(v, y, h, branch, K, yt, y1, rtol, atol):
    """One Dormand-Prince 5(4) step; returns the error norm (see the module docstring)."""
    ny = y.shape[0]
    for i in range(ny):
        yt[i] = y[i] + h * A21 * K[0, i]
    RHS(v, yt, branch, K, 1)
    run_stages(RHS, v, y, h, branch, K, yt, STAGES)
    for i in range(ny):
        y1[i] = y[i] + h * combine(K, i, B_ROWS, B)
    RHS(v, y1, branch, K, FSAL)
    acc = 0.0
    for i in range(ny):
        err = h * combine(K, i, E_ROWS, E)
        sk = atol + rtol * max(abs(y[i]), abs(y1[i]))
        acc += (err / sk) ** 2
    return np.sqrt(acc / ny)


def dense_template(v, y, y1, h, branch, K, yt, r):
    """Hairer's order-4 continuous extension of the step y -> y1 into ``r`` (5 rows)."""
    for i in range(y.shape[0]):
        dy = y1[i] - y[i]
        bspl = h * K[0, i] - dy
        r[0, i] = y[i]
        r[1, i] = dy
        r[2, i] = bspl
        r[3, i] = dy - h * K[FSAL, i] - bspl
        r[4, i] = h * combine(K, i, E_ROWS, D)
