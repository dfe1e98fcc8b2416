"""Declared rows against hand rows, per integrator step (issue 22, target 4's last bullet).

The wheel's fate-map integrator (DOPRI5, rtol 1e-6, as ``Scene(..., layers=fate)``
runs it) on the same random cells, with the declared model (what ``wheel`` runs)
and the hand module (``references.wheel.MODEL``, tests/references/): nanoseconds per step on
one thread, and the physics of a step timed alone (one right-hand side: sin,
cos and the roll row; one classification of every row), from
``benchmarks/fate_map.py``'s ``step_profile``.  The two models alternate over
``--rounds`` rounds; each figure is the fastest of 5 runs within a round, and
the table gives the median over rounds.

    python benchmarks/declared_rows.py [--rounds 3] [--cells 1500]

Writes the section "Declared rows per step" of ../BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import pathlib
import shlex
import statistics
import sys

import numba

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from fate_map import step_profile  # noqa: E402
from _report import load, machine, publish  # noqa: E402
from grid import hand_model  # noqa: E402

import phasemap  # noqa: E402

FIELDS = {"step_ns": "ns per step", "fit_step_ns": "ns per step, fitted",
          "lean_ns": "lean DOPRI5, ns per step",
          "rhs_ns": "one right-hand side (ns)", "point_ns": "one classification (ns)",
          "after_ns": "the test after a step (ns)"}


def why(med: dict) -> str:
    """Where the declared rows' time goes, read in the generated code, with this run's
    ratios."""
    r = {f: med["declared"][f] / med["hand"][f] for f in FIELDS}
    return (
        "Where the time goes: the declared roll row (`mode_1` of the generated wheel "
        "module) forms phi'' as one quotient over the row's determinant, the paper's "
        "right-hand side over its bracket, and reads no reaction "
        "(`phasemap.declare.solvers.quotients`; it solved the reactions by Cramer's rule "
        "first and formed phi'' from them through the inverse mass matrix before: about "
        "117 multiplications and 5 divisions against the hand row's 30 and 1), so one "
        f"right-hand side costs {r['rhs_ns']:.2f}x the hand one and the lean DOPRI5 step "
        f"{r['lean_ns']:.2f}x.  After a step the integrator reads only whether the stage "
        "goes on (`GOES_ON` of `phasemap.motion.integrate.templates`; moving, the generated "
        "`moving` of `phasemap.core.codegen.moving_test`: the statuses of the rows of the "
        "velocity's direction and the stage's coefficient, no stores): "
        f"{r['after_ns']:.2f}x the hand test, for a moving wheel has two declared candidate "
        "rows (rolling, and leaving the floor, which the hand module folds into its rolling "
        "row's contact_lost test) against one, and the rolling row's status reads three "
        "reactions and their tie scales (6 divisions against 2: every tie is kept).  The "
        f"classification of every row ({r['point_ns']:.2f}x; 5 rows of 7 fields against 3 "
        "of 6) runs only at events.")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cells", type=int, default=1500)
    ap.add_argument("--fit-cells", type=int, default=100)
    ap.add_argument("--no-write", action="store_true", help="print only")
    a = ap.parse_args()
    numba.set_num_threads(1)
    models = {"declared": phasemap.get_model("wheel"), "hand": hand_model("wheel")}
    before = load()
    got = {k: [] for k in models}
    for _ in range(a.rounds):
        for k, m in models.items():
            got[k].append(step_profile(m, cells=a.cells, fit_cells=a.fit_cells))
    med = {k: {f: statistics.median(p[f] for p in v) for f in FIELDS} for k, v in got.items()}
    p = got["declared"][0]
    lines = [
        "## Declared rows per step (`benchmarks/declared_rows.py`)", "",
        f"Machine: {machine()}; load average {before} before, {load()} after.  ",
        "Command: `" + " ".join(shlex.quote(x) for x in
                                ["python", "benchmarks/declared_rows.py",
                                 *(x for x in sys.argv[1:] if x != "--no-write")]) + "`",
        "",
        f"The wheel's fate-map integrator on {a.cells} random cells (phi in [-pi, pi], omega "
        f"in [-6, 6], DOPRI5, rtol 1e-6; {p['steps_per_cell']:.0f} steps per cell), one "
        "thread, declared (`phasemap/systems/seeds/wheel.py`, what `wheel` runs) against "
        "hand (`tests/references/wheel.py`), alternating over "
        f"{a.rounds} rounds: medians of each round's fastest of 5.  *fitted*: least squares "
        f"on steps and events over {a.fit_cells} cells, each timed alone.  The right-hand "
        "side and the classification are timed alone, each call waiting for the last "
        "(`fate_map.step_profile`); the lean DOPRI5 is the same step and right-hand side "
        "with the step-size controller alone (`fate_map.lean_dopri5`).  CPU time.",
        "",
        "| | " + " | ".join(FIELDS.values()) + " |",
        "|---|" + "---:|" * len(FIELDS),
    ]
    for k in models:
        lines.append(f"| {k} ({len(models[k].branches)} rows) | " + " | ".join(f"{med[k][f]:.0f}" for f in FIELDS) + " |")
    lines.append("| declared / hand | " + " | ".join(
        f"{med['declared'][f] / med['hand'][f]:.2f}" for f in FIELDS) + " |")
    ratio = med["declared"]["step_ns"] / med["hand"]["step_ns"]
    lines += ["", f"Target 4 (declared rows no slower per step than the hand ones): "
              f"{'met' if ratio <= 1.0 else f'**missed** ({ratio:.2f}x per step)'}.", "",
              why(med), ""]
    publish(lines, "## Declared rows per step", write=not a.no_write)


if __name__ == "__main__":
    main()
