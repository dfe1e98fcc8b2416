"""Stiff and extreme cases of the time integrator: does each meet its target or stop clearly?

Runs ``phasemap.simulate`` on the cases below and records, per case, the end
reason, whether every floating-point output is finite, the error against a
reference where there is one (a closed form, the first-integral tracer
``phasemap.motion.phase.phase_curve``, or the limit the case tends to), the steps
and the wall time, and gives a verdict:

* **meets target**: the expected end, finite outputs, error within target;
* **stops: <reason>**: the motion ends with a terminal event that says why
  it cannot go on (listed as an acceptable stop for that case);
* **FAILS: ...**: anything else (a wrong end, a missed event, an error over
  target, a non-finite output or an unexpected exception).

Cases: the ladder with f -> sqrt 2 from both sides; the hinge pendulum with
delta -> l; the elliptic pendulum near lambda = 0 (f = 3 > 2 sqrt 2); very
large and very small initial velocities; long horizons with thousands of
reversals (the wheel with small delta); tolerances at the edge of double
precision.  Writes the section "Stability" of ../BENCHMARKS.md.

    python benchmarks/stability.py [--no-write]
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.optimize import brentq

import phasemap
from phasemap.systems.hinge_pendulum import weightless_motion
from phasemap.motion.phase import phase_curve

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _report import machine, publish  # noqa: E402
from grid import hand_model  # noqa: E402

R2 = math.sqrt(2.0)
F_ELLIPTIC = 3.0
CLEAR_STOPS = {"singular", "no_solution", "indeterminate", "continuum", "step_failure",
               "contact_lost", "stiff"}


@dataclass
class Case:
    group: str
    name: str
    model: str
    t_end: float
    values: dict
    rtol: float = 1e-10
    options: dict = field(default_factory=dict)
    expect: tuple[str, ...] = ()           # end reasons that meet the target
    stops: tuple[str, ...] = ()            # end reasons accepted as a clear stop
    error: Callable | None = None          # ds -> error against the reference
    target: float = math.nan
    reference: str = ""
    raises: type | None = None             # the call must raise this


def finite(ds) -> bool:
    """Every floating-point variable and coordinate of ``ds`` is finite."""
    return all(np.isfinite(ds[v].values).all() for v in ds.variables
               if ds[v].dtype.kind == "f")


def end_state(ds, name):
    return float(ds[f"event_{name}"].values[-1])


# ------------------------------------------------------------------ references
def curve_end(model, **kw):
    """(end reason, phi, omega, n_reversals) of the first-integral tracer."""
    pc = phase_curve(model, max_stages=100_000, **kw)
    assert finite(pc), f"phase_curve {model} {kw}: non-finite output"
    return (pc.attrs["end_reason"], float(pc.stage_end_phi[-1]), float(pc.stage_end_omega[-1]),
            int(pc.attrs["n_reversals"]))


def against_curve(model, **kw):
    reason, phi, omega, n_rev = curve_end(model, **kw)

    def error(ds):
        if ds.attrs["end_reason"] != reason or int(ds.attrs["n_reversals"]) != n_rev:
            return math.inf
        return max(abs(end_state(ds, "phi") - phi), abs(end_state(ds, "omega") - omega))
    return error, reason


def against_weightless(phi0, omega0, delta, relative=False):
    def error(ds):
        phi, omega = weightless_motion(ds.t.values, phi0, omega0, delta, 1.0)
        e = max(np.max(np.abs(phi - ds.phi.values)), np.max(np.abs(omega - ds.omega.values)))
        return e / max(1.0, abs(omega0)) if relative else e
    return error


def wheel_fast_contact_loss(delta=0.05, r=1.0, l=0.5, rho=0.5, sigma=1.0):
    """The angle where N = 0 in the limit omega -> infinity (gravity negligible)."""
    def n_over_w2(phi):
        s, c = math.sin(phi), math.cos(phi)
        bracket = rho * rho + r * r + l * l - 2 * r * l * c + delta * sigma * l * s
        return c - l * s * (r * s + delta * sigma * c) / bracket
    return brentq(n_over_w2, 0.5, 1.5, xtol=1e-16)


def elliptic_lambda(phi, k):
    s, c = math.sin(phi), math.cos(phi)
    return 1.0 + s * s - k * F_ELLIPTIC * s * c


# ------------------------------------------------------------------ the cases
def cases() -> list[Case]:
    out = []
    # -- the ladder, f -> sqrt 2 ------------------------------------------------
    # The kept-contact ladder (the hand module, eq. (8)): its slide is stiff near sqrt 2.
    # The running ladder also counts leaving a contact: thrown at omega = -4 just above
    # sqrt 2 it is indeterminate at t = 0 (the slide and flying off), nothing to integrate.
    ladder = hand_model("ladder")
    for eps in (1e-3, 1e-6, 1e-9):
        f = R2 - eps
        err, reason = against_curve(ladder, phi=0.3, omega=-0.5, f=f)
        out.append(Case("ladder f -> sqrt2", f"f = sqrt2 - {eps:g}, phi 0.3, omega -0.5",
                        ladder, 1.0, dict(phi=0.3, omega=-0.5, f=f), expect=(reason,),
                        error=err, target=1e-8, reference="phase_curve"))
    out.append(Case("ladder f -> sqrt2", "f = sqrt2 (float), omega 0.5", ladder, 1.0,
                    dict(phi=0.3, omega=0.5, f=R2), expect=("singular",),
                    reference="2 - f^2 = 0: singular at t = 0"))
    for eps in (1e-3, 1e-6, 1e-9):
        f = R2 + eps
        err, reason = against_curve(ladder, phi=0.5, omega=-4.0, f=f)
        for rtol in ((1e-10, 1e-8, 1e-4) if eps == 1e-9 else (1e-10,)):
            out.append(Case("ladder f -> sqrt2", f"f = sqrt2 + {eps:g}, phi 0.5, omega -4",
                            ladder, 1.0, dict(phi=0.5, omega=-4.0, f=f), rtol=rtol,
                            expect=(reason,), stops=("step_failure", "stiff"), error=err,
                            target=1e-7, reference="phase_curve"))
    # -- the hinge pendulum, delta -> l -----------------------------------------
    for eps in (1e-3, 1e-9):
        delta = 1.0 - eps
        out.append(Case("hinge delta -> l", f"g = 0, delta = l (1 - {eps:g}), omega 2",
                        "hinge_pendulum", 5.0, dict(phi=0.0, omega=2.0, delta=delta, g=0.0),
                        expect=("horizon",), error=against_weightless(0.0, 2.0, delta),
                        target=1e-8, reference="exact (36)"))
    for eps in (1e-6, 1e-9):
        delta = 1.0 - eps
        err, reason = against_curve("hinge_pendulum", phi=2.0, omega=3.0, delta=delta)
        out.append(Case("hinge delta -> l", f"delta = l (1 - {eps:g}), phi 2, omega 3",
                        "hinge_pendulum", 5.0, dict(phi=2.0, omega=3.0, delta=delta),
                        expect=(reason,), error=err, target=1e-8,
                        reference="phase_curve"))
    for label, delta in (("l (1 - 1e-12)", 1.0 - 1e-12), ("l", 1.0)):
        out.append(Case("hinge delta -> l", f"delta = {label}, omega 2", "hinge_pendulum",
                        5.0, dict(phi=1.0, omega=2.0, delta=delta),
                        expect=("singular", "no_solution"),
                        reference="l^2 - delta^2 = 0 (within 1e-12): no motion from t = 0"))
    out.append(Case("hinge delta -> l", "delta = l, omega 0 (rest)", "hinge_pendulum", 5.0,
                    dict(phi=1.0, omega=0.0, delta=1.0), expect=("rest",),
                    reference="rest holds at every angle for delta >= l"))
    # -- the elliptic pendulum near lambda = 0 ----------------------------------
    root = math.atan(0.5)  # lambda_+ = 1 + s^2 - 3 s c vanishes at tan(phi) = 1/2 and 1
    out.append(Case("elliptic lambda -> 0", "at lambda_+ = 0 (phi = atan 1/2), xdot 0.5",
                    "elliptic_pendulum", 5.0, dict(phi=root, omega=0.0, xdot=0.5,
                                                   f=F_ELLIPTIC),
                    expect=("singular", "no_solution", "indeterminate"),
                    reference="lambda = 0 at t = 0"))
    out.append(Case("elliptic lambda -> 0", "lambda_+ = -1e-8 (phi = atan 1/2 + 1e-8)",
                    "elliptic_pendulum", 5.0, dict(phi=root + 1e-8, omega=0.0, xdot=0.5,
                                                   f=F_ELLIPTIC),
                    expect=("no_solution",), reference="Painleve: no solution"))
    out.append(Case("elliptic lambda -> 0", "lambda_+ < 0, xdot -0.5 (two solutions)",
                    "elliptic_pendulum", 5.0, dict(phi=root + 1e-8, omega=0.0, xdot=-0.5,
                                                   f=F_ELLIPTIC),
                    expect=("indeterminate",), reference="Painleve: two solutions"))
    t_ref = phasemap.simulate("elliptic_pendulum", 5.0, rtol=1e-14, phi=0.9, omega=-3.0,
                              xdot=50.0, f=F_ELLIPTIC)

    def reaches_lambda_zero(ds, ref=t_ref):
        if ds.attrs["end_reason"] != "singular":
            return math.inf
        phi = end_state(ds, "phi")
        lam = min(abs(elliptic_lambda(phi, 1.0)), abs(elliptic_lambda(phi, -1.0)))
        return max(lam, abs(float(ds.event_t[-1]) - float(ref.event_t[-1])))
    out.append(Case("elliptic lambda -> 0", "slides into lambda_- = 0 (phi 0.9, omega -3, "
                    "xdot 50)", "elliptic_pendulum", 5.0,
                    dict(phi=0.9, omega=-3.0, xdot=50.0, f=F_ELLIPTIC),
                    expect=("singular",), error=reaches_lambda_zero, target=1e-8,
                    reference="|lambda| at the stop, and its time against rtol 1e-14"))
    # -- very large and very small initial velocities ----------------------------
    for w0, rtol, target in ((1e6, 1e-10, 1e-8), (1e12, 1e-8, 1e-6)):
        out.append(Case("omega0 extreme", f"g = 0, omega0 = {w0:g}", "hinge_pendulum", 1.0,
                        dict(phi=0.0, omega=w0, delta=0.3, g=0.0), rtol=rtol,
                        options=dict(t_eval=np.linspace(0.0, 1.0, 11)), expect=("horizon",),
                        error=against_weightless(0.0, w0, 0.3, relative=True), target=target,
                        reference="exact (36), error relative to omega0"))
    out.append(Case("omega0 extreme", "g = 0, omega0 = 1e12 at rtol 1e-14", "hinge_pendulum",
                    1.0, dict(phi=0.0, omega=1e12, delta=0.3, g=0.0), rtol=1e-14,
                    expect=("horizon",), stops=("step_failure",),
                    error=against_weightless(0.0, 1e12, 0.3, relative=True), target=1e-6,
                    reference="exact (36); steps below 1e-14 t_end are refused"))
    out.append(Case("omega0 extreme", "omega0 = 1e300 (omega^2 overflows)", "hinge_pendulum",
                    1.0, dict(phi=1.0, omega=1e300, delta=0.1), stops=("step_failure",),
                    reference="-"))
    out.append(Case("omega0 extreme", "g = 0, omega0 = 1e-300", "hinge_pendulum", 1.0,
                    dict(phi=0.0, omega=1e-300, delta=0.3, g=0.0),
                    options=dict(t_eval=np.linspace(0.0, 1.0, 11)), expect=("horizon",),
                    error=lambda ds: float(np.max(np.abs(ds.phi.values - 1e-300 * ds.t.values))),
                    target=1e-310, reference="phi = 1e-300 t"))
    still = phasemap.simulate("hinge_pendulum", 5.0, rtol=1e-10, phi=1.0, omega=0.0)
    out.append(Case("omega0 extreme", "g = 9.81, omega0 = 1e-300 (counts as rest)",
                    "hinge_pendulum", 5.0, dict(phi=1.0, omega=1e-300),
                    expect=(still.attrs["end_reason"],),
                    error=lambda ds: abs(end_state(ds, "phi") - end_state(still, "phi")),
                    target=1e-12, reference="the same motion from omega0 = 0"))
    phi_c = wheel_fast_contact_loss()
    out.append(Case("omega0 extreme", "wheel, omega0 = 1e6 (bounces)", "wheel", 1.0,
                    dict(phi=0.0, omega=1e6), expect=("contact_lost",),
                    error=lambda ds: abs(end_state(ds, "phi") - phi_c), target=1e-8,
                    reference="N = 0 of the omega -> inf limit"))
    # -- long horizons, many reversals ------------------------------------------
    for delta, phi0, t_end in ((2e-3, 2.0, 1000.0), (5e-4, 2.5, 5000.0), (1e-4, 2.5, 20000.0)):
        err, reason = against_curve("wheel", phi=phi0, omega=0.0, delta=delta)
        out.append(Case("long horizon", f"wheel delta = {delta:g}, phi0 {phi0:g}", "wheel",
                        t_end, dict(phi=phi0, omega=0.0, delta=delta),
                        options=dict(max_events=100_000, t_eval=[0.0, t_end]),
                        expect=(reason,), error=err, target=1e4 * 1e-10,
                        reference="phase_curve (order-12 collocation); target 1e4 rtol, "
                                  "the error grows over 10^2-10^4 stages"))
    out.append(Case("long horizon", "wheel delta = 1e-4 at rtol 1e-14", "wheel", 20000.0,
                    dict(phi=2.5, omega=0.0, delta=1e-4), rtol=1e-14,
                    options=dict(max_events=100_000, t_eval=[0.0, 20000.0]),
                    expect=(reason,), stops=("max_events",), error=err, target=1e-9,
                    reference="phase_curve; max_steps = 10^6 (default)"))
    # -- tolerances at the edge of double precision -----------------------------
    out.append(Case("rtol edge", "rtol = 1e-14, weightless rotation", "hinge_pendulum", 10.0,
                    dict(phi=0.0, omega=5.0, delta=0.3, g=0.0), rtol=1e-14,
                    expect=("horizon",), error=against_weightless(0.0, 5.0, 0.3),
                    target=1e-12, reference="exact (36)"))
    err, reason = against_curve("hinge_pendulum", phi=2.5, omega=0.0, delta=0.05)
    for atol in (None, 1e-300):
        out.append(Case("rtol edge", f"rtol = 1e-14, atol = {atol or 1e-14:g}, 12 reversals",
                        "hinge_pendulum", 20.0, dict(phi=2.5, omega=0.0, delta=0.05),
                        rtol=1e-14, options={} if atol is None else dict(atol=atol),
                        expect=(reason,), stops=("step_failure",), error=err, target=1e-11,
                        reference="phase_curve"))
    out.append(Case("rtol edge", "rtol = 1e-15", "hinge_pendulum", 1.0, dict(phi=1.0),
                    rtol=1e-15, raises=ValueError, reference="ValueError"))
    return out


# ------------------------------------------------------------------ running
def run(case: Case) -> dict:
    start = time.perf_counter()
    row = dict(group=case.group, name=case.name, rtol=case.rtol, reference=case.reference,
               target=case.target)
    try:
        ds = phasemap.simulate(case.model, case.t_end, rtol=case.rtol, **case.options,
                               **case.values)
    except Exception as exc:  # noqa: BLE001 - every failure is reported, not raised
        row.update(seconds=time.perf_counter() - start, end="-", finite=True,
                   error=math.nan, steps=0)
        if case.raises is not None and isinstance(exc, case.raises):
            row["verdict"] = f"meets target (raises {type(exc).__name__}: {exc})"
        else:
            row["verdict"] = f"FAILS: {type(exc).__name__}: {exc}"
        return row
    seconds = time.perf_counter() - start
    end = ds.attrs["end_reason"]
    ok_finite = finite(ds)
    err = case.error(ds) if case.error is not None else math.nan
    row.update(seconds=seconds, end=end, finite=ok_finite, error=err,
               steps=int(ds.attrs["n_steps"]), t_stop=float(ds.event_t.values[-1]))
    within = case.error is None or err <= case.target
    if case.raises is not None:
        row["verdict"] = f"FAILS: did not raise {case.raises.__name__}"
    elif not ok_finite:
        row["verdict"] = "FAILS: non-finite output"
    elif end in case.expect and within:
        row["verdict"] = "meets target"
    elif end in case.stops and end in CLEAR_STOPS | {"max_events"}:
        row["verdict"] = (f"stops: {end} at t = {row['t_stop']:.3g} s "
                          f"({ds.attrs['end_message']})")
    elif end in case.expect:
        row["verdict"] = f"FAILS: error {err:.1e} over target {case.target:.0e}"
    else:
        row["verdict"] = (f"FAILS: ends with {end} at t = {row['t_stop']:.3g} s after "
                          f"{row['steps']} steps; expected {' or '.join(case.expect)}")
    return row


def table(rows) -> str:
    lines = ["| group | case | rtol | end reason | finite | error | target | steps | time | "
             "reference | verdict |",
             "|---|---|---:|---|---|---:|---:|---:|---:|---|---|"]
    for r in rows:
        err = ("other end" if math.isinf(r["error"]) else "-" if math.isnan(r["error"])
               else f"{r['error']:.1e}")
        tgt = "-" if not math.isfinite(r["target"]) else f"{r['target']:.0e}"
        lines.append(f"| {r['group']} | {r['name']} | {r['rtol']:.0e} | {r['end']} | "
                     f"{'yes' if r['finite'] else '**no**'} | {err} | {tgt} | {r['steps']} | "
                     f"{r['seconds']:.3f} s | {r['reference']} | {r['verdict']} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    phasemap.simulate("hinge_pendulum", 1.0)  # load the kernels
    rows = []
    for case in cases():
        row = run(case)
        rows.append(row)
        print(f"{row['group']:22s} {row['name']:55s} {row['end']:14s} {row['verdict']}",
              flush=True)
    met = sum(r["verdict"].startswith("meets") for r in rows)
    stopped = sum(r["verdict"].startswith("stops") for r in rows)
    failed = [r for r in rows if r["verdict"].startswith("FAILS")]
    lines = [
        "## Stability (`benchmarks/stability.py`)",
        "",
        f"Machine: {machine()}.",
        "Each case runs `phasemap.simulate`; *error* is against the reference named "
        "(`phase_curve` is the first-integral tracer: exponential Gauss collocation in phi, "
        "order 12, on the model's branch rows); it is the largest difference "
        "of the end state (phi, omega) unless said otherwise. *finite*: every floating-point "
        "variable of the returned Dataset is finite.",
        "",
        table(rows),
        "",
        f"{met} cases meet their target, {stopped} stop with a clear reason, "
        f"{len(failed)} fail.",
        "",
    ]
    if failed:
        lines += ["Failures:", ""]
        for r in failed:
            lines.append(f"- {r['group']}, {r['name']} (rtol {r['rtol']:.0e}): {r['verdict']}")
        lines.append("")
    publish(lines, "## Stability", write=not args.no_write)


if __name__ == "__main__":
    main()
