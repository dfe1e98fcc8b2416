"""The contact laws: a point on a surface, a corner on an edge, a rolling disc, a joint.

Each is a :class:`phasemap.declare.law.ContactLaw`: its fields are the geometry
and the friction coefficient, its hooks say what it constrains, which modes it
has, which reactions each mode adds and when a mode is admissible.
"""

from __future__ import annotations

from dataclasses import dataclass

from phasemap.core.model import Variable
from phasemap.declare.api import sym
from phasemap.declare.law import (
    SEPARATED,
    SLIP,
    ROLL,
    STICK,
    STICKING,
    TURN,
    Accelerates,
    ContactLaw,
    Kinematics,
    Mode,
    Pushes,
    SquaredLaw,
    WithinAbsCone,
    WithinCone,
    WithinNormCone,
)


def _unit_normal(normal):
    import sympy as sp

    nv = [sym(a) for a in normal]
    norm = sp.sqrt(nv[0] ** 2 + nv[1] ** 2)
    return [sp.simplify(a / norm) for a in nv]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1]


@dataclass(frozen=True, eq=False)
class PointContact(ContactLaw):
    """A body point on the flat surface ``dot(normal, point) = offset`` with Coulomb friction.

    ``normal`` points into the free side; ``sided`` is ``"one"`` (N >= 0, the
    point may lift off) or ``"two"`` (a guide: N of either sign).  The
    tangential direction is the normal turned clockwise by 90 degrees, so
    ``normal=(0, 1)`` (a floor) slips positive along +x.

    Parameters
    ----------
    name : str
        names the contact's reactions (``N_<name>``, ``F_<name>``) and modes.
    point : tuple of two expressions
        the body point in contact.
    normal : tuple of two numbers, default (0, 1)
    offset : number or expression, default 0
    friction : Parameter or expression, optional
        the Coulomb coefficient (while slipping: the kinetic one); 0 for a smooth
        contact.  It may depend on the relative sliding speed
        :data:`phasemap.declare.SLIP_SPEED` (a Stribeck curve).
    sided : {"one", "two"}, default "one"
    long_name : str
    static_friction : Parameter or expression, optional
        the static coefficient f_s >= ``friction`` (at zero speed): the limit of
        sticking, and what a slip must overcome to start.  None: ``friction``.
    surface_velocity : expression, default 0
        the surface's own velocity along the tangent (a belt; an expression of the
        parameters and :data:`phasemap.declare.TIME`): slipping and sticking are
        relative to it, sticking means moving with the surface.

    A contact with ``static_friction``, ``surface_velocity`` or a speed-dependent
    ``friction`` moves in full coordinates (:func:`phasemap.simulate`,
    :mod:`phasemap.motion.hybrid`); the maps of such a system are not built yet.

    Examples
    --------
    >>> from phasemap.declare import Coordinate, Parameter, PointContact
    >>> x, y = Coordinate("x", "m", "end A"), Coordinate("y", "m", "height of end A")
    >>> f = Parameter("f", "1", "friction coefficient", default=0.5)
    >>> floor = PointContact("A", point=(x, y), normal=(0, 1), friction=f)
    >>> floor.sided, floor.friction.name
    ('one', 'f')
    """

    name: str
    point: tuple
    normal: tuple = (0, 1)
    offset: object = 0
    friction: object = None
    sided: str = "one"
    long_name: str = ""
    static_friction: object = None
    surface_velocity: object = 0

    friction_field = "friction"
    speed_field = "friction"
    slip_channel = "T"
    point_fields = ("point", "normal")
    scalar_fields = ("offset",)

    def check_choices(self, fail):
        if self.sided not in ("one", "two"):
            fail(f"sided must be 'one' or 'two', got {self.sided!r}")

    def validate(self, fail, expr, state_names=frozenset()) -> None:
        from phasemap.declare.api import TIME

        super().validate(fail, expr)
        part = f"contact {self.name!r}"
        if self.static_friction is not None:
            expr(f"{part} static_friction", self.static_friction)
        v = expr(f"{part} surface_velocity", self.surface_velocity, allow=(TIME.name,))
        state = sorted(x.name for x in v.free_symbols if x.name in state_names)
        if state:
            fail(f"{part} surface_velocity", f"depends on {state[0]!r}: a surface's velocity "
                 "is an expression of the parameters and the time t only")
        if sym(self.surface_velocity) != 0 and hasattr(self, "corner"):
            fail(f"{part} surface_velocity", "an edge contact's obstacle is a fixed corner: "
                 "it has no surface to move")

    def static_expr(self):
        """The static coefficient (the friction law at zero speed where not declared)."""
        from phasemap.declare.api import SLIP_SPEED

        if self.static_friction is not None:
            return sym(self.static_friction)
        return self.law_expr().xreplace({sym(SLIP_SPEED): 0})

    def kinematics(self, vel):
        nv = _unit_normal(self.normal)
        tv = [nv[1], -nv[0]]
        P = [sym(a) for a in self.point]
        vP = [vel(a) for a in P]
        return Kinematics(channels={"N": _dot(nv, vP), "T": _dot(tv, vP)},
                          gaps=[_dot(nv, P) - sym(self.offset)], constraints=("N",))

    def modes(self):
        if self.sided == "one":
            return (Mode(SLIP, 1), Mode(SLIP, -1), STICKING, Mode(SEPARATED))
        return tuple(Mode(SLIP, s, r) for s in (1, -1) for r in (1, -1)) + (STICKING,)

    def unknowns(self, mode, channels, problem):
        import sympy as sp

        f, n, nm = self.law_expr(), problem.n, self.name
        wN, wT = channels["N"][0], channels["T"][0]
        if mode.kind == SLIP:
            sig = problem.sign_symbol("sig", nm)
            problem.args.append(sig.name)
            r = sp.Integer(1)
            if self.sided == "two":
                rho = problem.sign_symbol("rho", nm)
                problem.args.append(rho.name)
                r = rho
            N = problem.new(nm, "N", [wN[j] - sig * r * f * wT[j] for j in range(n)],
                            channels["N"])
            problem.signs[nm] = sig
            return [N, -sig * r * f * N]
        if mode.kind == STICK:
            return [problem.new(nm, "N", wN, channels["N"]),
                    problem.new(nm, "F", wT, channels["T"])]
        return [sp.Integer(0), sp.Integer(0)]

    def requirements(self, mode, reactions):
        import sympy as sp

        N, F = reactions
        if mode.kind == SLIP:
            r = sp.Symbol(f"_k_rho_{self.name}", real=True) if self.sided == "two" else 1
            sig = sp.Symbol(f"_k_sig_{self.name}", real=True)
            return [Pushes(self.name, N, r), Accelerates(self.name, "T", sig, True)]
        if mode.kind == STICK and self.sided == "one":
            return [Pushes(self.name, N), WithinCone(self.name, self.law_expr(), N, F)]
        if mode.kind == STICK:
            return [WithinAbsCone(self.name, self.law_expr(), N, F)]
        return [Accelerates(self.name, "N")]

    def reaction_variables(self):
        return (Variable(f"N_{self.name}", "N", f"normal reaction of {self.what}"),
                Variable(f"F_{self.name}", "N", f"tangential (friction) force of {self.what}"))


