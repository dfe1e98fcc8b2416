"""The build step: the generated module from the kernel cache (or derived and written
there), assembled into a :class:`phasemap.Model`."""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
from collections.abc import Mapping

import numpy as np

from phasemap.core import codegen as _codegen
from phasemap.core import numerics as nx
from phasemap.declare.runtime import checks, declare_sources
from phasemap._version import __version__
from phasemap.core.model import Candidate, Derived, Dynamics, Model, Variable
from phasemap.declare.api import Coordinate, numeric_bound, sym
from phasemap.declare.emit import GENERATION, module_source
from phasemap.declare.validation import IDENT, fail, reduced_limits, validate


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
    if sym(S.dissipation) != 0:      # (appended only where declared: the keys of the
        parts.append("dissipation " + e(S.dissipation))   # declarations before stay)
    if S.period is not None:
        parts.append("period " + e(S.period))
    for c in S.contacts:
        d = {k: (e(v) if not isinstance(v, (str, tuple)) else
                 (tuple(e(x) for x in v) if isinstance(v, tuple) else v))
             for k, v in c.__dict__.items() if k not in _UNLESS_SET or v != _UNLESS_SET[k]}
        parts.append(type(c).__name__ + repr(sorted(d.items())))
    parts.append(repr(sorted((k, tuple(v)) for k, v in S.default_axes.items())))
    parts.append(repr(sorted(S.edges.items())))
    parts.append(repr(getattr(S.check, "__qualname__", None)))
    return "\n".join(parts)


#: Contact fields a declaration's key holds only where they are set (they came after
#: atlases recorded their declarations' keys): the field's value when not set.
_UNLESS_SET = {"static_friction": None, "surface_velocity": 0}


def declaration_sha256(S) -> str:
    """SHA-256 (hex) of the declaration's canonical form: what an atlas records to be
    recomputed only from the very declaration it was made with."""
    return hashlib.sha256(canonical(S).encode()).hexdigest()


def cache_stem(S) -> str:
    """The generated module's name in the kernel cache: the declaration, the derivation's
    sources and the versions of what it runs on, hashed."""
    import numba
    import sympy as sp

    h = hashlib.sha256(canonical(S).encode())
    for f in declare_sources():
        h.update(f.read_bytes())
    h.update(f"{sp.__version__} {numba.__version__} {np.__version__} {__version__} "
             f"generation {GENERATION}".encode())
    return f"{S.name}_declared_{h.hexdigest()[:16]}"


def generated(S):
    """The generated module of ``S`` (validated; derived once, then loaded from the cache)."""
    validate(S)
    reduced_limits(S)
    return _codegen.load_module(cache_stem(S), lambda: module_source(S))


def build_model(S) -> Model:
    """Validate, derive (or load the derivation from the kernel cache) and build the Model."""
    module = generated(S)
    spec = json.loads(module.SPEC)
    state, params, moving = _variables(S, spec)
    explored = _default_axes(S, state, params, spec["scale_args"])
    reactions = _reactions(S, spec)
    renamed = [str(S.names.get(row[0], row[0])) for row in spec["rows"]]
    _check_distinct(S, renamed, reactions)
    candidates = tuple(Candidate(renamed[i], float(direction), getattr(module, fname), tuple(args),
                              None if bound is None else (bound[0], int(bound[1])),
                              None if edge is None else getattr(module, edge))
                       for i, (_, direction, _, fname, args, bound, edge)
                       in enumerate(spec["rows"]))
    positions = tuple(_variable(c, default=float(c.default)) for c in moving
                      if c.name not in spec["state_positions"])
    dynamics = Dynamics(coordinates=tuple((c.name, c.rate.name, f"{c.name}_ddot")
                                          for c in moving),
                        positions=positions, stick_is_rest=len(moving) == 1,
                        edges=dict(S.edges))
    model = Model(
        name=S.name, title=S.title, citation=S.citation, state=state, params=params,
        derived=tuple(Derived(nm, src, getattr(np, fn)) for nm, src, fn in spec["derived"]),
        candidates=candidates, accelerations=_accelerations(moving),
        reactions=tuple(reactions),
        coefficient=Variable("coef", "1", "determinant of the branch's contact problem, "
                             "relative to the magnitude of its terms"),
        velocity=spec["velocity"], velocity_scale=module.velocity_scale,
        default_axes=dict(S.default_axes) or explored,
        dynamics=dynamics, check=_checks(S, spec, module),
        declaration=S, inside=getattr(module, "inside", None),
        domain_text=_domain_text(spec),
        # every sign a mode's law depends on (a slip's, a two-sided contact's normal
        # force's) is fixed by the mode, so a reaction changing sign ends the mode's
        # stage instead of bending its law
        kinks=())
    explored.model = model
    return model


def _variable(x, **kw):
    import sympy as sp

    # no symbol declared: sympy's (rho -> \rho, x_a -> x_{a}), so figures stay mathtext
    return Variable(x.name, x.units, x.long_name, x.symbol or sp.latex(sp.Symbol(x.name)), **kw)


def _bounded(x):
    """The Variable of a quantity; a bound that is an expression of the parameters is
    left infinite here and checked by the model's ``check`` (:func:`_bounds_check`)."""
    lo, hi = (b if numeric_bound(b) else sign * math.inf
              for b, sign in ((x.lower, -1), (x.upper, 1)))
    return _variable(x, default=float(x.default), lower=float(lo), upper=float(hi),
                     lower_open=x.lower_open, upper_open=x.upper_open)


