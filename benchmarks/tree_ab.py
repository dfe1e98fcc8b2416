"""Two checkouts of phasemap, A against B, on the calls users make: did a refactoring
change the compiled kernels' speed?

Each figure is the CPU time of one public call in a process of its own (one numba
thread, warm caches, compilation excluded by a first call), the two trees alternating
A B A B so that the machine's drift falls on both; the table gives each tree's median
and the median of the paired ratios B/A.  The calls:

* ``Scene.compute()`` of the ``n_solutions`` layer on a 1024^2 map of the ladder, the
  hinge pendulum and the Painleve rod (the grid kernels and the parallel driver);
* ``simulate`` of the hinge pendulum (rtol 1e-10, 200 s), of the elliptic pendulum and
  of the wheel (the integrator, DOPRI5 and DOP853);
* a 64^2 fate map of the hinge pendulum (the fate driver);
* ``phase_curve`` of the hinge pendulum (the phase tracer);
* ``boundaries`` of the rod's first-paradox slice (the bifurcation tracer), and the trace
  alone (``tracing.trace``: seeding, marching, the check raster) of the five slices of
  ``benchmarks/boundaries.py``, 20 times each: a boundaries call is mostly Python.

    python benchmarks/tree_ab.py --a ../before --b . [--repeat 5] [--no-write]

Each tree compiles into kernel and numba caches of its own (under the system temp
folder) at numba's default optimisation, in the timed process (``PHASEMAP_JIT=eager``).
Writes the section "Before and after a refactoring" of ../BENCHMARKS.md.
"""

from __future__ import annotations

import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _report import load, machine, parser, write_section  # noqa: E402

CALLS = {
    "map ladder 1024^2": "phasemap.Scene('ladder', axes={'phi': np.linspace(0.01, 1.55, 1024), "
                         "'f': np.linspace(0, 3, 1024)}, fixed={'omega': 1.0}, "
                         "layers=['n_solutions']).compute()",
    "map hinge 1024^2": "phasemap.Scene('hinge_pendulum', axes={'phi': np.linspace(-3, 3, 1024), "
                        "'delta': np.linspace(0, 1.5, 1024)}, fixed={'omega': 1.0}, "
                        "layers=['n_solutions']).compute()",
    "map rod 1024^2": "phasemap.Scene('painleve_rod', axes={'theta': np.linspace(0.05, 1.5, 1024), "
                      "'f': np.linspace(0, 3, 1024)}, fixed={'omega': 1.0, 'xdot': -1.0}, "
                      "layers=['n_solutions']).compute()",
    "simulate hinge DOPRI5": "phasemap.simulate('hinge_pendulum', phi=2.5, omega=0.0, "
                             "delta=0.01, t_end=200.0, rtol=1e-10)",
    "simulate hinge DOP853": "phasemap.simulate('hinge_pendulum', phi=2.5, omega=0.0, "
                             "delta=0.01, t_end=200.0, rtol=1e-12, method='DOP853')",
    "simulate elliptic": "[phasemap.simulate('elliptic_pendulum', t_end=30.0, phi=1.0, "
                         "omega=0.0, xdot=1.0, f=0.3, rtol=1e-10) for _ in range(20)]",
    "simulate wheel": "[phasemap.simulate('wheel', phi=1.0, omega=2.0, t_end=20.0, "
                      "rtol=1e-10) for _ in range(20)]",
    "fate map hinge 64^2": "phasemap.Scene('hinge_pendulum', axes={'phi': np.linspace(-3, 3, 64), "
                           "'omega': np.linspace(-6, 6, 64)}, layers=['fate'], "
                           "options={'t_end': 30.0}).compute()",
    "phase_curve hinge": "[phasemap.phase_curve('hinge_pendulum', phi=2.5, omega=0.0, "
                         "delta=0.01) for _ in range(5)]",
    "boundaries rod": "phasemap.boundaries('painleve_rod', {'theta': (0.2, 1.5), 'f': (0, 3)}, "
                      "fixed={'xdot': -1.0, 'omega': 0.0})",
    "trace 5 slices x 20": "[tracing.trace(tracing.make_slice(m, a, f), ly, 1e-10) for m, a, f, ly in "
                           "[('painleve_rod', {'theta': (0.2, 1.5), 'f': (0.0, 3.0)}, "
                           "{'xdot': -1.0, 'omega': 0.0}, 'n_solutions'), "
                           "('elliptic_pendulum', {'phi': (-3.14159, 3.14159), 'f': (0.0, 6.0)}, "
                           "{'xdot': 1.0, 'omega': 0.0}, 'n_solutions'), "
                           "('ladder', {'phi': (0.05, 1.5), 'f': (0.05, 3.0)}, {'omega': 0.0}, "
                           "'stagnation'), "
                           "('hinge_pendulum', {'phi': (-3.0, 3.0), 'delta': (0.05, 1.4)}, "
                           "{'omega': 0.0}, 'stagnation'), "
                           "('wheel', {'phi': (-3.14159, 3.14159), 'delta': (0.0, 1.0)}, "
                           "{'omega': 0.0}, 'stagnation')] for _ in range(20)]",
}

