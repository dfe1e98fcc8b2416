"""What happens along a motion: the named events of trajectories and phase curves.

One enumeration serves the time integrator (:func:`phasemap.simulate`), the
first-integral tracer (:func:`phasemap.phase_curve`) and the fate maps, in
the manner of diffrax's ``RESULTS``: named members with messages, never magic
integers.  The numba kernels use the plain integer values below.

Events that continue the motion:

* ``start``: the motion begins on the branch ``classify()`` finds admissible;
* ``reversal``: the relative velocity reached zero and the motion went on in
  the opposite direction;
* ``stick``: the relative velocity reached zero and the stick branch took over
  while other coordinates keep moving (the elliptic pendulum's slider);
* ``slip``: the stick branch stopped being admissible and a slip began;
* ``switch``: another branch took over without a velocity zero (the sign of
  the elliptic pendulum's two-sided guide reaction changed);
* ``iwc``: an impact without collision: where the accelerations have no solution
  because the slip forces a contact into the obstacle (a Painleve inconsistency), an
  impulse at zero normal velocity jumps the velocities (:mod:`phasemap.motion.impact`)
  and the motion goes on from there (:func:`phasemap.simulate`, for a declared system
  with one contact).
* ``liftoff``, ``impact``, ``recontact``, ``zeno``: a contact opened, a gap closed with
  an impulse or without one, or the impacts of a bouncing contact accumulated: the
  motion through contact changes in a declared system's full coordinates
  (:mod:`phasemap.motion.hybrid`).
* ``jam``: a dynamic jam: a slip reached the point where the coefficient of its normal
  acceleration vanishes (the Genot-Brogliato singular point; its normal force grows
  without bound on the way, its impulse stays bounded), and a tangential impulse at zero
  normal velocity stopped the slip there (:mod:`phasemap.motion.hybrid`).

Events that end it (the *fate*):

* ``rest``: stopped in a stagnation zone, for good;
* ``contact_lost``: a one-sided contact would have to pull; the body leaves it
  and the model no longer applies;
* ``no_solution``: a state with no solution for the accelerations (Painleve
  inconsistency): the model predicts no motion from here;
* ``indeterminate``: a state with two or more solutions: the model cannot say
  which motion follows, and the tracer does not choose;
* ``continuum``: a whole family of accelerations solves the equations;
* ``singular``: the coefficient of the senior derivative reached zero (the
  accelerations grow without bound on the way);
* ``horizon``: still moving at the end of the time or angle range asked for;
* ``left_domain``: the motion reached an edge of the model's domain (the
  ladder lying flat at phi = pi/2); :attr:`phasemap.Dynamics.edges` says what
  each edge means for the body;
* ``max_events``: the number of events or stages asked for ran out;
* ``max_steps``: the number of integration steps asked for ran out;
* ``step_failure``: the step size fell below what double precision resolves
  (reported with the state reached; never silently continued);
* ``stiff``: the motion is stiff here (typically a coefficient of the senior
  derivative is close to zero, such as the ladder's 2 - f^2 for f near sqrt
  2), and the explicit integrator stops instead of crawling; the
  first-integral tracer :func:`phasemap.phase_curve` handles such cases.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from phasemap.core import numerics as nx

START = 0
REVERSAL = 1
STICK = 2
SLIP = 3
SWITCH = 4
REST = 5
CONTACT_LOST = 6
NO_SOLUTION = 7
INDETERMINATE = 8
CONTINUUM = 9
SINGULAR = 10
HORIZON = 11
MAX_EVENTS = 12
STEP_FAILURE = 13
STIFF = 14
LEFT_DOMAIN = 15
MAX_STEPS = 16
IWC = 17
LIFTOFF = 18
IMPACT = 19
RECONTACT = 20
ZENO = 21
JAM = 22

#: The events that end a motion (its fate), named one by one: event codes are
#: append-only (atlases and fate maps store them), so a later event that continues a
#: motion takes the next free code, and no order of codes says which events end one.
FATES = frozenset({REST, CONTACT_LOST, NO_SOLUTION, INDETERMINATE, CONTINUUM, SINGULAR,
                   HORIZON, MAX_EVENTS, STEP_FAILURE, STIFF, LEFT_DOMAIN, MAX_STEPS})

#: ``TERMINAL[code]``: whether the event of that code ends a motion (:data:`FATES`), as
#: an array the compiled rule :func:`after_event` reads.
TERMINAL = np.array([code in FATES for code in range(JAM + 1)])

#: What follows an event (:func:`after_event`): the running stage goes on (the event
#: was a rounding flicker), the next stage starts, or the motion ends.
GO_ON, NEXT_STAGE, END = 0, 1, 2


@njit(cache=True, forceinline=True)
def after_event(kind, flickers, n_events, max_events):
    """The one rule for what follows an event, shared by the integrator
    (:mod:`phasemap.motion.integrate.templates`), the phase-curve tracer
    (:mod:`phasemap.motion.phase.tracer`) and the staged scipy driver
    (:func:`phasemap.motion.workprecision.solve_ivp_staged`).

    ``kind`` is the event's code, or -1 where the stage's end was a rounding flicker;
    ``flickers`` the flickers in a row before it; ``n_events`` the events recorded so
    far, of at most ``max_events``.  Returns ``(action, fate, flickers)``:

    * ``GO_ON``: a flicker; the stage goes on (``fate`` -1), or ends the motion with
      ``step_failure`` after :data:`MAX_FLICKERS` in a row (``END``);
    * ``END`` with ``fate`` the event itself where it is terminal (:data:`TERMINAL`),
      or ``max_events`` where the events ran out;
    * ``NEXT_STAGE``: the motion goes on in the stage the event decided.

    >>> after_event(STICK, 0, 3, 10), after_event(REST, 0, 3, 10)
    ((1, -1, 0), (2, 5, 0))
    >>> after_event(-1, 8, 3, 10), after_event(STICK, 0, 10, 10)
    ((2, 13, 9), (2, 12, 0))
    """
    if kind < 0:
        flickers += 1
        if flickers > MAX_FLICKERS:
            return END, STEP_FAILURE, flickers
        return GO_ON, -1, flickers
    if TERMINAL[kind]:
        return END, kind, 0
    if n_events >= max_events:
        return END, MAX_EVENTS, 0
    return NEXT_STAGE, -1, 0


#: The most rounding flickers in a row (an event whose state the classification keeps
#: on the running stage, so the stage goes on) before a motion ends with
#: ``step_failure``: the integrator and :func:`phasemap.motion.workprecision.solve_ivp_staged`.
MAX_FLICKERS = 8


@njit(cache=True)
def fate_without_unique(n, lost, singular):
    """The fate at a state whose classification is not unique (``n`` != 1).

    No solution is ``contact_lost`` where a branch needs a one-sided contact
    to pull, ``singular`` where the senior-derivative coefficient vanishes,
    else ``no_solution``; a continuum is ``continuum``; two or more isolated
    solutions are ``indeterminate``.
    """
    if n == nx.N_NONE:
        if lost:
            return CONTACT_LOST
        return SINGULAR if singular else NO_SOLUTION
    if n == nx.N_CONTINUUM:
        return CONTINUUM
    return INDETERMINATE


@njit(cache=True, error_model="numpy", forceinline=True)
def first_admissible(out):
    """The first row of the classified rows ``out`` that is a solution (admissible, or a
    separation from a one-sided contact), or -1: the branch a unique motion takes."""
    for b in range(out.shape[0]):
        st = out[b, nx.STATUS]
        if st == nx.ADMISSIBLE or st == nx.SEPARATION:
            return b
    return -1


@njit(cache=True, error_model="numpy", forceinline=True)
def summary(out, stick):
    """(n_solutions, first admissible branch, contact_lost, singular) of classified rows
    (``stick``: the row of the stick branch, -1 if none)."""
    n, stag, lost, sing = nx.summarize(out, stick)
    return n, first_admissible(out), lost, sing


class Event(nx.Coded):
    """A named event of a motion; the members of :data:`FATES` end it.

    The ``fate`` layer of a fate map holds the terminal member that ended each
    motion; ``terminal`` and ``message`` say what a member means.

    Examples
    --------
    >>> import phasemap
    >>> phasemap.Event.STICK.terminal, phasemap.Event.REST.terminal
    (False, True)
    >>> phasemap.Event(7).name
    'NO_SOLUTION'
    """

    START = START, "the motion starts on the unique admissible branch"
    REVERSAL = REVERSAL, "the relative velocity reached zero and the motion reversed"
    STICK = STICK, "the relative velocity reached zero and the contact sticks"
    SLIP = SLIP, "the stick branch became inadmissible and slip began"
    SWITCH = SWITCH, "another branch took over (sign of a two-sided reaction changed)"
    REST = REST, "stopped in a stagnation zone"
    CONTACT_LOST = CONTACT_LOST, "a one-sided contact would have to pull: the body leaves it"
    NO_SOLUTION = NO_SOLUTION, "no solution for the accelerations (Painleve inconsistency)"
    INDETERMINATE = (INDETERMINATE,
                     "two or more solutions for the accelerations: the motion is not determined")
    CONTINUUM = CONTINUUM, "a continuum of solutions for the accelerations"
    SINGULAR = SINGULAR, "the coefficient of the senior derivative reached zero"
    HORIZON = HORIZON, "still moving at the end of the requested range"
    MAX_EVENTS = MAX_EVENTS, "the requested number of events or stages ran out"
    STEP_FAILURE = STEP_FAILURE, "the step size fell below double-precision resolution"
    STIFF = (STIFF,
             "the motion is stiff here (a coefficient of the senior derivative near zero): the "
             "explicit integrator stops; phase_curve handles such cases")
    LEFT_DOMAIN = LEFT_DOMAIN, "the motion leaves the model's domain"
    MAX_STEPS = MAX_STEPS, "the requested number of integration steps (max_steps) ran out"
    IWC = (IWC, "an impact without collision: the slip forced the contact into the obstacle (a "
                "Painleve inconsistency), and an impulse at zero normal velocity changed the "
                "velocities")
    LIFTOFF = LIFTOFF, "a one-sided contact opened: the body leaves it and flies"
    IMPACT = (IMPACT, "a gap closed with the contact approaching: an impulse changed the "
                      "velocities (phasemap.motion.impact)")
    RECONTACT = RECONTACT, "a gap closed without approach: the contact closed without an impulse"
    ZENO = (ZENO, "the impacts of a bouncing contact accumulated (Zeno): the contact closed "
                  "at their predicted accumulation time")
    JAM = (JAM, "a dynamic jam: the slip reached the singular point (the normal force grew "
                "without bound), and a tangential impulse at zero normal velocity stopped it")

    @property
    def terminal(self) -> bool:
        """Whether the event ends the motion (:data:`FATES`)."""
        return int(self) in FATES


#: The fates as CF flags: values and space-separated meanings.
FATE_VALUES = tuple(int(e) for e in Event if e.terminal)
FATE_MEANINGS = " ".join(e.name.lower() for e in Event if e.terminal)
EVENT_VALUES = tuple(int(e) for e in Event)
EVENT_MEANINGS = " ".join(e.name.lower() for e in Event)


def end_message(model, fate: Event, state=None) -> str:
    """The fate's message; at an edge of the domain, which edge and what it means.

    ``state`` maps names of the integrated variables to their values at the end
    (any subset); a value equal to a finite bound of its variable names that edge
    and, where :attr:`phasemap.Dynamics.edges` says, what reaching it means.
    """
    if fate != Event.LEFT_DOMAIN or state is None:
        return fate.message
    dyn = model.dynamics
    known = {**model.variables, **{p.name: p for p in dyn.positions}}
    for name, value in state.items():
        var = known[name]
        for side, bound in enumerate((var.lower, var.upper)):
            if math.isfinite(bound) and value == bound:
                meaning = dyn.edges.get(var.name, ("", ""))[side]
                return (f"{fate.message}: {var.name} reached {bound:.6g} {var.units}"
                        + (f" ({meaning})" if meaning else ""))
    if model.domain_text:
        return f"{fate.message}: {model.domain_text}"
    return fate.message
