"""A declared system, and loading one from a file."""

from __future__ import annotations

import hashlib
import importlib.util
import pathlib
from dataclasses import dataclass, field
from typing import Mapping

from .build import build_model


@dataclass(frozen=True, eq=False)
class System:
    """A declared planar system with dry friction.  ``System(...).model`` is its Model.

    ``potential`` is the potential energy; ``forces`` optional generalised
    forces ``{coordinate: expression}`` (they may depend on rates).
    ``default_axes`` is the map ``phasemap atlas NAME`` draws by default;
    ``edges`` what reaching a bound of a coordinate means (see
    :class:`phasemap.Dynamics`).
    """

    name: str
    title: str
    citation: str
    coordinates: tuple
    parameters: tuple
    bodies: tuple
    contacts: tuple
    potential: object = 0
    forces: Mapping = field(default_factory=dict)
    default_axes: Mapping = field(default_factory=dict)
    edges: Mapping = field(default_factory=dict)
    #: optional cross-variable domain check on (possibly array) values: raise ValueError
    check: object = None
    #: optional short names for branches and reactions: ``{generated name: name}``
    #: (such as ``{"floor_slip_pos_wall_slip_pos": "slide_pos", "N_floor": "N"}``);
    #: ``branch_names()`` lists the generated branch names, ``model.reactions`` the
    #: reactions (``N_<contact>``, ``F_<contact>``, ``M_<contact>``, ``Rx_``/``Ry_``)
    names: Mapping = field(default_factory=dict)

    def branch_names(self) -> tuple[str, ...]:
        """The generated branch names, before ``names`` renames them (derives the model)."""
        inverse = {v: k for k, v in self.names.items()}
        return tuple(inverse.get(b, b) for b in self.model.branches)

    @property
    def model(self):
        """The :class:`phasemap.Model` (derived once per declaration, cached on disk)."""
        cached = _MODELS.get(id(self))
        if cached is None or cached[0] is not self:
            cached = (self, build_model(self))
            _MODELS[id(self)] = cached
        return cached[1]


_MODELS: dict[int, tuple] = {}


def load(path) -> "object":
    """The Model declared in a Python file: its ``SYSTEM`` (a :class:`System`).

    ValueError naming the file when it cannot be read or declares no system.
    """
    p = pathlib.Path(path)
    if not p.is_file():
        raise ValueError(f"{path}: no such declaration file")
    name = "phasemap_declared_" + hashlib.sha256(str(p.resolve()).encode()).hexdigest()[:12]
    spec = importlib.util.spec_from_file_location(name, p)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as e:  # a user's file: report it as a declaration error
        raise ValueError(f"{path}: the declaration failed to run: {type(e).__name__}: {e}") \
            from e
    system = getattr(module, "SYSTEM", None)
    if not isinstance(system, System):
        raise ValueError(f"{path}: the file must define SYSTEM = phasemap.declare.System(...)")
    return system.model
