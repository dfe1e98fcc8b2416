"""The code emitter: each solved mode combination as a numba branch function, and the
generated module of a declared system (see GUIDE section 6 for why a real file)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from phasemap.core import numerics as nx
from phasemap.declare.algebra import scale_in, scale_of
from phasemap.declare.api import sym
from phasemap.declare.derivation import derive
from phasemap.declare.law import Accelerates
from phasemap.declare.solvers import joint_parts, quotients, short_determinant
from phasemap.declare.validation import fail

TOL = f"{nx.TOL!r}"

#: The generation of the printed code, part of every generated module's cache key
#: (:func:`phasemap.declare.build.cache_stem`): raised whenever the printer's output changes
#: meaning, so that no kernel printed before survives an upgrade.  2: a negative integer power
#: of a sum, 1/(A + B), had been printed without its parentheses (issue 37).
GENERATION = 2

#: Statuses of a generated row, as the module prints them.
_STATUS = {"ADMISSIBLE": nx.ADMISSIBLE, "SEPARATION": nx.SEPARATION}


def printer():
    """A sympy printer for numba: float literals everywhere (no mixed int/float tuples, a
    rational as the double its division gives), integer powers as products."""
    import sympy as sp
    from sympy.printing.precedence import PRECEDENCE
    from sympy.printing.pycode import PythonCodePrinter

    class Printer(PythonCodePrinter):
        def _print_Integer(self, e):
            return f"{int(e)}.0"

        def _print_Rational(self, e):
            # the double that p.0/q.0 evaluates to, written out: numba types and lowers
            # each division of two constants it is given (no folding before LLVM's)
            try:
                value = float(int(e.p)) / float(int(e.q))
            except OverflowError:
                return f"({int(e.p)}.0/{int(e.q)}.0)"
            return f"({value!r})"

        def _print_Half(self, e):
            return "0.5"

        def _print_Pow(self, e, rational=False):
            b, x = e.args
            pb = self._print(b)
            if x.is_Integer:
                k = int(x)
                if k < 0:  # numba raises ZeroDivisionError for 0.0 ** -k, whatever its error model
                    # a divisor that binds no tighter than a product gets its parentheses:
                    # 1/(A + B) was once printed as 1.0/A + B (issue 37)
                    div = self.parenthesize(b ** -k, PRECEDENCE["Mul"], strict=True)
                    return f"(1.0/{div})"
                if k == 2:
                    return f"(({pb})*({pb}))"
                return f"(({pb})**{k})"
            if x == sp.Rational(1, 2):
                return f"math.sqrt({pb})"
            if x == -sp.Rational(1, 2):
                return f"(1.0/math.sqrt({pb}))"
            return f"(({pb})**({self._print(x)}))"

        def _print_Abs(self, e):
            return f"abs({self._print(e.args[0])})"

    return Printer({"fully_qualified_modules": True})


class _Writer:
    """The body lines of one branch function, and the input names they read."""

    def __init__(self, inputs_of):
        import sympy as sp

        self.inputs_of = inputs_of
        self.printer = printer()
        self.lines: list[str] = []
        self.used: set = set()
        self.fresh = sp.numbered_symbols("_k_x")

    def emit(self, pairs):
        """Assign ``name = expr`` for (name, sympy expr) pairs, with common subexpressions."""
        import sympy as sp

        exprs = [self.inputs_of(e) for _, e in pairs]
        for e in exprs:
            self.used.update(s.name for s in e.free_symbols)
        reps, red = sp.cse(exprs, symbols=self.fresh, order="none")
        self.lines += [f"{s} = {self.printer.doprint(e)}" for s, e in reps]
        self.lines += [f"{a} = {self.printer.doprint(e)}" for (a, _), e in zip(pairs, red)]


def _symbols(prefix, k):
    import sympy as sp

    return [sp.Symbol(f"{prefix}{i}", real=True) for i in range(k)]


@dataclass(frozen=True)
class RowContext:
    """Where a row applies and when its contacts are at rest.

    ``edge``: the :class:`phasemap.declare.edges.Edge` a row exists on (None:
    everywhere); ``still``: per contact that is at rest on some edge, its slip
    factor ``k_c`` (an ordinary row tests a start of its slip wherever ``k_c``
    vanishes, not only at rest).
    """

    edge: object = None
    still: dict = field(default_factory=dict)
    #: ``(name, arguments)`` of the generated function that decides ``edge``
    #: (:func:`edge_code`), which the row calls: the grid kernels call it too, once per
    #: outer state where the inner axis does not enter it.
    edge_call: tuple | None = None

    def rest_of(self, contact: str) -> str:
        """The code of "contact is at rest" in the row."""
        if self.edge is not None and contact in self.edge.contacts:
            return "True"
        return f"_k_rest_{contact}" if contact in self.still else "rest"


def row_code(sol, eqs, inputs_of, ctx: RowContext = RowContext()) -> tuple[list[str], set]:
    """The branch function's body lines for the solution ``sol``, and the inputs it reads."""
    w = _Writer(inputs_of)
    p = sol.problem
    L = [u[2] for u in p.unknowns]
    Ls = _symbols("_k_Ls", len(L))
    _where(w, sol, ctx)
    if sol.family is not None:
        _family(w, sol, eqs, L, Ls, ctx)
    elif p.squared is not None:
        _joint(w, sol, eqs, L, Ls)
    else:
        _regular(w, sol, eqs, L, Ls)
    Q = _accelerations(w, sol, eqs, L, Ls)
    _admissible(w, sol, eqs, Q, L, Ls, ctx)
    w.emit([(f"_k_r{i}", e) for i, e in enumerate(p.reactions)])
    return w.lines, w.used


