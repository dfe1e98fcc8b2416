"""The registry of mechanical systems.

Each module defines one :class:`phasemap.model.Model` named ``MODEL``; adding a
system means adding its module and one entry here.
"""

from __future__ import annotations

from ..model import Model
from . import elliptic_pendulum, hinge_pendulum, ladder, wheel

MODELS: dict[str, Model] = {
    m.MODEL.name: m.MODEL for m in (ladder, wheel, elliptic_pendulum, hinge_pendulum)
}


def get_model(model: str | Model) -> Model:
    """The :class:`Model` for a name (or the model itself); ValueError for an unknown name."""
    if isinstance(model, Model):
        return model
    try:
        return MODELS[model]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown model {model!r}; available models: {', '.join(MODELS)}"
        ) from None


__all__ = ["MODELS", "get_model"]
