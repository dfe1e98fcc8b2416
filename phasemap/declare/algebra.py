"""Symbolic helpers of the derivation: magnitudes of terms, reductions, Cramer's rule."""

from __future__ import annotations


def scale_of(e):
    """The magnitude of the terms of ``e``: what its rounding error is relative to.

    Sums add the scales of their terms, products multiply them, sin and cos
    count as 1 (their rounding error is absolute), a denominator counts with
    its own magnitude, and the sign symbols (slip directions) as 1.
    """
    import sympy as sp

    if e.is_Number:
        return abs(e)
    if e.is_Symbol:
        return sp.Integer(1) if e.name.startswith(("_k_sig", "_k_rho", "_k_root")) else sp.Abs(e)
    if e.is_Add:
        return sp.Add(*(scale_of(a) for a in e.args))
    if e.is_Mul:
        return sp.Mul(*(scale_of(a) for a in e.args))
    if e.is_Pow:
        b, x = e.args
        if x.is_Integer and x > 0:
            return scale_of(b) ** x
        if x.is_Integer:
            return sp.Abs(b) ** x
        if x == sp.Rational(1, 2):
            return sp.sqrt(scale_of(b))
        return sp.Abs(e)
    if isinstance(e, (sp.sin, sp.cos)):
        return sp.Integer(1)
    if isinstance(e, sp.Abs):
        return scale_of(e.args[0])
    return sp.Abs(e)


def scale_in(form, L, Ls):
    """The scale of an expression of the unknowns ``L``: their scales ``Ls`` stand in for them."""
    import sympy as sp

    sub = {L[i]: Ls[i] for i in range(len(L))}
    return scale_of(form).xreplace({sp.Abs(L[i]): Ls[i] for i in range(len(L))}).xreplace(sub)


def count_ops(exprs) -> int:
    """The arithmetic operations of ``exprs`` as sympy counts them (a cost estimate)."""
    import sympy as sp

    return sum(int(sp.count_ops(e)) for e in exprs)


def cramer(K, rhs, i):
    """The numerator of unknown ``i`` of ``K x = rhs`` by Cramer's rule."""
    Ki = K.copy()
    Ki[:, i] = rhs
    return determinant(Ki)


def determinant(M):
    """``M.det(method="berkowitz")``, the same expression: for 2 x 2 and 3 x 3, where sympy's
    Berkowitz determinant of polynomial entries is their expanded determinant (checked
    against it, term for term, on every declaration the tests derive: 310 matrices), it is
    computed in a ring of polynomials (:func:`expanded`), four times faster; a 1 x 1 (its
    entry as it is), larger ones (whose Berkowitz form sympy leaves partly unexpanded) and
    entries that are not such polynomials, by sympy."""
    if 2 <= M.rows <= 3:
        got = _det_in_ring(M)
        if got is not None:
            return got
    return M.det(method="berkowitz")


def _det_in_ring(M):
    """The expanded determinant of ``M`` computed in the ring of its entries, or None."""
    from sympy.polys.matrices import DomainMatrix

    _, polys = _in_ring(list(M))
    if polys is None:
        return None
    n = M.rows
    rows = [polys[i * n:(i + 1) * n] for i in range(n)]
    return DomainMatrix(rows, (n, n), polys[0].ring.to_domain()).det().as_expr()


def pythagorean(e, angles):
    """``e`` reduced modulo sin(q)^2 + cos(q)^2 = 1 for every coordinate q, and factored
    (a constant times sin^2 + cos^2 becomes the constant).  Left as it is when it is
    not a polynomial in the sines and cosines."""
    import sympy as sp

    sub, back, ideal, gens = {}, {}, [], []
    for q in angles:
        if not e.has(sp.sin(q), sp.cos(q)):
            continue
        s, c = sp.Dummy(f"s_{q}"), sp.Dummy(f"c_{q}")
        sub.update({sp.sin(q): s, sp.cos(q): c})
        back.update({s: sp.sin(q), c: sp.cos(q)})
        ideal.append(s ** 2 + c ** 2 - 1)
        gens += [s, c]
    if not gens:
        return sp.factor(e)
    p = sp.expand(e.xreplace(sub))
    if p.has(*angles):  # sin(2 q), sin(q + a), ...: not a polynomial in s, c
        return e
    try:
        _, rem = sp.reduced(p, ideal, *gens)
    except sp.polys.polyerrors.PolynomialError:
        return e
    return sp.factor(rem).xreplace(back)