def edge_code(edge, inputs_of) -> tuple[list[str], list[str]]:
    """The body lines of the function that decides ``edge`` at a state (its contacts'
    slip factors vanish to the tie tolerance, and the state is near it:
    :func:`phasemap.declare.edges.edge_flag`), and the inputs it reads, sorted: its
    parameters."""
    from phasemap.declare.edges import NEAR, edge_flag

    w = _Writer(inputs_of)
    factors, scales, near = edge_flag(edge)
    w.emit([(f"_k_ef{i}", k) for i, k in enumerate(factors)]
           + [(f"_k_efs{i}", s) for i, s in enumerate(scales)] + [("_k_near", near)])
    w.lines.append("return " + " & ".join(
        [f"(abs(_k_ef{i}) <= {TOL} * _k_efs{i})" for i in range(len(factors))]
        + [f"(_k_near <= {NEAR!r})"]))
    return w.lines, sorted(w.used)


def edge_name(i: int) -> str:
    """The name of the generated function that decides edge ``i`` (:func:`edge_code`)."""
    return f"edge_{i}"


def _edge_function(i: int, edge, body: list[str], args: list[str]) -> list[str]:
    return ['@njit(cache=True, error_model="numpy", forceinline=True)',
            f"def {edge_name(i)}({', '.join(args)}):",
            f'    """Whether the state is on the edge {edge.label}."""',
            *("    " + ln for ln in body), ""]


def _where(w, sol, ctx: RowContext):
    """``_k_edge`` (the row's edge holds: a call of its :func:`edge_code` function) and
    ``_k_rest_<c>`` (contact c is at rest: at rest, or where its factor vanishes), for the
    contacts the row's requirements start."""
    if ctx.edge is None:
        w.lines.append("_k_edge = True")
    else:
        name, args = ctx.edge_call
        w.used.update(args)
        w.lines.append(f"_k_edge = {name}({', '.join(args)})")
    started = {r.contact for r in sol.problem.requirements
               if isinstance(r, Accelerates) and r.rest_only}
    for c in sorted(started & set(ctx.still)):
        if ctx.rest_of(c) == "True":
            continue
        k = ctx.still[c]
        w.emit([(f"_k_kf_{c}", k), (f"_k_kfs_{c}", scale_of(k))])
        w.lines.append(f"_k_rest_{c} = rest | (abs(_k_kf_{c}) <= {TOL} * _k_kfs_{c})")


