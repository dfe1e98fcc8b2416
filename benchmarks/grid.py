"""Grid throughput: cells per second of the numba kernel against two reference points.

For each model, a 2-D map over (phi, f), or (phi, delta) where there is no f,
at a moving state (the relative velocity is not zero), layer ``n_solutions``:

* **numba**: ``phasemap.Scene(...).compute()``'s kernel, through ``grid.evaluate``;
* **numpy**: the same classification written with NumPy whole-array operations
  (for this benchmark only; checked cell by cell against the kernel);
* **write bound**: a ``prange`` numba kernel that only writes the int8 output.

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
import statistics
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np
from numba import njit, prange

import phasemap
from phasemap.grid import evaluate
from phasemap.layers import layers_for

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
    return n.astype(np.int8)


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
    return np.where(singular, np.where(rhs_zero, 3, 0), ok).astype(np.int8)


def numpy_elliptic(phi, f, omega, xdot, l, g, m):
    sp, cp = np.sin(phi)[:, None], np.cos(phi)[:, None]
    sigma, w2 = np.sign(xdot), omega * omega
    q = g + l * cp * w2
    q_zero = np.abs(q) <= TOL * (g + l * w2)
    n = np.zeros(np.broadcast_shapes(sp.shape, np.shape(f)), dtype=np.int8)
    cont = np.zeros(n.shape, dtype=bool)
    for rho in (1.0, -1.0):
        k = sigma * rho
        lam = 1.0 + sp * sp - k * f * sp * cp
        singular = np.abs(lam) <= TOL * (2.0 + f)
        ok = (q_zero | (q * lam > 0)) if rho > 0 else (~q_zero & (q * lam < 0))
        n += (~singular & ok).astype(np.int8)
        cont |= singular & q_zero
    return np.where(cont, 3, n).astype(np.int8)


def numpy_hinge(phi, delta, omega, l, g, m):
    cp = np.cos(phi)[:, None]
    w2 = omega * omega
    coef = l * l - delta * delta
    singular = np.abs(coef) <= TOL * (l * l + delta * delta)
    qn_zero = np.abs(l * w2 + g * cp) <= TOL * (l * w2 + g)
    n = np.where(coef > 0, 1, np.where(qn_zero, 1, 0))
    return np.where(singular, np.where(qn_zero, 3, 0), n).astype(np.int8)


NUMPY = {"ladder": numpy_ladder, "wheel": numpy_wheel, "elliptic_pendulum": numpy_elliptic,
         "hinge_pendulum": numpy_hinge}


@njit(parallel=True, cache=True)
def write_bound(out):
    """The hardware bound for an int8 map: a kernel that only writes its output."""
    n0, n1 = out.shape
    for i in prange(n0):
        for j in range(n1):
            out[i, j] = (i + j) & 3


# ------------------------------------------------------------------ runs -----
def scene_args(model, n):
    name2, (lo, hi), fixed = CASES[model]
    m = phasemap.MODELS[model]
    full = {**m.defaults, **fixed}
    lo_phi = 0.0 if model == "ladder" else -np.pi
    hi_phi = np.pi / 2 if model == "ladder" else np.pi
    axes = {"phi": np.linspace(lo_phi, hi_phi, n), name2: np.linspace(lo, hi, n)}
    full = {k: v for k, v in full.items() if k not in axes}
    return m, axes, full


def run_numba(model, n):
    m, axes, fixed = scene_args(model, n)
    return evaluate(m, axes, fixed, [layers_for(m)["n_solutions"]])["n_solutions"]


def run_numpy(model, n):
    m, axes, fixed = scene_args(model, n)
    name2 = CASES[model][0]
    args = {k: v for k, v in fixed.items()}
    args[name2] = axes[name2][None, :]
    return NUMPY[model](axes["phi"], **args)


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
        for n in args.sizes:
            ref = run_numpy(model, n) if n <= args.numpy_max else None
            got = run_numba(model, n)
            if ref is not None:
                mismatch = int((ref != got).sum())
                assert mismatch == 0, f"{model} {n}: NumPy and numba differ in {mismatch} cells"
            out = np.empty((n, n), dtype=np.int8)
            write_bound(out)
            times = {"numba1": [], "numbaN": [], "numpy": [], "bound1": [], "boundN": []}
            for _ in range(args.repeat):  # alternate the methods within the run
                numba.set_num_threads(1)
                times["numba1"].append(timed(run_numba, model, n)[0])
                times["bound1"].append(timed(write_bound, out)[0])
                numba.set_num_threads(threads_all)
                times["numbaN"].append(timed(run_numba, model, n)[0])
                times["boundN"].append(timed(write_bound, out)[0])
                if ref is not None:
                    times["numpy"].append(timed(run_numpy, model, n)[0])
            med = {k: statistics.median(v) if v else float("nan") for k, v in times.items()}
            cells = n * n
            rows.append((model, n, cells / med["numba1"], cells / med["numbaN"],
                         cells / med["numpy"], cells / med["boundN"],
                         med["numpy"] / med["numbaN"], med["boundN"] / med["numbaN"]))
            print(f"{model:18s} {n:5d}  numba 1t {cells / med['numba1'] / 1e6:8.1f} Mcell/s  "
                  f"{threads_all}t {cells / med['numbaN'] / 1e6:8.1f}  numpy "
                  f"{cells / med['numpy'] / 1e6:8.1f}  bound {cells / med['boundN'] / 1e6:8.1f}",
                  flush=True)
    cold_warm, cold_empty = cold_start(False), cold_start(True)
    lines = [
        "## Grid throughput (`benchmarks/grid.py`)",
        "",
        f"Machine: {machine()}.",
        f"2-D maps (phi x f, or phi x delta), layer `n_solutions`, moving state; medians of "
        f"{args.repeat} alternating runs; compilation excluded. Mcell/s = 10^6 cells per second.",
        "",
        f"| model | side | numba 1 thread | numba {threads_all} threads | NumPy | write bound "
        f"({threads_all} threads) | numba / NumPy | share of write bound |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for model, n, r1, rn, rnp, rb, speedup, share in rows:
        np_txt = f"{rnp / 1e6:.1f}" if np.isfinite(rnp) else "not run"
        sp_txt = f"{speedup:.1f}x" if np.isfinite(speedup) else "-"
        lines.append(f"| {model} | {n}^2 | {r1 / 1e6:.1f} | {rn / 1e6:.1f} | {np_txt} | "
                     f"{rb / 1e6:.0f} | {sp_txt} | {100 * share:.1f} % |")
    lines += [
        "",
        f"Cold start (fresh process: import phasemap and map 8 cells of the ladder): "
        f"{cold_warm:.2f} s with numba's on-disk cache warm, {cold_empty:.2f} s with an empty "
        f"cache (full compilation).",
        "",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section(text, "## Grid throughput")


def write_section(text: str, heading: str) -> None:
    """Replace (or append) the section that starts with ``heading`` in BENCHMARKS.md."""
    path = ROOT / "BENCHMARKS.md"
    old = path.read_text() if path.exists() else "# Benchmarks\n\n"
    if heading in old:
        start = old.index(heading)
        nxt = old.find("\n## ", start + len(heading))
        old = old[:start] + old[nxt + 1:] if nxt >= 0 else old[:start]
    path.write_text(old.rstrip() + "\n\n" + text.rstrip() + "\n")


if __name__ == "__main__":
    main()
