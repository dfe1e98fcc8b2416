"""Shared numerical conventions of the point functions: tolerances, statuses, row layout.

Every model's ``point(v, out)`` fills one row of ``out`` per candidate branch.
The row layout and the status codes below are the contract between the models,
:func:`phasemap.classify` and the grid evaluator; they are plain integers so that
numba kernels can use them without Python objects.

Ties
----
A computed quantity is compared with zero through a tolerance that scales with
the magnitude of the terms it was built from: ``|q| <= TOL * scale``.  In a
scale, sin and cos factors count as 1: their rounding error is absolute, so a
term such as ``g cos(phi)`` at ``phi = pi/2`` is zero to within ``eps * g``,
not ``eps * g |cos(phi)|``.  Where a
comparison decides a boundary, the tie goes to the side listed here (and in each
model's docstring):

* the static-friction limit ``|F| <= f |N|`` is inclusive: ties go to **stick**;
* a slip (or roll, or turn) branch that *starts* from zero relative velocity in
  direction ``s`` needs ``s * acceleration > 0`` strictly: ties go to **stick**;
* a one-sided contact needs ``N >= 0``: a vanishing normal reaction (grazing
  contact) is **kept**, not lost;
* a two-sided contact split on ``sgn N`` counts ``N = 0`` in the ``N >= 0``
  branch, so the frictionless solution is counted once;
* a coefficient of the senior derivative within tolerance of zero is
  **singular**.

A relative velocity counts as zero when ``|v| <= TOL * v_ref``, with ``v_ref``
the model's natural velocity scale (for example ``sqrt(g / l)``), so that grid
axes built with ``numpy.linspace`` through zero hit the stick branch.
"""

from __future__ import annotations

import enum

import numpy as np
from numba import njit

#: Relative tolerance of every zero test on a computed quantity.
TOL = 1e-12

# Row layout of ``out[branch, :]``.  Accelerations follow from FIRST_ACC on,
# then the reactions; each model declares how many of each it has.
STATUS = 0
SINGULAR = 1
COEF = 2
FIRST_ACC = 3


class Coded(enum.IntEnum):
    """An integer code that says what it means: members are ``NAME = code, message``.

    The base of :class:`phasemap.BranchStatus`, :class:`phasemap.Solvability` and
    :class:`phasemap.Event`: each member is its code (an ``int``, what the kernels
    store) and carries its ``message``.

    >>> class Light(Coded):
    ...     RED = 0, "stop"
    >>> Light.RED == 0, Light(0).message
    (True, 'stop')
    """

    def __new__(cls, code: int, message: str):
        member = int.__new__(cls, code)
        member._value_ = code
        member.message = message
        return member


# Branch statuses (mirrored by :class:`phasemap.core.model.BranchStatus`).
ABSENT = 0
ADMISSIBLE = 1
INADMISSIBLE = 2
CONTACT_LOST = 3
NO_SOLUTION = 4
CONTINUUM = 5
#: Solves the equations with a one-sided contact opening: the body leaves it (a
#: solution, counted in n_solutions; declared systems, see phasemap.declare).
SEPARATION = 6

# Solvability codes (mirrored by :class:`phasemap.core.model.Solvability`).
N_NONE = 0
N_UNIQUE = 1
N_TWO = 2
N_CONTINUUM = 3
N_THREE_OR_MORE = 4


@njit(cache=True, error_model="numpy", forceinline=True)
def is_zero(q, scale):
    """True where ``q`` vanishes relative to the magnitude ``scale`` of its terms."""
    return abs(q) <= TOL * scale


#: The value of a row field a branch does not determine.
NAN = np.nan


# The helpers below are for branch functions: inlined, and free of control flow
# (conditional expressions compile to selects), so that a grid kernel's inner
# loop vectorises through them.

@njit(cache=True, error_model="numpy", forceinline=True)
def start_interval(rest, s):
    """Open interval of accelerations a branch may take: ``s * a > 0`` when it starts from rest."""
    lo = 0.0 if (rest & (s > 0.0)) else -np.inf
    hi = 0.0 if (rest & (not (s > 0.0))) else np.inf
    return lo, hi


@njit(cache=True, error_model="numpy", forceinline=True)
def restrict_affine(q0, dq, lo, hi):
    """Intersect the open interval ``(lo, hi)`` with ``{a : q0 + dq * a >= 0}``.

    Used for a continuum of solutions (a singular branch whose equation is
    satisfied by every acceleration ``a``): the reactions are affine in ``a`` and
    the admissible family is the set where they keep their required sign.
    """
    t = -q0 / dq
    up = dq > 0.0
    down = dq < 0.0
    new_lo = max(lo, t) if up else lo
    new_hi = min(hi, t) if down else (lo if ((not up) & (q0 < 0.0)) else hi)
    return new_lo, new_hi


@njit(cache=True, error_model="numpy")
def summarize(out, stick):
    """Reduce the branch rows of one point to the four per-point answers.

    Returns ``(n_solutions, stagnation, contact_lost, singular)``:

    * ``n_solutions``: 0 none, 1 unique, 2 two, 3 continuum (any admissible
      family of solutions), 4 three or more isolated solutions;
    * ``stagnation``: the stick branch (row ``stick``; -1 when the model has
      none) is admissible;
    * ``contact_lost``: a solution leaves a one-sided contact (a separation
      branch is admissible), or, in a model without separation branches, some
      branch solves the equations and its own sign assumptions but needs a
      one-sided contact to pull;
    * ``singular``: the coefficient of the senior derivative of some
      candidate branch vanishes.
    """
    n = 0
    continuum = False
    lost = False
    singular = False
    for b in range(out.shape[0]):
        st = out[b, STATUS]
        if st == ADMISSIBLE or st == SEPARATION:
            n += 1
        elif st == CONTINUUM:
            continuum = True
        if st == CONTACT_LOST or st == SEPARATION:
            lost = True
        if out[b, SINGULAR] != 0.0:
            singular = True
    if continuum:
        code = N_CONTINUUM
    elif n >= 3:
        code = N_THREE_OR_MORE
    else:
        code = n
    stagnation = stick >= 0 and out[stick, STATUS] == ADMISSIBLE
    return code, stagnation, lost, singular
