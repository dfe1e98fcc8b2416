"""The geometry of a branch followed by pseudo-arclength
(:mod:`phasemap.motion.periodic.continuation`): unit chords in the branch's metric, the
predictor's parabola, and the test functions of the multipliers' bifurcations."""

from __future__ import annotations

import math

import numpy as np


def parabola(Xz, Xa, Xb, ds, D):
    """The point ``ds`` beyond ``Xb`` along the parabola through ``Xz``, ``Xa``, ``Xb``,
    each placed at its chordal distance in the metric ``D``."""
    sz = -math.sqrt(float((Xa - Xz) * D @ (Xa - Xz)))
    sb = math.sqrt(float((Xb - Xa) * D @ (Xb - Xa)))
    s = sb + ds
    if not (sz < 0.0 < sb):
        return Xb + ds * unit(Xb - Xa, D)[0]
    return (Xz * (s * (s - sb)) / (sz * (sz - sb)) + Xa * ((s - sz) * (s - sb)) / (sz * sb)
            + Xb * ((s - sz) * s) / ((sb - sz) * sb))


def unit(d, D):
    """The chord ``d`` as a unit vector in the metric ``D``, and its length."""
    L = math.sqrt(float(d * D @ d))
    return d / L, L


def doubling_test(mult) -> float:
    """The period doubling's test function, the product of ``1 + m`` over the nontrivial
    multipliers (det(I + M) on them): real, continuous, and of another sign exactly where
    a real multiplier has passed -1 (a complex pair adds |1 + m|^2 > 0)."""
    return float(np.real(np.prod(1.0 + np.asarray(mult, dtype=complex))))


def torus_test(mult) -> float:
    """The torus (Neimark-Sacker) point's test function, the product of ``m_i m_j - 1``
    over the pairs of nontrivial multipliers: of another sign where a complex pair has
    passed the unit circle (|m|^2 - 1), and also where two real ones pass m_i m_j = 1 (a
    neutral saddle, not a bifurcation: :meth:`continuation._Context.doubling`
    checks the point)."""
    m = np.asarray(mult, dtype=complex)
    pairs = [m[i] * m[j] - 1.0 for i in range(m.size) for j in range(i + 1, m.size)]
    return float(np.real(np.prod(pairs))) if pairs else 1.0
