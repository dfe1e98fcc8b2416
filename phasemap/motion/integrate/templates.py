"""The integrator's numba templates, compiled per model (:func:`phasemap.motion.integrate.kernels`).

The integrator (:func:`_integrate_template`) is a short loop over named pieces,
each a template compiled per model with ``forceinline`` (LLVM inlines it into
its caller, so the compiled integrator is one function, as fast as one written
in a piece), in the manner of scipy's ``ivp.py``, which keeps
``find_active_events``, ``solve_event_equation`` and ``handle_events`` apart:

* the right-hand side of a stage (:func:`_rhs_template`) and the
  classification of a state (:func:`_classify_template`, :func:`_still_template`);
* the start of a motion: its first classification (:func:`_start_template`)
  and the initial step (:func:`_first_step_template`);
* after an accepted step, Hairer's stiffness test (:func:`_stiffness_template`)
  and the step-size controller (:func:`_next_step_template`); a step size too
  small to go on (:func:`_stalled_template`);
* where a step leaves its stage, the first state off it
  (:func:`_locate_template`, rooting with :func:`_zero_template`) and the
  event there (:func:`_event_template`, deciding the next stage with
  :func:`_next_stage_template`).

The step and the dense output of a method come from its module
(:mod:`phasemap.motion.integrate.dopri5`, :mod:`phasemap.motion.integrate.dop853`).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from phasemap.motion.integrate import dop853 as _dop853
from phasemap.motion.integrate import dopri5 as _dopri5
from phasemap.core import numerics as nx
from phasemap.core import events as ev
from phasemap.core.compile import grow

#: Modules compiled into these kernels besides this one (see phasemap.core.compile).
SOURCES = (_dopri5, _dop853)

#: What an integrator returns (:func:`_integrate_template`): the fate (an event code), the
#: time and state it ends at, the reversals and steps counted, the saved points (rows
#: t, branch, y...), the events (rows t, kind, branch after, y...) and the states at
#: the requested times (:func:`phasemap.motion.integrate.unpack` names the columns).
Integrated = namedtuple("Integrated", ["fate", "t", "y", "n_reversals", "n_steps",
                                       "points", "events", "y_eval"])

SAFETY, FAC_MIN, FAC_MAX = 0.9, 0.2, 10.0
EPS = np.finfo(np.float64).eps

# Compile-time structure of the model being compiled (see phasemap.core.compile).
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
BOUND_ROW = np.zeros(0, dtype=np.int64)
INSIDE = None
DOMAIN = None
REST_SPEED = None
FILL = None
BOUNDED = None
RHS = None
CLASSIFY = None
ON_STAGE = None
GOES_ON = None
MOVING = None
STILL = None
INDICATOR = None
ZERO = None
DIP = None
LOCATE = None
START = None
STAGE_COEFFICIENT = None
LEAVE = None
FIRST_STEP = None
STALLED = None
STIFFNESS = None
NEXT_STEP = None
NEXT_STAGE = None
EVENT = None
#: Columns of a branch row watched for zeros that end a stage: reactions, coefficient.
WATCH = np.zeros(0, dtype=np.int64)
# ... and of the method (a module such as phasemap.motion.integrate.dopri5; see METHODS)
STEP = None
DENSE = None
N_STAGES = 7
FSAL = 6
N_DENSE = 5
EXPONENT = 0.2
STIFF_BOUND = 3.25


# ------------------------------------------------------------ plain helpers

@njit(cache=True)
def push(a, n, t, code, branch, y):
    """Append the row (t, code[, branch], y...) at ``n`` (growing ``a``); return (a, n + 1).

    Saved points have two head columns (t, branch), events three (t, kind, branch).
    """
    a = grow(a, n + 1)
    k = a.shape[1] - y.shape[0]
    a[n, 0] = t
    a[n, 1] = code
    if k == 3:
        a[n, 2] = branch
    a[n, k:] = y
    return a, n + 1


@njit(cache=True)
def norm(e, y0, y1, rtol, atol):
    """RMS of ``e`` over the error scale ``atol + rtol max(|y0|, |y1|)``."""
    acc = 0.0
    for i in range(e.shape[0]):
        sk = atol + rtol * max(abs(y0[i]), abs(y1[i]))
        acc += (e[i] / sk) ** 2
    return np.sqrt(acc / e.shape[0])


@njit(cache=True)
def dense(r, theta, y):
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


# ------------------------------------------------------ the state and its stage

def _fill_template(v, y):
    """Put the integrated state ``y`` into the input vector ``v`` and derive the rest."""
    for i in range(Y_SLOT.shape[0]):
        s = Y_SLOT[i]
        if s >= 0:
            v[s] = y[i]
    DERIVE(v)


def _bounded_template(y):
    """The integrated state ``y`` lies within the bounds of its variables."""
    for i in range(y.shape[0]):
        if y[i] < LOWER[i] or y[i] > UPPER[i]:
            return False
    return True


def _inside_template(v, y):
    """The integrated state lies in the model's domain: the bounds of its variables
    and the model's own ``inside`` condition (``v`` is filled with ``y``)."""
    if not BOUNDED(y):
        return False
    FILL(v, y)
    return DOMAIN(v)


