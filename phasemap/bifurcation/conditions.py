"""The conditions a tracer follows, and their exact derivatives as generated numba code.

A class boundary of a map is the zero set of one scalar **condition** that
decides a branch's admissibility (GUIDE section 7).  A declared system lists
its own (:func:`phasemap.declare.conditions`); a hand-written model uses the
conditions of its declared twin (:attr:`phasemap.Model.twin`), while
its class still comes from its own kernels.  To these the model's relative velocity is
added (a ``velocity`` condition): where it changes sign the candidate branches
change.

Each condition is made smooth before it is differentiated: an ``Abs(u)`` in
it is split into the sign cases ``u`` and ``-u`` (both zero sets together are
the original's), so that Newton's method and the fold conditions see smooth
functions.  sympy then differentiates every condition with respect to the
variables a computation moves in (the two axes of a slice, a threshold's
parameters), and the values and gradients are printed as numba functions
into real ``.py`` files in the kernel cache (GUIDE section 6),
named after a hash of what decides them, and imported:

``values(x, out, scale)``
    every condition's value and tie scale at the input vector ``x`` (the
    model's :attr:`~phasemap.Model.inputs`; only the names are read), in a module of
    its own (one per model, whatever the variables);
``gradient(k, x, g)``
    condition ``k``'s value and tie scale, its gradient in ``g``, for the conditions
    of the call at hand (a slice compiles only those that can bound a class in it);
``hessian(k, x, g, H)``
    the same, and its Hessian in ``H``, by forward differences of the exact
    gradient (it is only Newton's Jacobian where the residual is a value and a
    gradient: :func:`_hessian_by_differences`).

Both modules hold ``SPEC``, a JSON text with each condition's name,
branch, kind and ``rest_only``: a warm start loads the file without sympy.
"""

from __future__ import annotations

import hashlib
import json
import pathlib
import sys
from dataclasses import dataclass

import numba
import numpy as np

from phasemap.core.args import WrongType, describe
from phasemap.core.memo import Memo
from phasemap.core import codegen as _codegen
from phasemap._version import __version__
from phasemap.core.cache import load_module
from phasemap.core.model import Model
from phasemap.declare import admissibility as _declare
from phasemap.declare.loader import twin

__all__ = ["Condition", "Conditions", "conditions_of", "compiled"]

#: Kinds of condition (:attr:`Condition.kind`); ``velocity`` is added here.
KINDS = ("coefficient", "normal", "friction_limit", "start", "gap", "family", "discriminant",
         "root", "domain", "velocity")


@dataclass(frozen=True)
class Condition:
    """One scalar condition that decides a branch's status (the shape of
    :class:`phasemap.declare.Condition`).

    ``name``
        unique in the model, in its own names (``coef_slide_neg``, ``N_floor_stick``);
    ``branch``
        the branch whose status it decides ("" for the model as a whole);
    ``kind``
        one of :data:`KINDS`;
    ``expr``
        a sympy expression of the model's names (coordinates through ``sin``
        and ``cos`` of their symbols), smooth and without poles where it
        matters: its zero set is where the branch's status may change;
    ``scale``
        the tie scale: ``|expr| <= 1e-12 * scale`` counts as zero;
    ``strict``
        whether the admissible side is ``expr > 0`` (ties to the other side);
    ``rest_only``
        it applies only where the relative velocity is zero.
    """

    name: str
    branch: str
    kind: str
    expr: object
    scale: object = 1
    strict: bool = False
    rest_only: bool = False


# -- where conditions come from -------------------------------------------------------

def declared_model(model: Model) -> Model:
    """The declared model whose conditions describe ``model``: itself, or its twin (a
    declaration of the same physics whose branches carry the hand model's names,
    :attr:`phasemap.Model.twin`).

    ValueError when the model is hand-written and has no declared twin.
    """
    if model.declaration is not None:
        return model
    S = twin(model)
    if S is None:
        raise ValueError(
            f"{model.name}: the bifurcation set needs the model's conditions; it is "
            "hand-written and has no declared twin (phasemap.Model.twin): declare "
            "the system (phasemap.declare) or pass conditions= explicitly")
    return S.model


