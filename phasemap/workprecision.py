r"""Error against run time (work-precision), in the manner of DiffEqDevTools.

For one :class:`Problem` (a model, an initial state, a horizon and a
:class:`Reference`), :func:`work_precision` runs every method at every
tolerance, measures the error of each run against the reference and the run
time per trajectory, and returns one row (a dict) per (method, tolerance).
:func:`report` turns the rows into a markdown table; the figure is
:func:`phasemap.plot.work_precision_figure`.

>>> import phasemap.workprecision as wp
>>> rows = wp.work_precision(wp.PROBLEMS["hinge_weightless"], tolerances=[1e-6],
...                          methods=["phasemap", "RK45"], repeats=1)   # doctest: +SKIP
>>> print(wp.report(rows))                                            # doctest: +SKIP

Methods
-------
``phasemap``, ``phasemap_DOP853``
    the numba integrator of :mod:`phasemap.integrate` with its Dormand-Prince
    5(4) (the default) or 8(5,3) method, called directly (its jitted kernel,
    the same call :func:`phasemap.simulate` and the fate maps make), with
    ``rtol = atol = tol``.
``simulate``
    :func:`phasemap.simulate` itself: the same kernel plus input validation and
    the :class:`xarray.Dataset` it returns.
``RK45``, ``DOP853``, ``Radau``, ``LSODA``
    :func:`scipy.integrate.solve_ivp` driven stage by stage by
    :func:`solve_ivp_staged`, with ``rtol = atol = tol``: the same problem,
    stage switching included.
``phase_curve``
    the first-integral tracer :func:`phasemap.phase.phase_curve` (one-degree-of-
    freedom models only).  It has no tolerance (its row has ``tol = nan``) and
    no time: its error is measured in the phase plane (below).

The scipy stage driver (fairness)
---------------------------------
On a stage the right-hand side is the model's own jitted branch function
``model.branch(v, b, row)``, called from Python: the equations are
exactly phasemap's, and a call costs about as much as the same equation
written with the ``math`` module (both ~3 us, measured), so scipy is not
handicapped by it.  Per call the driver builds only the small tuple
``solve_ivp`` converts and a cache key.  Each stage is one ``solve_ivp`` call
with terminal events (``direction = -1``):

* the relative velocity reaching zero (``d * v``, d the stage's direction);
* each reaction whose sign the stage assumes reaching zero (the ladder's
  ``N_floor`` and ``N_wall``, the wheel's ``N``, the elliptic pendulum's
  ``rho N`` on a branch that assumes sgn N = rho);
* the coefficient of the senior derivative changing sign;
* on the elliptic pendulum's stick stage, the friction margin ``f |N| - |F|``
  reaching zero.

Event functions and the right-hand side share the last branch row computed
(keyed on ``(t, y)``), so an event at a step end costs no extra model call.
At a terminal event the state is classified with the model's ``point``
function and :func:`phasemap._numerics.summarize`, which is what
:func:`phasemap.classify` does: at a velocity zero (the velocity set to
exactly 0) it decides rest, stick, reversal or another fate; where the
classification at the event still admits the running branch (a tie within the
model's 1e-12 tolerances), the state is advanced by Euler steps of
10^k * 2 eps max(1, t) (k = 1..9) to the first state that is decided (a
unique solution on another branch), refined by bisection, as the numba
integrator probes past a tie; a state that stays undecided past the tie is a
genuine paradox and its classification is the fate.  Then ``solve_ivp`` restarts on the next stage; its setup
cost at every restart is part of what is measured.  Implicit methods (Radau,
LSODA) get no Jacobian (none is available in closed form), so they
difference it numerically, as ``solve_ivp`` does by default.

Errors
------
Every method's solution is saved at ``n_save`` times evenly spaced on
[0, t_end] (``t_eval``; a motion that ends before t_end at a fate other than
rest has fewer); after a rest the state is the rest state.

* ``error_final``: max over components of |y_end - y_end_ref|, where y_end is
  the state where the motion ends: at t_end, or at the fate (rest, contact
  loss).
* ``error_l2``: the root mean square over the saved points (and the compared
  components) of y - y_ref, DiffEqDevTools' L2.

For the phase-curve tracer, which has no time, both are measured in the phase
plane: ``error_l2`` is the RMS over its points of omega - omega_ref(phi) on
the same stage, ``error_final`` the max difference of its end state (phi,
omega).

References (:class:`Reference`): a closed form in time (the weightless hinge
pendulum, eq. (36)); a first integral omega(phi) (the ladder's omega^2(phi),
compared at each method's own phi, with the exact contact-loss state where
N_wall or N_floor vanishes on the closed form); or ``"tight"``: the driver
with DOP853 at rtol = atol = 1e-13 (:func:`tight_reference`).  Its ``floor``
is its difference from DOP853 at 1e-12, errors below about that are not
resolved; it is cross-checked against the numba integrator at 1e-13.

Timing
------
The run time of a method is the median over ``repeats`` rounds; in each
round the methods alternate, tolerance by tolerance.  Every (method,
tolerance) runs once before timing (this warms numba's JIT and gives the
errors).  A sample repeats a fast run until it lasts ``min_time`` seconds and
divides.  Preparation that is not per trajectory (model lookup, input
validation, the input vector) is outside the timing for ``phasemap`` and the
scipy driver alike; ``simulate`` and ``phase_curve`` are timed as a user calls
them.  A method whose warm-up run exceeds ``budget`` seconds skips its tighter
tolerances (its rows say ``skipped``).
"""

