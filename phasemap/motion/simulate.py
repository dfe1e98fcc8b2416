"""Trajectories in time: :func:`simulate`.

A thin Python wrapper over the model's jitted integrator
(:mod:`phasemap.motion.integrate`): it validates the input, runs the integrator and
returns a self-describing :class:`xarray.Dataset`.
"""

from __future__ import annotations

import inspect
import math
import threading
import warnings
from dataclasses import dataclass
from typing import Mapping, NamedTuple, Sequence

import numpy as np
from phasemap.core.lazy import xarray as xr

from phasemap.core import progress
from phasemap.core.progress import human_bytes
from phasemap.core.resources import MEMORY_COPIES, MEMORY_SHARE, available_memory
from phasemap.core.memo import Memo
from phasemap.core import args as _args
from phasemap.core import events as ev
from phasemap.core import tiers
from phasemap.core.compile import remember
from phasemap.atlas.dataset import assemble, cf_header, variable_attrs
from phasemap.motion import hybrid
from phasemap.motion.hybrid.start import (full_attrs, mechanics_of, run_settings,
                                          say_full_memory, simulate_full)
from phasemap.motion.integrate import (DEFAULT_METHOD, METHODS, NO_STOP, check_method,
                                       compile_integrator, integrator, run_batch, unpack)
from phasemap.core.model import Model, Variable
from phasemap.motion.without_collision import impact_variables, through_impacts
from phasemap.systems import OSCILLATORS, get_model, reference

#: Tolerances tighter than this cannot be met in double precision.
RTOL_MIN = 1e-14


#: Validated :class:`Options` by ``(model, settings, their types)`` (see :meth:`Options.checked`).
_CHECKED = Memo("simulate.checked", maxsize=256)


@dataclass(frozen=True)
class Options:
    """Integrator settings shared by :func:`simulate` and the fate maps."""

    t_end: float = 10.0
    rtol: float = 1e-8
    atol: float | None = None
    max_step: float = math.inf
    max_steps: int = 1_000_000
    max_events: int = 10_000
    method: str = DEFAULT_METHOD

    def checked(self, model: str) -> "Options":
        """Validated copy (``atol`` defaults to ``rtol``); ValueError (or
        :class:`phasemap.core.args.WrongType`) naming the setting on bad values.
        Python and NumPy numbers alike; counts may be whole floats (``1e6``).

        The settings of a call are often those of the last (a sweep): a validated
        copy is remembered under the settings and their types (``1`` is not ``True``)."""
        fields = (self.t_end, self.rtol, self.atol, self.max_step, self.max_steps,
                  self.max_events, self.method)
        key = (model, fields, tuple(map(type, fields)))
        try:
            hash(key)
        except TypeError:  # an unhashable setting: validation says what is wrong with it
            return self._checked(model)
        return _CHECKED.get((), key, lambda: self._checked(model))

    def _checked(self, model: str) -> "Options":
        t_end = _args.finite("t_end", self.t_end, model, lower=0.0, lower_open=True)
        rtol = _args.real("rtol", self.rtol, model)
        if not RTOL_MIN <= rtol <= 0.1:
            raise ValueError(f"{model}: rtol must be in [{RTOL_MIN:g}, 0.1] (tighter is below "
                             f"double-precision resolution), got {self.rtol!r}")
        atol = rtol if self.atol is None else _args.finite("atol", self.atol, model, lower=0.0,
                                                           lower_open=True)
        max_step = _args.finite("max_step", self.max_step, model, lower=0.0, lower_open=True,
                                allow_inf=True)
        counts = [_args.count(name, getattr(self, name), model)
                  for name in ("max_steps", "max_events")]
        if not isinstance(self.method, str):
            raise _args.WrongType(f"{model}: method must be a string, one of "
                                          f"{', '.join(METHODS)}, got {type(self.method).__name__}")
        check_method(self.method, model)
        return Options(t_end, rtol, atol, max_step, *counts, self.method)

    def as_dict(self) -> dict:
        return {"t_end": self.t_end, "rtol": self.rtol, "atol": self.atol,
                "max_step": self.max_step, "max_steps": self.max_steps,
                "max_events": self.max_events, "method": self.method}


def integrated_variables(model: Model) -> list[Variable]:
    """The integrated state: positions, then velocities (with their descriptions)."""
    return list(_layout(model).integrated)


class _Layout(NamedTuple):
    """What a call of :func:`simulate` reads from its model, derived once per model (a
    call re-deriving it from the model's properties cost tens of microseconds)."""

    integrated: tuple  # the integrated Variables: positions, then velocities
    names: tuple  # ... and their names
    known: dict  # every name a call may set: the model's variables and extra positions
    state: frozenset  # the names of initial values (the batch form sweeps these)
    extra: dict  # positions the model integrates but does not take as inputs
    settable: tuple  # model.names, then the extra positions