def _rhs_template(v, y, branch, K, k):
    """dy/dt on the stage of ``branch`` into row ``k`` of the stage array ``K``
    (NaN where the branch has no solution).

    The branch row comes back as a tuple from the inlined ``BRANCH_ROW``.  The
    stage is addressed by its row index, not passed as a view ``K[k]``: a view
    made at each of the six (DOPRI5) or twelve (DOP853) calls per step costs a
    reference-count increment and decrement (atomic), measured at 40 % of a
    step of the wheel (BENCHMARKS.md, "Fate map of the wheel").
    """
    FILL(v, y)
    r = BRANCH_ROW(v, branch)
    for j in range(N_DOF):
        K[k, j] = y[N_DOF + j]
        K[k, N_DOF + j] = r[ACC_COL[j]]


def _classify_template(v, y, out):
    """Classify the state ``y``: (n_solutions, first admissible branch, lost, singular)."""
    FILL(v, y)
    POINT(v, out)
    return ev.summary(out, STICK)


def _on_stage_template(n, adm, out, branch, coef_sign):
    """A classification (``n``, ``adm`` of the rows ``out``) goes on with the stage of
    ``branch``: the unique solution, the same branch, the sign ``coef_sign`` of
    its coefficient kept (0: not watched)."""
    return n == 1 and adm == branch and (coef_sign == 0.0
                                       or out[branch, nx.COEF] * coef_sign > 0.0)


def _goes_on_template(v, y1, out, branch, coef_sign):
    """After an accepted step to ``y1`` (``v`` holds it and its derived inputs, as the
    step's last right-hand side left it): the stage of ``branch`` goes on.

    The decision of ``ON_STAGE`` on the full classification and of ``INSIDE``, bit
    for bit, from less: the stage goes on where its row is the one solution
    (admissible, or a separation) with its coefficient's sign kept, no other row is
    a solution or a continuum, and the state is inside the domain.  Moving, the
    classification computes only the rows of the velocity's direction (the others
    are absent, among them the stick row); ``MOVING`` (generated,
    :func:`phasemap.core.codegen.moving_test`) computes those with the same arguments and
    no stores, so that LLVM keeps what a status or the coefficient reads, and the
    coefficient goes into ``out``, which ``STALLED`` reads.  At rest, or within its
    tolerance, every row applies, and the full classification decides.  The events
    keep the full classification (``STILL``, ``CLASSIFY``).
    """
    vel = v[Y_SLOT[VEL_Y]]
    if abs(vel) <= REST_SPEED(v):
        POINT(v, out)
        n, adm, lost, sing = ev.summary(out, STICK)
        on = ON_STAGE(n, adm, out, branch, coef_sign)
    else:
        sole, coef = MOVING(v, branch)
        out[branch, nx.COEF] = coef
        on = sole and (coef_sign == 0.0 or coef * coef_sign > 0.0)
    return on and BOUNDED(y1) and DOMAIN(v)


def _still_template(v, yb, out, branch, coef_sign):
    """The state ``yb`` is still on the stage of ``branch`` (ON_STAGE) and inside
    the domain (``out``: its rows)."""
    n, adm, lost, sing = CLASSIFY(v, yb, out)
    return ON_STAGE(n, adm, out, branch, coef_sign) and INSIDE(v, yb)


