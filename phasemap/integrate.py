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
  and Hairer's order-4 continuous extension (:mod:`phasemap._dopri5`; the
  coefficients of Hairer's ``dopri5`` and scipy's ``RK45``), or ``DOP853``,
  order 8 with dop853's combined order-5/order-3 error estimate and its
  order-7 continuous extension (:mod:`phasemap._dop853`; Hairer's ``dop853``
  and scipy's ``DOP853``), for tight tolerances.  Both are
  first-same-as-last, with an RMS error norm over ``atol + rtol |y|`` and the
  standard step-size controller.
* **Events by classification.**  After every accepted step the end state is
  classified with the model's own ``point`` function, exactly as
  :func:`phasemap.classify` does.  The stage goes on while the classification
  is *unique and equal to the active branch* (and the branch's coefficient of
  the senior derivative keeps its sign).  Otherwise the first state where it
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
"""

from __future__ import annotations

import functools
import hashlib
import pathlib

import numpy as np
from numba import njit, prange
from numba import types as nb_types

from . import _dop853, _dopri5
from . import _numerics as nx
from . import events as ev
from ._codegen import _F1, _F2, _F3, _I1, _I2, set_cell
from ._compile import specialize
from .grid import pack_axes
from .model import Model

#: The methods by name (``simulate(method=...)``, the fate layers' ``method`` option).
METHODS = {m.NAME: m for m in (_dopri5, _dop853)}
#: The default method.
DEFAULT_METHOD = _dopri5.NAME

SAFETY, FAC_MIN, FAC_MAX = 0.9, 0.2, 10.0
EPS = np.finfo(np.float64).eps
#: Cells per work unit of a fate map; units interleave over the grid to balance threads.
FATE_UNITS = 1024

# Compile-time structure of the model being compiled (see phasemap._compile).
POINT = None
BRANCH_ROW = None
DERIVE = None
STICK = -1
N_BRANCHES = 0
N_FIELDS = 0
N_DOF = 1
Y_SLOT = np.zeros(2, dtype=np.int64)
ACC_COL = np.zeros(1, dtype=np.int64)
VEL_Y = 1
DIRECTIONS = np.zeros(1)
STICK_IS_REST = True
LOWER = np.zeros(2)
UPPER = np.zeros(2)
INSIDE = None
DOMAIN = None
FILL = None
RHS = None
SUMMARY = None
CLASSIFY = None
ON_STAGE = None
STILL = None
INDICATOR = None
ZERO = None
LOCATE = None
#: Columns of a branch row watched for zeros that end a stage: reactions, coefficient.
WATCH = np.zeros(0, dtype=np.int64)
INTEGRATE = None
# ... and of the method (a module such as phasemap._dopri5; see METHODS)
STEP = None
DENSE = None
N_STAGES = 7
FSAL = 6
N_DENSE = 5
EXPONENT = 0.2
STIFF_BOUND = 3.25


@njit(cache=True)
def _grow(a, n):
    """``a`` (2-D) with at least ``n`` rows, keeping its content."""
    if n <= a.shape[0]:
        return a
    b = np.empty((max(n, 2 * a.shape[0]), a.shape[1]))
    b[:a.shape[0]] = a
    return b


@njit(cache=True)
def _push(a, n, t, code, mode, y):
    """Append the row (t, code[, mode], y...) at ``n`` (growing ``a``); return (a, n + 1).

    Saved points have two head columns (t, branch), events three (t, kind, branch).
    """
    a = _grow(a, n + 1)
    k = a.shape[1] - y.shape[0]
    a[n, 0] = t
    a[n, 1] = code
    if k == 3:
        a[n, 2] = mode
    a[n, k:] = y
    return a, n + 1


@njit(cache=True)
def _norm(e, y0, y1, rtol, atol):
    """RMS of ``e`` over the error scale ``atol + rtol max(|y0|, |y1|)``."""
    acc = 0.0
    for i in range(e.shape[0]):
        sk = atol + rtol * max(abs(y0[i]), abs(y1[i]))
        acc += (e[i] / sk) ** 2
    return np.sqrt(acc / e.shape[0])


@njit(cache=True)
def _dense(r, theta, y):
    """The continuous extension at ``theta`` in [0, 1] into ``y``.

    Hairer's nested form, for any number of rows (5 for DOPRI5, 8 for DOP853):
    ``r0 + theta (r1 + (1 - theta) (r2 + theta (r3 + (1 - theta) (r4 + ...))))``.
    """
    t1 = 1.0 - theta
    last = r.shape[0] - 1
    for i in range(y.shape[0]):
        acc = r[last, i]
        for j in range(last - 1, -1, -1):
            acc = r[j, i] + (theta if j % 2 == 0 else t1) * acc
        y[i] = acc


def _fill_template(v, y):
    """Put the integrated state ``y`` into the input vector ``v`` and derive the rest."""
    for i in range(Y_SLOT.shape[0]):
        s = Y_SLOT[i]
        if s >= 0:
            v[s] = y[i]
    DERIVE(v)


def _inside_template(v, y):
    """The integrated state lies in the model's domain: the bounds of its variables
    and the model's own ``inside`` condition (``v`` is filled with ``y``)."""
    for i in range(y.shape[0]):
        if y[i] < LOWER[i] or y[i] > UPPER[i]:
            return False
    FILL(v, y)
    return DOMAIN(v)


def _rhs_template(v, y, mode, K, k):
    """dy/dt on the stage of branch ``mode`` into row ``k`` of the stage array ``K``
    (NaN where the branch has no solution).

    The branch row comes back as a tuple from the inlined ``BRANCH_ROW``.  The
    stage is addressed by its row index, not passed as a view ``K[k]``: a view
    made at each of the six (DOPRI5) or twelve (DOP853) calls per step costs a
    reference-count increment and decrement (atomic), measured at 40 % of a
    step of the wheel (BENCHMARKS.md, "Fate map of the wheel").
    """
    FILL(v, y)
    r = BRANCH_ROW(v, mode)
    for j in range(N_DOF):
        K[k, j] = y[N_DOF + j]
        K[k, N_DOF + j] = r[ACC_COL[j]]


def _summary_template(out):
    """(n_solutions, first admissible branch, lost, singular) of classified rows."""
    n, stag, lost, sing = nx.summarize(out, STICK)
    adm = -1
    for b in range(N_BRANCHES):
        st = out[b, nx.STATUS]
        if st == nx.ADMISSIBLE or st == nx.SEPARATION:
            adm = b
            break
    return n, adm, lost, sing


def _classify_template(v, y, out):
    """Classify the state ``y``: (n_solutions, first admissible branch, lost, singular)."""
    FILL(v, y)
    POINT(v, out)
    return SUMMARY(out)


def _on_stage_template(n, adm, out, mode, coef_sign):
    """A classification (``n``, ``adm`` of the rows ``out``) goes on with the stage of
    branch ``mode``: the unique solution, the same branch, the sign ``coef_sign`` of
    its coefficient kept (0: not watched)."""
    return n == 1 and adm == mode and (coef_sign == 0.0
                                       or out[mode, nx.COEF] * coef_sign > 0.0)


def _still_template(v, yb, out, mode, coef_sign):
    """The state ``yb`` is still on the stage of branch ``mode`` (ON_STAGE) and inside
    the domain (``out``: its rows)."""
    n, adm, lost, sing = CLASSIFY(v, yb, out)
    return ON_STAGE(n, adm, out, mode, coef_sign) and INSIDE(v, yb)


def _indicator_template(v, r, theta, mode, col, yb):
    """At ``theta`` of the step (dense output ``r``, into ``yb``): the stage's velocity
    (``col`` < 0) or column ``col`` of its branch row."""
    _dense(r, theta, yb)
    if col < 0:
        return yb[VEL_Y]
    FILL(v, yb)
    return BRANCH_ROW(v, mode)[col]


def _zero_template(v, r, mode, col, sg, fa, fb, h, t, yb):
    """Illinois on the step for the zero of ``sg`` times an indicator (see INDICATOR),
    from ``fa`` > 0 at theta = 0 and ``fb`` <= 0 at theta = 1: ``(a, b)``, a bracket
    of width 4 eps in time."""
    a, b = 0.0, 1.0
    side = 0
    for _ in range(100):
        c = (a * fb - b * fa) / (fb - fa)
        if not (a < c < b):
            c = 0.5 * (a + b)
        fc = sg * INDICATOR(v, r, c, mode, col, yb)
        if fc > 0.0:
            a, fa = c, fc
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            b, fb = c, fc
            if side == 1:
                fa *= 0.5
            side = 1
        if (b - a) * h <= 4.0 * EPS * max(abs(t), abs(h)):
            break
    return a, b


def _locate_template(v, y, y1, h, t, mode, coef_sign, r, out, yb, zs):
    """The first theta of the step ``y`` -> ``y1`` (dense output ``r``) where the stage
    stops being the unique solution, to 2 eps in time (``zs``: scratch, one row per
    WATCH column and one for the velocity).

    Classification decides where a stage ends, and is what bisection would call
    fifty times.  Most stages end where a continuous quantity of their branch
    row crosses zero: the velocity (a reversal or a stop), a reaction (a
    contact released), the coefficient of the senior derivative (a singular
    state).  Those crossing zero in the step are rooted on the dense output
    (Illinois: a few row evaluations each), and the earliest zero that
    classification confirms (the stage 1e-11 or 1e-9 of the step before it, not
    at it or 1e-13 or 1e-11 after it) leaves a bracket of 1e-11 to 1e-9 for a
    dozen bisection steps.  Anything else (a friction cone left at stick,
    another branch turning admissible, the domain's edge) is bisected from the
    whole step.
    """
    nz = 0
    d = DIRECTIONS[mode]
    if d != 0.0 and d * y[VEL_Y] > 0.0 and d * y1[VEL_Y] <= 0.0:
        zs[nz, 0], zs[nz, 1] = ZERO(v, r, mode, -1, d, d * y[VEL_Y], d * y1[VEL_Y], h, t, yb)
        nz += 1
    if WATCH.shape[0] > 0:
        FILL(v, y)
        g0 = BRANCH_ROW(v, mode)
        FILL(v, y1)
        g1 = BRANCH_ROW(v, mode)
        for q in range(WATCH.shape[0]):
            a0, a1 = g0[WATCH[q]], g1[WATCH[q]]
            if a0 * a1 < 0.0:
                sg = 1.0 if a0 > 0.0 else -1.0
                zs[nz, 0], zs[nz, 1] = ZERO(v, r, mode, WATCH[q], sg, sg * a0, sg * a1, h, t,
                                             yb)
                nz += 1
    lo, hi = 0.0, 1.0
    for _ in range(nz):  # the candidates in order of their zeros
        k = 0
        for j in range(1, nz):
            if zs[j, 1] < zs[k, 1]:
                k = j
        a, b = zs[k, 0], zs[k, 1]
        zs[k, 1] = 2.0
        if b > 1.0:
            break
        # the zero tests admit 1e-12 of a quantity's scale (GUIDE 1), so the stage
        # may end a little past the zero; still on it 1e-11 of the step past, the
        # zero does not end it (a reaction free in sign)
        for past in (0.0, 1e-13, 1e-11):
            c_hi = min(1.0, b + past)
            _dense(r, c_hi, yb)
            if not STILL(v, yb, out, mode, coef_sign):
                break
        else:
            continue
        for before in (1e-11, 1e-9):
            c_lo = max(0.0, a - before)
            _dense(r, c_lo, yb)
            if STILL(v, yb, out, mode, coef_sign):
                lo, hi = c_lo, c_hi
                break
        break
    for _ in range(200):
        if (hi - lo) * h <= 2.0 * EPS * max(abs(t), abs(h)):
            break
        mid = 0.5 * (lo + hi)
        _dense(r, mid, yb)
        if STILL(v, yb, out, mode, coef_sign):
            lo = mid
        else:
            hi = mid
    return hi


def _integrate_template(v, y0, t_end, rtol, atol, h_max, max_steps, max_events, save, t_eval):
    """Integrate from ``y0`` (positions then velocities) at t = 0 until a fate or ``t_end``.

    ``v`` is the model's input vector holding the parameters (its state slots
    are overwritten).  With ``save`` every accepted step is recorded; the
    states at the sorted times ``t_eval`` are always recorded.

    Returns ``(fate, t, y, n_reversals, n_steps, points, events, y_eval)``:
    ``points`` has one row (t, branch, y...) per saved point, ``events`` one row
    (t, kind, branch after, y...) per event (:func:`unpack` names their
    columns), ``y_eval`` the states at the first ``len(y_eval)`` times of
    ``t_eval``.  Four arrays, not one per column: each array handed back to
    Python costs about a microsecond and a half of boxing, a tenth of a short
    motion's whole call.
    """
    ny = 2 * N_DOF
    out = np.empty((N_BRANCHES, N_FIELDS))
    K = np.empty((N_STAGES, ny))  # the stages; K[0] = f(y)
    k1 = K[0]
    yt = np.empty(ny)
    y1 = np.empty(ny)
    err = np.empty(ny)
    r = np.empty((N_DENSE, ny))
    yb = np.empty(ny)
    zs = np.empty((WATCH.shape[0] + 1, 2))  # zeros ending the stage in a step (LOCATE)
    pts = np.empty((64 if save else 1, 2 + ny))  # saved points: t, branch, y
    n_saved = 0
    evs = np.empty((16, 3 + ny))  # events: t, kind, branch after, y
    n_ev = 0
    y_eval = np.empty((t_eval.shape[0], ny))
    n_eval = 0

    y = y0.copy()
    t = 0.0
    n_rev = 0
    n_steps = 0

    # -- the first classification decides how the motion starts ------------
    n, mode, lost, sing = CLASSIFY(v, y, out)
    kind = ev.START
    if n != 1:
        mode = -1
        kind = ev.fate_without_unique(n, lost, sing)
    elif out[mode, nx.STATUS] == nx.SEPARATION:  # the only motion leaves a contact
        mode = -1
        kind = ev.CONTACT_LOST
    elif mode == STICK and STICK_IS_REST:
        kind = ev.REST
    evs, n_ev = _push(evs, n_ev, t, kind, mode, y)
    if save:
        pts, n_saved = _push(pts, n_saved, t, mode, mode, y)
    fate = kind
    if kind == ev.START:
        fate = -1
    coef_sign = 0.0
    coef0 = 0.0
    if mode >= 0 and mode != STICK:  # the stick branch has no senior-derivative coefficient
        coef0 = out[mode, nx.COEF]
        coef_sign = 1.0 if coef0 > 0.0 else (-1.0 if coef0 < 0.0 else 0.0)
    # the scale of the coefficient: its largest size at a stage start of this motion
    # (switches close to a singular state start stages with a coefficient already small)
    coef_scale = abs(coef0)

    h = 0.0
    h_prev_ok = True
    flickers = 0
    stiff_hits = 0  # Hairer's stiffness detection: consecutive steps with h |lambda| > bound
    calm = 0
    if fate < 0:
        RHS(v, y, mode, K, 0)
        # Initial step (Hairer's hinit): from the scaled sizes of y and y'.
        d0 = _norm(y, y, y, rtol, atol)
        d1 = _norm(k1, y, y, rtol, atol)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, t_end, h_max)
        for i in range(ny):
            yt[i] = y[i] + h0 * k1[i]
        RHS(v, yt, mode, K, 1)
        for i in range(ny):
            err[i] = (K[1, i] - k1[i]) / h0
        d2 = _norm(err, y, y, rtol, atol)
        dm = max(d1, d2)
        h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else (0.01 / dm) ** EXPONENT
        h = min(100.0 * h0, h1, h_max)
        if not (h > 0.0):
            h = 1e-6

    while fate < 0:
        if n_steps >= max_steps:
            fate = ev.MAX_STEPS
            break
        if t >= t_end:
            fate = ev.HORIZON
            break
        last = False
        if t + 1.01 * h >= t_end:
            h = t_end - t
            last = True
        if h <= 16.0 * EPS * abs(t) or h <= 1e-14 * t_end:
            c = out[mode, nx.COEF] if coef_sign != 0.0 else coef0
            fate = ev.SINGULAR if abs(c) < 1e-6 * coef_scale else ev.STEP_FAILURE
            # the stage's branch may have no solution just ahead: then that is the fate
            s = max(h, 1e-14 * t_end)
            for _ in range(9):
                for i in range(ny):
                    yb[i] = y[i] + s * k1[i]
                n2, adm2, lost2, sing2 = CLASSIFY(v, yb, out)
                if n2 != 1:
                    fate = ev.fate_without_unique(n2, lost2, sing2)
                    break
                if adm2 != mode:
                    break
                s *= 10.0
            break
        # -- one step of the method ------------------------------------------
        e = STEP(v, y, h, mode, K, yt, y1, rtol, atol)
        n_steps += 1
        if not (e <= 1.0):  # also rejects NaN
            fac = FAC_MIN if not (e == e) else max(FAC_MIN, SAFETY * e ** -EXPONENT)
            h *= fac
            h_prev_ok = False
            continue
        # -- accepted: stiffness detection (Hairer's dopri5 and dop853) --------
        # h |lambda| ~ h ||f(y1) - f(yt)|| / ||y1 - yt||, yt the point of the last
        # stage before f(y1) (also at t + h); beyond the method's stability
        # boundary for 15 accepted steps the motion is stiff here (a coefficient
        # of the senior derivative near zero) and an explicit method would
        # crawl: stop and say so.
        num = 0.0
        den = 0.0
        for i in range(ny):
            num += (K[FSAL, i] - K[FSAL - 1, i]) ** 2
            den += (y1[i] - yt[i]) ** 2
        if den > 0.0 and h * np.sqrt(num / den) > STIFF_BOUND:
            calm = 0
            stiff_hits += 1
            if stiff_hits >= 15:
                fate = ev.STIFF
                break
        else:
            calm += 1
            if calm >= 6:
                stiff_hits = 0
        # v holds y1 and its derived inputs from the last stage of the step
        POINT(v, out)
        n, adm, lost, sing = SUMMARY(out)
        still = ON_STAGE(n, adm, out, mode, coef_sign) and INSIDE(v, y1)
        theta_end = 1.0
        # the dense output, only where it is used: to locate an event, at requested times
        if not still or (n_eval < t_eval.shape[0]
                         and t_eval[n_eval] <= (t_end if last else t + h)):
            DENSE(v, y, y1, h, mode, K, yt, r)
        if not still:
            theta_end = LOCATE(v, y, y1, h, t, mode, coef_sign, r, out, yb, zs)
            _dense(r, theta_end, y1)
        t1 = t + theta_end * h
        if theta_end == 1.0 and last:
            t1 = t_end
        # states at the requested times inside this step
        while n_eval < t_eval.shape[0] and t_eval[n_eval] <= t1:
            _dense(r, min(1.0, max(0.0, (t_eval[n_eval] - t) / h)), yb)
            y_eval[n_eval] = yb
            n_eval += 1
        if still:
            flickers = 0
            t = t1
            for i in range(ny):
                y[i] = y1[i]
                k1[i] = K[FSAL, i]
            if save:
                pts, n_saved = _push(pts, n_saved, t, mode, mode, y)
            fac = FAC_MAX if e == 0.0 else min(FAC_MAX, max(FAC_MIN, SAFETY * e ** -EXPONENT))
            if not h_prev_ok:
                fac = min(fac, 1.0)
            h = min(h * fac, h_max)
            h_prev_ok = True
            continue

        # -- an event at t1, state y1 --------------------------------------
        t_prev = t
        t = t1
        for i in range(ny):
            y[i] = y1[i]
        if not INSIDE(v, y):  # the state leaves the model's domain (the ladder lies flat)
            for i in range(ny):
                y[i] = min(max(y[i], LOWER[i]), UPPER[i])
            fate = ev.LEFT_DOMAIN
            break
        d = DIRECTIONS[mode]
        n, adm, lost, sing = CLASSIFY(v, y, out)
        vel_zero = d != 0.0 and (d * y[VEL_Y] <= 0.0 or out[STICK, nx.STATUS] != nx.ABSENT)
        if vel_zero:
            y[VEL_Y] = 0.0
            n, adm, lost, sing = CLASSIFY(v, y, out)
        elif n != 1 or ON_STAGE(n, adm, out, mode, coef_sign):
            # Within 1e-12 of a boundary the tie rules can admit two branches
            # (stick by its inclusive friction limit, and a slip whose starting
            # acceleration just clears its tolerance) or none, and a state one
            # rounding error away can still classify as the running stage (a
            # grazing reaction).  A genuine paradox persists past the boundary;
            # a tie does not: probe just beyond it on this step's dense output
            # (extrapolated by at most 1e-6 of the step) for the first state
            # that is decided, and unique if any is.
            first_bad = -1.0
            decided = False
            for k in range(1, 10):
                theta = theta_end + 10.0 ** k * 2.0 * EPS * max(abs(t_prev), abs(h)) / h
                if theta > 1.0 + 1e-6:
                    break
                _dense(r, theta, yb)
                n2, adm2, lost2, sing2 = CLASSIFY(v, yb, out)
                stage = ON_STAGE(n2, adm2, out, mode, coef_sign)
                if not stage and first_bad < 0.0:
                    first_bad = theta
                if n2 == 1 and not stage:
                    decided = True
                    t = t_prev + theta * h
                    for i in range(ny):
                        y[i] = yb[i]
                    break
            if not decided and first_bad >= 0.0:
                t = t_prev + first_bad * h
                _dense(r, first_bad, y)
            n, adm, lost, sing = CLASSIFY(v, y, out)
            if n == 1 and adm == mode and not decided and first_bad < 0.0:
                # a rounding flicker: the stage goes on from here
                flickers += 1
                if flickers > 8:
                    fate = ev.STEP_FAILURE
                    break
                RHS(v, y, mode, K, 0)
                continue
        flickers = 0
        new_mode = -1
        if n == 1:
            new_mode = adm
            if out[adm, nx.STATUS] == nx.SEPARATION:
                kind = ev.CONTACT_LOST  # the only motion from here leaves a contact
                new_mode = -1
            elif adm == STICK:
                kind = ev.REST if STICK_IS_REST else ev.STICK
            elif mode == STICK:
                kind = ev.SLIP
            elif DIRECTIONS[adm] == -d:
                kind = ev.REVERSAL
                n_rev += 1
            elif adm != mode:
                kind = ev.SWITCH
            elif vel_zero:
                kind = ev.SWITCH  # the velocity touched zero and the motion goes on
            else:
                kind = ev.SINGULAR  # same branch, its coefficient changed sign
                new_mode = -1
        else:
            kind = ev.fate_without_unique(n, lost, sing)
        if kind == ev.REST or new_mode < 0:
            fate = kind
            break
        if n_ev >= max_events:
            fate = ev.MAX_EVENTS
            break
        evs, n_ev = _push(evs, n_ev, t, kind, new_mode, y)
        if save:
            pts, n_saved = _push(pts, n_saved, t, new_mode, new_mode, y)
        mode = new_mode
        coef0 = out[mode, nx.COEF] if mode != STICK else 0.0
        coef_sign = 1.0 if coef0 > 0.0 else (-1.0 if coef0 < 0.0 else 0.0)
        coef_scale = max(coef_scale, abs(coef0))
        RHS(v, y, mode, K, 0)
        h_prev_ok = True

    # -- the fate, as the last event (unless the motion never started) ------
    if not (n_ev == 1 and fate == evs[0, 1]):
        after = STICK if fate == ev.REST else -1
        evs, n_ev = _push(evs, n_ev, t, fate, after, y)
        if save and (pts[n_saved - 1, 0] != t or fate == ev.REST):
            pts, n_saved = _push(pts, n_saved, t, STICK if fate == ev.REST
                                 else pts[n_saved - 1, 1], 0.0, y)
    if fate == ev.REST:
        # at rest for good: the requested times after the stop see the rest state
        while n_eval < t_eval.shape[0] and t_eval[n_eval] <= t_end:
            y_eval[n_eval] = y
            n_eval += 1
    return fate, t, y, n_rev, n_steps, pts[:n_saved], evs[:n_ev], y_eval[:n_eval]