def _layout(model: Model) -> _Layout:
    dyn = _dynamics(model)
    return remember(("simulate", model.name), model, lambda: _make_layout(model, dyn))


def _make_layout(model: Model, dyn) -> _Layout:
    extra = {p.name: p for p in dyn.positions}
    known = {**model.variables, **extra}
    integrated = tuple([known[c[0]] for c in dyn.coordinates]
                       + [known[c[1]] for c in dyn.coordinates])
    return _Layout(integrated, tuple(v.name for v in integrated), known,
                   frozenset({v.name for v in model.state} | set(extra)), extra,
                   (*model.names, *extra))


def _dynamics(model: Model):
    if model.dynamics is None:
        raise ValueError(f"{model.name}: this model has no dynamics; it can be classified and "
                         "mapped but not integrated in time")
    return model.dynamics


def split_values(model: Model, values: Mapping[str, float]):
    """Validate ``values``: model variables (complete) and extra positions (default 0)."""
    lay = _layout(model)
    extra = lay.extra
    values = _args.scalars(values, lay.settable, model.name,
                           " for simulate(); for grids of initial conditions use a Scene "
                           "with fate layers")
    positions = {}
    for name, var in extra.items():
        positions[name] = float(values.pop(name, var.default))
        var.check(model.name, positions[name])
    return model.complete(values), positions


def simulate(model: str | Model, t_end: float = 10.0, *, rtol: float = 1e-8,
             atol: float | None = None, max_step: float = math.inf,
             t_eval: Sequence[float] | None = None, max_steps: int = 1_000_000,
             max_events: int = 10_000, method: str = DEFAULT_METHOD,
             impact_law: str = "stronge", restitution: float = 0.0,
             painleve: str = "liftoff", zeno_speed: float = hybrid.ZENO_SPEED,
             through_contacts: bool = True, t0: float = 0.0, **values: float) -> xr.Dataset:
    """Integrate the motion from an initial state, with exact stick and slip.

    Parameters
    ----------
    model:
        a model name or :class:`phasemap.Model` with dynamics (all four
        built-in models).
    t_end:
        the time horizon (s): the motion runs from ``t0`` to ``t_end``.
    rtol, atol:
        relative and absolute tolerances of the steps (``atol`` defaults to
        ``rtol``); ``rtol`` in [1e-14, 0.1].
    max_step:
        largest step (s); lower it to resolve short excursions between steps.
    t_eval:
        sorted times in [t0, t_end] at which to report the state (from the
        dense output).  Default: every accepted step and every event.
    max_steps, max_events:
        limits after which the motion ends with ``max_steps`` or ``max_events``.
        Where the points and events they allow to be saved would not fit in the
        memory available (``RLIMIT_AS`` and cgroup limits included), they are lowered
        to what fits: such a motion ends early with ``end_message`` (and a warning)
        saying so and naming ``t_eval``, and keeps every point it computed.
    method:
        ``"DOPRI5"`` (Dormand-Prince 5(4), the default) or ``"DOP853"``
        (Dormand-Prince 8(5,3) with a dense output of order 7: fewer steps at
        tight tolerances, below about 1e-8).
    impact_law, restitution, painleve, zeno_speed:
        how a declared system's motion goes on through contact changes
        (:mod:`phasemap.motion.hybrid`): the impact law (``"stronge"``, the default,
        ``"poisson"`` or ``"newton"``, which can gain energy where a slip reverses, for
        a contact that lands alone; where others are closed, Moreau's generalised Newton
        law), its coefficient of restitution (default 0: plastic), what follows where the
        accelerations have two solutions (``"liftoff"``, the default, ``"iwc"`` or
        ``"stop"``), and the rebound speed below which the impacts of one contact are
        taken to accumulate (Zeno, default 1e-6).
    through_contacts:
        go on through contact changes (the default), or end where the reduced model
        (every contact closed) ends, with ``contact_lost``, ``no_solution`` or
        ``indeterminate``: the fate :func:`phasemap.phase_curve` and the fate maps give
        (``False`` is recorded, ``phasemap_through_contacts = "false"``, for a re-run).
    t0:
        the start time (s, default 0): where the forcing of a system forced in time is
        at the start (Den Hartog's block started at ``t0`` feels F0 cos(Omega t0)).  A
        motion in full coordinates takes it (a friction oscillator, a start in full
        coordinates); a reduced model's motion does not depend on the time, so it
        starts at 0.  Recorded as ``attrs["phasemap_t0"]`` where not 0.
    **values:
        initial state and parameters by name (``phasemap models`` lists them);
        missing names take the model's defaults.  The elliptic pendulum also
        takes the slider position ``x`` (default 0).  **Batch form:** initial
        values given as 1-D arrays of one length (parameters stay scalars)
        integrate every start in one compiled call, each exactly as a call of
        its own would.

    Returns
    -------
    xarray.Dataset
        coordinate ``t``; the state variables by name (positions, then
        velocities); ``branch``, the active branch; and an events table on
        dimension ``event``: ``event_t``, ``event_kind`` (see
        :class:`phasemap.Event`), ``event_branch`` (the branch after the
        event) and the state at each event (for an impulsive event, ``iwc``,
        ``impact`` or ``jam``, the state before its impulse: the state after it is the
        next saved point, at the same time).  The first event is ``start`` (or
        the fate, when the motion cannot start); the last is the fate.
        ``attrs["end_reason"]`` names the fate, ``attrs["end_message"]``
        explains it.

        **Through contact changes.**  For a declared system (its contacts point or
        edge contacts) the motion does not end where a contact opens: from there it
        goes on in the full coordinates (every coordinate and its rate, the fixed ones
        named ``<name>_dot``), through lift-off, flight, impacts, impacts without
        collision and Zeno, and the Dataset holds the full coordinates throughout
        (``attrs["phasemap_coordinates"] = "full"``), each contact's mode
        (``mode_<contact>``), and per event its contact and impulses
        (``event_contact``, ``event_impulse_n``, ``event_impulse_t``, ``event_dKE``).
        A start given in full coordinates (a value for a coordinate the contacts fix,
        or its rate), or a declaration (:class:`phasemap.declare.System`) whose contacts
        cannot all be closed at once, starts there.

        In the batch form, one Dataset with a ``start`` dimension: the
        variables above on (``start``, ``t``) with ``t_eval`` (NaN past a
        motion's end), else on (``start``, ``point``) with ``t`` a variable
        beside them; the events on (``start``, ``event``); ``n_points`` and
        ``n_events`` count each start's rows (the rest is padding: NaN, and -1
        for branches and kinds); ``end_reason`` (a fate code, see
        :class:`phasemap.Event`), ``n_reversals``, ``n_steps`` and
        ``initial_<name>`` are variables on ``start``.

    Raises
    ------
    ValueError
        for an unknown model or variable, a value outside its domain, or bad
        integrator settings.

    Examples
    --------
    >>> import phasemap
    >>> ds = phasemap.simulate("hinge_pendulum", t_end=10.0, phi=1.0, omega=0.0, delta=0.1)
    >>> ds.attrs["end_reason"], int(ds.attrs["n_reversals"])
    ('rest', 3)
    >>> abs(float(ds.phi[-1])) <= 0.1                  # rest needs l |sin phi| <= delta
    True
    >>> sweep = phasemap.simulate("hinge_pendulum", t_end=10.0, phi=[0.5, 1.0, 2.5],
    ...                           omega=0.0, delta=0.1)
    >>> sweep.n_reversals.values.tolist()
    [1, 3, 5]
    """
    return _run(model, t_end, rtol, atol, max_step, t_eval, max_steps, max_events, method,
                impact_law, restitution, painleve, zeno_speed, through_contacts, t0, values)


