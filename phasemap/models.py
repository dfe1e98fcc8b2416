"""The registry of systems under its first name: ``phasemap.models.MODELS``,
``get_model``, ``builtin_model`` and ``DECLARED`` are those of
:mod:`phasemap.systems`, where every system that runs lives.

>>> import phasemap.models, phasemap.systems
>>> phasemap.models.get_model is phasemap.systems.get_model
True
"""

from phasemap.systems import DECLARED, MODELS, builtin_model, get_model

__all__ = ["MODELS", "DECLARED", "builtin_model", "get_model"]