@dataclass(frozen=True, eq=False)
class EdgeContact(PointContact):
    """A fixed corner ``corner`` touching a straight edge of a body.

    The edge passes through the body point ``point`` with the direction angle
    ``angle`` (counter-clockwise from +x; the edge turns with the body).  The
    contact point slides along the edge; the normal force acts at the corner
    along the edge's normal.  ``side=+1`` when the corner touches the edge from
    its right (below an edge pointing along +x: a rod resting on a step), -1
    from its left.  Friction, ``sided`` and the modes are those of a
    :class:`PointContact`; the slip velocity is the body's material velocity
    at the corner along the edge.

    Parameters
    ----------
    name, point, normal, offset, friction, sided, long_name
        as for :class:`PointContact`.
    corner : tuple of two numbers or expressions, default (0, 0)
    angle : expression, default 0
        the edge's direction angle.
    side : {1, -1}, default 1
    extent : (low, high), optional
        where the edge is, as distances from ``point`` along it: a state with
        the corner outside is not in the model (the rod on a step: ``(0, 2 * l)``).

    Examples
    --------
    The rod on a step (``phasemap/systems/rod_on_step.py``) rests on the floor
    and across the step's edge:

    >>> from phasemap.systems import rod_on_step
    >>> [(type(c).__name__, c.name) for c in rod_on_step.SYSTEM.contacts]
    [('PointContact', 'floor'), ('EdgeContact', 'edge')]
    """

    corner: tuple = (0, 0)
    angle: object = 0
    side: int = 1
    #: optional ``(low, high)``: where along the edge (from ``point``, along the edge's
    #: direction) the corner may touch it, such as ``(0, 2 * l)`` for a rod of length
    #: 2l; outside, the state is outside the model's domain
    extent: tuple | None = None

    point_fields = ("point", "normal", "corner")
    scalar_fields = ("angle", "offset")

    def check_choices(self, fail):
        super().check_choices(fail)
        if self.side not in (1, -1):
            fail(f"side must be +1 or -1, got {self.side!r}")

    def kinematics(self, vel):
        import sympy as sp

        a = sym(self.angle)
        e = [sp.cos(a), sp.sin(a)]
        nv = [-self.side * sp.sin(a), self.side * sp.cos(a)]
        P = [sym(v) for v in self.point]
        K = [sym(v) for v in self.corner]
        w = vel(a)
        # the body's material velocity at the corner
        vK = [vel(P[0]) - w * (K[1] - P[1]), vel(P[1]) + w * (K[0] - P[0])]
        domain = {}
        if self.extent is not None:
            along = e[0] * (K[0] - P[0]) + e[1] * (K[1] - P[1])
            domain = {"low": along - sym(self.extent[0]), "high": sym(self.extent[1]) - along}
        return Kinematics(channels={"N": _dot(nv, vK), "T": _dot(e, vK)},
                          gaps=[nv[0] * (P[0] - K[0]) + nv[1] * (P[1] - K[1])],
                          constraints=("N",), domain=domain)