class MotionEnd(NamedTuple):
    """Where a motion ends, as a fate map's layers read it (:func:`motion_end`)."""

    fate: int             #: its fate (:class:`phasemap.Event`)
    n_reversals: int      #: its events of kind ``reversal``
    t: float              #: the time of its last event
    #: each state variable at its last event, by name: the reduced model's, or the full
    #: coordinates and their rates where the motion went on in them
    state: dict


def motion_end(model, t_end: float, **kwargs) -> MotionEnd:
    """The end of the motion ``simulate(model, t_end, **kwargs)`` gives (one start), read
    from the integrator's and the motion's own records, without building its Dataset:
    what a fate map's cell followed through its contact changes keeps
    (:mod:`phasemap.maps.through`).  The same numbers as :func:`end_of` of that Dataset
    wherever ``simulate`` answers (tests/test_fate_through.py); the Dataset's own columns
    (the outlines, the saved states in full coordinates) and its memory warnings are not
    made."""
    settings = {**_SIMULATE_DEFAULTS, **{k: kwargs.pop(k) for k in list(kwargs)
                                         if k in _SIMULATE_DEFAULTS}}
    return _run(model, t_end, **settings, values=kwargs, summary=True)


def end_of(ds, names) -> MotionEnd:
    """:class:`MotionEnd` of a motion's Dataset (``names``: the state variables)."""
    return _ended(int(ev.Event[ds.attrs["end_reason"].upper()]), ds.event_kind.values,
                  ds.event_t.values, [ds[f"event_{n}"].values[-1] for n in names], names)


