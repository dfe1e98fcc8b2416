"""The contract of a contact law: what a contact tells the derivation.

A contact law (a :class:`ContactLaw` subclass, see :mod:`phasemap.declare.contacts`)
is a frozen dataclass of its geometry and friction coefficient, and implements
five hooks, as sympy.physics.mechanics' ``Joint`` subclasses do:

``kinematics(vel)``
    its velocity *channels* (expressions linear in the rates: the normal and
    tangential velocity of a point, a rotation rate), the *gaps* that close it,
    which channels are *constraints* (zero while it is kept), and the *domain*
    where it exists (labelled expressions >= 0);
``modes()``
    its :class:`Mode` s (slip either way, stick, separate...);
``unknowns(mode, channels, problem)``
    the unknown reactions a mode adds to one mode combination's linear problem
    (through :meth:`LinearProblem.new`) and the reactions in those unknowns;
``requirements(mode, reactions)``
    the admissibility conditions of a mode, as :class:`Requirement` objects:
    the generated branch functions (:mod:`phasemap.declare.emit`) and the
    conditions the bifurcation tracer reads (:mod:`phasemap.declare.admissibility`)
    are both built from them;
``reaction_variables()``
    the reactions it reports: names, units, long names.

and names its class attributes: ``friction_field`` (the field that holds its
friction coefficient), ``slip_channel`` (the channel it slips with),
``point_fields`` and ``scalar_fields`` (the fields validated as expressions),
and optionally ``check_choices`` (fields with a few allowed values) and
``squared_law``.  Everything else (validation, the branch names, the arguments
a row passes, the model's reactions, the conditions) follows from these: a new
law is one class in :mod:`phasemap.declare.contacts`.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import ClassVar

from phasemap.declare.api import sym

SLIP, ROLL, TURN, STICK, SEPARATED = "slip", "roll", "turn", "stick", "sep"
#: How a mode's kind reads in a branch name.
_WORDS = {SLIP: "slip", ROLL: "roll", TURN: "turn", STICK: "stick", SEPARATED: "separated"}


@dataclass(frozen=True)
class Mode:
    """One mode of a contact.

    ``kind`` is one of ``slip``, ``roll``, ``turn`` (moving, in the direction
    ``slip`` = +-1), ``stick`` or ``sep`` (separated); ``normal`` the assumed
    sign of a two-sided contact's normal force (0: not split); ``root`` which
    root of a squared friction law (-1, +1; 0: none).
    """

    kind: str
    slip: int = 0
    normal: int = 0
    root: int = 0

    @property
    def moves(self) -> bool:
        return self.kind in (SLIP, ROLL, TURN)

    @property
    def args(self) -> list[float]:
        """The constants a branch row passes for this mode (slip sign, N sign, root)."""
        if not self.moves:
            return []
        return [float(x) for x in (self.slip, self.normal, self.root) if x]

    def word(self) -> str:
        """The mode in a branch name: ``slip_pos``, ``slip_neg_Nneg``, ``turn_pos_root2``..."""
        word = _WORDS[self.kind]
        if self.slip:
            word += "_pos" if self.slip > 0 else "_neg"
        if self.normal:
            word += "_Npos" if self.normal > 0 else "_Nneg"
        if self.root > 0:
            word += "_root2"
        return word


STICKING = Mode(STICK)


@dataclass
class Kinematics:
    """What a contact constrains: see :meth:`ContactLaw.kinematics`."""

    channels: dict
    gaps: list
    constraints: tuple[str, ...]
    domain: dict = field(default_factory=dict)   # label -> expression >= 0


# -- requirements: the admissibility conditions of a mode ------------------------

@dataclass(frozen=True)
class Form:
    """One reaction inequality: ``expr >= 0`` (``> 0`` when ``strict``).

    ``strict`` may be a sign symbol (a two-sided contact's assumed sign of N):
    strict where it is negative.  ``label`` names the quantity without the
    branch (``N_floor``, ``limit_pos_floor``), ``kind`` is ``normal`` or
    ``friction_limit``.  Where ``expr`` is not smooth (``f |N| - |F|``),
    ``smooth`` is the same inequality as a polynomial, ``smooth = expr * factor``
    with ``factor > 0`` (what the conditions for the tracer use).
    """

    label: str
    kind: str
    expr: object
    strict: object = False
    smooth: object = None
    factor: object = 1

    @property
    def smooth_expr(self):
        return self.expr if self.smooth is None else self.smooth


class Requirement:
    """One admissibility condition of a mode: a reaction inequality or the sign of a
    channel's acceleration."""

    contact: str

    def forms(self) -> list[Form]:
        """The reaction inequalities it states (none for an acceleration's sign)."""
        return []


@dataclass(frozen=True)
class Pushes(Requirement):
    """A normal force of the assumed sign: ``sign * N >= 0`` (``> 0`` for sign -1,
    so that N = 0 counts once, in the positive branch).  ``sign`` 1 for a one-sided
    contact."""

    contact: str
    normal: object
    sign: object = 1

    def forms(self):
        if self.sign == 1:
            return [Form(f"N_{self.contact}", "normal", self.normal, False)]
        return [Form(f"N_{self.contact}", "normal", self.sign * self.normal, self.sign)]


@dataclass(frozen=True)
class WithinCone(Requirement):
    """Static friction within its limit on a one-sided contact: ``|F| <= f N`` as the two
    sides ``f N - F >= 0`` and ``f N + F >= 0``."""

    contact: str
    coefficient: object
    normal: object
    force: object

    def forms(self):
        f, N, F = self.coefficient, self.normal, self.force
        return [Form(f"limit_pos_{self.contact}", "friction_limit", f * N - F),
                Form(f"limit_neg_{self.contact}", "friction_limit", f * N + F)]


@dataclass(frozen=True)
class WithinAbsCone(WithinCone):
    """Static friction within its limit on a two-sided contact: ``f |N| - |F| >= 0``;
    smooth, ``f^2 N^2 - F^2 >= 0`` (the same set for ``f >= 0``)."""

    def forms(self):
        import sympy as sp

        f, N, F = self.coefficient, self.normal, self.force
        return [Form(f"limit_{self.contact}", "friction_limit", f * sp.Abs(N) - sp.Abs(F),
                     smooth=f * f * N * N - F * F, factor=f * sp.Abs(N) + sp.Abs(F))]


@dataclass(frozen=True)
class WithinNormCone(Requirement):
    """A friction moment within ``delta |R|``: ``delta^2 (X^2 + Y^2) - M^2 >= 0``."""

    contact: str
    coefficient: object
    x: object
    y: object
    moment: object

    def forms(self):
        d = self.coefficient
        return [Form(f"limit_{self.contact}", "friction_limit",
                     d * d * (self.x * self.x + self.y * self.y) - self.moment * self.moment)]


@dataclass(frozen=True)
class Accelerates(Requirement):
    """A channel's acceleration strictly of the sign ``sign`` (ties go to the other side).

    From rest (``rest_only``): a slip starting in direction ``sign``
    (``start_<contact>``); always: a separated contact's gap opening
    (``gap_<contact>``, ``sign`` None for +1).
    """

    contact: str
    channel: str
    sign: object = None
    rest_only: bool = False

    @property
    def label(self) -> str:
        return f"{'start' if self.rest_only else 'gap'}_{self.contact}"


# -- one mode combination's linear problem ---------------------------------------

@dataclass
class SquaredLaw:
    """A friction moment ``M = -sigma delta |R|`` (a joint turning): the moment is an
    unknown ``moment`` of the linear problem, fixed afterwards by the squared law."""

    contact: str
    coefficient: object
    sign: object
    root: object
    moment: object


@dataclass
class LinearProblem:
    """One mode combination's equations before they are solved.

    The unknowns ``L_i`` (reactions) enter the generalised forces through
    ``columns`` and are fixed by ``constraints`` (a channel's acceleration
    ``w . q'' + bias = 0``).  ``zero`` sets the slip velocity to 0 where a
    contact sticks (a rest is consistent only there).
    """

    kinds: tuple
    fname: str
    n: int
    zero: dict
    args: list = field(default_factory=lambda: ["_k_presence"])
    unknowns: list = field(default_factory=list)      # (contact, key, symbol)
    columns: list = field(default_factory=list)
    constraints: list = field(default_factory=list)   # (w, bias)
    reactions: list = field(default_factory=list)
    requirements: list = field(default_factory=list)
    signs: dict = field(default_factory=dict)          # contact -> its slip sign symbol
    squared: SquaredLaw | None = None
    extra: list = field(default_factory=list)          # the squared law's generalised force

    def new(self, contact: str, key: str, column, channel):
        """A new unknown reaction with its column, fixed by ``channel`` (or free, None)."""
        import sympy as sp

        L = sp.Symbol(f"_k_L{len(self.unknowns)}", real=True)
        self.unknowns.append((contact, key, L))
        self.columns.append(column)
        if channel is not None:
            self.constraints.append((channel[0], channel[1].xreplace(self.zero)))
        return L

    def sign_symbol(self, kind: str, contact: str):
        import sympy as sp

        return sp.Symbol(f"_k_{kind}_{contact}", real=True)

    @property
    def forms(self) -> list[Form]:
        return [f for r in self.requirements for f in r.forms()]


# -- the contract -----------------------------------------------------------------

class ContactLaw(abc.ABC):
    """A contact and its friction law (see the module docstring for the hooks).

    The built-in laws (:class:`PointContact`, :class:`EdgeContact`,
    :class:`RollingContact`, :class:`Joint`) implement it; a law of one's own
    subclasses it and implements the hooks the module docstring lists, and
    everything else (the modes, the solvers, the generated kernels, the
    admissibility conditions) follows.

    Examples
    --------
    >>> from phasemap.declare import ContactLaw, Joint, PointContact, RollingContact
    >>> all(issubclass(law, ContactLaw) for law in (PointContact, RollingContact, Joint))
    True
    """

    #: the field holding the friction law's coefficient (a parameter or expression)
    friction_field: ClassVar[str]
    #: the channel whose velocity the contact slips with
    slip_channel: ClassVar[str]
    #: the friction law is squared to be solved (at most one such contact per system)
    squared_law: ClassVar[bool] = False
    #: the field whose law may depend on the sliding speed (``SLIP_SPEED``), if any
    speed_field: ClassVar[str | None] = None
    #: fields that are points (x, y) and scalar expressions, validated as expressions
    point_fields: ClassVar[tuple[str, ...]] = ()
    scalar_fields: ClassVar[tuple[str, ...]] = ()

    name: str
    long_name: str

    @property
    def friction_law(self):
        return getattr(self, self.friction_field)

    @property
    def what(self) -> str:
        return self.long_name or f"contact {self.name}"

    def token(self, mode: Mode) -> str:
        """The mode of this contact in a branch name."""
        return f"{self.name}_{mode.word()}" if self.name else mode.word()

    def validate(self, fail, expr, state_names=frozenset()) -> None:
        """Check the fields: ``fail(part, why)`` raises, ``expr(part, e)`` checks an
        expression; ``state_names``: the coordinates and rates (for a field that may not
        depend on them)."""
        part = f"contact {self.name!r}"
        law = self.friction_field
        if self.friction_law is None:
            fail(part, f"has no friction law: give {law}= (a parameter or an expression; 0 for "
                 "a frictionless contact)")
        from phasemap.declare.api import SLIP_SPEED

        expr(f"{part} {law}", self.friction_law,
             allow=(SLIP_SPEED.name,) if self.speed_field == law else ())
        self.check_choices(lambda why: fail(part, why))
        for name in self.point_fields:
            v = getattr(self, name)
            if len(v) != 2:
                fail(f"{part} {name}", "must be a pair (x, y)")
            for e in v:
                expr(f"{part} {name}", e)
        for name in self.scalar_fields:
            expr(f"{part} {name}", getattr(self, name))

    def check_choices(self, fail) -> None:
        """Check the fields that take one of a few values (``fail(why)`` raises)."""

    @abc.abstractmethod
    def kinematics(self, vel) -> Kinematics:
        """Channels, gaps, constraints and domain; ``vel(e)`` is the time derivative of ``e``."""

    @abc.abstractmethod
    def modes(self) -> tuple[Mode, ...]:
        """Every mode of the contact, the sticking one included."""

    @abc.abstractmethod
    def unknowns(self, mode: Mode, channels: dict, problem: LinearProblem) -> list:
        """Add the mode's unknowns to ``problem``; return the contact's reactions (as listed
        by :meth:`reaction_variables`) in them.  ``channels[key]`` is ``(w, bias, v)``."""

    @abc.abstractmethod
    def requirements(self, mode: Mode, reactions: list) -> list[Requirement]:
        """The mode's admissibility conditions, in the reactions of :meth:`unknowns`."""

    @abc.abstractmethod
    def reaction_variables(self) -> tuple:
        """The reactions it reports, as :class:`phasemap.core.model.Variable` s."""

    def law_expr(self):
        return sym(self.friction_law)
