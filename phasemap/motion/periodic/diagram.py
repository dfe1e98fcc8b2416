"""The brute-force orbit diagram of a friction oscillator: the settled motion's
stroboscopic points (one per forcing period; of an autonomous oscillator, its state at
each maximum of a coordinate) over a parameter axis, what a sweep by simulation shows
next to the branches :func:`phasemap.continue_orbit` follows.

Each parameter value's motion (:func:`phasemap.simulate`'s, in full coordinates, through
every stick-slip transition) runs ``settle`` forcing periods, which are discarded, then
``periods`` more, whose states at the forcing phase ``phase`` are kept: a period-one orbit
gives one point per value, a period-two orbit two, a chaotic motion a cloud.  The values
are independent, so a diagram is chunked with dask over its parameter axis like an atlas.

>>> import numpy as np, phasemap
>>> d = phasemap.orbit_diagram("den_hartog", "f", [0.3, 0.5], periods=3, settle=100)
>>> d.x.dims, d.sizes["cycle"], [int(m) for m in d.multiple]   # period-one orbits
(('f', 'cycle'), 3, [1, 1])
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping

import numpy as np

from phasemap.core import args as _args
from phasemap.core import events as ev
# MAX_MULTIPLE: the longest period ``multiple`` looks for, the one periodic_orbit's
# settling looks for
from phasemap.motion.periodic.orbit import MAX_MULTIPLE, state_variables

#: Default forcing periods run and discarded before the points are kept ...
SETTLE = 100
#: ... and the periods whose stroboscopic points are kept.
PERIODS = 200
#: How near (relative to the points' scale) two kept points must be to count as one.
SAME = 1e-6
#: What a value's motion keeps in memory per forcing period while it runs: its events
#: (two or three a period in a stick-slip orbit, each a few arrays in a Python list) and
#: its kept point (phasemap.motion.hybrid.start.FULL_POINT_BYTES).
PERIOD_BYTES = 2000


def orbit_diagram(model, param: str, values, *, start=None, periods: int = PERIODS,
                  settle: int = SETTLE, phase: float = 0.0, rtol: float = 1e-8,
                  follow: bool = False, section: str | None = None,
                  chunks: int | None = None, progress: bool | None = None):
    """The stroboscopic points of the settled motion of a forced oscillator over the
    values of one parameter: the classical orbit diagram (of an autonomous one, the
    maxima of a coordinate: the points where its rate turns from positive to negative).

    Parameters
    ----------
    model : str or System
        a friction oscillator (``"den_hartog"``, ``"duffing"``, forced; ``"belt"``,
        ``"stribeck_belt"``, autonomous) or a declared system.
    param : str
        the parameter on the diagram's axis.
    values : sequence of float
        its values, a non-empty 1-D sequence of finite values, strictly increasing or
        strictly decreasing, inside the parameter's domain.
    start : dict, optional
        the start of every value's motion at t = 0 (coordinates, rates and the other
        parameters by name; their defaults elsewhere).
    periods : int
        forcing periods whose points are kept (default 200); of an autonomous system,
        maxima kept.
    settle : int
        forcing periods run first and discarded (default 100; 0 keeps the transient);
        of an autonomous system, maxima discarded.
    phase : float
        where in the forcing period the points are taken, as a fraction in [0, 1).
    section : str, optional
        an autonomous system's coordinate whose maxima are kept (default its first),
        each on the cubic through the four saved steps around it (about 1e-7 of the
        coordinate's scale at rtol 1e-8; the time where the rate vanishes is
        less exact, but the maximum is flat there).
    rtol : float
        the integration's tolerance (1e-12 to 1e-4; default 1e-8).
    follow : bool
        each value's motion starts where the previous value's ended (a sweep that stays
        on an attractor as far as it exists, so that a sweep up and one down show a
        hysteresis); the default starts every value at ``start``.  Runs in one process:
        not with ``chunks``.
    chunks : int, optional
        parameter values per dask block: the Dataset is then dask-backed and each block
        runs when computed (locally or on a ``dask.distributed`` cluster).
    progress : bool, optional
        a progress bar over the values (default: in an interactive session).

    Returns
    -------
    xarray.Dataset
        on the dimensions ``(param, cycle)``: each coordinate and rate of the full
        state at ``t = (settle + cycle - 1 + phase) T`` (T the forcing period), or at
        the ``settle + cycle``-th maximum of ``section`` (NaN after a motion that ended
        early or stopped having maxima); on ``param``: ``fate`` (how the motion ended,
        ``horizon`` where it ran through, as :class:`phasemap.Event`) and ``multiple``
        (the settled motion's period in forcing periods, the least m <= 16 with the last
        points m periods apart the same to 1e-6 of their scale; 0 for none: a
        quasi-periodic or chaotic motion, or one still settling).  ``ds.phasemap.plot()``
        draws the diagram (:func:`phasemap.plot.orbits.diagram_figure`, branches of
        :func:`phasemap.continue_orbit` overlaid with ``branches=``).

    Raises
    ------
    ValueError
        one line: an unknown model, parameter or section, bad values, counts or
        tolerance, a value outside the parameter's domain, ``follow`` with ``chunks``,
        ``phase`` of an autonomous system or ``section`` of a forced one.

    Examples
    --------
    Den Hartog's oscillator (Omega = 0.8) as its friction grows: one point per value
    while the orbit is stable, moving with f, and every motion ran through:

    >>> import numpy as np, phasemap
    >>> d = phasemap.orbit_diagram("den_hartog", "f", np.linspace(0.3, 0.6, 3),
    ...                            periods=2, settle=100)
    >>> [int(m) for m in d.multiple], [phasemap.Event(int(f)).name for f in d.fate.values]
    ([1, 1, 1], ['HORIZON', 'HORIZON', 'HORIZON'])
    >>> d.x.values[:, -1].round(4).tolist()        # x at the forcing's phase 0
    [2.4603, 2.0416, 1.4333]
    """
    from phasemap.core.progress import human_bytes
    from phasemap.core.resources import MEMORY_SHARE, available_memory
    from phasemap.declare.full import mechanics
    from phasemap.motion.hybrid.results import start_values
    from phasemap.motion.periodic.orbit import system_of

    S = system_of(model)
    mech = mechanics(S)
    name = mech.name
    if not isinstance(param, str) or param not in mech.parameters:
        raise ValueError(f"{name}: unknown parameter {param!r}; the parameters are "
                         f"{', '.join(mech.parameters)}")
    values = _values(name, S, param, values)
    if start is not None and not isinstance(start, Mapping):
        raise ValueError(f"{name}: start must be a dict of values by name, got "
                         f"{_args.describe(start)}")
    start = dict(start or {})
    if param in start:
        raise ValueError(f"{name}: {param!r} is on the diagram's axis, so the start cannot "
                         "fix it")
    spec = settings(mech, periods, settle, phase, rtol, section)
    periods = spec["periods"]
    settle = spec["settle"]
    if not isinstance(follow, (bool, np.bool_)):
        raise ValueError(f"{name}: follow must be True or False, got {_args.describe(follow)}")
    if follow and chunks is not None:
        raise ValueError(f"{name}: follow=True runs the values one after another, in one "
                         "process; leave chunks out")
    q, u, p = start_values(mech, start)
    avail = available_memory()
    if avail is not None:
        need = values.size * periods * 2 * mech.n * 8
        if chunks is None and need > MEMORY_SHARE * avail:
            raise ValueError(f"{name}: the diagram's points take {human_bytes(need)}, more "
                             f"than half the memory available ({human_bytes(avail)}); keep "
                             "fewer periods or values, or pass chunks= and write it block "
                             "by block (ds.to_netcdf)")
    spec = {**{k: spec[k] for k in ("periods", "settle", "phase", "rtol")},
            "follow": bool(follow), "section": spec["section"]}
    if chunks is None:
        arrays = _eager(S, mech, p, q, u, param, values, spec, progress)
    else:
        arrays = _lazy(S, mech, p, q, u, param, values, spec, chunks)
    return _dataset(S, mech, p, param, values, arrays, spec, start)


def settings(mech, periods=PERIODS, settle=SETTLE, phase=0.0, rtol=1e-8, section=None) -> dict:
    """The settings of a motion's section points, checked (a one-line ValueError naming
    the setting): ``{"periods", "settle", "phase", "rtol", "section"}``, ``section`` the
    coordinate whose maxima an autonomous system keeps (default its first; None for a
    forced one)."""
    from phasemap.core.progress import human_bytes
    from phasemap.core.resources import MEMORY_SHARE, available_memory
    from phasemap.motion.periodic.orbit import no_rolling

    name = mech.name
    no_rolling(mech)
    if mech.period is None:
        if section is None:
            section = mech.coordinates[0]
        if not isinstance(section, str) or section not in mech.coordinates:
            raise ValueError(f"{name}: section must name a coordinate whose maxima are "
                             f"kept ({', '.join(mech.coordinates)}), got "
                             f"{_args.describe(section)}")
        if phase != 0.0:
            raise ValueError(f"{name} is autonomous: its points are the maxima of "
                             f"{section}, at no phase of a forcing; leave phase out")
    elif section is not None:
        raise ValueError(f"{name} is forced: its points are taken once per forcing "
                         "period (at phase=); section= is for an autonomous system")
    periods = _args.count("periods", periods, name)
    settle = _args.count("settle", settle, name, least=0)
    phase = _args.finite("phase", phase, name)
    if not 0.0 <= phase < 1.0:
        raise ValueError(f"{name}: phase is a fraction of the forcing period in [0, 1), "
                         f"got {phase!r}")
    rtol = _args.finite("rtol", rtol, name)
    if not 1e-12 <= rtol <= 1e-4:
        raise ValueError(f"{name}: rtol must be in [1e-12, 1e-4], got {rtol!r}")
    avail = available_memory()
    work = (settle + periods) * PERIOD_BYTES
    if avail is not None and work > MEMORY_SHARE * avail:
        raise ValueError(f"{name}: one motion over {settle + periods:,} periods keeps "
                         f"about {human_bytes(work)} while it runs (its events and points), "
                         f"more than half the memory available ({human_bytes(avail)}); give "
                         "fewer periods or a shorter settle")
    return {"periods": periods, "settle": settle, "phase": phase, "rtol": rtol,
            "section": section}


def _values(name, S, param, values) -> np.ndarray:
    """The parameter's values checked: 1-D, finite, monotonic, inside its domain."""
    a = _args.reals(f"values of {param}", values, name)
    if a.ndim != 1 or a.size == 0:
        raise ValueError(f"{name}: the values of {param} must be a non-empty 1-D sequence, "
                         f"got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: the values of {param} must be finite, got "
                         f"{float(a[~np.isfinite(a)][0])!r}")
    step = np.diff(a)
    if a.size > 1 and not (np.all(step > 0) or np.all(step < 0)):
        what = "repeat a value" if np.any(step == 0) else "go back and forth"
        raise ValueError(f"{name}: the values of {param} {what}; they must be strictly "
                         "increasing or strictly decreasing")
    par = next(x for x in S.parameters if x.name == param)
    lo, hi = float(par.lower), float(par.upper)
    for x in (a.min(), a.max()):
        if x < lo or x > hi or (x == lo and par.lower_open) or (x == hi and par.upper_open):
            raise ValueError(f"{name}: {param} = {x:g} is outside its domain "
                             f"{'(' if par.lower_open else '['}{lo:g}, {hi:g}"
                             f"{')' if par.upper_open else ']'}")
    return a


