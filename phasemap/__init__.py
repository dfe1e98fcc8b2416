"""phasemap: solvability, stagnation and phase-space maps of systems with dry friction.

The public API is re-exported here explicitly.
"""

from ._version import __version__
from .atlas import describe_atlas, open_atlas, write_atlas
from .classify import Branch, Classification, classify
from .layers import Layer, layers_for
from .model import BranchStatus, Derived, Model, Solvability, Variable
from .models import MODELS, get_model
from .scene import Scene

__all__ = [
    "MODELS",
    "Branch",
    "BranchStatus",
    "Classification",
    "Derived",
    "Layer",
    "Model",
    "Scene",
    "Solvability",
    "Variable",
    "__version__",
    "classify",
    "describe_atlas",
    "get_model",
    "layers_for",
    "open_atlas",
    "write_atlas",
]
