"""The registry of mechanical systems.

Two kinds of systems live here, and every feature treats them alike:

* **declared** systems (:mod:`phasemap.declare`): a module of
  :mod:`phasemap.systems` defines ``SYSTEM``, and its model is derived (with
  sympy, once, then cached on disk) the first time it is asked for.  The
  ladder and the wheel of Lapshin (2021) run this way
  (:mod:`phasemap.systems.seeds`), so that their maps count the bar leaving
  the wall and the wheel hopping;
* systems derived by hand: each module here defines one
  :class:`phasemap.model.Model` named ``MODEL``.  The elliptic and hinge
  pendulums run this way (their contacts cannot open; their declarations
  agree with them state by state, tests/test_declare.py).  The hand ladder
  and wheel (``phasemap.models.ladder.MODEL``, ``phasemap.models.wheel.MODEL``)
  keep the paper's equations, errata and closed forms and check the
  declarations in the tests; they are not registered.

Anywhere a model name is accepted, a path to a declaration file
(``path/to/system.py``, defining ``SYSTEM``) works too.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

from .. import _args, _declared
from ..model import Model
from . import elliptic_pendulum, hinge_pendulum

#: Declared built-in systems: name -> module of phasemap.systems defining SYSTEM.
DECLARED = {"ladder": "phasemap.systems.seeds.ladder", "wheel": "phasemap.systems.seeds.wheel",
            "painleve_rod": "phasemap.systems.painleve_rod",
            "rod_on_step": "phasemap.systems.rod_on_step"}


#: The order in which the built-in systems are listed (the paper's, then the rods).
ORDER = ("ladder", "wheel", "elliptic_pendulum", "hinge_pendulum", "painleve_rod",
         "rod_on_step")


class _Registry(Mapping):
    """Name -> Model; declared systems are built when first looked up."""

    def __init__(self, hand: dict[str, Model]):
        self._models = dict(hand)

    def __getitem__(self, name: str) -> Model:
        if name not in self._models and name in DECLARED:
            self._models[name] = _declared.load(DECLARED[name])
        return self._models[name]

    def __iter__(self):
        return iter(list(dict.fromkeys([*ORDER, *self._models, *DECLARED])))

    def __len__(self) -> int:
        return len(set(self._models) | set(DECLARED))

    def __contains__(self, name) -> bool:
        return name in self._models or name in DECLARED


MODELS: Mapping[str, Model] = _Registry(
    {m.MODEL.name: m.MODEL for m in (elliptic_pendulum, hinge_pendulum)})


def get_model(model: str | Model) -> Model:
    """The :class:`Model` for a name, a declaration file's path, or the model itself.

    Parameters
    ----------
    model : str, os.PathLike or Model
        a registered name (``phasemap.MODELS``), the path of a ``.py`` file
        that declares a ``SYSTEM`` (see :func:`phasemap.declare.load`), or a
        :class:`Model`, returned as it is.

    Returns
    -------
    Model

    Raises
    ------
    ValueError
        for an unknown name; for a file, naming the file and the part of the
        declaration that is wrong.

    Examples
    --------
    >>> import phasemap
    >>> model = phasemap.get_model("ladder")
    >>> [v.name for v in model.state], model.variables["phi"].units
    (['phi', 'omega'], 'rad')
    """
    if isinstance(model, Model):
        return model
    if isinstance(model, (str, os.PathLike)) and str(model).endswith(".py"):
        return _declared.load(model)
    if isinstance(model, str) and model in MODELS:
        return MODELS[model]
    raise ValueError(_args.unknown("model", model, MODELS, listing=(
        f"available models: {', '.join(MODELS)}, or the path of a declaration file, "
        "path/to/system.py")))


def builtin_model(name) -> Model:
    """The built-in model registered as ``name``: never a file, never a module named by
    the caller.  What a name read from a data file's metadata resolves to.

    >>> builtin_model("ladder").name
    'ladder'

    ValueError (one line) for anything else, a path to a declaration file included.
    """
    if isinstance(name, str) and name in MODELS:
        return MODELS[name]
    raise ValueError(f"{str(name)[:80]!r} is not a built-in model ({', '.join(MODELS)}); a "
                     "model named by a data file is never loaded from a file")


__all__ = ["MODELS", "DECLARED", "builtin_model", "get_model"]
