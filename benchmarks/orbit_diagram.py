"""Orbit diagrams by simulation: what a sweep costs, against the same sweep on solve_ivp.

Den Hartog's oscillator x'' + x = cos(0.8 t) - f sgn x' at ``VALUES`` values of f in
[0.15, 0.35] (non-stop orbits: each reversal a crossing), each value's motion settled for
100 forcing periods and its stroboscopic points kept for 200 more:

* :func:`phasemap.orbit_diagram`, eager in this process (CPU time), and chunked with dask
  on two worker processes (wall time; the workers' imports and kernel loads included);
* the same motion on ``solve_ivp`` (DOP853, the sign of x' flipped at each reversal
  located by its event: tests/references/duffing_fold.py's return map, which cannot
  stick), on ``SCIPY_VALUES`` of the values, per value;

the error of each: the largest distance of a value's kept points from the fixed point of
the return map there (solved by ``scipy.optimize.root`` at rtol 1e-12).  The issue's
target, 1000 values x 200 forcing periods in 5 s on two threads, is extrapolated from the
cost per forcing period.  Writes the section "Orbit diagrams" of ../BENCHMARKS.md.

    python benchmarks/orbit_diagram.py [--no-write]
"""

from __future__ import annotations

import pathlib
import sys
import time

import numpy as np

import _report
import phasemap

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from references import duffing_fold as ref  # noqa: E402

VALUES = 40
SCIPY_VALUES = 4
SETTLE, PERIODS = 100, 200
RTOL = 1e-8
AT = {"F": 1.0, "Omega": 0.8, "k1": 1.0, "beta": 0.0, "c": 0.0}


def scipy_strobe(f, rtol=RTOL):
    """The kept points of one value's motion from rest on solve_ivp."""
    from scipy.integrate import solve_ivp

    T = 2 * np.pi / AT["Omega"]
    z, out = np.zeros(2), []
    s = 1.0                       # from rest the forcing (1 > f) starts a positive slip
    t = 0.0
    for k in range(1, SETTLE + PERIODS + 1):
        while True:
            def rhs(tt, yy, s=s):
                return [yy[1], -yy[0] + np.cos(AT["Omega"] * tt) - f * s]

            def reversal(tt, yy):
                return yy[1]

            reversal.terminal, reversal.direction = True, -s
            sol = solve_ivp(rhs, (t, k * T), z, rtol=rtol, atol=rtol * 1e-2,
                            events=reversal, method="DOP853")
            if sol.status != 1:
                t, z = k * T, sol.y[:, -1]
                break
            t, z = sol.t_events[0][0], sol.y_events[0][0].copy()
            z[1] = 0.0
            if abs(-z[0] + np.cos(AT["Omega"] * t)) <= f:
                raise RuntimeError(f"f = {f:g}: the motion sticks at t = {t:g}, which "
                                   "this sign-flipping reference does not follow")
            s = -s
        if k > SETTLE:
            out.append(z.copy())
    return np.array(out)


def fixed_point(f, z0):
    from scipy.optimize import root

    return root(lambda z: ref.return_map(z, r=f, **AT) - z, z0, tol=1e-13).x


def compiled_share(values, periods=50, settle=50):
    """CPU seconds per forcing period spent inside the compiled flow's calls (the steps,
    the events' location, the surveys and the projections: every function of
    phasemap/motion/hybrid/flow.py that cProfile sees called from Python), and in the
    whole sweep, over a short sweep of ``values`` under cProfile (which slows the Python
    around the calls, not the machine code inside them)."""
    import cProfile
    import pstats

    prof = cProfile.Profile()
    prof.enable()
    phasemap.orbit_diagram("den_hartog", "f", values, periods=periods, settle=settle,
                           rtol=RTOL)
    prof.disable()
    stats = pstats.Stats(prof).stats
    inside = sum(row[2] for (path, _, _), row in stats.items()
                 if path.replace("\\", "/").endswith("motion/hybrid/flow.py"))
    return inside / (len(values) * (periods + settle))


