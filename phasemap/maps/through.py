"""Fate maps whose motions go on through contact changes (``options={"through_contacts":
True}`` of :class:`phasemap.Scene`).

A fate map's cells run the reduced model's compiled integrator, which ends a motion where
a contact must open, where the accelerations have no solution or two, or where a slip
reaches its singular point (``contact_lost``, ``no_solution``, ``indeterminate``,
``singular``).  With ``through_contacts``, each such cell of a declared system is run again
by :func:`phasemap.simulate` from its start, with the scene's integrator and contact
settings, and goes on in full coordinates through lift-off, flight, impacts, impacts
without collision, dynamic jams and Zeno (:mod:`phasemap.motion.hybrid`): its fate layers
are that motion's end.  A cell is exactly the motion ``simulate`` gives from its start.

A followed cell costs a ``simulate`` call without its Dataset
(:func:`phasemap.motion.simulate.motion_end`), 1-2 ms (its phases on the compiled flow,
what follows each event in Python; the wheel's 10^6-cell map, 9 % of it followed, takes
ten times the reduced one: BENCHMARKS.md).  The other cells keep the compiled integrator's values, bit for bit.
"""

from __future__ import annotations

import warnings

import numpy as np

from phasemap.core import args as _args
from phasemap.maps.layers import Outcome

#: The fate-map options that say how a motion goes on through contact changes, with the
#: defaults of :func:`phasemap.simulate` (``through_contacts`` off: a fate map ends its
#: motions where the reduced model ends them).
DEFAULTS = {"through_contacts": False, "impact_law": "stronge", "restitution": 0.0,
            "painleve": "liftoff", "zeno_speed": 1e-6}


def split(model, options: dict) -> tuple[dict, dict | None]:
    """``(integrator options, contact settings or None)`` of a scene's ``options``: the
    contact settings checked as :func:`phasemap.simulate` checks them, None where
    ``through_contacts`` is off (then no other contact setting may be given)."""
    from phasemap.maps.full import FullModel
    from phasemap.motion import hybrid

    full = isinstance(model, FullModel)     # always through its contact changes
    opts = dict(options)
    given = {k: opts.pop(k) for k in DEFAULTS if k in opts}
    through = given.pop("through_contacts", full)
    if not isinstance(through, (bool, np.bool_)):
        raise _args.WrongType(f"{model.name}: through_contacts must be True or False, got "
                              f"{_args.describe(through)}")
    if full and not through:
        raise ValueError(f"{model.name}: a system in full coordinates always moves through "
                         "its contact changes; leave through_contacts out")
    if not through:
        if given:
            raise ValueError(f"{model.name}: {sorted(given)[0]} is a setting of motions "
                             "through contact changes; pass through_contacts=True with it")
        return opts, None
    if hybrid.declaration_of(model) is None:
        raise ValueError(f"{model.name}: through_contacts needs a declared system (its full "
                         "coordinates); this model is written by hand, and its motions end "
                         "where its contacts change")
    settings = {k: given.get(k, DEFAULTS[k]) for k in DEFAULTS if k != "through_contacts"}
    return opts, hybrid.check_contact_options(model.name, **settings)


def as_options(contact: dict | None) -> dict:
    """The contact settings as a scene's options (for its spec): nothing where off."""
    return {} if contact is None else {"through_contacts": True, **contact}


def go_on(scene, axes: dict, outcome: Outcome) -> Outcome:
    """``outcome`` with every cell that ended at a contact change followed through it by
    :func:`phasemap.simulate` (module docstring)."""
    from phasemap.motion.simulate import GOES_ON, motion_end

    fate, n_rev, t_final, positions = (np.array(a) for a in outcome)
    cells = np.flatnonzero(np.isin(fate, GOES_ON))
    if not cells.size:
        return outcome
    m, o = scene.model, scene.options
    names = list(axes)
    shape = fate.shape
    coords = [c[0] for c in m.dynamics.coordinates]
    failed = []
    for cell in cells:
        at = np.unravel_index(cell, shape)
        values = {**scene.fixed, **{n: float(axes[n][i]) for n, i in zip(names, at)}}
        try:
            # (the fate layers read the events: no saved steps, one requested time)
            end = motion_end(m, o.t_end, rtol=o.rtol, atol=o.atol, max_step=o.max_step,
                             max_steps=o.max_steps, max_events=o.max_events,
                             method=o.method, t_eval=[o.t_end], **scene.contact, **values)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
            failed.append((values, err))     # (the cell keeps the reduced model's end)
            continue
        fate[at], n_rev[at], t_final[at] = end.fate, end.n_reversals, end.t
        for j, name in enumerate(coords):
            positions[(j, *at)] = end.state[name]
    if failed:
        values, err = failed[0]
        warnings.warn(f"{m.name}: {len(failed)} of {cells.size} cells could not be followed "
                      "through their contact change and keep the reduced model's end; the "
                      f"first, {values}: {err}", RuntimeWarning, stacklevel=3)
    return Outcome(fate, n_rev, t_final, positions)
