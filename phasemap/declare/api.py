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


class _Special(_Symbolic):
    """A name phasemap gives a meaning to (:data:`TIME`, :data:`SLIP_SPEED`)."""

    def __init__(self, name: str, doc: str):
        self.name, self.__doc__ = name, doc

    def _sympy_(self):
        import sympy as sp

        return sp.Symbol(self.name, real=True)

    def __repr__(self):
        return self.name


#: The time ``t`` (s), in the applied forces (``forces=``) and a surface's velocity
#: (``surface_velocity=``) of a forced system, which declares its ``period=``:
#: ``F0 * sp.cos(Omega * TIME)``.
TIME = _Special("t", "The time t (s) of a forced system (see System's period=).")
#: A contact's relative sliding speed ``|v_rel|`` (>= 0), in a slip coefficient that
#: depends on it (a Stribeck curve): ``friction=f_s / (1 + delta * SLIP_SPEED)``.
SLIP_SPEED = _Special("slip_speed", "A contact's relative sliding speed |v_rel| (>= 0), in "
                      "a friction law that depends on it.")
#: The names above, which a declaration may not give to its own quantities.
SPECIAL_NAMES = frozenset({TIME.name, SLIP_SPEED.name})


def uses(e, special) -> bool:
    """Whether the expression ``e`` depends on the special name ``special``."""
    return sym(special) in sym(e).free_symbols


def numeric_bound(bound) -> bool:
    """Whether a coordinate's bound is a number (else an expression of the parameters,
    checked through sympy by the model's ``check``): one rule for the build, the
    equations and the sympy-free cache manifest."""
    return isinstance(bound, (int, float))


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
    """A named constant: ``Parameter("l", "m", "half length", default=1.0, lower=0.0)``.

    Parameters
    ----------
    name, units, long_name : str
        an identifier, UDUNITS units (``"m"``, ``"1"``) and a description; they
        label the maps and the atlas variables.
    default : float, default 1.0
    lower, upper : float
        the domain; ``lower_open``/``upper_open`` exclude the bound itself.
    symbol : str
        LaTeX for the figures (default: the name).

    Examples
    --------
    >>> from phasemap.declare import Parameter
    >>> l = Parameter("l", "m", "half length of the rod", default=1.0, lower=0.0,
    ...               lower_open=True)
    >>> l.name, l.default, 2 * l                  # a sympy symbol in expressions
    ('l', 1.0, 2*l)
    """

    default: float = 1.0


@dataclass(frozen=True, eq=False)
class Rate(_Symbolic):
    """The velocity of a coordinate, a state variable.

    ``scale`` (an expression of the parameters, in the rate's units) is the
    natural size of the velocity: it counts as zero when
    ``|rate| <= 1e-12 * scale``.  The default, 1, means 1e-12 in SI units.

    Parameters
    ----------
    name, units, long_name : str
    default : float, default 0.0
    symbol : str
        LaTeX for the figures.
    scale : sympy expression or number, default 1

    Examples
    --------
    >>> import sympy as sp
    >>> from phasemap.declare import Parameter, Rate
    >>> g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81)
    >>> l = Parameter("l", "m", "half length", default=1.0)
    >>> Rate("omega", "rad s-1", "angular velocity", scale=sp.sqrt(g / l)).scale
    sqrt(g/l)
    """

    name: str
    units: str
    long_name: str
    default: float = 0.0
    symbol: str = ""
    scale: object = 1


@dataclass(frozen=True, eq=False)
class Coordinate(_Quantity):
    """A generalised coordinate; with a :class:`Rate` it is a state variable.

    Without a rate it is *dependent*: the contacts fix it (the height of a rod
    end on the floor).

    Parameters
    ----------
    name, units, long_name, default, lower, upper, lower_open, upper_open, symbol
        as for :class:`Parameter` (default 0).
    rate : Rate, optional
        its velocity.

    Examples
    --------
    >>> from phasemap.declare import Coordinate, Rate
    >>> theta = Coordinate("theta", "rad", "angle of the rod to the floor", default=1.0,
    ...                    lower=0.0, upper=3.14, rate=Rate("omega", "rad s-1", "angular velocity"))
    >>> y = Coordinate("y", "m", "height of end A")     # fixed by a contact
    >>> theta.rate.name, y.rate is None
    ('omega', True)
    """

    rate: Rate | None = None


@dataclass(frozen=True, eq=False)
class Body:
    """A mass ``mass`` at ``position`` (x, y) with ``inertia`` about it, turned by ``angle``.

    Parameters
    ----------
    mass : Parameter or expression
    position : tuple of two expressions
        the centre of mass in the coordinates and parameters.
    inertia : expression, default 0
        the moment of inertia about the centre of mass.
    angle : expression, default 0
        the body's rotation angle (counter-clockwise).

    Examples
    --------
    >>> import sympy as sp
    >>> from phasemap.declare import Body, Coordinate, Parameter
    >>> m, l = Parameter("m", "kg", "mass"), Parameter("l", "m", "half length")
    >>> theta, x = Coordinate("theta", "rad", "angle"), Coordinate("x", "m", "end A")
    >>> rod = Body(m, (x + l * sp.cos(theta), l * sp.sin(theta)), inertia=m * l**2 / 3,
    ...            angle=theta)
    >>> rod.inertia
    l**2*m/3
    """

    mass: object
    position: tuple
    inertia: object = 0
    angle: object = 0
