"""What a motion through contact changes gives a user: its settings checked, its start in
full coordinates, and its Dataset (see :mod:`phasemap.motion.hybrid`)."""

from __future__ import annotations

import numpy as np

from phasemap.core import events as ev
from phasemap.motion.hybrid import flow
from phasemap.motion.hybrid.engine import (MODE_NAMES, POLICIES, ZENO_SPEED, Motion, Options,
                                           Record)


#: The settings by default, as :func:`check_contact_options` returns them.
DEFAULTS = {"impact_law": "stronge", "restitution": 0.0, "painleve": "liftoff",
            "zeno_speed": ZENO_SPEED}


def check_contact_options(name: str, impact_law, restitution, painleve, zeno_speed) -> dict:
    """The motion-through-contact-changes settings of :func:`phasemap.simulate`, checked
    (a one-line ValueError naming the setting)."""
    if (type(impact_law) is str and type(painleve) is str and type(restitution) is float
            and type(zeno_speed) is float and (impact_law, restitution, painleve, zeno_speed)
            == tuple(DEFAULTS.values())):
        return dict(DEFAULTS)   # (every motion passes here: the defaults cost nothing)
    from phasemap.core import args as _args
    from phasemap.motion.impact import LAWS

    if not isinstance(impact_law, str) or impact_law not in LAWS:
        raise ValueError(f"{name}: impact_law must be one of {', '.join(LAWS)}, got "
                         f"{_args.describe(impact_law)}")
    e = _args.finite("restitution", restitution, name, lower=0.0)
    if e > 1.0:
        raise ValueError(f"{name}: restitution must be in [0, 1], got {_args.describe(restitution)}")
    if not isinstance(painleve, str) or painleve not in POLICIES:
        raise ValueError(f"{name}: painleve must be one of {', '.join(POLICIES)}, got "
                         f"{_args.describe(painleve)}")
    z = _args.finite("zeno_speed", zeno_speed, name, lower=0.0)
    return {"impact_law": impact_law, "restitution": e, "painleve": painleve, "zeno_speed": z}


def declaration_of(model):
    """The declaration behind a model, or None: a :class:`phasemap.declare.System`, or a
    loaded model's lazy :class:`phasemap.declare.loader.Declaration`, resolved by
    :func:`system_of` where it is needed (a motion that meets a contact change)."""
    return getattr(model, "declaration", None)


def system_of(S):
    """The :class:`phasemap.declare.System` of :func:`declaration_of`'s result."""
    return getattr(S, "system", S)


def full_names(mech) -> set:
    """The names a full-coordinate state takes: every coordinate and its rate."""
    return set(mech.coordinates) | set(mech.rates)


def start_values(mech, values: dict, known: dict | None = None):
    """``(q, u, p)`` from values by name: the parameters' and coordinates' defaults where
    a name is missing, after ``known`` (the full state of a reduced start)."""
    from phasemap.core import args as _args

    bad = set(values) - full_names(mech) - set(mech.parameters)
    if bad:
        raise ValueError(f"{mech.name}: unknown variable(s) {', '.join(sorted(bad))}; the "
                         "full coordinates are " + ", ".join(mech.coordinates + mech.rates)
                         + " and the parameters " + ", ".join(mech.parameters)
                         + ("; a motion's start time is t0=" if "t" in bad else ""))
    vals = {**mech.defaults, **(known or {}), **values}
    for k, x in vals.items():
        vals[k] = _args.finite(k, x, mech.name)
    return (np.array([vals[c] for c in mech.coordinates]),
            np.array([vals[r] for r in mech.rates]),
            np.array([vals[p] for p in mech.parameters]))


def run_full(mech, p, q, u, *, t_end, rtol, atol, max_step, max_steps, max_events, t0=0.0,
             t_eval=None, first=ev.START, **contact) -> Record:
    """The motion from the full state ``(q, u)`` at ``t0`` (see the module docstring)."""
    opts = Options(t_end, rtol, atol, max_step, max_steps, max_events, **contact)
    return Motion(mech, p, opts).run(q, u, t0=t0, t_eval=t_eval, first=first)


