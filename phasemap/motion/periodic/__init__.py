"""Periodic orbits of friction oscillators on the exact hybrid flow (issue 39).

:func:`periodic_orbit` lets a declared system's motion (in full coordinates,
:mod:`phasemap.motion.hybrid`) settle on a cycle, reads the cycle's mode sequence from its
events, and solves the orbit by multiple shooting: each segment (a phase of fixed contact
modes) integrated exactly, each ended by its event, the state carried across each event
by the projection onto the next phase's contacts.  Its Floquet multipliers come from the
variational equations and a saltation matrix at every event
(:mod:`phasemap.motion.periodic.floquet`).  :func:`continue_orbit` follows an orbit in a
parameter through the changes of its mode sequence (the nonsmooth bifurcations).
:func:`orbit_diagram` sweeps a parameter by simulation: the settled motion's stroboscopic
points, the brute-force diagram beside the branches.
"""

__all__ = ["continue_orbit", "orbit_diagram", "periodic_orbit"]

from phasemap.motion.periodic.continuation import continue_orbit  # noqa: F401
from phasemap.motion.periodic.diagram import orbit_diagram  # noqa: F401
from phasemap.motion.periodic.orbit import periodic_orbit  # noqa: F401
