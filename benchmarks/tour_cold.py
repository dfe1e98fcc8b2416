"""The README's first command from empty caches, and again warm: ``phasemap tour``.

Runs ``phasemap tour`` (quick, one study per core) in a fresh folder with an empty kernel
cache (``PHASEMAP_CACHE_DIR``) and an empty numba cache (``NUMBA_CACHE_DIR``), then again
with both warm, and reports each run's wall time, its CPU time (user + system of the
tour and its study processes, as ``/usr/bin/time`` counts it), how long numba compiled
(the tour's own last line), and the CPU time the whole machine spent from the tour's start
until every background compile it started had ended (``/proc/stat``; this counts them,
which the process's own figure does not, and anything else the machine ran meanwhile:
run it on a quiet machine).  pip is not timed.

    python benchmarks/tour_cold.py

Writes the section "The tour from empty caches" of ../BENCHMARKS.md.
"""

from __future__ import annotations

import os
import pathlib
import re
import resource
import subprocess
import sys
import tempfile
import time

from _report import background_quiet, load, machine, parser, publish

TARGET_CPU, TARGET_WALL = 150.0, 120.0


def busy() -> float:
    """CPU seconds the whole machine has spent busy since boot (``/proc/stat``)."""
    fields = [int(x) for x in pathlib.Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
    return (fields[0] + fields[1] + fields[2] + fields[5] + fields[6]) / os.sysconf("SC_CLK_TCK")


def tour(folder: pathlib.Path, env: dict) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    b0, t0 = busy(), time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "phasemap.cli", "tour"], cwd=folder, env=env,
                         capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        raise RuntimeError(f"the tour failed:\n{out.stderr[-3000:]}")
    background_quiet(pathlib.Path(env["PHASEMAP_CACHE_DIR"]))
    compiled = re.search(r"numba compiled kernels for (\d+) s", out.stdout)
    return dict(wall=wall, cpu=(after.ru_utime - before.ru_utime)
                + (after.ru_stime - before.ru_stime), machine=busy() - b0,
                until=time.perf_counter() - t0,
                compiled=float(compiled.group(1)) if compiled else 0.0,
                verdicts=out.stdout.strip().splitlines()[-1] if out.stdout.strip() else "")


def main() -> None:
    args = parser(__doc__).parse_args()
    before = load()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_OPT", "PHASEMAP_JIT")}
        env.update(PHASEMAP_CACHE_DIR=str(tmp / "kernels"), NUMBA_CACHE_DIR=str(tmp / "numba"),
                   MPLBACKEND="Agg")
        runs = {}
        for name in ("empty caches", "warm caches"):
            (tmp / name).mkdir()
            runs[name] = tour(tmp / name, env)
            print(name, runs[name], file=sys.stderr, flush=True)
    cold = runs["empty caches"]
    lines = [
        "## The tour from empty caches (`benchmarks/tour_cold.py`)",
        "",
        f"Machine: {machine()}; load average {before} before, {load()} after.  ",
        "Command: `python benchmarks/tour_cold.py`",
        "",
        "`phasemap tour` (quick; one study process per core) in a fresh folder, first with "
        "empty kernel and numba caches, then with both warm.  *CPU*: user + system of the "
        "tour and its study processes (what `/usr/bin/time` counts); *compiling*: numba's "
        "compile time summed over them (the tour's own figure); *machine*: the CPU time "
        "the whole machine spent from the tour's start until every background compile it "
        "started had ended (they run in sessions of their own, which the process's CPU "
        "does not count), over *until* seconds.  pip is not timed.  Target (issue 40): "
        f"<= {TARGET_CPU:.0f} s of CPU and <= {TARGET_WALL:.0f} s of wall time from empty "
        "caches.",
        "",
        "| run | wall (s) | CPU (s) | compiling (s) | machine (s) | until (s) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, r in runs.items():
        lines.append(f"| {name} | {r['wall']:.0f} | {r['cpu']:.0f} | {r['compiled']:.0f} | "
                     f"{r['machine']:.0f} | {r['until']:.0f} |")
    met = cold["machine"] <= TARGET_CPU and cold["wall"] <= TARGET_WALL
    lines += ["", f"Target from empty caches: {'met' if met else '**missed**'} "
              f"({max(cold['cpu'], cold['machine']):.0f} s of CPU, {cold['wall']:.0f} s of "
              f"wall time).  The tour's last line: {cold['verdicts']}",
              "",
              "The studies compile before they answer (`PHASEMAP_JIT=eager` in the tour's "
              "study processes, unless it is set): on 2026-12-02, same machine, one run "
              "each from empty caches, the machine's CPU time was 348 s (wall 177 s) with "
              "the interpreter tier's twins for classify and simulate (the tree at "
              "4ea7232), 390 s (203 s) with them for the tracer and its conditions too (at "
              "50ad334), and 311 s (159 s) compiling first (each `PYTHONPATH=<checkout> "
              "python benchmarks/tour_cold.py`): a study makes many calls of each kernel, and the twins' arithmetic and "
              "the background compiles, which compete with the other study for the cores, "
              "cost more than they save."]
    publish(lines, "## The tour from empty caches", not args.no_write)


if __name__ == "__main__":
    main()