def _regular(w, sol, eqs, L, Ls):
    """The unknowns by Cramer's rule: ``L_i = n_i / D``."""
    k = len(L)
    w.emit([("_k_D", short_determinant(sol, eqs.q)), ("_k_Ds", scale_of(sol.D))]
           + [(f"_k_n{i}", e) for i, e in enumerate(sol.nums)]
           + [(f"_k_ns{i}", scale_of(e)) for i, e in enumerate(sol.nums)])
    w.lines.append(f"_k_sing = abs(_k_D) <= {TOL} * _k_Ds")
    w.lines.append("_k_cont = " + " & ".join(
        [f"(abs(_k_n{i}) <= {TOL} * _k_ns{i})" for i in range(k)] or ["False"]))
    for i in range(k):
        w.lines.append(f"{L[i]} = _k_n{i} / _k_D")
        w.lines.append(f"{Ls[i]} = _k_ns{i} / abs(_k_D)")
    w.lines.append("_k_real = True")
    w.lines.append("_k_coef = _k_D / _k_Ds")


def _joint(w, sol, eqs, L, Ls):
    """The unknowns affine in the friction moment, and the moment from the squared law
    (:class:`phasemap.declare.solvers.JointRoots` states the same quantities over D)."""
    n0, n1, X, Y = joint_parts(sol)
    sq = sol.problem.squared
    w.emit([("_k_D", short_determinant(sol, eqs.q)), ("_k_Ds", scale_of(sol.D))]
           + [(f"_k_a{i}", e) for i, e in enumerate(n0)]
           + [(f"_k_as{i}", scale_of(e)) for i, e in enumerate(n0)]
           + [(f"_k_b{i}", e) for i, e in enumerate(n1)]
           + [(f"_k_bs{i}", scale_of(e)) for i, e in enumerate(n1)])
    w.emit([("_k_dl", sq.coefficient)])
    sig, root = sq.sign, sq.root
    w.lines += [
        "_k_sing0 = abs(_k_D) <= " + TOL + " * _k_Ds",
        f"_k_ax, _k_ay = _k_a{X} / _k_D, _k_a{Y} / _k_D",
        f"_k_bx, _k_by = _k_b{X} / _k_D, _k_b{Y} / _k_D",
        f"_k_sx, _k_sy = _k_as{X} / abs(_k_D), _k_as{Y} / abs(_k_D)",
        "_k_d2 = _k_dl * _k_dl",
        "_k_A = 1.0 - _k_d2 * (_k_bx * _k_bx + _k_by * _k_by)",
        "_k_As = 1.0 + _k_d2 * (_k_bx * _k_bx + _k_by * _k_by)",
        "_k_B = -2.0 * _k_d2 * (_k_ax * _k_bx + _k_ay * _k_by)",
        "_k_Bs = 2.0 * _k_d2 * (_k_sx * abs(_k_bx) + _k_sy * abs(_k_by))",
        "_k_C = -_k_d2 * (_k_ax * _k_ax + _k_ay * _k_ay)",
        "_k_Cs = _k_d2 * (_k_sx * _k_sx + _k_sy * _k_sy)",
        "_k_disc = _k_B * _k_B - 4.0 * _k_A * _k_C",
        "_k_discs = _k_Bs * _k_Bs + 4.0 * _k_As * _k_Cs",
        f"_k_sing = _k_sing0 | (abs(_k_A) <= {TOL} * _k_As)",
        f"_k_cont = (abs(_k_B) <= {TOL} * _k_Bs) & (abs(_k_C) <= {TOL} * _k_Cs)",
        f"_k_real = _k_disc >= -{TOL} * _k_discs",
        f"_k_mu = (-_k_B + {root} * math.sqrt(max(_k_disc, 0.0))) / (2.0 * _k_A)",
        "_k_mus = _k_dl * math.sqrt(_k_sx * _k_sx + _k_sy * _k_sy) + abs(_k_mu)",
        f"_k_keep = ({sig} * _k_mu <= {TOL} * _k_mus) & (({root} < 0.0) | "
        f"(_k_disc > {TOL} * _k_discs))",
        "_k_coef = _k_A",
    ]
    for i in range(len(L)):
        w.lines.append(f"{L[i]} = (_k_a{i} + _k_b{i} * _k_mu) / _k_D")
        w.lines.append(f"{Ls[i]} = (_k_as{i} + _k_bs{i} * abs(_k_mu)) / abs(_k_D)")