@dataclass(frozen=True, eq=False)
class RollingContact(ContactLaw):
    """A disc (centre ``centre``, radius ``radius``, counter-clockwise angle ``angle``)
    rolling without slip on ``dot(normal, point) = offset``, with a rolling-friction
    moment ``rolling_friction * N``.  One-sided: the disc may hop.

    Parameters
    ----------
    name : str
    centre : tuple of two expressions
    radius : Parameter or expression
    angle : expression
        the disc's rotation angle (counter-clockwise).
    normal, offset
        the surface, as for :class:`PointContact`.
    rolling_friction : Parameter or expression, optional
        the rolling friction coefficient (a length).
    long_name : str

    Examples
    --------
    The seed paper's wheel, declared (``phasemap/systems/seeds/wheel.py``):

    >>> from phasemap.systems.seeds import wheel
    >>> disc = wheel.SYSTEM.contacts[0]
    >>> type(disc).__name__, disc.radius.name, disc.rolling_friction.name
    ('RollingContact', 'r', 'delta')
    """

    name: str
    centre: tuple
    radius: object
    angle: object
    normal: tuple = (0, 1)
    offset: object = 0
    rolling_friction: object = None
    long_name: str = ""

    friction_field = "rolling_friction"
    slip_channel = "S"
    point_fields = ("centre", "normal")
    scalar_fields = ("radius", "angle", "offset")

    def kinematics(self, vel):
        nv = _unit_normal(self.normal)
        tv = [nv[1], -nv[0]]
        P = [sym(a) for a in self.centre]
        vP = [vel(a) for a in P]
        spin = vel(self.angle)
        return Kinematics(
            channels={"N": _dot(nv, vP), "T": _dot(tv, vP) + sym(self.radius) * spin,
                      "S": spin},
            gaps=[_dot(nv, P) - sym(self.offset) - sym(self.radius)], constraints=("N", "T"))

    def modes(self):
        return (Mode(ROLL, 1), Mode(ROLL, -1), STICKING, Mode(SEPARATED))

    def unknowns(self, mode, channels, problem):
        import sympy as sp

        d, n, nm = self.law_expr(), problem.n, self.name
        wN, wT, wS = channels["N"][0], channels["T"][0], channels["S"][0]
        if mode.kind == ROLL:
            sig = problem.sign_symbol("sig", nm)
            problem.args.append(sig.name)
            N = problem.new(nm, "N", [wN[j] - sig * d * wS[j] for j in range(n)],
                            channels["N"])
            F = problem.new(nm, "F", wT, channels["T"])
            problem.signs[nm] = sig
            return [N, F, -sig * d * N]
        if mode.kind == STICK:
            return [problem.new(nm, "N", wN, channels["N"]),
                    problem.new(nm, "F", wT, channels["T"]),
                    problem.new(nm, "M", wS, channels["S"])]
        return [sp.Integer(0)] * 3

    def requirements(self, mode, reactions):
        import sympy as sp

        N, _, M = reactions
        if mode.kind == ROLL:
            sig = sp.Symbol(f"_k_sig_{self.name}", real=True)
            return [Pushes(self.name, N), Accelerates(self.name, "S", sig, True)]
        if mode.kind == STICK:
            return [Pushes(self.name, N), WithinCone(self.name, self.law_expr(), N, M)]
        return [Accelerates(self.name, "N")]

    def reaction_variables(self):
        return (Variable(f"N_{self.name}", "N", f"normal reaction of {self.what}"),
                Variable(f"F_{self.name}", "N", f"tangential (friction) force of {self.what}"),
                Variable(f"M_{self.name}", "N m", f"rolling-friction moment of {self.what}"))


