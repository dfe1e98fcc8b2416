"""A new declaration's first calls from empty caches: derivation, classify, map, boundaries.

For each declaration a fresh process, with an empty kernel cache
(``PHASEMAP_CACHE_DIR``) and an empty numba cache (``NUMBA_CACHE_DIR``) of its own,
at numba's default optimisation (what a user's process compiles), runs in turn

* *derive*: ``System.model``: sympy's derivation and the generated module's text;
* *first classify*: one ``phasemap.classify`` at the declaration's defaults;
* *first map*: a 64 x 64 ``n_solutions`` Scene over the slice below;
* *first boundaries*: ``phasemap.boundaries`` over the same slice;
* *boundaries, second slice*: the same axes at another velocity (moving where the first
  is at rest, or the other way): only the derivatives of the conditions that can bound
  a class there are compiled (:func:`phasemap.bifurcation.tracing.make_slice`);
* *first threshold on a line*: the least f at which a class exists, on a line of f (Newton
  on the conditions' values and gradients in f, called from Python);

and reports each step's wall and CPU time (the process's user + system time), and
the compile time numba spent in it, per kind of compiled function (the conditions
module, the tracer's shared drivers, the model's own point and class functions).
The shared drivers (the grid driver, the tracer) are compiled once per machine and
shared by every model; a second declaration pays only its own functions and its
conditions (the columns *conditions* and *own*).

The declarations: the README's rod (``docs/examples/own_system.py``, one contact), the
drawer in a slot and the rod on a peg (``tests/unseen.py``, two contacts each, issue 37).

    python benchmarks/first_calls.py [--only NAME ...] [--jobs 2]

``--jobs 2`` runs two declarations at once (one core each: numba compiles on one
thread); the CPU columns are the steadier figures then.  Writes the section "First
calls of a new declaration" of ../BENCHMARKS.md.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

from _report import background_quiet, child_result, load, machine, parser, publish

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: name -> (the code that makes the System, the slice (two axes, ranges), fixed values,
#: the fixed values of a second slice on the same axes, moving where the first is at rest,
#: and a threshold of f on a line: its layer, value and fixed values)
CASES = {
    "README rod": ("sys.path.insert(0, str(ROOT / 'docs' / 'examples'))\n"
                   "from own_system import SYSTEM as S",
                   {"theta": (0.05, 1.5), "f": (0.0, 2.0)}, {"omega": 0.0, "xdot": -1.0},
                   {"omega": 0.0, "xdot": 1.0},
                   ("n_solutions", 0, {"omega": 0.0, "xdot": -1.0, "theta": 1.1071487177940904})),
    "drawer": ("sys.path.insert(0, str(ROOT / 'tests'))\nimport unseen\nS = unseen.drawer()",
               {"d": (-1.0, 1.0), "f": (0.0, 2.0)}, {"xdot": 0.0}, {"xdot": 0.5},
               ("stagnation", 1, {"xdot": 0.0, "d": 0.3})),
    "peg rod": ("sys.path.insert(0, str(ROOT / 'tests'))\nimport unseen\nS = unseen.peg_rod()",
                {"theta": (0.05, 0.95), "f": (0.0, 2.0)}, {"omega": 0.0}, {"omega": 0.5},
                ("stagnation", 1, {"omega": 0.0, "theta": 0.5})),
}

CHILD = r'''
import json, pathlib, resource, sys, time
ROOT = pathlib.Path({root!r})
from numba.core import dispatcher

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

compiles = []
_orig, _depth = dispatcher.Dispatcher.compile, [0]

def _timed(self, sig):
    t = time.perf_counter()
    _depth[0] += 1
    try:
        return _orig(self, sig)
    finally:
        _depth[0] -= 1
        if _depth[0] == 0:
            compiles.append((self.py_func.__module__, self.py_func.__name__,
                             time.perf_counter() - t))

dispatcher.Dispatcher.compile = _timed
steps, marks = [], [(time.perf_counter(), cpu(), 0)]

def mark(name):
    now = (time.perf_counter(), cpu(), len(compiles))
    w0, c0, k0 = marks[-1]
    kinds = {{}}
    own = getattr(globals().get("S"), "name", None) or "\0"
    for module, fname, dt in compiles[k0:]:
        # a model's own: its generated modules, and the drivers specialised to it
        # (named after it: the tracer's class function, the integrator)
        kind = ("conditions" if "_conditions_" in module or "_condvalues_" in module else
                "own" if not module.startswith("phasemap.") or own in fname else
                "shared")
        kinds[kind] = kinds.get(kind, 0.0) + dt
    steps.append(dict(step=name, wall=now[0] - w0, cpu=now[1] - c0, compile=kinds))
    marks.append(now)

import numpy as np
import phasemap
mark("import phasemap")
{make}
m = S.model
mark("derive")
phasemap.classify(m)
mark("first classify")
axes = {axes!r}
fixed = {fixed!r}
phasemap.Scene(m, axes={{k: np.linspace(a, b, 64) for k, (a, b) in axes.items()}},
               fixed=fixed, layers=("n_solutions",)).compute()
mark("first map")
phasemap.boundaries(m, axes, fixed=fixed)
mark("first boundaries")
phasemap.boundaries(m, axes, fixed={moving!r})
mark("boundaries, second slice")
layer, value, line = {line!r}
phasemap.threshold(m, "f", layer=layer, value=value, over={{"f": (0.0, 2.0)}}, fixed=line)
mark("first threshold on a line")
print("RESULT " + json.dumps(steps))
'''


def run(name: str) -> list[dict]:
    make, axes, fixed, moving, line = CASES[name]
    with tempfile.TemporaryDirectory() as tmp:
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_OPT",)}
        env.update(PHASEMAP_CACHE_DIR=str(pathlib.Path(tmp) / "kernels"),
                   NUMBA_CACHE_DIR=str(pathlib.Path(tmp) / "numba"), MPLBACKEND="Agg")
        code = CHILD.format(root=str(ROOT), make=make, axes=axes, fixed=fixed,
                            moving=moving, line=line)
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, cwd=tmp)
        # the background compiles it started write into the caches until they end
        background_quiet(pathlib.Path(tmp) / "kernels")
    return child_result(out, name)


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--only", nargs="*", choices=list(CASES), default=list(CASES))
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    before = load()
    with ThreadPoolExecutor(args.jobs) as pool:
        results = dict(zip(args.only, pool.map(run, args.only)))
    lines = [
        "## First calls of a new declaration (`benchmarks/first_calls.py`)",
        "",
        f"Machine: {machine()}; load average {before} before, {load()} after.  ",
        f"Command: `python benchmarks/first_calls.py --jobs {args.jobs}`",
        "",
        "A fresh process per declaration with empty kernel and numba caches, at numba's "
        "default optimisation; each step's wall and CPU time (s), and the compile time "
        "numba spent in it: the conditions modules (every condition's values, once per "
        "declaration; exact gradients in the slice's axes of the conditions that can bound "
        "a class in it, and the Hessian by differences), the drivers every model shares (compiled once per machine), "
        "and the model's own functions.  A second declaration pays its own functions "
        "and its conditions, not the shared drivers.  Under `PHASEMAP_JIT=background` (the "
        "default) the first classify is the interpreted twin, and a background process "
        "compiles the point function meanwhile (its CPU is not in the CPU column); the first "
        "map compiles the branch rows it calls beside it, on the other core.  The first "
        "boundaries runs on the tracer's interpreted twins, with the conditions and the "
        "class function as theirs where they are not yet compiled, while background "
        "processes compile them all (2026-12-02; before, the README rod's first boundaries "
        "took 29.6 s of CPU, 28.4 of them compiling the tracer, the drawer's 28.1 s, the "
        "peg rod's 15.4 s): what is left is the twins' arithmetic and sympy's printing of "
        "the conditions (the drawer's 62: most of its first boundaries).  A threshold on "
        "a line calls the conditions from Python, on their twins too until they are built "
        "(the drawer's first one took 30.9 s of CPU before, 14 of them compiling).",
        "",
        "| declaration | step | wall | CPU | compile: conditions | shared drivers | own |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for name, steps in results.items():
        for s in steps:
            c = s["compile"]
            lines.append(f"| {name} | {s['step']} | {s['wall']:.1f} | {s['cpu']:.1f} | "
                         f"{c.get('conditions', 0.0):.1f} | {c.get('shared', 0.0):.1f} | "
                         f"{c.get('own', 0.0):.1f} |")
    publish(lines, "## First calls of a new declaration", not args.no_write)


if __name__ == "__main__":
    main()
