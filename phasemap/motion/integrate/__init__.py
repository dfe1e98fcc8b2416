r"""The time integrator: Dormand-Prince 5(4) or 8(5,3) with exact set-valued friction.

One jitted integrator per model, specialised from the templates below with
the model's ``point``, ``branch`` and ``derive`` functions (see
:class:`phasemap.Dynamics`).  It is what :func:`phasemap.simulate` and the
fate maps run.

Method
------
* **Stages.**  A motion is a sequence of stages.  On a stage one branch of the
  friction law is active (slip in a direction with an assumed sign of N, or
  stick), and the right-hand side is that branch's accelerations, a smooth
  function of the state: ``branch(v, b, row)`` keeps the stage's slip
  direction even at trial points past a velocity zero.
* **Steps.**  Explicit Runge-Kutta of Dormand and Prince (:data:`METHODS`):
  ``DOPRI5`` (the default), order 5 with an embedded order-4 error estimate
  and Hairer's order-4 continuous extension (:mod:`phasemap.motion.integrate.dopri5`; the
  coefficients of Hairer's ``dopri5`` and scipy's ``RK45``), or ``DOP853``,
  order 8 with dop853's combined order-5/order-3 error estimate and its
  order-7 continuous extension (:mod:`phasemap.motion.integrate.dop853`; Hairer's ``dop853``
  and scipy's ``DOP853``), for tight tolerances.  Both are
  first-same-as-last, with an RMS error norm over ``atol + rtol |y|`` and the
  standard step-size controller.
* **Events by classification.**  After every accepted step the end state is
  classified with the model's own rows, exactly as :func:`phasemap.classify`
  does.  The stage goes on while the classification is *unique and equal to
  the active branch* (and the branch's coefficient of the senior derivative
  keeps its sign); after a step the integrator reads only that decision,
  from the statuses of the rows that apply and the stage's coefficient
  (``GOES_ON`` in :mod:`phasemap.motion.integrate.templates`), and events classify
  every row.  Where the slip velocity's rate turns from against the slip to along it
  inside a step, the velocity's minimum there is found on the dense output (``DIP``):
  one at rest speed is a velocity zero that neither end of the step shows (a stop or a
  pair of reversals inside the step), and ends the stage as one at its end would.
  Otherwise the first state where it
  stops being so is located by bisection on the dense output, to the
  resolution of double precision in t, and classified there: a velocity zero
  (then rest, stick or reversal, with the velocity set to exactly 0), a sign
  change of a two-sided reaction (switch), a stick that can no longer hold
  (slip), contact loss, or a state with no solution, two solutions or a
  continuum, where the motion stops and says so.  There is no smoothing of
  the friction law, and no branch is ever chosen where the equations leave a
  choice.
* **Stick is exact.**  On the elliptic pendulum's stick stage the slider's
  acceleration is exactly zero, so its velocity stays exactly 0: no creep.

A motion that leaves the model's domain (a state variable beyond its bounds,
such as the ladder's phi past 0 or pi/2) ends with ``left_domain`` at the
boundary; running out of ``max_steps`` ends it with ``max_steps``.  Where the
step size collapses because the stage's own branch has no solution just
ahead (the hinge pendulum with delta > l leaving the curve l omega^2 + g cos
phi = 0), the motion ends with the classification found there
(``no_solution``), not ``step_failure``.
A state the integrator cannot resolve (the step size falls below double
precision, which happens as a coefficient of the senior derivative approaches
zero and the accelerations grow without bound) ends the motion with
``singular`` (when the active coefficient has fallen below 1e-6 of its
largest value at a stage start of the motion) or ``step_failure``.

Layout: :mod:`phasemap.motion.integrate.templates` holds the integrator's numba
templates (its named pieces); this module compiles them per model and method
(:func:`kernels`) and runs fate maps over grids of initial conditions.
"""

from __future__ import annotations

import threading
from typing import NamedTuple

import numpy as np
from numba import njit, prange
from numba import types as nb_types
from numba.extending import intrinsic

