"""The seeded fuzz of every public function and command, thousands of calls (issue 42).

Runs ``tests/fuzzing.py`` over every built-in model, under an address-space limit of the
process's size plus ``--memory-gib`` (so that a call that would take the machine's memory
meets a limit first), and writes the counts per entry point into BENCHMARKS.md: how many
calls answered, how many were refused in one line, every failure, and the slowest call
that compiled nothing.  A call during which numba compiled is a first call, counted
apart and exempt from the time bound.

    python benchmarks/fuzz.py                 # 5000 calls, seed 42
    python benchmarks/fuzz.py --calls 500 --seed 7 --no-write
"""

from __future__ import annotations

import pathlib
import resource
import sys
import tempfile
import time

from _report import ROOT, load, machine, parser, publish

sys.path.insert(0, str(ROOT / "tests"))

import numpy as np  # noqa: E402

import phasemap  # noqa: E402
import fuzzing  # noqa: E402


def limit_memory(gib: float) -> None:
    """Cap this process's address space at its size now plus ``gib``."""
    with open("/proc/self/status") as fh:
        vm = next(int(line.split()[1]) * 1024 for line in fh if line.startswith("VmSize"))
    resource.setrlimit(resource.RLIMIT_AS, (vm + int(gib * 2 ** 30), resource.RLIM_INFINITY))


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--calls", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=42)
    ap.add_argument("--memory-gib", type=float, default=4.0)
    args = ap.parse_args()
    models = list(phasemap.MODELS)
    folder = pathlib.Path(tempfile.mkdtemp(prefix="phasemap-fuzz-"))
    atlas = phasemap.write_atlas(phasemap.Scene(
        "ladder", axes={"phi": np.linspace(0.1, 1.4, 6), "f": np.linspace(0.0, 2.0, 5)}
    ).compute(), folder / "ladder.nc")
    limit_memory(args.memory_gib)
    t0 = time.perf_counter()

    def progress(i, tally):
        if i % 250 == 0:
            print(f"  {i:5d} calls, {time.perf_counter() - t0:7.1f} s, "
                  f"{len(tally.failures)} failures", flush=True)

    tally = fuzzing.run(args.calls, args.seed, models, folder, atlas, heavy=True,
                        progress=progress)
    seconds = time.perf_counter() - t0
    rows = ["| entry point | calls | answered | refused in one line |", "|---|---:|---:|---:|"]
    for entry in tally.entries():
        a, r = tally.answered.get(entry, 0), tally.refused.get(entry, 0)
        rows.append(f"| `{entry}` | {a + r} | {a} | {r} |")
    rows.append(f"| **all** | **{tally.calls}** | **{sum(tally.answered.values())}** | "
                f"**{sum(tally.refused.values())}** |")
    failures = "\n".join(f"- {f}" for f in tally.failures) or "none"
    text = f"""## Fuzz of every entry point (`benchmarks/fuzz.py`)

{tally.calls} calls drawn with seed {args.seed} over every built-in model
({', '.join(models)})
and every command, each with one argument awkward (NaN, inf, a
subnormal, a huge integer, a wrong type, a bad path, a malformed mapping; see
`tests/fuzzing.py`), under an address-space limit of the process plus
{args.memory_gib:g} GiB.  A call passes when it answers, or raises one ValueError or
TypeError that names its argument, within {fuzzing.BOUND:g} s when numba compiles nothing;
a command passes when it exits 0, or 1 or 2 with a last line that starts `phasemap` and
no traceback.  {seconds:.0f} s in all; {tally.compiling} calls compiled a kernel (first
calls, not timed); the slowest call that compiled nothing took {tally.slowest[0]:.2f} s
({tally.slowest[1]}).

{chr(10).join(rows)}

Failures: {failures}

Machine: {machine()}; load {load()}.  Rerun: `python benchmarks/fuzz.py` (seconds
with warm kernels; a first run compiles every model's kernels, which takes minutes).
"""
    publish(text, "## Fuzz of every entry point", not args.no_write)
    if tally.failures:
        sys.exit(1)


if __name__ == "__main__":
    main()
