"""Friction oscillators: periodic orbits and their continuation, error against CPU time.

* **The belt's stick-slip orbit** (m = k = g = 1, f_s = 1, f_k = 0.5, v = 0.2) from
  :func:`phasemap.periodic_orbit`: settled from x = 0, x' = v, and from a period guess
  (no settling), against the closed form T = 2 delta / v + pi + 2 arctan(v / delta); beside
  the same orbit computed with ``solve_ivp`` and ``scipy.optimize.root`` by hand (the slip
  integrated to the event x' = v, the stick in closed form: what the orbit is once its
  mode sequence is known).
* **Den Hartog's non-stop orbit** (Omega = 0.8, r = 0.2) against the closed-form
  amplitude X0 = sqrt(V^2 - r^2 U^2).
* **Branches of 200 points:** the belt's orbit in the belt speed from v = 0.2, Den
  Hartog's in the friction from r = 0.2 (each point against its closed form), and the
  belt's 200 orbits by hand with ``solve_ivp`` and ``root``.
* **A continuation** of Den Hartog's orbit in the friction from 0.78 to 0.83 in two steps,
  through its crossing-sliding point (r* = 0.8174063857108825, from the closed form of the
  slip: tests/test_periodic.py).
* **Round a fold:** ``duffing``'s large orbit from Omega = 1.55, over the fold of its
  resonance curve and back to 1.55 on the unstable orbit; and **a period doubling** of
  Ueda's oscillator (``duffing`` with k = 0) in F0 (references: tests/references/
  duffing_fold.py).

CPU time (``time.process_time``) of the public call, medians.  Writes the section
"Friction oscillators" of ../BENCHMARKS.md.

    python benchmarks/oscillators.py [--repeat 3] [--no-write]
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

import _report
import phasemap

T_BELT = 1.0 / 0.2 + math.pi + 2 * math.atan(0.2 / 0.5)
R_STAR = 0.8174063857108825
#: tests/references/duffing_fold.py (scipy alone)
OMEGA_FOLD = 1.5726928315498
F0_DOUBLING = 8.0115330045


def cpu(fn, repeat):
    out, secs = None, []
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        secs.append(time.process_time() - t0)
    return statistics.median(secs), out


def by_hand(v=0.2, guess=3.9):
    """The belt's orbit with solve_ivp and scipy.optimize.root: the slip from the stick's
    end (x = 1, x' = v) until x' = v again, its duration found by root on the dense
    output; the stick back to x = 1 at the belt's speed.  ``(period, slip's duration)``
    with ``guess`` the slip's duration to start root from."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import root

    sol = solve_ivp(lambda t, z: [z[1], -z[0] + 0.5], (0.0, 10.0), [1.0, v], rtol=1e-12,
                    atol=1e-12, dense_output=True, method="DOP853")
    tau = root(lambda s: sol.sol(s[0])[1] - v, [guess], tol=1e-14).x[0]
    x_end = sol.sol(tau)[0]
    return tau + (1.0 - x_end) / v, tau


def belt_period(v, delta=0.5):
    """The belt orbit's closed-form period."""
    return 2 * delta / v + math.pi + 2 * math.atan(v / delta)


def den_hartog_amplitude(r, omega=0.8):
    """Den Hartog's non-stop orbit's closed-form amplitude."""
    V = 1 / (1 - omega**2)
    U = math.sin(math.pi / omega) / (omega * (1 + math.cos(math.pi / omega)))
    return math.sqrt(V**2 - r**2 * U**2)


def by_hand_branch(vs):
    """The belt's orbits at the values ``vs`` by hand (:func:`by_hand`, each from the last
    one's slip duration): what a branch of them costs with scipy, once the sequence is
    known, no stability and no checks."""
    guess, out = 3.9, []
    for v in vs:
        T, guess = by_hand(v, guess)
        out.append(T)
    return np.array(out)


