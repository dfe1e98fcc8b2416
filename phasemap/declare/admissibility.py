r"""The admissibility conditions of a declared model's branches, for the bifurcation tracer.

A class boundary of a map (``n_solutions``, ``stagnation``, ``contact_lost``)
is where one scalar condition that decides a branch's status changes sign
(GUIDE section 7).  :func:`conditions` lists every such condition of a
declared model, per candidate branch, in the model's row order and with the
model's own (possibly renamed) branch and reaction names, as sympy
expressions of the model's inputs.  They are built from the same contact-law
requirements (:mod:`phasemap.declare.law`) and the same solved rows
(:mod:`phasemap.declare.solvers`) as the generated branch functions, so they
are the same physics.

The contract of one :class:`Condition` ``c``
--------------------------------------------
* ``c.expr`` is smooth where the row is defined and has no poles: a quotient
  such as a reaction ``n / D`` is given by its numerator ``n``, and the
  denominator's sign enters through ``c.divisor``.  The tested value is
  ``v = sgn(c.divisor) * c.expr`` (``divisor`` 1: ``v = c.expr``).
* ``c.sense`` says which side is admissible, with the tie ``tol = 1e-12 *
  c.scale`` (``c.scale`` is the magnitude of the terms of ``c.expr``, as the
  kernels compute it): ``">= 0"``, ``v >= -tol`` (ties admissible);
  ``"> 0"``, ``v > tol`` (ties not); ``"!= 0"``, ``|v| > tol`` (a coefficient
  of the senior derivative: its zero set is where the branch is singular).
  ``c.strict`` is ``c.sense == "> 0"``.
* ``c.rest_only``: the condition applies only at zero relative velocity (a
  slip starting from rest); the expression is written with that velocity 0.
* ``c.where`` (or None): the condition applies only where ``c.where > 0``.
* Where a condition does not apply it counts as holding.
* The rows that exist only on an edge of the domain (``..._at_phi_max``, where a
  contact is at rest while the system moves: :mod:`phasemap.declare.edges`) have
  no conditions here: they apply on a line ``q = q*`` of a map, its border, where
  the tracer meets them as the end of the domain, not as a boundary it follows.  A branch is
  admissible (status ``ADMISSIBLE`` or ``SEPARATION``) exactly where it applies
  (at rest, or moving in its ``direction``; :func:`presence` tells the
  ``_moving_neg`` copies apart) and all its conditions hold;
  :meth:`Condition.holds` evaluates one with numpy.

Kinds and names (``<b>`` the branch's name, ``<c>`` a contact's)
----------------------------------------------------------------
``coefficient``
    ``coef_<b>``, the coefficient of the senior derivative, the quantity of the
    atlas layer ``coef_<b>`` (``!= 0``).  A turning joint's row has two:
    ``det_<b>``, the determinant of its linear part, and ``coef_<b>``, the
    leading coefficient of its squared law.
``normal``
    ``<N>_<b>`` (``<N>`` the reaction's model name, as in the layer
    ``N_floor_<b>``): a one-sided contact's ``N >= 0``, or a two-sided
    contact's assumed sign (``N >= 0``, or ``-N > 0``).
``friction_limit``
    ``limit_pos_<c>_<b>`` and ``limit_neg_<c>_<b>``, the two sides of a cone
    ``f N -+ F >= 0`` (a rolling contact: ``delta N -+ M``); a two-sided contact's
    ``limit_<c>_<b>``, ``f^2 N^2 - F^2 >= 0``; a joint's ``limit_<c>_<b>``,
    ``delta^2 |R|^2 - M^2 >= 0``.
``start``
    ``start_<c>_<b>``: a slip from rest starts in its direction (``> 0``,
    ``rest_only``).
``gap``
    ``gap_<c>_<b>``: a separated contact's gap accelerates open (``> 0``).
``family``
    ``family_<i>_<j>_<b>``, a statically indeterminate row (the ladder at rest):
    its reactions are ``L = (P + Dd t) / D`` and every form ``i`` is
    ``g0_i + g1_i t`` (``g0_i``, ``g1_i`` numerators over ``D``).  The family is
    nonempty iff every lower bound of ``t`` lies below every upper bound; the pair
    ``(i, j)`` gives ``expr = g0_j g1_i - g0_i g1_j``, ``divisor = D g1_i``, so
    that ``v`` is form ``j`` at the member where form ``i`` is tight, and applies
    ``where = -g1_i g1_j > 0`` (one bound below, one above).  Its zero set is
    where the two bounds meet (the ladder's static zone phi = 2 arctan f).  A form
    whose slope vanishes identically (a ray) adds no pair but is a condition of its
    own, named as in a determinate row (``expr = g0_i``, ``divisor = D``); the tie is
    the kernel's where both forms are inclusive.  ``slope_<form>_<b>`` (``expr =
    g1_i``, ``where = 0``: it never applies, so it decides nothing) marks where
    form ``i`` turns from a lower bound of ``t`` into an upper one: there the pairs
    start or stop applying, and a bound running off to infinity empties or fills
    the family, a class boundary on which no pair vanishes (a drawer jammed in its
    slot: its wedge line, where the reactions' internal squeeze leaves the
    friction cones).
``discriminant``, ``root``
    a turning joint's ``disc_<c>_<b>`` (the squared law has real roots:
    ``>= 0``, ``> 0`` for the second root so that a double root counts once) and
    ``root_<c>_<b>`` (the kept root opposes the rotation: ``-sigma M >= 0``).
``domain``
    ``domain_low_<c>``, ``domain_high_<c>`` (branch None): where the contact
    exists (a corner on a body's edge); outside, the state is not in the model.

Example
-------
The Painleve rod sliding back (``xdot < 0``): its coefficient vanishes where
``1 + 3 cos^2 theta - 3 f sin theta cos theta = 0``; past it (``f = 2``,
``theta = 1.1``) the normal force the slide needs is negative: a paradox.

>>> from phasemap.declare import conditions
>>> from phasemap.systems.painleve_rod import SYSTEM
>>> c = {c.name: c for c in conditions(SYSTEM)}
>>> c["coef_A_slip_neg"].expr
-3*f*sin(theta)*cos(theta) + 3*cos(theta)**2 + 1
>>> normal = c["N_A_A_slip_neg"]
>>> normal.kind, normal.sense, normal.expr
('normal', '>= 0', g*m/3 - l*m*omega**2*sin(theta)/3)
>>> normal.divisor
-f*sin(theta)*cos(theta) + cos(theta)**2 + 1/3
>>> state = dict(theta=1.1, omega=0.0, f=2.0, g=9.81, l=1.0, m=1.0)
>>> bool(c["coef_A_slip_neg"].holds(state)), bool(normal.holds(state))
(True, False)
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from phasemap.core.memo import Memo
from phasemap.core import numerics as nx
from phasemap.declare.algebra import pythagorean, scale_in, scale_of
from phasemap.declare.derivation import derive
from phasemap.declare.emit import accelerations, channel_acceleration, family_coefficients
from phasemap.declare.law import Accelerates
from phasemap.declare.modes import Presence
from phasemap.declare.solvers import joint_parts, solve_joint
from phasemap.declare.loader import twin
from phasemap.declare.system import System
from phasemap.declare.validation import validate

SENSES = ("!= 0", ">= 0", "> 0")


@dataclass(frozen=True)
class Condition:
    """One scalar condition that decides a branch's status (see the module docstring).

    Attributes
    ----------
    name, branch, kind : str
        the condition's label, its branch (None for the domain's) and its kind
        (``coefficient``, ``normal``, ``friction_limit``, ``start``, ``gap``,
        ``family``, ``discriminant``, ``root``, ``domain``).
    expr, scale : sympy expressions
        ``expr`` compared with 0 as ``sense`` says, with the tolerance scaled
        by ``scale``, the magnitude of its terms.
    sense : str
        ``">= 0"``, ``"> 0"`` or ``"!= 0"``.
    rest_only : bool
        applies only at zero relative velocity (a slip starting from rest).
    divisor, where
        the ``family`` conditions' divisor, and where a condition applies
        (``where > 0``; None: everywhere).  The module docstring has the rules.

    Examples
    --------
    >>> from phasemap.declare import conditions
    >>> from phasemap.systems.painleve_rod import SYSTEM
    >>> c = conditions(SYSTEM)[0]
    >>> c.name, c.branch, c.kind, c.sense
    ('N_A_stick', 'stick', 'normal', '>= 0')
    """

    name: str
    branch: str | None
    kind: str
    expr: object
    scale: object
    sense: str
    rest_only: bool = False
    divisor: object = 1
    where: object = None

    @property
    def strict(self) -> bool:
        return self.sense == "> 0"

    @property
    def symbols(self) -> tuple[str, ...]:
        """The input names it reads (coordinates, rates, parameters)."""
        import sympy as sp

        parts = [self.expr, self.scale, self.divisor] + ([self.where] if self.where is not None
                                                         else [])
        return tuple(sorted({s.name for p in parts for s in sp.sympify(p).free_symbols}))

    def value(self, values) -> np.ndarray:
        """``sgn(divisor) * expr`` at ``values`` (a mapping of input names to numbers or
        arrays)."""
        expr, _, divisor, _ = self._evaluated(values)
        return np.sign(divisor) * expr

    def holds(self, values, rest=False) -> np.ndarray:
        """Where the condition holds at ``values`` (``rest``: the relative velocity is
        zero there); True where it does not apply."""
        expr, scale, divisor, where = self._evaluated(values)
        v, tie = np.sign(divisor) * expr, nx.TOL * scale
        with np.errstate(invalid="ignore"):
            ok = {"!= 0": np.abs(v) > tie, ">= 0": v >= -tie, "> 0": v > tie}[self.sense]
            if where is not None:
                ok = ok | ~(where > 0)
        if self.rest_only:
            ok = ok | ~np.asarray(rest, bool)
        return ok

    def _evaluated(self, values):
        f = _numpy_function(self)
        with np.errstate(all="ignore"):
            out = f(*(np.asarray(values[n], float) for n in self.symbols))
        return out[0], out[1], out[2], (out[3] if self.where is not None else None)


@functools.lru_cache(maxsize=None)
def _numpy_function(c: Condition):
    import sympy as sp

    args = [sp.Symbol(n, real=True) for n in c.symbols]
    parts = [c.expr, c.scale, c.divisor, c.where if c.where is not None else 0]
    return sp.lambdify(args, [sp.sympify(p) for p in parts], "numpy")


# -- building them ------------------------------------------------------------------

_CACHE = Memo("admissibility.conditions")


def conditions(system_or_model) -> tuple[Condition, ...]:
    """Every condition that decides a branch's status, per branch in row order, then the
    domain's; for a :class:`phasemap.declare.System`, a declared :class:`phasemap.Model`,
    or a hand-written model with a declared twin (:attr:`phasemap.Model.twin`,
    whose branches carry the hand model's names: the twin's conditions of those
    branches, in the hand model's row order).  Derived with sympy once per declaration.

    Parameters
    ----------
    system_or_model : System or Model
        a declaration, a declared model, or a hand-written model with a twin
        (``phasemap.get_model("ladder")``; a name alone is refused).

    Returns
    -------
    tuple of Condition

    Raises
    ------
    TypeError
        for a model with neither a declaration nor a twin.

    Examples
    --------
    >>> from phasemap.declare import conditions
    >>> from phasemap.systems.painleve_rod import SYSTEM
    >>> sorted({c.branch for c in conditions(SYSTEM)})
    ['A_separated', 'A_separated_moving_neg', 'A_slip_neg', 'A_slip_pos', 'stick']
    """
    S, hand = _declaration(system_or_model)
    built = _CACHE.get((S,), (), lambda: _build(S))
    if hand is None:
        return built
    by_branch = {}
    for c in built:
        by_branch.setdefault(c.branch, []).append(c)
    return tuple(c for b in [*hand.branches, None] for c in by_branch.get(b, []))


def presence(system_or_model) -> dict[str, Presence]:
    """Per branch (the model's names), where it applies: moving in its direction and
    from rest, only at rest, or only while moving."""
    S, hand = _declaration(system_or_model)
    out = {S.names.get(r.name, r.name): r.presence for r in derive(S).candidates}
    return out if hand is None else {b: out[b] for b in hand.branches}


def _declaration(x):
    """The declaration behind ``x``, and the hand model it stands in for (or None)."""
    if isinstance(x, System):
        return x, None
    S = getattr(x, "declaration", None)
    if S is not None:  # a model loaded from the kernel cache holds a lazy Declaration
        return getattr(S, "system", S), None
    S = twin(x) if hasattr(x, "branches") else None
    if S is None:
        raise TypeError(f"conditions: {getattr(x, 'name', x)!r} is not a declared system or "
                        "model, and has no declared twin (phasemap.Model.twin)")
    return S, x


def _build(S) -> tuple[Condition, ...]:
    validate(S)
    d = derive(S)
    out = []
    for row in d.candidates:
        if row.edge is None:
            out += _Branch(d, row).conditions()
    out += [_without_poles(Condition(label, None, "domain", e, scale_of(e), ">= 0"))
            for (e, _), label in zip(d.eqs.domain, d.eqs.domain_labels)]
    names = [c.name for c in out]
    clash = sorted({n for n in names if names.count(n) > 1})
    if clash:
        raise AssertionError(f"{S.name}: two conditions named {clash[0]!r}")
    return tuple(out)


class _Branch:
    """The conditions of one candidate branch, from its solved row."""

    def __init__(self, d, row):
        import sympy as sp

        self.d, self.row = d, row
        self.sol = d.solutions[row.key]
        self.p = self.sol.problem
        self.names = d.S.names
        self.branch = str(self.names.get(row.name, row.name))
        self.constants = {}
        for c, m in zip(d.S.contacts, row.modes):
            for kind, x in (("sig", m.slip), ("rho", m.normal), ("root", m.root)):
                if x and m.moves:
                    self.constants[sp.Symbol(f"_k_{kind}_{c.name}", real=True)] = sp.Integer(x)
        self.L = [u[2] for u in self.p.unknowns]
        self._numerators()

    def conditions(self) -> list[Condition]:
        conds = self._coefficients() + self._joint()
        conds += self._family() if self.sol.family is not None else self._forms()
        conds += self._accelerations()
        return [c for c in map(self._fixed, conds) if not _always(c)]

    def _name(self, label: str) -> str:
        return f"{self.names.get(label, label)}_{self.branch}"

    def _fixed(self, c: Condition) -> Condition:
        """The row's constants (slip sign, N sign, root) in place; rest: velocity 0."""
        import sympy as sp

        sub = dict(self.constants)
        if c.rest_only:
            sub[self.d.velocity] = sp.Integer(0)

        def fix(e):
            return None if e is None else sp.sympify(e).xreplace(sub)

        c = _without_poles(Condition(c.name, c.branch, c.kind, fix(c.expr), fix(c.scale),
                                     c.sense, c.rest_only, fix(c.divisor), fix(c.where)))
        if c.kind != "coefficient":
            return c
        # reduced by sin^2 + cos^2 = 1, without a constant factor: the same quantity, and
        # the kernel's tie
        content, expr = pythagorean(c.expr, self.d.eqs.q).as_content_primitive()
        return dataclasses.replace(c, expr=expr, scale=c.scale / abs(content))

    # -- the row's quantities as numerators over common denominators ----------------

    def _numerators(self):
        """The unknowns ``L = nL / dL`` and accelerations ``Q = nQ / dQ``, with the
        scales of the numerators (the kernel's scales times ``|dL|``, ``|dQ|``)."""
        import sympy as sp

        sol = self.sol
        if sol.family is not None:
            D, P = sol.family[0].D, sol.family[0].P
            R = sum((scale_of(e) for e in P), sp.Integer(0))
            self.nL, self.sL, self.dL = list(P), [R] * len(P), D
        elif self.p.squared is not None:
            a, b, _, _ = joint_parts(sol)
            mu = self.p.squared.moment
            self.nL = [x + y * mu for x, y in zip(a, b)]
            self.sL = [scale_of(x) + scale_of(y) * sp.Abs(mu) for x, y in zip(a, b)]
            self.dL = sol.D
        else:
            self.nL, self.sL, self.dL = list(sol.nums), [scale_of(e) for e in sol.nums], sol.D
        self.nQ, self.sQ = accelerations(sol, self.nL, self.sL, over=False)
        self.dQ = sol.D if sol.qnums is not None else sol.dM * sol.D
        if self.p.squared is not None:
            self._without_moment()

    def _without_moment(self):
        """Substitute the kept root ``M = m / (2 A)`` of the squared law and clear ``2 A``."""
        import sympy as sp

        root = self.constants[self.p.squared.root]
        self.roots = solve_joint(self.sol, root)
        A, m, mu = self.roots.A, self.roots.moment, self.p.squared.moment
        t = sp.Dummy("abs_mu")

        def clear(e):
            return 2 * A * e.subs(mu, 0) + m * sp.diff(e, mu)

        def clear_scale(s):
            s = sp.sympify(s).xreplace({sp.Abs(mu): t})
            return 2 * sp.Abs(A) * s.subs(t, 0) + sp.Abs(m) * sp.diff(s, t)

        self.nL, self.sL = [clear(e) for e in self.nL], [clear_scale(s) for s in self.sL]
        self.nQ, self.sQ = [clear(e) for e in self.nQ], [clear_scale(s) for s in self.sQ]
        self.dL, self.dQ = 2 * A * self.dL, 2 * A * self.dQ

    # -- the conditions by kind -----------------------------------------------------

    def _coefficients(self) -> list[Condition]:
        sol, b = self.sol, self.branch
        if sol.family is not None and len(sol.family) > 1:
            return []  # singular only where both parametrisations' minors vanish: points
        D = sol.family[0].D if sol.family is not None else sol.D
        if self.p.squared is None:
            return [Condition(f"coef_{b}", b, "coefficient", D, scale_of(D), "!= 0")]
        A = self.roots.A
        return [Condition(f"det_{b}", b, "coefficient", D, scale_of(D), "!= 0"),
                Condition(f"coef_{b}", b, "coefficient", A, self.roots.scales["A"], "!= 0")]

    def _joint(self) -> list[Condition]:
        import sympy as sp

        sq = self.p.squared
        if sq is None:
            return []
        r, b = self.roots, self.branch
        first = self.constants[sq.root] < 0
        # the kernel: sigma M <= TOL (delta |a| / |D| + |M|), M = m / (2 A), times 2 |A|
        keep_scale = (2 * sp.Abs(r.A) * r.scales["moment_terms"] / sp.Abs(self.sol.D)
                      + sp.Abs(r.moment))
        return [Condition(f"disc_{sq.contact}_{b}", b, "discriminant", r.disc,
                          r.scales["disc"], ">= 0" if first else "> 0"),
                Condition(f"root_{sq.contact}_{b}", b, "root", -sq.sign * r.moment, keep_scale,
                          ">= 0", divisor=r.A)]

    def _sense(self, strict) -> str:
        strict = strict if isinstance(strict, bool) else bool(self.constants[strict] < 0)
        return "> 0" if strict else ">= 0"

    def _forms(self) -> list[Condition]:
        import sympy as sp

        sub = dict(zip(self.L, self.nL))
        out = []
        for form in self.p.forms:
            e = form.smooth_expr
            poly = sp.Poly(e, *self.L)
            if not poly.is_homogeneous:
                raise AssertionError(f"{form.label}: a form must be homogeneous in the reactions")
            degree = poly.total_degree()
            scale = scale_in(form.expr, self.L, self.sL) * sp.sympify(form.factor).xreplace(sub)
            out.append(Condition(self._name(form.label), self.branch, form.kind,
                                 e.xreplace(sub), scale, self._sense(form.strict),
                                 divisor=self.dL ** (degree % 2)))
        return out

    def _family(self) -> list[Condition]:
        import sympy as sp

        D, P, Dd = self.sol.family[0].D, self.sol.family[0].P, self.sol.family[0].Dd
        R = self.sL[0]
        lines, out = [], []
        for form in self.p.forms:
            c = family_coefficients(form, self.L, self.d.S, self.p.fname)
            g0 = sum((ci * x for ci, x in zip(c, P)), sp.Integer(0))
            g1 = sp.expand(sum((ci * x for ci, x in zip(c, Dd)), sp.Integer(0)))
            if g1 != 0:
                lines.append((form, g0, g1))
                # where the slope changes sign the form turns from a lower bound of t into
                # an upper one: the pairs below start or stop applying there, and a bound
                # that runs off to infinity can empty (or fill) the family (the drawer's
                # self-locking wedge).  It decides nothing itself: where = 0.
                out.append(Condition(f"slope_{self._name(form.label)}", self.branch,
                                     "family", g1, scale_of(g1), ">= 0", where=sp.Integer(0)))
            else:
                # a ray: the form has the same value on every member
                out.append(Condition(self._name(form.label), self.branch, form.kind, g0, R,
                                     self._sense(form.strict), divisor=D))
        for (fi, g0i, g1i), (fj, g0j, g1j) in ((a, b) for k, a in enumerate(lines)
                                               for b in lines[k + 1:]):
            det = sp.expand(g0j * g1i - g0i * g1j)
            if det == 0:
                continue
            strict = self._sense(fi.strict) == "> 0" or self._sense(fj.strict) == "> 0"
            out.append(Condition(f"family_{self.names.get(fi.label, fi.label)}_"
                                 f"{self._name(fj.label)}", self.branch, "family", det,
                                 R * (sp.Abs(g1i) + sp.Abs(g1j)), "> 0" if strict else ">= 0",
                                 divisor=D * g1i, where=-g1i * g1j))
        return out

    def _accelerations(self) -> list[Condition]:
        out = []
        for req in self.p.requirements:
            if not isinstance(req, Accelerates):
                continue
            a, s = channel_acceleration(self.d.eqs, self.sol, req.contact, req.channel,
                                        self.nQ, self.sQ, unit=self.dQ)
            sign = 1 if req.sign is None else req.sign
            out.append(Condition(self._name(req.label), self.branch,
                                 "start" if req.rest_only else "gap", sign * a, s, "> 0",
                                 rest_only=req.rest_only, divisor=self.dQ))
        return out


def _without_poles(c: Condition) -> Condition:
    """``c`` with the denominators that closing the contacts leaves (the rod on a step's
    ``cot theta``) cleared: ``n / d`` becomes ``n`` and ``d`` joins the divisor (the sign)
    and the scale (the tie), so that the tested side and the tie are unchanged."""
    import sympy as sp

    def split(e):
        e = sp.sympify(e)
        if any(p.exp.is_negative and p.base.free_symbols for p in e.atoms(sp.Pow)):
            return sp.fraction(sp.together(e))
        return e, sp.Integer(1)

    num, den = split(c.expr)
    div_n, div_d = split(c.divisor)
    if den == 1 and div_d == 1:
        return c
    return dataclasses.replace(c, expr=num, scale=c.scale * sp.Abs(den),
                               divisor=div_n * div_d * den)


def _always(c: Condition) -> bool:
    """A condition that holds everywhere (a constant on its admissible side)."""
    import sympy as sp

    if c.where is not None or not all(sp.sympify(e).is_Number
                                      for e in (c.expr, c.divisor, c.scale)):
        return False
    return bool(c.holds({}))
