r"""Declared systems: write the mechanics, get a :class:`phasemap.Model`.

A planar system with dry friction is declared in a few lines: its generalised
coordinates, parameters, bodies (mass, position, inertia), potential energy
and contacts.  phasemap derives the equations of motion with sympy (Lagrange),
enumerates every combination of contact modes, solves each in closed form,
and prints the result as numba branch functions in the kernel contract of
:mod:`phasemap.core.model`.  Every feature (``classify``, atlases, the CLI,
``simulate``, fate maps, phase curves, plots) then works for the system.

Example: the classic Painleve rod
---------------------------------
>>> import sympy as sp
>>> from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System
>>> f = Parameter("f", "1", "friction coefficient at the floor", default=0.5, lower=0.0)
>>> l = Parameter("l", "m", "half length of the rod", default=1.0, lower=0.0, lower_open=True)
>>> g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
>>> m = Parameter("m", "kg", "mass of the rod", default=1.0, lower=0.0, lower_open=True)
>>> theta = Coordinate("theta", "rad", "angle of the rod to the floor", default=1.0,
...                    lower=0.0, upper=float(sp.pi),
...                    rate=Rate("omega", "rad s-1", "angular velocity of the rod"))
>>> x = Coordinate("x", "m", "position of end A along the floor",
...                rate=Rate("xdot", "m s-1", "velocity of end A along the floor",
...                          scale=sp.sqrt(g * l)))
>>> y = Coordinate("y", "m", "height of end A above the floor")   # no rate: the contact fixes it
>>> rod = System(
...     "my_rod", "Painleve rod", "Painleve (1895)",
...     coordinates=(theta, x, y), parameters=(f, l, g, m),
...     bodies=(Body(m, (x + l * sp.cos(theta), y + l * sp.sin(theta)),
...                  inertia=m * l**2 / 3, angle=theta),),
...     potential=m * g * (y + l * sp.sin(theta)),
...     contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f),))
>>> model = rod.model          # derived once, then cached on disk  # doctest: +SKIP

The concepts
------------
:class:`Parameter`
    a named constant with units, a default and a domain.
:class:`Coordinate`
    a generalised coordinate.  With a :class:`Rate` (its velocity) it is part of
    the state; without one it is *dependent*: the contacts fix it (the height
    of a rod end on the floor) and phasemap solves for it.  A coordinate with a
    rate that no equation depends on (the slider position of the elliptic
    pendulum) is integrated in time but is not an input of the maps.
:class:`Body`
    a mass at a position (an expression of the coordinates), with an inertia
    about its centre of mass and its rotation angle.
:class:`PointContact`
    a point of a body on a flat surface ``normal . point = offset``: one-sided
    (``N >= 0``, it may separate) or two-sided (a guide, split on ``sgn N``),
    with Coulomb friction ``f``.
:class:`EdgeContact`
    a fixed corner touching a straight edge of a body (a rod lying across a
    step); the contact point slides along the edge.
:class:`RollingContact`
    a disc of radius ``radius`` centred at ``centre`` rolling without slip on a
    flat surface, with a rolling-friction moment ``delta N``; one-sided.
:class:`Joint`
    a point of a body pinned at ``at`` (two-sided), with a friction moment
    ``delta |R|``, ``R`` the joint's reaction force, opposing the relative
    rotation ``angle``.

Modes and what a row says
-------------------------
Every contact has modes: a point contact slips in the direction of its
relative velocity (or, at zero relative velocity, sticks or starts to slip
either way) or, if one-sided, separates (``N = F = 0``, the gap accelerating
open strictly; a vanishing ``N`` is a kept, grazing contact).  A two-sided
contact splits on the sign of ``N`` (``N = 0`` counted once, with ``N >= 0``).
A joint's friction law ``M = -sigma delta |R|`` is solved exactly: the linear
part gives the reaction affine in ``M``, squaring once gives a quadratic, and
only roots with ``sigma M <= 0`` are kept (GUIDE section 1).  Each combination
of modes is one candidate branch; ``n_solutions`` counts the admissible ones.
An admissible combination that separates a contact has the status
``SEPARATION``: it is a solution (the body leaves the contact), counted in
``n_solutions`` and flagged by ``contact_lost``.

Where the kept contacts do not determine the reactions (a ladder held at rest
by two rough contacts: four reactions, three equations), the reactions form a
one-parameter family; the combination is admissible when some member of the
family satisfies every friction limit, and phasemap reports the middle one.

Zero tests take their scale from the magnitudes of the terms of each quantity
(sin and cos count as 1, GUIDE section 1), computed alongside the quantity.

Limits (clear errors, not silent failures)
------------------------------------------
* All frictional contacts must slip with one state velocity when every contact
  is kept (their relative velocities are multiples of one rate, of a fixed
  sign over the domain): the maps and the integrator's stages are keyed on
  that velocity's sign.
* At most one joint with friction; statically indeterminate reactions with a
  family of more than one parameter are refused.
* Contact surfaces are flat (a line ``normal . point = offset``).

Conditions for the bifurcation tracer
-------------------------------------
:func:`conditions` lists, per candidate branch, every scalar condition that
decides whether it is admissible (coefficient, normal forces, friction limits,
start from rest, gap, family, the joint's roots, the domain) as sympy
expressions without poles, built from the same contact-law requirements as
the generated code.  See :mod:`phasemap.declare.admissibility`.

The package
-----------
``api``            the quantities: Parameter, Coordinate, Rate, Body
``law``            the contract of a contact law (its hooks), modes and requirements
``contacts``       the laws: PointContact, EdgeContact, RollingContact, Joint
``system``         System, load
``validation``     every problem of a declaration as one ValueError
``equations``      Lagrange's equations on the contact manifold (Equations)
``modes``          the candidate branches (mode combinations) and the slip velocity
``solvers``        one mode combination solved: regular, saddle point, indeterminate, joint
``derivation``     equations, candidates and solutions together (one derivation)
``emit``           the generated numba module
``admissibility``  the conditions of each branch as expressions (for the tracer)
``build``          the kernel cache and the Model
"""

from __future__ import annotations

from phasemap.declare.api import SLIP_SPEED, TIME, Body, Coordinate, Parameter, Rate
from phasemap.declare.admissibility import Condition, conditions
from phasemap.declare.contacts import EdgeContact, Joint, PointContact, RollingContact
from phasemap.declare.law import ContactLaw
from phasemap.declare.loader import load
from phasemap.declare.system import System

__all__ = ["Parameter", "Rate", "Coordinate", "Body", "PointContact", "EdgeContact",
           "RollingContact", "Joint", "ContactLaw", "System", "load",
           "Condition", "conditions", "TIME", "SLIP_SPEED"]