def _stage_coefficient_template(out, branch):
    """(coefficient, its sign) of the senior derivative on the stage of ``branch`` from its
    classified row (0, 0 for the stick branch and for no branch: not watched)."""
    coef = out[branch, nx.COEF] if (branch >= 0 and branch != STICK) else 0.0
    return coef, 1.0 if coef > 0.0 else (-1.0 if coef < 0.0 else 0.0)


def _leave_template(y, out):
    """The state ``y`` (classified into ``out``) lies on a closed bound of its domain and
    moves out through it: put it exactly on that bound and return True.

    On the bound is the classification's own rule, as a velocity is zero where the
    stick branch applies: a branch that exists only on that bound applies at ``y``
    (``BOUND_ROW``: a declared system's edge row, within the tie tolerance of the
    edge; :mod:`phasemap.declare.edges`).  Moving out is the bound's coordinate rate
    pointing out of the domain while the motion's velocity is not zero.  The motion
    then leaves the domain, whatever the state classifies as (the ladder lying flat
    with omega > 0: its edge rows find the foot sticking and the top leaving the
    wall, a motion through the floor).  A model without such rows reaches the bound
    by crossing it (see INSIDE).
    """
    if STICK >= 0 and out[STICK, nx.STATUS] != nx.ABSENT:
        return False  # at rest: the classification decides
    for b in range(BOUND_ROW.shape[0]):
        k = BOUND_ROW[b]
        if k < 0 or out[b, nx.STATUS] == nx.ABSENT:
            continue
        i = k // 2
        rate = y[N_DOF + i] if i < N_DOF else 0.0
        if (rate > 0.0) if k % 2 == 1 else (rate < 0.0):
            y[i] = UPPER[i] if k % 2 == 1 else LOWER[i]
            return True
    return False


# ------------------------------------------------------------- the start

def _start_template(v, y, out):
    """How the motion from ``y`` starts: (kind, branch), ``START`` and the unique
    admissible branch, or the fate (branch -1, or the stick branch at rest)."""
    n, branch, lost, sing = CLASSIFY(v, y, out)
    kind = ev.START
    if LEAVE(y, out):  # on a bound of the domain, moving out
        branch = -1
        kind = ev.LEFT_DOMAIN
    elif n != 1:
        branch = -1
        kind = ev.fate_without_unique(n, lost, sing)
    elif out[branch, nx.STATUS] == nx.SEPARATION:  # the only motion leaves a contact
        branch = -1
        kind = ev.CONTACT_LOST
    elif branch == STICK and STICK_IS_REST:
        kind = ev.REST
    return kind, branch


def _first_step_template(v, y, branch, K, yt, err, t_end, rtol, atol, h_max):
    """Hairer's initial step (``hinit``) from the scaled sizes of y and y'; leaves
    ``K[0] = f(y)``."""
    ny = y.shape[0]
    RHS(v, y, branch, K, 0)
    d0 = norm(y, y, y, rtol, atol)
    d1 = norm(K[0], y, y, rtol, atol)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, t_end, h_max)
    for i in range(ny):
        yt[i] = y[i] + h0 * K[0, i]
    RHS(v, yt, branch, K, 1)
    for i in range(ny):
        err[i] = (K[1, i] - K[0, i]) / h0
    d2 = norm(err, y, y, rtol, atol)
    dm = max(d1, d2)
    h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else (0.01 / dm) ** EXPONENT
    h = min(100.0 * h0, h1, h_max)
    if not (h > 0.0):
        h = 1e-6
    return h


# --------------------------------------------------------- step acceptance

