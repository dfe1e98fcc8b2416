"""Maps of the friction oscillators, which have no reduced model: speed per thread, and
every cell against its closed form.

* **The belt** (m = k = g = 1, f_s = 1, f_k = 0.5, v = 0.2) over x and x' in [-2, 2]
  (1000 x 1001 cells: x' = v is on the grid), ``n_solutions`` and ``stagnation``;
  checked against the closed form: one motion everywhere, stagnation exactly on the
  belt's speed where |k x| <= f_s m g.
* **Den Hartog's oscillator** (Omega = 0.8, f = 0.2) at x' = 0 over x in [-2, 2] and the
  forcing's phase t over one period (500 x 500), every layer; checked against
  |F0 cos(Omega t) - k x| <= f m g (stagnation) and m x'' = F0 cos(Omega t) - k x - f m g
  sgn(...) (the unique motion), away from the ties.
* **The same cells in Python:** the engine's own survey (``Motion.survey``, what the map's
  compiled kernel runs, with its grouping and ties in Python) on a sample of the belt's
  cells, per cell.

Wall time of ``Scene.compute()`` after a warm-up, best of ``--repeat``, on 1 and on 2
threads (``numba.set_num_threads``).  Writes the section "Maps of the friction
oscillators" of ../BENCHMARKS.md.

    python benchmarks/oscillator_maps.py [--repeat 3] [--no-write]
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

import _report
import phasemap


def best(fn, repeat):
    out, secs = None, []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        secs.append(time.perf_counter() - t0)
    return min(secs), out


def belt_check(ds) -> int:
    """Cells of the belt's map that differ from its closed form."""
    x, xd = np.meshgrid(ds.x.values, ds.xdot.values, indexing="ij")
    stuck = (np.abs(xd - 0.2) <= 1e-12) & (np.abs(x) <= 1.0)
    return int(np.sum(ds.stagnation.values != stuck) + np.sum(ds.n_solutions.values != 1))


def den_hartog_check(ds) -> tuple[int, float]:
    """Cells of Den Hartog's map whose stagnation differs from its closed form, and the
    largest error of x'' (both away from the ties, 1e-9)."""
    push = np.cos(0.8 * ds.t.values)[None, :] - ds.x.values[:, None]
    clear = np.abs(np.abs(push) - 0.2) > 1e-9
    bad = int(np.sum((ds.stagnation.values != (np.abs(push) <= 0.2))[clear]))
    want = np.where(np.abs(push) <= 0.2, 0.0, push - 0.2 * np.sign(push))
    return bad, float(np.max(np.abs(ds.x_ddot.values - want)[clear]))


def main() -> None:
    ap = _report.parser(__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    r = args.repeat
    from phasemap.core import tiers
    from phasemap.maps.full import map_model

    belt = phasemap.Scene("belt", axes={"x": np.linspace(-2, 2, 1000),
                                        "xdot": np.linspace(-2, 2, 1001)})
    dh = phasemap.Scene("den_hartog", axes={"x": np.linspace(-2, 2, 500),
                                            "t": np.linspace(0, 2 * math.pi / 0.8, 500)},
                        fixed={"xdot": 0.0}, layers=["n_solutions", "stagnation",
                                                     "contact_lost", "singular", "x_ddot",
                                                     "N_floor", "F_floor"])
    with tiers.forced("eager"):     # machine code before the clock starts, never the twins
        phasemap.Scene("belt", axes={"x": [0.0, 1.0]}).compute()
    rows = ["| map | cells | threads | wall time | per cell | cells off the closed form |",
            "|---|---:|---:|---:|---:|---|"]
    most = numba.get_num_threads()
    for threads in sorted({1, min(2, most)}):
        numba.set_num_threads(threads)
        sec, ds = best(lambda: belt.compute(progress=False), r)
        rows.append(f"| belt, x x x', n_solutions and stagnation | {belt.size:,} | {threads} "
                    f"| {sec:.2f} s | {sec / belt.size * 1e6:.2f} us | {belt_check(ds)} |")
        sec, ds = best(lambda: dh.compute(progress=False), r)
        bad, err = den_hartog_check(ds)
        rows.append(f"| Den Hartog, x x t at x' = 0, every layer | {dh.size:,} | {threads} | "
                    f"{sec:.2f} s | {sec / dh.size * 1e6:.2f} us | {bad} (x'' to {err:.0e}) |")
    numba.set_num_threads(most)
    m = map_model("belt")
    rng = np.random.default_rng(0)
    sample = [(float(x), float(v)) for x, v in zip(rng.uniform(-2, 2, 2000),
                                                  rng.choice([0.2, -1.0, 1.5], 2000))]
    motion = m.motion(np.array([m.defaults[p] for p in m.mech.parameters]))

    def python():
        for x, v in sample:
            q, u, _, t = m.state_of({**m.defaults, "x": x, "xdot": v})
            motion.survey(q, u, t=t)
    sec, _ = best(python, r)
    rows.append(f"| belt, the engine's survey in Python (`Motion.survey`), a sample | "
                f"{len(sample):,} | 1 | {sec:.2f} s | {sec / len(sample) * 1e6:.0f} us | "
                "- |")
    lines = ["## Maps of the friction oscillators (`benchmarks/oscillator_maps.py`)", "",
             f"Machine: {_report.machine()}; load {_report.load()}.  ",
             f"Command: `python benchmarks/oscillator_maps.py --repeat {r}`", "",
             f"Wall time of `Scene.compute()`, best of {r} runs, warm caches. The "
             "oscillators have no reduced model: a map's cells run in full coordinates, "
             "each the engine's own survey of the admissible phases "
             "(`phasemap.motion.hybrid.flow.survey_cells`, compiled, parallel over a "
             "block's cells), so the map, `classify` and `simulate` decide alike. Every "
             "cell is checked against its closed form in the same run.", "", *rows, "",
             "The belt's map computes the full state once per value of x and of x' (the "
             "closed contact's closure, in Python); the rest is the compiled kernel. A "
             "reduced model's map (BENCHMARKS.md, the grid evaluator) costs tens of "
             "nanoseconds a cell: these cells solve every candidate phase's linear "
             "system in full coordinates."]
    _report.publish(lines, "## Maps of the friction oscillators", write=not args.no_write)


if __name__ == "__main__":
    main()