@dataclass(frozen=True, eq=False)
class Joint(ContactLaw):
    """A body point pinned at ``at`` with a friction moment ``friction_radius * |R|``
    opposing the rotation ``angle`` (counter-clockwise).

    Parameters
    ----------
    name : str
    point : tuple of two expressions
        the body point pinned.
    angle : expression
        the rotation the friction moment opposes.
    at : tuple of two numbers, default (0, 0)
        the fixed pivot.
    friction_radius : Parameter or expression, optional
        the friction moment is ``friction_radius * |R|``, R the reaction.
    long_name : str

    Examples
    --------
    The seed paper's hinge pendulum, declared
    (``phasemap/systems/seeds/hinge_pendulum.py``):

    >>> from phasemap.systems.seeds import hinge_pendulum
    >>> hinge = hinge_pendulum.SYSTEM.contacts[0]
    >>> type(hinge).__name__, hinge.at, hinge.friction_radius.name
    ('Joint', (0, 0), 'delta')
    """

    name: str
    point: tuple
    angle: object
    at: tuple = (0, 0)
    friction_radius: object = None
    long_name: str = ""

    friction_field = "friction_radius"
    slip_channel = "S"
    squared_law = True
    point_fields = ("point", "at")
    scalar_fields = ("angle",)

    def kinematics(self, vel):
        P = [sym(a) for a in self.point]
        return Kinematics(channels={"X": vel(P[0]), "Y": vel(P[1]), "S": vel(self.angle)},
                          gaps=[P[0] - sym(self.at[0]), P[1] - sym(self.at[1])],
                          constraints=("X", "Y"))

    def modes(self):
        return tuple(Mode(TURN, s, root=r) for s in (1, -1) for r in (-1, 1)) + (STICKING,)

    def unknowns(self, mode, channels, problem):
        import sympy as sp

        nm = self.name
        wX, wY, wS = channels["X"][0], channels["Y"][0], channels["S"][0]
        X = problem.new(nm, "X", wX, channels["X"])
        Y = problem.new(nm, "Y", wY, channels["Y"])
        if mode.kind == TURN:
            sig, root = problem.sign_symbol("sig", nm), problem.sign_symbol("root", nm)
            problem.args += [sig.name, root.name]
            mu = sp.Symbol("_k_mu", real=True)
            problem.squared = SquaredLaw(nm, self.law_expr(), sig, root, mu)
            problem.extra = [problem.extra[j] + wS[j] * mu for j in range(problem.n)]
            problem.signs[nm] = sig
            return [X, Y, mu]
        return [X, Y, problem.new(nm, "M", wS, channels["S"])]

    def requirements(self, mode, reactions):
        import sympy as sp

        if mode.kind == TURN:
            sig = sp.Symbol(f"_k_sig_{self.name}", real=True)
            return [Accelerates(self.name, "S", sig, True)]
        return [WithinNormCone(self.name, self.law_expr(), *reactions)]

    def reaction_variables(self):
        return (Variable(f"Rx_{self.name}", "N", f"x component of the reaction of {self.what}"),
                Variable(f"Ry_{self.name}", "N", f"y component of the reaction of {self.what}"),
                Variable(f"M_{self.name}", "N m", f"friction moment of {self.what}"))
