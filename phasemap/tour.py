"""``phasemap tour``: run every study script and say where its figures are.

The studies live in the repository's ``studies/`` folder (phasemap/ only
defines; studies produce).  The tour finds that folder next to the package
(an editable install or a run from the clone) or in the working directory,
runs each study's ``main(["--quick", "--out", DIR])`` and ends with the list of
figures, the count of verdicts, and how much of the time numba spent compiling.

The studies are independent: on a machine with several cores they run at once, one
process each (``jobs``, default one per core), which on a cold cache compiles their
kernels in parallel (numba compiles on one thread).  Each study's printing is shown
whole, in the tour's order, as it ends; a ticking line on stderr names the studies
running and the time so far.  With ``jobs=1`` the studies run in this process in turn,
each under its own ticking line, its progress bars beneath it and its printing above.
"""

from __future__ import annotations

import contextlib
import io
from collections import Counter
import importlib.util
import os
import pathlib
import sys
import time
from typing import Iterator, Sequence

from phasemap.core import progress

#: The order of the tour: the four systems of the paper, the rod on a step (a declared
#: system with two frictional contacts), then the overview.
ORDER = ("ladder", "wheel", "elliptic_pendulum", "hinge_pendulum", "rod_on_step", "overview")


def find_studies(folder: str | None = None) -> pathlib.Path:
    """The folder of the study scripts; ValueError with a way out when there is none."""
    candidates = [pathlib.Path(folder)] if folder else [
        pathlib.Path.cwd() / "studies",
        pathlib.Path(__file__).resolve().parents[1] / "studies",
    ]
    for c in candidates:
        if (c / f"{ORDER[0]}.py").is_file():
            return c
    raise ValueError("no study scripts found (looked in "
                     f"{', '.join(str(c) for c in candidates)}); run the tour from a clone of "
                     "the phasemap repository or pass --studies DIR")


class _TqdmStdout:
    """A stdout that prints whole lines above the progress bars (``tqdm.write``)."""

    def __init__(self, stream):
        self.stream = stream
        self.pending = ""

    def write(self, text: str) -> int:
        from tqdm import tqdm

        self.pending += text
        *lines, self.pending = self.pending.split("\n")
        for line in lines:
            tqdm.write(line, file=self.stream)
        return len(text)

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return self.stream.isatty()


@contextlib.contextmanager
def _above_the_bars() -> Iterator[None]:
    if not progress.enabled():
        yield
        return
    out = _TqdmStdout(sys.stdout)
    try:
        with contextlib.redirect_stdout(out):
            yield
    finally:
        if out.pending:
            sys.stdout.write(out.pending + "\n")


def load(path: pathlib.Path):
    """Import a study script as a module."""
    spec = importlib.util.spec_from_file_location(f"phasemap_study_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def tour(out: str = "phasemap-out", *, full: bool = False, studies: str | None = None,
         only: Sequence[str] | None = None, size: str = "two_column",
         jobs: int | None = None) -> int:
    """Run the studies into ``out``; return 0, or 1 when a claim disagrees.

    ``size`` lays the figures out for a journal's ``"two_column"`` width (the
    default), ``"one_column"`` or ``"both"`` (see :func:`phasemap.study.save_figures`).
    ``jobs``: studies run at once, one process each (default: one per core, at most
    one per study); 1 runs them in this process, in turn.
    """
    from phasemap.core import compiletime
    from phasemap.core.args import count
    from phasemap.workers import default_jobs

    folder = find_studies(studies)
    names = [n for n in ORDER if (folder / f"{n}.py").is_file()]
    if only:
        unknown = sorted(set(only) - set(names))
        if unknown:
            raise ValueError(f"unknown study {unknown[0]!r}; available: {', '.join(names)}")
        names = [n for n in names if n in only]
    jobs = max(min(count("jobs", default_jobs() if jobs is None else jobs, "tour"),
                   len(names)), 1)
    out_dir = pathlib.Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    argv = ["--out", str(out_dir), "--size", size] + ([] if full else ["--quick"])
    verdicts: Counter[str] = Counter()
    start = time.perf_counter()
    compiled = compiletime.seconds()
    print(f"phasemap tour: {len(names)} stud{'ies' if len(names) > 1 else 'y'} "
          f"({'full' if full else 'quick'}) into {out_dir}/"
          + (f", {jobs} at a time in processes of their own" if jobs > 1 else ""),
          flush=True)
    if jobs == 1:
        for i, name in enumerate(names, 1):
            print(f"\n[{i}/{len(names)}] {name} ({'full' if full else 'quick'}), "
                  f"{time.perf_counter() - start:.0f} s so far", flush=True)
            # a ticking line on stderr for the whole study (compiling included), the
            # study's own bars beneath it, and its printing above both
            with progress.activity(f"[{i}/{len(names)}] {name}"), _above_the_bars(), \
                    _compiling_first():
                claims = load(folder / f"{name}.py").main(argv)
            verdicts.update(c.verdict for c in claims)
        compiled = compiletime.seconds() - compiled
    else:
        compiled = _in_parallel(folder, names, argv, jobs, full, start, verdicts)
    figures = sorted(out_dir.glob("*.png"))
    took = time.perf_counter() - start
    at_once = f", {jobs} at a time" if jobs > 1 else ""
    print(f"\nphasemap tour: {len(names)} studies in {took:.0f} s{at_once}; "
          f"atlases and figures in {out_dir}/")
    if compiled >= 1.0:
        summed = "summed over the processes; " if jobs > 1 else ""
        print(f"numba compiled kernels for {compiled:.0f} s of that ({summed}a second run "
              "loads them from the cache)")
    for png in figures:
        print(f"  {png}  (+ .pdf)")
    print("verdicts: " + ", ".join(f"{n} {k}" for k, n in sorted(verdicts.items())))
    sys.stdout.flush()
    return 1 if verdicts.get("DISAGREES") else 0


