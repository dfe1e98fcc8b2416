"""The seed systems' thresholds, exactly, beside their closed forms: the studies'
claims and the tests' cases.

Each case is a :func:`phasemap.threshold` call with the closed form it must
reproduce (derived in the case's note, independently of the tracer), the point's
closed form where it has one, and the kind of point it is.  A study states them
with ``claims += threshold_claims("ladder")``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from phasemap.facts import elliptic_threshold, wheel_singular_delta

P = math.pi


@dataclass(frozen=True)
class Case:
    """A threshold and its closed form: ``threshold(**call)`` must give ``value``
    (and ``at``), a point of kind ``kind``."""

    study: str
    what: str
    closed: str
    call: dict
    value: float
    kind: str
    at: dict = field(default_factory=dict)


CASES = (
    # lambda_k = (3 - cos 2 phi - k f sin 2 phi)/2 has least value (3 - sqrt(1 + f^2))/2
    Case("elliptic_pendulum", "no solution (xdot > 0) first exists", "f = 2 sqrt 2, 2 phi = arctan f",
         dict(model="elliptic_pendulum", param="f", value=0,
              over={"phi": (0.0, P / 2), "f": (0.0, 6.0)}, fixed={"xdot": 1.0, "omega": 0.0}),
         elliptic_threshold(), "fold_f", {"phi": 0.5 * math.atan(elliptic_threshold())}),
    # the kept slide's coefficient of phi'' in (8) is proportional to 2 - f^2
    Case("ladder", "slide coefficient vanishes", "f = sqrt 2",
         dict(model="ladder", param="f", layer="singular", value=1, over={"f": (0.0, 3.0)},
              fixed={"phi": 0.7, "omega": 1.0}), math.sqrt(2.0), "root"),
    # rest needs tan(phi/2) <= f
    Case("ladder", "static zone (omega = 0, f = 0.5) ends", "phi = 2 arctan f",
         dict(model="ladder", param="phi", layer="stagnation", value=1, side="max",
              over={"phi": (0.0, P / 2)}, fixed={"omega": 0.0, "f": 0.5}),
         2.0 * math.atan(0.5), "root"),
    # the turning coefficient (33) vanishes where the friction arm delta reaches l
    Case("hinge_pendulum", "turning coefficient vanishes", "delta = l",
         dict(model="hinge_pendulum", param="delta", layer="singular", value=1,
              over={"delta": (0.0, 1.5)}, fixed={"phi": 0.5, "omega": 1.0, "l": 1.0}),
         1.0, "root"),
    # at rest the hinge's moment delta |N| holds the weight's moment while l |sin phi| <= delta
    Case("hinge_pendulum", "stagnation zone (omega = 0, delta = 0.5) ends", "l |sin phi| = delta",
         dict(model="hinge_pendulum", param="phi", layer="stagnation", value=1, side="max",
              over={"phi": (0.0, P / 2)}, fixed={"omega": 0.0, "delta": 0.5, "l": 1.0}),
         math.asin(0.5), "root"),
    # the bracket of (13) has least value rho^2 + r^2 + l^2 - l sqrt(4 r^2 + delta^2)
    Case("wheel", "singular bracket first vanishes", "delta = sqrt((rho^2+r^2+l^2)^2 - 4r^2l^2)/l",
         dict(model="wheel", param="delta", layer="singular", value=1,
              over={"phi": (-P, P), "delta": (0.0, 3.0)},
              fixed={"omega": 1.0, "r": 1.0, "l": 0.5, "rho": 0.5}),
         wheel_singular_delta(1.0, 0.5, 0.5), "fold_delta"),
    # 1 + 3 cos^2 - 3 f sin cos = 0: f(theta) least at tan theta = 2
    Case("painleve_rod", "first paradox (xdot < 0)", "f = 4/3 at theta = arctan 2",
         dict(model="painleve_rod", param="f", value=0,
              over={"theta": (0.1, 1.5), "f": (0.0, 3.0)}, fixed={"xdot": -1.0, "omega": 0.0}),
         4.0 / 3.0, "fold_f", {"theta": math.atan(2.0)}),
)


def threshold_claims(study: str) -> list:
    """The claims of ``study`` (a model name): each exact threshold of :data:`CASES`
    beside its closed form and the difference, agreeing within 1e-10."""
    from phasemap.study import Claim, verdict
    from phasemap.bifurcation.search import threshold

    claims = []
    for case in CASES:
        if case.study != study:
            continue
        t = threshold(**case.call)
        diff = math.inf if t is None else t.value - case.value
        at = "" if t is None else ", ".join(f"{k} = {v:.12g}" for k, v in t.at.items()
                                           if k != t.param)
        claims.append(Claim(
            f"{study}: {case.what} (phasemap.threshold)", case.closed,
            "none found" if t is None else
            f"{t.param} = {t.value:.13g}{' at ' + at if at else ''} ({t.kind} of "
            f"{t.condition}); closed form {case.value:.13g}, difference {diff:.1e}",
            verdict(abs(diff) <= 1e-10)))
    return claims
