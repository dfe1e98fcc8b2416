"""A new declaration's first classify from an empty kernel cache: sympy's derivation and
the classify, for every declaration the tests use, one contact and two (issue 40's
targets: <= 3 s of CPU with one contact, <= 10 s with two, the derivation included).

For each declaration a fresh process with an empty kernel cache (``PHASEMAP_CACHE_DIR``)
and numba cache (``NUMBA_CACHE_DIR``) of its own runs ``import phasemap``, makes the
System, derives it (``System.model``: sympy's derivation and the generated module's
text) and classifies once at its defaults (``phasemap.classify``, on the interpreted
twin, as under the default ``PHASEMAP_JIT=background``, here with ``off``: the
default's background compile is another process's CPU, and would share the cores with
the next run).  CPU is the process's user + system time, medians of ``--repeat``
runs.  ``--before REV`` runs the same processes on another tree (a git worktree of
REV) beside, alternating, so that a change to the derivation is measured against the
tree before it.

    python benchmarks/derive.py [--repeat 3] [--before REV]

Writes the section "Deriving a new declaration" of ../BENCHMARKS.md.
"""

from __future__ import annotations

import os
import pathlib
import statistics
import subprocess
import sys
import tempfile

from _report import child_result, load, machine, parser, publish

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: name -> the code that makes the System ``S`` (tests/unseen.py, the README's rod)
CASES = {
    "README rod": "sys.path.insert(0, str(ROOT / 'docs' / 'examples'))\n"
                  "from own_system import SYSTEM as S",
    **{name: f"sys.path.insert(0, str(ROOT / 'tests'))\nimport unseen\nS = unseen.{name}()"
       for name in ("gyration_rod", "ledge_rod", "incline_point", "flat_block",
                    "corner_block", "leaning_ladder", "drawer", "peg_rod")},
    **{f"barrow {seed}": f"sys.path.insert(0, str(ROOT / 'tests'))\nimport unseen\n"
                         f"S, _ = unseen.barrow({seed})" for seed in (1, 4)},
}

CHILD = r'''
import json, pathlib, resource, sys, time
ROOT = pathlib.Path({root!r})

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

t0 = cpu()
import phasemap
t1 = cpu()
{make}
m = S.model
t2 = cpu()
phasemap.classify(m)
t3 = cpu()
print("RESULT " + json.dumps(dict(contacts=len(S.contacts), imp=t1 - t0, derive=t2 - t1,
                                  classify=t3 - t2, total=t3)))
'''


def run(name: str, tree: pathlib.Path) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, PHASEMAP_CACHE_DIR=str(pathlib.Path(tmp) / "kernels"),
                   NUMBA_CACHE_DIR=str(pathlib.Path(tmp) / "numba"),
                   PYTHONPATH=os.pathsep.join([str(tree), os.environ.get("PYTHONPATH", "")]))
        # the interpreted twin answers, as the default's first call does, without the
        # background compile the default starts (its CPU is another process's, and it
        # would share the cores with the next run)
        env["PHASEMAP_JIT"] = "off"
        code = CHILD.format(root=str(tree), make=CASES[name])
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, cwd=tmp)
    return child_result(out, f"{name} ({tree})")


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--only", nargs="*", choices=list(CASES), default=list(CASES))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--before", help="a git revision to measure beside (its worktree)")
    args = ap.parse_args()
    before_load = load()
    trees = {"now": ROOT}
    worktree = None
    if args.before:
        worktree = pathlib.Path(tempfile.mkdtemp()) / "before"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "-f", "--detach",
                        str(worktree), args.before], check=True, capture_output=True)
        trees["before"] = worktree
    runs: dict = {(n, t): [] for n in args.only for t in trees}
    try:
        for _ in range(args.repeat):
            for name in args.only:
                for t, tree in trees.items():       # (alternating: the same load for both)
                    runs[name, t].append(run(name, tree))
    finally:
        if worktree is not None:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                            str(worktree)], capture_output=True)

    def med(name, t, key):
        return statistics.median(r[key] for r in runs[name, t])

    head = "| declaration | contacts | import phasemap | derive | first classify | total CPU |"
    rule = "|---|---:|---:|---:|---:|---:|"
    if args.before:
        head += f" before ({args.before}): derive | total |"
        rule += "---:|---:|"
    head += " target |"
    rule += "---|"
    lines = [
        "## Deriving a new declaration (`benchmarks/derive.py`)",
        "",
        f"Machine: {machine()}; load average {before_load} before, {load()} after.  ",
        f"Command: `python benchmarks/derive.py --repeat {args.repeat}"
        + (f" --before {args.before}`" if args.before else "`"),
        "",
        "A fresh process per declaration and run with empty kernel and numba caches: "
        "`import phasemap`, sympy's derivation (`System.model`) and one `phasemap.classify` "
        "at the declaration's defaults (its interpreted twin, which the default "
        "`PHASEMAP_JIT=background` answers a first call with; run with `off`, which starts "
        "no background compile).  CPU time of the process (s), medians of "
        f"{args.repeat} runs"
        + (", the tree before beside, alternating" if args.before else "") + ".  "
        "The declarations are those of tests/unseen.py and the README's rod; a wheelbarrow "
        "(two contacts, one of them rolling, its rest statically indeterminate) is the "
        "costliest: its family of reactions is parametrised on every minor that does not "
        "vanish.  Targets (issue 40): a new declaration's first classify, its derivation "
        "included, <= 3 s of CPU with one contact, <= 10 s with two.",
        "",
        head,
        rule,
    ]
    for name in args.only:
        n = runs[name, "now"][0]["contacts"]
        total = med(name, "now", "total")
        target = 3.0 if n == 1 else 10.0
        row = (f"| {name} | {n} | {med(name, 'now', 'imp'):.2f} | "
               f"{med(name, 'now', 'derive'):.2f} | {med(name, 'now', 'classify'):.2f} | "
               f"{total:.2f} |")
        if args.before:
            row += f" {med(name, 'before', 'derive'):.2f} | {med(name, 'before', 'total'):.2f} |"
        row += f" {'met' if total <= target else '**missed**'} (<= {target:g} s) |"
        lines.append(row)
    publish(lines, "## Deriving a new declaration", not args.no_write)


if __name__ == "__main__":
    main()
