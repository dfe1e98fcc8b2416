"""The motion layers of a map in full coordinates (:mod:`phasemap.maps.full`: the friction
oscillators, a declared system without a reduced model): what each cell's state does
when it moves.

Each cell is the start of one motion, run by the engine :func:`phasemap.simulate` runs
in full coordinates (:mod:`phasemap.motion.hybrid`: every stick-slip transition, lift-off,
impact and Zeno decided as there), from the cell's time ``t`` where the system is forced.

* **Fate layers**, of the motion over ``t_end`` (the scene's integrator options, and its
  contact settings ``impact_law``, ``restitution``, ``painleve``, ``zeno_speed``):
  ``fate`` (how it ended, as :class:`phasemap.Event`; ``horizon`` where it ran through),
  ``n_reversals``, ``n_sticks`` (the times a contact stuck to its surface), ``t_final``
  and ``t_rest`` (from the start), and the end state ``x_final``, ``xdot_final``...
* **Orbit layers**, of the settled motion, as :func:`phasemap.orbit_diagram` finds it:
  ``section_x``, ``section_xdot``... on one more dimension, ``cycle``: the state once
  per forcing period at the forcing phase ``phase`` (of an autonomous system, at each
  maximum of the coordinate ``section``), the first ``settle`` discarded and ``periods``
  kept; and ``multiple``, the settled motion's period in those points (0 for none up
  to 16).  A scene over one parameter is the classical orbit diagram, over two a map of
  the periods.  Their options are ``periods`` (200), ``settle`` (100), ``phase`` (0)
  and ``section``.  A scene with an orbit layer integrates at ``rtol`` =
  :data:`ORBIT_RTOL` unless it gives one (a period is read to 1e-6 of the points'
  scale); they read ``rtol`` and the contact settings, as ``orbit_diagram`` does, while
  ``t_end`` and the step settings are the fate layers'.  Either runs scipy's DOP853 on
  the compiled flow, as ``simulate`` does in full coordinates, whatever ``method``.

A cell costs one motion: some milliseconds over a few dozen events, and about 2 ms a
forcing period for the orbit layers (BENCHMARKS.md, Orbit diagrams).  The cells run
one at a time, in blocks with a progress bar; ``Scene.compute(chunks=...)`` runs the
blocks with dask, in other processes or on a cluster.

>>> import numpy as np, phasemap
>>> ds = phasemap.Scene("den_hartog", axes={"f": [0.3, 0.5]}, fixed={"Omega": 0.8},
...                     layers=["multiple", "section_x"],
...                     options={"periods": 3, "settle": 100}).compute()
>>> ds.section_x.dims, ds.multiple.values.tolist()      # period-one orbits
(('f', 'cycle'), [1, 1])

On the belt (v = 0.2), a block riding with it at x = -0.5 slips at x = 1 (t = 7.5 s),
then sticks again at x = 0 (3.9 s later) on the stick-slip orbit; one at x = 2 slips
from the start.  Neither ever rests:

>>> fates = phasemap.Scene("belt", axes={"x": [-0.5, 2.0]}, fixed={"xdot": 0.2},
...                        layers=["fate", "n_sticks"], options={"t_end": 20.0}).compute()
>>> fates.n_sticks.values.tolist(), fates.fate.values.tolist() == [phasemap.Event.HORIZON] * 2
([1, 2], True)
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from phasemap.core import events as ev
from phasemap.maps.layers import layers_for

#: The options of the orbit layers and their defaults (:func:`phasemap.orbit_diagram`'s).
ORBIT_OPTIONS = {"periods": 200, "settle": 100, "phase": 0.0, "section": None}
#: The orbit layers' tolerance where the scene gives none (the fate layers' default,
#: 1e-6, would blur a period-m orbit's points beyond the 1e-6 that ``multiple`` reads).
ORBIT_RTOL = 1e-8
#: What a cell's motion to ``t_end`` can fail with (the cell is then NaN, its fate
#: ``step_failure``, and a warning names the first such cell).
FAILURES = (ValueError, ArithmeticError, np.linalg.LinAlgError)


def is_orbit(layer) -> bool:
    """Whether ``layer`` reads the settled motion (its section points)."""
    return layer.cycle or layer.name == "multiple"


def split(model, options: dict, layers, registry) -> tuple[dict, dict | None]:
    """``(the other options, the orbit settings or None)`` of a scene's ``options``: the
    orbit options taken out and checked (a one-line ValueError), None where no layer
    asks for the settled motion."""
    from phasemap.motion.periodic.diagram import settings

    opts = dict(options)
    given = {k: opts.pop(k) for k in ORBIT_OPTIONS if k in opts}
    orbit = [n for n in layers if is_orbit(registry[n])]
    if not orbit:
        if given:
            raise ValueError(f"{model.name}: {sorted(given)[0]} is an option of the orbit "
                             "layers (multiple, section_...); ask for one of them, or leave "
                             "it out")
        return opts, None
    spec = settings(model.mech, **{**ORBIT_OPTIONS, **given},
                    rtol=opts.get("rtol", ORBIT_RTOL))
    return opts, spec


#: The most forcing periods (settling and kept) a timed estimate's sample cells run: a
#: cell's time grows with its periods, so a long one is timed short and scaled.
SAMPLE_PERIODS = 20


def timed_parts(scene) -> list | None:
    """``[(scene, factor), ...]`` whose times per cell, scaled by their factors, add up
    to ``scene``'s: its orbit layers over at most :data:`SAMPLE_PERIODS` periods (the
    same share kept), scaled by its periods over those, and its other layers as they
    are; None where the orbit layers run no more than that (or there are none)."""
    import copy

    total = scene.orbit["settle"] + scene.orbit["periods"] if scene.orbit else 0
    if total <= SAMPLE_PERIODS:
        return None
    reg = layers_for(scene.model)
    short = copy.copy(scene)
    periods = max(1, round(SAMPLE_PERIODS * scene.orbit["periods"] / total))
    short.orbit = {**scene.orbit, "periods": periods, "settle": SAMPLE_PERIODS - periods}
    short.layers = tuple(n for n in scene.layers if is_orbit(reg[n]))
    parts = [(short, total / SAMPLE_PERIODS)]
    rest = tuple(n for n in scene.layers if not is_orbit(reg[n]))
    if rest:
        other = copy.copy(scene)
        other.layers, other.orbit = rest, None
        parts.append((other, 1.0))
    return parts


def cycles(scene) -> int:
    """The length of the ``cycle`` dimension of ``scene``'s orbit layers (0: none)."""
    return scene.orbit["periods"] if getattr(scene, "orbit", None) else 0


