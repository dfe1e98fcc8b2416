"""The build step: the generated module from the kernel cache (or derived and written
there), assembled into a :class:`phasemap.Model`."""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import json
import math
import pathlib

import numpy as np

from .. import _codegen
from .. import _numerics as nx
from .._version import __version__
from ..model import Branch, Derived, Dynamics, Model, Variable
from .api import Coordinate, sym
from .emit import module_source
from .validation import IDENT, fail, validate


def canonical(S) -> str:
    """A text that changes whenever the declaration does (the disk cache key)."""
    import sympy as sp

    def e(x):
        return sp.srepr(sym(x))

    parts = [S.name, S.title, S.citation]
    for c in S.coordinates:
        parts.append(repr((c.name, c.units, c.long_name, c.default, c.lower, c.upper,
                           c.lower_open, c.upper_open, c.symbol)))
        if c.rate:
            parts.append(repr((c.rate.name, c.rate.units, c.rate.long_name, c.rate.default,
                               c.rate.symbol, e(c.rate.scale))))
    for p in S.parameters:
        parts.append(repr((p.name, p.units, p.long_name, p.default, p.lower, p.upper,
                           p.lower_open, p.upper_open, p.symbol)))
    for b in S.bodies:
        parts.append(repr([e(b.mass), e(b.position[0]), e(b.position[1]), e(b.inertia),
                           e(b.angle)]))
    parts.append(e(S.potential))
    parts.append(repr(sorted((k.name if isinstance(k, Coordinate) else k, e(v))
                             for k, v in S.forces.items())))
    for c in S.contacts:
        d = {k: (e(v) if not isinstance(v, (str, tuple)) else
                 (tuple(e(x) for x in v) if isinstance(v, tuple) else v))
             for k, v in c.__dict__.items()}
        parts.append(type(c).__name__ + repr(sorted(d.items())))
    parts.append(repr(sorted((k, tuple(v)) for k, v in S.default_axes.items())))
    parts.append(repr(sorted(S.edges.items())))
    parts.append(repr(getattr(S.check, "__qualname__", None)))
    return "\n".join(parts)


def cache_stem(S) -> str:
    """The generated module's name in the kernel cache: the declaration, the derivation's
    sources and the versions of what it runs on, hashed."""
    import numba
    import sympy as sp

    h = hashlib.sha256(canonical(S).encode())
    # every module of the package but the conditions, which the generated text does not use
    sources = [f for f in sorted(pathlib.Path(__file__).parent.glob("*.py"))
               if f.name != "admissibility.py"]
    for f in sources + [pathlib.Path(nx.__file__)]:
        h.update(f.read_bytes())
    h.update(f"{sp.__version__} {numba.__version__} {np.__version__} {__version__}".encode())
    return f"{S.name}_declared_{h.hexdigest()[:16]}"


def generated(S):
    """The generated module of ``S`` (validated; derived once, then loaded from the cache)."""
    validate(S)
    return _codegen.load_module(cache_stem(S), lambda: module_source(S))


def build_model(S) -> Model:
    """Validate, derive (or load the derivation from the kernel cache) and build the Model."""
    module = generated(S)
    spec = json.loads(module.SPEC)
    state, params, moving = _variables(S, spec)
    reactions = _reactions(S, spec)
    renamed = [str(S.names.get(row[0], row[0])) for row in spec["rows"]]
    _check_distinct(S, renamed, reactions)
    candidates = tuple(Branch(renamed[i], float(direction), getattr(module, fname), tuple(args))
                       for i, (_, direction, _, fname, args) in enumerate(spec["rows"]))
    positions = tuple(_variable(c, default=float(c.default)) for c in moving
                      if c.name not in spec["state_positions"])
    dynamics = Dynamics(coordinates=tuple((c.name, c.rate.name, f"{c.name}_ddot")
                                          for c in moving),
                        positions=positions, stick_is_rest=len(moving) == 1,
                        edges=dict(S.edges))
    return Model(
        name=S.name, title=S.title, citation=S.citation, state=state, params=params,
        derived=tuple(Derived(nm, src, getattr(np, fn)) for nm, src, fn in spec["derived"]),
        candidates=candidates, accelerations=_accelerations(moving),
        reactions=tuple(reactions),
        coefficient=Variable("coef", "1", "determinant of the branch's contact problem, "
                             "relative to the magnitude of its terms"),
        velocity=spec["velocity"], velocity_scale=module.velocity_scale,
        default_axes=dict(S.default_axes) or _default_axes(S, state, params),
        dynamics=dynamics, check=_checks(S, spec, module),
        declaration=S, inside=getattr(module, "inside", None),
        domain_text=_domain_text(spec),
        # every sign a mode's law depends on (a slip's, a two-sided contact's normal
        # force's) is fixed by the mode, so a reaction changing sign ends the mode's
        # stage instead of bending its law
        kinks=())


