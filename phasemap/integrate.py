r"""The time integrator: Dormand-Prince 5(4) with exact set-valued friction.

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
* **Steps.**  Explicit Runge-Kutta of Dormand and Prince, order 5 with an
  embedded order-4 error estimate (Hairer, Norsett and Wanner, *Solving ODE
  I*, II.5; the coefficients of ``scipy``'s ``RK45`` and Hairer's ``dopri5``),
  first-same-as-last, with an RMS error norm over ``atol + rtol |y|`` and the
  standard step-size controller.  Dense output is Hairer's order-4
  continuous extension.
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
``singular`` (when the active coefficient has fallen below 1e-6 of its value
at the stage start) or ``step_failure``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import _numerics as nx
from . import events as ev
from ._compile import specialize
from .grid import pack_axes
from .model import Model

# Dormand-Prince 5(4) tableau.
C2, C3, C4, C5 = 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0,
                           -5103.0 / 18656.0)
A71, A73, A74, A75, A76 = (35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0,
                           11.0 / 84.0)
E1, E3, E4, E5, E6, E7 = (71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0,
                          22.0 / 525.0, -1.0 / 40.0)
D1, D3, D4, D5, D6, D7 = (-12715105075.0 / 11282082432.0, 87487479700.0 / 32700410799.0,
                          -10690763975.0 / 1880347072.0, 701980252875.0 / 199316789632.0,
                          -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0)

SAFETY, FAC_MIN, FAC_MAX = 0.9, 0.2, 10.0
EPS = np.finfo(np.float64).eps
#: Cells per work unit of a fate map; units interleave over the grid to balance threads.
FATE_UNITS = 1024

# Compile-time structure of the model being compiled (see phasemap._compile).
POINT = None
BRANCH = None
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
FILL = None
RHS = None
SUMMARY = None
CLASSIFY = None
INTEGRATE = None


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
    """Hairer's order-4 continuous extension at ``theta`` in [0, 1] into ``y``."""
    t1 = 1.0 - theta
    for i in range(y.shape[0]):
        y[i] = r[0, i] + theta * (r[1, i] + t1 * (r[2, i] + theta * (r[3, i] + t1 * r[4, i])))


def _fill_template(v, y):
    """Put the integrated state ``y`` into the input vector ``v`` and derive the rest."""
    for i in range(Y_SLOT.shape[0]):
        s = Y_SLOT[i]
        if s >= 0:
            v[s] = y[i]
    DERIVE(v)


def _inside_template(y):
    """The integrated state lies in the model's domain (bounds of its variables)."""
    for i in range(y.shape[0]):
        if y[i] < LOWER[i] or y[i] > UPPER[i]:
            return False
    return True


def _rhs_template(v, y, mode, row, dy):
    """dy/dt on the stage of branch ``mode``."""
    FILL(v, y)
    for j in range(N_DOF):
        row[ACC_COL[j]] = np.nan  # a branch without a solution leaves NaN, never stale values
    BRANCH(v, mode, row)
    for j in range(N_DOF):
        dy[j] = y[N_DOF + j]
        dy[N_DOF + j] = row[ACC_COL[j]]


def _summary_template(out):
    """(n_solutions, first admissible branch, lost, singular) of classified rows."""
    n, stag, lost, sing = nx.summarize(out, STICK)
    adm = -1
    for b in range(N_BRANCHES):
        if out[b, nx.STATUS] == nx.ADMISSIBLE:
            adm = b
            break
    return n, adm, lost, sing


def _classify_template(v, y, out):
    """Classify the state ``y``: (n_solutions, first admissible branch, lost, singular)."""
    FILL(v, y)
    POINT(v, out)
    return SUMMARY(out)