def evaluate(scene, axes: dict, wanted) -> dict[str, np.ndarray]:
    """The motion layers ``wanted`` of ``scene`` over the grid of ``axes``: each cell's
    motion to ``t_end`` for the fate layers, its settled motion for the orbit layers."""
    from phasemap.motion.hybrid.results import run_full
    from phasemap.motion.periodic.diagram import multiple, strobe
    from phasemap.motion.periodic.orbit import state_variables

    m, o = scene.model, scene.options
    mech = m.mech
    names = list(axes)
    shape = tuple(np.size(a) for a in axes.values())
    state = [nm for nm, _ in state_variables(mech)]
    ends = [l for l in wanted if not is_orbit(l)]
    orbit = [l for l in wanted if is_orbit(l)]
    out = {l.name: np.empty(shape + ((cycles(scene),) if l.cycle else ()), dtype=l.dtype)
           for l in wanted}
    failed = []
    for index in np.ndindex(*shape):
        values = {**scene.fixed, **{nm: float(axes[nm][j]) for nm, j in zip(names, index)}}
        q, u, p, t0 = m.state_of(values)
        if ends:
            try:
                # (the fate layers read the events: no saved steps, one requested time)
                rec = run_full(mech, p, q, u, t0=t0, t_end=t0 + o.t_end, rtol=o.rtol,
                               atol=o.atol, max_step=o.max_step, max_steps=o.max_steps,
                               max_events=o.max_events, t_eval=[t0 + o.t_end],
                               **scene.contact)
                row = _ends(rec, t0, o.t_end, state)
            except FAILURES as err:
                failed.append((values, err))
                row = {"fate": ev.STEP_FAILURE}
            for l in ends:
                out[l.name][index] = row.get(l.name, -1 if l.dtype == "int32" else math.nan)
        if orbit:
            try:
                pts, _, _ = strobe(mech, p, q, u, scene.orbit, t0, scene.contact)
            except FAILURES as err:
                failed.append((values, err))
                pts = np.full((cycles(scene), len(state)), np.nan)
            for l in orbit:
                out[l.name][index] = (multiple(pts) if l.name == "multiple"
                                      else pts[:, state.index(l.name[len("section_"):])])
    if failed:
        values, err = failed[0]
        warnings.warn(f"{m.name}: {len(failed)} motions of {math.prod(shape)} cells could "
                      "not be run (their fate is step_failure, their values NaN, their "
                      f"multiple 0); the first, {values}: {err}", RuntimeWarning,
                      stacklevel=3)
    return out


def _ends(rec, t0: float, t_end: float, state) -> dict:
    """The fate layers' values of one motion's :class:`phasemap.motion.hybrid.Record`
    from ``t0`` over ``t_end``."""
    kinds = np.array(rec.ev_kind)
    # (t_end itself where it ran through: (t0 + t_end) - t0 need not round to it)
    t_final = t_end if rec.fate == ev.HORIZON else float(rec.ev_t[-1]) - t0
    row = {"fate": int(rec.fate), "n_reversals": int(np.count_nonzero(kinds == ev.REVERSAL)),
           "n_sticks": int(np.count_nonzero(kinds == ev.STICK)), "t_final": t_final,
           "t_rest": t_final if rec.fate == ev.REST else math.nan}
    row.update({f"{nm}_final": float(x) for nm, x in zip(state, rec.ev_y[-1])})
    return row