def strobe(mech, p, q, u, spec, t0=0.0, contact=None):
    """One value's motion from ``(q, u)`` at the time ``t0``: ``(points, fate, end
    state)``, the points an array of ``(periods, 2 n)`` (NaN after the motion ended).
    A forced system's points are at the forcing phase ``spec["phase"]``, the first
    ``spec["settle"]`` of those at or after ``t0`` discarded.  ``contact``: the contact
    settings (``impact_law``...; default :func:`phasemap.simulate`'s)."""
    from phasemap.motion.hybrid import Motion, Options

    if mech.period is None:
        return peaks(mech, p, q, u, spec, t0, contact)
    T = float(mech.period(*p))
    settle, periods = spec["settle"], spec["periods"]
    first = _first(t0, T, spec["phase"])
    te = T * (np.arange(first + settle, first + settle + periods) + spec["phase"])
    opts = Options(float(te[-1]), rtol=spec["rtol"], max_events=10_000_000,
                   max_steps=10_000_000, **(contact or {}))
    rec = Motion(mech, p, opts).run(q, u, t0=t0, t_eval=te)
    out = np.full((periods, 2 * mech.n), np.nan)
    kept = [i for i, t in enumerate(rec.t) if t >= te[0]]
    if kept:
        ts = np.array([rec.t[i] for i in kept])
        rows = np.searchsorted(te, ts)
        ok = (rows < periods)
        ok[ok] &= te[rows[ok]] == ts[ok]
        out[rows[ok]] = np.array([rec.y[i] for i in kept])[ok]
    end = np.array(rec.y[-1]) if rec.y else np.concatenate([q, u])
    return out, int(rec.fate), end


