"""Grid throughput: cells per second of the numba kernel against three reference points.

For each model, a 2-D map over (phi, f), or (phi, delta) where there is no f,
at a moving state (the relative velocity is not zero), layer ``n_solutions``
(and, in a second table, all four summary layers at once):

* **numba**: ``phasemap.Scene(...).compute()``'s kernel, through ``grid.evaluate``
  (the generated kernel of :mod:`phasemap._codegen`);
* **previous kernel**: the kernel phasemap had before the per-point contract
  was rebuilt (issue 9): one out-of-line ``point(v, out)`` call per cell into
  heap scratch rows, then the array-based ``summarize``; it runs here on the
  generated ``point``, so it computes exactly the same classification;
* **numpy**: the same classification written with NumPy whole-array operations
  (for this benchmark only; checked cell by cell against the kernel);
* **store loop**: a kernel with the generated kernel's loop structure (prange
  over the outer axis, the inner axis read from its array) whose body only
  stores an int8 computed from the inner value: the roofline of a kernel that
  must read its axis and write int8.  (A memset is faster still, and says
  nothing about a kernel that classifies.)

Compilation is excluded (every kernel is warmed first) and reported separately
as cold start: a fresh process importing phasemap and classifying one tiny
grid, once with numba's on-disk cache warm and once with an empty cache.
Methods alternate within one run and the table reports medians of
``--repeat`` runs.  Writes the table into ../BENCHMARKS.md.

    python benchmarks/grid.py [--sizes 256 1024 2048 4096] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import pathlib
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np
from numba import njit, prange

import phasemap
from phasemap import _numerics as nx
from phasemap._compile import specialize
from phasemap.grid import evaluate, pack_axes
from phasemap.layers import SUMMARY, layers_for

ROOT = pathlib.Path(__file__).resolve().parents[1]
TOL = 1e-12
CASES = {  # model: (second axis, its range, fixed values)
    "ladder": ("f", (0.0, 3.0), {"omega": 1.0}),
    "wheel": ("delta", (0.0, 1.0), {"omega": 1.0}),
    "elliptic_pendulum": ("f", (0.0, 6.0), {"omega": 0.5, "xdot": 1.0}),
    "hinge_pendulum": ("delta", (0.0, 1.5), {"omega": 1.0}),
}


# ------------------------------------------------------ NumPy references -----
def numpy_ladder(phi, f, omega, l, g, m):
    sp, cp = np.sin(phi)[:, None], np.cos(phi)[:, None]
    s, w2 = np.sign(omega), omega * omega
    d = 2.0 - f * f
    rhs = 3.0 * (2.0 * s * f * l * w2 - 2.0 * s * f * g * cp + (1.0 - f * f) * g * sp)
    rhs_scale = 3.0 * (2.0 * f * l * w2 + 2.0 * f * g + np.abs(1.0 - f * f) * g)
    singular = np.abs(d) <= TOL * (2.0 + f * f)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = rhs / (2.0 * l * d)
    xdd, ydd = l * (cp * a - sp * w2), -l * (sp * a + cp * w2)
    inv = m / (1.0 + f * f)
    nf = inv * (g + ydd - s * f * xdd)
    nw = inv * (xdd + s * f * (g + ydd))
    tol = TOL * inv * (g + l * w2 + l * np.abs(a)) * (1.0 + f)
    ok = (nf >= -tol) & (nw >= -tol)
    n = np.where(singular, np.where(np.abs(rhs) <= TOL * rhs_scale, 3, 0), ok)
    lost = ~singular & ~ok
    return (n.astype(np.int8), lost.astype(np.int8),
            np.broadcast_to(singular, n.shape).astype(np.int8))


def numpy_wheel(phi, delta, omega, r, l, rho, g, m):
    sp, cp = np.sin(phi)[:, None], np.cos(phi)[:, None]
    s, w2 = np.sign(omega), omega * omega
    coef = rho * rho + r * r + l * l - 2.0 * r * l * cp + delta * s * l * sp
    rhs = -l * (r * sp + delta * s * cp) * w2 - g * l * sp - delta * s * g
    singular = np.abs(coef) <= TOL * (rho * rho + r * r + l * l + 2.0 * r * l + delta * l)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = rhs / coef
    n_normal = m * (g + l * (sp * a + cp * w2))
    ok = n_normal >= -TOL * m * (g + l * w2 + l * np.abs(a))
    rhs_zero = np.abs(rhs) <= TOL * (l * (r + delta) * w2 + g * l + delta * g)
    n = np.where(singular, np.where(rhs_zero, 3, 0), ok).astype(np.int8)
    return n, (~singular & ~ok).astype(np.int8), singular.astype(np.int8)


def numpy_elliptic(phi, f, omega, xdot, l, g, m):
    sp, cp = np.sin(phi)[:, None], np.cos(phi)[:, None]
    sigma, w2 = np.sign(xdot), omega * omega
    q = g + l * cp * w2
    q_zero = np.abs(q) <= TOL * (g + l * w2)
    n = np.zeros(np.broadcast_shapes(sp.shape, np.shape(f)), dtype=np.int8)
    cont = np.zeros(n.shape, dtype=bool)
    sing = np.zeros(n.shape, dtype=bool)
    for rho in (1.0, -1.0):
        k = sigma * rho
        lam = 1.0 + sp * sp - k * f * sp * cp
        singular = np.abs(lam) <= TOL * (2.0 + f)
        ok = (q_zero | (q * lam > 0)) if rho > 0 else (~q_zero & (q * lam < 0))
        n += (~singular & ok).astype(np.int8)
        cont |= singular & q_zero
        sing |= singular
    return np.where(cont, 3, n).astype(np.int8), np.zeros(n.shape, np.int8), sing.astype(np.int8)


def numpy_hinge(phi, delta, omega, l, g, m):
    cp = np.cos(phi)[:, None]
    w2 = omega * omega
    coef = l * l - delta * delta
    singular = np.abs(coef) <= TOL * (l * l + delta * delta)
    qn_zero = np.abs(l * w2 + g * cp) <= TOL * (l * w2 + g)
    n = np.where(coef > 0, 1, np.where(qn_zero, 1, 0))
    n = np.where(singular, np.where(qn_zero, 3, 0), n).astype(np.int8)
    return n, np.zeros(n.shape, np.int8), np.broadcast_to(singular, n.shape).astype(np.int8)


NUMPY = {"ladder": numpy_ladder, "wheel": numpy_wheel, "elliptic_pendulum": numpy_elliptic,
         "hinge_pendulum": numpy_hinge}


@njit(parallel=True, cache=True)
def store_loop(base, outer_values, inner_values, out):
    """The roofline: the generated kernel's loop structure, storing an int8 per cell."""
    n0 = outer_values.shape[0]
    n1 = inner_values.shape[0]
    for i in prange(n0):
        v = base.copy()
        v[0] = outer_values[i]
        x = v[0]
        for j in range(n1):
            out[i * n1 + j] = np.int8(inner_values[j] > x)