def main() -> None:
    ap = _report.parser(__doc__)
    args = ap.parse_args()
    import dask

    values = np.linspace(0.15, 0.35, VALUES)
    from phasemap.core import tiers

    with tiers.forced("eager"):     # machine code before the clock starts, never the twins
        phasemap.orbit_diagram("den_hartog", "f", values[:2], periods=2, settle=2)
    t0 = time.process_time()
    d = phasemap.orbit_diagram("den_hartog", "f", values, periods=PERIODS, settle=SETTLE,
                               rtol=RTOL)
    eager = time.process_time() - t0
    t0 = time.process_time()
    scene = phasemap.Scene("den_hartog", axes={"f": values},
                           layers=["section_x", "section_xdot", "multiple"],
                           options={"periods": PERIODS, "settle": SETTLE,
                                    "rtol": RTOL}).compute()
    as_scene = time.process_time() - t0
    scene_same = (np.array_equal(scene.section_x.values, d.x.values, equal_nan=True)
                  and np.array_equal(scene.section_xdot.values, d.xdot.values, equal_nan=True)
                  and np.array_equal(scene.multiple.values, d.multiple.values))
    lazy = phasemap.orbit_diagram("den_hartog", "f", values, periods=PERIODS, settle=SETTLE,
                                  rtol=RTOL, chunks=VALUES // 2)
    t0 = time.perf_counter()
    with dask.config.set(scheduler="processes", num_workers=2):
        lazy = lazy.compute()
    wall = time.perf_counter() - t0
    same = all(np.array_equal(lazy[n].values, d[n].values, equal_nan=True)
               for n in ("x", "xdot", "fate", "multiple"))
    kernels = compiled_share(values[::VALUES // 4])
    checked = np.linspace(0, VALUES - 1, SCIPY_VALUES).astype(int)
    err_pm, err_sp, scipy_cpu = 0.0, 0.0, 0.0
    for j in checked:
        f = float(values[j])
        z = fixed_point(f, [float(d.x[j, -1]), float(d.xdot[j, -1])])
        pts = np.column_stack([d.x.values[j], d.xdot.values[j]])
        err_pm = max(err_pm, float(np.abs(pts - z).max()))
        t0 = time.process_time()
        sp = scipy_strobe(f)
        scipy_cpu += time.process_time() - t0
        err_sp = max(err_sp, float(np.abs(sp - z).max()))
    per_value_sp = scipy_cpu / SCIPY_VALUES
    periods = SETTLE + PERIODS
    per_period = eager / (VALUES * periods)
    target = 1000 * periods
    rows = ["| sweep | time | per forcing period | error | 1000 values x 300 periods |",
            "|---|---:|---:|---:|---:|",
            f"| `orbit_diagram`, eager, one process | {eager:.1f} s CPU | "
            f"{per_period * 1e3:.2f} ms | {err_pm:.1e} | {per_period * target / 60:.0f} min "
            "CPU |",
            f"| `Scene(..., layers=['section_x', 'section_xdot', 'multiple'])`, eager | "
            f"{as_scene:.1f} s CPU | {as_scene / (VALUES * periods) * 1e3:.2f} ms | same bits: "
            f"{scene_same} | {as_scene / (VALUES * periods) * target / 60:.0f} min CPU |",
            f"| `orbit_diagram`, `chunks={VALUES // 2}`, dask on 2 processes | {wall:.1f} s "
            f"wall | {wall / (VALUES * periods) * 1e3:.2f} ms wall | same bits: {same} | "
            f"{wall / VALUES * 1000 / 60:.0f} min wall |",
            f"| `solve_ivp` by hand ({SCIPY_VALUES} of the values) | "
            f"{per_value_sp:.2f} s CPU per value | {per_value_sp / periods * 1e3:.2f} ms | "
            f"{err_sp:.1e} | {per_value_sp * 1000 / 60:.0f} min CPU |"]
    per_period_target = 2 * 5.0 / (1000 * 200)
    lines = ["## Orbit diagrams (`benchmarks/orbit_diagram.py`)", "",
             f"Machine: {_report.machine()}; load {_report.load()}. Den Hartog's oscillator "
             f"(Omega = 0.8), {VALUES} values of f in [0.15, 0.35], each settled for {SETTLE} "
             f"forcing periods and kept for {PERIODS}, rtol {RTOL:g}; the error is the "
             "largest distance of a value's kept points from the fixed point of the return "
             f"map (scipy alone), over {SCIPY_VALUES} values. CPU time is one thread's "
             "(the public call in this process; scipy's the same); the dask row is wall "
             "time on two worker processes. Reproduce: `python benchmarks/orbit_diagram.py`.",
             "", *rows, "",
             "The issue's target, an orbit diagram of 1000 values x 200 forcing periods in "
             "5 s on two threads, is not met: each value's motion is stepped by the "
             "compiled flow and at every reversal the scales, the candidate modes and the "
             "admissible phases are found in one compiled call (`flow.survey`) and the "
             "state is projected onto its contacts in another (`flow.project`), but the "
             "rest of each decision (the ties, the events' records) runs "
             "in Python, two per forcing period here. "
             + ("Compiling the decisions would not be enough: " if kernels > per_period_target
                else "Compiling the decisions is what is left: ")
             + "the compiled calls alone (the steps, the events' location, the "
             "surveys and the projections) take "
             f"{kernels * 1e3:.2f} ms a forcing period here (cProfile over 4 values x "
             f"100 periods: what the functions of flow.py take from their calls), "
             f"{kernels / per_period_target:.1f} times the "
             f"{per_period_target * 1e3:.3f} ms a period that the target leaves one "
             "thread (10 s of CPU for 200 000 periods), and the Python of the decisions "
             f"{(per_period - kernels) * 1e3:.2f} ms (0.19 ms until later on 2026-12-02, when "
             "the decisions stopped making their arrays anew at every event: the "
             "projections' flags, the survey's scratch, a phase's stepping arrays). A step "
             "in full coordinates still costs "
             "several times a step of the reduced model (the section 'Motion through "
             "contact changes'; it halved on 2026-12-02, when the flow's kernels stopped "
             "counting references: 0.19 ms of compiled calls a period before); the values "
             "would run in a prange kernel, the same work a compiled fate-map cell through "
             "contact changes needs (issue 38). The scipy column knows the orbit cannot stick and flips the sign by "
             "hand; phasemap's sweep decides every reversal and would follow stops. Two dask "
             "worker processes do not yet pay for themselves at this size: each imports "
             "phasemap and loads the oscillator's kernels before its first value, and the "
             "wall time includes that."]
    _report.publish(lines, "## Orbit diagrams", write=not args.no_write)


if __name__ == "__main__":
    main()
