"""The derivation's symbolic shortcuts give sympy's own answers (phasemap.declare.algebra,
phasemap.declare.solvers): the expansions in a ring of polynomials, the vanishing tests
evaluated together, the numerical test of proportional minors.  tests/test_shipped.py
checks the same on the built-in declarations, whose derivations must not change by a
character; these check the edges the declarations do not reach."""

import numpy as np
import pytest
import sympy as sp

import unseen
from phasemap.declare import algebra, solvers
from phasemap.declare.equations import Equations

m, l, f, h = sp.symbols("m l f h", real=True)
phi, theta = sp.symbols("phi theta", real=True)
ATOMS = [m, l, f, sp.sin(phi), sp.cos(phi), sp.cos(theta), sp.sin(theta)]


def _poly(rng, terms=4):
    """A random polynomial in ATOMS with rational coefficients, left unexpanded."""
    e = sp.Integer(0)
    for _ in range(terms):
        t = sp.Rational(int(rng.integers(-9, 10)), int(rng.integers(1, 7)))
        for _ in range(int(rng.integers(1, 4))):
            t *= ATOMS[int(rng.integers(len(ATOMS)))] ** int(rng.integers(1, 3))
        e += t
    return e * (ATOMS[int(rng.integers(len(ATOMS)))] + sp.Rational(1, 3)) if rng.random() < 0.5 else e


@pytest.mark.parametrize("seed", range(6))
def test_the_ring_expansion_of_determinants_is_sympys_to_the_character(seed):
    """Berkowitz determinants of random 2x2 and 3x3 polynomial matrices (Cramer's
    numerators are such), and products and powers of sums: the same expression, term for
    term, as sympy.expand (srepr compares the trees)."""
    rng = np.random.default_rng(seed)
    n = 2 + seed % 2
    A = sp.Matrix(n, n, lambda i, j: _poly(rng, 4 if n == 2 else 2))
    dets = [A.det(method="berkowitz"), (m * l + f) ** 3 * (A[0, 0] - A[1, 1]),
            sp.Integer(7), m, sp.Integer(0)]
    got = algebra.expanded(dets)
    assert [sp.srepr(g) for g in got] == [sp.srepr(sp.expand(d)) for d in dets]
    # and up to 3 x 3, sympy's Berkowitz determinant is that expansion, term for term
    assert sp.srepr(algebra.determinant(A)) == sp.srepr(A.det(method="berkowitz"))
    # reduced: the common monomial divided out term by term is the expansion of the quotient
    common = m ** 2 * l
    exprs = [sp.expand(d * common) for d in dets[:2]] + [common * (m + f)]
    want = [sp.expand(e / common) for e in exprs]
    assert [sp.srepr(g) for g in algebra.reduced(exprs)] == [sp.srepr(w) for w in want]


@pytest.mark.parametrize("e", [
    sp.sqrt(4 * l ** 2 - h ** 2) * (sp.sqrt(4 * l ** 2 - h ** 2) + m),   # sqrt squared: h, l
    sp.Float(0.5) * m * (m + l),                                           # a float
    (m + l) / m * (m - l),                                                 # a division
    sp.sin(2 * (phi + theta)) * (m + sp.sin(2 * (phi + theta))),           # an unexpanded angle
    sp.Abs(m - l) * (m + l),                                               # another function
])
def test_what_is_not_a_polynomial_in_the_ring_is_expanded_by_sympy(e):
    """A square root (whose square sympy rewrites to the sum inside, which the ring would
    leave unexpanded), a float, a division, a sine of an unexpanded angle, another
    function: the whole list goes to sympy.expand, the same answer."""
    got = algebra.expanded([e, (m + l) ** 2])
    assert [sp.srepr(g) for g in got] == [sp.srepr(sp.expand(x)) for x in (e, (m + l) ** 2)]


@pytest.fixture(scope="module")
def eqs():
    return Equations(unseen.gyration_rod())


def test_vanishing_tests_made_together_decide_as_one_at_a_time(eqs):
    """The dropped equation and the accelerations a family moves are tested for vanishing
    together, at shared samples: the same decisions as each alone, on expressions that
    vanish only by an identity (sin^2 + cos^2 = 1, a binomial) and ones that do not."""
    th, m_, l_ = (sp.Symbol(n, real=True) for n in ("theta", "m", "l"))
    exprs = [sp.sin(th) ** 2 + sp.cos(th) ** 2 - 1, sp.Integer(0),
             m_ * l_ * sp.sin(th), (l_ + m_) ** 2 - l_ ** 2 - 2 * l_ * m_ - m_ ** 2,
             (l_ + m_) ** 2 - l_ ** 2 - m_ ** 2, sp.cos(th) * 1e-3]
    together = solvers._vanish(eqs, exprs)
    assert together == [solvers._vanishes(eqs, e) for e in exprs]
    assert together == [True, True, False, True, False, False]
    # and the values are those of one expression alone at the same samples
    vals = eqs.numeric_all(exprs[2:3] + exprs[4:5], 5)
    assert vals.shape == (2, 5) and np.all(vals != 0.0)


def test_proportional_minors_are_found_numerically_and_exactly_alike(eqs):
    """Two minors are kept apart unless their ratio is a constant: decided from samples
    where it is clearly constant or clearly not, and by sympy's cancel otherwise; a ratio
    constant for each slip direction (a sign symbol) counts as constant."""
    th, m_, l_ = (sp.Symbol(n, real=True) for n in ("theta", "m", "l"))
    s = sp.Symbol("_k_sig_A", real=True)
    a = m_ * l_ + sp.sin(th)
    assert solvers._proportional(eqs, 3 * a, a)
    assert solvers._proportional(eqs, sp.expand((m_ + l_) * a), (m_ + l_) * a)
    assert not solvers._proportional(eqs, m_ * l_ - sp.sin(th), a)
    assert not solvers._proportional(eqs, a * (1 + 1e-7 * sp.cos(th)), a)   # nearly: cancel
    assert solvers._proportional(eqs, s * a, a)


@pytest.mark.parametrize("e", [
    m, m ** 2, 2 * m, 3 * m ** 2 * l * sp.sin(phi),
    m ** 2 * l + m * l ** 3 * sp.cos(phi), sp.Rational(1, 2) * m * f + sp.Rational(1, 3) * m ** 3,
    sp.sin(phi) * m + sp.sin(phi) * l, (m + l) ** 3 * m * sp.cos(theta) ** 2, f + 1,
])
def test_the_common_monomial_read_from_the_ring_is_factor_terms_one(e):
    """The common factor of an expansion's terms, read from its ring element, is the
    one factor_terms finds: symbols to their least power, never a sine or a cosine, and 1
    for a lone symbol or power (not a product), as the derivation always took it."""
    full, polys = algebra._in_ring([e])
    assert polys is not None
    assert algebra._common_symbols(full[0], polys[0]) == algebra._monomial(full[0])