def _ended(fate, kinds, times, last, names) -> MotionEnd:
    """:class:`MotionEnd` of a motion's events table (their kinds and times) and the state
    ``last`` at its last event (the values of ``names``)."""
    return MotionEnd(int(fate), int(np.count_nonzero(np.asarray(kinds) == ev.REVERSAL)),
                     float(times[-1]), dict(zip(names, (float(x) for x in last))))


#: :func:`simulate`'s settings and their defaults (what :func:`motion_end` takes by name)
_SIMULATE_DEFAULTS = {k: prm.default for k, prm in
                      inspect.signature(simulate).parameters.items()
                      if prm.kind is prm.KEYWORD_ONLY}


def _run(model, t_end, rtol, atol, max_step, t_eval, max_steps, max_events, method,
         impact_law, restitution, painleve, zeno_speed, through_contacts, t0, values,
         summary=False):
    """:func:`simulate`; with ``summary``, its :class:`MotionEnd` (one start)."""
    S, m = _model_of(model, values)
    name = m.name if m is not None else S.name
    opts = Options(t_end, rtol, atol, max_step, max_steps, max_events, method).checked(name)
    contact = hybrid.check_contact_options(name, impact_law, restitution, painleve,
                                           zeno_speed)
    if not isinstance(through_contacts, bool):
        raise _args.WrongType(f"{name}: through_contacts must be True or False, got "
                              f"{through_contacts!r}")
    if not through_contacts:
        if m is None:
            raise ValueError(f"{name}: its contacts cannot all be closed at once, so it has "
                             "no reduced model: through_contacts=False has nothing to run")
        S = None
    t0 = _args.finite("t0", t0, name)
    if S is not None and (m is None or _full_start(m, S, values)):
        if not opts.t_end > t0:
            raise ValueError(f"{name}: the motion runs from t0 = {t0:g} to t_end = "
                             f"{opts.t_end:g}: t_end must come after t0")
        ds = simulate_full(S, m, opts, contact, _times(name, t_eval, opts, t0), values, t0)
        if summary:
            mech = mechanics_of(S)
            return end_of(ds, [*mech.coordinates, *mech.rates])
        return ds
    if t0 != 0.0:
        raise ValueError(f"{name}: t0 = {t0:g} is the start time of a motion in full "
                         "coordinates (a system forced in time); this one runs on its "
                         "reduced model, which does not depend on the time: leave t0 out")
    starts = _starts(m, values)
    full, positions = split_values(m, {k: (val[0] if k in starts else val)
                                       for k, val in values.items()})
    te = np.empty(0) if t_eval is None else _times(m.name, t_eval, opts)
    names = list(_layout(m).names)
    y0 = np.array([positions[n] if n in positions else float(full[n]) for n in names])
    v = m.input_vector(full)
    n_starts = len(next(iter(starts.values()))) if starts else 1
    capped = _memory_cap(m, opts, len(names), t_eval is None, te.size, n_starts)
    run = (opts.t_end, opts.rtol, opts.atol, opts.max_step,
           *((opts.max_steps, opts.max_events) if capped is None else capped), t_eval is None, te)
    if starts and summary:
        raise ValueError(f"{m.name}: motion_end takes one start, not arrays of them")
    if starts:
        y0s = np.repeat(y0[None, :], n_starts, axis=0)
        for j, n in enumerate(names):
            if n in starts:
                y0s[:, j] = starts[n]
        ds = _batch(m, full, positions, opts, names, y0s, te if t_eval is not None else None,
                    run_batch(m, opts.method, v.copy(), y0s, *run))
        ds.attrs.update({} if through_contacts else {"phasemap_through_contacts": "false"})
        if capped is not None and np.isin(ds.end_reason.values,
                                          [ev.MAX_STEPS, ev.MAX_EVENTS]).any():
            warnings.warn(f"{m.name}: some motions stopped at max_steps or max_events lowered "
                          f"to {capped[0]:,} and {capped[1]:,}, what their saved points can "
                          "hold in memory; pass t_eval= to save the state at chosen times "
                          "only", RuntimeWarning, stacklevel=2)
        return ds
    # machine code where it is compiled; else, at once, its interpreted twin while a
    # background process compiles it (phasemap.core.tiers; $PHASEMAP_JIT)
    machine = integrator(m, opts.method)
    integrate = tiers.runner(machine, (v, y0, *run, NO_STOP),
                             (compile_integrator, (reference(m), opts.method), {}))
    if tiers.is_twin(integrate) and tiers.mode() != "off":
        integrate = _budgeted(integrate, machine, m.name)
    fate, t, y, n_rev, n_steps, points, events, y_eval, impacts = through_impacts(
        m, integrate, v, y0, run, names, full)
    if S is not None and int(fate) in GOES_ON and float(t) < opts.t_end:
        ds = _continued(S, m, opts, contact, names, full, positions, points, events,
                        y_eval, te if t_eval is not None else None, float(t), y,
                        int(n_steps), impacts, summary)
        if ds is not None:
            return ds
    if summary:
        ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode = _columns(points, events, y_eval, None)
        return _ended(fate, ev_kind, ev_t, ev_y[-1], names)
    ds = _dataset(m, full, positions, opts, names, int(fate), int(n_rev), int(n_steps),
                  *_columns(points, events, y_eval, te if t_eval is not None else None))
    if impacts:
        impact_variables(ds, impacts)
    ds.attrs.update({} if through_contacts else {"phasemap_through_contacts": "false"})
    if capped is not None and int(fate) in (ev.MAX_STEPS, ev.MAX_EVENTS):
        _say_memory(m, ds, opts, capped)
    return ds


