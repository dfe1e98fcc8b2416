"""Validation of a declaration: every problem as one ValueError naming the system and the part."""

from __future__ import annotations

import builtins
import keyword
import math
import re

from phasemap.declare.api import (SLIP_SPEED, SPECIAL_NAMES, TIME, Body, Coordinate, Parameter,
                                  sym, uses)
from phasemap.declare.law import ContactLaw

IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

#: Names the generated module uses itself (a parameter named ``abs`` would shadow
#: the builtin inside the kernels): Python's builtins and the module's globals.
RESERVED = frozenset(dir(builtins)) | {"rest", "math", "np", "njit", "NAN",
                                       "restrict_affine", "velocity_scale", "inside", "SPEC"}


def fail(system, part: str, why: str):
    raise ValueError(f"{system.name}: {part}: {why}")


def validate(S) -> None:
    """Raise one ValueError naming the system and every problem found, part by part
    (``name: part: why; part: why``).  The checks that do not depend on each other all
    run; one that needs an earlier part (the contacts need the bodies) runs only where
    that part is sound."""
    if not isinstance(S.name, str) or not IDENT.match(S.name):
        raise ValueError(f"a system's name must be an identifier, got {S.name!r}")
    problems: list[str] = []
    prefix = f"{S.name}: "

    def attempt(check, *args):
        try:
            return check(*args), True
        except ValueError as err:
            text = str(err)
            problems.append(text[len(prefix):] if text.startswith(prefix) else text)
            return None, False

    known, named = attempt(_declared_names, S)
    for part, why in _missing(S):
        problems.append(f"{part}: {why}")
    if named and not problems:
        at, valued = attempt(_check_values, S)
        expr = _expression_check(S, known)
        bodies = valued and attempt(_check_bodies, S, expr, at)[1]
        attempt(_check_potential, S, expr)
        for k, e in S.forces.items():
            nm = k.name if isinstance(k, Coordinate) else k
            if nm not in {c.name for c in S.coordinates}:
                problems.append(f"forces: {nm!r} is not a coordinate")
            else:
                attempt(expr, f"force on {nm}", e, (TIME.name,))
        attempt(expr, "dissipation", S.dissipation)
        if bodies and attempt(_check_contacts, S, expr, at)[1]:
            attempt(_check_period, S, expr, at)
    if problems:
        raise ValueError(prefix + "; ".join(problems))


def _declared_names(S) -> set[str]:
    """The names of the coordinates, rates and parameters (identifiers, each used once)."""
    names = {}
    for kind, items, cls in (("coordinate", S.coordinates, Coordinate),
                             ("parameter", S.parameters, Parameter)):
        if not isinstance(items, (tuple, list)):
            fail(S, f"{kind}s", "must be a tuple")
        for it in items:
            if not isinstance(it, cls):
                fail(S, f"{kind}s", f"{it!r} is not a {cls.__name__}")
            for nm in [it.name] + ([it.rate.name] if kind == "coordinate" and it.rate else []):
                if not IDENT.match(nm) or keyword.iskeyword(nm) \
                        or nm.startswith(("sin_", "cos_")):
                    fail(S, f"{kind} {nm!r}", "a name must be an identifier (not starting "
                         "with sin_ or cos_)")
                if nm in SPECIAL_NAMES:
                    fail(S, f"{kind} {nm!r}", "the name is phasemap's own (TIME is t, "
                         "SLIP_SPEED slip_speed, from phasemap.declare): rename it")
                if nm in RESERVED:
                    fail(S, f"{kind} {nm!r}", "the name is one the generated code uses (a "
                         "Python builtin or one of rest, math, np, NAN, ...): rename it")
                if nm in names:
                    fail(S, f"{kind} {nm!r}", f"the name is already used by a {names[nm]}")
                names[nm] = kind
    return set(names)


def _missing(S) -> list[tuple[str, str]]:
    """(part, why) for every part a system cannot do without and does not declare."""
    out = []
    if not S.coordinates:
        out.append(("coordinates", "declare at least one coordinate"))
    elif not any(c.rate for c in S.coordinates):
        out.append(("coordinates", "at least one coordinate needs a Rate (a state velocity)"))
    if not S.bodies:
        out.append(("bodies", "declare at least one Body (the system has no mass)"))
    if not S.contacts:
        out.append(("contacts", "declare at least one contact (a point contact, a rolling "
                    "contact or a joint): without dry friction phasemap has nothing to map"))
    return out


def _number(x) -> float | None:
    """``x`` as a float, or None where it is not a real number."""
    try:
        return float(x)
    except (TypeError, ValueError, OverflowError):
        return None