def _first(t0: float, T: float, phase: float) -> int:
    """The least k with ``T (k + phase) >= t0``, in the floating point the times are
    computed in (a t0 on a phase point keeps it: t0 / T may round above the integer)."""
    if not t0:
        return 0
    k = math.ceil(t0 / T - phase)
    while T * (k - 1 + phase) >= t0:
        k -= 1
    while T * (k + phase) < t0:
        k += 1
    return k


#: An autonomous motion runs in chunks of this many of its time scales ...
CHUNK = 50
#: ... and stops having maxima where a chunk holds none; its steps are at most this many
#: time scales long, so that the cubic through the saved steps holds each maximum to
#: about 1e-7 of the coordinate's scale.
STEP = 0.05


def peaks(mech, p, q, u, spec, t0=0.0, contact=None):
    """An autonomous motion's maxima of the coordinate ``spec["section"]``, as
    :func:`strobe` returns its points: the motion run in chunks of :data:`CHUNK` time
    scales until ``settle + periods`` maxima are found, it ends, or a chunk holds none
    (it has come to rest, or to a steady motion)."""
    from types import SimpleNamespace

    from phasemap.motion.hybrid import Motion, Options
    from phasemap.motion.periodic.section import returns

    n = mech.n
    settle, periods, rtol = spec["settle"], spec["periods"], spec["rtol"]
    normal = np.zeros(2 * n)
    normal[n + mech.coordinates.index(spec["section"])] = -1.0    # the rate turning down
    sc = Motion(mech, p, Options(1.0, rtol=rtol)).scales_at(q, u, 0.0)
    scale_t = math.sqrt(sc[3] / sc[2])
    chunk = CHUNK * scale_t
    out = np.full((periods, 2 * n), np.nan)
    t, z = float(t0), np.concatenate([q, u])
    ts, ys = [], []             # the last saved steps, for a maximum across two chunks
    found, fate = 0, ev.HORIZON
    while found < settle + periods:
        opts = Options(t + chunk, rtol=rtol, max_step=STEP * scale_t, max_events=10_000_000,
                       max_steps=10_000_000, **(contact or {}))
        rec = Motion(mech, p, opts).run(z[:n], z[n:], t0=t)
        if not ts:                        # the first chunk: its start too
            ts, ys = rec.t[:1], rec.y[:1]
        ts, ys = ts[-3:], ys[-3:]
        for tk, yk in zip(rec.t[1:], rec.y[1:]):
            if tk == ts[-1]:              # an event's two states at one time: the after
                ys[-1] = yk
            else:
                ts.append(tk)
                ys.append(yk)
        new = [(tk, yk) for tk, yk in returns(SimpleNamespace(t=ts, y=ys), 0.0 * z, normal)
               if tk > t]
        for _, yk in new:
            if settle <= found < settle + periods:
                out[found - settle] = yk
            found += 1
        if rec.fate != ev.HORIZON or not new:
            fate = rec.fate
            break
        t, z = rec.t[-1], np.array(rec.y[-1])
    return out, int(fate), np.array(rec.y[-1])


