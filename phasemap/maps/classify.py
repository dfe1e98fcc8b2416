"""Point-wise solvability and stagnation: :func:`classify`.

A thin Python wrapper over each model's jitted ``point`` function and the
shared :func:`phasemap.core.numerics.summarize`, which the grid evaluator calls too.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from phasemap.core import args as _args
from phasemap.core import numerics as nx
from phasemap.core import tiers
from phasemap.core.model import BranchStatus, Model, Solvability
from phasemap.systems import reference


@dataclass(frozen=True)
class BranchResult:
    """One candidate branch at one state: its status, accelerations and reactions (the
    result; :class:`phasemap.core.model.Candidate` is the candidate's definition).

    Attributes
    ----------
    name:
        the branch's name in its model (``slide_neg_Npos``: sliding in the
        negative direction with N >= 0).
    status:
        a :class:`BranchStatus`; ``admissible`` is true for a solution
        (admissible, a continuum or a consistent separation).
    singular, coefficient:
        whether the coefficient of the senior derivative vanishes, and its value.
    accelerations, reactions:
        by name (``phi_ddot``, ``N``, ...), NaN where the branch has no solution.

    Examples
    --------
    >>> import phasemap
    >>> c = phasemap.classify("elliptic_pendulum", phi=0.8, xdot=-1.0, f=4.0)
    >>> [(b.name, b.admissible, b.reactions["N"] > 0) for b in c.branches]
    [('slide_neg_Npos', True, True), ('slide_neg_Nneg', True, False)]
    """

    name: str
    status: BranchStatus
    singular: bool
    coefficient: float
    accelerations: Mapping[str, float]
    reactions: Mapping[str, float]

    @property
    def admissible(self) -> bool:
        return self.status in (BranchStatus.ADMISSIBLE, BranchStatus.CONTINUUM,
                               BranchStatus.SEPARATION)


#: The old name of :class:`BranchResult`, kept so that existing code keeps working.
Branch = BranchResult

@dataclass(frozen=True)
class Classification:
    """The answer of :func:`classify` at one point of state and parameter space.

    Attributes
    ----------
    n_solutions:
        0 none, 1 unique, 2 two, 3 continuum, 4 three or more isolated solutions
        (see :class:`Solvability`).
    stagnation:
        the relative velocity is zero and the stick branch is admissible.
    contact_lost:
        some branch solves the equations but needs a one-sided contact to pull.
    singular:
        the coefficient of the senior derivative of some candidate branch vanishes.
    branches:
        the admissible branches (including a continuum), in the model's order.
    candidates:
        every branch that applies at this state, with its :class:`BranchStatus`.

    Examples
    --------
    >>> import phasemap
    >>> c = phasemap.classify("ladder", phi=0.5, omega=0.0, f=0.3)
    >>> c.n_solutions, c.stagnation, c.contact_lost, c.singular
    (1, True, False, False)
    """

    model: str
    values: Mapping[str, float]
    n_solutions: int
    stagnation: bool
    contact_lost: bool
    singular: bool
    branches: tuple[BranchResult, ...]
    candidates: tuple[BranchResult, ...]
    #: name -> UDUNITS units of every value, acceleration and reaction (for printing).
    units: Mapping[str, str] = field(default_factory=dict, repr=False, compare=False)

    @property
    def solvability(self) -> Solvability:
        return Solvability(self.n_solutions)

    def __str__(self) -> str:
        vals = ", ".join(f"{k}={v:g}{self._unit(k)}" for k, v in self.values.items())
        lines = [
            f"{self.model}({vals})",
            f"  n_solutions = {self.n_solutions} ({self.solvability.message})",
            f"  stagnation = {self.stagnation}, contact_lost = {self.contact_lost}, "
            f"singular = {self.singular}",
        ]
        width = max([10] + [len(b.name) for b in self.candidates])
        rows = [{**b.accelerations, **b.reactions} for b in self.candidates]
        # a quantity within the tie tolerance of zero, relative to its largest magnitude
        # over the candidates at this state, prints as 0 (a stick branch's 1e-15)
        scale = {k: max((abs(r[k]) for r in rows if np.isfinite(r[k])), default=0.0)
                 for k in (rows[0] if rows else ())}
        for b, row in zip(self.candidates, rows):
            nums = ", ".join(
                f"{k}={0.0 if abs(v) <= nx.TOL * scale[k] else v:.6g}{self._unit(k)}"
                for k, v in row.items())
            lines.append(f"  {b.name:<{width}} {b.status.name.lower():<12} {nums}")
        return "\n".join(lines)

    def _unit(self, name: str) -> str:
        """`` rad s-1`` for printing after a value; nothing for a pure number."""
        unit = self.units.get(name, "1")
        return "" if unit == "1" else f" {unit}"


def classify(model: str | Model, **values: float) -> Classification:
    """Count the solutions for the senior derivatives at one state.

    Parameters
    ----------
    model:
        a model name (see ``phasemap.MODELS``) or a :class:`Model`.
    **values:
        state variables and parameters by name; missing names take the model's
        defaults (``phasemap.MODELS[name].defaults``).

    Returns
    -------
    Classification
        ``n_solutions`` and the flags (``stagnation``, ``contact_lost``,
        ``singular``), with every candidate branch, admissible or not.

    Raises
    ------
    ValueError
        for an unknown model or variable, a non-finite value, or a value outside
        the model's domain (for example a negative length).

    Examples
    --------
    >>> import phasemap
    >>> phasemap.classify("ladder", phi=1.2, omega=0.0, f=0.3).n_solutions
    1
    >>> phasemap.classify("hinge_pendulum", phi=0.05, omega=0.0).stagnation
    True
    """
    from phasemap.maps import full as _full

    m = _full.map_model(model)
    if isinstance(m, _full.FullModel):   # no reduced model: the phases in full coordinates
        return _classify_full(m, values)
    values = _args.scalars(values, m.names, m.name,
                           " for classify(); use a Scene for arrays of values")
    full = m.complete(values)
    v = m.input_vector(full)
    out = np.full((len(m.branches), m.n_fields), np.nan)
    # machine code where it is compiled; else, at once, its interpreted twin while a
    # background process compiles it (phasemap.core.tiers; $PHASEMAP_JIT)
    warm = (classify, (reference(m),), full)
    tiers.runner(m.point, (v, out), warm)(v, out)
    n, stagnation, lost, singular = tiers.runner(nx.summarize, (out, m.stick_branch),
                                                 warm)(out, m.stick_branch)
    candidates = tuple(_branch(m, b, out[b]) for b in range(len(m.branches))
                       if out[b, nx.STATUS] != nx.ABSENT)
    return Classification(
        model=m.name,
        values={k: float(x) for k, x in full.items()},
        n_solutions=int(n),
        stagnation=bool(stagnation),
        contact_lost=bool(lost),
        singular=bool(singular),
        branches=tuple(b for b in candidates if b.admissible),
        candidates=candidates,
        units={v.name: v.units for v in (*m.variables.values(), *m.accelerations,
                                         *m.reactions)},
    )


def _branch(m: Model, b: int, row: np.ndarray) -> BranchResult:
    na = len(m.accelerations)
    acc = row[nx.FIRST_ACC:nx.FIRST_ACC + na]
    rea = row[nx.FIRST_ACC + na:]
    return BranchResult(
        name=m.branches[b],
        status=BranchStatus(int(row[nx.STATUS])),
        singular=bool(row[nx.SINGULAR]),
        coefficient=float(row[nx.COEF]),
        accelerations={v.name: float(x) for v, x in zip(m.accelerations, acc)},
        reactions={v.name: float(x) for v, x in zip(m.reactions, rea)},
    )


def _classify_full(m, values: Mapping[str, float]) -> Classification:
    """:func:`classify` of a system in full coordinates (:mod:`phasemap.maps.full`): its
    branches are the admissible phases (``belt_stick``, ``floor_slip_pos``...), each with
    the accelerations and reactions of its motion; a phase that opens a contact is a
    separation."""
    from phasemap.maps import full as _full

    values = _args.scalars(values, m.names, m.name,
                           " for classify(); use a Scene for arrays of values")
    complete = m.complete(values)
    q, u, p, t = m.state_of(complete)
    motion = m.motion(p)
    n, flags, _ = _full.cell(m, motion, q, u, t)      # what the map's cell says
    _, _, _, groups, cand = _full.survey(m, motion, q, u, t)
    na = len(m.accelerations)
    branches = []
    for g in groups:
        for modes, solution in g:
            row = _full.motion_row(m, [[(modes, solution)]])
            branches.append(BranchResult(
                name=_full.phase_name(m, modes),
                status=(BranchStatus.SEPARATION if _full.opens(modes, cand)
                        else BranchStatus.ADMISSIBLE),
                singular=False, coefficient=float("nan"),
                accelerations={v.name: float(x) for v, x in zip(m.accelerations, row)},
                reactions={v.name: float(x) for v, x in zip(m.reactions, row[na:])}))
    return Classification(
        model=m.name, values={k: float(x) for k, x in complete.items()},
        n_solutions=int(n), stagnation=bool(flags & _full.BITS["stagnation"]),
        contact_lost=bool(flags & _full.BITS["contact_lost"]),
        singular=bool(flags & _full.BITS["singular"]),
        branches=tuple(branches), candidates=tuple(branches),
        units={v.name: v.units for v in (*m.variables.values(), *m.accelerations,
                                         *m.reactions)})
