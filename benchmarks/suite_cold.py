"""The test suite from a fresh clone with empty caches: its CPU time and wall time.

Clones the tree's last commit into a temporary folder and runs the README's test command's
pytest there (``python -m pytest -q``: two xdist workers, every test, ``slow`` ones too),
with empty kernel and numba caches of its own and this interpreter's environment (pip is
not timed: the packages are installed).  *CPU* is the user + system time of the pytest
process and everything it waited for (its workers, the processes the tests start); the
background compiles phasemap starts run in sessions of their own and are counted where a
test waits for them.  The per-test figures come from the suite's own log
(``PHASEMAP_TEST_LOG``): each test's CPU time in its worker, and numba's compile time in
it.  Target (issue 40): <= 900 s of CPU from a fresh clone.

    python benchmarks/suite_cold.py

Writes the section "The test suite from a fresh clone" of ../BENCHMARKS.md.
"""

from __future__ import annotations

import collections
import json
import os
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

from _report import load, machine, parser, publish

ROOT = pathlib.Path(__file__).resolve().parents[1]


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = parser(__doc__)
    args = ap.parse_args()
    before = load()
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True, check=True).stdout.strip()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        clone = tmp / "clone"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        log = tmp / "log"
        env = {k: v for k, v in os.environ.items()
               if k not in ("NUMBA_CACHE_DIR", "NUMBA_OPT", "PHASEMAP_JIT")}
        env.update(PHASEMAP_CACHE_DIR=str(tmp / "kernels"), PHASEMAP_TEST_LOG=str(log),
                   PYTHONPATH=str(clone), CI="true")
        cpu0, wall0 = children_cpu(), time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"],
                             cwd=clone, env=env, capture_output=True, text=True)
        cpu, wall = children_cpu() - cpu0, time.perf_counter() - wall0
        summary = [line for line in out.stdout.splitlines() if " in " in line
                   and ("passed" in line or "failed" in line)]
        tests, compiled = collections.Counter(), 0.0
        for f in log.glob("tests-*.jsonl"):
            for line in f.read_text().splitlines():
                d = json.loads(line)
                tests[d["test"].split("@")[0]] += d["cpu"]
        for f in log.glob("compiles-*.jsonl"):
            for line in f.read_text().splitlines():
                compiled += json.loads(line)["seconds"]
    files = collections.Counter()
    for t, c in tests.items():
        files[t.split("::")[0]] += c
    verdict = "met" if cpu <= 900.0 else "**missed**"
    lines = [
        "## The test suite from a fresh clone (`benchmarks/suite_cold.py`)",
        "",
        f"Machine: {machine()}; load average {before} before, {load()} after.  ",
        "Command: `python benchmarks/suite_cold.py`",
        "",
        f"`python -m pytest -q` in a fresh clone of {commit}, empty kernel and numba caches, "
        "the packages installed (pip not timed).  *CPU*: user + system time of pytest, its "
        "two workers and the processes the tests start; *tests*: the sum of each test's CPU "
        "in its worker (the suite's log), of which *compiling* is numba's.  Target (issue 40): "
        "<= 900 s of CPU.",
        "",
        "| wall (s) | CPU (s) | tests: CPU (s) | compiling (s) | result | target |",
        "|---:|---:|---:|---:|---|---|",
        f"| {wall:.0f} | {cpu:.0f} | {sum(tests.values()):.0f} | {compiled:.0f} | "
        f"{summary[-1].strip('= ') if summary else 'no summary: ' + out.stdout[-200:]} | "
        f"{verdict} |",
        "",
        "The costliest test files (CPU in their workers, s): "
        + ", ".join(f"{f.removeprefix('tests/')} {c:.0f}" for f, c in files.most_common(8))
        + ".",
    ]
    publish(lines, "## The test suite from a fresh clone", not args.no_write)
    if out.returncode != 0:
        print(out.stdout[-3000:], out.stderr[-3000:], file=sys.stderr)
        sys.exit(out.returncode)


if __name__ == "__main__":
    main()