def _check_values(S):
    """Defaults finite and inside their domains, bounds ordered, a coordinate's bounds
    numbers or expressions of the parameters; returns ``at(e)``: an expression's value
    at the defaults (None where it is not a real number there)."""
    import sympy as sp

    params = {p.name for p in S.parameters}
    defaults = {}
    for kind, items in (("parameter", S.parameters), ("coordinate", S.coordinates)):
        for it in items:
            part = f"{kind} {it.name!r}"
            d = _number(it.default)
            if d is None or not math.isfinite(d):
                fail(S, part, f"its default must be a finite number, got {it.default!r}")
            defaults[it.name] = d
            if it.rate is not None if kind == "coordinate" else False:
                r = _number(it.rate.default)
                if r is None or not math.isfinite(r):
                    fail(S, f"rate {it.rate.name!r}", "its default must be a finite number, "
                         f"got {it.rate.default!r}")
                defaults[it.rate.name] = r
    subs = {sp.Symbol(k, real=True): sp.Float(v) for k, v in defaults.items()}

    def at(e):
        x = sym(e).xreplace(subs)
        return _number(x) if not x.free_symbols else None

    for kind, items in (("parameter", S.parameters), ("coordinate", S.coordinates)):
        for it in items:
            part = f"{kind} {it.name!r}"
            lo, hi = (_bound(S, part, side, getattr(it, side), params if kind == "coordinate"
                             else set(), at) for side in ("lower", "upper"))
            if lo > hi:
                fail(S, part, f"its lower bound {lo:g} is above its upper bound {hi:g}")
            d = defaults[it.name]
            if d < lo or d > hi or (d == lo and it.lower_open) or (d == hi and it.upper_open):
                fail(S, part, f"its default {d:g} is outside its domain "
                     f"{'(' if it.lower_open else '['}{lo:g}, {hi:g}"
                     f"{')' if it.upper_open else ']'}")
    return at


def _bound(S, part, side, b, params, at) -> float:
    """A bound's value at the defaults: a number, or (``params`` not empty) a Parameter or
    an expression of the parameters."""
    import sympy as sp

    x = _number(b)
    if x is not None and not math.isnan(x):
        return x
    try:
        e = sym(b)
    except (sp.SympifyError, TypeError):
        e = None
    names = {s.name for s in e.free_symbols} if e is not None else None
    if e is None or not names or not names <= params:
        what = "a number or an expression of the parameters" if params else "a number"
        fail(S, part, f"its {side} bound must be {what}, got {b!r}")
    x = at(e)
    if x is None or math.isnan(x):
        fail(S, part, f"its {side} bound {e} is not a real number at the parameters' defaults")
    return x


def _check_potential(S, expr) -> None:
    rates = {c.rate.name for c in S.coordinates if c.rate}
    used = sorted(s.name for s in expr("potential", S.potential).free_symbols
                  if s.name in rates)
    if used:
        fail(S, "potential", f"depends on the rate {used[0]!r}: a potential energy depends on "
             "the positions only (give velocity-dependent forces in forces=)")


def _expression_check(S, known):
    """``expr(part, e)``: ``e`` as a sympy expression of declared names, or a ValueError."""
    import sympy as sp

    def expr(part, e, allow=()):
        """``e`` as an expression of the declared names and the special names ``allow``
        (:data:`TIME`, :data:`SLIP_SPEED`) may use."""
        try:
            x = sym(e)
        except (sp.SympifyError, TypeError) as err:
            fail(S, part, f"{e!r} is not an expression ({err})")
        unknown = sorted(str(s) for s in x.free_symbols if str(s) not in known
                         and str(s) not in allow)
        if unknown:
            where = {TIME.name: "forces= and surface_velocity=",
                     SLIP_SPEED.name: "a point contact's friction="}
            if unknown[0] in where:
                const = "TIME" if unknown[0] == TIME.name else "SLIP_SPEED"
                fail(S, part, f"{unknown[0]!r} ({const}) may appear only in "
                     f"{where[unknown[0]]}")
            fail(S, part, f"unknown name {unknown[0]!r} (declared: {', '.join(sorted(known))})")
        stray = sorted(str(s) for s in x.free_symbols if s != sp.Symbol(str(s), real=True))
        if stray:       # sympy tells symbols apart by their assumptions, not their names
            fail(S, part, f"the symbol {stray[0]!r} is not the declared one (its sympy "
                 "assumptions differ): use the declared quantity itself (a Parameter, a "
                 "Coordinate, its .rate, TIME) rather than a new sp.Symbol")
        return x

    return expr


def _check_bodies(S, expr, at) -> None:
    import sympy as sp

    rates = {sp.Symbol(c.rate.name, real=True) for c in S.coordinates if c.rate}
    for i, b in enumerate(S.bodies):
        if not isinstance(b, Body):
            fail(S, "bodies", f"{b!r} is not a Body")
        if len(b.position) != 2:
            fail(S, f"body {i}", "position must be a pair (x, y)")
        for part, e in (("mass", b.mass), ("inertia", b.inertia), ("angle", b.angle),
                        ("position x", b.position[0]), ("position y", b.position[1])):
            if expr(f"body {i} {part}", e).free_symbols & rates:
                fail(S, f"body {i} {part}", "must not depend on a rate")
        if sym(b.mass) == 0:
            fail(S, f"body {i} mass", "is zero (a missing mass term)")
        for part, e, positive in (("mass", b.mass, True), ("inertia", b.inertia, False)):
            x = at(e)
            if x is not None and (x < 0 or (positive and x == 0)):
                fail(S, f"body {i} {part}", f"is {x:g} at the defaults: a {part} must be "
                     f"{'positive' if positive else 'at least 0'}")
        _mass_domain(S, i, b.mass)