# The previous grid kernel (before issue 9), kept here as the baseline column.
POINT = None
STICK = -1
N_BRANCHES = 0
N_FIELDS = 0
BLOCK = 2048


@njit(cache=True)
def _set_axis(v, d, i, axis_slot, axis_values, deriv_slot, deriv_values):
    v[axis_slot[d]] = axis_values[d, i]
    for k in range(deriv_slot.shape[1]):
        if deriv_slot[d, k] >= 0:
            v[deriv_slot[d, k]] = deriv_values[d, k, i]


def _previous_template(base, shape, axis_slot, axis_values, deriv_slot, deriv_values, summary):
    """The previous kernel's loop, n_solutions only: blocks of cells, out-of-line calls."""
    ndim = shape.shape[0]
    ncells = 1
    for d in range(ndim):
        ncells *= shape[d]
    nblocks = (ncells + BLOCK - 1) // BLOCK
    for blk in prange(nblocks):
        v = base.copy()
        out = np.empty((N_BRANCHES, N_FIELDS))
        idx = np.empty(ndim, dtype=np.int64)
        start = blk * BLOCK
        stop = min(start + BLOCK, ncells)
        rem = start
        for d in range(ndim - 1, -1, -1):
            idx[d] = rem % shape[d]
            rem //= shape[d]
        for d in range(ndim):
            _set_axis(v, d, idx[d], axis_slot, axis_values, deriv_slot, deriv_values)
        for cell in range(start, stop):
            POINT(v, out)
            n, stag, lost, sing = nx.summarize(out, STICK)
            summary[cell] = n
            d = ndim - 1
            while d >= 0:
                idx[d] += 1
                if idx[d] < shape[d]:
                    _set_axis(v, d, idx[d], axis_slot, axis_values, deriv_slot, deriv_values)
                    break
                idx[d] = 0
                _set_axis(v, d, 0, axis_slot, axis_values, deriv_slot, deriv_values)
                d -= 1