def _bounds_check(S):
    """``check(values)`` of the coordinates' bounds that are expressions of the
    parameters (None if there are none): a ValueError naming the coordinate and the bound."""
    import sympy as sp

    tests = []
    for c in S.coordinates:
        for side, b, is_open in (("lower", c.lower, c.lower_open), ("upper", c.upper,
                                                                    c.upper_open)):
            if numeric_bound(b):
                continue
            e = sym(b)
            names = sorted(s.name for s in e.free_symbols)
            f = sp.lambdify([sp.Symbol(n, real=True) for n in names], e, "numpy")
            tests.append((c.name, side, is_open, e, names, f))
    if not tests:
        return None

    def check(values):
        for name, side, is_open, e, names, f in tests:
            x = np.asarray(values[name], float)
            bound = f(*(np.asarray(values[n], float) for n in names))
            below = (x <= bound if is_open else x < bound) if side == "lower" else \
                (x >= bound if is_open else x > bound)
            if np.any(below):
                raise ValueError(f"{S.name}: {name} is outside its domain: its {side} bound "
                                 f"is {e} (= {np.max(bound) if side == 'lower' else np.min(bound):g})")

    return check


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
    """The model's Python-level domain check: the declaration's own and the generated
    ``inside`` (:func:`phasemap.declare.runtime.checks`, shared with a model loaded from the
    cache), then the coordinates' bounds that are expressions."""
    base = checks(S.name, S.check, getattr(module, "inside", None), _domain_text(spec))
    bounds = _bounds_check(S)
    if bounds is None or base is None:
        return bounds or base

    def check(values):
        base(values)
        bounds(values)

    return check


def _per_s2(units: str) -> str:
    return "s-2" if units == "1" else f"{units} s-2"


def _default_axes(S, state, params, scale_args):
    """A first map where the declaration gives none: the first state position with a
    finite domain (else its default +- pi) against the first contact's friction
    parameter (none if the law is not one parameter), over the range that holds the
    system's classes (:class:`ExploredAxes`: decided on first use)."""
    first = next((v for v in state if math.isfinite(v.lower) and math.isfinite(v.upper)),
                 None)
    if first is not None:
        position = (first.name, (first.lower, first.upper))
    else:
        v = next((v for v in state if v.name in {c.name for c in S.coordinates}), state[0])
        position = (v.name, (float(v.default) - math.pi, float(v.default) + math.pi))
    law = S.contacts[0].law_expr()
    friction = next((p for p in params if law.is_Symbol and p.name == law.name), None)
    return ExploredAxes(position, friction, scale_args)


class ExploredAxes(Mapping):
    """The default axes of a declared system without ``default_axes``, read off a coarse
    exploratory raster the first time they are asked for.

    The rule: the position axis spans its domain.  The friction axis starts at its
    lower bound; its upper end is the smallest of 1, 2, 4, 8 (within its domain) up
    to which every class (the pair n_solutions, stagnation) has appeared that a raster
    finds of 22 positions inside the domain x 24 friction values over [lower, 8], at
    the relative velocity zero and +-1 times its scale, every other value at its
    default: a paradox that needs f > 4/3 (the Painleve rod sliding back) is on the
    map whichever velocity the user then fixes.  512 x 512 cells.
    """

    def __init__(self, position, friction, scale_args):
        self._position, self._friction, self._scale_args = position, friction, scale_args
        self._axes = None
        #: the model it explores (set once the model is built)
        self.model = None

    def _explore(self) -> dict:
        name, (lo, hi) = self._position
        axes = {name: (lo, hi, 512)}
        p = self._friction
        if p is None or self.model is None:
            return axes
        f_lo = max(p.lower, 0.0)
        ends = [x for x in (1.0, 2.0, 4.0, 8.0) if x > f_lo and x <= p.upper] or [p.upper]
        first_seen = self._first_seen(name, lo, hi, p.name, f_lo, ends[-1])
        need = max(first_seen.values(), default=f_lo)
        axes[p.name] = (f_lo, next((x for x in ends if x >= need), ends[-1]), 512)
        return axes

    def _first_seen(self, name, lo, hi, fname, f_lo, f_hi) -> dict:
        """Each class's smallest friction on the raster."""
        m = self.model
        out = np.full((len(m.branches), m.n_fields), np.nan)
        values = dict(m.defaults)
        scale = float(m.velocity_scale(*(values[a] for a in self._scale_args)))
        seen: dict = {}
        for x, f, s in itertools.product(np.linspace(lo, hi, 24)[1:-1] if lo < hi else [lo],
                                         np.linspace(f_lo, f_hi, 24), (0.0, 1.0, -1.0)):
            values.update({name: float(x), fname: float(f), m.velocity: s * scale})
            try:
                m.complete(values)
            except ValueError:
                continue
            m.point(m.input_vector(values), out)
            n, stagnation, _, _ = nx.summarize(out, m.stick_branch)
            key = (int(n), bool(stagnation))
            seen[key] = min(seen.get(key, math.inf), float(f))
        return seen

    def _get(self) -> dict:
        if self._axes is None:
            self._axes = self._explore()
        return self._axes

    def __getitem__(self, key):
        return self._get()[key]

    def __iter__(self):
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())