def _family(w, sol, eqs, L, Ls, ctx: RowContext):
    """The statically indeterminate family ``L_j = (P_j + Dd_j t) / D`` (P = 0, Dd = D
    for the parameter), on the best conditioned of its parametrisations, the interval
    of ``t`` where every form holds (and, as they are affine in ``t`` too, every
    acceleration's sign), and its middle.  ``_k_real``: the family exists (its dropped
    equation holds); ``_k_moves``: its admissible members differ in their
    accelerations (a continuum)."""
    k = len(L)
    fields = ["_k_D", "_k_Ds"] + [f"_k_{x}{j}" for x in ("P", "PS", "Dd") for j in range(k)]
    for r, fam in enumerate(sol.family):
        w.emit([(f"_k_D_{r}", fam.D), (f"_k_Ds_{r}", scale_of(fam.D))]
               + [(f"_k_P{j}_{r}", e) for j, e in enumerate(fam.P)]
               + [(f"_k_PS{j}_{r}", scale_of(e)) for j, e in enumerate(fam.P)]
               + [(f"_k_Dd{j}_{r}", e) for j, e in enumerate(fam.Dd)])
    w.lines += [f"{x} = {x}_0" for x in fields]
    for r in range(1, len(sol.family)):
        # the larger minor, relative to the magnitude of its terms
        w.lines.append(f"_k_use = abs(_k_D_{r}) * _k_Ds > abs(_k_D) * _k_Ds_{r}")
        w.lines += [f"{x} = {x}_{r} if _k_use else {x}" for x in fields]
    w.lines += [f"_k_sing = abs(_k_D) <= {TOL} * _k_Ds", "_k_cont = False", "_k_real = True",
                "_k_coef = _k_D / _k_Ds",
                "_k_R = " + " + ".join(f"_k_PS{j}" for j in range(k)) + " + 0.0"]
    if sol.consistency is not None:
        # the family exists where adj(K) rhs vanishes
        c = sol.consistency
        w.emit([(f"_k_C{j}", e) for j, e in enumerate(c)]
               + [(f"_k_Cs{j}", scale_of(e)) for j, e in enumerate(c)])
        w.lines.append("_k_real = " + " & ".join(
            f"(abs(_k_C{j}) <= {TOL} * _k_Cs{j})" for j in range(len(c))))
    fam = {j: (f"_k_P{j} / _k_D", f"_k_Dd{j} / _k_D") for j in range(k)}
    w.lines.append("_k_lo, _k_hi = -np.inf, np.inf")
    for form in sol.problem.forms:
        _restrict(w, form, fam, family_coefficients(form, L, eqs.S, sol.problem.fname))
    Q0, Q1, Qs = _family_accelerations(w, sol, L, Ls)
    for ci, req in enumerate(sol.problem.requirements):
        if isinstance(req, Accelerates):
            _restrict_acceleration(w, eqs, sol, ci, req, Q0, Q1, Qs, ctx)
    # a single member is admissible where every condition it meets is inclusive (the
    # tolerances are zero where every term is: no load at all)
    strict = any(f.strict is not False for f in sol.problem.forms) or any(
        isinstance(r, Accelerates) for r in sol.problem.requirements)
    w.lines.append(f"_k_fam = _k_lo {'<' if strict else '<='} _k_hi")
    w.lines.append("_k_t = 0.5 * (_k_lo + _k_hi) if (_k_lo > -np.inf) & (_k_hi < np.inf) "
                   "else (_k_lo if _k_lo > -np.inf else (_k_hi if _k_hi < np.inf else 0.0))")
    if sol.moves:
        w.lines.append("_k_moves = " + " | ".join(
            f"(abs({q1}) * (_k_hi - _k_lo) > {TOL} * {qs})" for q1, qs in zip(Q1, Qs)))
    for i in range(k):
        a, b = fam[i]
        w.lines.append(f"{L[i]} = {a} + ({b}) * _k_t")
        w.lines.append(f"{Ls[i]} = _k_R / abs(_k_D)")