def multiple(points) -> int:
    """The least m <= :data:`MAX_MULTIPLE` for which the last points repeat every m
    forcing periods (the last ``min(3 m, periods)`` of them agree, to :data:`SAME` of
    their scale, with the ones m before), else 0."""
    pts = points[~np.isnan(points).any(axis=1)]
    if len(pts) < 2:
        return 0
    scale = max(float(np.max(np.abs(pts))), 1e-300)
    for m in range(1, min(MAX_MULTIPLE, len(pts) - 1) + 1):
        span = min(3 * m, len(pts) - m)
        a, b = pts[len(pts) - span:], pts[len(pts) - span - m:len(pts) - m]
        if np.max(np.abs(a - b)) <= SAME * scale:
            return m
    return 0


def _block(S, p, q, u, i_par, values, spec, tick=None) -> dict:
    """The diagram over ``values``: its arrays by name (``S`` the declaration, which
    pickles, so that a block runs in another process too)."""
    from phasemap.declare.full import mechanics

    mech = mechanics(S)
    n2 = 2 * mech.n
    pts = np.full((len(values), spec["periods"], n2), np.nan)
    fates = np.empty(len(values), dtype=np.int8)
    mult = np.empty(len(values), dtype=np.int8)
    q0, u0 = q, u
    for j, lam in enumerate(values):
        pj = p.copy()
        pj[i_par] = lam
        pts[j], fates[j], end = strobe(mech, pj, q0, u0, spec)
        mult[j] = multiple(pts[j])
        if spec["follow"] and fates[j] == ev.HORIZON:
            q0, u0 = end[:mech.n], end[mech.n:]
        if tick is not None:
            tick()
    out = {nm: pts[:, :, i] for i, (nm, _) in enumerate(state_variables(mech))}
    out.update({"fate": fates, "multiple": mult})
    return out