def _stalled_template(v, y, h, t_end, branch, coef_sign, coef0, coef_scale, out, K, yb):
    """The fate where the step size has fallen below what double precision resolves.

    ``singular`` where the active coefficient has fallen below 1e-6 of its scale,
    else ``step_failure``; but where the stage's branch has no solution just ahead
    (probed along f(y) up to 1e9 times the step), that classification's fate.
    """
    c = out[branch, nx.COEF] if coef_sign != 0.0 else coef0
    fate = ev.SINGULAR if abs(c) < 1e-6 * coef_scale else ev.STEP_FAILURE
    s = max(h, 1e-14 * t_end)
    for _ in range(9):
        for i in range(y.shape[0]):
            yb[i] = y[i] + s * K[0, i]
        n2, adm2, lost2, sing2 = CLASSIFY(v, yb, out)
        if n2 != 1:
            return ev.fate_without_unique(n2, lost2, sing2)
        if adm2 != branch:
            break
        s *= 10.0
    return fate


def _stiffness_template(K, y1, yt, h, stiff_hits, calm):
    """Hairer's stiffness detection (``dopri5``, ``dop853``) after an accepted step:
    ``(stiff_hits, calm, stiff)``.

    h |lambda| ~ h ||f(y1) - f(yt)|| / ||y1 - yt||, yt the point of the last
    stage before f(y1) (also at t + h); beyond the method's stability boundary
    for 15 accepted steps in a row (6 calm steps reset the count) the motion is
    stiff here (a coefficient of the senior derivative near zero), and an
    explicit method would crawl.
    """
    num = 0.0
    den = 0.0
    for i in range(y1.shape[0]):
        num += (K[FSAL, i] - K[FSAL - 1, i]) ** 2
        den += (y1[i] - yt[i]) ** 2
    if den > 0.0 and h * np.sqrt(num / den) > STIFF_BOUND:
        return stiff_hits + 1, 0, stiff_hits + 1 >= 15
    calm += 1
    return (0 if calm >= 6 else stiff_hits), calm, False


def _next_step_template(h, e, h_prev_ok, h_max):
    """The next step size after a step of size ``h`` with error norm ``e`` was accepted
    (no growth right after a rejection)."""
    fac = FAC_MAX if e == 0.0 else min(FAC_MAX, max(FAC_MIN, SAFETY * e ** -EXPONENT))
    if not h_prev_ok:
        fac = min(fac, 1.0)
    return min(h * fac, h_max)


# ---------------------------------------------------------------- events

def _indicator_template(v, r, theta, branch, col, yb):
    """At ``theta`` of the step (dense output ``r``, into ``yb``): the stage's velocity
    (``col`` < 0) or column ``col`` of its branch row."""
    dense(r, theta, yb)
    if col < 0:
        return yb[VEL_Y]
    FILL(v, yb)
    return BRANCH_ROW(v, branch)[col]


def _zero_template(v, r, branch, col, sg, level, fa, fb, h, t, yb, b_end):
    """Illinois on the step for the zero of ``sg`` times an indicator (see INDICATOR)
    minus ``level``, from ``fa`` > 0 at theta = 0 and ``fb`` <= 0 at theta = ``b_end``:
    ``(a, b)``, a bracket of width 4 eps in time."""
    a, b = 0.0, b_end
    side = 0
    for _ in range(100):
        c = (a * fb - b * fa) / (fb - fa)
        if not (a < c < b):
            c = 0.5 * (a + b)
        fc = sg * INDICATOR(v, r, c, branch, col, yb) - level
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


def _dip_template(r, d, rest, yb):
    """Where in the step (dense output ``r``) the stage's velocity, moving in its
    direction ``d`` at both ends, comes closest to zero, if it comes to the speed that
    classification counts as rest (``rest``) there: a velocity zero that neither end of
    the step shows (a pair of reversals, or a stop, inside one step); else 2.  Called
    where the velocity's rate turns from against ``d`` to along it inside the step, so
    that ``d v`` has one minimum in it: a golden-section search, to 1e-13 of the step."""
    a, b = 0.0, 1.0
    g = 0.6180339887498949
    c, e = b - g * (b - a), a + g * (b - a)
    dense(r, c, yb)
    fc = d * yb[VEL_Y]
    dense(r, e, yb)
    fe = d * yb[VEL_Y]
    for _ in range(64):
        if fc <= rest:
            return c
        if fc < fe:
            b, e, fe = e, c, fc
            c = b - g * (b - a)
            dense(r, c, yb)
            fc = d * yb[VEL_Y]
        else:
            a, c, fc = c, e, fe
            e = a + g * (b - a)
            dense(r, e, yb)
            fe = d * yb[VEL_Y]
    return c if fc <= rest else 2.0