def conditions_of(model: Model) -> tuple:
    """Every condition of ``model`` (its declaration's, or its twin's in the hand model's
    names) and its relative velocity's."""
    declared_model(model)
    try:
        from phasemap.declare import conditions
    except ImportError:
        raise ValueError(f"{model.name}: this phasemap.declare provides no conditions(); "
                         "pass conditions= explicitly") from None
    return tuple(conditions(model)) + (velocity_condition(model),)


def velocity_condition(model: Model) -> Condition:
    """The model's relative velocity as a condition: the candidates change where it does."""
    import sympy as sp

    return Condition(model.velocity, "", "velocity", sp.Symbol(model.velocity, real=True),
                     sp.Symbol("_velocity_scale"))


def _smooth(cond) -> list[Condition]:
    """``cond`` without ``Abs``: one condition per sign case, each with cond's name.

    Variants equal up to sign are generated once.
    """
    import sympy as sp

    expr = sp.sympify(cond.expr)
    variants = [expr]
    while True:
        absolutes = sorted({a for e in variants for a in e.atoms(sp.Abs)}, key=sp.default_sort_key)
        if not absolutes:
            break
        a = absolutes[0]
        variants = [e.xreplace({a: s * a.args[0]}) for e in variants if e.has(a) for s in (1, -1)] \
            + [e for e in variants if not e.has(a)]
    out, seen = [], []
    for e in variants:
        x = sp.expand(e)
        if any(sp.expand(x - y) == 0 or sp.expand(x + y) == 0 for y in seen):
            continue
        seen.append(x)
        out.append(Condition(cond.name, cond.branch, cond.kind, e, cond.scale,
                             bool(cond.strict), bool(cond.rest_only)))
    return out


# -- the generated module ---------------------------------------------------------------

class Conditions:
    """The conditions of one model with their derivatives in ``variables``, compiled.

    ``values``: the compiled ``values(x, out, scale)`` of every condition (its own
    module, one per model whatever the variables); ``module``: the generated module of
    the derivatives (``gradient``, ``hessian``), None where only the values are
    compiled (:func:`values_of`); ``subset``: the conditions whose derivatives
    ``module`` holds (None: every one; for any other ``gradient`` returns NaN);
    ``names``, ``branches``, ``kinds``, ``rest_only``: per condition, in the
    module's order; ``tag``: a short hash naming the module.
    """

    def __init__(self, model: Model, variables: tuple[str, ...], module, values_module,
                 subset: tuple[int, ...] | None = None):
        self.model = model
        self.variables = variables
        self.module = module
        self.values = values_module.values
        self.subset = subset
        if module is not None and module.SPEC != values_module.SPEC:
            raise RuntimeError(f"{model.name}: the kernel cache's conditions modules "
                               f"{values_module.__name__} and {module.__name__} list "
                               "different conditions; clear the cache (phasemap cache clear)")
        spec = json.loads(values_module.SPEC)
        self.names = tuple(c["name"] for c in spec)
        self.branches = tuple(c["branch"] for c in spec)
        self.kinds = tuple(c["kind"] for c in spec)
        self.rest_only = np.array([c["rest_only"] for c in spec], dtype=bool)
        self.tag = (module or values_module).__name__.rsplit("_", 1)[-1]

    def __len__(self) -> int:
        return len(self.names)


#: (model, conditions given or None; variables, subset) -> the compiled Conditions
_COMPILED = Memo("conditions.compiled")
#: (model, conditions given or None) -> the Conditions with their values only
_VALUES_ONLY = Memo("conditions.values")


def compiled(model: Model, variables, conditions=None, subset=None) -> Conditions:
    """The model's conditions with exact derivatives in ``variables`` (names of the model:
    a slice's two axes, a threshold's parameters).

    ``conditions``: a sequence of :class:`Condition` to use instead of the
    model's own (the velocity condition is added to them too).  ``subset``: the
    indices of the conditions whose derivatives are needed (None: all of them); the
    others' are not compiled, which is most of a module's compile time on a slice
    where the velocity's sign leaves few branches (:func:`phasemap.bifurcation.tracing.
    make_slice`).  Generated once per model, variables, conditions and subset (sympy
    runs only then), then loaded from the kernel cache.
    """
    conditions = _given(model, conditions)
    variables = tuple(variables)
    for name in variables:
        if name not in model.names:
            raise ValueError(f"{model.name}: {name!r} is not a variable of the model; "
                             f"allowed: {', '.join(model.names)}")
    if subset is not None:
        subset = tuple(sorted({int(k) for k in subset}))
    return _COMPILED.get((model, conditions), (variables, subset),
                         lambda: _compile(model, variables, conditions, subset))