#: The fates of the reduced integrator from which a declared system's motion goes on in
#: its full coordinates (:mod:`phasemap.motion.hybrid`).
GOES_ON = (ev.CONTACT_LOST, ev.NO_SOLUTION, ev.INDETERMINATE, ev.SINGULAR)


def _model_of(model, values):
    """``(declaration or None, Model or None)`` of what :func:`simulate` was given: a name,
    a Model, or a :class:`phasemap.declare.System` (whose contacts may be too many to
    close at once: then it has no reduced model, and moves in full coordinates only; nor
    is its reduced model built for a start in full coordinates)."""
    from phasemap.declare.system import System

    if isinstance(model, System):
        reduced = {p.name for p in model.parameters} | {
            n for c in model.coordinates if c.rate is not None for n in (c.name, c.rate.name)}
        if set(values) - reduced:
            try:
                if set(values) & hybrid.full_names(mechanics_of(model)) - reduced:
                    return model, None
            except ValueError:
                pass
        try:
            return model, model.model
        except ValueError as err:
            try:
                mechanics_of(model)
            except ValueError:
                raise err from None
            return model, None
    if isinstance(model, str) and model in OSCILLATORS:
        from phasemap.systems import oscillators

        return _model_of(oscillators.OSCILLATORS[model], values)
    m = get_model(model)
    return hybrid.declaration_of(m), m


def _full_start(m: Model, S, values) -> bool:
    """Whether ``values`` name a full-coordinate variable the reduced model does not have
    (a coordinate the contacts fix, or a rate of one)."""
    known = set(_layout(m).known) | set(m.names)
    extra = set(values) - known
    if not extra:
        return False
    try:
        mech = mechanics_of(S)
    except ValueError:
        return False
    return bool(extra & hybrid.full_names(mech))


def _times(name, t_eval, opts: Options, t0: float = 0.0):
    if t_eval is None:
        return None
    te = _args.reals("t_eval", t_eval, name)
    if te.ndim != 1 or not np.all(np.isfinite(te)) or np.any(np.diff(te) < 0) or (
            te.size and (te[0] < t0 or te[-1] > opts.t_end)):
        start = "0" if t0 == 0.0 else f"t0 = {t0:g}"
        raise ValueError(f"{name}: t_eval must be a sorted 1-D sequence of times in "
                         f"[{start}, t_end = {opts.t_end:g}]")
    return te


