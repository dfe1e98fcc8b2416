"""The systems that run, and their registry: ``MODELS``, ``get_model``, ``builtin_model``.

**Declare first.**  A system is a :class:`phasemap.declare.System` in a module
that defines ``SYSTEM``; its model is derived (with sympy, once, then cached on
disk) the first time it is asked for.  What runs, by name:

* ``painleve_rod``, ``rod_on_step`` (:mod:`phasemap.systems.painleve_rod`,
  :mod:`phasemap.systems.rod_on_step`) and ``ladder``, ``wheel``
  (:mod:`phasemap.systems.seeds`, two of the four systems of Lapshin 2021):
  declared, so that their maps count a body leaving a contact;
* ``belt``, ``stribeck_belt``, ``den_hartog``, ``duffing``: friction oscillators
  (:mod:`phasemap.systems.oscillators`), which :func:`phasemap.simulate`,
  :func:`phasemap.classify` and :class:`phasemap.Scene` run by name in full coordinates;
  they are not in ``MODELS`` (they have no reduced model);
* ``elliptic_pendulum``, ``hinge_pendulum``: written by hand
  (:mod:`phasemap.systems.elliptic_pendulum`,
  :mod:`phasemap.systems.hinge_pendulum`, each defining a
  :class:`phasemap.core.model.Model` named ``MODEL``), because their contacts cannot
  open and their maps are pinned bit for bit.  Their declarations in
  :mod:`phasemap.systems.seeds` are twins that agree with them state by state
  (tests/test_declare.py) and give the bifurcation tracer their admissibility
  conditions (each hand model names its twin: :attr:`phasemap.Model.twin`).

The paper's own equations for the ladder and the wheel, with its errata and
closed forms, are test references (tests/references/), not systems.  A new
built-in system is a declaration here and one line in :data:`DECLARED`.
Anywhere a model name is accepted, a path to a declaration file
(``path/to/system.py``, defining ``SYSTEM``) works too.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping

from phasemap.core import args as _args
from phasemap.declare import loader as _declared
from phasemap.core.model import Model
from phasemap.systems import elliptic_pendulum, hinge_pendulum

#: Declared built-in systems: name -> the module defining its SYSTEM.
DECLARED = {"ladder": "phasemap.systems.seeds.ladder", "wheel": "phasemap.systems.seeds.wheel",
            "painleve_rod": "phasemap.systems.painleve_rod",
            "rod_on_step": "phasemap.systems.rod_on_step"}


#: The friction oscillators (:mod:`phasemap.systems.oscillators`): declared, they run in
#: :func:`phasemap.simulate` by name, in full coordinates; they have no maps yet.
OSCILLATORS = ("belt", "stribeck_belt", "den_hartog", "duffing")


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
    model : str, os.PathLike, Model or phasemap.declare.System
        a registered name (``phasemap.MODELS``), the path of a ``.py`` file
        that declares a ``SYSTEM`` (see :func:`phasemap.declare.loader`), a
        declaration (its reduced model, :attr:`phasemap.declare.System.model`), or a
        :class:`Model`, returned as it is.

    Returns
    -------
    Model

    Raises
    ------
    ValueError
        for an unknown name; for a file, naming the file and the part of the
        declaration that is wrong; for a friction oscillator or a declaration like
        one (a moving surface, forcing in time...), saying what takes it instead.

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
    if isinstance(model, str) and model in OSCILLATORS:
        from phasemap.declare.validation import no_reduced_model
        from phasemap.systems.oscillators import OSCILLATORS as systems

        raise ValueError(f"{model}: a friction oscillator has "
                         f"{no_reduced_model(systems[model])}")
    declared = sys.modules.get("phasemap.declare.system")  # (a System imported it)
    if declared is not None and isinstance(model, declared.System):
        return model.model   # its reduced model, or why it has none
    raise ValueError(_args.unknown("model", model, MODELS, listing=(
        f"available models: {', '.join(MODELS)}, or the path of a declaration file, "
        "path/to/system.py")))


def reference(model: Model) -> str | Model:
    """``model`` as another process gets it (a background compile): its name where the
    registry holds this very model, else the model itself (a declared one pickles as its
    declaration)."""
    return model.name if MODELS._models.get(model.name) is model else model


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
