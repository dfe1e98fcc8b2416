"""phasemap: solvability, stagnation and phase-space maps of systems with dry friction.

The house, in nine parts, each importing only from the parts below it (ARCHITECTURE.md
at the top of the repository says more, with a picture):

- ``core/``: the contract every system gives the rest (``Model``, ``Candidate``,
  ``Dynamics``, ``Event``) and the machinery that compiles it (generated kernels, the
  kernel cache, the numba types, the argument checks);
- ``declare/``: a declared ``System`` made a ``Model`` (contact laws, equations,
  solvers, the code emitter, admissibility conditions);
- ``systems/``: every system that runs, and the registry (``MODELS``, ``get_model``);
- ``atlas/``: Datasets and their netCDF files (writing, atomic files, reading);
- ``motion/``: the integrator, ``simulate``, phase curves, work against precision;
- ``maps/``: one state (``classify``), the layers, grids and ``Scene``;
- ``bifurcation/``: the bifurcation set (``boundaries``, ``threshold``);
- ``plot/``: figures;
- the front door (this file, ``cli.py``, ``study.py``, ``tour.py``, ``warm.py``,
  ``workers.py``, ``accessor.py``):
  what users, the study scripts and the command line call.

The public API is re-exported here explicitly.
"""

from phasemap._version import __version__
from phasemap.core import compiletime as _compiletime
from phasemap.core import fasttyping as _fasttyping

# numba types each scalar operation once per process (before anything below compiles)
_fasttyping.install()

from phasemap.core import interrupts as _interrupts
from phasemap.atlas.read import describe_atlas, open_atlas
from phasemap.atlas.write import write_atlas
from phasemap.maps.classify import Branch, BranchResult, Classification, classify
from phasemap.core.events import Event
from phasemap.maps.layers import Layer, layers_for
from phasemap.core.model import BranchStatus, Derived, Dynamics, Model, Solvability, Variable
from phasemap.systems import MODELS, get_model
from phasemap.motion.phase import phase_curve
from phasemap.maps.scene import Scene
from phasemap.motion.simulate import simulate
from phasemap import accessor as _accessor  # noqa: F401  (registers Dataset.phasemap)

# a Ctrl-C during a compile ends the call, never lost inside LLVM's callbacks into Python;
# and the time numba compiles is counted, for the tour's and --timing's reports
_interrupts.install()
_compiletime.install()


def __getattr__(name: str):
    """``phasemap.plot`` is imported (with matplotlib, half a second) on first use: a
    script that maps, integrates or writes atlases does not pay for it; so are
    ``phasemap.boundaries`` and ``phasemap.threshold`` (:mod:`phasemap.bifurcation`), and
    ``phasemap.periodic_orbit``, ``phasemap.continue_orbit`` and
    ``phasemap.orbit_diagram`` (:mod:`phasemap.motion.periodic`)."""
    if name == "plot":
        import importlib

        return importlib.import_module(".plot", __name__)
    if name in ("boundaries", "threshold"):  # sympy and the tracer load on first use
        from phasemap import bifurcation

        return getattr(bifurcation, name)
    if name in ("periodic_orbit", "continue_orbit", "orbit_diagram"):    # (scipy's optimisers)
        from phasemap.motion import periodic

        return getattr(periodic, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "MODELS",
    "Branch",
    "BranchResult",
    "BranchStatus",
    "Classification",
    "Derived",
    "Dynamics",
    "Event",
    "Layer",
    "Model",
    "Scene",
    "Solvability",
    "Variable",
    "__version__",
    "boundaries",
    "classify",
    "describe_atlas",
    "get_model",
    "layers_for",
    "open_atlas",
    "orbit_diagram",
    "continue_orbit",
    "periodic_orbit",
    "phase_curve",
    "plot",
    "simulate",
    "threshold",
    "write_atlas",
]