def _variable(x, **kw):
    import sympy as sp

    # no symbol declared: sympy's (rho -> \rho, x_a -> x_{a}), so figures stay mathtext
    return Variable(x.name, x.units, x.long_name, x.symbol or sp.latex(sp.Symbol(x.name)), **kw)


def _bounded(x):
    return _variable(x, default=float(x.default), lower=x.lower, upper=x.upper,
                     lower_open=x.lower_open, upper_open=x.upper_open)


def _variables(S, spec):
    """The state (positions the equations use, then rates), parameters and moving
    coordinates."""
    coords = {c.name: c for c in S.coordinates}
    moving = [c for c in S.coordinates if c.rate]
    state = tuple(_bounded(coords[nm]) for nm in spec["state_positions"])
    state += tuple(_variable(c.rate, default=float(c.rate.default)) for c in moving)
    return state, tuple(_bounded(p) for p in S.parameters), moving


def _accelerations(moving):
    return tuple(Variable(f"{c.name}_ddot", _per_s2(c.units),
                          f"second derivative of the {c.long_name}",
                          f"\\ddot{{{c.symbol or c.name}}}") for c in moving)


def reaction_variables(S) -> list[Variable]:
    """Every contact's reactions, with the declaration's ``names`` applied."""
    reactions = [v for c in S.contacts for v in c.reaction_variables()]
    return [dataclasses.replace(r, name=str(S.names[r.name])) if r.name in S.names else r
            for r in reactions]


def _reactions(S, spec) -> list[Variable]:
    """The reactions, renamed; a ValueError for a name in ``names`` that is neither a
    branch nor a reaction."""
    generated = [row[0] for row in spec["rows"]]
    plain = [v.name for c in S.contacts for v in c.reaction_variables()]
    unknown = sorted(set(S.names) - set(generated) - set(plain))
    if unknown:
        fail(S, "names", f"{unknown[0]!r} is not a branch or a reaction of the system; its "
             f"branches are {', '.join(generated)}; its reactions {', '.join(plain)}")
    return reaction_variables(S)


def _check_distinct(S, branches, reactions):
    for what, got in (("branch", branches), ("reaction", [r.name for r in reactions])):
        clash = sorted({n for n in got if got.count(n) > 1})
        bad = [n for n in got if not IDENT.match(n)]
        if clash or bad:
            fail(S, "names", f"{what} names must be distinct identifiers: {(clash or bad)[0]!r}")


def _domain_text(spec) -> str:
    names = spec.get("domain", [])
    if not names:
        return ""
    return ("the corner of contact " + " or ".join(repr(n) for n in names)
            + " leaves the body's edge (the contact no longer exists)")


def _checks(S, spec, module):
    """The model's Python-level domain check: the declaration's own, and ``inside``."""
    inside = getattr(module, "inside", None)
    if inside is None:
        return S.check
    names = list(inspect.signature(inside.py_func).parameters)
    text = _domain_text(spec)

    def check(values):
        if S.check is not None:
            S.check(values)
        vals = {}
        for n in names:
            src = n[4:] if n.startswith(("sin_", "cos_")) else n
            x = np.asarray(values[src], float)
            vals[n] = np.sin(x) if n.startswith("sin_") else (np.cos(x) if n.startswith("cos_")
                                                              else x)
        ok = np.vectorize(inside.py_func, otypes=[bool])(*(vals[n] for n in names))
        if not np.all(ok):
            raise ValueError(f"{S.name}: outside the domain: {text}")

    return check


def _per_s2(units: str) -> str:
    return "s-2" if units == "1" else f"{units} s-2"


def _default_axes(S, state, params):
    """A first map: the first state variable with a finite domain against the first friction law."""
    axes = {}
    for v in state:
        if math.isfinite(v.lower) and math.isfinite(v.upper):
            axes[v.name] = (v.lower, v.upper, 512)
            break
    else:
        v = state[0]
        axes[v.name] = (float(v.default) - math.pi, float(v.default) + math.pi, 512)
    law = S.contacts[0].law_expr()
    for p in params:
        if law.is_Symbol and p.name == law.name:
            axes[p.name] = (max(p.lower, 0.0), max(2.0 * p.default, 1.0), 512)
            break
    return axes