from phasemap.core import calls, tiers
from phasemap.core.memo import Memo
from phasemap.motion.integrate import dop853 as _dop853
from phasemap.motion.integrate import dopri5 as _dopri5
from phasemap.core import numerics as nx
from phasemap.core import events as ev
from phasemap.core.codegen import moving_test, set_cell
from phasemap.core.types import F1, F2, F3, I1, I2
from phasemap.core.compile import contract_constants, grow, remember, specialize
from phasemap.core.codegen import pack_axes
from phasemap.core.model import Model
from phasemap.motion.integrate import templates as tp

#: The integrator's pieces that allocate arrays (or return one), compiled with numba's
#: reference counts; the others without (``specialize(counts=False)``).
COUNTED = ("INTEGRATE",)
#: The methods by name (``simulate(method=...)``, the fate layers' ``method`` option).
METHODS = {m.NAME: m for m in (_dopri5, _dop853)}
#: The default method.
DEFAULT_METHOD = _dopri5.NAME
#: Cells per work unit of a fate map; units interleave over the grid to balance threads.
FATE_UNITS = 1024


def unpack(points, events):
    """The columns of an integrator's ``points`` and ``events`` (see
    ``phasemap.motion.integrate.templates._integrate_template``): ``(ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode)``."""
    return (points[:, 0], points[:, 2:], points[:, 1], events[:, 0], events[:, 1],
            events[:, 3:], events[:, 2])