def values_of(model: Model, conditions=None) -> Conditions:
    """The model's conditions with their values only (no derivatives): what decides
    which conditions a slice needs, before their derivatives are compiled."""
    conditions = _given(model, conditions)
    return _VALUES_ONLY.get((model, conditions), (), lambda: Conditions(
        model, (), None, _values_module(model, *_source(model, conditions))))


def _given(model: Model, conditions):
    if conditions is not None:
        if isinstance(conditions, (str, bytes)) or not isinstance(conditions, (list, tuple)) \
                or not all(isinstance(c, (Condition, _declare.Condition)) for c in conditions):
            raise WrongType(f"{model.name}: conditions must be a list of "
                            f"phasemap.declare.Condition, got {describe(conditions)}")
        conditions = tuple(conditions)
    return conditions


def _source(model: Model, conditions) -> tuple:
    """``(hash, make)``: what decides the conditions' text, hashed with the code that
    prints them, and a function that lists them (sympy runs there)."""
    if conditions is None:
        key_text = _source_key(model)

        def make():
            return conditions_of(model)
    else:
        given = tuple(conditions) + (velocity_condition(model),)
        key_text = _explicit_key(given)

        def make():
            return given
    h = hashlib.sha256(key_text.encode())
    # the generated file imports the model's velocity scale by its module's name
    h.update(repr((model.name, model.inputs,
                   _module_of(model.velocity_scale).__name__)).encode())
    h.update(pathlib.Path(__file__).read_bytes())
    h.update(f"{numba.__version__} {np.__version__} {__version__}".encode())
    return h, make


def _values_module(model: Model, h, make):
    stem = f"{model.name}_condvalues_{h.hexdigest()[:16]}"
    return load_module(stem, lambda: _generate_values(model, make()))


def _compile(model: Model, variables: tuple, conditions, subset) -> Conditions:
    h, make = _source(model, conditions)
    values = _values_module(model, h.copy(), make)
    h.update(repr((variables, subset)).encode())
    stem = f"{model.name}_conditions_{h.hexdigest()[:16]}"
    module = load_module(stem, lambda: _generate(model, variables, make(), subset))
    return Conditions(model, variables, module, values, subset)


def _source_key(model: Model) -> str:
    """What decides a model's conditions, without deriving them: the declared model's
    generated module (its name hashes the declaration) and the code that lists them."""
    source = declared_model(model)
    parts = [_module_of(source.candidates[0].func).__name__, model.velocity,
             hashlib.sha256(pathlib.Path(_module_of(model.velocity_scale).__file__)
                            .read_bytes()).hexdigest()]
    from phasemap import declare

    root = pathlib.Path(declare.__file__)
    files = sorted(root.parent.glob("*.py")) if root.name == "__init__.py" else [root]
    for f in files:
        parts.append(hashlib.sha256(f.read_bytes()).hexdigest())
    return "\n".join(parts)


def _module_of(func):
    """The module a (jitted) function was defined in."""
    return sys.modules[getattr(func, "py_func", func).__module__]


def _explicit_key(conds) -> str:
    import sympy as sp

    return "\n".join(repr((c.name, c.branch, c.kind, sp.srepr(sp.sympify(c.expr)),
                           sp.srepr(sp.sympify(c.scale)), bool(c.strict), bool(c.rest_only)))
                     for c in conds)


# The generated functions are compiled (or loaded from numba's cache) when first called,
# not when their module is imported: a first boundaries traces on their interpreted twins
# while a background process compiles them (the drawer's 62 conditions take numba about
# 30 s; :func:`phasemap.bifurcation._trace.functions`).  The tracer takes each at its
# address, compiled for its signature (:data:`phasemap.bifurcation._trace.VALUES_SIG` and
# the next two).


#: The relative step of the Hessian's forward differences: the square root of the machine
#: epsilon, which balances the truncation (h) and the rounding (eps / h) errors.
_H_STEP = float(np.sqrt(np.finfo(float).eps))


