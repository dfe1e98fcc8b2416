"""Trajectories in time: :func:`simulate`.

A thin Python wrapper over the model's jitted integrator
(:mod:`phasemap.integrate`): it validates the input, runs the integrator and
returns a self-describing :class:`xarray.Dataset`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import xarray as xr

from . import _args
from . import events as ev
from ._dataset import cf_header, variable_attrs
from .integrate import DEFAULT_METHOD, METHODS, check_method, kernels, unpack
from .model import Model, Variable
from .models import get_model

#: Tolerances tighter than this cannot be met in double precision.
RTOL_MIN = 1e-14


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
        :class:`phasemap._args.ArgumentTypeError`) naming the setting on bad values.
        Python and NumPy numbers alike; counts may be whole floats (``1e6``)."""
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
            raise _args.ArgumentTypeError(f"{model}: method must be a string, one of "
                                          f"{', '.join(METHODS)}, got {type(self.method).__name__}")
        check_method(self.method, model)
        return Options(t_end, rtol, atol, max_step, *counts, self.method)

    def as_dict(self) -> dict:
        return {"t_end": self.t_end, "rtol": self.rtol, "atol": self.atol,
                "max_step": self.max_step, "max_steps": self.max_steps,
                "max_events": self.max_events, "method": self.method}


def integrated_variables(model: Model) -> list[Variable]:
    """The integrated state: positions, then velocities (with their descriptions)."""
    dyn = _dynamics(model)
    known = {**model.variables, **{p.name: p for p in dyn.positions}}
    return ([known[c[0]] for c in dyn.coordinates] + [known[c[1]] for c in dyn.coordinates])


def _dynamics(model: Model):
    if model.dynamics is None:
        raise ValueError(f"{model.name}: this model has no dynamics; it can be classified and "
                         "mapped but not integrated in time")
    return model.dynamics


def split_values(model: Model, values: Mapping[str, float]):
    """Validate ``values``: model variables (complete) and extra positions (default 0)."""
    dyn = _dynamics(model)
    extra = {p.name: p for p in dyn.positions}
    values = _args.scalars(values, [*model.names, *extra], model.name,
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
             **values: float) -> xr.Dataset:
    """Integrate the motion from an initial state, with exact stick and slip.

    Parameters
    ----------
    model:
        a model name or :class:`phasemap.Model` with dynamics (all four
        built-in models).
    t_end:
        the time horizon (s).
    rtol, atol:
        relative and absolute tolerances of the steps (``atol`` defaults to
        ``rtol``); ``rtol`` in [1e-14, 0.1].
    max_step:
        largest step (s); lower it to resolve short excursions between steps.
    t_eval:
        sorted times in [0, t_end] at which to report the state (from the
        dense output).  Default: every accepted step and every event.
    max_steps, max_events:
        limits after which the motion ends with ``max_steps`` or ``max_events``.
    method:
        ``"DOPRI5"`` (Dormand-Prince 5(4), the default) or ``"DOP853"``
        (Dormand-Prince 8(5,3) with a dense output of order 7: fewer steps at
        tight tolerances, below about 1e-8).
    **values:
        initial state and parameters by name (``phasemap models`` lists them);
        missing names take the model's defaults.  The elliptic pendulum also
        takes the slider position ``x`` (default 0).

    Returns
    -------
    xarray.Dataset
        coordinate ``t``; the state variables by name (positions, then
        velocities); ``branch``, the active branch; and an events table on
        dimension ``event``: ``event_t``, ``event_kind`` (see
        :class:`phasemap.Event`), ``event_branch`` (the branch after the
        event) and the state at each event.  The first event is ``start`` (or
        the fate, when the motion cannot start); the last is the fate.
        ``attrs["end_reason"]`` names the fate, ``attrs["end_message"]``
        explains it.

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
    """
    m = get_model(model)
    opts = Options(t_end, rtol, atol, max_step, max_steps, max_events, method).checked(m.name)
    full, positions = split_values(m, values)
    if t_eval is None:
        te = np.empty(0)
    else:
        te = _args.reals("t_eval", t_eval, m.name)
        if te.ndim != 1 or not np.all(np.isfinite(te)) or np.any(np.diff(te) < 0) or (
                te.size and (te[0] < 0 or te[-1] > opts.t_end)):
            raise ValueError(f"{m.name}: t_eval must be a sorted 1-D sequence of times in "
                             f"[0, t_end = {opts.t_end:g}]")
    integrate, _ = kernels(m, opts.method)
    names = [v.name for v in integrated_variables(m)]
    y0 = np.array([positions[n] if n in positions else float(full[n]) for n in names])
    v = m.input_vector(full)
    fate, t, y, n_rev, n_steps, points, events, y_eval = integrate(
        v, y0, opts.t_end, opts.rtol, opts.atol, opts.max_step, opts.max_steps,
        opts.max_events, t_eval is None, te)
    ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode = unpack(points, events)
    if t_eval is not None:
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
    return _dataset(m, full, positions, opts, names, int(fate), int(n_rev), int(n_steps),
                    ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode)


