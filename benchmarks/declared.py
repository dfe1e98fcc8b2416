"""Declared systems against the hand-written models: map throughput, cold start, per call.

Issue 12 asks for the declarations (:mod:`phasemap.declare`) to be what runs,
unless a hand module stays for a measured reason.  This script measures:

* **grid throughput** (Mcell/s) of the grid kernel alone, on 2-D maps of side
  ``--side`` (default 2048) over the cases of ``benchmarks/grid.py`` (same
  axes, same fixed values), for the hand module and its declaration
  (``phasemap/systems/seeds/*.py``), layer ``n_solutions`` and all four
  summary layers, at the moving state of the case and at zero slip velocity
  (rest: the stick and both slip-start rows are candidates too), per thread
  (one numba thread) and on every thread.  The Painleve rod is declared only;
  it is compared with a NumPy whole-array version of its classification
  (``numpy_rod`` in ``benchmarks/grid.py``, checked cell by cell against the
  kernel, all four layers);
* **cold start**: fresh processes, first with empty kernel and numba caches
  (``PHASEMAP_CACHE_DIR``, ``NUMBA_CACHE_DIR``: sympy derivation of the
  declaration, then compilation of its generated file at the first
  classify, map and motion), then with both caches warm;
* **per call**: ``phasemap.classify`` at rest and a short
  ``phasemap.simulate``.

Compilation is excluded from throughput and per-call figures (everything is
warmed first).  Methods alternate within each repeat; the tables report
medians.  Writes the section "Declared systems" of ../BENCHMARKS.md.

    python benchmarks/declared.py [--side 2048] [--repeat 7] [--cold-repeat 2]
"""

from __future__ import annotations

import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numba

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import phasemap  # noqa: E402
from _report import ROOT, load, machine, parser, publish  # noqa: E402
from grid import (CASES, HAND_MODULES, SEEDS, Kernel, hand_model, median_times,  # noqa: E402
                  numpy_rod, scene_args)
from phasemap.maps.layers import SUMMARY  # noqa: E402

#: model -> (declared model: a path or a registered name, map case, short motion)
SYSTEMS = {
    "ladder": (str(SEEDS / "ladder.py"), CASES["ladder"],
               {"phi": 0.8, "omega": 0.0, "f": 0.3}),
    "wheel": (str(SEEDS / "wheel.py"), CASES["wheel"], {"phi": 1.0, "omega": 0.0}),
    "elliptic_pendulum": (str(SEEDS / "elliptic_pendulum.py"), CASES["elliptic_pendulum"],
                          {"phi": 1.0, "omega": 0.0, "xdot": 0.5}),
    "hinge_pendulum": (str(SEEDS / "hinge_pendulum.py"), CASES["hinge_pendulum"],
                       {"phi": 1.0, "omega": 0.0, "delta": 0.1}),
    "painleve_rod": ("painleve_rod", CASES["painleve_rod"],
                     {"theta": 1.0, "omega": 0.0, "xdot": -1.0, "f": 0.5}),
}
T_MOTION = 1.0
TOL = 1e-12


def run_numpy_rod(n, state, all_layers=False):
    m, axes, fixed = rod_scene(n, state)
    res = numpy_rod(axes["theta"], axes["f"][None, :], **fixed)
    return res if all_layers else res[0]


def rod_scene(n, state):
    return scene_args("painleve_rod", n, m=phasemap.MODELS["painleve_rod"], state=state,
                      case=CASES["painleve_rod"])


# ------------------------------------------------------------ helpers -----
def models(name):
    """(label, Model) pairs of one system: the hand module if any, then the declaration."""
    out = [("hand", hand_model(name))] if has_hand(name) else []
    return out + [("declared", phasemap.get_model(SYSTEMS[name][0]))]


def has_hand(name) -> bool:
    """Whether a system has a hand-written module (its declaration is then a seed)."""
    return (SEEDS / f"{name}.py").exists()


def rest_state(m):
    return {m.velocity: 0.0}


def per_call(fn, k):
    t = time.perf_counter()
    for _ in range(k):
        fn()
    return (time.perf_counter() - t) / k


def count_rows(m, state):
    """Candidate rows of a model at a state (classify's candidates: absent rows left out)."""
    return len(phasemap.classify(m, **state).candidates)


