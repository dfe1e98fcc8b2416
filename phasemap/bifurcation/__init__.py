"""The bifurcation set of a map as exact curves (being built)."""

from .tracing import boundaries
from .conditions import Condition
from .thresholds import Threshold, threshold

__all__ = ["Condition", "Threshold", "boundaries", "threshold"]
