"""Declared built-in systems: each module defines SYSTEM (see phasemap.declare).

Registered by name in phasemap.models.DECLARED; seeds/ holds the four systems of
Lapshin (2021) declared, as independent checks of the hand-derived modules.
"""
