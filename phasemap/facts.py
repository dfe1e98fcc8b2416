"""The numbers the documentation states, computed: a test checks each one is in the
README or the user guide (``docs/guide/``).

Each entry of :func:`readme_facts` is a piece of README text built from the
code that decides it (a closed form, a constant the library uses), so a
README number can only change together with the code, and a wrong one fails
``tests/test_readme_claims.py::test_readme_numbers_come_from_code``.
"""

from __future__ import annotations

import math


def wheel_singular_delta(r: float, l: float, rho: float) -> float:
    """The least rolling friction delta at which the wheel's bracket of (13) can vanish.

    B = rho^2 + r^2 + l^2 - 2 r l cos phi + delta sigma l sin phi has minimum
    rho^2 + r^2 + l^2 - l sqrt(4 r^2 + delta^2) over phi, so a singular state
    exists iff delta >= sqrt((rho^2 + r^2 + l^2)^2 - 4 r^2 l^2) / l.
    """
    total = rho * rho + r * r + l * l
    return math.sqrt(total * total - 4.0 * r * r * l * l) / l


def elliptic_threshold() -> float:
    """The sharp friction threshold of the elliptic pendulum's paradoxes: 2 sqrt 2.

    lambda_k = (3 - cos 2 phi - k f sin 2 phi)/2 has minimum (3 - sqrt(1 + f^2))/2.
    """
    return math.sqrt(3.0 ** 2 - 1.0)


def readme_facts() -> dict[str, str]:
    """README text, by what it states, as the code computes it."""
    from phasemap.core.numerics import TOL
    from phasemap.atlas.dataset import CONVENTIONS
    from phasemap.maps.blocks import YES_CELLS
    from phasemap.core.cache import DEFAULT_MAX_MB
    from phasemap.core.model import MAX_MAGNITUDE, MIN_POSITIVE
    from phasemap.maps.scene import MAX_SPEC_CELLS

    return {
        "wheel singular threshold at r = 1, l = rho = 0.5":
            f"({wheel_singular_delta(1.0, 0.5, 0.5):.3f} m for r = 1,\n  l = ρ = 0.5)",
        "elliptic sharp threshold": f"2√2 ≈ {elliptic_threshold():.3f}",
        "tie tolerance": f"within a tolerance of {TOL:g}",
        "largest value": f"magnitude of at most {MAX_MAGNITUDE:g}",
        "smallest positive scale": f"must be at least {MIN_POSITIVE:g}",
        "CF version": f"declare **{CONVENTIONS}**",
        "--yes threshold": f"above 10^{round(math.log10(YES_CELLS))} cells",
        "kernel cache bound": f"{DEFAULT_MAX_MB} MB by default",
        "largest scene spec read from a file":
            f"at most 10^{round(math.log10(MAX_SPEC_CELLS))} cells",
    }
