"""The seed systems of Lapshin (2021), declared.

The ladder and the wheel run from here (``phasemap.models.DECLARED``).  The
elliptic and hinge pendulums run their hand-derived modules
(:mod:`phasemap.models`); their declarations here are *twins*: the same inputs,
and branches named as the hand modules name them, so that a twin's
admissibility conditions (:func:`phasemap.declare.conditions`) serve the hand
model (tests/test_declare.py checks both, state by state).
"""

#: hand-written model name -> the module of its declared twin
TWINS = {"elliptic_pendulum": "phasemap.systems.seeds.elliptic_pendulum",
         "hinge_pendulum": "phasemap.systems.seeds.hinge_pendulum"}
