"""Motion through contact changes: lift-off, flight, impacts, impacts without collision,
Zeno, in the full coordinates of a declared system (event-driven, GUIDE section 8).

The reduced integrator (:mod:`phasemap.motion.integrate`) holds every contact closed and
ends a motion where one opens.  This one goes on.  Its state is every coordinate and its
rate ``(q, u)``; each contact is, in a *phase*, one of

* ``open`` (no reaction; its gap ``g`` may be positive: the body flies off it),
* ``smooth`` (closed, frictionless: ``g'' = 0``, ``N`` free, ``F = 0``),
* ``stick`` (closed, ``g'' = 0`` and the tangential acceleration zero),
* ``slip_pos`` / ``slip_neg`` (closed, ``F = -s mu N`` with ``s`` the slip's sign).

A rolling disc takes these modes on its spin (rolling friction ``M = -s delta N``; stuck
with ``|M| <= delta N``), and while closed its tangent is held: it rolls without slip.

A phase's accelerations solve ``M u' = h + sum_c J_c^T (N_c, F_c)`` with the closed
contacts' accelerations ``J_c u' + J_c' u`` held (:func:`accelerations`: one small linear
system, from :func:`phasemap.declare.full.mechanics`, the same Lagrangian and contact
kinematics as every other computation of the declaration).  A phase ends at an *event*,
rooted on the dense output of DOP853 (scipy's method in machine code, :mod:`.flow`) to a
few ulps in time:

* a closed contact's ``N`` reaches 0: **lift-off** where the open mode is the one that
  is admissible (the tie between "slip with N = 0" and "open with g'' = 0" is decided
  for the contact that is leaving, as Siconos decides it by the next derivative);
* a slip velocity reaches 0 (**stick** or **reversal**), a stuck contact reaches its
  friction limit (**slip**);
* an open gap reaches 0 (also between steps: a minimum of ``g`` below zero inside a
  step, where ``g'`` turns from negative to positive, is found too).  With ``g' < 0``
  it is an **impact**: one contact's is integrated in its normal impulse
  (:func:`phasemap.motion.impact.impact`, the law chosen), several contacts at once take
  Moreau's impulse-level solution, inelastic or with the restitution by his generalised
  Newton law (:func:`phasemap.motion.impact.simultaneous`); a rolling disc, perfectly
  rough, first has its slip stopped by a tangential impulse alone (the limit mu -> oo),
  then Moreau's solution with its tangent held (:mod:`.landing`);
  with ``g' = 0`` the contact **recontacts** without an impulse;
* a coordinate's bound or a declared domain condition: the motion leaves the model
  (``left_domain``);
* a slip phase's normalised determinant (:meth:`Motion.singularity`) reaches zero, or the
  step size collapses there: a **dynamic jam** (the Genot-Brogliato singular point, where
  the normal force grows without bound but its impulse stays bounded).  The impulse at
  zero normal velocity that stops the slip is applied (for one contact P_n = -v_t /
  (W_tn - s mu W_tt), P_t = -s mu P_n), and a ``jam`` event recorded.

After every event the contact modes are enumerated (every combination of the closed
contacts' modes, solved and kept where admissible, as the acceleration level is counted
everywhere in phasemap).  One solution: the next phase.  None: a Painleve
inconsistency, resolved by an **impact without collision** at the slipping contact.
Two or more: the ``painleve`` policy (``"liftoff"``: the solution with the most contacts
open, as a compliant contact started at zero penetration does; ``"iwc"``; ``"stop"``).
At every event the state is projected onto the closed contacts in the mass metric
(positions on ``g = 0``, velocities on ``J_n u = 0`` and the stuck ``J_t u = 0``), so
no drift accumulates.  **Zeno**: where one contact's rebounds fall below ``zeno_speed``
the impacts' accumulation time ``t_inf = t_k + 2 v_k / (|a_n| (1 - e))`` is predicted,
the contact closes plastically, and a ``zeno`` event is recorded at ``t_inf``; the motion
does not come to rest before it.
"""

__all__ = ["MODE_NAMES", "OPEN", "POLICIES", "QUIET", "SLIP_NEG", "SLIP_POS", "SMOOTH",
           "STICK", "TOL", "ZENO_SPEED", "Motion", "Options", "Record",
           "check_contact_options", "dataset", "declaration_of", "full_names", "run_full",
           "start_values", "system_of", "tangential_impact"]

from phasemap.motion.hybrid.engine import (  # noqa: F401 - the package's names
    MODE_NAMES, OPEN, POLICIES, QUIET, SLIP_NEG, SLIP_POS, SMOOTH, STICK, TOL, ZENO_SPEED,
    Motion, Options, Record, tangential_impact)
from phasemap.motion.hybrid.results import (  # noqa: F401
    check_contact_options, dataset, declaration_of, full_names, run_full, start_values,
    system_of)
