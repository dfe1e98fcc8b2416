"""phasemap: solvability, stagnation and phase-space maps of systems with dry friction.

The public API is re-exported here explicitly.
"""

from ._version import __version__
from .classify import Branch, Classification, classify
from .model import BranchStatus, Derived, Model, Solvability, Variable
from .models import MODELS, get_model

__all__ = [
    "MODELS",
    "Branch",
    "BranchStatus",
    "Classification",
    "Derived",
    "Model",
    "Solvability",
    "Variable",
    "__version__",
    "classify",
    "get_model",
]
