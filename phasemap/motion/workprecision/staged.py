r"""The baseline: :func:`scipy.integrate.solve_ivp` driven stage by stage with phasemap's events.

On a stage the right-hand side is the model's own jitted branch function
``model.branch(v, b, row)``, called from Python: the equations are exactly
phasemap's, and a call costs about as much as the same equation written with
the ``math`` module (both ~3 us, measured), so scipy is not handicapped by it.
Per call the driver builds only the small tuple ``solve_ivp`` converts and a
cache key.  Each stage is one ``solve_ivp`` call with terminal events
(``direction = -1``), all derived from the model, none written per system:

* ``velocity``: the relative velocity (:attr:`phasemap.Model.velocity`) reaching
  zero, ``d v`` with d the stage's direction;
* ``coefficient``: the coefficient of the senior derivative of the stage's
  branch row changing sign;
* ``classification``: the stage stopping to be the unique solution (or leaving
  the model's domain) for any other reason: a contact that would have to pull,
  a friction cone left at stick, another branch taking over.  This is the
  integrator's own test after every step (its compiled ``still`` piece, the
  model's ``point`` function and statuses), +1 on the stage and -1 off it, so
  ``solve_ivp`` locates it by bisecting a step function (about 50
  classifications per event).  A velocity the model counts as zero is left to
  the ``velocity`` event.

Event functions and the right-hand side share the last branch row computed
(keyed on ``(t, y)``), so an event at a step end costs no extra row.  At a
terminal event the integrator's own compiled event piece
(:func:`phasemap.motion.integrate.stage_kernels`) decides what happens, as it does in
:func:`phasemap.simulate`: the state is classified (at a velocity zero with
the velocity set to exactly 0), a tie within the model's 1e-12 tolerances is
probed past along the Euler line y + dt f(y) (dt = 10^k 2 eps max(|t|, h), k =
1..9, the integrator's probe on its dense output), and the next stage or the
fate follows.  Then ``solve_ivp`` restarts on the next stage; its setup cost
at every restart is part of what is measured.  Implicit methods (Radau, LSODA)
get no Jacobian (none is available in closed form), so they difference it
numerically, as ``solve_ivp`` does by default.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from phasemap.core import numerics as nx
from phasemap.core import events as ev
from phasemap.motion.integrate import stage_kernels
from phasemap.core.model import Model
from phasemap.systems import get_model
from phasemap.motion.simulate import Options, integrated_variables, split_values

_EPS = np.finfo(float).eps


@dataclass
class Staged:
    """A motion solved stage by stage by :func:`solve_ivp_staged`."""

    t: np.ndarray            # the requested times reached
    y: np.ndarray            # states there (n, ny)
    t_final: float
    y_final: np.ndarray
    fate: str
    n_reversals: int
    nfev: int
    events: list = field(default_factory=list)   # (t, kind name, branch, y)
    stages: list = field(default_factory=list)   # (t0, t1, branch, OdeSolution) if dense


class StageDriver:
    """The per-problem preparation of :func:`solve_ivp_staged` (not timed)."""

    def __init__(self, model: str | Model, values: Mapping[str, float]):
        m = self.m = get_model(model)
        self.kernels = stage_kernels(m)  # ValueError for a model without dynamics
        full, positions = split_values(m, values)
        names = [v.name for v in integrated_variables(m)]
        self.y0 = np.array([positions[n] if n in positions else float(full[n]) for n in names])
        self.v = m.input_vector(full)
        self.full = full
        consts = self.kernels.constants
        self.fill = [(i, int(s)) for i, s in enumerate(consts["Y_SLOT"]) if s >= 0]
        self.ndof = consts["N_DOF"]
        self.acc_col = [int(c) for c in consts["ACC_COL"]]
        self.vel = consts["VEL_Y"]
        self.directions = m.directions
        self.out = np.empty((len(m.branches), m.n_fields))
        self.row = np.empty(m.n_fields)
        self.yb = np.empty(len(names))
        self.key = None

    # -- the model, from Python ---------------------------------------------
    def branch_row(self, t, y, branch):
        """The row of ``branch`` at (t, y), cached on the last (t, y)."""
        key = (t, y.tobytes())
        if key != self.key:
            v = self.v
            for i, s in self.fill:
                v[s] = y[i]
            self.m.derive(v)
            row = self.row
            for c in self.acc_col:
                row[c] = np.nan
            self.m.branch(v, branch, row)
            self.key = key
        return self.row

    # -- one stage ------------------------------------------------------------
    def stage_functions(self, branch, coef_sign):
        """The right-hand side and the terminal events of the stage of ``branch``."""
        nd, cols, branch_row = self.ndof, self.acc_col, self.branch_row
        if nd == 1:
            c0 = cols[0]

            def fun(t, y):
                return (y[1], branch_row(t, y, branch)[c0])
        elif nd == 2:
            c0, c1 = cols

            def fun(t, y):
                row = branch_row(t, y, branch)
                return (y[2], y[3], row[c0], row[c1])
        else:
            def fun(t, y):
                row = branch_row(t, y, branch)
                return tuple(y[nd:]) + tuple(row[c] for c in cols)

        events = []
        d, vel = self.directions[branch], self.vel
        if d != 0.0:
            def velocity(t, y):
                return d * y[vel]
            events.append(("velocity", velocity))
        if coef_sign != 0.0:
            def coefficient(t, y):
                return coef_sign * branch_row(t, y, branch)[nx.COEF]
            events.append(("coefficient", coefficient))
        still, out, v, stick = self.kernels.still, self.out, self.v, self.m.stick_branch

        def classification(t, y):
            y = np.ascontiguousarray(y, dtype=float)
            if still(v, y, out, branch, coef_sign):
                return 1.0
            # a velocity the model counts as zero: the velocity event's
            zero_velocity = d != 0.0 and out[stick, nx.STATUS] != nx.ABSENT
            return 1.0 if zero_velocity and d * y[vel] >= 0.0 else -1.0
        events.append(("classification", classification))
        for _, e in events:
            e.terminal = True
            e.direction = -1.0
        return fun, events

    def event(self, fun, t, y, branch, coef_sign):
        """The integrator's event piece at a terminal event (t, y) of the stage of
        ``branch``: ``(t, y, kind, branch)``, kind -1 for a rounding flicker."""
        y = np.array(y, dtype=float)
        h = 1e9 * 2.0 * _EPS * max(1.0, abs(t))  # the probes past a tie reach t + h
        r = np.stack([y, h * np.asarray(fun(t, y), dtype=float)])  # the Euler line
        t, kind, new_branch = self.kernels.event(self.v, y, t, t, h, 0.0, r, branch, coef_sign,
                                               self.out, self.yb)
        return t, y, int(kind), int(new_branch)

    def run(self, method: str, rtol: float, atol: float, t_end: float, t_eval: np.ndarray,
            dense: bool = False, max_events: int = 10_000, h_max: float = math.inf) -> Staged:
        from scipy.integrate import solve_ivp

        m = self.m
        stick = m.stick_branch
        y = self.y0.copy()
        t = 0.0
        te = np.asarray(t_eval, dtype=float)
        sentinel = te.size == 0 or te[-1] < t_end  # t_end is always evaluated, for y_final
        if sentinel:
            te = np.append(te, t_end)
        ts, ys = [], []
        n_rev = nfev = flickers = 0
        events, stages = [], []
        kind, branch = self.kernels.start(self.v, y, self.out)
        fate = None if kind == ev.START else int(kind)
        if fate is None:
            events.append((t, "start", branch, y.copy()))
        i_eval = 0
        while fate is None:
            coef_sign = float(self.kernels.coefficient(self.out, branch)[1])
            fun, evs = self.stage_functions(branch, coef_sign)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # rtol near 100 eps; LSODA's own notes
                sol = solve_ivp(fun, (t, t_end), y, method=method, rtol=rtol, atol=atol,
                                t_eval=te[i_eval:], events=[e for _, e in evs],
                                dense_output=dense, max_step=h_max)
            nfev += sol.nfev
            # (scipy 1.17 gives empty lists, not arrays, where no requested time was
            # reached before a terminal event)
            sol_t = np.asarray(sol.t, dtype=float)
            sol_y = np.asarray(sol.y, dtype=float).reshape(y.size, sol_t.size)
            if sol_t.size:
                ts.append(sol_t)
                ys.append(sol_y.T)
                i_eval += sol_t.size
            if sol.status == -1:
                fate = ev.STEP_FAILURE
                t, y = float(sol_t[-1]) if sol_t.size else t, (
                    np.array(sol_y[:, -1]) if sol_t.size else y)
                break
            if sol.status == 0:  # reached t_end on this stage
                if dense:
                    stages.append((t, t_end, branch, sol.sol))
                t, y = t_end, np.array(sol_y[:, -1], dtype=float)
                fate = ev.HORIZON
                break
            # the terminal event that ended the stage: the latest recorded one
            which, t_ev = max(((j, x[-1]) for j, x in enumerate(sol.t_events) if x.size),
                              key=lambda p: p[1])
            if dense:
                stages.append((t, float(t_ev), branch, sol.sol))
            t, y, kind, new_branch = self.event(fun, float(t_ev), sol.y_events[which][-1], branch,
                                              coef_sign)
            action, code, flickers = ev.after_event(kind, flickers, len(events), max_events)
            if action == ev.GO_ON:  # a rounding flicker: the stage goes on from here
                continue
            if kind == ev.REVERSAL:
                n_rev += 1
            if action == ev.END:
                fate = int(code)
                break
            events.append((t, ev.Event(kind).name.lower(), new_branch, y.copy()))
            branch = new_branch
        if fate == ev.REST and i_eval < te.size:  # at rest for good
            ts.append(te[i_eval:])
            ys.append(np.repeat(y[None, :], te.size - i_eval, axis=0))
        events.append((t, ev.Event(fate).name.lower(), stick if fate == ev.REST else -1,
                       y.copy()))
        t_all = np.concatenate(ts) if ts else np.empty(0)
        y_all = np.concatenate(ys) if ys else np.empty((0, y.size))
        if sentinel and t_all.size and t_all[-1] == t_end:
            t_all, y_all = t_all[:-1], y_all[:-1]
        return Staged(t_all, y_all, t, y, ev.Event(fate).name.lower(), n_rev, nfev, events,
                      stages)


def solve_ivp_staged(model: str | Model, t_end: float, *, method: str = "DOP853",
                     rtol: float = 1e-8, atol: float | None = None,
                     t_eval: Sequence[float] | None = None, dense_output: bool = False,
                     max_events: int = 10_000, **values: float) -> Staged:
    """The motion by :func:`scipy.integrate.solve_ivp`, stage by stage, with phasemap's events.

    The same problem as :func:`phasemap.simulate` (the model's branch
    equations, rest, stick, reversal and the fates decided by the integrator's
    own event piece; see the module docstring), solved by ``solve_ivp`` with
    ``method`` on each stage.  Returns a :class:`Staged`: the states at
    ``t_eval`` (default: t_end only) that the motion reached, the end state,
    the fate and the events.

    >>> from phasemap.motion.workprecision import solve_ivp_staged
    >>> run = solve_ivp_staged("hinge_pendulum", 20.0, phi=2.5, omega=0.0, delta=0.05)
    >>> run.fate, run.n_reversals
    ('rest', 12)
    """
    m = get_model(model)
    opts = Options(t_end, rtol, atol).checked(m.name)
    te = np.array([opts.t_end]) if t_eval is None else np.asarray(t_eval, dtype=float)
    driver = StageDriver(m, values)
    return driver.run(method, opts.rtol, opts.atol, opts.t_end, te, dense=dense_output,
                      max_events=max_events)