def unpack(points, events):
    """The columns of an integrator's ``points`` and ``events`` (see
    ``_integrate_template``): ``(ts, ys, ms, ev_t, ev_kind, ev_y, ev_mode)``."""
    return (points[:, 0], points[:, 2:], points[:, 1], events[:, 0], events[:, 1],
            events[:, 3:], events[:, 2])


def _fate_drive(integrate, y_slot, base, shape, axis_slot, axis_values, deriv_slot,
                deriv_values, y0_fixed, t_end, rtol, atol, h_max, max_steps, max_events,
                pos_col, fate, n_rev, t_final, pos_rest):
    """Integrate from every cell of a grid of initial conditions; record how each ends.

    ``integrate`` is a model's integrator, taken as a first-class function, so
    that this parallel driver compiles once for every model and method (and
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
            cell = u + q * units
            set_cell(v, cell, shape, axis_slot, axis_values, deriv_slot, deriv_values)
            for i in range(y_slot.shape[0]):
                if y_slot[i] >= 0:
                    y0[i] = v[y_slot[i]]
            res = integrate(v, y0, t_end, rtol, atol, h_max, max_steps, max_events, False,
                            no_eval)
            fate[cell] = res[0]
            n_rev[cell] = res[3]
            t_final[cell] = res[1]
            for j in range(pos_col.shape[0]):
                pos_rest[j, cell] = res[2][pos_col[j]] if res[0] == ev.REST else np.nan


#: The argument types of every integrator (see _integrate_template).
INTEGRATE_ARGS = (_F1, _F1, nb_types.float64, nb_types.float64, nb_types.float64,
                  nb_types.float64, nb_types.int64, nb_types.int64, nb_types.boolean, _F1)
_FATE_DRIVERS: dict = {}


def _fate_driver(integrate):
    """The parallel fate driver for integrators of ``integrate``'s signature (compiled once)."""
    sig = integrate.nopython_signatures[0]
    driver = _FATE_DRIVERS.get(sig)
    if driver is None:
        fsig = nb_types.void(nb_types.FunctionType(sig), _I1, _F1, _I1, _I1, _F2, _I2, _F3, _F1,
                             nb_types.float64, nb_types.float64, nb_types.float64,
                             nb_types.float64, nb_types.int64, nb_types.int64, _I1,
                             nb_types.Array(nb_types.int8, 1, "C"),
                             nb_types.Array(nb_types.int32, 1, "C"), _F1, _F2)
        driver = _FATE_DRIVERS[sig] = njit(fsig, parallel=True, cache=True,
                                           error_model="numpy")(_fate_drive)
    return driver