# ------------------------------------------------------------- throughput -----
def throughput(side, repeat):
    """Per system and state: seconds of each version's kernel (``n_solutions`` and the four
    summary layers) on one thread and on all, alternating, medians."""
    nt = numba.config.NUMBA_NUM_THREADS
    rows = []
    for name, (_, case, _) in SYSTEMS.items():
        ms = models(name)
        for regime in ("moving", "rest"):
            state = {} if regime == "moving" else rest_state(ms[0][1])
            runs, kernels = {}, {}
            for label, m in ms:
                _, axes, fixed = scene_args(name, side, m=m, state=state, case=case)
                for key, layers in ((label, ("n_solutions",)), (label + "4", SUMMARY)):
                    k = kernels[key] = Kernel(m, axes, fixed, layers)
                    k.run()  # compile / load
                    runs[(key, 1)] = (k.run, 1)
                    if key == label:
                        runs[(key, nt)] = (k.run, nt)
            if name == "painleve_rod":
                runs[("numpy", 1)] = (lambda state=state: run_numpy_rod(side, state), 1)
                runs[("numpy4", 1)] = (lambda state=state: run_numpy_rod(side, state, True), 1)
                ref = run_numpy_rod(side, state, True)
                for layer, r in zip(SUMMARY, ref):
                    bad = int((r != kernels["declared4"].result(layer)).sum())
                    assert bad == 0, f"rod {regime}: NumPy and kernel differ in {bad} cells of {layer}"
                differ = 0
            else:
                differ = int((kernels["hand"].result("n_solutions")
                              != kernels["declared"].result("n_solutions")).sum())
            med = median_times(runs, repeat)
            rate = {k: side * side / v for k, v in med.items()}
            nrows = {label: count_rows(m, {**case[2], **state}) for label, m in ms}
            rows.append((name, regime, rate, nrows, differ))
            print(name, regime, {f"{k[0]} {k[1]}": round(v / 1e6, 1) for k, v in rate.items()},
                  nrows, differ, flush=True)
    return rows


# ---------------------------------------------------------------- per call -----
def calls(repeat, k_classify=300, k_sim=20):
    rows = []
    for name, (_, case, motion) in SYSTEMS.items():
        ms = models(name)
        fns, steps = {}, []
        for label, m in ms:
            state = {**case[2], **rest_state(m)}
            fns["classify " + label] = (lambda m=m, s=state: phasemap.classify(m, **s), k_classify)
            fns["simulate " + label] = (
                lambda m=m: phasemap.simulate(m, T_MOTION, **motion), k_sim)
            fns["classify " + label][0]()
            steps.append(str(fns["simulate " + label][0]().sizes["t"]))
        times = {k: [] for k in fns}
        for _ in range(repeat):
            for key, (fn, k) in fns.items():
                times[key].append(per_call(fn, k))
        med = {k: statistics.median(v) for k, v in times.items()}
        rows.append((name, med, " / ".join(steps)))
        print(name, {k: f"{v * 1e3:.3f} ms" for k, v in med.items()}, steps, flush=True)
    return rows


# -------------------------------------------------------------- cold start -----
CHILD = r"""
import importlib, json, sys, time
spec = json.loads(sys.argv[1])
T = {}
t = time.perf_counter()
import numpy as np, phasemap
import phasemap.declare.build as d
from phasemap.maps.grid import evaluate
from phasemap.maps.layers import layers_for
T["import phasemap"] = time.perf_counter() - t
if spec["declared"] and spec["empty"]:  # a warm process loads the model without sympy
    t = time.perf_counter()
    import sympy
    T["import sympy"] = time.perf_counter() - t
spent = [0.0]
_derive = d.module_source
def _timed(S):
    t = time.perf_counter()
    try:
        return _derive(S)
    finally:
        spent[0] += time.perf_counter() - t
d.module_source = _timed
t = time.perf_counter()
m = (phasemap.get_model(spec["model"]) if spec["declared"] else
     importlib.import_module(spec["hand"]).MODEL)
T["load"] = time.perf_counter() - t - spent[0]
T["derive"] = spent[0]
t = time.perf_counter()
phasemap.classify(m, **spec["state"])
T["classify"] = time.perf_counter() - t
t = time.perf_counter()
axes = {k: np.linspace(lo, hi, 8) for k, (lo, hi) in spec["axes"].items()}
fixed = {k: v for k, v in {**m.defaults, **spec["state"]}.items() if k not in axes}
evaluate(m, axes, fixed, [layers_for(m)["n_solutions"]])
T["map"] = time.perf_counter() - t
t = time.perf_counter()
phasemap.simulate(m, spec["t_end"], **spec["motion"])
T["simulate"] = time.perf_counter() - t
print(json.dumps(T))
"""