def _hessian_by_differences(slots: list[int]) -> list[str]:
    """The text of the generated ``hessian(k, x, g, H)``: the value, the tie scale and the
    exact gradient of condition ``k`` at ``x`` (from ``gradient``), and its Hessian by
    forward differences of that exact gradient, symmetrised.

    The Hessian serves only as the Jacobian of Newton's method on systems whose residuals
    are values and exact gradients (a fold, an extremum, a tangency): an error of about
    1e-8 relative in it makes Newton's last step linear with that ratio and leaves the
    root where the exact residual puts it.  Printed symbolically it cost as much compile
    time as the gradient (the drawer: 36 s of 72 s for its conditions module); central
    differences cost n more gradients a call than these (the hinge pendulum's
    boundaries 10-24 % slower warm, against the printed Hessian).  The step is
    ``_H_STEP * max(1, |x_i|)``, rounded to what ``x_i + h`` represents; where the
    forward point is NaN (the edge of a condition's domain) the difference is backward.
    ``x`` is perturbed in place and restored bit for bit, and ``H``'s rows hold the
    shifted gradients, so the function needs no scratch of its own.
    """
    n = len(slots)
    return ['@njit(cache=True, error_model="numpy")',
            "def hessian(_k, _x, _g, _H):",
            '    """Condition k: (value, tie scale), its gradient into g and its Hessian '
            'into H (forward differences of the exact gradient)."""',
            "    _c, _s = gradient(_k, _x, _g)",
            f"    _slots = {tuple(slots)!r}",
            f"    for _i in range({n}):",
            "        _u = _x[_slots[_i]]",
            f"        _x[_slots[_i]] = _u + {_H_STEP!r} * max(1.0, abs(_u))",
            "        _h = _x[_slots[_i]] - _u",
            "        _row = _H[_i]",
            "        gradient(_k, _x, _row)",
            "        if np.isnan(_row).any():",
            "            _x[_slots[_i]] = _u - _h",
            "            _h = _x[_slots[_i]] - _u",
            "            gradient(_k, _x, _row)",
            "        _x[_slots[_i]] = _u",
            f"        for _j in range({n}):",
            "            _row[_j] = (_row[_j] - _g[_j]) / _h",
            f"    for _i in range({n}):",
            f"        for _j in range(_i + 1, {n}):",
            "            _H[_i, _j] = _H[_j, _i] = 0.5 * (_H[_i, _j] + _H[_j, _i])",
            "    return _c, _s", "", ""]


class _Printing:
    """What both generated modules print from: the conditions made smooth, their
    expressions and tie scales in one symbol per name, and :meth:`body`, which prints
    assignments with common subexpressions (sympy runs here, and only here), by the
    declared systems' own printer (:func:`phasemap.declare.emit.printer`)."""

    def __init__(self, model: Model, conds):
        import sympy as sp

        from phasemap.declare.emit import printer

        self.sp = sp
        self.model = model
        self.conds = conds = [c for cond in conds for c in _smooth(cond)]
        names = self.names = set(model.names)
        for c in conds:
            for s in sp.sympify(c.expr).free_symbols | sp.sympify(c.scale).free_symbols:
                if s.name not in names and s.name != "_velocity_scale":
                    raise ValueError(f"{model.name}: condition {c.name!r} uses {s.name!r}, "
                                     f"which is not a variable of the model "
                                     f"({', '.join(model.names)})")
        # one symbol per name (a user's sympy Symbol may differ in assumptions from ours)
        self.canon = canon = {n: sp.Symbol(n, real=True) for n in names}

        def canonical(e):
            e = sp.sympify(e)
            return e.xreplace({s: canon[s.name] for s in e.free_symbols if s.name in canon})

        self.exprs = [canonical(c.expr) for c in conds]
        self.scales = [canonical(c.scale) for c in conds]
        self.slot = {n: i for i, n in enumerate(model.inputs)}
        self.P = printer()
        self.fresh = sp.numbered_symbols("_t")
        # sin and cos of an input become locals computed once
        self.trig = {}
        for e in self.exprs + self.scales:
            for f in e.atoms(sp.sin, sp.cos):
                if f.args[0].is_Symbol:
                    self.trig[f] = sp.Symbol(f"_{type(f).__name__}_{f.args[0].name}", real=True)
        vscale = model.velocity_scale
        vargs = _codegen.input_names(vscale, 0, model.inputs, f"{model.name}: velocity_scale")
        self.vsc = f"VSCALE({', '.join(f'_x[{self.slot[n]}]' for n in vargs)})"
        self.head = ["import math", "import numpy as np", "from numba import njit",
                     _codegen.import_line(vscale, "VSCALE"), ""]
        spec = [{"name": c.name, "branch": c.branch, "kind": c.kind, "rest_only": c.rest_only}
                for c in conds]
        self.spec = f"SPEC = {json.dumps(spec)!r}"

    def load(self, used: set) -> list[str]:
        slot = self.slot
        lines = [f"    {n} = _x[{slot[n]}]" for n in sorted(used & self.names, key=slot.get)]
        for f, s in self.trig.items():
            if s.name in used:
                lines.append(f"    {s.name} = math.{type(f).__name__}({f.args[0].name})")
        return lines

    def body(self, pairs) -> list[str]:
        """Lines assigning ``target = expr`` for (target, expr), with common subexpressions."""
        sp, trig = self.sp, self.trig
        red_in = [e.xreplace(trig) for _, e in pairs]
        reps, red = sp.cse(red_in, symbols=self.fresh, order="none")
        used = set()
        for e in red_in:
            used |= {s.name for s in e.free_symbols}
        # a trig local is read through its argument's name
        used |= {f.args[0].name for f, s in trig.items() if s.name in used}
        lines = self.load(used)
        lines += [f"    {s} = {self.P.doprint(e)}" for s, e in reps]
        lines += [f"    {t} = {self.P.doprint(e)}" for (t, _), e in zip(pairs, red)]
        return lines

    def scale_of(self, e):
        sp = self.sp
        return e.xreplace({sp.Symbol("_velocity_scale"): sp.Symbol("_vscale")})


