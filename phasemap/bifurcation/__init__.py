"""The bifurcation set of a map as exact curves (being built)."""

from .boundaries import boundaries
from .conditions import Condition
from .threshold import Threshold, threshold

__all__ = ["Condition", "Threshold", "boundaries", "threshold"]
