"""What an impulse at a contact needs from a declaration: the mass matrix in the full
coordinates and each contact's normal and tangential rows, as numeric functions.

A velocity jump at a contact is ``M dq' = J^T P`` with ``J`` the contact's rows (its
normal and tangential velocity as ``J q'``) in the declaration's full coordinates (every
coordinate, those the contacts fix included), and the Delassus matrix of the contact is
``W = J M^-1 J^T`` (:func:`phasemap.motion.impact.delassus`).  Both come from the same
derivation as the equations of motion (:class:`phasemap.declare.equations.Equations`:
``M`` and the channels, on the contact manifold), turned into NumPy functions once per
declaration with sympy's ``lambdify``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from phasemap.core.memo import Memo

_IMPULSES = Memo("declare.impulses")


@dataclass(frozen=True)
class Impulses:
    """Numeric pieces of one declaration, each a function of :attr:`args` values."""

    #: argument names, in order: the coordinates with a rate, the rates, the parameters
    args: tuple[str, ...]
    #: the full coordinates' rates, in the declaration's coordinate order
    coordinates: tuple[str, ...]
    #: index, in ``coordinates``, of each coordinate that has a rate (the state's)
    free: tuple[int, ...]
    mass: Callable            # args -> M (n x n)
    rates: Callable           # args -> q' of every coordinate (the fixed ones from the contacts)
    rows: dict                # contact name -> (args -> (2, n) array: normal row, tangential row)
    friction: dict            # contact name -> (args -> its friction coefficient)

    def at(self, values: dict) -> tuple:
        """The argument values from a name -> value mapping."""
        return tuple(float(values[a]) for a in self.args)


def impulses(S) -> Impulses:
    """The :class:`Impulses` of the declaration ``S`` (derived with sympy once)."""
    return _IMPULSES.get((S,), (), lambda: _make(S))


def _make(S) -> Impulses:
    import sympy as sp

    from phasemap.declare.api import sym
    from phasemap.declare.derivation import derive

    eqs = derive(S).eqs
    free = tuple(i for i, c in enumerate(S.coordinates) if c.rate is not None)
    arg_syms = ([eqs.q[i] for i in free] + [eqs.qd[i] for i in free] + list(eqs.params))
    names = tuple(str(a) for a in arg_syms)
    rates = [eqs.on(eqs.qd[i]) for i in range(eqs.n)]

    def fn(expr):
        return sp.lambdify(arg_syms, expr, modules="numpy")

    rows, friction = {}, {}
    for c in S.contacts:
        ch = eqs.channels.get(c.name, {})
        if "N" not in ch or "T" not in ch:
            continue  # a contact without a normal and a tangent (a joint): no impact there
        rows[c.name] = fn(sp.Matrix([ch["N"][0], ch["T"][0]]))
        friction[c.name] = fn(sym(getattr(c, c.friction_field)))
    return Impulses(names, tuple(c.name for c in S.coordinates), free, fn(eqs.M),
                    fn(sp.Matrix(rates)), rows, friction)


def at_contact(imp: Impulses, contact: str, values: dict):
    """``(M, J, q', mu)`` at the state and parameters ``values`` (names of
    :attr:`Impulses.args`; KeyError naming a missing one): the mass matrix, the contact's
    normal and tangential rows, every coordinate's rate, and its friction coefficient.
    The jump of an impulse P there is ``q'+ = q' + M^-1 J^T P``."""
    a = imp.at(values)
    return (np.atleast_2d(np.asarray(imp.mass(*a), dtype=float)),
            np.asarray(imp.rows[contact](*a), dtype=float),
            np.asarray(imp.rates(*a), dtype=float).ravel(),
            float(imp.friction[contact](*a)))
