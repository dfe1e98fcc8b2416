"""The seed systems of Lapshin (2021), declared.

The ladder and the wheel run from here (``phasemap.systems.DECLARED``); the
paper's hand derivations of them are test references (tests/references/).  The
elliptic and hinge pendulums run their hand-derived modules
(:mod:`phasemap.systems.elliptic_pendulum`, :mod:`phasemap.systems.hinge_pendulum`);
their declarations here are *twins*: the same inputs, and branches named as the
hand modules name them, so that a twin's admissibility conditions
(:func:`phasemap.declare.conditions`) serve the hand model (tests/test_declare.py
checks both, state by state).  ``checks.py`` and ``closed_forms.py`` hold what runs
without sympy: the wheel's domain check and the ladder's first integral.
"""


def citation(where: str) -> str:
    """The seed paper, cited at ``where`` (its figure and equations).

    >>> citation("Fig. 4")
    'Lapshin V.V. (2021), Herald of ... pp. 4-16, Fig. 4. doi:10.18698/1812-3368-2021-6-4-16'
    """
    return ("Lapshin V.V. (2021), Herald of the Bauman Moscow State Technical University, "
            f"Series Natural Sciences, no. 6 (99), pp. 4-16, {where}. "
            "doi:10.18698/1812-3368-2021-6-4-16")