def _family_accelerations(w, sol, L, Ls):
    """The accelerations of the family's member ``t``, ``Q0 + Q1 t``, and their scales:
    the names of the emitted locals."""
    import sympy as sp

    k, n = len(L), sol.problem.n
    t = sp.Symbol("_k_tfam", real=True)
    D = sp.Symbol("_k_D", real=True)
    member = {L[j]: (sp.Symbol(f"_k_P{j}", real=True) + sp.Symbol(f"_k_Dd{j}", real=True) * t)
              / D for j in range(k)}
    acc, accs = accelerations(sol, L, Ls)
    moving = [a.xreplace(member) for a in acc]
    ls = {Ls[j]: sp.Symbol("_k_R", real=True) / sp.Abs(D) for j in range(k)}
    w.emit([(f"_k_Qa{j}", moving[j].subs(t, 0)) for j in range(n)]
           + [(f"_k_Qb{j}", sp.diff(moving[j], t)) for j in range(n)]
           + [(f"_k_Qc{j}", accs[j].xreplace(ls)) for j in range(n)])
    return ([f"_k_Qa{j}" for j in range(n)], [f"_k_Qb{j}" for j in range(n)],
            [f"_k_Qc{j}" for j in range(n)])


def _restrict_acceleration(w, eqs, sol, ci, req, Q0, Q1, Qs, ctx):
    """Intersect the family's interval with a channel's acceleration of the required sign
    (strictly; a start only where its contact is at rest)."""
    import sympy as sp

    q0, q1, qs = ([sp.Symbol(x, real=True) for x in names] for names in (Q0, Q1, Qs))
    a0, s = channel_acceleration(eqs, sol, req.contact, req.channel, q0, qs)
    a1, _ = channel_acceleration(eqs, sol, req.contact, req.channel, q1, qs, unit=0)
    sign = 1 if req.sign is None else req.sign
    w.emit([(f"_k_ca{ci}", sign * a0), (f"_k_cb{ci}", sign * a1), (f"_k_cs{ci}", s)])
    applies = ctx.rest_of(req.contact) if req.rest_only else "True"
    w.lines.append(f"_k_lo, _k_hi = restrict_affine(_k_ca{ci} - {TOL} * _k_cs{ci} if {applies} "
                   f"else 1.0, _k_cb{ci} if {applies} else 0.0, _k_lo, _k_hi)")


def family_coefficients(form, L, S, fname):
    """The coefficients of a form linear in the unknowns ``L`` (a ValueError otherwise)."""
    import sympy as sp

    coeffs = [sp.diff(form.expr, L[i]) for i in range(len(L))]
    if any(cf.free_symbols & set(L) for cf in coeffs):
        fail(S, f"mode {fname}", "a nonlinear friction limit on indeterminate reactions is "
             "not supported")
    return coeffs


def _restrict(w, form, fam, coeffs):
    """Intersect the interval of the family's parameter with ``form >= 0`` (or > 0)."""
    c_names = []
    for i, cf in enumerate(coeffs):
        if cf != 0:
            nmc = f"_k_c{len(w.lines)}_{i}"
            w.emit([(nmc, cf)])
            c_names.append((i, nmc))
    g0 = " + ".join(f"{cn} * ({fam[i][0]})" for i, cn in c_names) or "0.0"
    g1 = " + ".join(f"{cn} * ({fam[i][1]})" for i, cn in c_names) or "0.0"
    g1s = " + ".join(f"abs({cn} * ({fam[i][1]}))" for i, cn in c_names) or "0.0"
    strict = form.strict
    shift = (f"{'-' if strict is True else ''}{TOL} * _k_R / abs(_k_D)"
             if isinstance(strict, bool) else
             f"({TOL} if {strict} > 0.0 else -{TOL}) * _k_R / abs(_k_D)")
    # a slope that cancels to rounding is zero (a ray, not a far endpoint)
    w.lines.append(f"_k_sl = {g1}")
    w.lines.append(f"_k_sl = _k_sl if abs(_k_sl) > {TOL} * ({g1s}) else 0.0")
    w.lines.append(f"_k_lo, _k_hi = restrict_affine({g0} + {shift}, _k_sl, _k_lo, _k_hi)")