def _locate_template(v, y, y1, h, t, branch, coef_sign, r, out, yb, zs, theta_dip):
    """The first theta of the step ``y`` -> ``y1`` (dense output ``r``) where the stage
    stops being the unique solution, to 2 eps in time (``zs``: scratch, one row per
    WATCH column and one for the velocity).

    Classification decides where a stage ends, and is what bisection would call
    fifty times.  Most stages end where a continuous quantity of their branch
    row crosses zero: the velocity (a reversal or a stop), a reaction (a
    contact released), the coefficient of the senior derivative (a singular
    state).  Those crossing zero in the step are rooted on the dense output
    (Illinois: a few row evaluations each), and the earliest zero that
    classification confirms (the stage at it or 1e-11 or 1e-9 of the step
    before it, not at it or 1e-13 or 1e-11 after it) leaves a bracket of 4 eps
    in time, or 1e-11 to 1e-9 of the step, for bisection.  The velocity is
    rooted where it reaches the speed that classification counts as rest
    (``REST_SPEED``), not at its zero: the stage ends there, so its bracket
    needs a step or two of bisection, not the dozen (each a classification)
    that the 1e-11 before an exact zero took.  Anything else (a friction cone left at stick,
    another branch turning admissible, the domain's edge) is bisected from the
    whole step.  ``theta_dip`` <= 1: the velocity is at rest speed there, inside the
    step, though not at its end (DIP): its zero before it is a candidate too.
    """
    nz = 0
    d = DIRECTIONS[branch]
    rest = REST_SPEED(v)
    if d != 0.0 and d * y[VEL_Y] > rest and (d * y1[VEL_Y] <= rest or theta_dip <= 1.0):
        b_end, fb = 1.0, d * y1[VEL_Y] - rest
        if fb > 0.0:
            dense(r, theta_dip, yb)
            b_end, fb = theta_dip, d * yb[VEL_Y] - rest
        zs[nz, 0], zs[nz, 1] = ZERO(v, r, branch, int(-1), d, rest, d * y[VEL_Y] - rest,
                                     fb, h, t, yb, b_end)
        nz += 1
    if WATCH.shape[0] > 0:
        FILL(v, y)
        g0 = BRANCH_ROW(v, branch)
        FILL(v, y1)
        g1 = BRANCH_ROW(v, branch)
        for q in range(WATCH.shape[0]):
            a0, a1 = g0[WATCH[q]], g1[WATCH[q]]
            if a0 * a1 < 0.0:
                sg = 1.0 if a0 > 0.0 else -1.0
                zs[nz, 0], zs[nz, 1] = ZERO(v, r, branch, WATCH[q], sg, 0.0, sg * a0, sg * a1,
                                             h, t, yb, 1.0)
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
            dense(r, c_hi, yb)
            if not STILL(v, yb, out, branch, coef_sign):
                break
        else:
            continue
        for before in (0.0, 1e-11, 1e-9):
            c_lo = max(0.0, a - before)
            dense(r, c_lo, yb)
            if STILL(v, yb, out, branch, coef_sign):
                lo, hi = c_lo, c_hi
                break
        break
    for _ in range(200):
        if (hi - lo) * h <= 2.0 * EPS * max(abs(t), abs(h)):
            break
        mid = 0.5 * (lo + hi)
        dense(r, mid, yb)
        if STILL(v, yb, out, branch, coef_sign):
            lo = mid
        else:
            hi = mid
    return hi


def _next_stage_template(out, n, adm, lost, sing, branch, vel_zero):
    """What happens at an event that ends the stage of ``branch``, from the classification
    there (``n``, ``adm``, ``lost``, ``sing`` of the rows ``out``): ``(kind, branch)``,
    branch -1 where the motion ends (and for ``rest``, the stick branch)."""
    if n != 1:
        return ev.fate_without_unique(n, lost, sing), -1
    if out[adm, nx.STATUS] == nx.SEPARATION:
        return ev.CONTACT_LOST, -1  # the only motion from here leaves a contact
    if adm == STICK:
        return (ev.REST if STICK_IS_REST else ev.STICK), adm
    if branch == STICK:
        return ev.SLIP, adm
    if DIRECTIONS[adm] == -DIRECTIONS[branch]:
        return ev.REVERSAL, adm
    if adm != branch or vel_zero:
        return ev.SWITCH, adm  # (or the velocity touched zero and the motion goes on)
    return ev.SINGULAR, -1  # same branch, its coefficient changed sign