def _fate_drive(integrate_at, y_slot, base, shape, axis_slot, axis_values, deriv_slot,
                deriv_values, y0_fixed, t_end, rtol, atol, h_max, max_steps, max_events,
                pos_col, fate, n_rev, t_final, pos_rest, stop):
    """Integrate from every cell of a grid of initial conditions; record how each ends.

    ``stop`` (one int64), set nonzero by another thread, ends the work within a step
    (:func:`run_stoppable`); the cells not done are left as they were.

    ``integrate_at`` is the address of a model's integrator (:mod:`phasemap.core.calls`),
    so that this parallel driver compiles once for every model and method (and
    numba's parfor lowering does not re-optimise the integrator inside it).
    Work units interleave over the grid (unit u takes cells u, u + U, ...), so
    that both threads see the same mix of quick and slow cells.
    """
    ndim = shape.shape[0]
    ncells = 1
    for d in range(ndim):
        ncells *= shape[d]
    units = min(FATE_UNITS, ncells)
    no_eval = np.empty(0)
    for u in prange(units):
        v = base.copy()
        y0 = y0_fixed.copy()
        for q in range((ncells - u + units - 1) // units):
            if stop[0] != 0:
                break
            cell = u + q * units
            # every cell starts from the scene's inputs: the integrator writes the state
            # it reaches into v, and a state variable that is not an axis (a fixed
            # omega) would otherwise start the next cell where the last one ended
            for i in range(v.shape[0]):
                v[i] = base[i]
            set_cell(v, cell, shape, axis_slot, axis_values, deriv_slot, deriv_values)
            for i in range(y_slot.shape[0]):
                if y_slot[i] >= 0:
                    y0[i] = v[y_slot[i]]
            res = call_integrate(integrate_at, v, y0, t_end, rtol, atol, h_max, max_steps,
                                 max_events, False, no_eval, stop)
            fate[cell] = res.fate
            n_rev[cell] = res.n_reversals
            t_final[cell] = res.t
            for j in range(pos_col.shape[0]):
                pos_rest[j, cell] = res.y[pos_col[j]] if res.fate == ev.REST else np.nan


#: The argument types of every integrator (see templates._integrate_template).
INTEGRATE_ARGS = (F1, F1, nb_types.float64, nb_types.float64, nb_types.float64,
                  nb_types.float64, nb_types.int64, nb_types.int64, nb_types.boolean, F1, I1)
#: The ``stop`` of a motion nothing stops (simulate's: a Ctrl-C there ends the call between
#: its compiled pieces).
NO_STOP = np.zeros(1, dtype=np.int64)
#: What every integrator returns (a :data:`phasemap.motion.integrate.templates.Integrated`;
#: ``motion.hybrid.Motion`` is the engine of a motion through contact changes).
INTEGRATED = nb_types.NamedTuple((nb_types.int64, nb_types.float64, F1, nb_types.int64,
                              nb_types.int64, F2, F2, F2), tp.Integrated)
#: Every integrator's signature.
INTEGRATE_SIGNATURE = INTEGRATED(*INTEGRATE_ARGS)


@intrinsic
def call_integrate(typingctx, at, v, y0, t_end, rtol, atol, h_max, max_steps, max_events,
                   save, t_eval, stop):
    """A model's integrator (:data:`INTEGRATE_SIGNATURE`) at its compiled address ``at``."""
    return calls.typer(INTEGRATE_SIGNATURE, at, (v, y0, t_end, rtol, atol, h_max, max_steps,
                                                 max_events, save, t_eval, stop))


_DRIVERS = Memo("integrate.drivers")


def _fate_driver():
    """The parallel fate driver of every integrator (compiled once, cached on disk)."""

    def make():
        fsig = nb_types.void(nb_types.intp, I1, F1, I1, I1, F2, I2, F3, F1,
                             nb_types.float64, nb_types.float64, nb_types.float64,
                             nb_types.float64, nb_types.int64, nb_types.int64, I1,
                             nb_types.Array(nb_types.int8, 1, "C"),
                             nb_types.Array(nb_types.int32, 1, "C"), F1, F2, I1)
        # nogil: it runs in a thread of its own while the main thread waits for a signal
        return njit(fsig, parallel=True, nogil=True, cache=True,
                    error_model="numpy")(_fate_drive)

    return _DRIVERS.get((), ("fate",), make)


def _batch_drive(integrate_at, y_slot, v, y0s, t_end, rtol, atol, h_max, max_steps, max_events,
                 save, t_eval, stop):
    """Integrate from every row of ``y0s`` (one compiled call for a sweep of starts).

    Returns ``(head, points, point_end, events, event_end, y_eval, eval_end)``:
    ``head`` one row (fate, t, n_reversals, n_steps) per start; the rows of
    start i of ``points``, ``events`` and ``y_eval`` (see
    ``templates._integrate_template``) are those before ``*_end[i]`` and from
    ``*_end[i - 1]`` on, stacked start after start.
    """
    n, ny = y0s.shape
    head = np.empty((n, 4))
    point_end = np.empty(n, dtype=np.int64)
    event_end = np.empty(n, dtype=np.int64)
    eval_end = np.empty(n, dtype=np.int64)
    pts = np.empty((0, 2 + ny))
    evs = np.empty((0, 3 + ny))
    yev = np.empty((0, ny))
    n_pts = n_evs = n_yev = 0
    for i in range(n):
        y0 = y0s[i].copy()
        for j in range(y_slot.shape[0]):
            if y_slot[j] >= 0:
                v[y_slot[j]] = y0[j]
        res = call_integrate(integrate_at, v, y0, t_end, rtol, atol, h_max, max_steps,
                             max_events, save, t_eval, stop)
        head[i, 0] = res.fate
        head[i, 1] = res.t
        head[i, 2] = res.n_reversals
        head[i, 3] = res.n_steps
        p, e, ye = res.points, res.events, res.y_eval
        pts = grow(pts, n_pts + p.shape[0])
        pts[n_pts:n_pts + p.shape[0]] = p
        n_pts += p.shape[0]
        evs = grow(evs, n_evs + e.shape[0])
        evs[n_evs:n_evs + e.shape[0]] = e
        n_evs += e.shape[0]
        yev = grow(yev, n_yev + ye.shape[0])
        yev[n_yev:n_yev + ye.shape[0]] = ye
        n_yev += ye.shape[0]
        point_end[i] = n_pts
        event_end[i] = n_evs
        eval_end[i] = n_yev
    return head, pts[:n_pts], point_end, evs[:n_evs], event_end, yev[:n_yev], eval_end


def _batch_driver():
    """The batch driver of every integrator (compiled once, cached on disk)."""

    def make():
        args = (nb_types.intp, I1, F1, F2, *INTEGRATE_ARGS[2:])
        return njit(args, cache=True, error_model="numpy")(_batch_drive)

    return _DRIVERS.get((), ("batch",), make)


def run_batch(model: Model, method: str, v: np.ndarray, y0s: np.ndarray, *args):
    """Integrate from every row of ``y0s`` in one compiled call (see :func:`_batch_drive`);
    ``args`` are the integrator's from ``t_end`` on."""
    integrate, _ = kernels(model, method)
    y_slot = stage_kernels(model).constants["Y_SLOT"]
    return _batch_driver()(calls.address(integrate, INTEGRATE_ARGS), y_slot, v, y0s, *args,
                           NO_STOP)


def check_method(method, model_name: str) -> str:
    """``method`` if it names one of :data:`METHODS`, else ValueError."""
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"{model_name}: method must be one of {', '.join(METHODS)}, "
                         f"got {method!r}")
    return method


