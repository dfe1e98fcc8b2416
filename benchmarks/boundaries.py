"""The bifurcation set of a slice to 1e-10 beside a 512^2 raster of the same slice.

For each model, one slice (two axes, the fixed values, a layer): the median wall
time of ``phasemap.boundaries(..., tol=1e-10)`` (seeding raster, tracing, special
points, and the 128^2 completeness check, all included) beside the median of
``Scene(model, 512 x 512 axes of the same slice, layers=[layer]).compute()``,
both with warm caches (one untimed call first), the two calls alternating.  Per
thread first (``numba.set_num_threads(1)``), then the raster on 2 threads (the
tracer is serial).  Beside the wall times, the least CPU time of the process
(``time.process_time``) of each: steadier than wall time on a shared machine.
The table goes to BENCHMARKS.md, section "Boundaries", with the machine and its
load.

    python benchmarks/boundaries.py [--repeat 9] [--only MODEL,...] [--no-write]
"""

from __future__ import annotations

import argparse
import math
import pathlib
import statistics
import sys
import time

import numba
import numpy as np

import phasemap
from phasemap.bifurcation import tracing
from grid import load, machine, write_section  # benchmarks/grid.py: the report's helpers

ROOT = pathlib.Path(__file__).resolve().parents[1]
P = math.pi
#: model: (axes, fixed, layer)
SLICES = {
    "painleve_rod": ({"theta": (0.2, 1.5), "f": (0.0, 3.0)}, {"xdot": -1.0, "omega": 0.0},
                     "n_solutions"),
    "elliptic_pendulum": ({"phi": (-P, P), "f": (0.0, 6.0)}, {"xdot": 1.0, "omega": 0.0},
                          "n_solutions"),
    "ladder": ({"phi": (0.05, 1.5), "f": (0.05, 3.0)}, {"omega": 0.0}, "stagnation"),
    "hinge_pendulum": ({"phi": (-3.0, 3.0), "delta": (0.05, 1.4)}, {"omega": 0.0},
                       "stagnation"),
    "wheel": ({"phi": (-P, P), "delta": (0.0, 1.0)}, {"omega": 0.0}, "stagnation"),
}
N = 512


def timed(fns, repeat: int) -> list[tuple[float, float, float]]:
    """Per function of ``fns``, called in turn ``repeat`` times after one warm call each:
    (median wall time, best wall time, best CPU time).  The best is the run least
    disturbed by other work on a shared machine."""
    for fn in fns:
        fn()
    wall = [[] for _ in fns]
    cpu = [[] for _ in fns]
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            c0, t0 = time.process_time(), time.perf_counter()
            fn()
            wall[i].append(time.perf_counter() - t0)
            cpu[i].append(time.process_time() - c0)
    return [(statistics.median(w), min(w), min(c)) for w, c in zip(wall, cpu)]


def row(name: str, repeat: int) -> dict:
    axes, fixed, layer = SLICES[name]
    grid = {n: np.linspace(lo, hi, N) for n, (lo, hi) in axes.items()}

    def exact():
        return phasemap.boundaries(name, axes, fixed=fixed, layer=layer, tol=1e-10)

    def raster():
        return phasemap.Scene(name, axes=grid, fixed=fixed, layers=[layer]).compute()

    def parts():
        """The call's three stages, each timed: (slice, trace, Dataset) CPU seconds."""
        c0 = time.process_time()
        sl = tracing.make_slice(name, axes, fixed)
        c1 = time.process_time()
        traced = tracing.trace(sl, layer, 1e-10)
        c2 = time.process_time()
        tracing.to_dataset(sl, traced, layer, 1e-10)
        return c1 - c0, c2 - c1, time.process_time() - c2

    numba.set_num_threads(1)
    b = exact()
    t_exact, t_raster1 = timed([exact, raster], repeat)
    stages = np.min([parts() for _ in range(repeat + 1)][1:], axis=0)
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    t_raster2, = timed([raster], repeat)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    return dict(model=name, slice=", ".join(f"{n} {lo:.3g}..{hi:.3g}" for n, (lo, hi)
                                            in axes.items()),
                fixed=", ".join(f"{k} = {v:g}" for k, v in fixed.items()), layer=layer,
                pieces=b.sizes["piece"], vertices=b.sizes["vertex"], points=b.sizes["point"],
                worst=float(b.point_residual.max()) if b.sizes["point"] else 0.0,
                exact=t_exact, raster1=t_raster1, raster2=t_raster2, stages=stages)


def _t(pair) -> str:
    return f"{pair[0]:.4f} ({pair[1]:.4f})"


def table(rows: list[dict], repeat: int, loads: tuple[str, str], argv) -> str:
    lines = [
        "## Boundaries (`benchmarks/boundaries.py`)",
        "",
        f"`phasemap.boundaries(..., tol=1e-10)` of one slice per model (its pieces, crossings, "
        f"folds and ends; the 33^2 seeding raster and the 128^2 completeness check included) "
        f"beside a {N}^2 `Scene.compute()` of the same slice and layer: median (best) of "
        f"{repeat} warm runs, the two calls alternating, and the least CPU time of each "
        f"(`time.process_time`).  Machine: {machine()}, shared with other work; load average "
        f"{loads[0]} before, {loads[1]} after.  "
        "The tracer is serial; the raster is timed on 1 thread and on 2.  "
        f"`python benchmarks/boundaries.py {' '.join(argv)}`".rstrip() + ".",
        "",
        "| model | slice | fixed | layer | pieces | vertices | points | worst point residual "
        f"| boundaries (s) | {N}^2 raster, 1 thread (s) | ratio | CPU ratio | met "
        "| raster, 2 threads (s) | stages: slice, trace, Dataset (ms) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['model']} | {r['slice']} | {r['fixed']} | {r['layer']} | "
                     f"{r['pieces']} | {r['vertices']} | {r['points']} | {r['worst']:.1e} | "
                     f"{_t(r['exact'])} | {_t(r['raster1'])} | "
                     f"{r['exact'][1] / r['raster1'][1]:.2f} | "
                     f"{r['exact'][2] / r['raster1'][2]:.2f} | "
                     f"{'yes' if r['exact'][1] < r['raster1'][1] else 'no'} | {_t(r['raster2'])} | "
                     + ", ".join(f"{1e3 * x:.2f}" for x in r["stages"]) + " |")
    lines += ["", "ratio: best boundaries / best raster (1 thread), in wall time; CPU ratio: the "
              "same in CPU time; met: the wall ratio below 1, the exact set is cheaper than the "
              "raster (issue 21, item 6).  stages: the least CPU time of each stage of the call "
              "(validating the slice and loading its compiled conditions; the trace with its "
              "seeding raster, 128^2 check raster and completeness check; building the "
              "Dataset), each timed alone."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--only", help="models, comma separated")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    names = args.only.split(",") if args.only else list(SLICES)
    before = load()
    rows = []
    for name in names:
        rows.append(row(name, args.repeat))
        print(rows[-1], file=sys.stderr, flush=True)
    text = table(rows, args.repeat, (before, load()),
                 sys.argv[1:] if argv is None else list(argv))
    print(text)
    if not args.no_write:
        write_section(text, "## Boundaries")


if __name__ == "__main__":
    main()