def _event_template(v, y, t, t_prev, h, theta_end, r, branch, coef_sign, out, yb):
    """The event where the stage of ``branch`` stopped: at ``t`` (theta_end of the step
    of size ``h`` from ``t_prev``, dense output ``r``), state ``y`` (updated).

    Returns ``(t, kind, branch)`` (see NEXT_STAGE); kind -1 where the stop was a
    rounding flicker and the stage goes on from ``(t, y)``.  At a velocity zero
    the velocity is set to exactly 0.  Within 1e-12 of a boundary the tie rules
    can admit two branches (stick by its inclusive friction limit, and a slip
    whose starting acceleration just clears its tolerance) or none, and a state
    one rounding error away can still classify as the running stage (a grazing
    reaction).  A genuine paradox persists past the boundary; a tie does not:
    probe just beyond it on this step's dense output (extrapolated by at most
    1e-6 of the step) for the first state that is decided, and unique if any is.
    """
    if not INSIDE(v, y):  # the state leaves the model's domain (the ladder lies flat)
        for i in range(y.shape[0]):
            y[i] = min(max(y[i], LOWER[i]), UPPER[i])
        return t, ev.LEFT_DOMAIN, -1
    d = DIRECTIONS[branch]
    n, adm, lost, sing = CLASSIFY(v, y, out)
    vel_zero = d != 0.0 and (d * y[VEL_Y] <= 0.0 or out[STICK, nx.STATUS] != nx.ABSENT)
    if not vel_zero and LEAVE(y, out):  # on a bound (its tie band), moving out
        return t, ev.LEFT_DOMAIN, -1
    if vel_zero:
        y[VEL_Y] = 0.0
        n, adm, lost, sing = CLASSIFY(v, y, out)
    elif n != 1 or ON_STAGE(n, adm, out, branch, coef_sign):
        first_bad = -1.0
        decided = False
        for k in range(1, 10):
            theta = theta_end + 10.0 ** k * 2.0 * EPS * max(abs(t_prev), abs(h)) / h
            if theta > 1.0 + 1e-6:
                break
            dense(r, theta, yb)
            n2, adm2, lost2, sing2 = CLASSIFY(v, yb, out)
            stage = ON_STAGE(n2, adm2, out, branch, coef_sign)
            if not stage and first_bad < 0.0:
                first_bad = theta
            if n2 == 1 and not stage:
                decided = True
                t = t_prev + theta * h
                for i in range(y.shape[0]):
                    y[i] = yb[i]
                break
        if not decided and first_bad >= 0.0:
            t = t_prev + first_bad * h
            dense(r, first_bad, y)
        n, adm, lost, sing = CLASSIFY(v, y, out)
        if n == 1 and adm == branch and not decided and first_bad < 0.0:
            return t, -1, branch  # a rounding flicker: the stage goes on from here
    kind, new_branch = NEXT_STAGE(out, n, adm, lost, sing, branch, vel_zero)
    return t, kind, new_branch


# ------------------------------------------------------------ the integrator

