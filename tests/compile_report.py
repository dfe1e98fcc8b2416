"""What the suite compiles, from the logs that ``PHASEMAP_COMPILE_LOG=folder`` writes.

    PHASEMAP_COMPILE_LOG=/tmp/compiles python -m pytest ...   # cold caches
    python tests/compile_report.py /tmp/compiles

Prints the CPU seconds of numba compilation per test (most first: the test that first
needs a kernel pays for it), per kind of kernel (the engine and the model, digests
left out), and the kernels compiled more than once (by both xdist workers at once, or
again in a child process with a cache of its own).
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