def _geometry(mech, p, ys, modes, ts) -> dict:
    """Where the bodies and contacts are, and the contact reactions, at each saved state:
    what a figure of the motion draws (``phasemap.plot``'s outline strip)."""
    n, k = mech.n, len(mech.contacts)
    cen, pts = mech.points_along(ys[:, :n], p)
    N = np.full((len(ys), k), np.nan)
    F = np.full((len(ys), k), np.nan)
    at = np.flatnonzero(modes.min(axis=1, initial=0) >= 0) if all(
        c.one_sided for c in mech.contacts) else np.empty(0, dtype=int)
    if at.size:
        motion = Motion(mech, p, Options(1.0))
        Ns, Fs, status = motion.flow.reactions(ts[at], ys[at], modes[at])
        for j, i in enumerate(at):
            if status[j] == flow.OK:
                N[i], F[i] = Ns[j], Fs[j]
            elif status[j] == flow.REDUNDANT:   # (the engine picks an admissible member)
                sol = motion.solve(ys[i, :n], ys[i, n:], tuple(int(m) for m in modes[i]),
                                   None, ts[i])
                if sol is not None:
                    N[i], F[i] = sol[1], sol[2]
    data = {}
    for b in range(mech.n_bodies):
        tail = "" if mech.n_bodies == 1 else f"_{b + 1}"
        for j, axis in enumerate("xy"):
            data[f"centre_{axis}{tail}"] = ("t", cen[:, b, j], {
                "long_name": f"{axis} of the centre of mass of body {b + 1}", "units": "m"})
    for c in mech.contacts:
        for j, axis in enumerate("xy"):
            data[f"point_{axis}_{c.name}"] = ("t", pts[:, c.index, j], {
                "long_name": f"{axis} of the body point of contact {c.name}", "units": "m"})
        data[f"N_{c.name}"] = ("t", N[:, c.index], {
            "long_name": f"normal reaction at contact {c.name} (NaN: not computed, where "
                         "the reduced model ran or a contact is two-sided)", "units": "N"})
        data[f"F_{c.name}"] = ("t", F[:, c.index], {
            "long_name": f"rolling-friction moment at contact {c.name}", "units": "N m"}
            if c.rolls else {
            "long_name": f"tangential (friction) reaction at contact {c.name}", "units": "N"})
    return data