def _integrate_template(v, y0, t_end, rtol, atol, h_max, max_steps, max_events, save, t_eval,
                        stop):
    """Integrate from ``y0`` (positions then velocities) at t = 0 until a fate or ``t_end``.

    ``v`` is the model's input vector holding the parameters (its state slots
    are overwritten).  With ``save`` every accepted step is recorded; the
    states at the sorted times ``t_eval`` are always recorded.  ``stop`` (one
    int64) is read at every step: set nonzero by another thread (a Ctrl-C while
    a fate map runs), the motion ends there, as at ``max_steps``.

    Returns an :data:`Integrated` ``(fate, t, y, n_reversals, n_steps, points, events,
    y_eval)``:
    ``points`` has one row (t, branch, y...) per saved point, ``events`` one row
    (t, kind, branch after, y...) per event (:func:`phasemap.motion.integrate.unpack`
    names their columns), ``y_eval`` the states at the first ``len(y_eval)``
    times of ``t_eval``.  Four arrays, not one per column: each array handed
    back to Python costs about a microsecond and a half of boxing, a tenth of a
    short motion's whole call.
    """
    ny = 2 * N_DOF
    out = np.empty((N_BRANCHES, N_FIELDS))
    K = np.empty((N_STAGES, ny))  # the stages; K[0] = f(y)
    yt = np.empty(ny)
    y1 = np.empty(ny)
    err = np.empty(ny)
    r = np.empty((N_DENSE, ny))
    yb = np.empty(ny)
    zs = np.empty((WATCH.shape[0] + 1, 2))  # zeros ending the stage in a step (LOCATE)
    pts = np.empty((64 if save else 1, 2 + ny))  # saved points: t, branch, y
    n_saved = int(0)  # int(): see phase.tracer.PIECES
    evs = np.empty((16, 3 + ny))  # events: t, kind, branch after, y
    n_ev = int(0)
    y_eval = np.empty((t_eval.shape[0], ny))
    n_eval = 0

    y = y0.copy()
    t = 0.0
    n_rev = 0
    n_steps = 0

    kind, branch = START(v, y, out)
    evs, n_ev = push(evs, n_ev, t, kind, branch, y)
    if save:
        pts, n_saved = push(pts, n_saved, t, branch, branch, y)
    fate = -1 if kind == ev.START else kind
    coef0, coef_sign = STAGE_COEFFICIENT(out, branch)
    # the scale of the coefficient: its largest size at a stage start of this motion
    # (switches close to a singular state start stages with a coefficient already small)
    coef_scale = abs(coef0)

    h = 0.0
    h_prev_ok = True
    flickers = 0
    stiff_hits = int(0)  # Hairer's stiffness detection: consecutive steps with h |lambda| > bound
    calm = int(0)
    if fate < 0:
        h = FIRST_STEP(v, y, branch, K, yt, err, t_end, rtol, atol, h_max)

    while fate < 0:
        if n_steps >= max_steps or stop[0] != 0:
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
            fate = STALLED(v, y, h, t_end, branch, coef_sign, coef0, coef_scale, out, K, yb)
            break
        # -- one step of the method ------------------------------------------
        e = STEP(v, y, h, branch, K, yt, y1, rtol, atol)
        n_steps += 1
        if not (e <= 1.0):  # also rejects NaN
            fac = FAC_MIN if not (e == e) else max(FAC_MIN, SAFETY * e ** -EXPONENT)
            h *= fac
            h_prev_ok = False
            continue
        stiff_hits, calm, stiff = STIFFNESS(K, y1, yt, h, stiff_hits, calm)
        if stiff:
            fate = ev.STIFF
            break
        # v holds y1 and its derived inputs from the last stage of the step
        still = GOES_ON(v, y1, out, branch, coef_sign)
        theta_end = 1.0
        theta_dip = 2.0
        d = DIRECTIONS[branch]
        rest = REST_SPEED(v)
        made = (d != 0.0 and d * y[VEL_Y] > rest and d * y1[VEL_Y] > rest
                and d * K[0, VEL_Y] < 0.0 < d * K[FSAL, VEL_Y])
        if made:    # the velocity's rate turns inside the step: its minimum may be a zero
            DENSE(v, y, y1, h, branch, K, yt, r)
            theta_dip = DIP(r, d, rest, yb)
            if theta_dip <= 1.0:   # (where the stage holds there after all, no event)
                dense(r, theta_dip, yb)
                if STILL(v, yb, out, branch, coef_sign):
                    theta_dip = 2.0
                else:
                    still = False
        # the dense output, only where it is used: to locate an event, at requested times
        if not made and (not still or (n_eval < t_eval.shape[0]
                                       and t_eval[n_eval] <= (t_end if last else t + h))):
            DENSE(v, y, y1, h, branch, K, yt, r)
        if not still:
            theta_end = LOCATE(v, y, y1, h, t, branch, coef_sign, r, out, yb, zs, theta_dip)
            dense(r, theta_end, y1)
        t1 = t + theta_end * h
        if theta_end == 1.0 and last:
            t1 = t_end
        # states at the requested times inside this step
        while n_eval < t_eval.shape[0] and t_eval[n_eval] <= t1:
            dense(r, min(1.0, max(0.0, (t_eval[n_eval] - t) / h)), yb)
            y_eval[n_eval] = yb
            n_eval += 1
        if still:
            flickers = 0
            t = t1
            for i in range(ny):
                y[i] = y1[i]
                K[0, i] = K[FSAL, i]
            if save:
                pts, n_saved = push(pts, n_saved, t, branch, branch, y)
            h = NEXT_STEP(h, e, h_prev_ok, h_max)
            h_prev_ok = True
            continue

        # -- an event at t1, state y1 --------------------------------------
        for i in range(ny):
            y[i] = y1[i]
        t, kind, new_branch = EVENT(v, y, t1, t, h, theta_end, r, branch, coef_sign, out, yb)
        action, fate, flickers = ev.after_event(kind, flickers, n_ev, max_events)
        if action == ev.GO_ON:  # a rounding flicker: the stage goes on from here
            RHS(v, y, branch, K, 0)
            continue
        if kind == ev.REVERSAL:
            n_rev += 1
        if action == ev.END:
            break
        evs, n_ev = push(evs, n_ev, t, kind, new_branch, y)
        if save:
            pts, n_saved = push(pts, n_saved, t, new_branch, new_branch, y)
        branch = new_branch
        coef0, coef_sign = STAGE_COEFFICIENT(out, branch)
        coef_scale = max(coef_scale, abs(coef0))
        RHS(v, y, branch, K, 0)
        h_prev_ok = True

    # -- the fate, as the last event (unless the motion never started) ------
    if not (n_ev == 1 and fate == evs[0, 1]):
        after = STICK if fate == ev.REST else -1
        evs, n_ev = push(evs, n_ev, t, fate, after, y)
        if save and (pts[n_saved - 1, 0] != t or fate == ev.REST):
            pts, n_saved = push(pts, n_saved, t, STICK if fate == ev.REST
                                else pts[n_saved - 1, 1], 0.0, y)
    if fate == ev.REST:
        # at rest for good: the requested times after the stop see the rest state
        while n_eval < t_eval.shape[0] and t_eval[n_eval] <= t_end:
            y_eval[n_eval] = y
            n_eval += 1
    return Integrated(fate, t, y, n_rev, n_steps, pts[:n_saved], evs[:n_ev], y_eval[:n_eval])