def _generate_values(model: Model, conds) -> str:
    """The text of the values module: every condition's value and tie scale."""
    pr = _Printing(model, conds)
    out = [f'"""Conditions of {model.name}, their values: generated by phasemap.bifurcation, '
           'do not edit."""', *pr.head]
    pairs = [(f"_out[{k}]", e) for k, e in enumerate(pr.exprs)]
    pairs += [(f"_scale[{k}]", pr.scale_of(s)) for k, s in enumerate(pr.scales)]
    out += ['@njit(cache=True, error_model="numpy")',
            "def values(_x, _out, _scale):",
            '    """Every condition\'s value into out, its tie scale into scale."""',
            f"    _vscale = {pr.vsc}"]
    out += pr.body(pairs) + ["", ""]
    out += [pr.spec, ""]
    return "\n".join(out)


def _generate(model: Model, variables: tuple[str, ...], conds, subset=None) -> str:
    """The text of the derivatives' module: ``gradient`` and ``hessian`` in ``variables``
    for the conditions of ``subset`` (None: all)."""
    pr = _Printing(model, conds)
    sp = pr.sp
    var_syms = [pr.canon[v] for v in variables]
    keep = range(len(pr.exprs)) if subset is None else subset
    which = "" if subset is None else f", for {len(keep)} of {len(pr.exprs)} conditions"
    out = [f'"""Conditions of {model.name}, their derivatives in ({", ".join(variables)})'
           f'{which}: generated by phasemap.bifurcation, do not edit."""', *pr.head]
    # every condition's body in its own branch of one function: numba's compile time is
    # about linear in the operations (the drawer's 62 conditions: 69 s in one function,
    # 67-76 s in 4 to 62), so only fewer operations save time: the conditions a slice
    # cannot meet are left out (subset); the Hessian is not printed
    # (_hessian_by_differences)
    gradient = ['@njit(cache=True, error_model="numpy")',
                "def gradient(_k, _x, _g):",
                '    """Condition k: (value, tie scale), its gradient into the arrays."""']
    for i, k in enumerate(keep):
        e, s = pr.exprs[k], pr.scales[k]
        grad = [sp.diff(e, v) for v in var_syms]
        first = [("_c", e), ("_s", pr.scale_of(s))] + [(f"_g[{j}]", d)
                                                      for j, d in enumerate(grad)]
        test = f"    {'if' if i == 0 else 'elif'} _k == {k}:"
        gradient += [test, f"        _vscale = {pr.vsc}"]
        gradient += ["    " + line for line in pr.body(first)] + ["        return _c, _s"]
    out += gradient + ["    return np.nan, np.nan", "", ""]
    out += _hessian_by_differences([pr.slot[v] for v in variables])
    out += [f"VARIABLES = {tuple(variables)!r}", f"SUBSET = {subset!r}", pr.spec, ""]
    return "\n".join(out)
