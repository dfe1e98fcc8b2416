"""Declared systems against the hand-written models: map throughput, cold start, per call.

Issue 12 asks for the declarations (:mod:`phasemap.declare`) to be what runs,
unless a hand module stays for a measured reason.  This script measures, on
``--threads`` numba threads (default 2):

* **grid throughput** (Mcell/s) of 2-D maps of side ``--side`` (default
  2048) over the cases of ``benchmarks/grid.py`` (same axes, same fixed
  values), for the hand module and its declaration
  (``phasemap/systems/seeds/*.py``), layer ``n_solutions`` and all four
  summary layers, at the moving state of the case and at zero slip velocity
  (rest: the stick and both slip-start rows are candidates too).  The
  Painleve rod is declared only; it is compared with a NumPy whole-array
  version of its classification (derived by hand below, checked cell by cell
  against the kernel, all four layers);
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

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import phasemap  # noqa: E402
from grid import CASES, ROOT, hand_model, machine, run_numba, timed, write_section  # noqa: E402
from phasemap.layers import SUMMARY  # noqa: E402

SEEDS = ROOT / "phasemap" / "systems" / "seeds"
ROD_CASE = ("f", (0.0, 3.0), {"omega": 1.0, "xdot": -1.0}, ("theta", (0.0, np.pi / 2)))
#: model -> (declared model: a path or a registered name, map case, short motion)
SYSTEMS = {
    "ladder": (str(SEEDS / "ladder.py"), CASES["ladder"],
               {"phi": 0.8, "omega": 0.0, "f": 0.3}),
    "wheel": (str(SEEDS / "wheel.py"), CASES["wheel"], {"phi": 1.0, "omega": 0.0}),
    "elliptic_pendulum": (str(SEEDS / "elliptic_pendulum.py"), CASES["elliptic_pendulum"],
                          {"phi": 1.0, "omega": 0.0, "xdot": 0.5}),
    "painleve_rod": ("painleve_rod", ROD_CASE,
                     {"theta": 1.0, "omega": 0.0, "xdot": -1.0, "f": 0.5}),
}
T_MOTION = 1.0
TOL = 1e-12


# ------------------------------------------------- NumPy reference: the rod -----
def numpy_rod(theta, f, omega, xdot, l, g, m):
    """n_solutions, stagnation, contact_lost, singular of the Painleve rod (NumPy).

    Derived by hand (Newton-Euler about the centre G = (x + l cos, l sin)):
    m xG'' = F, m yG'' = N - m g, (m l^2/3) theta'' = l (sin F - cos N).
    Kept contact (y'' = 0), slipping in direction s (F = -s f N):
    N (1 + 3 cos^2 + 3 s f sin cos) = m (g - l omega^2 sin);
    x'' = -s f N/m - 3 l sin N (cos + s f sin)/(m l) + l cos omega^2.
    Stick (x'' = 0): theta'' = -3 g cos/(4 l), N = m g (1 - 3 cos^2/4) - m l omega^2 sin,
    F = m (3 g sin cos/4 - l omega^2 cos).  Separated (N = F = 0):
    y'' = l omega^2 sin - g > 0.  Tolerances: the magnitudes of the generated code.
    """
    sn, c = np.sin(theta)[:, None], np.cos(theta)[:, None]
    w2 = omega * omega
    rest = xdot == 0.0
    shape = np.broadcast_shapes(sn.shape, np.shape(f))
    n = np.zeros(shape, np.int8)
    cont = np.zeros(shape, bool)
    sing = np.zeros(shape, bool)
    n0 = m * (g - l * w2 * sn) / 3.0
    ns0 = m * (w2 * l + g) / 3.0
    for s in ((1.0, -1.0) if rest else (float(np.sign(xdot)),)):
        d = c * c + s * f * sn * c + 1.0 / 3.0
        singular = np.abs(d) <= TOL * (np.abs(f) + 4.0 / 3.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            nn = n0 / d
            nscale = ns0 / np.abs(d)
        ok = nn >= -TOL * nscale
        if rest:  # the slip must start in its direction
            xdd = -s * f * nn / m - 3.0 * sn * nn * (c + s * f * sn) / m + l * c * w2
            xscale = 3.0 / m * (nscale * (1.0 + 4.0 * f / 3.0) + 7.0 / 3.0 * m * l * w2
                                + 2.0 * m * g)
            ok &= s * xdd > TOL * xscale
        n += (~singular & ok).astype(np.int8)
        cont |= singular & (np.abs(n0) <= TOL * ns0)
        sing |= singular
    lost = np.broadcast_to(l * w2 * sn - g > TOL * 7.0 * (g + l * w2), shape)
    n += lost.astype(np.int8)
    if rest:
        nn = m * g * (1.0 - 0.75 * c * c) - m * l * w2 * sn
        ff = m * (0.75 * g * sn * c - l * w2 * c)
        ns, fs = m * g + 1.75 * m * l * w2, 0.75 * m * g + 1.75 * m * l * w2
        stag = ((nn >= -TOL * ns) & (f * nn - ff >= -TOL * (f * ns + fs))
                & (f * nn + ff >= -TOL * (f * ns + fs)))
        n += stag.astype(np.int8)
    else:
        stag = np.zeros(shape, bool)
    code = np.where(cont, 3, np.where(n >= 3, 4, n)).astype(np.int8)
    return code, stag.astype(np.int8), lost.astype(np.int8), np.broadcast_to(sing, shape).astype(np.int8)


def run_numpy_rod(n, state, all_layers=False):
    m, axes, fixed = rod_scene(n, state)
    res = numpy_rod(axes["theta"], axes["f"][None, :], **fixed)
    return res if all_layers else res[0]


def rod_scene(n, state):
    from grid import scene_args
    return scene_args("painleve_rod", n, m=phasemap.MODELS["painleve_rod"], state=state,
                      case=ROD_CASE)


# ------------------------------------------------------------ helpers -----
def models(name):
    """(label, Model) pairs of one system: the hand module if any, then the declaration."""
    out = [("hand", hand_model(name))] if name in CASES else []
    return out + [("declared", phasemap.get_model(SYSTEMS[name][0]))]


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
    rows = []
    for name, (_, case, _) in SYSTEMS.items():
        ms = models(name)
        for regime in ("moving", "rest"):
            state = {} if regime == "moving" else rest_state(ms[0][1])
            runs = {}
            for label, m in ms:
                for key, layers in ((label, ("n_solutions",)), (label + "4", SUMMARY)):
                    runs[key] = (lambda m=m, layers=layers, state=state:
                                 run_numba(name, side, layers, m=m, state=state, case=case))
                    runs[key]()  # compile / load
            if name == "painleve_rod":
                runs["numpy"] = lambda state=state: run_numpy_rod(side, state)
                runs["numpy4"] = lambda state=state: run_numpy_rod(side, state, True)
                got = runs["declared4"]()
                ref = runs["numpy4"]()
                for layer, r in zip(SUMMARY, ref):
                    bad = int((r != got[layer]).sum())
                    assert bad == 0, f"rod {regime}: NumPy and kernel differ in {bad} cells of {layer}"
                differ = 0
            else:
                differ = int((runs["hand"]() != runs["declared"]()).sum())
            times = {k: [] for k in runs}
            for _ in range(repeat):
                for k, fn in runs.items():  # alternate the methods within each repeat
                    times[k].append(timed(fn)[0])
            rate = {k: side * side / statistics.median(v) for k, v in times.items()}
            nrows = {label: count_rows(m, {**case[2], **state}) for label, m in ms}
            rows.append((name, regime, rate, nrows, differ))
            print(name, regime, {k: round(v / 1e6, 1) for k, v in rate.items()}, nrows, differ,
                  flush=True)
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
from phasemap.grid import evaluate
from phasemap.layers import layers_for
T["import phasemap"] = time.perf_counter() - t
if spec["declared"]:
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
     importlib.import_module("phasemap.models." + spec["model"]).MODEL)
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
               NUMBA_CACHE_DIR=os.path.join(cache, "numba"))
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(spec)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def cold(repeat):
    rows = []
    for name, (decl, case, motion) in SYSTEMS.items():
        axes = {case[3][0] if len(case) > 3 else "phi": (0.0, 1.0), case[0]: case[1]}
        variants = ([("hand", name)] if name in CASES else []) + [("declared", decl)]
        res = {label: {"empty": [], "warm": []} for label, _ in variants}
        for _ in range(repeat):
            for label, model in variants:
                spec = {"model": model, "declared": label == "declared",
                        "state": dict(case[2]), "axes": axes, "motion": motion,
                        "t_end": T_MOTION}
                with tempfile.TemporaryDirectory() as tmp:
                    res[label]["empty"].append(child(spec, tmp))
                    res[label]["warm"].append(child(spec, tmp))
        for label, _ in variants:
            med = {c: {k: statistics.median(r[k] for r in res[label][c])
                       for k in res[label][c][0]} for c in ("empty", "warm")}
            rows.append((name, label, med))
            print(name, label, json.dumps(med), flush=True)
    return rows


# ------------------------------------------------------------------ report -----
def report(args, tp, pc, cs):
    thr = args.threads
    mc = lambda x: f"{x / 1e6:.0f}" if x >= 1e7 else f"{x / 1e6:.1f}"  # noqa: E731
    lines = [
        "## Declared systems (`benchmarks/declared.py`)",
        "",
        f"Machine: {machine()}.",
        f"Hand-written models (`phasemap/models/`) against their declarations "
        f"(`phasemap/systems/seeds/`, generated by `phasemap.declare`), and the declared "
        f"Painleve rod against a NumPy version of its classification (checked cell by cell, "
        f"all four layers). {thr} numba threads; the 2 cores were shared with other jobs, "
        f"so times are noisy: methods alternate within each repeat and the tables give "
        f"medians of {args.repeat} repeats (cold start: {args.cold_repeat}). Compilation is "
        "excluded from throughput and per-call times.",
        "",
        f"### Grid throughput, {args.side}^2 maps (Mcell/s)",
        "",
        "Axes and fixed values of `benchmarks/grid.py` (the rod: theta in [0, pi/2] x f in "
        "[0, 3], omega = 1, xdot = -1). *moving*: the case's state; *rest*: its slip velocity "
        "set to 0, where the stick and both slip-start rows are candidates. *rows*: candidate "
        "rows at that velocity (hand / declared). *cells differ*: cells where the hand and "
        "declared `n_solutions` disagree (the declaration counts separation; the hand models "
        "do not).",
        "",
        "| model | state | rows | `n_solutions` hand | declared | declared / hand | "
        "4 layers hand | declared | declared / hand | cells differ |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, regime, r, nrows, differ in tp:
        base = "numpy" if name == "painleve_rod" else "hand"
        lab = "NumPy " if base == "numpy" else ""
        rows_txt = " / ".join(str(nrows[k]) for k in nrows)
        diff_txt = "checked: 0" if base == "numpy" else f"{differ} ({100 * differ / args.side ** 2:.1f} %)"
        lines.append(
            f"| {name} | {regime} | {rows_txt} | {lab}{mc(r[base])} | {mc(r['declared'])} | "
            f"{r['declared'] / r[base]:.2f} | {lab}{mc(r[base + '4'])} | "
            f"{mc(r['declared4'])} | {r['declared4'] / r[base + '4']:.2f} | {diff_txt} |")
    ratio = {(name, regime): r["declared"] / r["hand"] for name, regime, r, _, _ in tp
             if name in ("elliptic_pendulum", "hinge_pendulum") and "hand" in r}
    slower = ", ".join(f"{n} {regime} {x:.2f}" for (n, regime), x in ratio.items())
    lines += [
        "",
        "(For the rod the *hand* columns hold the NumPy reference: the ratio is "
        "kernel / NumPy.)",
        "",
        "**Which runs.** The ladder and the wheel run as their declarations (their maps "
        "count leaving a contact, the *cells differ* column; the hand modules are "
        "references in the tests), at the *declared* columns' speed. The elliptic and "
        "hinge pendulums run their hand modules: their contacts cannot open, so their "
        "declarations agree with them state by state (tests/test_declare.py; 0 cells "
        f"differ above), the hand kernel is as fast or faster (declared / hand, "
        f"`n_solutions`: {slower}; the hinge is not timed here), and the hand modules "
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
        "file, the generated module, the Model). `import phasemap` is the same for both "
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
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--side", type=int, default=2048)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--cold-repeat", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    tp = throughput(args.side, args.repeat)
    pc = calls(args.repeat)
    cs = cold(args.cold_repeat)
    text = report(args, tp, pc, cs)
    print(text)
    if not args.no_write:
        write_section(text, "## Declared systems")


if __name__ == "__main__":
    main()
