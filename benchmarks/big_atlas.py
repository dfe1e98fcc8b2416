"""Peak memory and time of a 10^9-cell atlas written block by block by the CLI.

Runs ``phasemap atlas`` in a child process on a 31623 x 31623 (phi, f) map of
the ladder (layer n_solutions, a moving state), and reports the child's peak
resident memory (getrusage), the wall time and the file size.  Writes the
result into ../BENCHMARKS.md.

    python benchmarks/big_atlas.py [--side 31623] [--out /tmp/phasemap-big.nc]
"""

from __future__ import annotations

import argparse
import pathlib
import resource
import subprocess
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _report import machine, publish  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--side", type=int, default=31623)
    ap.add_argument("--out", default="/tmp/phasemap-big.nc")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    cmd = [sys.executable, "-m", "phasemap.cli", "atlas", "ladder",
           "--axis", f"phi=0:1.5707963:{args.side}", "--axis", f"f=0:3:{args.side}",
           "--set", "omega=1", "--yes", "--overwrite", "-o", str(out)]
    t = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - t
    peak_mib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    cells = args.side ** 2
    size_mib = out.stat().st_size / 2 ** 20
    text = "\n".join([
        "## A 10^9-cell atlas on bounded memory (`benchmarks/big_atlas.py`)",
        "",
        f"Machine: {machine()}.",
        "",
        f"`phasemap atlas ladder --axis phi=0:1.5707963:{args.side} --axis f=0:3:{args.side} "
        f"--set omega=1 --yes`: {cells:.3e} cells, layer `n_solutions` (int8), computed and written "
        f"block by block straight into the file (`phasemap.maps.blocks.write_scene`, blocks of "
        f"about a quarter second, no dask graph).",
        "",
        "| cells | int8 data in memory if eager | peak resident memory | wall time | file size |",
        "|---:|---:|---:|---:|---:|",
        f"| {cells:.3e} | {cells / 2 ** 20:.0f} MiB | {peak_mib:.0f} MiB | {wall:.0f} s | "
        f"{size_mib:.1f} MiB |",
        "",
    ])
    out.unlink()
    publish(text, "## A 10^9-cell atlas", write=not args.no_write)


if __name__ == "__main__":
    main()