def _in_parallel(folder: pathlib.Path, names: list[str], argv: list[str], jobs: int,
                 full: bool, start: float, verdicts: Counter) -> float:
    """Run the studies ``jobs`` at a time, one process each
    (:func:`phasemap.workers.in_processes`); print each one's output in order as it ends;
    return the seconds numba compiled in them, summed."""
    from phasemap.workers import in_processes

    compiled = 0.0
    wall_start = time.time() - (time.perf_counter() - start)  # the clocks of two processes
    total = len(names)

    def status(running: list[int], done: int) -> None:
        now = ", ".join(f"[{i + 1}/{total}] {names[i]}" for i in running)
        progress.status(f"{now or 'starting'}; {done}/{total} done")

    calls = [(str(folder), name, argv) for name in names]
    with progress.activity(f"tour, {jobs} studies at a time"), _above_the_bars():
        for i, (text, counts, seconds, compile_s, ended) in in_processes(
                run_study, calls, jobs, status):
            print(f"\n[{i + 1}/{total}] {names[i]} ({'full' if full else 'quick'}), "
                  f"{seconds:.0f} s, ended {ended - wall_start:.0f} s into the tour")
            print(text, end="", flush=True)
            compiled += compile_s
            verdicts.update(counts)
    return compiled


@contextlib.contextmanager
def _compiling_first():
    """The studies compile before they answer (``PHASEMAP_JIT=eager``) unless the user chose
    otherwise: a study makes many calls of each kernel, and the interpreter tier's first
    answers (:mod:`phasemap.core.tiers`) would cost it the twins' arithmetic and background
    compiles that compete with the other studies for the cores: from empty caches the tour
    took 390 s of the machine's CPU time with them, 311 s compiling first (BENCHMARKS.md,
    the tour).  Set in the environment for the study's time, so that the threads it
    starts see it too (:func:`phasemap.core.tiers.forced` holds in its own thread only)."""
    if os.environ.get("PHASEMAP_JIT"):
        yield
        return
    os.environ["PHASEMAP_JIT"] = "eager"
    try:
        yield
    finally:
        os.environ.pop("PHASEMAP_JIT", None)


def run_study(folder: str, name: str, argv: list[str]
              ) -> tuple[str, dict, float, float, float]:
    """One study in a worker process: ``(its printing, {verdict: count}, seconds, seconds
    numba compiled, when it ended by the wall clock)``.  Progress bars stay off (the tour's
    own line shows progress)."""
    import phasemap  # noqa: F401 - installs the compile-time listener
    from phasemap.core import compiletime
    from phasemap.workers import ended_by_signal

    t0, c0 = time.perf_counter(), compiletime.seconds()
    out = io.StringIO()
    with progress.enable(False), ended_by_signal(), contextlib.redirect_stdout(out), \
            _compiling_first():
        claims = load(pathlib.Path(folder) / f"{name}.py").main(argv)
    return (out.getvalue(), Counter(c.verdict for c in claims), time.perf_counter() - t0,
            compiletime.seconds() - c0, time.time())