def main() -> None:
    ap = _report.parser(__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    r = args.repeat
    from phasemap.core import tiers

    with tiers.forced("eager"):     # machine code before the clock starts, never the twins
        phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2})
    rows = ["| computation | CPU time | result | error |", "|---|---:|---:|---:|"]
    sec, o = cpu(lambda: phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2}), r)
    belt = sec
    rows.append(f"| belt orbit, settled (`periodic_orbit`) | {sec * 1e3:.0f} ms | "
                f"T = {float(o.period):.12f} | {abs(float(o.period) - T_BELT):.1e} |")
    sec, o = cpu(lambda: phasemap.periodic_orbit("belt", start={"x": 0.0, "xdot": 0.2},
                                                 period=9.0), r)
    rows.append(f"| belt orbit, from a period guess | {sec * 1e3:.0f} ms | "
                f"T = {float(o.period):.12f} | {abs(float(o.period) - T_BELT):.1e} |")
    sec, T = cpu(lambda: by_hand()[0], r)
    rows.append(f"| belt orbit by hand (`solve_ivp` + `root`, sequence known) | "
                f"{sec * 1e3:.1f} ms | T = {T:.12f} | {abs(T - T_BELT):.1e} |")
    V = 1 / (1 - 0.8**2)
    U = math.sin(math.pi / 0.8) / (0.8 * (1 + math.cos(math.pi / 0.8)))
    X0 = math.sqrt(V**2 - 0.2**2 * U**2)
    sec, o = cpu(lambda: phasemap.periodic_orbit("den_hartog", start={"f": 0.2}), r)
    turns = o.event_x.values[o.event_kind.values == phasemap.Event.REVERSAL]
    rows.append(f"| Den Hartog orbit (`periodic_orbit`, settled from rest) | "
                f"{sec * 1e3:.0f} ms | X0 = {float(np.max(turns)):.12f} | "
                f"{abs(float(np.max(turns)) - X0):.1e} |")
    start = phasemap.periodic_orbit("den_hartog", start={"f": 0.78})
    sec, b = cpu(lambda: phasemap.continue_orbit(start, "f", (0.78, 0.83), steps=2), 1)
    at = float(b.point_f[0])
    rows.append(f"| Den Hartog continued in f, 0.78 to 0.83, 2 steps (`continue_orbit`) | "
                f"{sec:.1f} s | {b.point_kind.values[0]} at f = {at:.12f} | "
                f"{abs(at - R_STAR):.1e} |")
    fold = phasemap.periodic_orbit("duffing", start={"Omega": 1.55, "x": 0.19, "xdot": 1.96})
    sec, b = cpu(lambda: phasemap.continue_orbit(fold, "Omega", (1.55, 1.6), steps=2), 1)
    per_point = sec / b.sizes["vertex"]
    at = float(b.point_Omega[0])
    rows.append(f"| `duffing` continued in Omega, 1.55 to 1.6 and back round the fold "
                f"({b.sizes['vertex']} points) | {sec:.1f} s | {b.point_kind.values[0]} at "
                f"Omega = {at:.12f} | {abs(at - OMEGA_FOLD):.1e} |")
    # branches of 200 points (each with its stability and its checks), from the orbits at
    # the start of a span they do not reach the end of
    belt_orbit = phasemap.periodic_orbit("belt")
    phasemap.continue_orbit(belt_orbit, "v", (0.2, 0.6), steps=20)
    sec, b = cpu(lambda: phasemap.continue_orbit(belt_orbit, "v", (0.2, 0.6), steps=1000,
                                                 max_points=200), r)
    branch200 = {"belt": (sec, b.sizes["vertex"])}
    err = max(abs(float(T) - belt_period(float(v))) for v, T in zip(b.v.values, b.period.values))
    rows.append(f"| belt continued in v from 0.2, {b.sizes['vertex']} points "
                f"(`continue_orbit`, `max_points=200`) | {sec:.2f} s | v = "
                f"{float(b.v[-1]):.4f} at the end | {err:.1e} (T, the worst point) |")
    vs = b.v.values
    sec, Ts = cpu(lambda: by_hand_branch(vs), r)
    err = max(abs(T - belt_period(float(v))) for v, T in zip(vs, Ts))
    rows.append(f"| the same {vs.size} belt orbits by hand (`solve_ivp` + `root`, sequence "
                f"known; no stability, no checks) | {sec:.2f} s | | {err:.1e} |")
    dh_orbit = phasemap.periodic_orbit("den_hartog", start={"f": 0.2})
    sec, b = cpu(lambda: phasemap.continue_orbit(dh_orbit, "f", (0.2, 0.6), steps=1000,
                                                 max_points=200), r)
    branch200["den_hartog"] = (sec, b.sizes["vertex"])
    err = max(abs(float(a) - den_hartog_amplitude(float(f)))
              for f, a in zip(b.f.values, b.amplitude_x.values))
    rows.append(f"| Den Hartog continued in f from 0.2, {b.sizes['vertex']} points | "
                f"{sec:.2f} s | f = {float(b.f[-1]):.4f} at the end | {err:.1e} (X0, the "
                "worst point) |")
    ueda = {"k": 0.0, "c": 0.05, "f": 0.01, "Omega": 1.0, "F0": 8.0}
    pd = phasemap.periodic_orbit("duffing", start={**ueda, "x": 2.37959359,
                                                   "xdot": -0.31001823}, period=2 * math.pi)
    sec, b = cpu(lambda: phasemap.continue_orbit(pd, "F0", (8.0, 8.05), steps=2), 1)
    at = float(b.point_F0[0])
    rows.append(f"| `duffing` with k = 0 (Ueda) continued in F0, 8 to 8.05 | {sec:.1f} s | "
                f"{b.point_kind.values[0]} at F0 = {at:.12f} | {abs(at - F0_DOUBLING):.1e} |")
    lines = ["## Friction oscillators (`benchmarks/oscillators.py`)", "",
             f"Machine: {_report.machine()}; load {_report.load()}.  ",
             f"Command: `python benchmarks/oscillators.py --repeat {r}`", "",
             f"CPU time of the public call on one thread (an orbit's computation is "
             f"serial), medians of {r} runs (the short continuations: one run each). The fold "
             "and "
             "the period doubling are checked against scipy's own "
             "(tests/references/duffing_fold.py: 5e-9 between its two steps of "
             "differences at the period doubling).", "", *rows, "",
             "The orbits run on the full-coordinate motion, on the compiled flow "
             "(phasemap.motion.hybrid.flow): the settling motion, the shooting segments, "
             "each segment's variational equations with its transition matrix "
             "(`flow.transition`, one call a segment), the samples of the orbit and of a "
             "continuation's checks (the flow's dense output) and the Dataset's reactions "
             "(`flow.reactions`), and at each event of the settling motion its scales, "
             "candidate modes and admissible phases (`flow.survey`, one call an event), "
             "and the projections onto the contacts (`flow.project`; NumPy's `lstsq` "
             "until 2026-12-02, a quarter of an orbit diagram's time). What is left in "
             "Python is the rest of those decisions: the ties between phases, the saltation "
             "matrices' differences, the events' records, and numba's dispatch of each call "
             "(the declaration's functions reach the kernels as addresses: typed as "
             "first-class functions, until 2026-12-02, they took a tenth).", "",
             "| target (issue 39) | measured | verdict |", "|---|---:|---|",
             f"| a belt orbit to 1e-10 within 10 ms | {belt * 1e3:.1f} ms | "
             f"{'met' if belt <= 0.010 else '**missed**'} |",
             *[f"| a continuation of 200 points within 1 s ({name}) | "
               f"{sec_n / n_n * 200:.2f} s ({sec_n / n_n * 1e3:.1f} ms a point) | "
               f"{'met' if sec_n / n_n * 200 <= 1.0 else '**missed**'} |"
               for name, (sec_n, n_n) in branch200.items()],
             f"| (round the fold, with its location) | {200 * per_point:.1f} s "
             f"({per_point * 1e3:.0f} ms a point) | - |", "",
             "A point of a branch: its corrector (Newton's method on the shooting equations "
             "with a chord Jacobian kept along the branch and updated by Broyden's rule "
             "after every step, from a prediction along the parabola through the last "
             "three points, since 2026-12-02: about two steps a point where the chord alone "
             "from the secant took four or five), its checks (each segment integrated once with its "
             "dense output kept, `flow.steps_of`, for its end, its samples and every search "
             "between them, and its conditions in one call, `flow.watch_many`; until "
             "2026-12-02 every sample and every step of a search integrated the segment "
             "again), its Floquet multipliers (the variational equations of the directions "
             "along the contacts alone, two solves a direction and stage, not the whole "
             "transition matrix with two a coordinate) and one period of the motion itself "
             "(its mode sequence). Before 2026-12-02 the same 200-point branches took "
             "1.55-1.64 s (belt) and 1.62-1.78 s (Den Hartog), this script run on the tree at "
             "e8cbe03 (`PYTHONPATH=<checkout of e8cbe03> python benchmarks/oscillators.py "
             "--no-write`) alternating with the tree at 994e7c3, which took 0.74-0.76 s and "
             "0.88-0.92 s in the same minutes; the flow's kernels have run without numba's "
             "reference counts since (`flow.ALLOCATING`), about 0.2 s less each. A fold's or a period doubling's branch adds their location. The "
             "hand-written belt orbits know the mode sequence and integrate one segment "
             "each, without stability or checks: the floor a compiled hybrid flow would "
             "start from."]
    _report.publish(lines, "## Friction oscillators", write=not args.no_write)


if __name__ == "__main__":
    main()