def child(spec, cache):
    env = dict(os.environ, PHASEMAP_CACHE_DIR=os.path.join(cache, "kernels"),
               NUMBA_CACHE_DIR=os.path.join(cache, "numba"),
               PYTHONPATH=os.pathsep.join([str(ROOT / "tests"),
                                           os.environ.get("PYTHONPATH", "")]))
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(spec)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def cold(repeat):
    rows = []
    for name, (decl, case, motion) in SYSTEMS.items():
        axes = {case[3][0] if len(case) > 3 else "phi": (0.0, 1.0), case[0]: case[1]}
        variants = ([("hand", name)] if has_hand(name) else []) + [("declared", decl)]
        res = {label: {"empty": [], "warm": []} for label, _ in variants}
        for _ in range(repeat):
            for label, model in variants:
                spec = {"model": model, "declared": label == "declared",
                        "hand": HAND_MODULES.get(model),
                        "state": dict(case[2]), "axes": axes, "motion": motion,
                        "t_end": T_MOTION}
                with tempfile.TemporaryDirectory() as tmp:
                    res[label]["empty"].append(child(dict(spec, empty=True), tmp))
                    res[label]["warm"].append(child(dict(spec, empty=False), tmp))
        for label, _ in variants:
            med = {c: {k: statistics.median(r[k] for r in res[label][c])
                       for k in res[label][c][0]} for c in ("empty", "warm")}
            rows.append((name, label, med))
            print(name, label, json.dumps(med), flush=True)
    return rows


