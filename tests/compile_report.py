"""What the suite compiles and what each test costs, from the logs that
``PHASEMAP_TEST_LOG=folder`` writes (tests/conftest.py).

    PHASEMAP_TEST_LOG=/tmp/testlog python -m pytest ...   # cold caches, or warm
    python tests/compile_report.py /tmp/testlog

Prints the CPU seconds of numba compilation per test (most first: the test that first
needs a kernel pays for it), per kind of kernel (the engine and the model, digests
left out), and the kernels compiled more than once (by both xdist workers at once, or
again in a child process with a cache of its own); then the tests by CPU time (this
process and its children: what a test costs on a quiet machine) with their wall time,
and the CPU time of the tests marked ``slow`` and of the rest.
"""

from __future__ import annotations

import collections
import json
import pathlib
import re
import sys


def read(folder) -> list[dict]:
    return [json.loads(line) for path in sorted(pathlib.Path(folder).glob("compiles-*.jsonl"))
            for line in path.read_text().splitlines()]


def read_tests(folder) -> list[dict]:
    return [json.loads(line) for path in sorted(pathlib.Path(folder).glob("tests-*.jsonl"))
            for line in path.read_text().splitlines()]


def tests_report(rows: list[dict], slow: set[str], most: int = 30) -> str:
    rows = sorted(rows, key=lambda r: -r["cpu"])
    marked = sum(r["cpu"] for r in rows if r["test"].split("@")[0] in slow)
    out = [f"{len(rows)} tests, {sum(r['cpu'] for r in rows):.0f} s CPU "
           f"({marked:.0f} s in tests marked slow), {sum(r['wall'] for r in rows):.0f} s wall",
           "", "    CPU s   wall s  test"]
    out += [f"{r['cpu']:9.1f} {r['wall']:8.1f}  {r['test'].split('@')[0]}" for r in rows[:most]]
    return "\n".join(out)


def slow_tests() -> set[str]:
    """The node ids of the tests marked slow (collected without running them)."""
    import subprocess

    listed = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n0", "--collect-only",
                             "-m", "slow", "-p", "no:cacheprovider"], capture_output=True,
                            text=True, cwd=pathlib.Path(__file__).resolve().parents[1])
    return {line for line in listed.stdout.splitlines() if "::" in line}


def report(rows: list[dict], most: int = 30) -> str:
    per_test = collections.Counter()
    users = collections.defaultdict(list)
    for r in rows:
        test = r["test"].split("@")[0]
        per_test[test] += r["seconds"]
        users[(r["kernel"], r["args"])].append((test, r["seconds"]))
    out = [f"{len(rows)} compilations, {sum(per_test.values()):.0f} s CPU in all", "",
           "CPU seconds of compilation per test:"]
    out += [f"{s:8.1f}  {t}" for t, s in per_test.most_common(most)]
    again = {k: v for k, v in users.items() if len(v) > 1}
    out += ["", f"compiled more than once ({len(again)} kernels):"]
    out += [f"{sum(s for _, s in v[1:]):8.1f}  {k[0]}  x{len(v)}" for k, v in
            sorted(again.items(), key=lambda kv: -sum(s for _, s in kv[1][1:]))[:most]]
    kinds = collections.Counter()
    for r in rows:
        kinds[re.sub(r"_[0-9a-f]{8,}", "", r["kernel"])] += r["seconds"]
    out += ["", "CPU seconds per kind of kernel:"]
    out += [f"{s:8.1f}  {k}" for k, s in kinds.most_common(most)]
    return "\n".join(out)


if __name__ == "__main__":
    print(report(read(sys.argv[1])))
    tests = read_tests(sys.argv[1])
    if tests:
        print("\n" + tests_report(tests, slow_tests()))