def _integrate_template(v, y0, t_end, rtol, atol, h_max, max_steps, max_events, save, t_eval):
    """Integrate from ``y0`` (positions then velocities) at t = 0 until a fate or ``t_end``.

    ``v`` is the model's input vector holding the parameters (its state slots
    are overwritten).  With ``save`` every accepted step is recorded; the
    states at the sorted times ``t_eval`` are always recorded.

    Returns ``(fate, t, y, n_reversals, n_steps, ts, ys, ms, n_saved, ev_t,
    ev_kind, ev_y, ev_mode, n_events, y_eval, n_eval)``.
    """
    ny = 2 * N_DOF
    out = np.empty((N_BRANCHES, N_FIELDS))
    row = np.empty(N_FIELDS)
    k1 = np.empty(ny)
    k2 = np.empty(ny)
    k3 = np.empty(ny)
    k4 = np.empty(ny)
    k5 = np.empty(ny)
    k6 = np.empty(ny)
    k7 = np.empty(ny)
    yt = np.empty(ny)
    y1 = np.empty(ny)
    err = np.empty(ny)
    r = np.empty((5, ny))
    yb = np.empty(ny)
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

    h = 0.0
    h_prev_ok = True
    flickers = 0
    stiff_hits = 0  # Hairer's stiffness detection: consecutive steps with h |lambda| > 3.25
    calm = 0
    if fate < 0:
        RHS(v, y, mode, row, k1)
        # Initial step (Hairer's hinit): from the scaled sizes of y and y'.
        d0 = _norm(y, y, y, rtol, atol)
        d1 = _norm(k1, y, y, rtol, atol)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, t_end, h_max)
        for i in range(ny):
            yt[i] = y[i] + h0 * k1[i]
        RHS(v, yt, mode, row, k2)
        for i in range(ny):
            err[i] = (k2[i] - k1[i]) / h0
        d2 = _norm(err, y, y, rtol, atol)
        dm = max(d1, d2)
        h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else (0.01 / dm) ** 0.2
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
            fate = ev.SINGULAR if abs(c) < 1e-6 * abs(coef0) else ev.STEP_FAILURE
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
        # -- one Dormand-Prince step ---------------------------------------
        for i in range(ny):
            yt[i] = y[i] + h * A21 * k1[i]
        RHS(v, yt, mode, row, k2)
        for i in range(ny):
            yt[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i])
        RHS(v, yt, mode, row, k3)
        for i in range(ny):
            yt[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i])
        RHS(v, yt, mode, row, k4)
        for i in range(ny):
            yt[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
        RHS(v, yt, mode, row, k5)
        for i in range(ny):
            yt[i] = y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i]
                                + A65 * k5[i])
        RHS(v, yt, mode, row, k6)
        for i in range(ny):
            y1[i] = y[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i]
                                + A76 * k6[i])
        RHS(v, y1, mode, row, k7)
        n_steps += 1
        for i in range(ny):
            err[i] = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i]
                          + E7 * k7[i])
        e = _norm(err, y, y1, rtol, atol)
        if not (e <= 1.0):  # also rejects NaN
            fac = FAC_MIN if not (e == e) else max(FAC_MIN, SAFETY * e ** -0.2)
            h *= fac
            h_prev_ok = False
            continue
        # -- accepted: stiffness detection (Hairer's dopri5) ------------------
        # h |lambda| ~ h ||f(y1) - f(y6)|| / ||y1 - y6||, y6 the sixth stage's point;
        # beyond the stability boundary (3.25) for 15 accepted steps the motion
        # is stiff here (a coefficient of the senior derivative near zero) and an
        # explicit method would crawl: stop and say so.
        num = 0.0
        den = 0.0
        for i in range(ny):
            num += (k7[i] - k6[i]) ** 2
            den += (y1[i] - yt[i]) ** 2
        if den > 0.0 and h * np.sqrt(num / den) > 3.25:
            calm = 0
            stiff_hits += 1
            if stiff_hits >= 15:
                fate = ev.STIFF
                break
        else:
            calm += 1
            if calm >= 6:
                stiff_hits = 0
        # -- accepted: dense output coefficients ---------------------------
        for i in range(ny):
            dy = y1[i] - y[i]
            bspl = h * k1[i] - dy
            r[0, i] = y[i]
            r[1, i] = dy
            r[2, i] = bspl
            r[3, i] = dy - h * k7[i] - bspl
            r[4, i] = h * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i]
                           + D7 * k7[i])
        # v holds y1 and its derived inputs from the last stage of the step
        POINT(v, out)
        n, adm, lost, sing = SUMMARY(out)
        still = n == 1 and adm == mode and (coef_sign == 0.0 or out[mode, nx.COEF]
                                             * coef_sign > 0.0) and INSIDE(y1)
        theta_end = 1.0
        if not still:
            # locate the first state where the stage stops being the unique solution
            lo, hi = 0.0, 1.0
            for _ in range(200):
                if (hi - lo) * h <= 2.0 * EPS * max(abs(t), abs(h)):
                    break
                mid = 0.5 * (lo + hi)
                _dense(r, mid, yb)
                n, adm, lost, sing = CLASSIFY(v, yb, out)
                if n == 1 and adm == mode and (coef_sign == 0.0 or out[mode, nx.COEF]
                                               * coef_sign > 0.0) and INSIDE(yb):
                    lo = mid
                else:
                    hi = mid
            theta_end = hi
            _dense(r, hi, y1)
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
                k1[i] = k7[i]
            if save:
                pts, n_saved = _push(pts, n_saved, t, mode, mode, y)
            fac = FAC_MAX if e == 0.0 else min(FAC_MAX, max(FAC_MIN, SAFETY * e ** -0.2))
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
        if not INSIDE(y):  # the state leaves the model's domain (the ladder lies flat)
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
        elif n != 1 or (adm == mode and (coef_sign == 0.0
                                         or out[mode, nx.COEF] * coef_sign > 0.0)):
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
                stage = n2 == 1 and adm2 == mode and (coef_sign == 0.0 or out[mode, nx.COEF]
                                                      * coef_sign > 0.0)
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
                RHS(v, y, mode, row, k1)
                continue
        flickers = 0
        new_mode = -1
        if n == 1:
            new_mode = adm
            if adm == STICK:
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
        RHS(v, y, mode, row, k1)
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
    return (fate, t, y, n_rev, n_steps, pts[:n_saved, 0], pts[:n_saved, 2:],
            pts[:n_saved, 1], n_saved, evs[:n_ev, 0], evs[:n_ev, 1], evs[:n_ev, 3:],
            evs[:n_ev, 2], n_ev, y_eval[:n_eval], n_eval)


