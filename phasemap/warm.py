"""``phasemap warm [MODEL ...]``: compile what a model's work needs, before the work.

numba compiles a kernel the first time a kind of work meets it, and keeps it in its
on-disk cache for every later process (``phasemap cache info``).  A long job, a script
run on a cluster, or a lecture that must not wait can compile first: ``warm`` makes, for
each model, one small call of each kind of work the model supports, so that the real
calls load their kernels from the cache.  The kinds, :data:`KINDS`:

``classify``     one state (:func:`phasemap.classify`);
``map``          the default atlas (``phasemap atlas MODEL``: its default axes and layers,
                 on a 3 x 3 grid; the kernel is the same for any grid of those axes);
``simulate``     a motion (:func:`phasemap.simulate`, its default method), for a model
                 that moves;
``fates``        a fate map over the default axes (a Scene with the layer ``fate``);
``phase_curve``  a phase curve, for a model of one coordinate;
``boundaries``   the exact class boundaries of the default slice (:func:`phasemap.boundaries`).

The calls run at once, one process each (``jobs``; numba compiles on one thread), under a
progress bar, and ``warm`` returns what each took and how much of it was compiling.  A
second ``warm`` finds every kernel in the cache and takes seconds.  Kernels that other
scenes need (other layers, another innermost axis) compile on their first use, as usual.

>>> from phasemap.warm import kinds_of
>>> kinds_of("ladder")
('classify', 'map', 'simulate', 'fates', 'phase_curve', 'boundaries')
>>> kinds_of("elliptic_pendulum")          # two coordinates: no phase curve
('classify', 'map', 'simulate', 'fates', 'boundaries')
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from typing import Sequence

from phasemap.core import progress

KINDS = ("classify", "map", "simulate", "fates", "phase_curve", "boundaries")


@dataclass(frozen=True)
class Warmed:
    """One kind of work warmed for one model: ``seconds`` in all, ``compiling`` of them
    spent by numba compiling (0 when every kernel came from the cache)."""

    model: str
    kind: str
    seconds: float
    compiling: float


def kinds_of(model) -> tuple[str, ...]:
    """The kinds of work (:data:`KINDS`) that ``model`` supports."""
    from phasemap.systems import get_model

    m = get_model(model)
    moves = m.dynamics is not None
    one = moves and len(m.dynamics.coordinates) == 1
    two_axes = len(m.default_axes) >= 2
    keep = {"classify": True, "map": True, "simulate": moves, "fates": moves,
            "phase_curve": one, "boundaries": two_axes}
    return tuple(k for k in KINDS if keep[k])


def warm(models: Sequence[str] | None = None, jobs: int | None = None,
         show: bool | None = None) -> list[Warmed]:
    """Compile what each of ``models`` (default: every built-in one; names or declaration
    files) needs, ``jobs`` calls at once (default one per core); return what each took.

    Raises
    ------
    ValueError
        for an unknown model, or ``jobs`` below 1.
    """
    from phasemap.core.args import count
    from phasemap.systems import MODELS, get_model
    from phasemap.workers import default_jobs, in_processes

    names = list(models) if models else list(MODELS)
    for name in names:
        get_model(name)  # an unknown name fails here, in one line, before any work
    work = [(name, kind) for name in names for kind in kinds_of(name)]
    jobs = max(min(count("jobs", default_jobs() if jobs is None else jobs, "warm"),
                   len(work)), 1)
    done = []
    desc = "warming" + (f", {jobs} at a time" if jobs > 1 else "")
    with progress.enable(progress.wanted(show), force=show is True), \
            progress.bar(len(work), desc, unit="call") as bar:
        if jobs == 1:
            for name, kind in work:
                done.append(warm_one(name, kind))
                bar.update(1)
        else:
            for _, warmed in in_processes(warm_one, work, jobs):
                done.append(warmed)
                bar.update(1)
    return done


def warm_one(model: str, kind: str) -> Warmed:
    """One small call of ``kind`` for ``model`` (in a worker process)."""
    import numpy as np

    import phasemap
    from phasemap.core import compiletime, tiers

    from phasemap.workers import ended_by_signal

    m = phasemap.get_model(model)
    t0, c0 = time.perf_counter(), compiletime.seconds()
    axes = {n: np.linspace(lo, hi, 3) for n, (lo, hi, _) in m.default_axes.items()}
    # machine code, compiled here: never the interpreted twin (phasemap.core.tiers)
    with progress.enable(False), ended_by_signal(), warnings.catch_warnings(), \
            tiers.forced("eager"):
        warnings.simplefilter("ignore")  # (an unexplained class change of the small slice)
        if kind == "classify":
            phasemap.classify(m)
        elif kind == "map":
            phasemap.Scene(m, axes=axes).compute()
        elif kind == "simulate":
            phasemap.simulate(m, 1e-3)
        elif kind == "fates":
            phasemap.Scene(m, axes=axes, layers=["fate"], options={"t_end": 1e-3}).compute()
        elif kind == "phase_curve":
            pos, vel = m.dynamics.coordinates[0][:2]
            phasemap.phase_curve(m, **{pos: m.defaults[pos], vel: m.defaults[vel]},
                                 max_stages=1)
        elif kind == "boundaries":
            x, y = list(m.default_axes)[:2]
            phasemap.boundaries(m, {x: m.default_axes[x][:2], y: m.default_axes[y][:2]},
                                strict=False)
        else:
            raise ValueError(f"unknown kind of work {kind!r}; known: {', '.join(KINDS)}")
    return Warmed(m.name, kind, time.perf_counter() - t0, compiletime.seconds() - c0)