def accelerations(sol, L, Ls, over=True):
    """The accelerations and their scales, in the unknowns ``L`` and their scales ``Ls``
    (solved together with the reactions: in ``_k_D`` and the moment ``_k_mu``).

    ``over=False``: the numerators over the common denominator instead, ``dM D``
    (``D`` the row's determinant) or, solved together, ``D``; ``L`` and ``Ls`` are
    then the numerators over ``D``, and the scales are multiplied by ``|dM D|``.
    """
    import sympy as sp

    n, k = sol.problem.n, len(L)
    one = sp.Integer(1)
    if sol.qnums is None:
        unit, unit_s, den = (one, one, sol.dM) if over else (sol.D, sp.Abs(sol.D), one)
        gen = [unit * sol.hx[a] + sum((sol.W[a, i] * L[i] for i in range(k)), sp.Integer(0))
               for a in range(n)]
        gens = [scale_of(sol.hx[a]) * unit_s + sum(
            (scale_of(sol.W[a, i]) * Ls[i] for i in range(k)), sp.Integer(0)) for a in range(n)]
        acc = [sum((sol.aM[j, a] * gen[a] for a in range(n)), sp.Integer(0)) / den
               for j in range(n)]
        accs = [sum((scale_of(sol.aM[j, a]) * gens[a] for a in range(n)), sp.Integer(0))
                / sp.Abs(den) for j in range(n)]
        return acc, accs
    D = sp.Symbol("_k_D", real=True) if over else one
    mu = sol.problem.squared.moment if sol.problem.squared is not None else None
    if mu is None:
        return [e / D for e in sol.qnums], [scale_of(e) / sp.Abs(D) for e in sol.qnums]
    q0 = [e.subs(mu, 0) for e in sol.qnums]
    q1 = [sp.diff(e, mu) for e in sol.qnums]
    return ([(a + b * mu) / D for a, b in zip(q0, q1)],
            [(scale_of(a) + scale_of(b) * sp.Abs(mu)) / sp.Abs(D) for a, b in zip(q0, q1)])


def rated(eqs) -> list[int]:
    """The indices of the coordinates with a rate: the accelerations a row returns."""
    return [i for i, c in enumerate(eqs.S.coordinates) if c.rate]


def _accelerations(w, sol, eqs, L, Ls):
    """``_k_Q<j>`` and their scales ``_k_Qs<j>``.  The accelerations a row returns (all of
    them in a row without reactions) are one quotient each over the row's determinant
    where that is the shorter way
    (:func:`phasemap.declare.solvers.quotients`): they then read no reaction, and a
    caller that reads only them (the integrator's right-hand side) computes none.
    ``_k_dM`` is the part of the mass matrix's determinant left in their denominator
    (1.0: none), kept to refuse a degenerate mass as the path through the reactions
    does (a division by zero there)."""
    import sympy as sp

    n = sol.problem.n
    Q, Qs = _symbols("_k_Q", n), _symbols("_k_Qs", n)
    acc, accs = accelerations(sol, L, Ls)
    # without reactions (a free flight) every acceleration is a short quotient; with
    # them the others are formed from the reactions that classification needs anyway
    rows = rated(eqs) if sol.problem.unknowns else list(range(n))
    quot = quotients(sol, rows, eqs.q)
    if quot is None:
        w.lines.append("_k_dM = 1.0")
    else:
        nums, dM = quot
        w.emit([("_k_dM", sol.dM)])
        D = sol.D if sp.sympify(sol.D).is_Number else sp.Symbol("_k_D", real=True)
        for j, e in zip(rows, nums):
            acc[j] = e / (dM * D)
    w.emit([(str(Q[j]), acc[j]) for j in range(n)] + [(str(Qs[j]), accs[j]) for j in range(n)])
    return Q


def channel_acceleration(eqs, sol, contact, key, Q, Qs, unit=1):
    """A channel's acceleration ``w . Q + bias`` and its scale, in the accelerations ``Q``
    and their scales ``Qs`` (numerators over ``unit``: the bias times ``unit``)."""
    import sympy as sp

    w, b, _ = eqs.channels[contact][key]
    b = b.xreplace(sol.problem.zero)
    n = sol.problem.n
    a = sum((w[j] * Q[j] for j in range(n)), sp.Integer(0)) + b * unit
    s = sum((scale_of(w[j]) * Qs[j] for j in range(n)), sp.Integer(0)) + scale_of(b) * abs(unit)
    return a, s