def _fate_template(base, shape, axis_slot, axis_values, deriv_slot, deriv_values, y0_fixed,
                   t_end, rtol, atol, h_max, max_steps, max_events, pos_col,
                   fate, n_rev, t_final, pos_rest):
    """Integrate from every cell of a grid of initial conditions; record how each ends.

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
            rem = cell
            for d in range(ndim - 1, -1, -1):
                i = rem % shape[d]
                rem //= shape[d]
                v[axis_slot[d]] = axis_values[d, i]
                for k in range(deriv_slot.shape[1]):
                    if deriv_slot[d, k] >= 0:
                        v[deriv_slot[d, k]] = deriv_values[d, k, i]
            for i in range(Y_SLOT.shape[0]):
                if Y_SLOT[i] >= 0:
                    y0[i] = v[Y_SLOT[i]]
            res = INTEGRATE(v, y0, t_end, rtol, atol, h_max, max_steps, max_events, False,
                            no_eval)
            fate[cell] = res[0]
            n_rev[cell] = res[3]
            t_final[cell] = res[1]
            for j in range(pos_col.shape[0]):
                pos_rest[j, cell] = res[2][pos_col[j]] if res[0] == ev.REST else np.nan


def kernels(model: Model):
    """The model's jitted integrator functions: ``(integrate, fate_map)``."""
    dyn = model.dynamics
    if dyn is None:
        raise ValueError(f"{model.name}: this model has no dynamics (Model.dynamics is None); "
                         "it can be classified and mapped but not integrated in time")
    slot = {n: i for i, n in enumerate(model.inputs)}
    variables = {**model.variables, **{p.name: p for p in dyn.positions}}
    positions = [c[0] for c in dyn.coordinates]
    velocities = [c[1] for c in dyn.coordinates]
    acc_names = [a.name for a in model.accelerations]
    consts = dict(
        POINT=model.point, BRANCH=dyn.branch, DERIVE=dyn.derive,
        STICK=model.stick_branch, N_BRANCHES=len(model.branches), N_FIELDS=model.n_fields,
        N_DOF=len(dyn.coordinates),
        Y_SLOT=np.array([slot.get(n, -1) for n in positions + velocities], dtype=np.int64),
        ACC_COL=np.array([nx.FIRST_ACC + acc_names.index(c[2]) for c in dyn.coordinates],
                         dtype=np.int64),
        VEL_Y=len(positions) + velocities.index(model.velocity),
        DIRECTIONS=np.array(dyn.directions, dtype=np.float64),
        STICK_IS_REST=dyn.stick_is_rest,
        LOWER=np.array([variables[n].lower for n in positions + velocities]),
        UPPER=np.array([variables[n].upper for n in positions + velocities]),
    )
    consts["INSIDE"] = specialize(_inside_template, model, "inside", **consts)
    consts["FILL"] = specialize(_fill_template, model, "fill", **consts)
    consts["RHS"] = specialize(_rhs_template, model, "rhs", **consts)
    consts["SUMMARY"] = specialize(_summary_template, model, "summary", **consts)
    consts["CLASSIFY"] = specialize(_classify_template, model, "classify_state", **consts)
    consts["INTEGRATE"] = integrate = specialize(_integrate_template, model, "integrate",
                                                 **consts)
    fate_map = specialize(_fate_template, model, "fate_map", parallel=True, **consts)
    return integrate, fate_map


def run_fate_map(model: Model, axes: dict[str, np.ndarray], fixed: dict[str, float],
                 y0_fixed: np.ndarray, t_end: float, rtol: float, atol: float, h_max: float,
                 max_steps: int, max_events: int):
    """Fate of every cell of a grid of initial conditions (validated values)."""
    _, fate_map = kernels(model)
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