def dataset(mech, rec: Record, attrs: dict, prefix=None, p=None, extra=None):
    """The Dataset of a motion in full coordinates (``prefix``: the reduced motion before
    it, as ``(ts, ys, branch, ev_t, ev_kind, ev_y[, impulses, contacts])`` with ``ys`` in
    full coordinates, and its events' impulses ``(P_n, P_t, dKE)`` and contacts where
    they had any); ``extra``: more variables, ``(dims, values, attrs)`` by name, after
    the motion's."""
    import xarray as xr

    n, k = mech.n, len(mech.contacts)
    ts = np.array(rec.t, dtype=float)
    ys = np.array(rec.y, dtype=float).reshape(-1, 2 * n)
    modes = np.array(rec.modes, dtype=np.int8).reshape(-1, k)
    branch = np.full(ts.size, -1, dtype=np.int8)
    ev_t = np.array(rec.ev_t, dtype=float)
    ev_kind = np.array(rec.ev_kind, dtype=np.int8)
    ev_y = np.array(rec.ev_y, dtype=float).reshape(-1, 2 * n)
    ev_modes = np.array(rec.ev_modes, dtype=np.int8).reshape(-1, k)
    ev_c = np.array(rec.ev_contact, dtype=np.int8)
    imp = np.array(rec.ev_impulse, dtype=float).reshape(-1, 3)
    if prefix is not None:
        pt, py, pb, pet, pek, pey = prefix[:6]
        m = pet.size
        pimp, pc = prefix[6:] if len(prefix) > 6 else (np.full((m, 3), np.nan),
                                                         np.full(m, -1))
        ts, ys = np.concatenate([pt, ts]), np.concatenate([py, ys])
        branch = np.concatenate([np.asarray(pb, dtype=np.int8), branch])
        modes = np.concatenate([np.full((pt.size, k), -1, np.int8), modes])
        ev_t, ev_kind = np.concatenate([pet, ev_t]), np.concatenate([pek.astype(np.int8),
                                                                      ev_kind])
        ev_y = np.concatenate([pey, ev_y])
        ev_modes = np.concatenate([np.full((m, k), -1, np.int8), ev_modes])
        ev_c = np.concatenate([np.asarray(pc, dtype=np.int8), ev_c])
        imp = np.concatenate([np.asarray(pimp, dtype=float).reshape(m, 3), imp])
    mode_attrs = {"flag_values": np.arange(-1, len(MODE_NAMES), dtype=np.int8),
                  "flag_meanings": "closed_see_branch " + " ".join(MODE_NAMES)}
    kind_attrs = {"long_name": "kind of event",
                  "flag_values": np.array(ev.EVENT_VALUES, dtype=np.int8),
                  "flag_meanings": ev.EVENT_MEANINGS}
    data = {
        "event_t": ("event", ev_t, {"long_name": "time of the event", "units": "s"}),
        "event_kind": ("event", ev_kind, kind_attrs),
        "event_contact": ("event", ev_c, {
            "long_name": "contact of the event",
            "flag_values": np.arange(-1, k, dtype=np.int8),
            "flag_meanings": " ".join(["none", *(c.name for c in mech.contacts)])}),
        "event_impulse_n": ("event", imp[:, 0], {
            "long_name": "normal impulse of the impact on the body", "units": "N s"}),
        "event_impulse_t": ("event", imp[:, 1], {
            "long_name": "tangential impulse of the impact on the body", "units": "N s"}),
        "event_dKE": ("event", imp[:, 2], {
            "long_name": "change of kinetic energy in the impact", "units": "J"}),
    }
    if prefix is not None:
        data["branch"] = ("t", branch, {"long_name": "active branch of the reduced model "
                                        "(-1: off its contact manifold, see mode_<contact>)"})
    for c in mech.contacts:
        data[f"mode_{c.name}"] = ("t", modes[:, c.index],
                                  {**mode_attrs, "long_name": f"mode of contact {c.name}"})
        data[f"event_mode_{c.name}"] = ("event", ev_modes[:, c.index], {
            **mode_attrs, "long_name": f"mode of contact {c.name} before the event"})
    for j, (name, units, long_name) in enumerate(
            [(c, u, ln) for c, u, ln in zip(mech.coordinates, mech.units, mech.long_names)]
            + [(r, f"{u} s-1", f"rate of {ln}") for r, u, ln in
               zip(mech.rates, mech.units, mech.long_names)]):
        data[name] = ("t", ys[:, j], {"long_name": long_name, "units": units})
        data[f"event_{name}"] = ("event", ev_y[:, j], {
            "long_name": f"{long_name} at the event (before its impulse, for an impulsive "
                         "event)", "units": units})
    if p is not None:
        data.update(_geometry(mech, p, ys, modes, ts))
        surf = mech.surfaces(p)
        for c in mech.contacts:
            if np.all(np.isfinite(surf[c.index, :3])):
                attrs = {**attrs, f"phasemap_surface_{c.name}": surf[c.index, :3]}
            if np.isfinite(surf[c.index, 3]):       # a rolling disc's radius
                attrs = {**attrs, f"phasemap_radius_{c.name}": surf[c.index, 3]}
    fate = ev.Event(rec.fate)
    attrs = {**attrs, "end_reason": fate.name.lower(), "end_message": _end_message(
                 mech, fate, ev_y[-1] if len(ev_y) else None, p),
             "n_steps": np.int64(rec.n_steps), "phasemap_coordinates": "full",
             "phasemap_integrator_full": "DOP853 (scipy), events rooted on its dense output"}
    data.update(extra or {})
    # fastpath: every value is a NumPy array or number made here, which xarray takes as it
    # is (without, it asks each whether it is a pandas, dask or masked array)
    return xr.Dataset({k: xr.Variable(v[0], np.asarray(v[1]), v[2], fastpath=True)
                       for k, v in data.items()},
                      coords={"t": xr.Variable("t", ts, {"long_name": "time", "units": "s"},
                                               fastpath=True)}, attrs=attrs)


def _end_message(mech, fate, y, p) -> str:
    """The fate's message; at a coordinate's bound, which bound (the reduced model's
    :func:`phasemap.core.events.end_message` names its edge alike)."""
    if fate != ev.LEFT_DOMAIN or y is None or p is None:
        return fate.message
    bounds = mech.bounds(p)
    for j, (name, units) in enumerate(zip(mech.coordinates, mech.units)):
        for side in (0, 1):
            if np.isfinite(bounds[j, side]) and y[j] == bounds[j, side]:
                return f"{fate.message}: {name} reached {bounds[j, side]:.6g} {units}"
    return fate.message
