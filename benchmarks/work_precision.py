"""Work-precision: error against run time per trajectory, phasemap against solve_ivp.

For each built-in problem of :mod:`phasemap.motion.workprecision` (one per system)
this runs the first-integral tracer, the numba integrator (its kernel with
the DOPRI5 and the DOP853 method, and ``phasemap.simulate`` with its
Dataset) and scipy's ``solve_ivp`` (RK45,
DOP853, Radau, LSODA, driven stage by stage with the same events) at
rtol = atol = 1e-3 ... 1e-13, and measures the error at the end of the motion
and the L2 error over 101 saved points against an exact or a much tighter
reference.  Methods alternate within each timing round; times are medians;
JIT compilation is excluded.

Outputs: ``benchmarks/work_precision.pdf`` and ``.png`` (drawn by
``phasemap.plot.work_precision_figure``), ``benchmarks/work_precision.csv``
(every row), and the section "Work-precision" of ../BENCHMARKS.md.  The fate
map of the wheel is timed by ``benchmarks/fate_map.py``.

    python benchmarks/work_precision.py [--quick] [--repeats 3] [--no-write] [--figure-only]
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import pathlib
import statistics
import sys
import time

import phasemap.motion.workprecision as wp

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _report import machine, publish, write_section  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent
LEVELS = (1e-3, 1e-5, 1e-7, 1e-9, 1e-11)
def write_csv(rows, path):
    keys = ["system", "method", "tol", "error_final", "error_l2", "seconds", "seconds_min",
            "seconds_max", "n_samples", "fate",
            "n_reversals", "same_fate", "n_steps", "nfev", "skipped", "reference", "floor",
            "cross_check"]
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)


def read_csv(path):
    """The rows :func:`write_csv` wrote (numbers as floats, words as they are)."""
    def value(v):
        try:
            return float(v)
        except ValueError:
            return v

    with open(path, newline="") as fh:
        return [{k: value(v) for k, v in row.items() if v != ""} for row in csv.DictReader(fh)]


def figure(rows, stem):
    from phasemap.plot import save_figure, work_precision_figure

    fig = work_precision_figure(rows, error="error_final")
    return save_figure(fig, stem)


KERNELS = tuple(wp.PHASEMAP_METHODS)


def faster_kernel(rows, system, level):
    """The phasemap kernel (method) that reaches ``level`` first on ``system``."""
    times = [(wp.time_at_error(rows, system, m, level), m) for m in KERNELS]
    times = [(t, m) for t, m in times if math.isfinite(t)]
    return min(times)[1] if times else ""


def ratio_summary(rows, systems):
    """Per system: the faster phasemap kernel vs best solve_ivp at equal final error."""
    out = []
    for system in systems:
        floor = max(r["floor"] for r in rows if r["system"] == system)
        ratios = []
        for lv in LEVELS:
            if lv < 10 * floor:
                continue
            ratio, who = wp.equal_error_ratio(rows, system, lv, KERNELS)
            if math.isfinite(ratio):
                ratios.append((lv, ratio, f"{who}; {faster_kernel(rows, system, lv)}"))
        out.append((system, ratios))
    return out


def order_gain(rows, systems) -> list[str]:
    """DOP853 against DOPRI5 in the numba kernel: time ratio at equal error, per level."""
    parts = []
    for system in systems:
        cells = []
        for lv in LEVELS:
            a = wp.time_at_error(rows, system, "phasemap", lv)
            b = wp.time_at_error(rows, system, "phasemap_DOP853", lv)
            if math.isfinite(a) and math.isfinite(b):
                cells.append(f"{a / b:.2g}x at {lv:.0e}")
        if cells:
            parts.append(f"{system}: {', '.join(cells)}")
    return parts


def limits(rows, systems) -> list[str]:
    """What sets the ratios, from the measured rows."""
    def fastest(method, system):
        runs = [r for r in rows if r["method"] == method and r["system"] == system
                and not r["skipped"]]
        return min(runs, key=lambda r: r["seconds"]) if runs else None

    fixed = [fastest("phasemap", s) for s in systems]
    fixed = [r for r in fixed if r is not None]
    setup = [fastest(m, s) for m in wp.SCIPY_METHODS for s in systems]
    setup = [r for r in setup if r is not None]
    lines = ["What sets these ratios:", ""]
    if fixed and setup:
        short = min(fixed, key=lambda r: r["seconds"])
        lines.append(
            f"- Fixed costs. The kernel's cheapest run ({short['system']}, "
            f"{short['n_steps']} steps) takes {short['seconds'] * 1e6:.0f} us, mostly per-call "
            f"cost (dispatch, work arrays, the 101 saved points); the cheapest solve_ivp run "
            f"takes {min(r['seconds'] for r in setup) * 1e3:.1f} ms. On a short motion (the "
            f"ladder: one stage, a few dozen steps) these fixed costs set the ratio.")
    gain = order_gain(rows, systems)
    lines += [
        "- Order. At tight tolerances the fastest scipy method is DOP853 (order 8), which "
        "needs several times fewer steps than Dormand-Prince 5(4); phasemap's own DOP853 "
        "(`phasemap_DOP853`) answers it. Time of phasemap's DOPRI5 over its DOP853 at equal "
        "error (above 1: DOP853 is faster): " + ("; ".join(gain) if gain else "not measured")
        + ".",
        "- `simulate` adds validation and the xarray Dataset to the kernel: the section "
        "'simulate() at the public call' splits a call into its parts.",
        "- DOP853 at 1e-13 is the tight references themselves (error 0 there, not drawn); "
        "errors below ten times a reference's floor are not compared ('(floor)').",
    ]
    return lines


def _median_time(fn, rounds: int) -> float:
    """Median CPU time of ``fn`` over ``rounds`` calls: this process's, which a share of
    the cores lost to other jobs does not inflate (every call timed here is serial)."""
    ts = []
    for _ in range(rounds):
        t0 = time.process_time()
        fn()
        ts.append(time.process_time() - t0)
    return statistics.median(ts)


def public_call(rounds: int = 200) -> tuple[str, list]:
    """simulate() at the public call on the frictionless hinge (phi = 1, t_end = 20,
    DOP853 at rtol = atol = 1e-9) against solve_ivp's DOP853 with a velocity event,
    the per-call cost split into the kernel, the Dataset and the rest, and the batch
    form against a call per start.  Alternating rounds, medians."""
    import numpy as np
    from scipy.integrate import solve_ivp

    import phasemap
    from phasemap.motion.integrate import NO_STOP, kernels

    sim = sys.modules["phasemap.simulate"]  # the module (phasemap.simulate is the function)

    kw, opts = dict(phi=1.0, omega=0.0, delta=0.0), dict(t_end=20.0, rtol=1e-9,
                                                          method="DOP853")
    m = phasemap.get_model("hinge_pendulum")
    g, l = float(m.complete(kw)["g"]), float(m.complete(kw)["l"])
    integrate, _ = kernels(m, "DOP853")
    full, positions = sim.split_values(m, kw)
    v, y0, te = m.input_vector(full), np.array([1.0, 0.0]), np.empty(0)
    names = [x.name for x in sim.integrated_variables(m)]
    checked = sim.Options(**opts).checked(m.name)

    def kernel():
        return integrate(v, y0, 20.0, 1e-9, 1e-9, math.inf, 1_000_000, 10_000, True, te, NO_STOP)

    res = kernel()
    cols = sim._columns(res[5], res[6], res[7], None)

    def dataset():
        return sim._dataset(m, full, positions, checked, names, int(res[0]), int(res[3]),
                            int(res[4]), *cols)

    def public():
        return phasemap.simulate("hinge_pendulum", **opts, **kw)

    def velocity(t, y):
        return y[1]

    def scipy_run():
        return solve_ivp(lambda t, y: (y[1], -g / l * math.sin(y[0])), (0.0, 20.0),
                         [1.0, 0.0], method="DOP853", rtol=1e-9, atol=1e-9, events=velocity)

    starts = np.linspace(0.2, 2.8, 64)

    def batch():
        return phasemap.simulate("hinge_pendulum", t_end=10.0, phi=starts, omega=0.0)

    def loop():
        return [phasemap.simulate("hinge_pendulum", t_end=10.0, phi=p, omega=0.0)
                for p in starts]

    for fn in (public, batch, scipy_run):
        fn()
    t = {k: [] for k in ("kernel", "dataset", "public", "scipy", "batch", "loop")}
    for _ in range(5):
        t["kernel"].append(_median_time(kernel, rounds))
        t["dataset"].append(_median_time(dataset, rounds))
        t["public"].append(_median_time(public, rounds))
        t["scipy"].append(_median_time(scipy_run, max(3, rounds // 40)))
        t["batch"].append(_median_time(batch, 3))
        t["loop"].append(_median_time(loop, 3))
    t = {k: statistics.median(x) for k, x in t.items()}
    overhead = t["public"] - t["kernel"] - t["dataset"]
    ratio = t["scipy"] / t["public"]
    targets = [("simulate() >= 20x solve_ivp (DOP853, velocity event) on the frictionless "
                "hinge", f"{ratio:.0f}x", ratio >= 20),
               ("per-call overhead <= 100 us beyond the kernel and the Dataset",
                f"{overhead * 1e6:.0f} us", overhead <= 100e-6)]
    lines = [
        "| part of a simulate() call | time |",
        "| --- | --- |",
        f"| the kernel (DOP853, {int(res[4])} steps) | {t['kernel'] * 1e6:.0f} us |",
        f"| the Dataset | {t['dataset'] * 1e6:.0f} us |",
        f"| the rest (validation, look-ups, columns) | {overhead * 1e6:.0f} us |",
        f"| simulate() | {t['public'] * 1e6:.0f} us |",
        f"| solve_ivp DOP853 with a velocity event | {t['scipy'] * 1e3:.2f} ms |",
        "",
        f"Batch form: 64 starts (phi 0.2 ... 2.8, t_end = 10, DOPRI5 1e-8) in one call "
        f"{t['batch'] * 1e3:.1f} ms, one call per start {t['loop'] * 1e3:.1f} ms "
        f"({t['loop'] / t['batch']:.1f}x).",
    ]
    return "\n".join(lines), targets


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="4 tolerances, 1 round, a 200^2 fate map (a few minutes)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--problems", nargs="+", default=list(wp.PROBLEMS))
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("--figure-only", action="store_true",
                    help="redraw the figure from work_precision.csv, time nothing")
    ap.add_argument("--calls-only", action="store_true",
                    help="time only simulate() at the public call (section 'simulate() at "
                    "the public call')")
    args = ap.parse_args()
    load_start = os.getloadavg()
    table, targets = public_call(40 if args.quick else 200)
    calls = "\n".join([
        "## simulate() at the public call (`benchmarks/work_precision.py --calls-only`)", "",
        f"Machine: {machine()}; load average {load_start[0]:.1f} at the start, "
        f"{os.getloadavg()[0]:.1f} at the end; one thread (a trajectory is serial). "
        "The frictionless hinge pendulum (phi = 1, omega = 0, delta = 0, t_end = 20 s, "
        "DOP853, rtol = atol = 1e-9); alternating rounds, medians of 5; CPU time of the "
        "process (`time.process_time`), which the load on the shared cores does not "
        "inflate.", "",
        table, "", "| target | measured | met |", "| --- | --- | --- |",
        *[f"| {what} | {value} | {'met' if ok else 'missed'} |"
          for what, value, ok in targets], ""])
    print(calls)
    if not args.no_write:
        write_section(calls, "## simulate() at the public call")
    if args.calls_only:
        return
    if args.figure_only:
        print("figure:", *figure(read_csv(HERE / "work_precision.csv"), HERE / "work_precision"))
        return
    if args.quick:
        tolerances, repeats, min_time = (1e-3, 1e-6, 1e-9, 1e-12), 1, 0.005
    else:
        tolerances, repeats, min_time = wp.DEFAULT_TOLERANCES, args.repeats, 0.05
    load_start = os.getloadavg()
    started = time.perf_counter()
    rows, refs = [], {}
    for name in args.problems:
        problem = wp.PROBLEMS[name]
        ref = problem.resolve()
        refs[name] = ref
        print(f"# {name}: {problem.description}; reference {ref.kind} {ref.note}", flush=True)
        rows += wp.work_precision(problem, tolerances=tolerances, repeats=repeats,
                                  min_time=min_time, reference=ref,
                                  progress=lambda s: print(s, flush=True))
    sweep_seconds = time.perf_counter() - started
    table = wp.report(rows, LEVELS)
    print(table)
    summary = ratio_summary(rows, args.problems)
    load_end = os.getloadavg()

    paths = ("(not written)",)
    if not args.no_write:
        write_csv(rows, HERE / "work_precision.csv")
        paths = figure(rows, HERE / "work_precision")

    lines = [
        "## Work-precision (`benchmarks/work_precision.py`)",
        "",
        f"Machine: {machine()}.",
        f"Run {'--quick' if args.quick else 'in full'}: tolerances "
        f"{', '.join(f'{t:.0e}' for t in tolerances)} (rtol = atol); {repeats} timing "
        f"round(s), methods alternating within each, medians; JIT compilation excluded. "
        f"Sweep: {sweep_seconds / 60:.1f} min. Load average {load_start[0]:.1f} at the start, "
        f"{load_end[0]:.1f} at the end"
        + (": **the machine was shared** (other jobs ran at the same time), so absolute times "
           "are noisy; the ratios compare methods within one run."
           if max(load_start[0], load_end[0]) > 1.5 else
           " (this run alone on the 2 cores); the ratios compare methods within one run."),
        "",
        "Figure: `benchmarks/work_precision.pdf` / `.png` (error at the end of the motion "
        "against seconds per trajectory, one panel per system, one line per method); every "
        "run in `benchmarks/work_precision.csv`.",
        "",
        "Problems and references:",
        "",
    ]
    for name in args.problems:
        p, ref = wp.PROBLEMS[name], refs[name]
        extra = f"; {ref.note}" if ref.note else ""
        lines.append(f"- **{name}**: {p.description} (t_end = {p.t_end:g} s, "
                     f"{', '.join(f'{k} = {v:g}' for k, v in p.values.items())}); reference: "
                     f"{ref.kind}{extra}; ends with {ref.fate} after {ref.n_reversals} "
                     f"reversals.")
    lines += [
        "",
        "Methods: `phasemap` is the numba integrator's jitted kernel (what `simulate` and "
        "the fate maps call) with its default method, Dormand-Prince 5(4); "
        "`phasemap_DOP853` the same kernel with `method=\"DOP853\"` (order 8, dense output "
        "of order 7); `simulate` is `phasemap.simulate` with validation and the "
        "Dataset; RK45 ... LSODA are `scipy.integrate.solve_ivp` restarted on every stage by "
        "`phasemap.motion.workprecision.solve_ivp_staged` with terminal events (velocity zero, "
        "assumed reaction signs, the coefficient, the stick limit) and the model's own jitted "
        "branch as right-hand side; `phase_curve` is the first-integral tracer (rtol = the "
        "tolerance; error in the phase plane).",
        "",
        "Seconds per trajectory needed for an error at the end of the motion of at most the "
        "level (log-log interpolation between the runs on each method's Pareto front; the "
        "fastest run's time where even that meets the level; '-' where no run does), and "
        "the ratio of the fastest solve_ivp method's time to each phasemap kernel's, and "
        "to the faster of the two at each level:",
        "",
        table,
        "",
        "### Against the target (>= 100x the best solve_ivp method at equal error)",
        "",
        "The faster phasemap kernel at each level against the fastest solve_ivp method "
        "(ratio at equal error at the end of the motion; in brackets: that solve_ivp "
        "method; the phasemap kernel):",
        "",
    ]
    all_ratios = [r for _, rs in summary for _, r, _ in rs]
    for system, ratios in summary:
        if ratios:
            text = ", ".join(f"{r:.0f}x at {lv:.0e} ({who})" for lv, r, who in ratios)
            lines.append(f"- {system}: {text}.")
    if all_ratios:
        met = sum(r >= 100 for r in all_ratios)
        lines.append(f"- Overall: median {statistics.median(all_ratios):.0f}x, range "
                     f"{min(all_ratios):.0f}x-{max(all_ratios):.0f}x; >= 100x at {met} of "
                     f"{len(all_ratios)} (system, level) pairs.")
    lines += ["", *limits(rows, args.problems), "",
              "The fate map of the wheel has its own section (`benchmarks/fate_map.py`).", ""]
    publish(lines, "## Work-precision", write=not args.no_write)
    print("figure:", *paths)


if __name__ == "__main__":
    main()