def _admissible(w, sol, eqs, Q, L, Ls, ctx: RowContext):
    """``_k_ok``: every requirement of the mode combination holds (ties as documented in
    :mod:`phasemap.core.numerics`); a family's are in its interval already."""
    p = sol.problem
    Qs = _symbols("_k_Qs", p.n)
    conds = []
    if sol.family is not None:
        conds.append("_k_fam")
    for ci, req in enumerate(p.requirements):
        if not isinstance(req, Accelerates) or sol.family is not None:
            continue
        a, s = channel_acceleration(eqs, sol, req.contact, req.channel, Q, Qs)
        w.emit([(f"_k_ca{ci}", a), (f"_k_cs{ci}", s)])
        if req.rest_only:
            conds.append(f"((not {ctx.rest_of(req.contact)}) | "
                         f"({req.sign} * _k_ca{ci} > {TOL} * _k_cs{ci}))")
        else:
            conds.append(f"(_k_ca{ci} > {TOL} * _k_cs{ci})")
    if sol.family is None:
        for fi, form in enumerate(p.forms):
            w.emit([(f"_k_g{fi}", form.expr), (f"_k_gs{fi}", scale_in(form.expr, L, Ls))])
            gt, ge = f"(_k_g{fi} > {TOL} * _k_gs{fi})", f"(_k_g{fi} >= -{TOL} * _k_gs{fi})"
            strict = form.strict
            conds.append((gt if strict else ge) if isinstance(strict, bool)
                         else f"({ge} if {strict} > 0.0 else {gt})")
    if p.squared is not None:
        conds.append("_k_keep")
    w.lines.append("_k_ok = " + (" & ".join(conds) if conds else "True"))
    if not sol.moves:
        w.lines.append("_k_moves = False")


# -- the generated module ---------------------------------------------------------

def module_source(S) -> str:
    """The generated module's source text (from the derivation of ``S``)."""
    d = derive(S)
    still = {c: d.factors[c] for c in sorted(d.still)}
    edges = {i: edge_code(d.edges[i], d.inputs_of)
             for i in sorted({key[1] for key in d.solutions if key[1] is not None})}
    code = {key: row_code(sol, d.eqs, d.inputs_of, RowContext(
                None if key[1] is None else d.edges[key[1]], still,
                None if key[1] is None else (edge_name(key[1]), edges[key[1]][1])))
            for key, sol in d.solutions.items()}
    inputs, state_pos, derived = _inputs(S, d, set().union(*(u for _, u in code.values())))
    scale_expr = velocity_scale_expr(S, d.velocity)
    scale_args = sorted(s.name for s in scale_expr.free_symbols)
    out = [f'"""Generated by phasemap.declare from the declaration of {S.name}: do not edit."""',
           "import math", "import numpy as np", "from numba import njit",
           "from phasemap.core.numerics import restrict_affine", "", "NAN = np.nan", ""]
    out += _velocity_scale(scale_expr, scale_args) + _inside(d, inputs)
    for i, (body, args) in edges.items():
        out += _edge_function(i, d.edges[i], body, args)
    for key, sol in d.solutions.items():
        out += _branch_function(S, sol, *code[key], inputs)
    spec = {
        "velocity": str(d.velocity),
        "inputs": inputs,
        "state_positions": [c.name for c in state_pos],
        "derived": derived,
        "scale_args": scale_args,
        "rows": [(r.name, r.direction, int(r.presence), d.solutions[r.key].problem.fname,
                  _row_args(d.solutions[r.key].problem, r), _row_bound(d, r),
                  None if r.edge is None else edge_name(r.edge))
                 for r in d.candidates],
        "kappa": d.kappa,
        "domain": sorted({nm for _, nm in d.eqs.domain}),
        "n_acc": len(d.positions),
    }
    out += [f"SPEC = {json.dumps(spec)!r}", ""]
    return "\n".join(out)


def _row_bound(d, row):
    """``[coordinate, side]`` where ``row`` exists only on a closed bound of a coordinate
    (its edge is that bound), else None (:attr:`phasemap.core.model.Candidate.bound`)."""
    edge = None if row.edge is None else d.edges[row.edge]
    return None if edge is None or edge.bound is None else [edge.coordinate, edge.bound]


def _inputs(S, d, used):
    """The model's inputs (state positions the equations use, rates, parameters, then
    the sines and cosines they use), the state positions, and the derived inputs."""
    state_pos = [c for c in d.positions if c.name in used
                 or f"sin_{c.name}" in used or f"cos_{c.name}" in used]
    derived = [(f"{fn}_{c.name}", c.name, fn) for c in state_pos for fn in ("sin", "cos")
               if f"{fn}_{c.name}" in used]
    inputs = ([c.name for c in state_pos] + [c.rate.name for c in d.positions]
              + [p.name for p in S.parameters] + [x[0] for x in derived])
    return inputs, state_pos, derived