def _mass_domain(S, i, mass) -> None:
    """A mass that is one parameter: its domain must exclude 0."""
    p = next((p for p in S.parameters if sym(mass) == sym(p)), None)
    if p is not None and (p.lower < 0 or (p.lower == 0 and not p.lower_open)):
        fail(S, f"body {i} mass", f"the domain of {p.name!r} includes masses <= 0: declare "
             "lower=0.0, lower_open=True")


def _check_contacts(S, expr, at) -> None:
    seen = set()
    state = frozenset(n for c in S.coordinates for n in (c.name, *([c.rate.name] if c.rate
                                                                   else [])))
    for c in S.contacts:
        if not isinstance(c, ContactLaw):
            fail(S, "contacts", f"{c!r} is not a PointContact, RollingContact or Joint")
        if not IDENT.match(c.name) or c.name in seen:
            fail(S, f"contact {c.name!r}", "a contact needs a unique identifier as its name")
        seen.add(c.name)
        c.validate(lambda part, why: fail(S, part, why), expr, state)
        kinetic = c.law_expr().xreplace({sym(SLIP_SPEED): 0})
        x = at(kinetic)
        if x is not None and x < 0:
            fail(S, f"contact {c.name!r} {c.friction_field}", f"is {x:g} at the defaults: a "
                 "friction coefficient must be at least 0")
        if getattr(c, "static_friction", None) is not None:
            fs = at(c.static_friction)
            if x is not None and fs is not None and fs < x:
                fail(S, f"contact {c.name!r} static_friction", f"is {fs:g} at the defaults, "
                     f"below the kinetic friction {x:g} (at zero speed): f_s >= f_k")
    if sum(c.squared_law for c in S.contacts) > 1:
        fail(S, "contacts", "at most one Joint with friction is supported (two friction "
             "moments make a system of quadratic equations)")


def _check_period(S, expr, at) -> None:
    """A system that depends on the time declares its forcing period, and only such a
    system does: a positive expression of the parameters."""
    timed = time_dependent(S)
    if S.period is None:
        if timed:
            fail(S, "period", "the forces or a surface's velocity depend on the time t: "
                 "declare the forcing period (period=, such as 2 * sp.pi / Omega)")
        return
    if not timed:
        fail(S, "period", "is declared, but nothing depends on the time t (TIME): drop it, "
             "or use TIME in forces= or surface_velocity=")
    e = expr("period", S.period)
    params = {p.name for p in S.parameters}
    if any(x.name not in params for x in e.free_symbols):
        fail(S, "period", f"must be an expression of the parameters, got {e}")
    x = at(e)
    if x is None or not x > 0:
        fail(S, "period", f"must be positive at the parameters' defaults, got {e}")


def time_dependent(S) -> bool:
    """Whether the declaration depends on the time (a forced system)."""
    return (any(uses(e, TIME) for e in S.forces.values())
            or any(uses(getattr(c, "surface_velocity", 0), TIME) for c in S.contacts))


def oscillator_features(S) -> list[str]:
    """What the declaration has that only its motion in full coordinates takes yet: the
    time, a moving surface, a static coefficient above the kinetic one, a friction law
    that depends on the sliding speed."""
    out = []
    if time_dependent(S):
        out.append("forcing in time")
    for c in S.contacts:
        if sym(getattr(c, "surface_velocity", 0)) != 0:
            out.append(f"a moving surface (contact {c.name!r})")
        fs = getattr(c, "static_friction", None)
        if fs is not None and sym(fs) != c.law_expr():
            out.append(f"static friction (contact {c.name!r})")
        if uses(c.law_expr(), SLIP_SPEED):
            out.append(f"speed-dependent friction (contact {c.name!r})")
    return out


def no_reduced_model(S) -> str | None:
    """Why the declaration ``S`` has no reduced model and what takes it instead, or None
    where it has one (the one text of :attr:`System.model` and :func:`phasemap.get_model`)."""
    found = oscillator_features(S)
    if not found:
        return None
    return (f"no reduced model (it has {' and '.join(found)}): phasemap.classify and "
            "phasemap.Scene map it in full coordinates, phasemap.simulate and "
            "phasemap.periodic_orbit move it; the phase curves and the bifurcation tracer "
            "need a reduced model")


def reduced_limits(S) -> None:
    """A ValueError where the declaration needs what its reduced model (maps, classify,
    the fate maps, the phase curves, the tracer) does not take yet: it runs in full
    coordinates (:func:`no_reduced_model`)."""
    why = no_reduced_model(S)
    if why:
        raise ValueError(f"{S.name}: {why}")