from __future__ import annotations

import gc
import math
import statistics
import time
import warnings
from dataclasses import dataclass, field
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from . import _numerics as nx
from . import events as ev
from .integrate import kernels
from .model import Model
from .models import get_model
from .models import hinge_pendulum as _hinge
from .models import ladder as _ladder
from .simulate import Options, integrated_variables, simulate, split_values

__all__ = ["DEFAULT_METHODS", "DEFAULT_TOLERANCES", "PHASEMAP_METHODS", "PROBLEMS",
           "SCIPY_METHODS", "Problem",
           "Reference", "Staged", "equal_error_ratio", "report", "solve_ivp_staged",
           "tight_reference", "time_at_error", "work_precision"]

#: The solve_ivp methods compared.
SCIPY_METHODS = ("RK45", "DOP853", "Radau", "LSODA")
#: The numba integrator's kernel, by the integrator method it runs.
PHASEMAP_METHODS = {"phasemap": "DOPRI5", "phasemap_DOP853": "DOP853"}
#: Every method, in the order of the figure's legend.
DEFAULT_METHODS = ("phase_curve", *PHASEMAP_METHODS, "simulate") + SCIPY_METHODS
#: rtol = atol of the sweep: 1e-3 to 1e-13.
DEFAULT_TOLERANCES = tuple(10.0 ** -k for k in range(3, 14))
#: Tolerance of the tight references.
TIGHT = 1e-13

_EPS = np.finfo(float).eps


# ------------------------------------------------------------------ the problems
@dataclass(frozen=True)
class Reference:
    """What a run is measured against.

    ``states(t, y)``
        the reference states (n, ny) at the saved points ``(t, y)`` of a run.
        A closed form in time ignores ``y``; a first integral omega(phi)
        returns ``y`` with omega replaced by its exact value at ``y``'s phi.
    ``end``
        the state (ny,) where the motion ends (at t_end or at its fate).
    ``omega(phi, stage)``
        omega_ref at the angles ``phi`` on the stages ``stage`` (stage 0 is
        the first; a stage ends at every reversal), for the phase-curve
        tracer; None where the model has no phase curve.
    ``components``
        the state components compared (default: all).
    ``fate``, ``n_reversals``
        how the reference motion ends.
    ``floor``
        the reference's own uncertainty (0 for a closed form).
    ``cross_check``
        the largest difference from an independent solution (tight references).
    """

    kind: str
    states: Callable[[np.ndarray, np.ndarray], np.ndarray]
    end: np.ndarray
    fate: str
    n_reversals: int
    omega: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    components: tuple[int, ...] | None = None
    floor: float = 0.0
    cross_check: float = 0.0
    note: str = ""


@dataclass(frozen=True)
class Problem:
    """One work-precision problem: a model, an initial state, a horizon, a reference.

    ``values`` are the initial state and parameters by name, as for
    :func:`phasemap.simulate`.  ``reference`` is a :class:`Reference`, a
    callable ``problem -> Reference``, or ``"tight"`` (see
    :func:`tight_reference`).  ``phi_range`` is passed to the phase-curve
    tracer (default: the model's).
    """

    name: str
    model: str
    values: Mapping[str, float]
    t_end: float
    reference: object = "tight"
    n_save: int = 101
    phi_range: tuple[float, float] | None = None
    description: str = ""

    @property
    def t_save(self) -> np.ndarray:
        return np.linspace(0.0, self.t_end, self.n_save)

    def resolve(self) -> Reference:
        """The problem's :class:`Reference` (computing a tight one if asked)."""
        ref = self.reference
        if isinstance(ref, Reference):
            return ref
        if isinstance(ref, str):
            if ref != "tight":
                raise ValueError(f"{self.name}: reference must be a Reference, a callable or "
                                 f"'tight', got {ref!r}")
            return tight_reference(self)
        return ref(self)


def _weightless_reference(p: Problem) -> Reference:
    """Eq. (36) of the hinge pendulum, exact in time and in the phase plane."""
    phi0, omega0 = p.values["phi"], p.values["omega"]
    delta, l = p.values["delta"], p.values.get("l", 1.0)
    k = delta / math.sqrt(l * l - delta * delta)

    def states(t, y):
        phi, omega = _hinge.weightless_motion(t, phi0, omega0, delta, l)
        return np.column_stack([phi, omega])

    def omega(phi, stage):
        return omega0 * np.exp(-k * np.abs(np.asarray(phi) - phi0))

    return Reference("closed form (36)", states, states(np.array([p.t_end]), None)[0],
                     "horizon", 0, omega)