def _row_args(p, row) -> list[float]:
    """The constants a row passes first to its function."""
    vals = row.args()
    assert len(vals) == len(p.args), (vals, p.args)
    return vals


def _velocity_scale(scale_expr, scale_args) -> list[str]:
    import sympy as sp

    return ['@njit(cache=True, error_model="numpy", forceinline=True)',
            f"def velocity_scale({', '.join(scale_args)}):",
            f"    return {printer().doprint(sp.Float(1) * scale_expr)}", ""]


def _inside(d, inputs) -> list[str]:
    """``inside(...)``: every domain edge of the contacts holds (ties inside)."""
    import sympy as sp

    if not d.eqs.domain:
        return []
    P = printer()
    conds = [d.inputs_of(e) for e, _ in d.eqs.domain]
    scales = [d.inputs_of(scale_of(e)) for e, _ in d.eqs.domain]
    reps, red = sp.cse(conds + scales, symbols=sp.numbered_symbols("_k_x"), order="none")
    used = {x.name for e in conds + scales for x in e.free_symbols}
    args = [nm for nm in inputs if nm in used]
    k = len(conds)
    return (['@njit(cache=True, error_model="numpy", forceinline=True)',
             f"def inside({', '.join(args)}):"]
            + [f"    {a} = {P.doprint(b)}" for a, b in reps]
            + ["    return " + " & ".join(
                f"(({P.doprint(red[i])}) >= -{TOL} * ({P.doprint(red[k + i])}))"
                for i in range(k)), ""])


def _branch_function(S, sol, body, used, inputs) -> list[str]:
    p = sol.problem
    params = p.args + ["rest"] + [nm for nm in inputs if nm in used]
    ok_status = _STATUS["SEPARATION" if "sep" in p.kinds else "ADMISSIBLE"]
    acc_idx = [i for i, c in enumerate(S.coordinates) if c.rate]
    modes = ", ".join(f"{c.name}: {k}" for c, k in zip(S.contacts, p.kinds))
    return ['@njit(cache=True, error_model="numpy", forceinline=True)',
            f"def {p.fname}({', '.join(params)}):",
            f'    """Modes {modes}."""',
            *("    " + ln for ln in body),
            "    _k_absent = ((_k_presence == 1.0) & (not rest)) | ((_k_presence == 2.0) & rest)"
            " | (not _k_edge)",
            # a non-finite acceleration or reaction is never a solution, whatever the
            # declaration (a zero mass, an overflow)
            "    _k_finq = " + " & ".join(
                [f"np.isfinite(_k_Q{j})" for j in acc_idx] + ["(abs(_k_dM) > 0.0)"]),
            "    _k_fin = _k_finq & " + " & ".join(
                [f"np.isfinite(_k_r{i})" for i in range(len(p.reactions))] + ["True"]),
            # the accelerations' own test, so that reading them computes no reaction
            "    _k_badq = _k_sing | _k_absent | (not (_k_real & _k_finq))",
            "    _k_real = _k_real & _k_fin",
            "    _k_bad = _k_sing | _k_absent | (not _k_real)",
            f"    _k_st = {nx.ABSENT} if _k_absent else (({nx.CONTINUUM} if _k_cont else "
            f"{nx.NO_SOLUTION}) if _k_sing else ({nx.NO_SOLUTION} if not _k_real else "
            f"(({nx.CONTINUUM} if _k_moves else {ok_status}) if _k_ok else "
            f"{nx.INADMISSIBLE})))",
            "    return (_k_st, 1.0 if (_k_sing & (not _k_absent)) else 0.0,",
            "            NAN if _k_absent else _k_coef,",
            *[f"            NAN if _k_badq else _k_Q{j}," for j in acc_idx],
            *[f"            NAN if _k_bad else _k_r{i}," for i in range(len(p.reactions))],
            "            )", ""]


def velocity_scale_expr(S, velocity):
    """The declared scale of the slip velocity's rate."""
    for c in S.coordinates:
        if c.rate and c.rate.name == str(velocity):
            return sym(c.rate.scale)
    raise AssertionError(velocity)