def check_method(method, model_name: str) -> str:
    """``method`` if it names one of :data:`METHODS`, else ValueError."""
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"{model_name}: method must be one of {', '.join(METHODS)}, "
                         f"got {method!r}")
    return method


@functools.cache
def _method_tag(name: str) -> str:
    """The kernels' name for a method: its name and a hash of its module and this one.

    A kernel's on-disk cache is named after the source of its template's module
    (:func:`phasemap._compile.source_hash`); the step of a method lives in
    another module and is compiled into the integrator, so the hash of both
    goes into the name, and an edit to either recompiles.
    """
    h = hashlib.sha256()
    for path in (METHODS[name].__file__, __file__):
        h.update(pathlib.Path(path).read_bytes())
    return f"{name.lower()}_{h.hexdigest()[:8]}"


def kernels(model: Model, method: str = DEFAULT_METHOD):
    """The model's jitted integrator functions for ``method``: ``(integrate, fate_map)``."""
    spec = METHODS[check_method(method, model.name)]
    dyn = model.dynamics
    if dyn is None:
        raise ValueError(f"{model.name}: this model has no dynamics (Model.dynamics is None); "
                         "it can be classified and mapped but not integrated in time")
    slot = {n: i for i, n in enumerate(model.inputs)}
    variables = {**model.variables, **{p.name: p for p in dyn.positions}}
    positions = [c[0] for c in dyn.coordinates]
    velocities = [c[1] for c in dyn.coordinates]
    acc_names = [a.name for a in model.accelerations]
    contract = model.contract
    consts = dict(
        POINT=contract.point, BRANCH_ROW=contract.branch_row_inline,
        DERIVE=contract.derive_inline, DOMAIN=contract.domain_inline,
        STICK=model.stick_branch, N_BRANCHES=len(model.branches), N_FIELDS=model.n_fields,
        N_DOF=len(dyn.coordinates),
        Y_SLOT=np.array([slot.get(n, -1) for n in positions + velocities], dtype=np.int64),
        ACC_COL=np.array([nx.FIRST_ACC + acc_names.index(c[2]) for c in dyn.coordinates],
                         dtype=np.int64),
        VEL_Y=len(positions) + velocities.index(model.velocity),
        DIRECTIONS=np.array(model.directions, dtype=np.float64),
        STICK_IS_REST=dyn.stick_is_rest,
        LOWER=np.array([variables[n].lower for n in positions + velocities]),
        UPPER=np.array([variables[n].upper for n in positions + velocities]),
        WATCH=np.array([nx.COEF, *range(model.first_reaction, model.n_fields)],
                       dtype=np.int64),
    )
    # Per-step helpers: the small ones inline into their callers, so that a
    # right-hand side is one call (a step makes six or twelve of them) with the
    # branch physics inlined, and no array is passed between helpers; the step
    # and the dense output have one call site each and inline into the integrator.
    for name, template, inline in (("FILL", _fill_template, True),
                                   ("INSIDE", _inside_template, True),
                                   ("RHS", _rhs_template, False),
                                   ("SUMMARY", _summary_template, True),
                                   ("CLASSIFY", _classify_template, True),
                                   ("ON_STAGE", _on_stage_template, True),
                                   ("STILL", _still_template, True),
                                   ("INDICATOR", _indicator_template, True),
                                   ("ZERO", _zero_template, False),
                                   ("LOCATE", _locate_template, False)):
        consts[name] = specialize(template, model, name.lower(), inline=inline, **consts)
    tag = _method_tag(spec.NAME)
    consts.update(N_STAGES=spec.N_STAGES, FSAL=spec.FSAL, N_DENSE=spec.N_DENSE,
                  EXPONENT=spec.EXPONENT, STIFF_BOUND=spec.STIFF_BOUND)
    consts["STEP"] = specialize(spec._step_template, model, f"step_{tag}", inline=True,
                                **consts)
    consts["DENSE"] = specialize(spec._dense_template, model, f"dense_{tag}", inline=True,
                                 **consts)
    consts["INTEGRATE"] = integrate = specialize(_integrate_template, model,
                                                 f"integrate_{tag}", **consts)
    integrate.compile(INTEGRATE_ARGS)
    y_slot = consts["Y_SLOT"]

    def fate_map(*args):
        """Run the shared parallel fate driver with this model's integrator."""
        return _fate_driver(integrate)(integrate, y_slot, *args)

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
    fate_map(*packed, y0_fixed, t_end, rtol, atol, h_max, max_steps, max_events,
             np.arange(n_pos, dtype=np.int64), fate, n_rev, t_final, pos_rest)
    grid = tuple(int(s) for s in shape)
    return (fate.reshape(grid), n_rev.reshape(grid), t_final.reshape(grid),
            pos_rest.reshape((n_pos,) + grid))
