"""Domain checks of the seed declarations, in a module without sympy.

A declaration's ``check`` defined in an importable module other than the
declaration file lets a process with a warm kernel cache load the model
without building the declaration (and importing sympy): see
:mod:`phasemap.declare.loader`.
"""

import numpy as np


def centre_of_mass_inside_the_disc(v):
    """The wheel: ValueError unless ``l`` (offset of the centre of mass) <= ``r`` (radius).

    >>> centre_of_mass_inside_the_disc({"l": 0.5, "r": 1.0})
    >>> centre_of_mass_inside_the_disc({"l": 2.0, "r": 1.0})
    Traceback (most recent call last):
    ...
    ValueError: wheel: l (offset of the centre of mass) must not exceed r (radius): got l = 2, r = 1
    """
    if np.any(np.asarray(v["l"], float) > np.asarray(v["r"], float)):
        raise ValueError("wheel: l (offset of the centre of mass) must not exceed r (radius): "
                         f"got l = {np.max(v['l']):g}, r = {np.min(v['r']):g}")
