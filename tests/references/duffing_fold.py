"""Folds and a period doubling of forced hardening oscillators with dry and viscous
friction, computed without phasemap (scipy alone), as the references of
``continue_orbit``'s special points.

    x'' + c x' + k1 x + beta x^3 = F cos(Omega t) - r sgn x'

Their period-one orbits here never stick: each reversal of x' is a crossing, so the
flow is integrated with a fixed sign of x' and the sign flipped at each zero of x' (a
stop would raise).  A special point is a period-one orbit z = P(z) (P the time-2pi/Omega
map of the flow, from t = 0) with a Floquet multiplier +1 (a fold: det(DP - I) = 0) or -1
(a period doubling: det(DP + I) = 0), solved for (x0, x0', parameter) by scipy's
``root``, DP by central differences of P.

* FOLD: F = 0.5, r = 0.05, k1 = beta = 1, c = 0.2.  The resonance curve in Omega bends to
  the right (the spring hardens) and folds twice.
* DOUBLING: Ueda's oscillator (k1 = 0, beta = 1, c = 0.05, Omega = 1) with r = 0.01: its
  period-one orbit, followed in F, is unstable with a multiplier below -1 at F = 8 and
  regains its stability through -1 before F = 8.1, with no change of its sequence of
  reversals.  (It loses it near F = 4.838 otherwise: two reversals there merge and
  vanish, and the multiplier jumps past -1, which the differences of DP here cannot
  resolve; that is not a smooth period doubling.)  Here the root in F of det(DP + I)
  is found by Brent's method, each orbit by ``root``.

``python tests/references/duffing_fold.py`` recomputes the values below (a few
minutes); the steps of the differences 1e-5 and 1e-6 agree to 4e-12 in Omega at the
folds and to 5e-9 in F at the period doubling.
"""

from __future__ import annotations

import numpy as np

FOLD = {"F": 0.5, "r": 0.05, "k1": 1.0, "beta": 1.0, "c": 0.2}
#: Omega at the upper fold (the stable large orbit turns back, unstable) and at the
#: lower one (the unstable orbit turns into the stable small one).
OMEGA_UPPER = 1.5726928315498
OMEGA_LOWER = 1.40642806574375

DOUBLING = {"Omega": 1.0, "r": 0.01, "k1": 0.0, "beta": 1.0, "c": 0.05}
#: F where the period-one orbit's multiplier passes -1 (coming back from below -1: the
#: orbit is unstable below it, stable above it to F = 8.11245, where its velocity grazes
#: zero and a stop appears; the return map below, whose steps are not capped, would miss
#: a velocity that crosses zero and back inside one step).
F_DOUBLING = 8.0115330045


def return_map(z, F, Omega, r, k1, beta, c):
    return flow(z, 0.0, 2 * np.pi / Omega, F, Omega, r, k1, beta, c)[0]


def flow(z, t0, t1, F, Omega, r, k1, beta, c):
    """``(state at t1, reversals)`` of the flow from ``z`` at ``t0`` (x' = 0 at the
    start: the sign it takes first is +)."""
    from scipy.integrate import solve_ivp

    n = 0
    t, y = t0, np.array(z, float)
    s = np.sign(y[1]) or 1.0
    while True:
        def f(tt, yy, s=s):
            return [yy[1], -c * yy[1] - k1 * yy[0] - beta * yy[0] ** 3
                    + F * np.cos(Omega * tt) - r * s]

        def reversal(tt, yy):
            return yy[1]

        reversal.terminal, reversal.direction = True, -s
        sol = solve_ivp(f, (t, t1), y, rtol=1e-12, atol=1e-13, events=reversal,
                        method="DOP853")
        if sol.status != 1:
            return sol.y[:, -1], n
        t, y = sol.t_events[0][0], sol.y_events[0][0].copy()
        y[1] = 0.0
        if abs(-k1 * y[0] - beta * y[0] ** 3 + F * np.cos(Omega * t)) <= r:
            raise RuntimeError("the orbit sticks: not a pure-slip orbit")
        s, n = -s, n + 1


def derivative(z, h=1e-6, **par):
    """DP at ``z``, by central differences."""
    return np.column_stack([(return_map(z + e, **par) - return_map(z - e, **par)) / (2 * h)
                            for e in np.eye(2) * h])


def doubling(lo, hi, z0, h=1e-6, **par):
    """F in (lo, hi) where a multiplier of the orbit near ``z0`` is -1."""
    from scipy.optimize import brentq, root

    z = [np.array(z0, float)]

    def g(F):
        at = {**par, "F": F}
        z[0] = root(lambda zz: return_map(zz, **at) - zz, z[0], tol=1e-13).x
        return np.linalg.det(derivative(z[0], h, **at) + np.eye(2))

    return brentq(g, lo, hi, xtol=1e-14)


def special(guess, free, sign, h=1e-6, **par):
    """``(x0, x0', <free>)`` where the orbit has the multiplier ``sign`` (+1 a fold, -1 a
    period doubling), from ``guess``."""
    from scipy.optimize import root

    def eqs(X):
        at = {**par, free: X[2]}
        D = derivative(X[:2], h, **at)
        return np.concatenate([return_map(X[:2], **at) - X[:2],
                               [np.linalg.det(D - sign * np.eye(2))]])

    return root(eqs, guess, tol=1e-15).x


if __name__ == "__main__":
    for h in (1e-5, 1e-6):
        print(h, special([-0.144, 1.981, 1.5727], "Omega", 1, h, **FOLD),
              special([-0.6016, 0.5494, 1.4064], "Omega", 1, h, **FOLD),
              doubling(8.0, 8.1, [2.37959359, -0.31001823], h, **DOUBLING))