def _monomial(e):
    """The monomial factor common to the terms of the expanded ``e`` (such as m**4 l**4)."""
    import sympy as sp

    f = sp.factor_terms(e)
    if not f.is_Mul:
        return sp.Integer(1)
    return sp.Mul(*(a for a in f.args if a.is_Symbol or (a.is_Pow and a.args[0].is_Symbol
                                                         and a.args[1].is_Integer)))


def expanded(exprs):
    """``sympy.expand`` of each of ``exprs``, the same canonical sums, computed in a ring of
    polynomials where every one is a polynomial with rational coefficients in symbols and
    sines and cosines: sympy's expansion of a product of large sums (Cramer's numerators,
    the accelerations' numerators) builds and flattens every partial product as an
    expression, and took most of a wheelbarrow's derivation.  Any other atom (a division,
    a float, a square root, whose square sympy rewrites) leaves every expression to
    ``sympy.expand``."""
    return _in_ring(exprs)[0]


def _in_ring(exprs):
    """``(expansions, polynomials)``: :func:`expanded` of ``exprs``, and their elements of
    the ring they were expanded in (None where sympy expanded them)."""
    import sympy as sp
    from sympy.polys.rings import ring

    exprs = [sp.sympify(e) for e in exprs]
    atoms = set()
    for e in exprs:
        atoms |= e.free_symbols | e.atoms(sp.sin, sp.cos)
    trig = [a for a in atoms if not a.is_Symbol]
    if not atoms or any(a.args[0] != sp.expand(a.args[0]) for a in trig):
        return [sp.expand(e) for e in exprs], None
    gens = sorted(atoms, key=sp.default_sort_key)
    R = ring(gens, sp.QQ)[0]
    index = dict(zip(gens, R.gens))
    memo = {}

    class NotPolynomial(Exception):
        pass

    def conv(e):
        got = memo.get(e)
        if got is not None:
            return got
        if e.is_Rational:
            r = R(sp.QQ.from_sympy(e))
        elif e in index:
            r = index[e]
        elif e.is_Add:
            r = R.zero
            for a in e.args:
                r = r + conv(a)
        elif e.is_Mul:
            r = R.one
            for a in e.args:
                r = r * conv(a)
        elif e.is_Pow and e.exp.is_Integer and e.exp > 0:
            r = conv(e.base) ** int(e.exp)
        else:
            raise NotPolynomial
        memo[e] = r
        return r

    try:
        polys = [conv(e) for e in exprs]
    except NotPolynomial:
        return [sp.expand(e) for e in exprs], None
    return [p.as_expr() for p in polys], polys


def _common_symbols(E, P):
    """:func:`_monomial` of the expansion ``E``, read from its ring element ``P``: each
    symbol (not a sine or cosine) to its least power over the terms.  The same product:
    ``factor_terms`` of a sum extracts exactly these, of a product (one term) its own;
    a lone symbol or power, which is not a product, gives 1 there as here."""
    import sympy as sp

    if not (E.is_Add or E.is_Mul):
        return sp.Integer(1)
    least = [min(k) for k in zip(*P.monoms())]
    return sp.Mul(*(g ** k for g, k in zip(P.ring.symbols, least) if k and g.is_Symbol))


def reduced(exprs):
    """``exprs`` (a quotient's denominator and numerators) divided by their common
    monomial factor, so that no power of a parameter larger than needed is formed
    (m**5 overflows for m = 1e62).

    Each is expanded once (:func:`expanded`): its terms give the common factor, and
    divided by it term by term they are the expansion of the quotient (expanding it again
    took a third of a wheelbarrow's derivation)."""
    import sympy as sp

    full, polys = _in_ring(exprs)
    monos = [_monomial(E) if polys is None else _common_symbols(E, polys[i])
             for i, (e, E) in enumerate(zip(exprs, full)) if e != 0]
    common = monos[0]
    for mo in monos[1:]:
        common = sp.gcd(common, mo)
    if common == 1:
        return list(exprs)
    return [sp.Add(*(t / common for t in E.args)) if E.is_Add else sp.expand(E / common)
            for E in full]
