"""The work-precision problems, one per system, and what a run is measured against.

A :class:`Problem` is a model, an initial state, a horizon and a
:class:`Reference`: a closed form in time (the weightless hinge pendulum, eq.
(36)), a first integral (the ladder's omega^2(phi)) or a much tighter solution
(:func:`tight_reference`).  :data:`PROBLEMS` holds the built-in ones (the
figure's panels).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from phasemap.core import events as ev
from phasemap.motion.integrate import NO_STOP, kernels
from phasemap.systems import get_model
from phasemap.systems import hinge_pendulum as _hinge
from phasemap.systems.seeds.closed_forms import ladder_omega_squared
from phasemap.motion.simulate import Options, integrated_variables, split_values
from phasemap.motion.workprecision.staged import StageDriver

#: Tolerance of the tight references.
TIGHT = 1e-13

_EPS = np.finfo(float).eps


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
        the reference's own uncertainty (0 for a closed form), in the states' units
        (the largest over components); ``floor_scaled`` the same with each
        component divided by its scale (what the scaled errors compare with).
    ``cross_check``
        the largest difference from an independent solution (tight references).
    ``scales``
        the scale of each state component (in its unit) that makes the error
        dimensionless: the largest magnitude the component reaches along the
        reference motion (:func:`peak_scales`).  The scaled errors of
        :func:`phasemap.motion.workprecision.work_precision` divide each component's
        error by it.
    """

    kind: str
    states: Callable[[np.ndarray, np.ndarray], np.ndarray]
    end: np.ndarray
    fate: str
    n_reversals: int
    omega: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    components: tuple[int, ...] | None = None
    floor: float = 0.0
    floor_scaled: float = 0.0
    cross_check: float = 0.0
    note: str = ""
    scales: tuple[float, ...] | None = None


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


def peak_scales(states: np.ndarray) -> tuple[float, ...]:
    """The largest magnitude of each component over ``states`` (n, ny), NaN ignored.

    A component that stays zero (to within 1e-300) gets the scale 1 in its own unit,
    so that its error is still counted rather than divided by zero.

    >>> peak_scales(np.array([[0.0, 5.0], [8.5, -0.5], [np.nan, 1.0]]))
    (8.5, 5.0)
    """
    peak = np.nanmax(np.abs(np.asarray(states, dtype=float)), axis=0)
    return tuple(float(x) if x > 1e-300 else 1.0 for x in peak)


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
                     "horizon", 0, omega, scales=peak_scales(states(p.t_save, None)))


def _ladder_reference(p: Problem) -> Reference:
    """omega^2(phi) of the ladder's stage in closed form; the exact contact-loss state."""
    from scipy.optimize import brentq

    m = get_model("ladder")
    full = m.complete(dict(p.values))
    phi0, omega0, f, l, g = (float(full[n]) for n in ("phi", "omega", "f", "l", "g"))
    s = 1.0 if omega0 > 0 else -1.0

    def omega(phi, stage=None):
        phi = np.asarray(phi, dtype=float)
        u = np.array([ladder_omega_squared(x, phi0, omega0, f, l, g) for x in phi.ravel()])
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

    # the motion runs from phi0 to the contact loss
    path = np.linspace(phi0, phi_c, 1001)
    scales = peak_scales(np.column_stack([path, omega(path)]))
    return Reference("first integral omega^2(phi)", states, end, "contact_lost", 0, omega,
                     components=(1,), note="omega compared at each method's own phi",
                     scales=scales)


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
    driver = StageDriver(p.model, p.values)
    dop = driver.run("DOP853", rtol, rtol, p.t_end, p.t_save, dense=True)
    loose = driver.run("DOP853", 10.0 * rtol, 10.0 * rtol, p.t_end, p.t_save)
    pm = kernel_run(p, rtol)()
    pm_end = dict(fate=ev.Event(int(pm[0])).name.lower(), n_reversals=int(pm[3]))
    for who, other in (("DOP853 at 10 rtol", dict(fate=loose.fate,
                                                  n_reversals=loose.n_reversals)),
                       ("phasemap", pm_end)):
        if other != dict(fate=dop.fate, n_reversals=dop.n_reversals):
            raise RuntimeError(f"{p.name}: the tight references disagree: DOP853 ends with "
                               f"{dop.fate} after {dop.n_reversals} reversals, {who} with "
                               f"{other['fate']} after {other['n_reversals']}")

    scales = peak_scales(np.vstack([dop.y, dop.y_final[None, :]]))

    def gap(t_other, y_other, end_other, unit=1.0):
        k = min(len(dop.t), len(t_other))
        return max(float(np.max(np.abs(dop.y[:k] - y_other[:k]) / unit, initial=0.0)),
                   float(np.max(np.abs(dop.y_final - end_other) / unit)))

    floor = gap(loose.t, loose.y, loose.y_final)
    floor_scaled = gap(loose.t, loose.y, loose.y_final, np.asarray(scales))
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
                     omega, floor=floor, floor_scaled=floor_scaled, cross_check=cross,
                     scales=scales,
                     note=f"DOP853 at {rtol:g} differs from DOP853 at {10 * rtol:g} by "
                          f"{floor:.1e} and from phasemap at {rtol:g} by {cross:.1e}")


def kernel_run(p: Problem, tol: float, method: str = "DOPRI5"):
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
                         opts.max_events, False, te, NO_STOP)
    return go
