"""The quantities of a declaration: parameters, coordinates and their rates, bodies.

Arithmetic on a declared name builds a sympy expression, so a position is
written as ``x + l * sp.cos(theta)``.  The contacts are in
:mod:`phasemap.declare.contacts`, the system in :mod:`phasemap.declare.system`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


class _Symbolic:
    """Arithmetic on a declared name builds a sympy expression."""

    def _sympy_(self):
        import sympy as sp

        return sp.Symbol(self.name, real=True)

    def _op(name):  # noqa: N805 - a small factory of forwarding operators
        def op(self, other):
            return getattr(self._sympy_(), name)(sym(other))
        return op

    for _n in ("add", "sub", "mul", "truediv", "pow"):
        locals()[f"__{_n}__"] = _op(f"__{_n}__")
        locals()[f"__r{_n}__"] = _op(f"__r{_n}__")
    del _n, _op

    def __neg__(self):
        return -self._sympy_()

    def __pos__(self):
        return self._sympy_()


def sym(x):
    """``x`` (a declared name, a number or an expression) as a sympy expression."""
    import sympy as sp

    return x._sympy_() if isinstance(x, _Symbolic) else sp.sympify(x)


@dataclass(frozen=True, eq=False)
class _Quantity(_Symbolic):
    """A named value with units, a default and a domain (bounds, open or closed)."""

    name: str
    units: str
    long_name: str
    default: float = 0.0
    lower: float = -math.inf
    upper: float = math.inf
    lower_open: bool = False
    upper_open: bool = False
    symbol: str = ""


@dataclass(frozen=True, eq=False)
class Parameter(_Quantity):
    """A named constant: ``Parameter("l", "m", "half length", default=1.0, lower=0.0)``."""

    default: float = 1.0


@dataclass(frozen=True, eq=False)
class Rate(_Symbolic):
    """The velocity of a coordinate, a state variable.

    ``scale`` (an expression of the parameters, in the rate's units) is the
    natural size of the velocity: it counts as zero when
    ``|rate| <= 1e-12 * scale``.  The default, 1, means 1e-12 in SI units.
    """

    name: str
    units: str
    long_name: str
    default: float = 0.0
    symbol: str = ""
    scale: object = 1


@dataclass(frozen=True, eq=False)
class Coordinate(_Quantity):
    """A generalised coordinate; with a :class:`Rate` it is a state variable."""

    rate: Rate | None = None


@dataclass(frozen=True, eq=False)
class Body:
    """A mass ``mass`` at ``position`` (x, y) with ``inertia`` about it, turned by ``angle``."""

    mass: object
    position: tuple
    inertia: object = 0
    angle: object = 0