#: The pieces of the integrator that do not depend on the method: (name, template,
#: inline).  The small per-step helpers inline into their callers, so that a
#: right-hand side is one call (a step makes six or twelve of them) with the branch
#: physics inlined, and no array is passed between helpers; the right-hand side, the
#: root finder and the event location are called.
PIECES = (("FILL", _fill_template, True),
          ("BOUNDED", _bounded_template, True),
          ("INSIDE", _inside_template, True),
          ("RHS", _rhs_template, False),
          ("CLASSIFY", _classify_template, True),
          ("ON_STAGE", _on_stage_template, True),
          ("GOES_ON", _goes_on_template, True),
          ("STILL", _still_template, True),
          ("STAGE_COEFFICIENT", _stage_coefficient_template, True),
          ("LEAVE", _leave_template, True),
          ("INDICATOR", _indicator_template, True),
          ("ZERO", _zero_template, False),
          ("DIP", _dip_template, False),
          ("LOCATE", _locate_template, False),
          ("START", _start_template, True),
          ("STALLED", _stalled_template, True),
          ("NEXT_STAGE", _next_stage_template, True),
          ("EVENT", _event_template, True))
#: ... and those compiled with the method's constants (after its ``STEP`` and ``DENSE``),
#: which inline into the integrator (one call site each); INTEGRATE is the integrator.
METHOD_PIECES = (("FIRST_STEP", _first_step_template, True),
                 ("STIFFNESS", _stiffness_template, True),
                 ("NEXT_STEP", _next_step_template, True),
                 ("INTEGRATE", _integrate_template, False))