def _continued(S, m: Model, opts: Options, contact: dict, names, full, positions, points,
               events, y_eval, te, t_stop: float, y_stop, n_steps: int, impacts=(),
               summary=False) -> xr.Dataset | MotionEnd | None:
    """The reduced motion that ended at ``t_stop`` where a contact opens (or the
    accelerations have no or two solutions, or a slip reached its singular point) goes
    on in full coordinates: the Dataset of both, or None where the declaration's contacts
    are not the kind that can open.  ``impacts``: the reduced motion's impacts without
    collision (:func:`phasemap.motion.without_collision.through_impacts`), whose impulses
    its ``iwc`` events keep.  With ``summary``, the :class:`MotionEnd` of that Dataset,
    without making it."""
    from phasemap.declare.full import closure

    try:
        mech = mechanics_of(S)
    except ValueError:
        return None
    close = closure(S)
    ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode = _columns(points, events, y_eval, te)

    def full_of(y):
        vals = {**full, **dict(zip(names, (float(x) for x in y)))}
        q, u = close(vals)
        return np.concatenate([q, u])

    pey = np.array([full_of(y) for y in ev_y[:-1]]).reshape(-1, 2 * mech.n)
    q0, u0 = np.split(full_of(y_stop), 2)
    p = np.array([float(full[k]) for k in mech.parameters])
    rest = None if te is None else te[te > t_stop]
    settings = run_settings(opts, mech.n if rest is None else 0)
    rec = hybrid.run_full(mech, p, q0, u0, t0=t_stop, t_eval=rest, first=-1,
                          **settings, **contact)
    kinds = np.asarray(ev_kind[:-1])
    if summary:     # (the Dataset's events: the reduced motion's but its last, then rec's)
        return _ended(rec.fate, [*kinds, *rec.ev_kind], [*ev_t[:-1], *rec.ev_t],
                      rec.ev_y[-1] if rec.ev_t else pey[-1], [*mech.coordinates, *mech.rates])
    py = np.array([full_of(y) for y in ys]).reshape(-1, 2 * mech.n)
    imp = np.full((kinds.size, 3), np.nan)
    imp[kinds == ev.IWC] = [i[1:] for i in impacts] if len(impacts) else np.empty((0, 3))
    prefix = (np.asarray(ts, float), py, ms, np.asarray(ev_t[:-1], float), kinds, pey,
              imp, np.where(kinds == ev.IWC, 0, -1))   # (one contact: the impacts' own)
    attrs = full_attrs(S, m, opts.as_dict(), contact, {**full, **positions})
    rec.n_steps += n_steps
    ds = hybrid.dataset(mech, rec, attrs, prefix, p=p)
    ds.attrs["phasemap_reduced_end"] = ev.Event(int(events[-1, 1])).name.lower()
    say_full_memory(ds, opts, settings)
    return ds


#: Seconds of a motion the interpreted integrator runs before the machine code takes over
#: (the twin takes about a millisecond a step: a long motion waits for the compiler).
TWIN_BUDGET = 3.0


def _budgeted(twin, machine, name: str):
    """The integrator's twin, stopped after :data:`TWIN_BUDGET` seconds: a motion that
    long runs again, from its start, on the machine code (the background compile's, once
    it has ended, or compiled here), so that a twin never takes longer than compiling."""

    def integrate(*args):
        stop = np.zeros(1, dtype=np.int64)
        timer = threading.Timer(TWIN_BUDGET, stop.__setitem__, (0, 1))
        timer.daemon = True
        timer.start()
        try:
            res = twin(*args[:-1], stop)
        finally:
            timer.cancel()
        if not stop[0] or int(res.fate) != ev.MAX_STEPS:
            return res  # (ended before its budget did)
        with progress.activity(f"{name}: compiling the integrator"):
            tiers.wait_for(machine, tuple(machine.typeof_pyval(a) for a in args))
            return machine(*args)

    return integrate


