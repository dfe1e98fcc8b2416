"""phasemap: solvability, stagnation and phase-space maps of systems with dry friction.

The house, one line per room (docs/guide/layout.md says more):

- ``model.py``: the contract every system gives the rest (``Model``, ``Branch``, ``Dynamics``);
- ``declare/``: a declared ``System`` made a ``Model`` (contact laws, equations, solvers,
  the code emitter, the kernel cache, admissibility conditions);
- ``systems/``: every system that runs, and the registry (``MODELS``, ``get_model``);
  ``models.py`` is its first name, a re-export;
- ``classify.py``, ``_numerics.py``, ``_codegen.py``, ``layers.py``, ``grid.py``,
  ``_compile.py``, ``scene.py``: points and grids of points;
- ``events.py``, ``integrate/``, ``simulate.py``, ``phase/``, ``workprecision/``: motion;
- ``bifurcation/``: the bifurcation set (``boundaries``, ``threshold``);
- ``_dataset.py``, ``atlas.py``, ``plot/``, ``accessor.py``: datasets, atlases and figures;
- ``study.py``, ``tour.py``, ``cli.py``: what the study scripts, the tour and the command
  line share.

The public API is re-exported here explicitly.
"""

from ._version import __version__
from .atlas import describe_atlas, open_atlas, write_atlas
from .classify import Branch, BranchResult, Classification, classify
from .events import Event
from .layers import Layer, layers_for
from .model import BranchStatus, Derived, Dynamics, Model, Solvability, Variable
from .systems import MODELS, get_model
from .phase import phase_curve
from .scene import Scene
from .simulate import simulate
from . import accessor as _accessor  # noqa: F401  (registers Dataset.phasemap)


def __getattr__(name: str):
    """``phasemap.plot`` is imported (with matplotlib, half a second) on first use: a
    script that maps, integrates or writes atlases does not pay for it; so are
    ``phasemap.boundaries`` and ``phasemap.threshold`` (:mod:`phasemap.bifurcation`)."""
    if name == "plot":
        import importlib

        return importlib.import_module(".plot", __name__)
    if name in ("boundaries", "threshold"):  # sympy and the tracer load on first use
        from . import bifurcation

        return getattr(bifurcation, name)
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
    "phase_curve",
    "plot",
    "simulate",
    "threshold",
    "write_atlas",
]