# ------------------------------------------------------------------ report -----
def report(args, tp, pc, cs, loads):
    nt = numba.config.NUMBA_NUM_THREADS
    mc = lambda x: f"{x / 1e6:.0f}" if x >= 1e7 else f"{x / 1e6:.1f}"  # noqa: E731
    lines = [
        "## Declared systems (`benchmarks/declared.py`)",
        "",
        f"Machine: {machine()}. Load average {loads[0]} at the start, {loads[1]} at the end. "
        f"Command: `python benchmarks/declared.py {' '.join(sys.argv[1:])}`.",
        f"Hand-written models (`phasemap/systems/` the pendulums, `tests/references/` the "
        f"ladder and the wheel) against their declarations "
        f"(`phasemap/systems/seeds/`, generated by `phasemap.declare`), and the declared "
        f"Painleve rod against a NumPy version of its classification (checked cell by cell, "
        f"all four layers). Other jobs share the cores, so times are noisy: methods alternate "
        f"within each repeat and the tables give medians of {args.repeat} repeats (cold "
        f"start: {args.cold_repeat}). Compilation is excluded from throughput and per-call "
        "times.",
        "",
        f"### Grid kernels, {args.side}^2 maps (Mcell/s)",
        "",
        "Axes and fixed values of `benchmarks/grid.py` (the rod: theta in [0, pi/2] x f in "
        "[0, 3], omega = 1, xdot = -1). *moving*: the case's state; *rest*: its slip velocity "
        "set to 0, where the stick and both slip-start rows are candidates. *rows*: candidate "
        "rows at that velocity (hand / declared). *cells differ*: cells where the hand and "
        "declared `n_solutions` disagree (the declaration counts separation; the hand models "
        f"do not). Per thread: one numba thread (NumPy runs on one); {nt} threads beside.",
        "",
        f"| model | state | rows | `n_solutions` hand | declared | declared / hand | "
        f"hand, {nt} threads | declared, {nt} threads | 4 layers hand | declared | "
        "declared / hand | cells differ |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, regime, r, nrows, differ in tp:
        base = "numpy" if name == "painleve_rod" else "hand"
        lab = "NumPy " if base == "numpy" else ""
        rows_txt = " / ".join(str(nrows[k]) for k in nrows)
        diff_txt = ("checked: 0" if base == "numpy"
                    else f"{differ} ({100 * differ / args.side ** 2:.1f} %)")
        base_n = f"{lab}{mc(r[(base, 1)])}" if base == "numpy" else mc(r[("hand", nt)])
        lines.append(
            f"| {name} | {regime} | {rows_txt} | {lab}{mc(r[(base, 1)])} | "
            f"{mc(r[('declared', 1)])} | {r[('declared', 1)] / r[(base, 1)]:.2f} | "
            f"{'-' if base == 'numpy' else base_n} | {mc(r[('declared', nt)])} | "
            f"{lab}{mc(r[(base + '4', 1)])} | {mc(r[('declared4', 1)])} | "
            f"{r[('declared4', 1)] / r[(base + '4', 1)]:.2f} | {diff_txt} |")
    ratio = {(name, regime): r[("declared", 1)] / r[("hand", 1)] for name, regime, r, _, _ in tp
             if name in ("elliptic_pendulum", "hinge_pendulum") and ("hand", 1) in r}
    slower = ", ".join(f"{n} {regime} {x:.2f}" for (n, regime), x in ratio.items())
    lines += [
        "",
        "(For the rod the *hand* columns hold the NumPy reference: the ratio is "
        "kernel / NumPy, per thread.)",
        "",
        "**Which runs.** The ladder and the wheel run as their declarations (their maps "
        "count leaving a contact, the *cells differ* column; the hand modules are "
        "references in the tests), at the *declared* columns' speed. The elliptic and "
        "hinge pendulums run their hand modules: their contacts cannot open, so their "
        "declarations agree with them state by state (tests/test_declare.py; 0 cells "
        f"differ above), the hand kernel is as fast or faster (declared / hand, "
        f"`n_solutions` per thread: {slower}), and the hand modules "
        "report the reactions the paper uses (the hinge's R_n, R_t along and across the "
        "rod). The ladder's rest map differs on one edge, phi = pi/2 (the bar lying flat), "
        "where the floor end cannot start to slip in the declaration and the hand module "
        "keeps the limit from inside. At rest the declared ladder has 10 candidate rows "
        "(3 by hand) and a statically indeterminate stick row: about 10x slower there, a "
        "0.3 s map at 2048^2.",
        "",
        "### Cold start (s, fresh processes)",
        "",
        "*empty*: empty kernel cache and numba cache: the declaration is derived with sympy "
        "(*derive*), and its generated file is compiled at the first classify, the first "
        "8x8 map (`n_solutions`) and the first motion. *warm*: the same process again with "
        "both caches filled. *load* is `get_model` without the derivation (the declaration "
        "file, the generated module, the Model; warm, from the kernel cache's manifest, without "
        "sympy: *import sympy* is then `-`). `import phasemap` is the same for both "
        "(about "
        f"{statistics.median(x[2]['warm']['import phasemap'] for x in cs):.1f} s here).",
        "",
        "| model | version | caches | import sympy | derive | load | first classify | "
        "first map | first motion | total after import phasemap |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, label, med in cs:
        for c in ("empty", "warm"):
            t = med[c]
            total = sum(v for k, v in t.items() if k != "import phasemap")
            sym = f"{t['import sympy']:.2f}" if "import sympy" in t else "-"
            der = f"{t['derive']:.2f}" if label == "declared" else "-"
            lines.append(f"| {name} | {label} | {c} | {sym} | {der} | {t['load']:.2f} | "
                         f"{t['classify']:.2f} | {t['map']:.2f} | {t['simulate']:.2f} | "
                         f"{total:.2f} |")
    lines += [
        "",
        "### Per call",
        "",
        f"`phasemap.classify` at the case's state at rest; `phasemap.simulate` of a short "
        f"motion ({T_MOTION:g} s; ladder phi = 0.8, wheel phi = 1, elliptic pendulum phi = 1 "
        "xdot = 0.5, rod theta = 1 xdot = -1 f = 0.5; *steps*: saved points, hand / "
        "declared).",
        "",
        "| model | classify hand (ms) | declared (ms) | declared / hand | "
        "simulate hand (ms) | declared (ms) | declared / hand | steps |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, med, steps in pc:
        ch = med.get("classify hand")
        sh = med.get("simulate hand")
        cd, sd = med["classify declared"], med["simulate declared"]
        f = lambda x: f"{x * 1e3:.3f}" if x is not None else "-"  # noqa: E731
        rr = lambda a, b: f"{a / b:.2f}" if b else "-"  # noqa: E731
        lines.append(f"| {name} | {f(ch)} | {f(cd)} | {rr(cd, ch)} | {f(sh)} | {f(sd)} | "
                     f"{rr(sd, sh)} | {steps} |")
    return "\n".join(lines) + "\n"


def main():
    ap = parser(__doc__)
    ap.add_argument("--side", type=int, default=2048)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--cold-repeat", type=int, default=2)
    args = ap.parse_args()
    loads = [load()]
    tp = throughput(args.side, args.repeat)
    pc = calls(args.repeat)
    cs = cold(args.cold_repeat)
    loads.append(load())
    publish(report(args, tp, pc, cs, loads), "## Declared systems", write=not args.no_write)


if __name__ == "__main__":
    main()
