"""Maps and :func:`phasemap.classify` of a declared system that has no reduced model.

A reduced model (:class:`phasemap.Model`) holds one relative velocity, whose zero is the
stick branch's: a moving surface (a belt), a static coefficient above the kinetic one, a
slip coefficient that depends on the sliding speed, or forcing in time do not fit it
(:func:`phasemap.declare.validation.oscillator_features`).  Such a system moves in full
coordinates (:mod:`phasemap.motion.hybrid`), and its maps are read from the same
place: at each state, :meth:`phasemap.motion.hybrid.Motion.survey` finds every
admissible phase (each contact open, stuck or slipping, the slip relative to the
contact's surface), grouped by their accelerations, exactly as :func:`phasemap.simulate`
decides what a motion does at an event.  So the map, ``classify`` and the motion never
disagree.

A map's names are the declaration's free coordinates and their rates (the contacts
closed: the belt's block on the belt), its parameters, and the time ``t`` (the phase of
the forcing) of a system forced in time.  Its layers (:func:`layers`):

* ``n_solutions``: how many motions the equations admit (the groups of admissible
  phases; three or more is ``three_or_more``);
* ``stagnation``: a contact is at rest relative to its surface (for a belt: moves with
  it) and a motion keeps every such contact stuck;
* ``contact_lost``: a motion opens a contact that touches (the body leaves it);
* ``singular``: a slipping phase's reaction matrix is singular
  (:meth:`phasemap.motion.hybrid.Motion.singularity`, the coefficient of the senior
  derivative);
* the unique motion's accelerations (``x_ddot``...) and each contact's reactions
  (``N_belt``, ``F_belt``...), NaN where the motion is not unique;
* the motion layers, which move from each cell (:mod:`phasemap.maps.motions`): its fate
  over ``t_end`` (``fate``, ``n_sticks``, ``x_final``...) and its settled motion's
  section points (``section_x``... on one more dimension, and ``multiple``).

A map's cells run in one compiled, parallel call per block
(:func:`phasemap.motion.hybrid.flow.survey_cells`, the engine's own survey, some 3-5 us a
cell per thread), in blocks with a progress bar like a fate map's; a cell whose contacts
are redundant is surveyed by the engine in Python.  While the kernel compiles, its
interpreted twin answers (:mod:`phasemap.core.tiers`; tens of milliseconds a cell).

>>> import numpy as np, phasemap
>>> c = phasemap.classify("belt", x=-0.5, xdot=0.2)    # with the belt (v = 0.2), |k x| < f_s m g
>>> c.n_solutions, c.stagnation, [b.name for b in c.branches]
(1, True, ['belt_stick'])
>>> ds = phasemap.Scene("belt", axes={"x": np.linspace(-1.5, 1.5, 7)}, fixed={"xdot": 0.2}).compute()
>>> ds.stagnation.values.tolist()       # sticks where the spring's pull is within f_s m g = 1
[0, 1, 1, 1, 1, 1, 0]
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from phasemap.core import args as _args
from phasemap.core.memo import Memo
from phasemap.core.model import Solvability, Variable
from phasemap.motion.hybrid import flow as _flow

#: A map's default grid over a coordinate and over its rate: (start, stop, count).
DEFAULT_AXIS = (-2.0, 2.0, 201)

_MODELS = Memo("maps.full.models")


class FullModel:
    """What a map of a declaration without a reduced model takes: its names, their
    domains and defaults (as a :class:`phasemap.Model` gives them), and the motion at
    each state.  :func:`map_model` makes it.

    >>> import phasemap
    >>> from phasemap.maps.full import map_model
    >>> m = map_model("den_hartog")
    >>> m.names[:3], m.variables["t"].units
    (('x', 'xdot', 't'), 's')
    """

    def __init__(self, S):
        from phasemap.declare.full import closure
        from phasemap.motion.hybrid.start import mechanics_of

        self.declaration = S
        self.name, self.title, self.citation = S.name, S.title, S.citation
        self.state, self.params, self.accelerations = _variables(S)
        self.mech = mechanics_of(S)
        self.closure = closure(S)
        self.reactions = tuple(
            v for c in self.mech.contacts for v in (
                Variable(f"N_{c.name}", "N", f"normal reaction of the contact {c.name}",
                         rf"N_{{\mathrm{{{_tex(c.name)}}}}}"),
                Variable(f"F_{c.name}", "N", f"friction force of the contact {c.name}",
                         rf"F_{{\mathrm{{{_tex(c.name)}}}}}")))
        # what an atlas header describes (phasemap.atlas.dataset): no branches, no
        # coefficient, no reduced dynamics
        self.coefficient, self.branches, self.dynamics = None, (), None
        moving = [c for c in S.coordinates if c.rate]
        self.default_axes = dict(S.default_axes) or {
            v.name: _within(v) for v in (self.variables[moving[0].name],
                                        self.variables[moving[0].rate.name])}
        self.moving = [self.mech.coordinates.index(c.name) for c in moving]

    def __repr__(self) -> str:
        return f"FullModel({self.name!r})"

    def __reduce__(self):
        # made again from its declaration, which pickles: its generated functions live
        # in kernel modules another process (a dask worker) has not imported
        return (map_model, (self.declaration,))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(v.name for v in self.state + self.params)

    @property
    def variables(self) -> dict[str, Variable]:
        return {v.name: v for v in self.state + self.params}

    def variable(self, name: str) -> Variable:
        return self.variables[name]

    @property
    def defaults(self) -> dict[str, float]:
        return {v.name: float(v.default) for v in self.state + self.params}

    def complete(self, values: Mapping[str, object]) -> dict[str, object]:
        """Validate user values (scalars or arrays) and fill in the defaults (ValueError
        naming the system and the variable, as :meth:`phasemap.Model.complete`)."""
        full: dict[str, object] = self.defaults
        full.update(_args.values(values, self.names, self.name))
        for name, var in self.variables.items():
            var.check(self.name, full[name])
        return full

    def motion(self, p):
        """The :class:`phasemap.motion.hybrid.Motion` at the parameters ``p`` (a map's
        block binds one, and moves it to each cell's parameters)."""
        from phasemap.motion.hybrid.engine import Motion, Options

        return Motion(self.mech, p, Options(t_end=math.inf))

    def state_of(self, values: Mapping[str, float]):
        """``(q, u, p, t)`` of complete values: the full coordinates with every contact
        closed."""
        q, u = self.closure(values)
        p = np.array([float(values[n]) for n in self.mech.parameters])
        return q, u, p, float(values.get("t", 0.0))


def _variables(S):
    """``(state, params, accelerations)`` of a map of ``S`` in full coordinates: every
    coordinate a closed contact leaves free, then their rates, then the time ``t`` where
    the system depends on it; the parameters; the free coordinates' accelerations.  As a
    reduced model's (:func:`phasemap.declare.build.build_model`; built here, since a
    change to :mod:`phasemap.declare` renews every declared model's derivation)."""
    import sympy as sp       # (a System is made with sympy: it is loaded)

    from phasemap.declare.api import numeric_bound
    from phasemap.declare.validation import time_dependent

    def variable(x, bounded=True):
        kw = {}
        if bounded:
            for b in (x.lower, x.upper):
                if not numeric_bound(b):
                    raise ValueError(f"{S.name}: {x.name} has the bound {b}, an expression "
                                     "of the parameters: a map in full coordinates takes "
                                     "numbers only")
            kw = dict(lower=float(x.lower), upper=float(x.upper), lower_open=x.lower_open,
                      upper_open=x.upper_open)
        return Variable(x.name, x.units, x.long_name, x.symbol or sp.latex(sp.Symbol(x.name)),
                        default=float(x.default), **kw)

    moving = [c for c in S.coordinates if c.rate]
    state = tuple(variable(c) for c in moving) + tuple(variable(c.rate, False)
                                                      for c in moving)
    if time_dependent(S):
        state += (Variable("t", "s", "time (the phase of the forcing)", "t", 0.0),)
    accelerations = tuple(Variable(f"{c.name}_ddot",
                                   "s-2" if c.units == "1" else f"{c.units} s-2",
                                   f"second derivative of the {c.long_name}",
                                   f"\\ddot{{{c.symbol or c.name}}}") for c in moving)
    return state, tuple(variable(p) for p in S.parameters), accelerations


def _within(v: Variable) -> tuple[float, float, int]:
    """:data:`DEFAULT_AXIS` inside the domain of ``v`` (an open end stepped in by a
    thousandth of the span)."""
    lo, hi, count = DEFAULT_AXIS
    lo, hi = max(lo, v.lower), min(hi, v.upper)
    inset = 1e-3 * (hi - lo)
    return (lo + inset * v.lower_open * (lo == v.lower),
            hi - inset * v.upper_open * (hi == v.upper), count)


def _tex(name: str) -> str:
    r"""A contact's name inside mathtext's ``\mathrm{}``."""
    return name.replace("_", r"\_")


def map_model(model):
    """The model a map or :func:`phasemap.classify` of ``model`` runs on: its reduced
    :class:`phasemap.Model` where it has one (:func:`phasemap.get_model`), else a
    :class:`FullModel` (a built-in friction oscillator, or a
    :class:`phasemap.declare.System` that needs full coordinates)."""
    from phasemap.declare.system import System
    from phasemap.systems import OSCILLATORS, get_model

    if isinstance(model, FullModel):
        return model
    if isinstance(model, str) and model in OSCILLATORS:
        from phasemap.systems.oscillators import OSCILLATORS as systems

        model = systems[model]
    if isinstance(model, System):
        from phasemap.declare.validation import oscillator_features

        if not oscillator_features(model):
            return model.model
        return _MODELS.get((model,), (), lambda: FullModel(model))
    return get_model(model)


def phase_name(model: FullModel, modes) -> str:
    """A phase's name: each contact's mode (``belt_stick``, ``floor_slip_pos``)."""
    from phasemap.motion.hybrid.phases import MODE_NAMES

    return "_".join(f"{c.name}_{MODE_NAMES[m]}" for c, m in zip(model.mech.contacts, modes))


def survey(model: FullModel, motion, q, u, t):
    """What one state is: ``(n_solutions, stagnation, contact_lost, groups, candidates)``
    (module docstring), the groups those of
    :meth:`phasemap.motion.hybrid.Motion.survey`."""
    from phasemap.motion.hybrid.phases import STICK

    groups, cand = motion.survey(q, u, t=t)
    rest = [c for c, ms in enumerate(cand) if STICK in ms]
    phases = [modes for g in groups for modes, _ in g]
    stagnation = bool(rest) and any(all(m[c] == STICK for c in rest) for m in phases)
    lost = any(opens(m, cand) for m in phases)
    n = len(groups)
    return (n if n < 3 else int(Solvability.THREE_OR_MORE)), stagnation, lost, groups, cand


def opens(modes, cand) -> bool:
    """Whether the phase ``modes`` opens a contact that touches (whose candidate modes,
    ``cand``, are more than open): the body leaves it."""
    from phasemap.motion.hybrid.phases import OPEN

    return any(m == OPEN and tuple(ms) != (OPEN,) for m, ms in zip(modes, cand))


def singular(motion, q, u, t, cand) -> bool:
    """Whether a slipping phase among the candidate modes is singular (module docstring)."""
    from phasemap.motion.hybrid.phases import SLIP_NEG, SLIP_POS

    for pick in np.ndindex(*[len(ms) for ms in cand]):
        modes = tuple(cand[c][i] for c, i in enumerate(pick))
        if any(m in (SLIP_POS, SLIP_NEG) for m in modes) and \
                abs(motion.singularity(q, u, modes, t=t)) <= _flow.SINGULAR_TOL:
            return True
    return False


def cell(model: FullModel, motion, q, u, t, want_singular: bool = True):
    """``(n_solutions, flags, row)`` of one state, as a map's cell
    (:func:`phasemap.motion.hybrid.flow.survey_cells`; :func:`python_cell` where the
    contacts are redundant): what :func:`phasemap.classify` reports."""
    n, flags, rows = motion.flow.cells(motion.p[None, :], np.concatenate([q, u])[None, :],
                                       np.array([t]), model.moving, want_singular)
    if n[0] < 0:
        return python_cell(model, motion, q, u, t, want_singular)
    return int(n[0]), int(flags[0]), rows[0]


def python_cell(model: FullModel, motion, q, u, t, want_singular: bool):
    """:func:`cell` from :meth:`phasemap.motion.hybrid.Motion.survey` in Python: where the
    contacts are redundant (a member of their family of reactions picked by the engine)."""
    n, stagnation, lost, groups, cand = survey(model, motion, q, u, t)
    flags = (BITS["stagnation"] * stagnation + BITS["contact_lost"] * lost
             + BITS["singular"] * (want_singular and singular(motion, q, u, t, cand)))
    # the row of the unique motion's first phase in the survey's order, as the compiled
    # cell takes it (a group's phases agree in their accelerations to 1e-7, not always in
    # their reactions: stuck at the limit and slipping from rest)
    first = [[min(g, key=lambda item: tuple(cand[c].index(m) for c, m in enumerate(item[0])))]
             for g in groups]
    return n, flags, motion_row(model, first)


def motion_row(model: FullModel, groups) -> np.ndarray:
    """The unique motion's accelerations and reactions, NaN unless it is unique."""
    row = np.full(len(model.accelerations) + len(model.reactions), np.nan)
    if len(groups) == 1:
        ud, N, F = groups[0][0][1][:3]
        na = len(model.accelerations)
        row[:na] = ud[model.moving]
        row[na::2] = N
        row[na + 1::2] = F
    return row


def evaluate(model: FullModel, axes: Mapping[str, np.ndarray], fixed: Mapping[str, float],
             wanted) -> dict[str, np.ndarray]:
    """The layers ``wanted`` over the grid of ``axes`` (the other names ``fixed``): every
    cell in one compiled call (:func:`phasemap.motion.hybrid.flow.survey_cells`, the
    survey :meth:`phasemap.motion.hybrid.Motion.survey` makes), a cell whose contacts are
    redundant by the motion's own survey in Python."""
    names = list(axes)
    shape = tuple(np.size(a) for a in axes.values())
    cells = math.prod(shape)
    Y, P, T = _cells(model, axes, fixed, shape)
    motion = model.motion(P[0].copy() if cells else np.zeros(len(model.mech.parameters)))
    want_singular = any(l.name == "singular" for l in wanted)
    n, flags, rows = motion.flow.cells(P, Y, T, model.moving, want_singular)
    for i in np.flatnonzero(n < 0):      # redundant contacts: the engine picks a member
        index = np.unravel_index(i, shape)
        values = {**fixed, **{nm: float(axes[nm][j]) for nm, j in zip(names, index)}}
        q, u, p, t = model.state_of(values)
        motion.at_parameters(p)
        n[i], flags[i], rows[i] = python_cell(model, motion, q, u, t, want_singular)
    out = {}
    for l in wanted:
        if l.name == "n_solutions":
            a = n
        elif l.name in BITS:
            a = (flags & BITS[l.name]) != 0
        else:
            a = rows[:, l.column]
        out[l.name] = np.ascontiguousarray(a.reshape(shape), dtype=l.dtype)
    return out


def scratch_bytes(model: FullModel) -> int:
    """Bytes per cell :func:`evaluate` allocates besides the layers: each cell's full
    state, parameters and time (twice: built, then made writable for the kernel), its
    count, flags and unique motion's row."""
    n, k = model.mech.n, len(model.mech.contacts)
    return 2 * 8 * (2 * n + len(model.mech.parameters) + 1) + 2 + 8 * (len(model.moving)
                                                                      + 2 * k)


#: Each flag layer's bit in :func:`phasemap.motion.hybrid.flow.survey_cells`' flags.
BITS = {"stagnation": _flow.STAGNATION, "contact_lost": _flow.CONTACT_LOST,
        "singular": _flow.SINGULAR_PHASE}


def _cells(model: FullModel, axes, fixed, shape):
    """``(Y, P, T)``: each cell's full state (every contact closed), parameters and time,
    in C order.  The positions and the rates are each computed once per value of the
    names they read (:func:`_reads`): a map over a position and a rate makes one call per
    value of each, not per cell."""
    cells = math.prod(shape)
    names = list(axes)
    mech, cl = model.mech, model.closure

    def grid(name):
        """The values of ``name`` over the grid (broadcast, no copy)."""
        if name in axes:
            i = names.index(name)
            return np.broadcast_to(np.asarray(axes[name], dtype=float).reshape(
                [-1 if j == i else 1 for j in range(len(shape))]), shape)
        return np.broadcast_to(float(fixed[name]), shape)

    def over(fn):
        """``fn``'s values over the grid, (cells, n)."""
        on = [nm for nm in names if nm in _reads(fn)]
        sub = tuple(np.size(axes[nm]) for nm in on)
        small = np.empty(sub + (mech.n,))
        values = dict(fixed)
        for index in np.ndindex(*sub):
            values.update({nm: float(axes[nm][j]) for nm, j in zip(on, index)})
            small[index] = fn(*(float(values.get(a, 0.0)) for a in cl.args))
        view = small.reshape([np.size(axes[nm]) if nm in on else 1 for nm in names]
                             + [mech.n])
        return np.broadcast_to(view, shape + (mech.n,)).reshape(cells, mech.n)

    Y = np.concatenate([over(cl.positions), over(cl.rates)], axis=1)
    P = np.stack([grid(p).reshape(cells) for p in mech.parameters], axis=1) \
        if mech.parameters else np.zeros((cells, 0))
    T = grid("t").reshape(cells) if "t" in model.variables else np.zeros(cells)
    return Y, np.ascontiguousarray(P), np.ascontiguousarray(T)


def _reads(fn) -> set:
    """The arguments a generated function reads (a closure's positions read the positions,
    its rates the rates too)."""
    import dis

    out = set()
    for i in dis.get_instructions(fn):
        if i.opname.startswith("LOAD_FAST"):     # (3.13's LOAD_FAST_LOAD_FAST: a pair)
            out |= set(i.argval) if isinstance(i.argval, tuple) else {i.argval}
    return out
