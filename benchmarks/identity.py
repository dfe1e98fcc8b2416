"""Bit-identity of results across a refactoring: hash what the public calls return.

Runs a fixed set of public calls (maps of every built-in model with every layer it has,
fate maps, ``simulate``, ``phase_curve``, ``boundaries``, ``threshold``) and prints one
SHA-256 per call, of every data variable's and coordinate's bytes (dtype and shape
included) and of the attributes that carry results (dates and versions left out).
Run it on two trees and compare the files::

    python benchmarks/identity.py > before.json     # on the old tree
    python benchmarks/identity.py > after.json      # on the new tree
    diff before.json after.json

``--data`` hashes the arrays alone (no attributes).

Kernels compile the first time, so a cold run takes minutes; ``NUMBA_OPT=1`` makes it
faster and does not change a float (phasemap never asks for fast-math).
"""

from __future__ import annotations

import hashlib
import json
import sys
import warnings

import numpy as np

import phasemap

#: Attributes that say when or with what a result was made, not what it is.
VOLATILE = ("history", "date_created", "phasemap_version", "source", "phasemap_seconds")


def digest(obj, data_only: bool = False) -> str:
    """SHA-256 of a Dataset's variables, coordinates and result attributes (or of a
    threshold's fields); with ``data_only`` of the arrays alone (a new event code adds
    to every trajectory's flag attributes, not to its numbers)."""
    h = hashlib.sha256()
    if hasattr(obj, "variables"):
        for name in sorted(obj.variables):
            v = obj.variables[name]
            a = np.ascontiguousarray(v.values)
            h.update(f"{name}{a.dtype}{a.shape}{v.dims}".encode())
            h.update(a.tobytes() if a.dtype != object else repr(a.tolist()).encode())
            if not data_only:
                h.update(repr(sorted((k, str(x)) for k, x in v.attrs.items()
                                     if k not in VOLATILE)).encode())
        if not data_only:
            h.update(repr(sorted((k, str(x)) for k, x in obj.attrs.items()
                                 if k not in VOLATILE)).encode())
    else:
        h.update(repr(obj).encode())
    return h.hexdigest()


def cases():
    """(name, thunk) for every call hashed."""
    lin = np.linspace
    maps = {
        "ladder": ({"phi": lin(0.01, 1.55, 61), "f": lin(0, 3, 47)}, {"omega": 1.0}),
        "wheel": ({"phi": lin(-3, 3, 61), "delta": lin(0, 1, 47)}, {"omega": 1.0}),
        "elliptic_pendulum": ({"phi": lin(-3, 3, 61), "f": lin(0, 6, 47)},
                              {"omega": 0.5, "xdot": 1.0}),
        "hinge_pendulum": ({"phi": lin(-3, 3, 61), "delta": lin(0, 1.5, 47)}, {"omega": 1.0}),
        "painleve_rod": ({"theta": lin(0.05, 1.5, 61), "f": lin(0, 3, 47)},
                         {"omega": 1.0, "xdot": -1.0}),
        "rod_on_step": ({"theta": lin(0.45, 1.55, 61), "f": lin(0, 2, 47)}, {"omega": 1.0}),
    }
    for name, (axes, fixed) in maps.items():
        yield f"map {name}", lambda n=name, a=axes, f=fixed: phasemap.Scene(
            n, axes=a, fixed=f, layers=[k for k, ly in phasemap.layers_for(n).items()
                                        if not ly.fate]).compute()
    yield "fates hinge", lambda: phasemap.Scene(
        "hinge_pendulum", axes={"phi": lin(-3, 3, 21), "omega": lin(-6, 6, 21)},
        layers=["fate", "phi_rest", "n_reversals", "t_final"], options={"t_end": 30.0}).compute()
    yield "fates ladder", lambda: phasemap.Scene(
        "ladder", axes={"phi": lin(0.05, 1.5, 17), "omega": lin(-2, 2, 17)},
        fixed={"f": 0.3}, layers=["fate", "t_final"], options={"t_end": 5.0}).compute()
    yield "simulate hinge", lambda: phasemap.simulate("hinge_pendulum", phi=2.5, omega=0.0,
                                                      t_end=10.0)
    yield "simulate elliptic", lambda: phasemap.simulate("elliptic_pendulum", t_end=3.0, phi=1.0,
                                                         omega=0.0, xdot=1.0, f=0.3)
    yield "simulate elliptic none", lambda: phasemap.simulate("elliptic_pendulum", t_end=1.0,
                                                              phi=0.8, xdot=1.0, f=4.0)
    yield "simulate ladder", lambda: phasemap.simulate("ladder", phi=0.3, omega=0.0, f=0.2,
                                                       t_end=3.0)
    yield "simulate wheel", lambda: phasemap.simulate("wheel", phi=1.0, omega=2.0, t_end=5.0)
    yield "simulate hinge dop853", lambda: phasemap.simulate(
        "hinge_pendulum", phi=2.0, omega=1.0, t_end=5.0, method="DOP853", rtol=1e-10)
    yield "phase hinge", lambda: phasemap.phase_curve("hinge_pendulum", phi=2.5, omega=0.0,
                                                      delta=0.1)
    yield "phase ladder", lambda: phasemap.phase_curve("ladder", phi=0.3, omega=0.0, f=0.2)
    yield "phase wheel", lambda: phasemap.phase_curve("wheel", phi=1.0, omega=2.0)
    yield "boundaries rod", lambda: phasemap.boundaries(
        "painleve_rod", {"theta": (0.2, 1.5), "f": (0, 3)}, fixed={"xdot": -1.0, "omega": 0.0})
    yield "boundaries ladder", lambda: phasemap.boundaries(
        "ladder", {"phi": (0.05, 1.5), "f": (0, 3)}, fixed={"omega": 1.0})
    yield "threshold rod", lambda: phasemap.threshold(
        "painleve_rod", "f", value=0, over={"theta": (0.1, 1.5)},
        fixed={"xdot": -1.0, "omega": 0.0})
    try:
        from phasemap.claims import CASES
    except ImportError:  # the tree before the move into parts
        from phasemap.bifurcation.claims import CASES
    for i, case in enumerate(CASES):
        yield f"threshold claim {i} {case.study}", lambda c=case: phasemap.threshold(**c.call)


def main() -> None:
    data_only = "--data" in sys.argv[1:]
    out = {}
    warnings.simplefilter("ignore")
    for name, thunk in cases():
        try:
            out[name] = digest(thunk(), data_only)
        except Exception as exc:  # a call that fails must fail the same way
            out[name] = f"{type(exc).__name__}: {exc}"
        print(name, out[name], file=sys.stderr, flush=True)
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    print()


if __name__ == "__main__":
    main()
