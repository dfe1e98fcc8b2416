"""Study: the elliptic pendulum's paradox threshold, measured from atlases.

The paper (Lapshin 2021, after (27)) proves that Painleve's elliptic pendulum
has a unique solution for f <= 2.  phasemap's finding is the sharp version:
the no-solution (xdot > 0) and two-solution (xdot < 0) regions exist if and
only if f > 2 sqrt 2.  This study maps n_solutions over (phi, f) for both
slider directions, writes the two atlases, and measures the smallest f at
which a paradox cell appears.

    python studies/elliptic_threshold.py [--quick] [--out DIR]

Ends with a table of the claims checked, measured value beside the paper's.
"""

from __future__ import annotations

import argparse
import math
import pathlib

import numpy as np

import phasemap


def main(argv=None) -> list[tuple[str, str, str, str]]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse grids, a few seconds")
    ap.add_argument("--out", default="phasemap-out", help="folder for the atlases")
    args = ap.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    n_phi, n_f = (721, 801) if args.quick else (2881, 3201)
    f = np.linspace(2.0, 4.0, n_f)
    phi = np.linspace(-math.pi, math.pi, n_phi)

    first_paradox = {}
    for xdot, label in ((1.0, "right"), (-1.0, "left")):
        scene = phasemap.Scene("elliptic_pendulum", axes={"phi": phi, "f": f},
                               fixed={"xdot": xdot, "omega": 0.0},
                               layers=["n_solutions", "singular"])
        ds = scene.compute(progress=True)
        phasemap.write_atlas(ds, out / f"elliptic_threshold_{label}.nc")
        paradox = (ds.n_solutions != 1).any("phi").values
        first_paradox[label] = float(f[np.argmax(paradox)]) if paradox.any() else math.inf

    step = f[1] - f[0]
    sharp = 2 * math.sqrt(2)
    rows = [
        ("no solution for xdot > 0 first appears at f", "> 2 (proved safe up to 2)",
         f"{first_paradox['right']:.4f}", _verdict(first_paradox["right"], sharp, step)),
        ("two solutions for xdot < 0 first appear at f", "> 2 (proved safe up to 2)",
         f"{first_paradox['left']:.4f}", _verdict(first_paradox["left"], sharp, step)),
        ("unique everywhere for f <= 2", "yes",
         "yes" if min(first_paradox.values()) > 2.0 else "no",
         "agrees" if min(first_paradox.values()) > 2.0 else "DISAGREES"),
    ]
    width = [max(len(r[i]) for r in rows + [_HEAD]) for i in range(4)]
    for r in [_HEAD] + rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, width)).rstrip())
    print(f"sharp threshold 2 sqrt 2 = {sharp:.4f}; grid step in f = {step:.4f}; "
          f"atlases in {out}/")
    return rows


_HEAD = ("claim", "paper", "measured", "verdict")


def _verdict(measured: float, sharp: float, step: float) -> str:
    """Within one grid step above 2 sqrt 2: the sharp threshold, not the paper's 2."""
    return "sharp at 2 sqrt 2" if sharp <= measured <= sharp + step else "DISAGREES"


if __name__ == "__main__":
    main()