def _ladder_reference(p: Problem) -> Reference:
    """omega^2(phi) of the ladder's stage in closed form; the exact contact-loss state."""
    from scipy.optimize import brentq

    m = get_model("ladder")
    full = m.complete(dict(p.values))
    phi0, omega0, f, l, g = (float(full[n]) for n in ("phi", "omega", "f", "l", "g"))
    s = 1.0 if omega0 > 0 else -1.0

    def omega(phi, stage=None):
        phi = np.asarray(phi, dtype=float)
        u = np.array([_ladder.omega_squared(x, phi0, omega0, f, l, g) for x in phi.ravel()])
        return s * np.sqrt(np.maximum(u, 0.0)).reshape(phi.shape)

    v = m.input_vector(full)
    row = np.empty(m.n_fields)
    cols = [m.first_reaction + i for i, r in enumerate(m.reactions)
            if r.name in ("N_floor", "N_wall")]
    b = m.branches.index("slide_pos" if s > 0 else "slide_neg")

    def n_min(phi):
        v[0], v[1] = phi, float(omega(np.array([phi]))[0])
        m.derive(v)
        m.branch(v, b, row)
        return min(row[c] for c in cols)

    lo, hi = phi0, (math.pi / 2 if s > 0 else 0.0)
    grid = np.linspace(lo, hi, 2001)
    vals = [n_min(x) for x in grid]
    i = next(i for i in range(1, grid.size) if vals[i] < 0.0)
    phi_c = brentq(n_min, grid[i - 1], grid[i], xtol=1e-16, rtol=4 * _EPS, maxiter=200)
    end = np.array([phi_c, float(omega(np.array([phi_c]))[0])])

    def states(t, y):
        out = np.array(y, dtype=float, copy=True)
        out[:, 1] = omega(out[:, 0])
        return out

    return Reference("first integral omega^2(phi)", states, end, "contact_lost", 0, omega,
                     components=(1,), note="omega compared at each method's own phi")


_K_WEIGHTLESS = 0.3 / math.sqrt(1.0 - 0.3 ** 2)

#: The built-in problems, one per system (the figure's panels).
PROBLEMS: dict[str, Problem] = {p.name: p for p in (
    Problem("hinge_weightless", "hinge_pendulum",
            {"phi": 0.0, "omega": 5.0, "delta": 0.3, "g": 0.0}, 10.0,
            reference=_weightless_reference,
            # the tracer runs to phi(t_end) of (36), where the time integrators stop
            phi_range=(-1.0, math.log1p(_K_WEIGHTLESS * 5.0 * 10.0) / _K_WEIGHTLESS),
            description="weightless hinge pendulum, rotation, exact solution (36)"),
    Problem("hinge_pendulum", "hinge_pendulum", {"phi": 2.5, "omega": 0.0, "delta": 0.05},
            20.0, description="hinge pendulum with gravity: 12 reversals, then rest"),
    Problem("ladder", "ladder", {"phi": 0.3, "omega": 0.5, "f": 0.1}, 1.0,
            reference=_ladder_reference,
            description="ladder sliding down until the wall contact is lost; exact "
                        "omega^2(phi)"),
    Problem("wheel", "wheel", {"phi": 2.0, "omega": 0.0, "delta": 0.01}, 60.0,
            description="wheel with small rolling friction: 36 reversals, then rest"),
    Problem("elliptic_pendulum", "elliptic_pendulum",
            {"phi": 1.0, "omega": 0.0, "xdot": 0.5, "f": 0.3}, 10.0,
            description="elliptic pendulum: the slider sticks and slips repeatedly"),
)}


# ------------------------------------------------------------ the scipy driver
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


#: Reactions whose sign a slip stage assumes, per model: name -> sign on branch b.
_SIGNED_REACTIONS: dict[str, dict[str, Callable[[str], float]]] = {
    "ladder": {"N_floor": lambda b: 1.0, "N_wall": lambda b: 1.0},
    "wheel": {"N": lambda b: 1.0},
    "elliptic_pendulum": {"N": lambda b: 1.0 if b.endswith("Npos") else -1.0},
    "hinge_pendulum": {},
}
#: Models whose stick stage ends where |F| = f |N|: (N name, F name, friction parameter).
_STICK_LIMIT = {"elliptic_pendulum": ("N", "F", "f")}