def _eager(S, mech, p, q, u, param, values, spec, show):
    from phasemap.core import progress

    i_par = mech.parameters.index(param)
    with progress.enable(force=progress.wanted(show)):
        bar = progress.bar(len(values), f"{mech.name} orbit diagram", unit="value")
        with bar:
            return _block(S, p, q, u, i_par, values, spec, tick=lambda: bar.update(1))


def _lazy(S, mech, p, q, u, param, values, spec, chunks):
    """Dask-backed arrays: one task per block of values computes every variable once."""
    import dask
    import dask.array as da

    name = mech.name
    if isinstance(chunks, (bool, np.bool_)) or not isinstance(chunks, (int, np.integer)) \
            or chunks < 1:
        raise ValueError(f"{name}: chunks must be a positive whole number of parameter "
                         f"values per block, got {_args.describe(chunks)}")
    i_par = mech.parameters.index(param)
    periods = spec["periods"]
    parts = {nm: [] for nm in [*(nm for nm, _ in state_variables(mech)), "fate", "multiple"]}
    for lo in range(0, len(values), int(chunks)):
        vals = values[lo:lo + int(chunks)]
        block = dask.delayed(_block, pure=True)(S, p, q, u, i_par, vals, spec)
        for nm in parts:
            scalar = nm in ("fate", "multiple")
            shape = (len(vals),) if scalar else (len(vals), periods)
            parts[nm].append(da.from_delayed(block[nm], shape,
                                             dtype=np.int8 if scalar else np.float64))
    return {nm: da.concatenate(a, axis=0) for nm, a in parts.items()}


def _dataset(S, mech, p, param, values, arrays, spec, start):
    import xarray as xr

    from phasemap._version import __version__
    from phasemap.atlas.dataset import CONVENTIONS, created

    par = next(x for x in S.parameters if x.name == param)
    data = {}
    where = ("at the forcing phase, once per forcing period" if spec["section"] is None
             else f"at each maximum of {spec['section']}")
    for nm, un in state_variables(mech):
        data[nm] = ((param, "cycle"), arrays[nm], {"long_name": f"{nm} {where}",
                                                   "units": un})
    data["fate"] = (param, arrays["fate"], {
        "long_name": "how the motion ended (horizon: it ran through)",
        "flag_values": np.array(ev.EVENT_VALUES, dtype=np.int8),
        "flag_meanings": ev.EVENT_MEANINGS})
    data["multiple"] = (param, arrays["multiple"], {
        "long_name": "period of the settled motion in forcing periods (0: none up to "
                     f"{MAX_MULTIPLE})", "units": "1"})
    coords = {
        param: (param, values, {"long_name": par.long_name, "units": par.units}),
        "cycle": ("cycle", np.arange(1, spec["periods"] + 1, dtype=np.int32), {
            "long_name": "forcing periods after the settling time" if spec["section"] is None
                         else f"maxima of {spec['section']} after the settling ones",
            "units": "1"}),
    }
    attrs = {"Conventions": CONVENTIONS, "title": f"phasemap orbit diagram: {S.title}",
             "source": f"phasemap {__version__}", "references": S.citation,
             "phasemap_version": __version__, "date_created": created(),
             "phasemap_kind": "orbit_diagram", "phasemap_model": S.name,
             "phasemap_parameter": param, "phasemap_diagram": json.dumps(spec),
             "phasemap_start": json.dumps({k: float(v) for k, v in start.items()})}
    attrs.update({f"phasemap_parameter_{nm}": float(v)
                  for nm, v in zip(mech.parameters, p) if nm != param})
    return xr.Dataset(data, coords, attrs)

