"""``phasemap tour``: run every study script and say where its figures are.

The studies live in the repository's ``studies/`` folder (phasemap/ only
defines; studies produce).  The tour finds that folder next to the package
(an editable install or a run from the clone) or in the working directory,
runs each study's ``main(["--quick", "--out", DIR])`` in turn with a progress
line, and ends with the list of figures and the count of verdicts.  With
progress on (the command line), each study runs under a ticking line on
stderr that names it and its elapsed time, so that no wait is silent, not even
numba compiling the kernels on a cold cache; the study's own progress bars
appear beneath it and its printing above.
"""

from __future__ import annotations

import contextlib
import importlib.util
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
         only: Sequence[str] | None = None, size: str = "two_column") -> int:
    """Run the studies into ``out``; return 0, or 1 when a claim disagrees.

    ``size`` lays the figures out for a journal's ``"two_column"`` width (the
    default), ``"one_column"`` or ``"both"`` (see :func:`phasemap.study.save_figures`).
    """
    folder = find_studies(studies)
    names = [n for n in ORDER if (folder / f"{n}.py").is_file()]
    if only:
        unknown = sorted(set(only) - set(names))
        if unknown:
            raise ValueError(f"unknown study {unknown[0]!r}; available: {', '.join(names)}")
        names = [n for n in names if n in only]
    out_dir = pathlib.Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    argv = ["--out", str(out_dir), "--size", size] + ([] if full else ["--quick"])
    verdicts: dict[str, int] = {}
    start = time.perf_counter()
    for i, name in enumerate(names, 1):
        print(f"\n[{i}/{len(names)}] {name} ({'full' if full else 'quick'}), "
              f"{time.perf_counter() - start:.0f} s so far", flush=True)
        # a ticking line on stderr for the whole study (compiling included), the
        # study's own bars beneath it, and its printing above both
        with progress.activity(f"[{i}/{len(names)}] {name}"), _above_the_bars():
            claims = load(folder / f"{name}.py").main(argv)
        for c in claims:
            verdicts[c.verdict] = verdicts.get(c.verdict, 0) + 1
    figures = sorted(out_dir.glob("*.png"))
    print(f"\nphasemap tour: {len(names)} studies in {time.perf_counter() - start:.0f} s; "
          f"atlases and figures in {out_dir}/")
    for png in figures:
        print(f"  {png}  (+ .pdf)")
    print("verdicts: " + ", ".join(f"{n} {k}" for k, n in sorted(verdicts.items())))
    sys.stdout.flush()
    return 1 if verdicts.get("DISAGREES") else 0