class _Driver:
    """The per-problem preparation of :func:`solve_ivp_staged` (not timed)."""

    def __init__(self, model: str | Model, values: Mapping[str, float]):
        m = self.m = get_model(model)
        dyn = m.dynamics
        if dyn is None:
            raise ValueError(f"{m.name}: this model has no dynamics")
        if m.name not in _SIGNED_REACTIONS:
            raise ValueError(f"{m.name}: solve_ivp_staged knows the events of "
                             f"{', '.join(_SIGNED_REACTIONS)} only")
        full, positions = split_values(m, values)
        names = [v.name for v in integrated_variables(m)]
        self.y0 = np.array([positions[n] if n in positions else float(full[n]) for n in names])
        self.v = m.input_vector(full)
        self.full = full
        slot = {n: i for i, n in enumerate(m.inputs)}
        self.fill = [(i, slot[n]) for i, n in enumerate(names) if n in slot]
        self.ndof = len(dyn.coordinates)
        acc = [a.name for a in m.accelerations]
        self.acc_col = [nx.FIRST_ACC + acc.index(c[2]) for c in dyn.coordinates]
        self.vel = names.index(m.velocity)
        self.directions = m.directions
        self.out = np.empty((len(m.branches), m.n_fields))
        self.row = np.empty(m.n_fields)
        rea = [r.name for r in m.reactions]
        base = m.first_reaction
        self.signed = {b: [(base + rea.index(n), sgn(bname))
                           for n, sgn in _SIGNED_REACTIONS[m.name].items()]
                       for b, bname in enumerate(m.branches)}
        lim = _STICK_LIMIT.get(m.name)
        self.stick_limit = None if lim is None else (base + rea.index(lim[0]),
                                                     base + rea.index(lim[1]),
                                                     float(full[lim[2]]))
        self.key = None

    # -- the model, from Python ---------------------------------------------
    def set_state(self, y):
        v = self.v
        for i, s in self.fill:
            v[s] = y[i]
        self.m.derive(v)

    def branch_row(self, t, y, mode):
        """The row of branch ``mode`` at (t, y), cached on the last (t, y)."""
        key = (t, y.tobytes())
        if key != self.key:
            self.set_state(y)
            row = self.row
            for c in self.acc_col:
                row[c] = np.nan
            self.m.branch(self.v, mode, row)
            self.key = key
        return self.row

    def classify(self, y):
        """(n, first admissible branch, contact_lost, singular) at ``y``.

        A unique solution that leaves a contact (a separation) has no
        admissible branch: the branch is -1 and the motion ends there."""
        self.set_state(y)
        out = self.out
        self.m.point(self.v, out)
        n, _, lost, sing = nx.summarize(out, self.m.stick_branch)
        adm = -1
        for b in range(out.shape[0]):
            if out[b, nx.STATUS] == nx.ADMISSIBLE:
                adm = b
                break
        return int(n), adm, bool(lost), bool(sing)

    # -- one stage ------------------------------------------------------------
    def stage_functions(self, mode, y0):
        nd, cols, stick = self.ndof, self.acc_col, mode == self.m.stick_branch
        branch_row = self.branch_row
        if nd == 1:
            c0 = cols[0]

            def fun(t, y):
                return (y[1], branch_row(t, y, mode)[c0])
        elif nd == 2:
            c0, c1 = cols

            def fun(t, y):
                row = branch_row(t, y, mode)
                return (y[2], y[3], row[c0], row[c1])
        else:
            def fun(t, y):
                row = branch_row(t, y, mode)
                return tuple(y[nd:]) + tuple(row[c] for c in cols)

        events = []
        d = self.directions[mode]
        if d != 0.0:
            vel = self.vel

            def velocity(t, y):
                return d * y[vel]
            events.append(("velocity", velocity))
            for col, sgn in self.signed[mode]:
                def reaction(t, y, col=col, sgn=sgn):
                    return sgn * branch_row(t, y, mode)[col]
                events.append(("reaction", reaction))
        if not stick:
            self.set_state(y0)
            self.m.branch(self.v, mode, self.row)
            self.key = None
            c_sign = math.copysign(1.0, self.row[nx.COEF])

            def coefficient(t, y):
                return c_sign * branch_row(t, y, mode)[nx.COEF]
            events.append(("coefficient", coefficient))
        elif self.stick_limit is not None:
            cn, cf, f = self.stick_limit

            def margin(t, y):
                row = branch_row(t, y, mode)
                return f * abs(row[cn]) - abs(row[cf])
            events.append(("stick_limit", margin))
        for _, e in events:
            e.terminal = True
            e.direction = -1.0
        return fun, events

    def past_tie(self, fun, t, y, mode, here):
        """The state just past a tie at an event, and its classification.

        Probe along the stage for the first state that is decided (unique, on
        another branch) and bisect to it; without one, the first state off the
        stage (a genuine paradox); without that, the event state itself.
        """
        f0 = np.asarray(fun(t, y), dtype=float)

        def off(c):
            return not (c[0] == 1 and c[1] == mode)

        def decided(c):
            return c[0] == 1 and c[1] != mode

        def first(lo, hi, found, pred):
            for _ in range(60):  # the earliest dt in (lo, hi] with pred
                mid = 0.5 * (lo + hi)
                if mid in (lo, hi):
                    break
                probe = self.classify(y + mid * f0)
                if pred(probe):
                    hi, found = mid, probe
                else:
                    lo = mid
            return hi, found

        prev, first_off, chosen = 0.0, None, None
        for k in range(1, 10):
            dt = 10.0 ** k * 2.0 * _EPS * max(1.0, abs(t))
            found = self.classify(y + dt * f0)
            if off(found) and first_off is None:
                first_off = (prev, dt, found)
            if decided(found):
                chosen = first(prev, dt, found, decided)
                break
            prev = dt
        if chosen is None and first_off is not None:
            chosen = first(*first_off, off)
        if chosen is None:
            return t, y, here
        dt, found = chosen
        return t + dt, y + dt * f0, found

    def run(self, method: str, rtol: float, atol: float, t_end: float, t_eval: np.ndarray,
            dense: bool = False, max_events: int = 10_000, h_max: float = math.inf) -> Staged:
        from scipy.integrate import solve_ivp

        m, dyn = self.m, self.m.dynamics
        stick = m.stick_branch
        y = self.y0.copy()
        t = 0.0
        te = np.asarray(t_eval, dtype=float)
        sentinel = te.size == 0 or te[-1] < t_end  # t_end is always evaluated, for y_final
        if sentinel:
            te = np.append(te, t_end)
        ts, ys = [], []
        n_rev = nfev = 0
        events, stages = [], []
        n, mode, lost, sing = self.classify(y)
        fate = None
        if n == 1 and mode < 0:  # the unique solution leaves a contact
            fate = ev.CONTACT_LOST
        elif n != 1:
            fate = int(ev.fate_without_unique(n, lost, sing))
            mode = -1
        elif mode == stick and dyn.stick_is_rest:
            fate = ev.REST
        if fate is None:
            events.append((t, "start", mode, y.copy()))
        i_eval = 0
        while fate is None:
            fun, evs = self.stage_functions(mode, y)
            sub = te[i_eval:]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # rtol near 100 eps; LSODA's own notes
                sol = solve_ivp(fun, (t, t_end), y, method=method, rtol=rtol, atol=atol,
                                t_eval=sub, events=[e for _, e in evs], dense_output=dense,
                                max_step=h_max)
            nfev += sol.nfev
            if sol.t.size:
                ts.append(sol.t)
                ys.append(sol.y.T)
                i_eval += sol.t.size
            if sol.status == -1:
                fate = ev.STEP_FAILURE
                t, y = float(sol.t[-1]) if sol.t.size else t, (
                    np.array(sol.y[:, -1]) if sol.t.size else y)
                break
            if sol.status == 0:  # reached t_end on this stage
                if dense:
                    stages.append((t, t_end, mode, sol.sol))
                t, y = t_end, np.array(sol.y[:, -1], dtype=float)
                fate = ev.HORIZON
                break
            # the terminal event that ended the stage: the latest recorded one
            which, t_ev = max(((j, x[-1]) for j, x in enumerate(sol.t_events) if x.size),
                              key=lambda p: p[1])
            if dense:
                stages.append((t, float(t_ev), mode, sol.sol))
            name = evs[which][0]
            t, y = float(t_ev), np.array(sol.y_events[which][-1], dtype=float)
            d = self.directions[mode]
            vel_zero = name == "velocity"
            if vel_zero:
                y[self.vel] = 0.0
            n, adm, lost, sing = self.classify(y)
            if not vel_zero and n == 1 and adm == mode:
                t, y, (n, adm, lost, sing) = self.past_tie(fun, t, y, mode, (n, adm, lost, sing))
            new_mode = -1
            if n == 1 and adm < 0:
                kind = ev.CONTACT_LOST  # the unique solution leaves a contact
            elif n == 1:
                new_mode = adm
                if adm == mode and not vel_zero:
                    kind, new_mode = ev.STEP_FAILURE, -1  # an event the model does not see
                elif adm == stick:
                    kind = ev.REST if dyn.stick_is_rest else ev.STICK
                elif mode == stick:
                    kind = ev.SLIP
                elif self.directions[adm] == -d:
                    kind = ev.REVERSAL
                    n_rev += 1
                else:
                    kind = ev.SWITCH
            else:
                kind = int(ev.fate_without_unique(n, lost, sing))
            if kind == ev.REST or new_mode < 0:
                fate = kind
                break
            if len(events) >= max_events:
                fate = ev.MAX_EVENTS
                break
            events.append((t, ev.Event(kind).name.lower(), new_mode, y.copy()))
            mode = new_mode
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
    equations, rest, stick, reversal and the fates decided by the model's
    classification; see the module docstring), solved by ``solve_ivp`` with
    ``method`` on each stage.  Returns a :class:`Staged`: the states at
    ``t_eval`` (default: t_end only) that the motion reached, the end state,
    the fate and the events.
    """
    m = get_model(model)
    opts = Options(t_end, rtol, atol).checked(m.name)
    te = np.array([opts.t_end]) if t_eval is None else np.asarray(t_eval, dtype=float)
    driver = _Driver(m, values)
    return driver.run(method, opts.rtol, opts.atol, opts.t_end, te, dense=dense_output,
                      max_events=max_events)


# --------------------------------------------------------------- references
def tight_reference(problem: Problem, rtol: float = TIGHT) -> Reference:
    """A much tighter solution: the scipy driver with DOP853 at ``rtol``, cross-checked.

    The reference states are the DOP853 solution's (dense output, stage by
    stage).  Its ``floor``, the uncertainty below which errors are not
    resolved, is the largest difference over the saved points and the end
    state from DOP853 at ``10 rtol`` (DOP853 converges with order 8, so this
    bounds the error of the reference generously).  It is cross-checked
    against the numba integrator at ``rtol``: ``cross_check`` is the largest
    difference.  A different fate or number of reversals among the three
    raises RuntimeError: the reference would be meaningless.
    """
    p = problem
    driver = _Driver(p.model, p.values)
    dop = driver.run("DOP853", rtol, rtol, p.t_end, p.t_save, dense=True)
    loose = driver.run("DOP853", 10.0 * rtol, 10.0 * rtol, p.t_end, p.t_save)
    pm = _kernel_run(p, rtol)()
    pm_end = dict(fate=ev.Event(int(pm[0])).name.lower(), n_reversals=int(pm[3]))
    for who, other in (("DOP853 at 10 rtol", dict(fate=loose.fate,
                                                  n_reversals=loose.n_reversals)),
                       ("phasemap", pm_end)):
        if other != dict(fate=dop.fate, n_reversals=dop.n_reversals):
            raise RuntimeError(f"{p.name}: the tight references disagree: DOP853 ends with "
                               f"{dop.fate} after {dop.n_reversals} reversals, {who} with "
                               f"{other['fate']} after {other['n_reversals']}")

    def gap(t_other, y_other, end_other):
        k = min(len(dop.t), len(t_other))
        return max(float(np.max(np.abs(dop.y[:k] - y_other[:k]), initial=0.0)),
                   float(np.max(np.abs(dop.y_final - end_other))))

    floor = gap(loose.t, loose.y, loose.y_final)
    cross = gap(p.t_save[:len(pm[7])], pm[7], pm[2])
    stages = dop.stages
    starts = np.array([s[0] for s in stages])
    t_stop, y_stop, fate = dop.t_final, dop.y_final, dop.fate

    def states(t, y=None):
        t = np.asarray(t, dtype=float)
        out = np.full((t.size, y_stop.size), np.nan)
        for i, ti in enumerate(t):
            if ti >= t_stop:
                if fate in ("rest", "horizon") and ti <= p.t_end:
                    out[i] = y_stop
                continue
            k = max(0, int(np.searchsorted(starts, ti, side="right")) - 1)
            out[i] = stages[k][3](ti)
        return out

    omega = None
    if driver.ndof == 1:
        def omega(phi, stage):
            phi = np.asarray(phi, dtype=float)
            stage = np.asarray(stage, dtype=int)
            res = np.full(phi.shape, np.nan)
            for k in np.unique(stage):
                if not 0 <= k < len(stages):
                    continue
                sel = stage == k
                t0, t1, _, sol = stages[k]
                sign = math.copysign(1.0, sol(0.5 * (t0 + t1))[0] - sol(t0)[0])
                target = phi[sel]
                lo = np.full(target.shape, t0)
                hi = np.full(target.shape, t1)
                for _ in range(64):  # bisection in t: phi is monotone on a stage
                    mid = 0.5 * (lo + hi)
                    past = sign * (sol(mid)[0] - target) > 0.0
                    hi = np.where(past, mid, hi)
                    lo = np.where(past, lo, mid)
                w = sol(0.5 * (lo + hi))[1]
                if k == len(stages) - 1 and fate == "rest":
                    w = np.where(sign * (target - y_stop[0]) >= 0.0, 0.0, w)
                res[sel] = w
            return res

    return Reference(f"DOP853 at rtol {rtol:g}", states, y_stop, fate, dop.n_reversals,
                     omega, floor=floor, cross_check=cross,
                     note=f"DOP853 at {rtol:g} differs from DOP853 at {10 * rtol:g} by "
                          f"{floor:.1e} and from phasemap at {rtol:g} by {cross:.1e}")


# ------------------------------------------------------------------ runners
def _kernel_run(p: Problem, tol: float, method: str = "DOPRI5"):
    """A zero-argument call of the jitted integrator, prepared as simulate() prepares it."""
    m = get_model(p.model)
    integrate, _ = kernels(m, method)
    full, positions = split_values(m, p.values)
    names = [v.name for v in integrated_variables(m)]
    y0 = np.array([positions[n] if n in positions else float(full[n]) for n in names])
    v = m.input_vector(full)
    te = p.t_save
    t_end = float(p.t_end)
    opts = Options(t_end, tol).checked(m.name)

    def go():
        return integrate(v, y0, t_end, opts.rtol, opts.atol, opts.max_step, opts.max_steps,
                         opts.max_events, False, te)
    return go


def _time_errors(ref: Reference, t, y, y_end):
    """(error_final, error_l2) of a run saved at times ``t``."""
    y = np.asarray(y, dtype=float)
    final = float(np.max(np.abs(np.asarray(y_end, dtype=float) - ref.end)))
    if len(t) == 0:
        return final, math.nan
    y_ref = ref.states(np.asarray(t, dtype=float), y)
    comps = list(ref.components) if ref.components is not None else slice(None)
    diff = (y - y_ref)[:, comps]
    return final, float(np.sqrt(np.mean(diff ** 2)))


def _methods_for(p: Problem, methods):
    m = get_model(p.model)
    keep = []
    for method in methods:
        if method == "phase_curve":
            if len(m.dynamics.coordinates) != 1:  # phase curves of 1-DOF models only
                continue
        elif method not in (*PHASEMAP_METHODS, "simulate") + SCIPY_METHODS:
            raise ValueError(f"unknown method {method!r}; choose from "
                             f"{', '.join(DEFAULT_METHODS)}")
        keep.append(method)
    return keep


def _job(p: Problem, ref: Reference, method: str, tol: float):
    """(go, measure): a timed zero-argument call and the measurement of its result."""
    if method in PHASEMAP_METHODS:
        go = _kernel_run(p, tol, PHASEMAP_METHODS[method])

        def measure(r):
            fe, l2 = _time_errors(ref, p.t_save[:len(r[7])], r[7], r[2])
            return dict(error_final=fe, error_l2=l2, fate=ev.Event(int(r[0])).name.lower(),
                        n_reversals=int(r[3]), n_steps=int(r[4]), nfev=math.nan)
    elif method == "simulate":
        values = dict(p.values)

        def go():
            return simulate(p.model, p.t_end, rtol=tol, t_eval=p.t_save, **values)

        def measure(ds):
            names = [v.name for v in integrated_variables(get_model(p.model))]
            y = np.column_stack([ds[n].values for n in names])
            y_end = np.array([float(ds[f"event_{n}"][-1]) for n in names])
            fe, l2 = _time_errors(ref, ds.t.values, y, y_end)
            return dict(error_final=fe, error_l2=l2, fate=ds.attrs["end_reason"],
                        n_reversals=int(ds.attrs["n_reversals"]),
                        n_steps=int(ds.attrs["n_steps"]), nfev=math.nan)
    elif method in SCIPY_METHODS:
        driver = _Driver(p.model, p.values)
        te = p.t_save

        def go():
            return driver.run(method, tol, tol, float(p.t_end), te)

        def measure(r):
            fe, l2 = _time_errors(ref, r.t, r.y, r.y_final)
            return dict(error_final=fe, error_l2=l2, fate=r.fate, n_reversals=r.n_reversals,
                        n_steps=math.nan, nfev=int(r.nfev))
    elif method == "phase_curve":
        from .phase import phase_curve

        m = get_model(p.model)
        full = m.complete({k: v for k, v in p.values.items()})
        params = {v.name: float(full[v.name]) for v in m.params}
        kw = {} if p.phi_range is None else {"phi_range": p.phi_range}

        def go():
            return phase_curve(m, phi=float(full["phi"]), omega=float(full["omega"]),
                               **kw, **params)

        def measure(ds):
            phi, omega = ds.phi.values, ds.omega.values
            w_ref = ref.omega(phi, ds.point_stage.values) if ref.omega else np.nan * phi
            end = np.array([float(ds.stage_end_phi[-1]), float(ds.stage_end_omega[-1])])
            return dict(error_final=float(np.max(np.abs(end - ref.end))),
                        error_l2=float(np.sqrt(np.mean((omega - w_ref) ** 2))),
                        fate=ds.attrs["end_reason"], n_reversals=int(ds.attrs["n_reversals"]),
                        n_steps=math.nan, nfev=math.nan)
    else:
        raise ValueError(f"unknown method {method!r}")
    return go, measure


def _sample(go, min_time: float) -> float:
    """Seconds per call: ``go`` repeated until ``min_time`` has passed."""
    count = 0
    start = time.perf_counter()
    while True:
        go()
        count += 1
        elapsed = time.perf_counter() - start
        if elapsed >= min_time:
            return elapsed / count


def work_precision(problem: Problem | str, tolerances: Sequence[float] = DEFAULT_TOLERANCES,
                   methods: Sequence[str] = DEFAULT_METHODS, repeats: int = 3, *,
                   min_time: float = 0.02, budget: float = 10.0, slow: float = 1.0,
                   reference: Reference | None = None,
                   progress: Callable[[str], None] | None = None) -> list[dict]:
    """Error against run time of every method at every tolerance on one problem.

    Parameters
    ----------
    problem:
        a :class:`Problem` or the name of a built-in one (:data:`PROBLEMS`).
    tolerances:
        rtol = atol of each run (the phase-curve tracer runs once).
    methods:
        any of :data:`DEFAULT_METHODS` (see the module docstring).
    repeats:
        timing rounds; each round alternates the methods tolerance by tolerance
        and the reported time is the median.  A run that took more than
        ``slow`` seconds is timed once.
    min_time:
        a fast run is repeated until one sample lasts this long.
    budget:
        a method whose run exceeds this many seconds skips tighter tolerances.
    reference:
        the reference to use (default: ``problem.resolve()``).
    progress:
        called with a line of text as the sweep goes.

    Returns
    -------
    list of dict
        one per (method, tolerance): ``system`` (the problem's name),
        ``model``, ``method``, ``tol``, ``error_final``, ``error_l2``,
        ``seconds`` (median per trajectory), ``seconds_min`` and
        ``seconds_max`` (the spread of the ``n_samples`` rounds), ``fate``, ``n_reversals``,
        ``same_fate`` (fate and reversal count equal the reference's),
        ``n_steps`` (phasemap), ``nfev`` (scipy), ``skipped`` and the
        reference's ``reference`` kind, ``floor`` and ``cross_check``.
    """
    p = PROBLEMS[problem] if isinstance(problem, str) else problem
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be a positive integer, got {repeats!r}")
    tols = [float(t) for t in tolerances]
    for t in tols:
        if not 1e-14 <= t <= 0.1:
            raise ValueError(f"tolerances must lie in [1e-14, 0.1], got {t!r}")
    ref = reference if reference is not None else p.resolve()
    say = progress or (lambda text: None)
    methods = _methods_for(p, methods)
    jobs: dict[tuple[str, float], dict] = {}
    for method in methods:
        over = False
        for tol in ([math.nan] if method == "phase_curve" else sorted(tols, reverse=True)):
            row = dict(system=p.name, model=p.model, method=method, tol=tol,
                       reference=ref.kind, floor=ref.floor, cross_check=ref.cross_check)
            if over:
                jobs[(method, tol)] = dict(row, error_final=math.nan, error_l2=math.nan,
                                           seconds=math.nan, seconds_min=math.nan,
                                           seconds_max=math.nan, n_samples=0,
                                           fate="", n_reversals=-1,
                                           same_fate=False, n_steps=math.nan,
                                           nfev=math.nan, skipped=True)
                continue
            go, measure = _job(p, ref, method, tol)
            start = time.perf_counter()
            result = go()  # warm-up (JIT, caches) and the errors
            took = time.perf_counter() - start
            row.update(measure(result))
            # a slow scipy run (no JIT to warm) counts its first run as its one sample
            first = [took] if method in SCIPY_METHODS and took > slow else []
            row.update(same_fate=row["fate"] == ref.fate
                       and row["n_reversals"] == ref.n_reversals,
                       skipped=False, _go=go, _took=took, _samples=first)
            jobs[(method, tol)] = row
            over = took > budget
            say(f"{p.name:18s} {method:11s} tol {tol:7.0e}  error {row['error_final']:.2e}  "
                f"{took:.4f} s  {row['fate']}")
    for r in range(repeats):
        gc.collect()
        for tol in [math.nan] + sorted(tols, reverse=True):
            for method in methods:
                row = jobs.get((method, tol))
                if row is None or row["skipped"]:
                    continue
                if row["_took"] > slow and row["_samples"]:
                    continue
                row["_samples"].append(_sample(row["_go"], min_time))
    rows = []
    for row in jobs.values():
        if not row["skipped"]:
            samples = row.pop("_samples")
            row["seconds"] = float(statistics.median(samples))
            row["seconds_min"], row["seconds_max"] = float(min(samples)), float(max(samples))
            row["n_samples"] = len(samples)
            row.pop("_go")
            row.pop("_took")
        rows.append(row)
    return rows


# ------------------------------------------------------------------ summaries
def _front(rows, system, method, error):
    pts = sorted((r["seconds"], r[error]) for r in rows
                 if r["system"] == system and r["method"] == method and not r["skipped"]
                 and math.isfinite(r["seconds"]) and math.isfinite(r[error])
                 and r["seconds"] > 0)
    front, best = [], math.inf
    for sec, err in pts:
        if err < best:
            front.append((sec, max(err, 1e-300)))
            best = err
    return front


def time_at_error(rows: Sequence[Mapping], system: str, method: str, level: float,
                  error: str = "error_final") -> float:
    """Seconds per trajectory ``method`` needs for an error <= ``level`` on ``system``.

    Log-log interpolation on the method's Pareto front (its runs that no faster
    run beats in error); the time of its fastest run when that already meets
    ``level``; NaN when no run reaches it.
    """
    front = _front(rows, system, method, error)
    if not front or level < front[-1][1]:
        return math.nan
    if level >= front[0][1]:
        return front[0][0]
    for (s0, e0), (s1, e1) in zip(front, front[1:]):
        if e1 <= level <= e0:
            if e0 == e1:
                return s1
            w = math.log(level / e0) / math.log(e1 / e0)
            return math.exp(math.log(s0) + w * math.log(s1 / s0))
    return math.nan


def equal_error_ratio(rows: Sequence[Mapping], system: str, level: float,
                      method: str | Sequence[str] = "phasemap",
                      against: Sequence[str] = SCIPY_METHODS,
                      error: str = "error_final") -> tuple[float, str]:
    """(time of the fastest of ``against`` / time of ``method``, that method) at ``level``.

    ``method`` may be several methods: the fastest of them at ``level`` counts.
    """
    ours = [method] if isinstance(method, str) else list(method)
    mine = min((time_at_error(rows, system, m, level, error) for m in ours),
               key=lambda t: t if math.isfinite(t) else math.inf)
    theirs = [(time_at_error(rows, system, m, level, error), m) for m in against]
    theirs = [(t, m) for t, m in theirs if math.isfinite(t)]
    if not theirs or not math.isfinite(mine):
        return math.nan, ""
    best, name = min(theirs)
    return best / mine, name


def _fmt_time(sec: float) -> str:
    if not math.isfinite(sec):
        return "-"
    if sec >= 1.0:
        return f"{sec:.2f} s"
    if sec >= 1e-3:
        return f"{sec * 1e3:.3g} ms"
    return f"{sec * 1e6:.3g} us"


def report(rows: Sequence[Mapping], levels: Sequence[float] = (1e-3, 1e-5, 1e-7, 1e-9, 1e-11),
           error: str = "error_final",
           method: str | Sequence[str] = tuple(PHASEMAP_METHODS)) -> str:
    """A markdown table: run time per trajectory needed for each error level, per method.

    One block per system: a line per method (its smallest error, and whether
    every run ended like the reference), then for each of ``method`` that ran
    the ratio of the fastest solve_ivp method's time to its time at equal
    error, and, when several ran, the same for the fastest of them at each
    level.  Levels below ten times the reference's floor are shown as
    ``(floor)``.
    """
    ours = [method] if isinstance(method, str) else list(method)
    systems = list(dict.fromkeys(r["system"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    head = " | ".join(f"err <= {lv:.0e}" for lv in levels)
    lines = [f"| system | method | {head} | smallest error | fates as reference |",
             "|---|---|" + "---:|" * len(levels) + "---:|---|"]
    for system in systems:
        mine = [r for r in rows if r["system"] == system]
        floor = max((r.get("floor", 0.0) for r in mine), default=0.0)
        for m in methods:
            runs = [r for r in mine if r["method"] == m and not r["skipped"]]
            if not runs:
                continue
            cells = [_fmt_time(time_at_error(rows, system, m, lv, error)) for lv in levels]
            errs = [r[error] for r in runs if math.isfinite(r[error])]
            smallest = f"{min(errs):.1e}" if errs else "-"
            same = sum(bool(r["same_fate"]) for r in runs)
            lines.append(f"| {system} | {m} | " + " | ".join(cells)
                         + f" | {smallest} | {same}/{len(runs)} |")
        ran = [m for m in ours if any(r["method"] == m and not r["skipped"] for r in mine)]
        groups = [(m, [m]) for m in ran]
        if len(ran) > 1:
            groups.append((f"best of {', '.join(ran)}", ran))
        for label, group in groups:
            cells = []
            for lv in levels:
                if lv < 10.0 * floor:
                    cells.append("(floor)")
                    continue
                ratio, who = equal_error_ratio(rows, system, lv, group, SCIPY_METHODS, error)
                cells.append(f"**{ratio:.0f}x** ({who})" if math.isfinite(ratio) else "-")
            lines.append(f"| {system} | {label} speed-up over best solve_ivp | "
                         + " | ".join(cells) + f" | floor {floor:.0e} | |")
    return "\n".join(lines)