class Stage(NamedTuple):
    """A model's compiled stage pieces (see :mod:`phasemap.motion.integrate.templates`), for
    a caller that drives stages itself (:func:`phasemap.motion.workprecision.solve_ivp_staged`).

    ``classify(v, y, out)``: (n_solutions, first admissible branch, lost, singular) at
    the integrated state ``y``; ``still(v, y, out, branch, coef_sign)``: ``y`` goes on
    with the stage of ``branch``; ``event(v, y, t, t_prev, h, theta_end, r, branch,
    coef_sign, out, yb)``: the event where a stage stopped (``r``: a dense output in
    Hairer's nested form, see ``templates.dense``); ``start(v, y, out)``: how a motion
    starts; ``coefficient(out, branch)``: the stage's coefficient and its sign.
    """

    classify: object
    still: object
    event: object
    start: object
    coefficient: object
    constants: dict


def stage_kernels(model: Model) -> Stage:
    """The model's compiled stage pieces (the same the integrator inlines)."""
    return remember(("stage", model.name), model, lambda: _stage_kernels(model))


def _stage_kernels(model: Model) -> Stage:
    if model.dynamics is None:
        raise ValueError(f"{model.name}: this model has no dynamics (Model.dynamics is None); "
                         "it can be classified and mapped but not integrated in time")
    consts = contract_constants(model)
    consts["WATCH"] = np.concatenate([[nx.COEF], consts["REACTIONS"]]).astype(np.int64)
    consts["MOVING"] = moving_test(model).moving
    for name, template, inline in tp.PIECES:
        consts[name] = specialize(template, model, name.lower(), inline=inline,
                                  counts=name in COUNTED, **consts)
    return Stage(consts["CLASSIFY"], consts["STILL"], consts["EVENT"], consts["START"],
                 consts["STAGE_COEFFICIENT"], consts)


def kernels(model: Model, method: str = DEFAULT_METHOD):
    """The model's jitted integrator functions for ``method``: ``(integrate, fate_map)``."""
    check_method(method, model.name)
    return remember(("integrate", model.name, method), model, lambda: _kernels(model, method))


def integrator(model: Model, method: str = DEFAULT_METHOD):
    """The model's integrator for ``method`` (:data:`INTEGRATE_SIGNATURE`), jitted but not
    compiled yet: what :func:`phasemap.simulate` runs, as machine code or, before numba has
    compiled it, as its interpreted twin (:mod:`phasemap.core.tiers`)."""
    check_method(method, model.name)
    return remember(("integrator", model.name, method), model,
                    lambda: _integrator(model, method))


def _integrator(model: Model, method: str):
    spec = METHODS[method]
    consts = dict(stage_kernels(model).constants)
    consts.update(N_STAGES=spec.N_STAGES, FSAL=spec.FSAL, N_DENSE=spec.N_DENSE,
                  EXPONENT=spec.EXPONENT, STIFF_BOUND=spec.STIFF_BOUND)
    tag = spec.NAME.lower()
    for name, template, inline in (("STEP", spec.step_template, True),
                                   ("DENSE", spec.dense_template, True), *tp.METHOD_PIECES):
        consts[name] = specialize(template, model, f"{name.lower()}_{tag}", inline=inline,
                                  counts=name in COUNTED, **consts)
    return consts["INTEGRATE"]


