"""A declared system, and loading one from a file."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

from phasemap.core.memo import Memo
from phasemap.declare.build import build_model


@dataclass(frozen=True, eq=False)
class System:
    """A declared planar system with dry friction.  ``System(...).model`` is its Model.

    ``potential`` is the potential energy; ``forces`` optional generalised
    forces ``{coordinate: expression}`` (they may depend on rates, and on
    :data:`phasemap.declare.TIME` in a forced system); ``dissipation`` a Rayleigh
    dissipation function ``D`` of the rates (viscous damping: the generalised force
    on ``q_i`` is ``-dD/dq_i'``, so ``D = c * xdot**2 / 2`` is a damper ``c``);
    ``period`` the forcing period of a system whose forces or surfaces depend on
    the time (an expression of the parameters, ``2 * sp.pi / Omega``).
    ``default_axes`` is the map ``phasemap atlas NAME`` draws by default;
    ``edges`` what reaching a bound of a coordinate means (see
    :class:`phasemap.Dynamics`).

    Parameters
    ----------
    name, title, citation : str
        the model's name (``phasemap.MODELS``, file names), a one-line title
        and the source of the system.
    coordinates : tuple of Coordinate
        the generalised coordinates; those with a :class:`Rate` are the state.
    parameters : tuple of Parameter
    bodies : tuple of Body
    contacts : tuple of ContactLaw
        :class:`PointContact`, :class:`EdgeContact`, :class:`RollingContact`,
        :class:`Joint`, or a law of one's own.
    potential, forces, dissipation, period, default_axes, edges, check, names
        as above and in the attribute comments of the source.

    Raises
    ------
    ValueError
        when ``.model`` is first built, naming the system and the part of the
        declaration with the first problem found.

    Examples
    --------
    The declared built-in Painlevé rod (``phasemap/systems/painleve_rod.py``):

    >>> from phasemap.systems.painleve_rod import SYSTEM
    >>> [c.name for c in SYSTEM.coordinates], [c.name for c in SYSTEM.contacts]
    (['theta', 'x', 'y'], ['A'])
    >>> SYSTEM.branch_names()
    ('stick', 'A_slip_pos', 'A_slip_neg', 'A_separated', 'A_separated_moving_neg')

    A declaration of one's own is in the gallery and the user guide
    ("Declaring a system").
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
    #: Rayleigh's dissipation function of the rates (viscous damping), 0 for none
    dissipation: object = 0
    #: the forcing period of a system that depends on the time (None: autonomous)
    period: object = None
    default_axes: Mapping = field(default_factory=dict)
    edges: Mapping = field(default_factory=dict)
    #: optional cross-variable domain check on (possibly array) values: raise ValueError.
    #: Defined in an importable module other than the declaration file, it lets a warm
    #: process load the model without building the declaration (phasemap.declare.loader).
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
        return _MODELS.get((self,), (), lambda: build_model(self))


_MODELS = Memo("system.models")
