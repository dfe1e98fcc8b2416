"""Validation of a declaration: every problem as one ValueError naming the system and the part."""

from __future__ import annotations

import keyword
import re

from .api import Body, Coordinate, Parameter, sym
from .law import ContactLaw

IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def fail(system, part: str, why: str):
    raise ValueError(f"{system.name}: {part}: {why}")


def validate(S) -> None:
    """Raise ValueError naming the system and the part for the first problem found."""
    if not isinstance(S.name, str) or not IDENT.match(S.name):
        raise ValueError(f"a system's name must be an identifier, got {S.name!r}")
    known = _declared_names(S)
    _check_present(S)
    expr = _expression_check(S, known)
    _check_bodies(S, expr)
    expr("potential", S.potential)
    for k, e in S.forces.items():
        nm = k.name if isinstance(k, Coordinate) else k
        if nm not in {c.name for c in S.coordinates}:
            fail(S, "forces", f"{nm!r} is not a coordinate")
        expr(f"force on {nm}", e)
    _check_contacts(S, expr)


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
                if not IDENT.match(nm) or keyword.iskeyword(nm) or nm in ("rest",) \
                        or nm.startswith(("sin_", "cos_")):
                    fail(S, f"{kind} {nm!r}", "a name must be an identifier (not 'rest', "
                         "not starting with sin_ or cos_)")
                if nm in names:
                    fail(S, f"{kind} {nm!r}", f"the name is already used by a {names[nm]}")
                names[nm] = kind
    return set(names)


def _check_present(S) -> None:
    if not S.coordinates:
        fail(S, "coordinates", "declare at least one coordinate")
    if not any(c.rate for c in S.coordinates):
        fail(S, "coordinates", "at least one coordinate needs a Rate (a state velocity)")
    if not S.bodies:
        fail(S, "bodies", "declare at least one Body (the system has no mass)")
    if not S.contacts:
        fail(S, "contacts", "declare at least one contact (a point contact, a rolling "
             "contact or a joint): without dry friction phasemap has nothing to map")


def _expression_check(S, known):
    """``expr(part, e)``: ``e`` as a sympy expression of declared names, or a ValueError."""
    import sympy as sp

    def expr(part, e):
        try:
            x = sym(e)
        except (sp.SympifyError, TypeError) as err:
            fail(S, part, f"{e!r} is not an expression ({err})")
        unknown = sorted(str(s) for s in x.free_symbols if str(s) not in known)
        if unknown:
            fail(S, part, f"unknown name {unknown[0]!r} (declared: {', '.join(sorted(known))})")
        return x

    return expr


def _check_bodies(S, expr) -> None:
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


def _check_contacts(S, expr) -> None:
    seen = set()
    for c in S.contacts:
        if not isinstance(c, ContactLaw):
            fail(S, "contacts", f"{c!r} is not a PointContact, RollingContact or Joint")
        if not IDENT.match(c.name) or c.name in seen:
            fail(S, f"contact {c.name!r}", "a contact needs a unique identifier as its name")
        seen.add(c.name)
        c.validate(lambda part, why: fail(S, part, why), expr)
    if sum(c.squared_law for c in S.contacts) > 1:
        fail(S, "contacts", "at most one Joint with friction is supported (two friction "
             "moments make a system of quadratic equations)")