def compile_integrator(model, method: str = DEFAULT_METHOD) -> None:
    """Compile the integrator of ``model`` (a registered name or a :class:`Model`) into the
    kernel cache: the background compile a first :func:`phasemap.simulate` starts."""
    from phasemap.systems import get_model

    calls.address(integrator(get_model(model), method), INTEGRATE_ARGS)


def _kernels(model: Model, method: str):
    integrate = integrator(model, method)
    # a first simulate's background compile of it under way: its result, not a second
    # compile of the same function
    tiers.wait_for(integrate, INTEGRATE_ARGS)
    at = calls.address(integrate, INTEGRATE_ARGS)
    if integrate.nopython_signatures[0] != INTEGRATE_SIGNATURE:  # a template's change
        raise TypeError(f"{model.name}: the integrator's signature is "
                        f"{integrate.nopython_signatures[0]}, not {INTEGRATE_SIGNATURE}")
    y_slot = stage_kernels(model).constants["Y_SLOT"]

    driver = _fate_driver()  # compiled here, not in the thread that runs it

    def fate_map(*args):
        """Run the shared parallel fate driver with this model's integrator."""
        return driver(at, y_slot, *args)

    fate_map.integrate = integrate  # the machine code at ``at`` lives while it does

    return integrate, fate_map


def run_fate_map(model: Model, axes: dict[str, np.ndarray], fixed: dict[str, float],
                 y0_fixed: np.ndarray, t_end: float, rtol: float, atol: float, h_max: float,
                 max_steps: int, max_events: int, method: str = DEFAULT_METHOD):
    """Fate of every cell of a grid of initial conditions (validated values)."""
    _, fate_map = kernels(model, method)
    packed = pack_axes(model, axes, fixed)
    shape = packed[1]
    ncells = int(np.prod(shape))
    dyn = model.dynamics
    n_pos = len(dyn.coordinates)
    fate = np.empty(ncells, dtype=np.int8)
    n_rev = np.empty(ncells, dtype=np.int32)
    t_final = np.empty(ncells)
    pos_rest = np.empty((n_pos, ncells))
    stop = np.zeros(1, dtype=np.int64)
    run_stoppable(lambda: fate_map(*packed, y0_fixed, t_end, rtol, atol, h_max, max_steps,
                                   max_events, np.arange(n_pos, dtype=np.int64), fate, n_rev,
                                   t_final, pos_rest, stop), stop)
    grid = tuple(int(s) for s in shape)
    return (fate.reshape(grid), n_rev.reshape(grid), t_final.reshape(grid),
            pos_rest.reshape((n_pos,) + grid))


def run_stoppable(call, stop: np.ndarray) -> None:
    """``call()``, a compiled call that releases the GIL and reads ``stop[0]`` at every
    step, in a thread of its own while this (the main) thread waits for it: a signal
    that raises here (Ctrl-C's KeyboardInterrupt, or phasemap's ``Terminated``) sets
    ``stop[0]``, waits the step or so the call takes to notice, and is raised.  A fate
    cell can be a trajectory of minutes, which a signal could not otherwise interrupt.
    Off the main thread (a dask worker), where no signal is raised, the call runs as it
    is."""
    if threading.current_thread() is not threading.main_thread():
        call()
        return
    import numba

    failed = []
    threads = numba.get_num_threads()  # numba's thread count is per thread: the caller's

    def target():
        try:
            numba.set_num_threads(threads)
            call()
        except BaseException as err:  # handed to the waiting thread
            failed.append(err)

    worker = threading.Thread(target=target, name="phasemap-fates", daemon=True)
    try:
        worker.start()
        while worker.is_alive():
            worker.join(0.05)
    finally:
        # on any way out (a signal, even one between two lines here) the work stops
        # within a step and is waited for: no compiled work runs on behind the caller
        stop[0] = 1
        while worker.is_alive():
            try:
                worker.join()
            except BaseException:  # a second Ctrl-C: the work is ending already
                continue
    if failed:
        raise failed[0]
