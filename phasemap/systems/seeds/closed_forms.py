"""The seed systems' closed forms that run, in a module without sympy.

The ladder's first integral on a sliding stage (Lapshin 2021, after eq. (8), with
the errata of tests/references/ladder.py corrected): what the work-precision
problems and the phase-curve tests measure the ladder's motion against.
tests/test_closed_forms.py checks it against a tight integration of the
independently derived equations (tests/reference.py).
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, error_model="numpy")
def ladder_first_integral(s, f, l, g):
    """(lam, a, b) of the ladder's omega^2 = c e^{lam phi} + a sin phi + b cos phi.

    On a sliding stage of sign ``s`` (the sign of omega), for f != sqrt 2:
    lam = 6 s f / (2 - f^2), a = -6 s f g (5 - 4 f^2) / (l q),
    b = -3 g (2 - 15 f^2 + f^4) / (l q), q = 4 + 32 f^2 + f^4.

    >>> lam, a, b = ladder_first_integral(1.0, 0.0, 1.0, 9.81)
    >>> lam, a, round(b, 6)
    (0.0, -0.0, -14.715)
    """
    d = 2.0 - f * f
    q = 4.0 + 32.0 * f * f + f ** 4
    lam = 6.0 * s * f / d
    a = -6.0 * s * f * g * (5.0 - 4.0 * f * f) / (l * q)
    b = -3.0 * g * (2.0 - 15.0 * f * f + f ** 4) / (l * q)
    return lam, a, b


@njit(cache=True, error_model="numpy")
def ladder_omega_squared(phi, phi0, omega0, f, l, g):
    """The ladder's omega^2(phi) on the sliding stage through (phi0, omega0), omega0 != 0.

    The constant is carried as (omega0^2 - a sin phi0 - b cos phi0) e^{lam (phi - phi0)},
    which never forms e^{lam phi} or e^{-lam phi0} on their own.

    >>> round(ladder_omega_squared(0.5, 0.5, 2.0, 0.3, 1.0, 9.81), 12)
    4.0
    """
    s = 1.0 if omega0 > 0.0 else -1.0
    lam, a, b = ladder_first_integral(s, f, l, g)
    c0 = omega0 * omega0 - a * math.sin(phi0) - b * math.cos(phi0)
    return c0 * math.exp(lam * (phi - phi0)) + a * math.sin(phi) + b * math.cos(phi)
