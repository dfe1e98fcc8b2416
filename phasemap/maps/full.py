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
  (``N_belt``, ``F_belt``...), NaN where the motion is not unique.

Each cell costs one survey, some 0.1-0.3 ms (the phases on the compiled flow, their
grouping in Python), so a map of these systems runs in blocks with a progress bar, like a
fate map.

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

#: A map's default grid over a coordinate and over its rate: (start, stop, count).
DEFAULT_AXIS = (-2.0, 2.0, 201)
#: Where a slipping phase's reaction matrix counts as singular: its determinant, scaled
#: to [-1, 1] (:meth:`phasemap.motion.hybrid.Motion.singularity`), at most this.
SINGULAR_TOL = 1e-9

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
        from phasemap.declare.full import closure, map_variables
        from phasemap.motion.hybrid.start import mechanics_of

        self.declaration = S
        self.name, self.title, self.citation = S.name, S.title, S.citation
        self.state, self.params, self.accelerations, self.check = map_variables(S)
        self.mech = mechanics_of(S)
        self.closure = closure(S)
        self.reactions = tuple(
            v for c in self.mech.contacts for v in (
                Variable(f"N_{c.name}", "N", f"normal reaction of the contact {c.name}"),
                Variable(f"F_{c.name}", "N", f"friction force of the contact {c.name}")))
        # what an atlas header describes (phasemap.atlas.dataset): no branches, no
        # coefficient, no reduced dynamics
        self.coefficient, self.branches, self.dynamics = None, (), None
        moving = [c for c in S.coordinates if c.rate]
        self.default_axes = dict(S.default_axes) or {
            moving[0].name: DEFAULT_AXIS, moving[0].rate.name: DEFAULT_AXIS}
        self.moving = [self.mech.coordinates.index(c.name) for c in moving]

    def __repr__(self) -> str:
        return f"FullModel({self.name!r})"

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
        if self.check is not None:
            self.check(full)
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
                abs(motion.singularity(q, u, modes, t=t)) <= SINGULAR_TOL:
            return True
    return False


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
    """The layers ``wanted`` over the grid of ``axes`` (the other names ``fixed``): one
    survey per cell (module docstring)."""
    shape = tuple(np.size(a) for a in axes.values())
    out = {l.name: np.zeros(shape, dtype=l.dtype) for l in wanted}
    fields = [l for l in wanted if not l.is_summary]
    motion = None
    names = list(axes)
    for index in np.ndindex(*shape):
        values = dict(fixed)
        for n, i in zip(names, index):
            values[n] = float(axes[n][i])
        q, u, p, t = model.state_of(values)
        if motion is None:
            motion = model.motion(p)
        elif not np.array_equal(p, motion.p):
            motion.at_parameters(p)
        n, stagnation, lost, groups, cand = survey(model, motion, q, u, t)
        for l in wanted:
            if l.name == "n_solutions":
                out[l.name][index] = n
            elif l.name == "stagnation":
                out[l.name][index] = stagnation
            elif l.name == "contact_lost":
                out[l.name][index] = lost
            elif l.name == "singular":
                out[l.name][index] = singular(motion, q, u, t, cand)
        if fields:
            row = motion_row(model, groups)
            for l in fields:
                out[l.name][index] = row[l.column]
    return out
