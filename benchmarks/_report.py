"""What every benchmark script shares to report: the machine, its load, and its section
of BENCHMARKS.md (printed, then written in place of the old one).

The scripts run from any folder (``python benchmarks/NAME.py``); Python puts this
folder first on the path, so they import it as ``_report``.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import platform
import re

import numba
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]


def machine() -> str:
    """The cores, the CPU model and the versions that decide a kernel's speed."""
    cpu = platform.processor() or "unknown CPU"
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{os.cpu_count()} cores, {cpu}; Python {platform.python_version()}, "
            f"numba {numba.__version__}, numpy {np.__version__}")


def load() -> str:
    """The load average over the last minute, and the cores it is shared among."""
    return f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


def background_quiet(cache_folder: pathlib.Path, limit: float = 900.0) -> float:
    """Wait until no background compile (``phasemap.core.tiers``) of the kernel cache
    ``cache_folder`` runs: its ``compiling/`` folder holds no marker (a failed compile's
    ``.log`` stays); the seconds waited."""
    import time

    start = time.perf_counter()
    markers = cache_folder / "compiling"
    while (markers.exists() and any(p.suffix != ".log" for p in markers.iterdir())
           and time.perf_counter() - start < limit):
        time.sleep(0.25)
    return time.perf_counter() - start


def child_result(out, what: str):
    """What a script's child process printed as JSON on its line ``RESULT ...`` (``out``:
    its ``subprocess.run`` with the output captured); a RuntimeError with the end of its
    stderr, naming ``what``, where it printed none."""
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(f"{what}: the child failed:\n{out.stderr[-3000:]}")


def parser(doc: str) -> argparse.ArgumentParser:
    """A script's argument parser: its docstring's first line, and ``--no-write``."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--no-write", action="store_true", help="print only")
    return ap


def write_section(text: str, heading: str) -> None:
    """Replace, where it stands, the section that starts with ``heading`` in BENCHMARKS.md
    (or append it), so that a rerun's diff shows its figures alone."""
    path = ROOT / "BENCHMARKS.md"
    old = path.read_text() if path.exists() else "# Benchmarks\n\n"
    # the heading at the start of a line: "## Grid throughput" must not match the
    # declared systems' "### Grid throughput, 2048^2 maps" (it did, and deleted it)
    found = re.search(rf"(?m)^{re.escape(heading)}", old)
    if not found:
        path.write_text(old.rstrip() + "\n\n" + text.rstrip() + "\n")
        return
    start = found.start()
    nxt = old.find("\n## ", start + len(heading))
    rest = old[nxt + 1:] if nxt >= 0 else ""
    path.write_text(old[:start] + text.rstrip() + "\n" + ("\n" + rest if rest else ""))


def publish(lines, heading: str, write: bool = True) -> str:
    """Print a section (its text, or its lines) and, when ``write``, put it in
    BENCHMARKS.md under ``heading`` (a line such as ``"## Stability"``); returns the text."""
    text = lines if isinstance(lines, str) else "\n".join(lines)
    print(text)
    if write:
        write_section(text, heading)
    return text
