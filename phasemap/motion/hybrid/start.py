"""A motion in full coordinates as :func:`phasemap.simulate` runs it: the declaration's
mechanics, the settings (bounded by the memory available), the Dataset's attributes,
and a start given in full coordinates (see :mod:`phasemap.motion.hybrid`)."""

from __future__ import annotations

import warnings

import numpy as np

from phasemap.core.progress import human_bytes
from phasemap.core.resources import MEMORY_COPIES, MEMORY_SHARE, available_memory
from phasemap.motion.hybrid.results import dataset, run_full, start_values


def mechanics_of(S):
    """The full-coordinate mechanics of a declaration (or a loaded model's lazy one, left
    unbuilt: its mechanics come from the kernel cache without sympy)."""
    from phasemap.declare.full import mechanics

    return mechanics(S)


def full_attrs(S, m, settings: dict, contact: dict, values) -> dict:
    """The attributes of a motion in full coordinates: the model's CF header (or the
    declaration's, where it has no reduced model), the settings (``Options.as_dict()``)
    and the start."""
    if m is not None:
        from phasemap.atlas.dataset import cf_header

        attrs = cf_header(m, "trajectory", "phasemap.simulate")
    else:
        from phasemap._version import __version__
        from phasemap.atlas.dataset import CONVENTIONS, created

        attrs = {"Conventions": CONVENTIONS,
                 "title": f"phasemap trajectory: {S.title}",
                 "source": f"phasemap {__version__}", "references": S.citation,
                 "phasemap_kind": "trajectory", "phasemap_model": S.name,
                 "phasemap_version": __version__, "date_created": created()}
    for k, value in settings.items():
        attrs[f"phasemap_{k}"] = value
    for k, value in contact.items():
        attrs[f"phasemap_{k}"] = value
    for k, value in values.items():
        attrs[f"phasemap_initial_{k}"] = float(value)
    return attrs


def simulate_full(S, m, opts, contact: dict, te, values, t0: float = 0.0):
    """A motion that starts in the full coordinates of the declaration ``S`` at ``t0``
    (``te``: the checked ``t_eval``, or None)."""
    mech = mechanics_of(S)
    if any(np.ndim(x) for x in values.values()):
        raise ValueError(f"{mech.name}: a start in full coordinates takes one number per "
                         "variable (the batch form runs on the reduced model only)")
    q, u, p = start_values(mech, values)
    settings = run_settings(opts, mech.n if te is None else 0)
    rec = run_full(mech, p, q, u, t0=t0, t_eval=te, **settings, **contact)
    recorded = opts.as_dict() if t0 == 0.0 else {**opts.as_dict(), "t0": t0}
    ds = dataset(mech, rec, full_attrs(S, m, recorded, contact, values), p=p)
    say_full_memory(ds, opts, settings)
    return ds


#: Bytes a saved point of a motion in full coordinates takes while it is integrated (a
#: Python list entry: its state array, its modes, its time), per coordinate and fixed.
FULL_POINT_BYTES = (48, 400)


def run_settings(opts, n: int = 0) -> dict:
    """The settings of a motion in full coordinates of ``n`` coordinates: ``max_steps``
    lowered, as the reduced integrator's (``phasemap.motion.simulate._memory_cap``), to
    what its saved points can hold in the memory available."""
    steps = opts.max_steps
    avail = available_memory()
    if avail is not None and n:
        per_point = FULL_POINT_BYTES[0] * n + FULL_POINT_BYTES[1]
        steps = int(min(steps, max(MEMORY_SHARE * avail / (MEMORY_COPIES * per_point), 16)))
    return {"t_end": opts.t_end, "rtol": opts.rtol, "atol": opts.atol,
            "max_step": opts.max_step, "max_steps": steps, "max_events": opts.max_events}


def say_full_memory(ds, opts, settings: dict) -> None:
    """A motion in full coordinates cut by :func:`run_settings`' memory cap says so."""
    if ds.attrs["end_reason"] == "max_steps" and settings["max_steps"] < opts.max_steps:
        message = (f"stopped after {settings['max_steps']:,} steps of the "
                   f"{opts.max_steps:,} allowed: saving more would not fit in the memory "
                   f"available ({human_bytes(available_memory() or 0)}); pass t_eval= to "
                   "save the state at chosen times only, or a shorter t_end")
        ds.attrs["end_message"] = message
        warnings.warn(f"{ds.attrs.get('phasemap_model', '')}: {message}", RuntimeWarning,
                      stacklevel=4)
