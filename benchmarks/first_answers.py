"""A first classify and simulate from empty caches: machine code first, or the interpreter tier.

For each built-in model, and the README's own declared rod, a fresh process with an
empty kernel cache (``PHASEMAP_CACHE_DIR``) and an empty numba cache (``NUMBA_CACHE_DIR``)
of its own, at numba's default optimisation, runs

    import phasemap
    phasemap.classify(MODEL)          # at the model's defaults
    phasemap.simulate(MODEL, 5.0)

under ``PHASEMAP_JIT=eager`` (numba compiles the point function first, as before issue 40)
and under ``PHASEMAP_JIT=background`` (the default: the interpreted twin answers, and a
separate low-priority process compiles into the cache).  Reported: the process's wall time
and CPU time (user + system; a background compile runs in a session of its own, so it is
not counted), each call alone, how long numba compiled in the process, and, for
``background``, how long the background compiles took to leave machine code in the cache
and what a second process's calls then cost.  Rows run one at a time, and each waits
for its background compile to end, so none competes with the next.

    python benchmarks/first_answers.py [--only NAME ...]

Writes the section "First answers from empty caches" of ../BENCHMARKS.md.
"""

from __future__ import annotations

import json
import os
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

from _report import background_quiet, child_result, load, machine, parser, publish

ROOT = pathlib.Path(__file__).resolve().parents[1]
MODELS = ("ladder", "wheel", "elliptic_pendulum", "hinge_pendulum", "painleve_rod",
          "rod_on_step", "README rod")
TARGET = 1.5
#: a new declaration's first classify, sympy's derivation included (one contact)
DECLARED_TARGET = 3.0
SIMULATE_TARGET = 5.0

CHILD = r'''
import json, sys, time
t0 = time.perf_counter()
import phasemap
from phasemap.core import compiletime
model = {model!r}
if model == "README rod":
    model = phasemap.get_model({readme!r})
t1 = time.perf_counter()
c = phasemap.classify(model)
t2 = time.perf_counter()
import resource
r = resource.getrusage(resource.RUSAGE_SELF)
to_classify = r.ru_utime + r.ru_stime
k = compiletime.seconds()
ds = phasemap.simulate(model, 5.0)
t3 = time.perf_counter()
m = phasemap.get_model(model)
print("RESULT " + json.dumps(dict(classify=t2 - t1, compile=k, simulate=t3 - t2,
                                  to_classify=to_classify,
                                  simulate_compile=compiletime.seconds() - k,
                                  machine=bool(m.point.signatures), n=c.n_solutions,
                                  points=ds.sizes["t"], end=ds.attrs["end_reason"])))
'''


def child(model: str, jit: str, env: dict) -> dict:
    code = CHILD.format(model=model, readme=str(ROOT / "docs" / "examples" / "own_system.py"))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", code], env={**env, "PHASEMAP_JIT": jit},
                         capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    got = child_result(out, f"{model} ({jit})")
    got.update(wall=wall, cpu=(after.ru_utime - before.ru_utime)
               + (after.ru_stime - before.ru_stime))
    return got


def row(model: str) -> dict:
    result = {}
    for jit in ("eager", "background"):
        # a leftover file of a compile that ended as the folder went is no error
        with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as tmp:
            env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_OPT",)}
            kernels = pathlib.Path(tmp) / "kernels"
            env.update(PHASEMAP_CACHE_DIR=str(kernels), NUMBA_CACHE_DIR=str(pathlib.Path(tmp)
                                                                          / "numba"))
            result[jit] = child(model, jit, env)
            if jit == "background":
                result["built"] = background_quiet(kernels)
                result["second"] = child(model, jit, env)
                background_quiet(kernels)   # what the second process set compiling
    return result


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--only", nargs="*", choices=list(MODELS), default=list(MODELS))
    args = ap.parse_args()
    before = load()
    results = {}
    for name in args.only:
        results[name] = row(name)
        print(name, json.dumps(results[name]), file=sys.stderr, flush=True)
    lines = [
        "## First answers from empty caches (`benchmarks/first_answers.py`)",
        "",
        f"Machine: {machine()}; load average {before} before, {load()} after.  ",
        "Command: `python benchmarks/first_answers.py`",
        "",
        "A fresh process per row with empty kernel and numba caches of its own, at numba's "
        "default optimisation: `import phasemap`, one `phasemap.classify` and one "
        "`phasemap.simulate(model, 5.0)` at the model's defaults.  *eager*: numba compiles "
        "first (`PHASEMAP_JIT=eager`, what every first call did before).  *background* "
        "(the default): the interpreted twins answer at once, with the same bits, while "
        "separate low-priority processes compile into the cache (their CPU is not in the "
        "process's).  *built after*: seconds from the end of that process until the "
        "background compiles had left the machine code in the cache; *then*: a second "
        "process's calls, which load it.  Wall and CPU of the whole process, and each call "
        "alone (s).  *to classify*: the process's CPU from its start to the end of the "
        "classify, `import phasemap` included: what a process that only classifies costs.  "
        "A declared built-in model (the ladder, the wheel, the rods) is read from its "
        "derivation shipped in the package (`phasemap/systems/derived`); the README rod's "
        "classify includes its derivation with sympy.  `import phasemap` does not import "
        "xarray (and pandas): the process's first Dataset does, which the *simulate* columns "
        "include (about 0.6 s here; before 2026-12-01 it was in *to classify*); it no "
        "longer imports dask.array, which xarray's first Variable did (0.9 s, until "
        "2026-12-01: `phasemap.core.lazy.dask_checked_lazily`).  "
        "Targets (issue 40): a built-in "
        f"model's first classify <= {TARGET} s of CPU in all (*to classify*), its first "
        f"simulate <= {SIMULATE_TARGET} s; a new declaration's first classify, its "
        f"derivation included, <= {DECLARED_TARGET} s (the README rod: one contact).",
        "",
        "| model | eager: process wall | CPU | classify | simulate | compiling "
        "| background: process wall | CPU | to classify | classify | simulate | compiling "
        "| built after "
        "| then: classify | simulate | targets: to classify | simulate |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|",
    ]
    for name, r in results.items():
        e, b, s = r["eager"], r["background"], r["second"]
        builtin = name != "README rod"
        verdicts = [("met" if ok else "**missed**") if builtin or i == 0 else "-"
                    for i, ok in enumerate((b["to_classify"] <= (TARGET if builtin
                                                                  else DECLARED_TARGET),
                                            b["simulate"] <= SIMULATE_TARGET))]
        lines.append(
            f"| {name} | {e['wall']:.2f} | {e['cpu']:.2f} | {e['classify']:.2f} | "
            f"{e['simulate']:.2f} | {e['compile'] + e['simulate_compile']:.1f} | "
            f"{b['wall']:.2f} | {b['cpu']:.2f} | {b['to_classify']:.2f} | "
            f"{b['classify']:.3f} | {b['simulate']:.3f} | "
            f"{b['compile'] + b['simulate_compile']:.1f} | {r['built']:.1f} | "
            f"{s['classify']:.3f} | {s['simulate']:.3f} | {verdicts[0]} | {verdicts[1]} |")
    agree = all(r["eager"]["n"] == r["background"]["n"] == r["second"]["n"] and
                r["eager"]["points"] == r["background"]["points"] == r["second"]["points"]
                for r in results.values())
    lines += ["", "Same n_solutions, and motions with the same number of saved points and "
              f"the same end, in every process of a row: {agree}."]
    publish(lines, "## First answers from empty caches", not args.no_write)


if __name__ == "__main__":
    main()
