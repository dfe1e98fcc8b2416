"""Motion through contact changes: what a flight step costs, and error against CPU time.

* **Per step.** The frictionless ladder (2l = 1 m, released 60 degrees from the floor)
  slides on both contacts, then flies off the wall with its foot on the floor.  The
  contact step is the reduced model's compiled integrator (``simulate`` with
  ``through_contacts=False`` to the release, ``max_step`` small so that steps dominate);
  the flight step is the full-coordinate integrator (:mod:`phasemap.motion.hybrid`, its
  compiled flow) from the release to the ladder lying flat, and the same on the flow's
  interpreted twins (``PHASEMAP_JIT=off``: what a motion runs on while the flow's kernels
  are first compiled, and what every flight step cost before they were).  CPU time per
  accepted step, medians.
* **Error against CPU time.** The release angle against the closed form
  sin theta_s = (2/3) sin 60 degrees, and the time the ladder lies flat against the
  issue's 0.485174 s (to 1e-6, its printed digits) and against the tightest run,
  per ``rtol``, for the public call ``simulate``.
* **Zeno.** The ball dropped from 1 m with e = 0.5: the accumulation time against
  sqrt(2 h / g) (1 + e) / (1 - e), its impacts and its CPU time.

Writes the section "Motion through contact changes" of ../BENCHMARKS.md.

    python benchmarks/contacts.py [--repeat 7] [--no-write]
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

import _report
import phasemap
from phasemap.core import tiers
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System
from phasemap.declare.full import mechanics
from phasemap.motion import hybrid

G = 9.81
PHI0 = math.radians(30.0)
THETA_S = math.asin(2.0 / 3.0 * math.sin(math.radians(60.0)))


def cpu(fn):
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def ball() -> System:
    m = Parameter("m", "kg", "mass", 1.0, 0.0, lower_open=True)
    g = Parameter("g", "m s-2", "gravitational acceleration", G, 0.0)
    f = Parameter("f", "1", "friction coefficient", 0.3, 0.0)
    x = Coordinate("x", "m", "position", rate=Rate("vx", "m s-1", "velocity"))
    y = Coordinate("y", "m", "height")
    return System("ball", "A ball on a floor", "-", coordinates=(x, y), parameters=(m, g, f),
                  bodies=(Body(m, (x, y)),), potential=m * g * y,
                  contacts=(PointContact("floor", (x, y), friction=f),))


def per_step(repeat: int) -> list[str]:
    ladder = dict(phi=PHI0, omega=0.0, f=0.0, l=0.5)
    with tiers.forced("eager"):      # compiled here, not on the twins meanwhile
        phasemap.simulate("ladder", t_end=1.0, through_contacts=False, **ladder)
        phasemap.simulate("ladder", t_end=1.0, **ladder)
    contact = []
    for _ in range(repeat):
        sec, ds = cpu(lambda: phasemap.simulate("ladder", t_end=1.0, rtol=1e-10,
                                                max_step=1e-4, through_contacts=False,
                                                **ladder))
        contact.append(sec / int(ds.attrs["n_steps"]))
    full = phasemap.simulate("ladder", t_end=1.0, rtol=1e-10, **ladder)
    at = [int(k) for k in full.event_kind.values].index(phasemap.Event.LIFTOFF)
    S = phasemap.get_model("ladder").declaration
    S = getattr(S, "system", S)
    mech = mechanics(S)
    p = np.array([{"f": 0.0, "l": 0.5, "g": G, "m": 1.0}[k] for k in mech.parameters])
    names = list(mech.coordinates) + list(mech.rates)
    y = np.array([float(full[f"event_{n}"][at]) for n in names])
    flight, twin = [], []
    for _ in range(repeat):
        sec, rec = cpu(lambda: hybrid.run_full(
            mech, p, y[:3], y[3:], t0=float(full.event_t[at]), t_end=1.0, rtol=1e-10,
            atol=1e-10, max_step=1e-4, max_steps=10**6, max_events=100))
        flight.append(sec / rec.n_steps)
    with tiers.forced("off"):
        for _ in range(max(1, repeat // 3)):
            sec, rec_twin = cpu(lambda: hybrid.run_full(
                mech, p, y[:3], y[3:], t0=float(full.event_t[at]), t_end=1.0, rtol=1e-10,
                atol=1e-10, max_step=1e-4, max_steps=10**6, max_events=100))
            twin.append(sec / rec_twin.n_steps)
    c, f_, tw = statistics.median(contact), statistics.median(flight), statistics.median(twin)
    return [
        "| step | CPU per accepted step | steps |",
        "|---|---|---|",
        f"| contact (reduced, compiled DOPRI5, `max_step=1e-4`) | {c * 1e6:.1f} µs | "
        f"{int(ds.attrs['n_steps'])} |",
        f"| flight (full coordinates, the compiled flow's DOP853, `max_step=1e-4`) | "
        f"{f_ * 1e6:.1f} µs | {rec.n_steps} |",
        f"| flight on the interpreted twins (`PHASEMAP_JIT=off`) | {tw * 1e6:.0f} µs | "
        f"{rec_twin.n_steps} |",
        "",
        f"A flight step costs **{f_ / c:.0f}×** a contact step, and the compiled flow is "
        f"{tw / f_:.0f}× its interpreted twin (the same bits). A flight step takes 13 "
        "solves of its phase (DOP853's 12 stages and the events at the step's end), the "
        "contact step 6 right-hand sides (DOPRI5, first same as last), so a solve costs "
        f"about {f_ / c * 6 / 13:.0f}× a reduced right-hand side: it runs the "
        "declaration's functions at the addresses of their machine code (not inlined), "
        "solves the phase by a small LU and forms the reactions, where the reduced "
        "model's equations are solved in closed form and inlined. Since 2026-12-02 the "
        "flow's kernels run without numba's reference counts (`flow.ALLOCATING`), which "
        "halved a flight step (7.8-8.8 µs before, the same bits), and its LU factors "
        "and substitutions run with the size a constant up to 4 (`flow._lu`), which LLVM "
        "unrolls (3.3-3.4 µs before, the same bits). The step timed is the ladder's after "
        "its release, in full coordinates: the top free, the foot sliding on the floor "
        "(one reaction in each solve). The issue's target (a flight step no dearer than a "
        "contact step) is not met; it is open.",
    ]


def precision(repeat: int) -> list[str]:
    rows = ["| rtol | release angle error (rad) | t flat (s) | error vs 0.485174 | "
            "CPU per call |", "|---|---|---|---|---|"]
    best = None
    for rtol in (1e-6, 1e-8, 1e-10, 1e-12):
        secs = []
        for _ in range(repeat):
            sec, ds = cpu(lambda: phasemap.simulate("ladder", t_end=1.0, rtol=rtol, phi=PHI0,
                                                    omega=0.0, f=0.0, l=0.5))
            secs.append(sec)
        at = [int(k) for k in ds.event_kind.values].index(phasemap.Event.LIFTOFF)
        err = abs((math.pi / 2 - float(ds.event_phi[at])) - THETA_S)
        t_flat = float(ds.event_t[-1])
        best = t_flat
        rows.append(f"| {rtol:g} | {err:.1e} | {t_flat:.9f} | {abs(t_flat - 0.485174):.1e} | "
                    f"{statistics.median(secs) * 1e3:.1f} ms |")
    rows += ["", f"The tightest run lies flat at t = {best:.12f} s."]
    return rows


def zeno(repeat: int) -> list[str]:
    S = ball()
    e, h0 = 0.5, 1.0
    exact = math.sqrt(2 * h0 / G) * (1 + e) / (1 - e)
    secs = []
    for _ in range(repeat):
        sec, ds = cpu(lambda: phasemap.simulate(S, t_end=3.0, rtol=1e-12, restitution=e,
                                                y=h0))
        secs.append(sec)
    impacts = int((ds.event_kind == phasemap.Event.IMPACT).sum())
    return [f"The ball dropped from {h0:g} m with e = {e:g} comes to rest at "
            f"t = {float(ds.event_t[-1]):.12f} s; the closed form is {exact:.12f} s "
            f"(error {abs(float(ds.event_t[-1]) - exact):.1e} s). It takes {impacts} impacts "
            f"before the `zeno` event and {statistics.median(secs) * 1e3:.0f} ms of CPU time."]


def main() -> None:
    ap = _report.parser(__doc__)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    lines = ["## Motion through contact changes (`benchmarks/contacts.py`)", "",
             f"Machine: {_report.machine()}; load {_report.load()}.  ",
             f"Command: `python benchmarks/contacts.py --repeat {args.repeat}`", "",
             "CPU time (`time.process_time`) of one thread (a motion is serial), medians "
             f"of {args.repeat} runs, compilation excluded. The contact step is timed at "
             "the public call (`simulate`); the flight step at the motion in full "
             "coordinates that `simulate` runs after the release (`hybrid.run_full`, "
             "without the Dataset).", "",
             "### What a flight step costs", ""]
    lines += per_step(args.repeat)
    lines += ["", "### The ladder's release and landing, error against CPU time "
              "(`simulate`)", ""]
    lines += precision(args.repeat)
    lines += ["", "### Zeno", ""]
    lines += zeno(args.repeat)
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        _report.write_section(text, "## Motion through contact changes")


if __name__ == "__main__":
    main()