CHILD = """
import json, sys, time, warnings
import numba, numpy as np
numba.set_num_threads(1)
import phasemap
from phasemap.bifurcation import tracing
warnings.simplefilter("ignore")
call = compile(sys.argv[1], "call", "eval")
eval(call)  # compiles (or loads) what the call needs
best = []
for _ in range(3):
    t = time.process_time()
    eval(call)
    best.append(time.process_time() - t)
print(json.dumps({"cpu": min(best), "file": phasemap.__file__}))
"""


def run(tree: pathlib.Path, call: str, cache: str) -> float:
    # each tree its own kernel and numba caches (two versions of phasemap that share a
    # kernel cache may write its files by turns), and numba compiles in the process, not
    # in a background one while the interpreted twins answer (phasemap.core.tiers)
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=cache,
               PHASEMAP_CACHE_DIR=str(pathlib.Path(cache) / "kernels"), PHASEMAP_JIT="eager")
    env.pop("NUMBA_OPT", None)
    out = subprocess.run([sys.executable, "-c", CHILD, call], env=env, check=True,
                         capture_output=True, text=True, cwd=tempfile.gettempdir())
    got = json.loads(out.stdout.strip().splitlines()[-1])
    if not got["file"].startswith(str(tree)):
        raise RuntimeError(f"{tree}: imported phasemap from {got['file']}")
    return got["cpu"]


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--a", required=True, help="the tree before (a checkout's root)")
    ap.add_argument("--b", required=True, help="the tree after")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    trees = {k: pathlib.Path(getattr(args, k)).resolve() for k in ("a", "b")}
    caches = {k: str(pathlib.Path(tempfile.gettempdir()) / f"phasemap-ab-{k}") for k in trees}
    rows = []
    for name, call in CALLS.items():
        t = {"a": [], "b": []}
        for k in trees:  # warm: compile outside the timings
            run(trees[k], call, caches[k])
        for _ in range(args.repeat):
            for k in ("a", "b"):
                t[k].append(run(trees[k], call, caches[k]))
        ratio = statistics.median(b / a for a, b in zip(t["a"], t["b"]))
        rows.append((name, statistics.median(t["a"]), statistics.median(t["b"]), ratio))
        print(f"{name:24s} A {rows[-1][1]:8.3f} s  B {rows[-1][2]:8.3f} s  B/A {ratio:.3f}",
              flush=True)
    lines = ["## Before and after a refactoring (`benchmarks/tree_ab.py`)", "",
             f"Machine: {machine()}; load {load()} at the end.  A = `{trees['a'].name}`, "
             f"B = `{trees['b'].name}`; CPU seconds of one call on one numba thread, warm "
             f"caches, best of 3 per process, median of {args.repeat} processes per tree "
             "alternating; B/A the median of the paired ratios.", "",
             f"Command: `python benchmarks/tree_ab.py --a {trees['a']} --b . "
             f"--repeat {args.repeat}`", "",
             "| call | A (s) | B (s) | B/A |", "| --- | ---: | ---: | ---: |"]
    lines += [f"| {n} | {a:.3f} | {b:.3f} | {r:.3f} |" for n, a, b, r in rows]
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        write_section(text, "## Before and after a refactoring")


if __name__ == "__main__":
    main()
