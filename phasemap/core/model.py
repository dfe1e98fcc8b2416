"""The model contract: what one mechanical system tells the rest of phasemap.

Everything (``classify``, the grid evaluator, the atlas writer, the CLI, the
integrator) reads only a :class:`Model`.  **Declare first**: a new system is a
:class:`phasemap.declare.System` (its coordinates, bodies, potential and
contacts, a few lines; see :mod:`phasemap.declare`), in a module of
:mod:`phasemap.systems` with one line in ``phasemap.systems.DECLARED``, or in
any file passed where a model name is accepted.  phasemap derives its
branches and generates this contract.  Write a model by hand only for what a
declaration cannot say, or for speed where a map is pinned bit for bit (the
elliptic and hinge pendulums run by hand, their declarations are twins).

A model written by hand
-----------------------
A hand-written model provides:

``state``, ``params``
    :class:`Variable` tuples: name, UDUNITS units, long name, default and the
    domain (bounds, open or closed).  ``params`` must include ``m`` when the
    reactions scale with the mass.
``derived``
    :class:`Derived` inputs that depend on one name only (``sin(phi)``...).
    Callers compute them once per value, which is how the grid evaluator
    hoists per-axis work out of its inner loop.
``candidates``
    one :class:`Candidate` per candidate branch: its name, the sign of the relative
    velocity on it (+1, -1, or 0 for the stick branch) and a pure scalar
    function that returns its row (see below).
``accelerations``, ``reactions``, ``coefficient``
    :class:`Variable` descriptions of the numbers a branch row carries.
``velocity``, ``velocity_scale``
    the state name whose zero activates the stick branch, and a branch function
    (same conventions) returning its natural scale: the velocity counts as zero
    when ``|velocity| <= TOL * velocity_scale(...)``.
``check``
    optional cross-variable domain check on (possibly array) values; raises
    :class:`ValueError`.
``default_axes``
    optional ``{name: (start, stop, count)}``: the map ``phasemap atlas MODEL``
    draws when no axis is given.
``dynamics``
    optional :class:`Dynamics`: what :func:`phasemap.simulate` and the fate
    maps need to move the system in time (which coordinates are integrated).

Candidate functions
----------------
A branch function is ``@numba.njit(cache=True, forceinline=True, error_model="numpy")``,
takes scalars and **returns** its row as a tuple laid out as in
:mod:`phasemap.core.numerics`: ``(status, singular, coefficient,
accelerations..., reactions...)``, the status an integer code (so that the
grid kernel compares integers), the rest floats, NaN for what it does not
determine.  Its
first parameters receive ``Candidate.args`` (such as the slip direction); the
others are named after model inputs (``phi``, ``f``, ``sin_phi``...), and a
parameter named ``rest`` receives whether the branch starts from zero
relative velocity.  Write it without early returns and with ``&``/``|`` and
conditional expressions instead of ``and``/``or``/``if``, so that it inlines
into the grid kernel's inner loop and vectorises there.  ``forceinline`` asks
LLVM to inline it; numba's own ``inline="always"`` gives the same machine code
but repeats the work for every call site (about twice the compile time).

From these the framework generates (:mod:`phasemap.core.codegen`) everything the
rest of phasemap calls: ``model.point(v, out)`` (all candidate rows at one
state, for :func:`phasemap.classify`), ``model.branch(v, b, row)`` (one
branch along its stage, for the integrator), ``model.derive(v)`` and the
grid kernels, specialised per scene.  No model writes a row index or an
input slot by hand.

Everything else just works.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from phasemap.core import args as _args
from phasemap.core import numerics as nx


class BranchStatus(nx.Coded):
    """What one candidate branch is at one state.

    Examples
    --------
    >>> import phasemap
    >>> c = phasemap.classify("elliptic_pendulum", phi=0.8, xdot=1.0, f=4.0)
    >>> sorted({b.status.name for b in c.candidates})
    ['INADMISSIBLE']
    """

    ABSENT = nx.ABSENT, "does not apply at this state"
    ADMISSIBLE = nx.ADMISSIBLE, "solves the equations and satisfies its own assumptions"
    INADMISSIBLE = nx.INADMISSIBLE, "violates its own sign or friction-limit assumption"
    CONTACT_LOST = nx.CONTACT_LOST, "solves the equations but needs a one-sided contact to pull"
    NO_SOLUTION = nx.NO_SOLUTION, "has no acceleration that solves the equations"
    CONTINUUM = nx.CONTINUUM, "is solved by a whole family of accelerations"
    SEPARATION = (nx.SEPARATION,
                  "solves the equations with a one-sided contact opening: the body leaves it")


#: Largest magnitude of any value: squares and products of a few values must stay
#: finite in double precision (an overflow would be counted as a solution).
MAX_MAGNITUDE = 1e30
#: Smallest value of a quantity whose domain excludes zero (a length, a mass): the
#: models divide by it.
MIN_POSITIVE = 1e-30


class Solvability(nx.Coded):
    """How many solutions the motion equations have for the senior derivatives.

    The values are the ``n_solutions`` of :func:`phasemap.classify` and the
    ``flag_values`` of an atlas's ``n_solutions`` layer.

    Examples
    --------
    >>> import phasemap
    >>> [s.name.lower() for s in phasemap.Solvability]
    ['none', 'unique', 'two', 'continuum', 'three_or_more']
    >>> phasemap.Solvability(phasemap.classify("elliptic_pendulum", phi=0.8, xdot=-1.0,
    ...                                        f=4.0).n_solutions)
    <Solvability.TWO: 2>
    """

    NONE = nx.N_NONE, "no solution: the motion equations are inconsistent (Painleve paradox)"
    UNIQUE = nx.N_UNIQUE, "a unique solution"
    TWO = nx.N_TWO, "two solutions: indeterminacy, determinism fails"
    CONTINUUM = nx.N_CONTINUUM, "a continuum of solutions"
    THREE_OR_MORE = nx.N_THREE_OR_MORE, "three or more isolated solutions"


@dataclass(frozen=True)
class Variable:
    """A named scalar: state variable, parameter, acceleration or reaction.

    Its units, long name and symbol label the maps and the atlas variables;
    ``default`` and the domain (``lower``, ``upper``, open or closed) are what
    :func:`phasemap.classify` and :class:`phasemap.Scene` check values against.

    Examples
    --------
    >>> import phasemap
    >>> phi = phasemap.MODELS["ladder"].variables["phi"]
    >>> phi.units, phi.long_name, phi.lower, round(phi.upper, 4)
    ('rad', 'angle of the bar from the vertical', 0.0, 1.5708)
    """

    name: str
    units: str
    long_name: str
    symbol: str = ""
    default: float | None = None
    lower: float = -math.inf
    upper: float = math.inf
    lower_open: bool = False
    upper_open: bool = False

    def _fine(self, x: float) -> bool:
        """Whether the number ``x`` passes every test of :meth:`check` (which explains a
        failure)."""
        return (math.isfinite(x) and abs(x) <= MAX_MAGNITUDE
                and not (self.lower == 0.0 and self.lower_open and 0.0 < x < MIN_POSITIVE)
                and (x > self.lower if self.lower_open else x >= self.lower)
                and (x < self.upper if self.upper_open else x <= self.upper))

    def domain_text(self) -> str:
        lo = "(" if self.lower_open else "["
        hi = ")" if self.upper_open else "]"
        return f"{lo}{_fmt(self.lower)}, {_fmt(self.upper)}{hi}"

    def check(self, model: str, value) -> None:
        """Raise ValueError unless every element of ``value`` is finite and in the domain."""
        if isinstance(value, (int, float)) and self._fine(float(value)):
            return  # a plain number in the domain: no array to build (a Scene checks several)
        try:
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{model}: {self.name} must be a number, got {value!r}") from None
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{model}: {self.name} must be finite, got {_show(a)}")
        if np.any(np.abs(a) > MAX_MAGNITUDE):
            raise ValueError(
                f"{model}: {self.name} = {_show(a[np.abs(a) > MAX_MAGNITUDE])} is too large: "
                f"values are limited to |{self.name}| <= {MAX_MAGNITUDE:g} {self.units} so "
                "that products stay finite in double precision")
        if self.lower == 0.0 and self.lower_open and np.any((a > 0) & (a < MIN_POSITIVE)):
            raise ValueError(
                f"{model}: {self.name} = {_show(a[(a > 0) & (a < MIN_POSITIVE)])} is too small: "
                f"{self.long_name} must be at least {MIN_POSITIVE:g} {self.units} so that "
                "quotients stay finite in double precision")
        too_low = a <= self.lower if self.lower_open else a < self.lower
        too_high = a >= self.upper if self.upper_open else a > self.upper
        if np.any(too_low) or np.any(too_high):
            bad = a[too_low | too_high] if a.ndim else a
            raise ValueError(
                f"{model}: {self.name} = {_show(bad)} is outside its domain "
                f"{self.domain_text()} ({self.long_name}, {self.units})"
            )


@dataclass(frozen=True)
class Derived:
    """An input computed from one other input, once per value (e.g. sin(phi)).

    Examples
    --------
    >>> import phasemap
    >>> [(d.name, d.source) for d in phasemap.MODELS["hinge_pendulum"].derived]
    [('sin_phi', 'phi'), ('cos_phi', 'phi')]
    """

    name: str
    source: str
    func: Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Candidate:
    """One candidate branch of the friction law.

    ``name``
        how atlases, events and :func:`phasemap.classify` call it;
    ``direction``
        the sign of the relative velocity on the branch's stage: +1 or -1 for
        slip (or roll, or turn), 0 for the stick branch.  It decides where the
        branch applies: at zero velocity every branch is a candidate (a slip
        one starting from rest), otherwise only those whose direction is the
        velocity's sign;
    ``func``
        the branch function (see the module docstring);
    ``args``
        constants passed first to ``func`` (such as the direction itself);
    ``bound``
        ``(state variable, side)`` where the branch exists only on a closed bound of
        that variable (side 0 the lower, 1 the upper: a declared system's edge row,
        :mod:`phasemap.declare.edges`); a motion there moving out leaves the domain;
    ``edge``
        for a row that exists only on an edge, the compiled function of model inputs
        (by its parameter names) that says whether the state is on it: the row calls it
        and is absent where it is false, and a grid kernel calls it once per outer state
        where its inner axis does not enter it, and leaves the row out of the inner loop
        there (a declared system's edge rows).  None: the row is not restricted so.
    """

    name: str
    direction: float
    func: Callable = field(repr=False)
    args: tuple[float, ...] = ()
    bound: tuple[str, int] | None = None
    edge: Callable | None = field(default=None, repr=False)

    @classmethod
    def both_ways(cls, name: str, func: Callable) -> tuple[Candidate, Candidate]:
        """The two slip (or roll, or turn) branches ``name_pos`` and ``name_neg`` of one
        branch function whose first argument is the direction.

        >>> [(b.name, b.direction, b.args) for b in Candidate.both_ways("turn", print)]
        [('turn_pos', 1.0, (1.0,)), ('turn_neg', -1.0, (-1.0,))]
        """
        return (cls(f"{name}_pos", 1.0, func, (1.0,)), cls(f"{name}_neg", -1.0, func, (-1.0,)))


@dataclass(frozen=True)
class Dynamics:
    """How a model moves: what the time integrator needs beyond its branches.

    ``coordinates``
        ``(position, velocity, acceleration)`` name triples, one per degree of
        freedom.  The integrated vector is the positions, then the velocities.
        A position that is not a model input (the elliptic pendulum's slider
        position ``x``) is described in ``positions``.
    ``stick_is_rest``
        the stick branch freezes the whole state (one degree of freedom), so
        reaching it ends the motion.
    ``edges``
        optional ``{state name: (at the lower bound, at the upper bound)}``:
        what reaching an edge of the domain means for the body (the ladder
        lying flat).  A motion that reaches one ends with ``left_domain`` and
        this text.

    The integrator evaluates a branch *along its stage* with
    :attr:`Model.branch`: the slip direction is the branch's own, whatever the
    sign of the velocity, so that the right-hand side stays smooth across the
    trial points of a step that overshoots a velocity zero.

    Examples
    --------
    >>> import phasemap
    >>> phasemap.MODELS["hinge_pendulum"].dynamics.coordinates
    (('phi', 'omega', 'phi_ddot'),)
    >>> phasemap.MODELS["elliptic_pendulum"].dynamics.stick_is_rest
    False
    """

    coordinates: tuple[tuple[str, str, str], ...]
    positions: tuple[Variable, ...] = ()
    stick_is_rest: bool = True
    edges: Mapping[str, tuple[str, str]] = field(default_factory=dict)


# ------------------------------------------------ what hand models share -----
#: sin and cos of the angle ``phi``, computed once per value (per axis on a grid).
SIN_COS_PHI = (Derived("sin_phi", "phi", np.sin), Derived("cos_phi", "phi", np.cos))


def angle_state(body: str, angle: str, default: float = 0.0, lower: float = -math.inf,
                upper: float = math.inf) -> tuple[Variable, Variable]:
    """The state ``(phi, omega)`` of a ``body`` turning on one ``angle`` (its long name).

    >>> [v.long_name for v in angle_state("rod", "angle of the rod from the vertical")]
    ['angle of the rod from the vertical', 'angular velocity of the rod']
    """
    return (Variable("phi", "rad", angle, "\\varphi", default, lower, upper),
            Variable("omega", "rad s-1", f"angular velocity of the {body}", "\\omega", 0.0))


def angular_acceleration(body: str) -> Variable:
    """The acceleration ``phi_ddot`` of a ``body`` turning on the angle ``phi``.

    >>> angular_acceleration("disc").units
    'rad s-2'
    """
    return Variable("phi_ddot", "rad s-2", f"angular acceleration of the {body}",
                    "\\ddot\\varphi")


def gravity_and_mass(mass: str) -> tuple[Variable, Variable]:
    """The parameters ``g`` (9.81 m s-2) and ``m`` (1 kg, described as ``mass``).

    >>> [(v.name, v.default) for v in gravity_and_mass("mass of the bob")]
    [('g', 9.81), ('m', 1.0)]
    """
    return (Variable("g", "m s-2", "gravitational acceleration", "g", 9.81, 0.0),
            Variable("m", "kg", mass, "m", 1.0, 0.0, lower_open=True))


def one_angle(body: str, motion: str, move: Callable, stick: Callable,
              velocity_scale: Callable, edges: Mapping[str, tuple[str, str]] | None = None
              ) -> dict[str, object]:
    """The :class:`Model` keywords every hand model of one ``body`` turning on ``phi`` shares.

    ``derived`` (:data:`SIN_COS_PHI`), ``candidates`` (the two ``motion`` branches of
    ``move`` and the ``stick`` branch), ``accelerations``, ``velocity`` (``omega``),
    ``velocity_scale`` and ``dynamics`` (the coordinate ``phi``, with the ``edges`` of
    :class:`Dynamics`), to pass as ``Model(name=..., **one_angle(...), ...)``.

    >>> kw = one_angle("rod", "turn", print, print, print)
    >>> [b.name for b in kw["candidates"]], kw["dynamics"].coordinates
    (['turn_pos', 'turn_neg', 'stick'], (('phi', 'omega', 'phi_ddot'),))
    """
    return dict(derived=SIN_COS_PHI,
                candidates=(*Candidate.both_ways(motion, move), Candidate("stick", 0.0, stick)),
                accelerations=(angular_acceleration(body),), velocity="omega",
                velocity_scale=velocity_scale,
                dynamics=Dynamics(coordinates=(("phi", "omega", "phi_ddot"),),
                                  edges=dict(edges or {})))


@dataclass(frozen=True)
class Model:
    """One mechanical system: its variables, branches and jitted point function.

    The contract a new model implements is the "for developers" section of
    the module docstring of :mod:`phasemap.core.model`; a declared system builds its
    Model itself (:class:`phasemap.declare.System`).

    Examples
    --------
    >>> import phasemap
    >>> model = phasemap.get_model("wheel")
    >>> model.title
    'Disc with a displaced centre of mass, rolling with rolling friction'
    >>> [v.name for v in model.state], model.velocity, list(model.defaults)[:3]
    (['phi', 'omega'], 'omega', ['phi', 'omega', 'delta'])
    """

    name: str
    title: str
    citation: str
    state: tuple[Variable, ...]
    params: tuple[Variable, ...]
    derived: tuple[Derived, ...]
    candidates: tuple[Candidate, ...]
    accelerations: tuple[Variable, ...]
    reactions: tuple[Variable, ...]
    coefficient: Variable
    velocity: str
    velocity_scale: Callable = field(repr=False)
    check: Callable[[Mapping[str, object]], None] | None = field(default=None, repr=False)
    #: A map worth drawing first: ``{name: (start, stop, count)}`` for the CLI's defaults.
    default_axes: Mapping[str, tuple[float, float, int]] = field(default_factory=dict)
    #: How the model moves in time (None: classification and maps only).
    dynamics: Dynamics | None = field(default=None, repr=False)
    #: The :class:`phasemap.declare.System` a declared model was derived from.
    declaration: object = field(default=None, repr=False, compare=False)
    #: A hand-written model's declared twin: the module (its ``SYSTEM``) of a declaration
    #: of the same physics whose branches carry this model's names.  The bifurcation set
    #: reads the twin's admissibility conditions (:func:`phasemap.declare.twin`).
    twin: str | None = field(default=None, repr=False, compare=False)
    #: Optional branch function (same conventions, no ``rest``) returning True where a
    #: state is in the model's domain beyond the bounds of its variables (the rod on a
    #: step must touch the step); a motion that leaves it ends with ``left_domain``.
    inside: Callable | None = field(default=None, repr=False)
    #: What leaving that domain means, for the ``left_domain`` message.
    domain_text: str = ""
    #: Reactions whose sign enters a branch's law within the branch (the hinge
    #: pendulum's R_n, through |Q_n|): phi'' has a kink where one changes sign, and a
    #: phase curve ends its panel there.  A reaction whose sign change ends the
    #: branch's stage (a contact that would pull) or does not enter the law (the
    #: wheel's friction force) is not one.  None: every reaction (safe, and slower).
    kinks: tuple[str, ...] | None = None

    # -- branches and the generated contract --------------------------------
    @property
    def branches(self) -> tuple[str, ...]:
        """The names of the candidate branches, in row order."""
        return tuple(b.name for b in self.candidates)

    @property
    def stick_branch(self) -> int:
        """The row of the stick branch (direction 0), or -1 when there is none."""
        rows = [i for i, b in enumerate(self.candidates) if b.direction == 0.0]
        return rows[0] if rows else -1

    @property
    def directions(self) -> tuple[float, ...]:
        """Per branch, the sign of the relative velocity on its stage."""
        return tuple(float(b.direction) for b in self.candidates)

    def __reduce_ex__(self, protocol):
        # A declared model's branch functions live in a generated module that
        # another process (a dask worker) has not imported: ship the
        # declaration, which rebuilds the model from the kernel cache there.
        if self.declaration is not None:
            return _declared_model, (self.declaration,)
        return super().__reduce_ex__(protocol)

    def __getstate__(self):
        # The generated contract is a module (not picklable) and is rebuilt on
        # demand: a model shipped to a dask worker goes without it.
        state = dict(self.__dict__)
        state.pop("contract", None)
        return state

    @functools.cached_property
    def contract(self):
        """The generated per-point module: ``point``, ``branch`` and ``derive``."""
        from phasemap.core.codegen import contract

        return contract(self)

    @property
    def point(self) -> Callable:
        """``point(v, out)``: every candidate row at the state ``v`` (jitted).

        ``v`` holds the values of :attr:`inputs`; ``out`` has one row per branch
        (status, singular flag, coefficient, accelerations, reactions), NaN in
        what a branch does not determine and in every field of a branch that
        does not apply.
        """
        return self.contract.point

    @property
    def branch(self) -> Callable:
        """``branch(v, b, row)``: branch ``b`` along its stage, into ``row`` (jitted)."""
        return self.contract.branch

    @property
    def derive(self) -> Callable:
        """``derive(v)``: fill the derived inputs of ``v`` from its state and parameters."""
        return self.contract.derive

    # -- names -------------------------------------------------------------
    @functools.cached_property
    def names(self) -> tuple[str, ...]:
        """State then parameter names: what a user may set or sweep."""
        return tuple(v.name for v in self.state + self.params)

    @functools.cached_property
    def inputs(self) -> tuple[str, ...]:
        """The layout of the point function's input vector ``v``."""
        return self.names + tuple(d.name for d in self.derived)

    @property
    def variables(self) -> dict[str, Variable]:
        return {v.name: v for v in self.state + self.params}

    def variable(self, name: str) -> Variable:
        """The :class:`Variable` of ``name``: a state variable, a parameter, or a position the
        model integrates but does not take as an input (``dynamics.positions``: a point
        block's position on an incline, whose equations depend on its velocity only)."""
        extra = {v.name: v for v in (self.dynamics.positions if self.dynamics else ())}
        return {**extra, **self.variables}[name]

    @property
    def defaults(self) -> dict[str, float]:
        return {v.name: float(v.default) for v in self.state + self.params}

    @property
    def n_fields(self) -> int:
        return nx.FIRST_ACC + len(self.accelerations) + len(self.reactions)

    @property
    def first_reaction(self) -> int:
        """The column of a branch row that holds the first reaction (the rest follow)."""
        return nx.FIRST_ACC + len(self.accelerations)

    # -- validation --------------------------------------------------------
    def complete(self, values: Mapping[str, object]) -> dict[str, object]:
        """Validate user values (scalars or arrays) and fill in the defaults.

        Raises ValueError naming the model and the variable for an unknown
        name, a non-finite value or a value outside the domain.
        """
        defaults, variables = self._completion
        full: dict[str, object] = dict(defaults)
        if all(type(x) is float and n in full for n, x in values.items()):
            full.update(values)  # what _args.values makes of known names and Python floats
        else:
            full.update(_args.values(values, self.names, self.name))
        for name, var in variables:
            value = full[name]
            # An array whose least and greatest values pass passes whole: each variable's
            # domain is an interval (NaN fails); otherwise check names what fails.
            if not (isinstance(value, np.ndarray) and value.dtype == np.float64 and value.size
                    and var._fine(float(value.min())) and var._fine(float(value.max()))):
                var.check(self.name, value)
        if self.check is not None:
            self.check(full)
        return full

    @functools.cached_property
    def _completion(self) -> tuple[dict[str, float], tuple[tuple[str, Variable], ...]]:
        """What :meth:`complete` starts from, made once: the defaults, and each variable
        by name (a call of a sweep validates its values only)."""
        return self.defaults, tuple(self.variables.items())

    def input_vector(self, values: Mapping[str, float]) -> np.ndarray:
        """The point function's ``v`` for complete scalar values."""
        v = np.empty(len(self.inputs))
        for i, name in enumerate(self.names):
            v[i] = float(values[name])
        for j, d in enumerate(self.derived):
            v[len(self.names) + j] = d.func(float(values[d.source]))
        return v


def _declared_model(declaration) -> Model:
    """The model of a declaration (how a declared model is unpickled): the declaration
    rebuilds it, from the kernel cache."""
    return declaration.model


def _fmt(x: float) -> str:
    return _args.bound(x)


def _show(a: np.ndarray) -> str:
    flat = np.ravel(a)
    if flat.size == 1:
        return _args.bound(flat[0])
    return f"[{', '.join(map(_args.bound, flat[:3]))}{', ...' if flat.size > 3 else ''}]"
