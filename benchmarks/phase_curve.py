"""Phase curves: the generic compiled tracer against the per-system one it replaced.

For the ladder, the wheel and the hinge pendulum, times one phase curve

* ``after``: :func:`phasemap.phase_curve` (the generic exponential-collocation
  tracer, compiled per model), with its Dataset, and its kernel alone;
* ``before``: the per-system tracer of ``phasemap/phase.py`` at git revision
  ``--before`` (closed forms for the ladder and the hinge, Gauss-Legendre
  quadrature for the wheel; Python stage logic), loaded from git;
* ``simulate``: :func:`phasemap.simulate` (DOP853 at rtol 1e-12, which is about
  the tracer's accuracy) to the same fate, with its Dataset, and its kernel alone;

alternating the three in one process, medians over ``--repeat`` runs, JIT
compilation excluded (reported separately as the first call).  Accuracy:
omega^2 along the curve against the ladder's closed form
(``phasemap.systems.seeds.closed_forms.ladder_omega_squared``), the weightless hinge pendulum's
u = omega0^2 exp(-2 k (phi - phi0)) (from ``weightless_motion``), and the
wheel's first-integral equation integrated by scipy's DOP853 at rtol 1e-13.
Writes the section "Phase curves" of ../BENCHMARKS.md.

    python benchmarks/phase_curve.py [--repeat 21] [--before main] [--no-write]
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy.integrate import solve_ivp

import phasemap
from phasemap.motion import phase
from phasemap.motion.integrate import NO_STOP
from phasemap.systems import get_model
from phasemap.systems import hinge_pendulum as hinge
from phasemap.systems.seeds.closed_forms import ladder_omega_squared

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from _report import machine, publish  # noqa: E402
from grid import hand_model  # noqa: E402

G = 9.81
#: (label, model, start and parameters, t_end for simulate)
CASES = [
    ("ladder: falls from rest, leaves the floor", "ladder",
     dict(phi=1.0, omega=0.0, f=0.3, l=0.8), 5.0),
    ("ladder: thrown up, reverses, falls", "ladder",
     dict(phi=1.2, omega=-1.2, f=0.3, l=0.8), 5.0),
    ("ladder: f = sqrt2 + 1e-6, to the floor", "ladder",
     dict(phi=0.6, omega=-3.0, f=math.sqrt(2.0) + 1e-6), 5.0),
    ("wheel: swings to rest (4 stages)", "wheel", dict(phi=1.0, omega=0.0), 60.0),
    ("wheel: over the top, then swings", "wheel", dict(phi=0.0, omega=7.0), 60.0),
    ("hinge: swings to rest (5 stages)", "hinge_pendulum",
     dict(phi=0.2, omega=0.0, delta=0.02), 60.0),
    ("hinge: k = 22, pieces with layers", "hinge_pendulum",
     dict(phi=2.0, omega=8.0, delta=0.999), 60.0),
]


def load_before(rev: str):
    """The phase module at git revision ``rev``, as ``phasemap._phase_before``."""
    text = subprocess.run(["git", "show", f"{rev}:phasemap/phase.py"], cwd=ROOT, check=True,
                          capture_output=True, text=True).stdout
    path = pathlib.Path(tempfile.mkdtemp()) / "_phase_before.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("phasemap._phase_before", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def median_ms(fn, repeat, clock=time.perf_counter):
    """Median of ``repeat`` calls of ``fn`` (ms) by ``clock``."""
    times = []
    for _ in range(repeat):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return 1e3 * statistics.median(times)


def setup(name, values):
    """(model, values, phi range, compiled curve, input vector, u_ref) of one curve."""
    m = get_model(name)
    full = {k: float(v) for k, v in m.complete(values).items()}
    lo, hi = phase._checked_range(m, "phi", full["phi"], None)
    return m, full, lo, hi, phase.kernel(m), m.input_vector(full), \
        phase.velocity_reference(m, full)


def runners(name, values, t_end, before):
    m, full, lo, hi, kernel, v, u_ref = setup(name, values)
    integrate, _ = phasemap.motion.integrate.kernels(m, "DOP853")
    y0 = np.array([full["phi"], full["omega"]])
    no_eval = np.empty(0)
    return {
        "after": lambda: phase.phase_curve(name, **values),
        "after kernel": lambda: kernel(v, full["phi"], full["omega"], lo, hi, 50, 200, u_ref,
                                       phase.RTOL, phase.H_MAX,
                                       phase.first_width(phase.RTOL, phase.H_MAX)),
        "after kernel, 2 points": lambda: kernel(v, full["phi"], full["omega"], lo, hi, 50, 2,
                                                 u_ref, phase.RTOL, phase.H_MAX,
                                                 phase.first_width(phase.RTOL, phase.H_MAX)),
        "before": (lambda: before.phase_curve(name, **values)) if before else None,
        "simulate": lambda: phasemap.simulate(name, t_end, rtol=1e-12, method="DOP853",
                                              **values),
        "simulate kernel": lambda: integrate(v, y0, t_end, 1e-12, 1e-12, math.inf, 10**6,
                                             10**4, True, no_eval, NO_STOP),
    }


def timing(repeat, before):
    rows = []
    for label, name, values, t_end in CASES:
        run = runners(name, values, t_end, before)
        cold = {}
        for key, fn in run.items():
            if fn is not None:
                t0 = time.perf_counter()
                fn()
                cold[key] = time.perf_counter() - t0
        ds = run["after"]()
        sim = run["simulate"]()
        med = {k: [] for k in run}
        for _ in range(3):  # alternate the methods
            for key, fn in run.items():
                if fn is not None:
                    med[key].append(median_ms(fn, max(repeat // 3, 1)))
        med = {k: statistics.median(x) if x else math.nan for k, x in med.items()}
        rows.append((label, ds.attrs["end_reason"], int(ds.sizes["stage"]),
                     sim.attrs["end_reason"], med))
    return rows


#: Curves timed at equal accuracy: (label, model, start and parameters, t_end)
EQUAL = [CASES[0], CASES[3], CASES[5]]
TOLS = (1e-6, 1e-8, 1e-10, 1e-12, 1e-14)
LEVELS = (1e-6, 1e-9, 1e-12)


def equal_accuracy(repeat):
    """Cost of one curve at equal accuracy: the tracer at rtol in TOLS against simulate's
    kernel (DOPRI5 and DOP853) at the same tolerances, both to the curve's fate, all 15
    runs alternating (``repeat`` rounds of 3 calls, medians).  Error:
    the end state, max(|d phi|, |d omega^2| / u_ref), against the tracer at rtol 1e-14
    with the simulate runs also checked against simulate at rtol 1e-14 (DOP853)."""
    rows = []
    for label, name, values, t_end in EQUAL:
        m, full, lo, hi, kernel, v, u_ref = setup(name, values)

        def curve_end(rtol):
            _, st = kernel(v, full["phi"], full["omega"], lo, hi, 50, 2, u_ref, rtol,
                           phase.H_MAX, phase.first_width(rtol, phase.H_MAX))
            return float(st[-1, 4]), float(st[-1, 5])

        def sim_end(method, rtol):
            ds = phasemap.simulate(name, t_end, rtol=rtol, atol=rtol * math.sqrt(u_ref),
                                   method=method, **values)
            return float(ds.event_phi[-1]), float(ds.event_omega[-1]) ** 2

        ref = curve_end(phase.RTOL)
        check = sim_end("DOP853", 1e-14)

        def err(end):
            return max(abs(end[0] - ref[0]), abs(end[1] - ref[1]) / u_ref)

        errors, calls = {}, {}  # (method, tol): end-state error, the timed call
        y0 = np.array([full["phi"], full["omega"]])
        no_eval = np.empty(0)
        for tol in TOLS:
            errors["tracer", tol] = err(curve_end(tol))
            calls["tracer", tol] = lambda tol=tol: kernel(
                v, full["phi"], full["omega"], lo, hi, 50, 2, u_ref, tol, phase.H_MAX,
                phase.first_width(tol, phase.H_MAX))
            for method in ("DOPRI5", "DOP853"):
                integrate, _ = phasemap.motion.integrate.kernels(m, method)
                atol = tol * math.sqrt(u_ref)
                errors[method, tol] = err(sim_end(method, tol))
                calls[method, tol] = lambda integrate=integrate, tol=tol, atol=atol: integrate(
                    v, y0, t_end, tol, atol, math.inf, 10**6, 10**4, True, no_eval, NO_STOP)
        times = {key: [] for key in calls}
        for fn in calls.values():
            fn()  # (compiled above; first calls out of the timing)
        for _ in range(repeat):  # all runs alternating, so that a change of load hits each
            for key, fn in calls.items():
                times[key].append(median_ms(fn, 3))
        runs = {method: [(errors[method, tol], statistics.median(times[method, tol]))
                         for tol in TOLS] for method in ("tracer", "DOPRI5", "DOP853")}

        def cheapest(pairs, level):
            ok = [t for e, t in pairs if e <= level]
            return min(ok) if ok else math.nan
        rows.append((label, err(check), {
            level: (cheapest(runs["tracer"], level),
                    min(cheapest(runs["DOPRI5"], level), cheapest(runs["DOP853"], level),
                        key=lambda x: math.inf if math.isnan(x) else x))
            for level in LEVELS}))
    return rows


#: Issue 22's target 5: the hinge from (2.5, 0), delta = 0.1, with the default output.
TARGET = ("hinge: phi = 2.5, omega = 0, delta = 0.1", "hinge_pendulum",
          dict(phi=2.5, omega=0.0, delta=0.1), 60.0)


def target_five(repeat):
    """Issue 22's target 5 at the public call and in the kernels: ``phase_curve`` with its
    default output (200 points per stage) against ``simulate`` with its own (every step),
    DOPRI5 and DOP853, at rtol in TOLS, each level's cheapest run whose end state errs at
    most the level (the error as in :func:`equal_accuracy`).  All runs alternate
    (``repeat`` rounds, medians of 3 calls each)."""
    label, name, values, t_end = TARGET
    m, full, lo, hi, kernel, v, u_ref = setup(name, values)
    ref = kernel(v, full["phi"], full["omega"], lo, hi, 50, 2, u_ref, phase.RTOL, phase.H_MAX,
                 phase.first_width(phase.RTOL, phase.H_MAX))[1][-1]

    def err(phi_e, u_e):
        return max(abs(phi_e - ref[4]), abs(u_e - ref[5]) / u_ref)

    y0 = np.array([full["phi"], full["omega"]])
    no_eval = np.empty(0)
    errors, calls = {}, {}
    for tol in TOLS:
        ds = phase.phase_curve(name, rtol=tol, **values)
        errors["curve", tol] = err(float(ds.stage_end_phi[-1]),
                                   float(ds.stage_end_omega[-1]) ** 2)
        calls["curve", tol, "public"] = lambda tol=tol: phase.phase_curve(name, rtol=tol,
                                                                          **values)
        calls["curve", tol, "kernel"] = lambda tol=tol: kernel(
            v, full["phi"], full["omega"], lo, hi, 50, 200, u_ref, tol, phase.H_MAX,
            phase.first_width(tol, phase.H_MAX))
        for method in ("DOPRI5", "DOP853"):
            atol = tol * math.sqrt(u_ref)
            ds = phasemap.simulate(name, t_end, rtol=tol, atol=atol, method=method, **values)
            errors[method, tol] = err(float(ds.event_phi[-1]), float(ds.event_omega[-1]) ** 2)
            calls[method, tol, "public"] = (
                lambda tol=tol, atol=atol, method=method: phasemap.simulate(
                    name, t_end, rtol=tol, atol=atol, method=method, **values))
            integrate, _ = phasemap.motion.integrate.kernels(m, method)
            calls[method, tol, "kernel"] = (
                lambda integrate=integrate, tol=tol, atol=atol: integrate(
                    v, y0, t_end, tol, atol, math.inf, 10**6, 10**4, True, no_eval, NO_STOP))
    times = {key: [] for key in calls}
    for _ in range(repeat):
        for key, fn in calls.items():
            # CPU time: every call is serial, and other jobs on the cores do not inflate it
            times[key].append(1e3 * median_ms(fn, 3, time.process_time))
    med = {key: statistics.median(x) for key, x in times.items()}

    def cheapest(methods, level, where):
        ok = [med[mt, tol, where] for mt in methods for tol in TOLS
              if errors[mt, tol] <= level]
        return min(ok) if ok else math.nan

    return label, {level: {where: (cheapest(["curve"], level, where),
                                   cheapest(["DOPRI5", "DOP853"], level, where))
                           for where in ("public", "kernel")} for level in LEVELS}


def accuracy():
    """(label, max |omega^2 error| / (g/l), end-point error) against independent references."""
    out = []
    # ladder: one stage against the closed form of the kept slide (the hand module: the
    # running ladder is indeterminate at once at f = sqrt 2 + 1e-6, phi0 0.6, omega0 -3)
    for f, phi0, omega0 in ((0.3, 0.6, 2.0), (0.5, 1.2, -1.5), (math.sqrt(2) + 1e-6, 0.6, -3.0),
                            (math.sqrt(2) - 1e-3, 0.9, 0.5)):
        ds = phasemap.phase_curve(hand_model("ladder"), phi=phi0, omega=omega0, f=f)
        sel = ds.point_stage.values == 0
        phis, u = ds.phi.values[sel], ds.omega_squared.values[sel]
        exact = np.array([ladder_omega_squared(p, phi0, omega0, f, 1.0, G) for p in phis])
        out.append((f"ladder f = {f:.6g}, phi0 {phi0}, omega0 {omega0} "
                    f"({ds.stage_end_reason.attrs['flag_meanings'].split()[ds.stage_end_reason.values[0]]})",
                    float(np.max(np.abs(u - exact))) / G))
    # hinge pendulum, weightless: u = omega0^2 exp(-2 k sigma (phi - phi0))
    for delta, omega0 in ((0.3, 3.0), (0.9, -5.0)):
        ds = phasemap.phase_curve("hinge_pendulum", phi=0.0, omega=omega0, delta=delta, g=0.0)
        k = delta / math.sqrt(1 - delta ** 2)
        s = math.copysign(1.0, omega0)
        exact = omega0 ** 2 * np.exp(-2 * k * s * ds.phi.values)
        check = hinge.weightless_motion(np.array([1.0]), 0.0, omega0, delta, 1.0)
        assert abs(check[1][0] ** 2 - omega0 ** 2 * math.exp(-2 * k * s * check[0][0])) < 1e-9
        out.append((f"hinge weightless delta = {delta}, omega0 {omega0} (to the horizon, 4 pi)",
                    float(np.max(np.abs(ds.omega_squared.values - exact) / omega0 ** 2))))
    # wheel: the first-integral equation by DOP853 at rtol 1e-13
    for delta, phi0, u0, span in ((0.1, -1.0, 40.0, 2.0), (0.05, 0.0, 49.0, 6.0)):
        r, l, rho = 1.0, 0.5, 0.5

        def slope(phi, u):
            sp, cp = math.sin(phi), math.cos(phi)
            br = rho ** 2 + r ** 2 + l ** 2 - 2 * r * l * cp + delta * l * sp
            return [(-2 * l * (r * sp + delta * cp) * u[0] - 2 * G * l * sp - 2 * delta * G) / br]
        ds = phasemap.phase_curve("wheel", phi=phi0, omega=math.sqrt(u0), delta=delta,
                                  phi_range=(phi0 - 1, phi0 + span))
        sel = ds.point_stage.values == 0
        phis = ds.phi.values[sel]
        ref = solve_ivp(slope, (phi0, phis[-1]), [u0], method="DOP853", rtol=1e-13, atol=1e-13,
                        t_eval=phis).y[0]
        out.append((f"wheel delta = {delta}, phi0 {phi0}, omega0^2 {u0} over {phis[-1] - phi0:.3g}"
                    " rad", float(np.max(np.abs(ds.omega_squared.values[sel] - ref))) / (G / l)))
    return out


def order():
    """Observed order of the collocation with fixed panels (wheel, as in the tests)."""
    m = get_model("wheel")
    delta, phi0, u0, span = 0.1, -1.0, 40.0, 2.0
    r, l, rho = 1.0, 0.5, 0.5

    def slope(phi, u):
        sp, cp = math.sin(phi), math.cos(phi)
        br = rho ** 2 + r ** 2 + l ** 2 - 2 * r * l * cp + delta * l * sp
        return [(-2 * l * (r * sp + delta * cp) * u[0] - 2 * G * l * sp - 2 * delta * G) / br]
    exact = solve_ivp(slope, (phi0, phi0 + span), [u0], method="DOP853", rtol=1e-13,
                      atol=1e-13).y[0, -1]
    full = {k: float(x) for k, x in m.complete(dict(phi=phi0, omega=math.sqrt(u0),
                                                     delta=delta)).items()}
    ns = np.array([2, 3, 4, 5])
    errs = []
    for n in ns:
        h = span / n * (1 + 1e-12)
        _, st = phase._trace(m, full, (phi0 - 1, phi0 + span), 1, 2, rtol=math.inf, h_max=h,
                             h_first=h)
        errs.append(abs(st[0, 5] - exact))
    return float(np.polyfit(np.log(span / ns), np.log(errs), 1)[0]), errs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=21)
    ap.add_argument("--before", default="main", help="git revision of the old tracer")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    try:
        before = load_before(args.before)
        before.phase_curve("hinge_pendulum", phi=0.2, omega=0.0)
    except Exception as exc:  # noqa: BLE001 - a missing revision only drops a column
        print(f"no 'before' tracer: {exc}")
        before = None
    t0 = time.perf_counter()
    rows = timing(args.repeat, before)
    acc = accuracy()
    equal = equal_accuracy(max(args.repeat, 3))
    p, errs = order()
    load = os.getloadavg()[0]
    five_label, five = target_five(max(args.repeat, 3))
    lines = ["## Phase curves (`benchmarks/phase_curve.py`)", "",
             f"Machine: {machine()}.  Medians of {args.repeat} runs per method, the methods "
             "alternating in one process; JIT compilation excluded.  *after*: "
             "`phasemap.phase_curve`, the generic exponential Gauss collocation in phi "
             f"({phase.NODES} nodes, rtol {phase.RTOL:g}) compiled per model, with its Dataset "
             "(200 points per stage); *kernel*: the compiled curve alone.  *before*: the "
             f"per-system tracer at `{args.before}` (closed forms for the ladder and the hinge "
             "pendulum, Gauss-Legendre quadrature for the wheel, Python stage logic).  "
             "*simulate*: `phasemap.simulate(..., rtol=1e-12, method='DOP853')` to the same "
             "fate (its accuracy is about the tracer's), with its Dataset, and its kernel "
             "(saving every step).  *kernel, 2 points*: the compiled curve with "
             "points_per_stage = 2, i.e. the tracing alone without the 200 output points per "
             "stage, which cost one pass of 12 branch rows per panel (and one Gauss pass of "
             "6 rows per point on a panel whose |beta h| exceeds 1) to keep the output at "
             "the method's order.", "",
             "| curve | fate (stages) | simulate fate | before | after | after kernel | "
             "kernel, 2 points | simulate | simulate kernel | before / after | "
             "simulate / after | simulate kernel / kernel, 2 points |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, fate, n, sfate, med in rows:
        lines.append(
            f"| {label} | {fate} ({n}) | {sfate} | "
            + ("-" if math.isnan(med["before"]) else f"{med['before']:.2f} ms")
            + f" | {med['after']:.2f} ms"
            f" | {med['after kernel']:.3f} ms | {med['after kernel, 2 points']:.3f} ms | "
            f"{med['simulate']:.2f} ms | {med['simulate kernel']:.3f} ms | "
            + ("-" if math.isnan(med["before"]) else f"{med['before'] / med['after']:.1f}x")
            + f" | {med['simulate'] / med['after']:.2f}x | "
            f"{med['simulate kernel'] / med['after kernel, 2 points']:.2f}x |")
    lines += ["", "### At equal accuracy", "",
              "The compiled curve alone (2 points per stage) at rtol = "
              f"{', '.join(f'{t:g}' for t in TOLS)} (`phase_curve(..., rtol=...)`) against "
              "`simulate`'s kernel, DOPRI5 and DOP853, at the same tolerances (atol = rtol "
              "times the velocity scale), to the same fate; the 15 runs of a curve "
              f"alternate (medians of {max(args.repeat, 3)} rounds of 3 calls), so that a "
              "change of the load on the shared cores hits each alike.  Error: the end state, "
              "max(|d phi|, |d omega^2| / u_ref), against the curve at rtol 1e-14 "
              "(*check*: DOP853 at rtol 1e-14 against it).  Cheapest run with the error at "
              "most the level ('-': no run reaches it); *simulate kernel / curve* above 1 "
              "means the curve is cheaper.  For the ladder and the hinge the curve's cost "
              "does not change with rtol: the exponential integrates their linear part "
              "exactly, so their panels are few (3 on the ladder's stage, about 2 per swing "
              "of the hinge) and the cost is per stage: classifying its start and locating "
              "its end to double precision in phi.  A zero of omega^2 is found by Newton's "
              "method on the dense output (its Taylor series in theta where |beta h| <= 1: "
              "13 ns a point instead of 60-100 ns of phi-functions), then by Newton on Gauss "
              "passes with the slope the equation itself gives (one branch row), ending on "
              "the straight line omega^2 is within 1e-8 of the zero: 1-2 passes of 6 branch "
              "rows, 2.7 us a reversal of the wheel (4.5 us with the secant's 3-4 passes).  "
              "A zero of a reaction or of the coefficient takes the secant's 3-4 passes; a "
              "change of classification is bisected on that straight line, within 1e-11 of "
              "the zero where classification confirms that bracket, else 1e-8 (about 15 or "
              "25 classifications, no Gauss pass).  That location used to bisect on Gauss "
              "passes, about 50 per event (the ladder 130 us, the hinge 158 us at every "
              "level).  The wheel's cost is in its panels, about 2 us each (each part "
              "measured by repeating it inside the curve): 7 slopes of 2 branch rows each "
              "(0.4 us), the phi-functions at the 6 nodes with the collocation matrix (0.36 "
              "us), the Newton matrix and its LU factorisation (0.13 us), a second Newton "
              "pass of 6 rows and the classification of the end (75 ns); DOP853 takes 12 "
              "right-hand sides per step.  The Newton iteration stops at NEWTON = 1e-3 "
              "rtol, not at 1e-14, so at loose rtol the third pass half the wheel's panels "
              "took is gone.  A panel ends at a reaction's sign change only where the model "
              "names that reaction a kink of its law (`Model.kinks`: the hinge's R_n = m "
              "Q_n, through |Q_n|; a declared system's modes fix every sign their laws use, "
              "so its kinks are none).  The wheel's contact force F enters phi'' without a "
              "kink, and the panels split at its sign changes (at rtol 1e-6, 3 of 17 redone "
              "and 3 short ones added: about a third of the wheel's panel work there, "
              "counted before this change) are gone.  The first panel is H_MAX = 0.5 rad "
              "wide where rtol >= 1e-10 (`phase.first_width`), instead of growing from "
              "H_MAX / 20: a fifth of the ladder's curve and 7-12 % of the wheel's and the "
              "hinge's at those levels.",
              "", "| curve | check | " + " | ".join(
                  f"curve, err <= {lv:g} | simulate kernel | simulate kernel / curve"
                  for lv in LEVELS) + " |",
              "|---|---|" + "---:|" * (3 * len(LEVELS))]
    for label, check, by_level in equal:
        cells = []
        for lv in LEVELS:
            c, sk = by_level[lv]
            cells += ["-" if math.isnan(x) else f"{x * 1e3:.0f} us" for x in (c, sk)]
            cells.append("-" if math.isnan(sk / c) else f"{sk / c:.2f}x")
        lines.append(f"| {label} | {check:.1e} | " + " | ".join(cells) + " |")
    lines += ["", "### Target 5 of issue 22: the default output at equal accuracy", "",
              f"{five_label}, with the default output: `phase_curve(..., rtol=...)` (200 "
              "points per stage, with its Dataset; *kernel*: the compiled curve with 200 "
              "points) against `simulate(..., rtol=..., atol=rtol times the velocity scale)`, "
              "DOPRI5 or DOP853, whichever is cheaper (every step saved, with its Dataset; "
              f"*kernel*: the integrator alone), at rtol = {', '.join(f'{t:g}' for t in TOLS)}: "
              "at each level the cheapest run whose end state errs at most the level, as "
              "above.  CPU time of the process (medians; every call is serial), all runs "
              f"alternating; load average {load:.1f} on {os.cpu_count()} cores.  The output "
              "points cost one pass per panel (the remainder sampled at 12 Gauss nodes of the "
              "panel and solved in Legendre coefficients), not one Gauss pass of 6 branch "
              "rows per point, and the points' Legendre sums are evaluated 64 at a time "
              "(`collocation.legendre_many`: independent recurrences side by side, where one "
              "point's waits on its previous term; about 20 ns a point instead of 40).  "
              "*wrapper*: the public call minus its kernel (validation, and the Dataset of "
              "1200 points and 6 stages against simulate's of its steps and events).  "
              "Target: the curve at least as fast as simulate at the public call.", "",
              "| level | curve | simulate | simulate / curve | curve kernel | simulate kernel "
              "| simulate kernel / curve kernel | curve wrapper | simulate wrapper | target 5 |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for lv in LEVELS:
        (c, sm), (ck, sk) = five[lv]["public"], five[lv]["kernel"]
        ok = c <= sm
        lines.append(f"| {lv:g} | {c:.0f} us | {sm:.0f} us | {sm / c:.2f}x | {ck:.0f} us | "
                     f"{sk:.0f} us | {sk / ck:.2f}x | {c - ck:.0f} us | {sm - sk:.0f} us | "
                     f"{'met' if ok else '**missed**'} |")
    lines += ["", "Accuracy against independent references (largest error of omega^2 over the "
              "output points of the stage, relative to g/l; the hinge's relative to omega0^2):",
              "", "| case | error |", "|---|---|"]
    lines += [f"| {label} | {err:.1e} |" for label, err in acc]
    lines += ["", f"Observed order with fixed panels (wheel, n = 2..5 panels over 2 rad): "
              f"{p:.1f} (errors {', '.join(f'{e:.1e}' for e in errs)}); "
              f"the test suite asserts 10..14.  Run time of this script "
              f"{time.perf_counter() - t0:.0f} s."]
    publish(lines, "## Phase curves", write=not args.no_write)


if __name__ == "__main__":
    main()