def run_previous(model, n):
    m, axes, fixed = scene_args(model, n)
    kernel = specialize(_previous_template, m, "benchmark_previous_grid", parallel=True,
                        POINT=m.point, STICK=m.stick_branch, N_BRANCHES=len(m.branches),
                        N_FIELDS=m.n_fields)
    out = np.empty(n * n, dtype=np.int8)
    kernel(*pack_axes(m, axes, fixed), out)
    return out.reshape(n, n)


def run_store(model, n):
    m, axes, fixed = scene_args(model, n)
    names = list(axes)
    out = np.empty(n * n, dtype=np.int8)
    store_loop(np.zeros(len(m.inputs)), axes[names[0]], axes[names[1]], out)
    return out


# ------------------------------------------------------------------ runs -----
def hand_model(name):
    """The hand-written kernel of a seed system (the ladder and the wheel run as their
    declarations, which also count separation; benchmarks/declared.py compares the two),
    or the registered model of any other name."""
    import importlib

    if name in ("ladder", "wheel", "elliptic_pendulum", "hinge_pendulum"):
        return importlib.import_module(f"phasemap.models.{name}").MODEL
    return phasemap.MODELS[name]


def scene_args(model, n, m=None, state=None, case=None):
    """The model, axes and fixed values of ``model``'s map of side ``n``.

    ``m`` replaces the registered model (a declared version of it), ``state``
    overrides values of the case (another velocity), ``case`` replaces
    ``CASES[model]``; a fourth element ``(name, (lo, hi))`` of a case names the
    first axis (default: phi).
    """
    case = case or CASES[model]
    name2, (lo, hi), fixed = case[:3]
    m = hand_model(model) if m is None else m
    full = {**m.defaults, **fixed, **(state or {})}
    if len(case) > 3:
        name1, (lo1, hi1) = case[3]
    else:
        name1 = "phi"
        lo1 = 0.0 if model == "ladder" else -np.pi
        hi1 = np.pi / 2 if model == "ladder" else np.pi
    axes = {name1: np.linspace(lo1, hi1, n), name2: np.linspace(lo, hi, n)}
    full = {k: v for k, v in full.items() if k not in axes}
    return m, axes, full


def run_numba(model, n, layers=("n_solutions",), **scene):
    """The kernel's map (``scene``: keywords of :func:`scene_args`)."""
    m, axes, fixed = scene_args(model, n, **scene)
    reg = layers_for(m)
    got = evaluate(m, axes, fixed, [reg[k] for k in layers])
    return got["n_solutions"] if len(layers) == 1 else got


def run_numpy(model, n, all_layers=False):
    """The NumPy reference: n_solutions, or (n_solutions, contact_lost, singular)."""
    m, axes, fixed = scene_args(model, n)
    name2 = CASES[model][0]
    args = {k: v for k, v in fixed.items()}
    args[name2] = axes[name2][None, :]
    res = NUMPY[model](axes["phi"], **args)
    if not all_layers:
        return res[0]
    # stagnation is identically 0 at a moving state; NumPy still stores it
    return res[0], np.zeros(res[0].shape, np.int8), res[1], res[2]