def _memory_cap(m: Model, opts: Options, ny: int, every_step: bool, n_eval: int,
                starts: int = 1):
    """``(max_steps, max_events)`` lowered so that the saved points and events fit in
    memory, or None when the requested limits fit already.  Every step is saved when
    no ``t_eval`` is given (a row of t, branch and the state), and every event always
    (t, kind, branch and the state); :data:`MEMORY_COPIES` of them may live at once.
    A motion that ends before either limit is what it would be without the cap.  A batch
    of ``starts`` motions holds them all at once."""
    avail = available_memory()
    if avail is None:
        return None
    budget = MEMORY_SHARE * max(avail - 8 * ny * n_eval * MEMORY_COPIES * starts, 0) / (
        MEMORY_COPIES * starts)
    row_point, row_event = 8 * (2 + ny), 8 * (3 + ny)
    steps = opts.max_steps + 2 if every_step else 0
    if steps * row_point + (opts.max_events + 2) * row_event <= budget:
        return None
    events = int(min(opts.max_events, max(budget / 4 // row_event - 2, 16)))
    left = budget - (events + 2) * row_event
    max_steps = int(min(opts.max_steps, max(left // row_point - 2, 16))) if every_step \
        else opts.max_steps
    return max_steps, events


def _say_memory(m: Model, ds: xr.Dataset, opts: Options, capped) -> None:
    """The end of a motion cut by :func:`_memory_cap`: its message says why, and a warning."""
    what = ("steps" if ds.attrs["end_reason"] == "max_steps" else "events")
    asked = opts.max_steps if what == "steps" else opts.max_events
    got = capped[0] if what == "steps" else capped[1]
    message = (f"stopped after {got:,} {what} of the {asked:,} allowed: saving more would "
               f"not fit in the memory available ({human_bytes(available_memory() or 0)}); "
               "pass t_eval= to save the state at chosen times only, or a shorter t_end")
    ds.attrs["end_message"] = message
    warnings.warn(f"{m.name}: {message}", RuntimeWarning, stacklevel=3)


def _columns(points, events, y_eval, te):
    """``(ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode)`` of one motion; at the requested times
    ``te`` (None: at the saved points)."""
    ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode = unpack(points, events)
    if te is not None:
        ts = te[:len(y_eval)]
        ys = y_eval
        # the branch at t: the one after the last event at or before t that
        # started a stage (a terminal event at t_end ends no stage before it)
        started = ev_mode >= 0
        if started.any():
            at = np.searchsorted(ev_t[started], ts, side="right") - 1
            ms = ev_mode[started][np.maximum(at, 0)]
        else:
            ms = np.full(len(ts), -1.0)
    return ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode


def _starts(m: Model, values: Mapping) -> dict[str, np.ndarray]:
    """The initial-state values given as 1-D arrays (the batch form), checked: one
    length for all, every start in the domain, the parameters scalars."""
    plain = _args.PLAIN
    if all(type(val) in plain for val in values.values()):
        return {}  # every value one number: a single motion
    lay = _layout(m)
    known, state = lay.known, lay.state
    starts = {}
    for k, val in values.items():
        if type(val) in _args.PLAIN:
            continue
        try:
            nd = np.ndim(val)
        except (TypeError, ValueError):  # a ragged nesting: [0.1, [0.2]]
            raise ValueError(f"{m.name}: {k} must be a number or a 1-D array of numbers, "
                             f"got {_args.describe(val)}") from None
        if nd == 0:
            continue
        if k not in state or nd != 1 or np.size(val) == 0:
            raise ValueError(f"{m.name}: {k} must be a scalar for simulate()"
                             + (", or a 1-D array of initial values (the batch form)"
                                if k in state else " (it is a parameter)")
                             + "; for grids of initial conditions use a Scene with fate "
                             "layers")
        starts[k] = val
    sizes = {k: np.size(a) for k, a in starts.items()}
    if len(set(sizes.values())) > 1:
        raise ValueError(f"{m.name}: the arrays of initial values must have one length, got "
                         + ", ".join(f"{k}: {n}" for k, n in sizes.items()))
    for k, a in starts.items():
        starts[k] = _args.reals(k, a, m.name)
        known[k].check(m.name, starts[k])
    return starts


def _motion_variables(m: Model, t_dims, event_dims, ys, ms, ev_t, ev_kind, ev_y, ev_mode):
    """The variables of motions: the state and branch on ``t_dims``, the events table on
    ``event_dims`` (the last axis of ``ys`` and ``ev_y`` runs over the integrated state)."""
    branch_attrs = {"long_name": "active branch of the friction law",
                    "flag_values": np.arange(-1, len(m.branches), dtype=np.int8),
                    "flag_meanings": " ".join(["none", *m.branches])}
    kind_attrs = {"long_name": "kind of event",
                  "flag_values": np.array(ev.EVENT_VALUES, dtype=np.int8),
                  "flag_meanings": ev.EVENT_MEANINGS}
    # fastpath: every array is a NumPy array made here, which xarray takes as it is
    # (without, it asks each whether it is a pandas, dask or masked array: 10 us apiece)
    data = {
        "branch": xr.Variable(t_dims, np.asarray(ms, dtype=np.int8), branch_attrs,
                              fastpath=True),
        "event_t": xr.Variable(event_dims, np.asarray(ev_t, dtype=float),
                               {"long_name": "time of the event", "units": "s"}, fastpath=True),
        "event_kind": xr.Variable(event_dims, ev_kind.astype(np.int8), kind_attrs,
                                  fastpath=True),
        "event_branch": xr.Variable(event_dims, ev_mode.astype(np.int8),
                                    {**branch_attrs,
                                     "long_name": "active branch after the event"},
                                    fastpath=True),
    }
    for j, var in enumerate(_layout(m).integrated):
        data[var.name] = xr.Variable(t_dims, ys[..., j], variable_attrs(var), fastpath=True)
        data[f"event_{var.name}"] = xr.Variable(
            event_dims, ev_y[..., j], {"long_name": f"{var.long_name} at the event "
                                       "(before its impulse, for an impulsive event)",
                                       "units": var.units}, fastpath=True)
    return data


def _motion_attrs(m: Model, full, positions, opts: Options, skip=()) -> dict:
    """The global attributes of motions after their header: how they were integrated
    and from what (the initial values and parameters, but those named in ``skip``)."""
    attrs = {
        "integrator": f"{METHODS[opts.method].DESCRIPTION}, events by classification",
        # the coordinate and velocity of the phase plane (the first degree of freedom)
        "phasemap_phase_plane": " ".join(m.dynamics.coordinates[0][:2]),
    }
    for k, value in opts.as_dict().items():
        attrs[f"phasemap_{k}"] = value
    state = {v.name for v in m.state}
    for name in m.names:
        if name not in skip:
            key = "initial" if name in state else "fixed"
            attrs[f"phasemap_{key}_{name}"] = float(full[name])
    for name, value in positions.items():
        if name not in skip:
            attrs[f"phasemap_initial_{name}"] = value
    return attrs


def _dataset(m: Model, full, positions, opts: Options, names, fate, n_rev, n_steps, ts, ys,
             ms, ev_t, ev_kind, ev_y, ev_mode) -> xr.Dataset:
    data = _motion_variables(m, "t", "event", ys, ms, ev_t, ev_kind, ev_y, ev_mode)
    fate_event = ev.Event(fate)
    attrs = {
        **cf_header(m, "trajectory", "phasemap.simulate"),
        "end_reason": fate_event.name.lower(),
        "end_message": ev.end_message(m, fate_event, dict(zip(names, ev_y[-1]))
                                      if len(ev_y) else None),
        "n_reversals": np.int32(n_rev),
        "n_steps": np.int64(n_steps),
        **_motion_attrs(m, full, positions, opts),
    }
    coords = {"t": xr.Variable("t", np.asarray(ts, dtype=float),
                               {"long_name": "time", "units": "s"}, fastpath=True)}
    return assemble(data, coords, attrs)


def _batch(m: Model, full, positions, opts: Options, names, y0s, te, result) -> xr.Dataset:
    """The Dataset of a batch of motions (see :func:`simulate`) from the batch driver's
    ``result`` (:func:`phasemap.motion.integrate.run_batch`); ``te``: the requested times, or
    None (every saved point)."""
    head, points, point_end, events, event_end, y_eval, eval_end = result
    n, ny = y0s.shape
    cuts = [np.concatenate([[0], ends]) for ends in (point_end, event_end, eval_end)]
    per = [_columns(points[cuts[0][i]:cuts[0][i + 1]], events[cuts[1][i]:cuts[1][i + 1]],
                    y_eval[cuts[2][i]:cuts[2][i + 1]], te) for i in range(n)]
    n_t = len(te) if te is not None else max(len(c[0]) for c in per)
    n_ev = max(len(c[3]) for c in per)
    ts, ys, ms = np.full((n, n_t), np.nan), np.full((n, n_t, ny), np.nan), np.full((n, n_t), -1)
    ev_t, ev_kind = np.full((n, n_ev), np.nan), np.full((n, n_ev), -1.0)
    ev_y, ev_mode = np.full((n, n_ev, ny), np.nan), np.full((n, n_ev), -1.0)
    for i, (t_i, y_i, m_i, et_i, ek_i, ey_i, em_i) in enumerate(per):
        k, e = len(t_i), len(et_i)
        ts[i, :k], ys[i, :k], ms[i, :k] = t_i, y_i, m_i
        ev_t[i, :e], ev_kind[i, :e], ev_y[i, :e], ev_mode[i, :e] = et_i, ek_i, ey_i, em_i
    t_dims = ("start", "t") if te is not None else ("start", "point")
    data = _motion_variables(m, t_dims, ("start", "event"), ys, ms, ev_t, ev_kind, ev_y,
                             ev_mode)
    counts = {"n_points": ("states reported", np.array([len(c[0]) for c in per])),
              "n_events": ("events", event_end - cuts[1][:-1])}
    data |= {
        "end_reason": xr.Variable("start", head[:, 0].astype(np.int8), {
            "long_name": "how the motion ended",
            "flag_values": np.array(ev.FATE_VALUES, dtype=np.int8),
            "flag_meanings": ev.FATE_MEANINGS}),
        "n_reversals": xr.Variable("start", head[:, 2].astype(np.int32), {
            "long_name": "number of reversals", "units": "1"}),
        "n_steps": xr.Variable("start", head[:, 3].astype(np.int64), {
            "long_name": "number of steps", "units": "1"}),
        **{k: xr.Variable("start", v.astype(np.int64), {"long_name": f"number of {what}",
                                                          "units": "1"})
           for k, (what, v) in counts.items()},
    }
    known = _layout(m).known
    for j, name in enumerate(names):
        data[f"initial_{name}"] = xr.Variable("start", y0s[:, j].copy(), {
            "long_name": f"initial {known[name].long_name}", "units": known[name].units})
    time = {"long_name": "time", "units": "s"}
    coords = {"start": xr.Variable("start", np.arange(n, dtype=np.int32),
                                   {"long_name": "index of the initial state", "units": "1"})}
    if te is not None:
        coords["t"] = xr.Variable("t", te.copy(), time)
    else:
        data["t"] = xr.Variable(t_dims, ts, time)
    attrs = {**cf_header(m, "trajectory", "phasemap.simulate"),
             **_motion_attrs(m, full, positions, opts, skip=names)}
    return assemble(data, coords, attrs)
