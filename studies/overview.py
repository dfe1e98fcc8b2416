"""Overview: error against run time of every solver, and a fate map of the wheel.

Two figures a reader of the paper meets first:

* **work-precision**: for the weightless hinge pendulum (exact reference, eq.
  (36)) and the hinge pendulum swinging to rest through reversals (tight
  reference), the dimensionless error along the motion (each component over
  its peak) against the run time per trajectory, for phasemap's two
  Dormand-Prince integrators beside SciPy's (RK45, DOP853) driven stage by
  stage, and the first-integral tracer at the same tolerances
  (``benchmarks/work_precision.py`` runs every system and method);
* **fate map**: how the wheel's motion from each initial (phi, omega) ends, at
  delta/l = 0.2: at rest in a stagnation zone, and how long that takes, or
  bouncing off the floor (contact lost, condition (12)).

    python studies/overview.py [--quick] [--out DIR]

Ends with a table of the claims checked.
"""

from __future__ import annotations

import math

import numpy as np

import phasemap
from phasemap.claims import threshold_claims
from phasemap.motion import workprecision as wp
from phasemap.study import Claim, arguments, finish, save_atlas, save_figures, verdict

NAME = "overview"


#: The methods of the work-precision figure: each phasemap integrator beside its SciPy
#: counterpart (the same Dormand-Prince pair), and the first-integral tracer.
PAIRS = ("phasemap", "RK45", "phasemap_DOP853", "DOP853")
METHODS = PAIRS + ("phase_curve",)
#: The figure's error: dimensionless (each component over its peak along the reference
#: motion), so that rad and rad s-1 are never added (phasemap.motion.workprecision).
ERROR = "error_scaled_l2"


def work_precision_figure(rows, size):
    """The scaled L2 error along the motion against run time per trajectory (per curve for
    the first-integral tracer, whose error is of omega^2 at its own phi)."""
    drawn = [r for r in rows if not r.get("skipped") and r["method"] in METHODS]
    n_save = wp.PROBLEMS[rows[0]["system"]].n_save
    key = [rf"$L_2$ error: RMS of $\Delta y_i/\hat y_i$ over $\varphi$, $\omega$ and "
           rf"{n_save} times",
           r"first integrals: of $\Delta(\omega^2)/\hat\omega^2$ at their own $\varphi$, "
           "one marker per rtol (" + ", ".join(
               rf"$10^{{{round(math.log10(t))}}}$" for t in sorted(
                   {r["tol"] for r in drawn if r["method"] == "phase_curve"}, reverse=True))
           + ")"]
    return phasemap.plot.work_precision_figure(drawn, size=size, error=ERROR, key=key)


def work_precision_rows(quick: bool) -> list[dict]:
    """The sweep of the figure, its table and its claims: one source for all three."""
    if quick:
        # five timing rounds: the figure plots the fastest, so noise cannot zig-zag a line
        tolerances, repeats = (1e-4, 1e-7, 1e-10), 5
    else:
        tolerances, repeats = wp.DEFAULT_TOLERANCES, 3
    rows = []
    for name in ("hinge_weightless", "hinge_pendulum"):
        rows += wp.work_precision(wp.PROBLEMS[name], tolerances=tolerances, methods=METHODS,
                                  repeats=repeats, min_time=0.002 if quick else 0.02,
                                  budget=10.0)
    return rows


def main(argv=None) -> list[Claim]:
    args = arguments(__doc__, argv)
    out, files, claims = args.out, [], []

    # -- work-precision ------------------------------------------------------
    rows = work_precision_rows(args.quick)
    files += save_figures(lambda size: work_precision_figure(rows, size), out,
                          f"{NAME}_work_precision", args.sizes)
    (out / f"{NAME}_work_precision.md").write_text(wp.report(rows, error=ERROR) + "\n")
    files.append(out / f"{NAME}_work_precision.md")

    for name in ("hinge_weightless", "hinge_pendulum"):
        mine = [r for r in rows if r["system"] == name and r["method"] == "phasemap"
                and not r.get("skipped")]
        best = min(r["error_scaled_final"] for r in mine)
        tight = min(r["tol"] for r in mine)
        claims.append(Claim(f"{name}: phasemap integrator converges (error at rtol {tight:g}, "
                            "each component over its peak)",
                            "-", f"{best:.1e}", verdict(best < 1e3 * tight, "finding")))
        level = 1e-6
        ratio, rival = wp.equal_error_ratio(rows, name, level, error=ERROR)
        if math.isfinite(ratio):
            print(f"{name}: at error {level:g} the compiled integrator is {ratio:.0f}x faster "
                  f"per trajectory than the best solve_ivp method ({rival})")
    weightless = [r for r in rows if r["system"] == "hinge_weightless"
                  and r["method"] == "phasemap" and not r.get("skipped")]
    least = min(r["error_scaled_final"] for r in weightless)
    claims.append(Claim("weightless hinge pendulum follows (36) exactly",
                        "omega = omega0/(1 + k|omega0| t)",
                        f"error {least:.1e} (each component over its peak)",
                        verdict(least < 1e-8)))

    # -- fate map of the wheel -------------------------------------------------
    n = 240 if args.quick else 400  # a cell under 3 px at 300 dpi: no visible stair-steps
    scene = phasemap.Scene("wheel", axes={"phi": np.linspace(-math.pi, math.pi, n),
                                          "omega": np.linspace(-8.0, 8.0, n)},
                           fixed={"delta": 0.1},  # delta/l = 0.2: not the wheel study's
                           layers=["fate", "phi_rest", "n_reversals", "t_rest"],
                           options={"t_end": 60.0})
    fates = scene.compute()   # a bar where a terminal watches, none in a log
    files.append(save_atlas(fates, out, f"{NAME}_wheel_fates", NAME))
    files += save_figures(lambda size: phasemap.plot.fate_figure(fates, extra="t_rest",
                                                                 size=size),
                          out, f"{NAME}_wheel_fates", args.sizes)

    rest = fates.fate == phasemap.Event.REST
    p = scene.fixed
    inside = np.abs(np.sin(fates.phi_rest.where(rest))) * p["l"] <= p["delta"] * (1 + 1e-9)
    claims.append(Claim("wheel stops only inside its stagnation zones (15)",
                        "l |sin phi| <= delta", f"{int(inside.sum())} of {int(rest.sum())} rest "
                        "cells inside", verdict(bool(inside.sum() == rest.sum()))))
    kinds = sorted({phasemap.Event(int(k)).name.lower() for k in np.unique(fates.fate)})
    claims.append(Claim("every motion ends at rest, in a hop, or where rolling would pull "
                        "and a hop is inconsistent (no_solution), within 60 s",
                        "-", ", ".join(kinds),
                        verdict(set(kinds) <= {"rest", "contact_lost", "no_solution"},
                                "finding")))
    claims += threshold_claims("painleve_rod")  # exact, beside the closed form
    finish("overview", claims, files)
    return claims


if __name__ == "__main__":
    main()