def timed(fn, *args):
    t = time.perf_counter()
    result = fn(*args)
    return time.perf_counter() - t, result


GRID_START = ("import time; t=time.perf_counter(); import numpy as np, phasemap; "
              "phasemap.Scene('ladder', axes={'phi': np.linspace(0, 1, 8)}).compute(); "
              "print(time.perf_counter()-t)")


def cold_start(empty_cache: bool, code: str = GRID_START) -> float:
    """Seconds ``code`` (which prints its own timing last) takes in a fresh process,
    with numba's on-disk cache as it is or empty."""
    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as tmp:
        if empty_cache:
            env["NUMBA_CACHE_DIR"] = tmp
            env["PHASEMAP_CACHE_DIR"] = os.path.join(tmp, "kernels")
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def machine() -> str:
    cpu = platform.processor() or "unknown CPU"
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{os.cpu_count()} cores, {cpu}; Python {platform.python_version()}, "
            f"numba {numba.__version__}, numpy {np.__version__}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 1024, 2048, 4096])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--numpy-max", type=int, default=2048,
                    help="largest side for the NumPy reference (memory)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()

    threads_all = numba.config.NUMBA_NUM_THREADS
    rows = []
    for model in CASES:
        run_numba(model, 16)  # compile / load
        run_numba(model, 16, SUMMARY)
        run_previous(model, 16)
        run_store(model, 16)
        for n in args.sizes:
            ref = run_numpy(model, n) if n <= args.numpy_max else None
            got = run_numba(model, n)
            prev = run_previous(model, n)
            assert np.array_equal(prev, got), f"{model} {n}: previous and new kernels differ"
            if ref is not None:
                mismatch = int((ref != got).sum())
                assert mismatch == 0, f"{model} {n}: NumPy and numba differ in {mismatch} cells"
                ref4 = run_numpy(model, n, True)
                got4 = run_numba(model, n, SUMMARY)
                for name, r in zip(SUMMARY, ref4):
                    assert np.array_equal(r, got4[name]), f"{model} {n}: {name} differs"
            keys = ["numba1", "numbaN", "prevN", "numpy", "storeN", "all4N", "numpy4"]
            times = {k: [] for k in keys}
            for _ in range(args.repeat):  # alternate the methods within the run
                numba.set_num_threads(1)
                times["numba1"].append(timed(run_numba, model, n)[0])
                numba.set_num_threads(threads_all)
                times["numbaN"].append(timed(run_numba, model, n)[0])
                times["prevN"].append(timed(run_previous, model, n)[0])
                times["storeN"].append(timed(run_store, model, n)[0])
                times["all4N"].append(timed(run_numba, model, n, SUMMARY)[0])
                if ref is not None:
                    times["numpy"].append(timed(run_numpy, model, n)[0])
                    times["numpy4"].append(timed(run_numpy, model, n, True)[0])
            med = {k: statistics.median(v) if v else float("nan") for k, v in times.items()}
            cells = n * n
            rate = {k: cells / med[k] for k in keys}
            rows.append((model, n, rate))
            print(f"{model:18s} {n:5d}  " + "  ".join(f"{k} {rate[k] / 1e6:8.1f}" for k in keys),
                  flush=True)
    cold_warm, cold_empty = cold_start(False), cold_start(True)

    def mc(x):
        return f"{x / 1e6:.1f}" if np.isfinite(x) else "not run"

    def ratio(a, b):
        return f"{a / b:.1f}x" if np.isfinite(a / b) else "-"

    lines = [
        "## Grid throughput (`benchmarks/grid.py`)",
        "",
        f"Machine: {machine()}.",
        f"2-D maps (phi x f, or phi x delta), moving state; medians of {args.repeat} "
        "alternating runs; compilation excluded. Mcell/s = 10^6 cells per second. Every kernel "
        "is checked cell by cell against the NumPy reference (and the previous kernel) first.",
        "",
        "### Layer `n_solutions`",
        "",
        f"| model | side | numba 1 thread | numba {threads_all} threads | previous kernel "
        f"({threads_all} threads) | NumPy | store loop ({threads_all} threads) | "
        "numba / NumPy | numba / previous | share of store loop |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for model, n, r in rows:
        lines.append(f"| {model} | {n}^2 | {mc(r['numba1'])} | {mc(r['numbaN'])} | "
                     f"{mc(r['prevN'])} | {mc(r['numpy'])} | {mc(r['storeN'])} | "
                     f"{ratio(r['numbaN'], r['numpy'])} | {ratio(r['numbaN'], r['prevN'])} | "
                     f"{100 * r['numbaN'] / r['storeN']:.0f} % |")
    lines += [
        "",
        "### All four summary layers at once",
        "",
        "`n_solutions`, `stagnation`, `contact_lost`, `singular` in one pass, against NumPy "
        "computing the same four arrays.",
        "",
        f"| model | side | numba {threads_all} threads | NumPy | numba / NumPy |",
        "|---|---:|---:|---:|---:|",
    ]
    for model, n, r in rows:
        lines.append(f"| {model} | {n}^2 | {mc(r['all4N'])} | {mc(r['numpy4'])} | "
                     f"{ratio(r['all4N'], r['numpy4'])} |")
    lines += [
        "",
        f"Cold start (fresh process: import phasemap and map 8 cells of the ladder): "
        f"{cold_warm:.2f} s with the kernel caches warm, {cold_empty:.2f} s with empty "
        f"caches (code generation and full compilation).",
        "",
    ]
    lines += targets(rows, threads_all, cold_warm, cold_empty)
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section(text, "## Grid throughput")


#: Issue 9's targets: n_solutions against NumPy (the elliptic pendulum's is higher).
TARGET = {"elliptic_pendulum": 15.0}
SHORT = {"elliptic_pendulum": "elliptic", "hinge_pendulum": "hinge"}


def targets(rows, threads, cold_warm, cold_empty) -> list[str]:
    """The targets of issue 9 at the largest side with a NumPy reference, met or not, and
    what limits the kernel where one is missed."""
    at = {}
    for model, n, r in rows:
        if np.isfinite(r["numpy"]) and (model not in at or n > at[model][0]):
            at[model] = (n, r)
    models = [m for m in CASES if m in at]
    if not models:
        return []
    side = max(at[m][0] for m in models)

    def verdict(value, goal, unit):
        ok = value >= goal
        return f"{value:.1f}{unit} {'met' if ok else 'missed'}"

    head = "| target | " + " | ".join(SHORT.get(m, m) for m in models) + " |"
    lines = ["### Against the targets (issue 9), and what limits the kernel", "",
             f"At {side}^2, {threads} threads, against NumPy in the same process:", "", head, "|---|" + "---:|" * len(models)]
    lines.append("| `n_solutions` >= 10x NumPy (>= 15x elliptic) | " + " | ".join(
        verdict(at[m][1]["numbaN"] / at[m][1]["numpy"], TARGET.get(m, 10.0), "x")
        for m in models) + " |")
    lines.append("| `n_solutions` >= 25 % of the store loop | " + " | ".join(
        verdict(100 * at[m][1]["numbaN"] / at[m][1]["storeN"], 25.0, " %") for m in models)
        + " |")
    lines.append("| all four summary layers >= 5x NumPy | " + " | ".join(
        verdict(at[m][1]["all4N"] / at[m][1]["numpy4"], 5.0, "x") for m in models) + " |")
    lines.append("| gain over the previous kernel (same process) | " + " | ".join(
        f"{at[m][1]['numbaN'] / at[m][1]['prevN']:.1f}x" for m in models) + " |")
    r = {m: at[m][1] for m in models}
    lines += [
        "",
        f"Cold start with warm caches (above), target 3 s: "
        f"{'met' if cold_warm <= 3.0 else 'missed'} (`import phasemap` no longer imports "
        f"matplotlib; `phasemap.plot` loads it on first use).",
        "",
        "- **What changed** (issue 9): branch functions return their rows and are written "
        "without control flow; the grid kernel is generated per (layer set, innermost axis) "
        "with every other input a scalar local; when the innermost axis does not move the "
        "relative velocity, one loop per velocity regime computes only the branches that can "
        "apply; several summary layers are packed into one byte per cell (one store stream "
        "per loop, which LLVM vectorises: AVX2 `vdivpd`/`vblendvpd` in the loop, checked in "
        "the assembly). One prange driver, compiled once, takes each generated `cells` "
        "function as a first-class function.",
    ]
    if "hinge_pendulum" in r:
        h = r["hinge_pendulum"]
        lines.append(
            f"- **The hinge pendulum's NumPy reference is four comparisons** on a (1, n) "
            f"parameter row broadcast over the grid: at {h['numpy'] / 1e6:.0f} Mcell/s it is "
            f"near NumPy's own store rate, and the kernel ({h['numbaN'] / 1e6:.0f} Mcell/s, "
            f"{100 * h['numbaN'] / h['storeN']:.0f} % of the store loop) cannot be 10x faster "
            "than a memory-bound NumPy expression; the same holds for its four layers.")
    if "elliptic_pendulum" in r:
        e = r["elliptic_pendulum"]
        lines.append(
            f"- **The elliptic pendulum** ({e['numbaN'] / e['numpy']:.1f}x NumPy, "
            f"{100 * e['numbaN'] / e['storeN']:.0f} % of the store loop): its two slide "
            f"branches cost three divisions each per cell; {threads} threads gave "
            f"{e['numbaN'] / e['numba1']:.1f}x one thread in this run.")
    if "ladder" in r:
        la = r["ladder"]
        lines.append(
            f"- **The ladder** (declared; it counts a released contact) computes its "
            f"reactions (affine forms and their tolerances) to decide contact loss for "
            f"`n_solutions`: {la['numba1'] / 1e6:.0f} Mcell/s per thread, "
            f"{100 * la['numbaN'] / la['storeN']:.0f} % of the store loop.")
    spread = []
    for m in models:
        shares = [100 * rr["numbaN"] / rr["storeN"] for mm, n, rr in rows if mm == m and n >= 1024]
        if shares:
            spread.append(f"{SHORT.get(m, m)} {min(shares):.0f}-{max(shares):.0f} %")
    lines += [
        "- The store loop is itself noisy on these shared cores: the share of it across the "
        "sides from 1024^2 up is " + ", ".join(spread) + " in this run, so a share near 25 % "
        "is met in one run and missed in the next.",
        f"- Thread scaling ({threads} threads over one) is "
        + ", ".join(f"{SHORT.get(m, m)} {r[m]['numbaN'] / r[m]['numba1']:.1f}x" for m in models)
        + " here: the two cores are virtual and other jobs may share them.",
        "- **A first `phasemap tour` on empty caches** (numba's and the kernel cache), "
        "measured once when the kernels were rebuilt: 135 s, against 149 s for the same "
        "studies on the previous kernels (branch `issue-11` at 67215c6). Not slower: met. Its "
        "11 grid kernels compile in about 3 s each; the shared fate driver (3 s, once) "
        "replaces a 15 s parfor compile per model.",
        "",
    ]
    return lines


def write_section(text: str, heading: str) -> None:
    """Replace (or append) the section that starts with ``heading`` in BENCHMARKS.md."""
    path = ROOT / "BENCHMARKS.md"
    old = path.read_text() if path.exists() else "# Benchmarks\n\n"
    # the heading at the start of a line: "## Grid throughput" must not match the
    # declared systems' "### Grid throughput, 2048^2 maps" (it did, and deleted it)
    found = re.search(rf"(?m)^{re.escape(heading)}", old)
    if found:
        start = found.start()
        nxt = old.find("\n## ", start + len(heading))
        old = old[:start] + old[nxt + 1:] if nxt >= 0 else old[:start]
    path.write_text(old.rstrip() + "\n\n" + text.rstrip() + "\n")


if __name__ == "__main__":
    main()