def end_message(m: Model, fate: ev.Event, y=None) -> str:
    """The fate's message; at an edge of the domain, which edge and what it means."""
    if fate != ev.Event.LEFT_DOMAIN or y is None:
        return fate.message
    variables = integrated_variables(m)
    edges = m.dynamics.edges
    for var, value in zip(variables, y):
        for side, bound in enumerate((var.lower, var.upper)):
            if math.isfinite(bound) and value == bound:
                meaning = edges.get(var.name, ("", ""))[side]
                return (f"{fate.message}: {var.name} reached {bound:.6g} {var.units}"
                        + (f" ({meaning})" if meaning else ""))
    if m.domain_text:
        return f"{fate.message}: {m.domain_text}"
    return fate.message


def _dataset(m: Model, full, positions, opts: Options, names, fate, n_rev, n_steps, ts, ys,
             ms, ev_t, ev_kind, ev_y, ev_mode) -> xr.Dataset:
    variables = integrated_variables(m)
    branch_values = np.arange(-1, len(m.branches), dtype=np.int8)
    branch_attrs = {"long_name": "active branch of the friction law",
                    "flag_values": branch_values,
                    "flag_meanings": " ".join(["none", *m.branches])}
    kind_attrs = {"long_name": "kind of event", "flag_values": np.array(ev.EVENT_VALUES,
                                                                        dtype=np.int8),
                  "flag_meanings": ev.EVENT_MEANINGS}
    data = {
        "branch": xr.Variable("t", np.asarray(ms, dtype=np.int8), branch_attrs),
        "event_t": xr.Variable("event", ev_t, {"long_name": "time of the event",
                                               "units": "s"}),
        "event_kind": xr.Variable("event", ev_kind.astype(np.int8), kind_attrs),
        "event_branch": xr.Variable("event", ev_mode.astype(np.int8),
                                    {**branch_attrs,
                                     "long_name": "active branch after the event"}),
    }
    for j, var in enumerate(variables):
        data[var.name] = xr.Variable("t", ys[:, j], variable_attrs(var))
        data[f"event_{var.name}"] = xr.Variable(
            "event", ev_y[:, j], {"long_name": f"{var.long_name} at the event",
                                  "units": var.units})
    fate_event = ev.Event(fate)
    attrs = {
        **cf_header(m, "trajectory", "phasemap.simulate"),
        "end_reason": fate_event.name.lower(),
        "end_message": end_message(m, fate_event, ev_y[-1] if len(ev_y) else None),
        "n_reversals": np.int32(n_rev),
        "n_steps": np.int64(n_steps),
        "integrator": f"{METHODS[opts.method].DESCRIPTION}, events by classification",
        # the coordinate and velocity of the phase plane (the first degree of freedom)
        "phasemap_phase_plane": " ".join(m.dynamics.coordinates[0][:2]),
    }
    for k, value in opts.as_dict().items():
        attrs[f"phasemap_{k}"] = value
    for name in m.names:
        key = "initial" if name in {v.name for v in m.state} else "fixed"
        attrs[f"phasemap_{key}_{name}"] = float(full[name])
    for name, value in positions.items():
        attrs[f"phasemap_initial_{name}"] = value
    coords = {"t": xr.Variable("t", np.asarray(ts, dtype=float),
                               {"long_name": "time", "units": "s"})}
    return xr.Dataset(data, coords, attrs)
