"""Declared built-in systems: each module defines SYSTEM (see phasemap.declare).

Registered by name in phasemap.models.DECLARED.  seeds/ holds the four systems of
Lapshin (2021) declared: the ladder and the wheel run from there; the elliptic and
hinge pendulums' declarations are twins of their hand-derived modules
(seeds.TWINS), with the same names.
"""
