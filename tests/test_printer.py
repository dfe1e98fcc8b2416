"""The code printer of declared systems against sympy's own evaluation (issue 37).

The printer once printed 1/(A + B) as ``1.0/A + B``: a dropped pair of parentheses that gave
wrong classes on some declarations.  Here random sympy expressions (sums, products, negative
and fractional powers of sums and products, rationals, ``Abs``, ``sqrt``, nested quotients,
unary minus, the trigonometric functions the declarations use) are printed, as a whole and
through the emitter's common-subexpression path, and the printed text is evaluated in 50-digit
arithmetic (mpmath standing in for :mod:`math`), so that only the structure of the text is
tested, not rounding.  sympy's ``evalf`` at the same point is the reference.  No numba here.
"""

from __future__ import annotations

import math

import mpmath
import pytest
import sympy as sp
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from phasemap.declare.emit import _Writer, printer

X, Y, Z = sp.symbols("x y z", real=True)
SYMBOLS = (X, Y, Z)

_leaf = st.one_of(
    st.sampled_from(SYMBOLS),
    st.integers(-4, 4).map(sp.Integer),
    st.tuples(st.integers(-7, 7), st.integers(1, 9)).map(lambda pq: sp.Rational(*pq)),
    st.sampled_from([sp.Rational(1, 2), sp.Rational(-1, 2), sp.pi, sp.Float(0.3)]),
)

_EXPONENTS = [-3, -2, -1, 2, 3, sp.Rational(1, 2), sp.Rational(-1, 2), sp.Rational(3, 2),
              sp.Rational(-3, 2), sp.Rational(1, 3), sp.Rational(-2, 3)]


def _grow(children):
    pair = st.tuples(children, children)
    return st.one_of(
        pair.map(lambda ab: ab[0] + ab[1]),
        pair.map(lambda ab: ab[0] - ab[1]),
        pair.map(lambda ab: ab[0] * ab[1]),
        pair.map(lambda ab: ab[0] / ab[1]),                    # nested quotients
        pair.map(lambda ab: 1 / (ab[0] + ab[1])),              # the pattern of the bug
        pair.map(lambda ab: 1 / (ab[0] * ab[1] + 1)),
        children.map(lambda a: -a),                            # unary minus
        children.map(lambda a: -(a + X)),
        st.tuples(children, st.sampled_from(_EXPONENTS)).map(lambda ax: sp.Pow(ax[0], ax[1])),
        st.tuples(pair, st.sampled_from(_EXPONENTS)).map(          # powers of sums, products
            lambda ax: sp.Pow(ax[0][0] + ax[0][1], ax[1])),
        st.tuples(pair, st.sampled_from(_EXPONENTS)).map(
            lambda ax: sp.Pow(ax[0][0] * ax[0][1], ax[1])),
        children.map(sp.Abs),
        children.map(lambda a: sp.sqrt(a * a + 1)),
        children.map(sp.sqrt),
        children.map(sp.sin),
        children.map(sp.cos),
    )


EXPRESSIONS = st.recursive(_leaf, _grow, max_leaves=12)
POINTS = st.tuples(*[st.floats(-3.0, 3.0, allow_nan=False).filter(lambda v: abs(v) > 1e-3)
                     for _ in SYMBOLS])


class _MathInMpmath:
    """:mod:`math` as the printed text names it, in mpmath (complex where sympy's is)."""

    def __getattr__(self, name):
        return getattr(mpmath, name)


_MP = {"math": _MathInMpmath(), "abs": abs}


def _reference(expr, point):
    value = sp.N(expr.xreplace(dict(zip(SYMBOLS, map(sp.Float, point, [60] * 3)))), 50)
    assume(value.is_finite and value.is_number and not value.has(sp.zoo, sp.nan))
    return complex(value)


def _close(got, want):
    assume(math.isfinite(abs(want)))
    return abs(complex(got) - want) <= 1e-10 * max(1.0, abs(want))


def _evaluate(lines, names, point):
    scope = dict(_MP)
    scope.update({s.name: mpmath.mpf(v) for s, v in zip(SYMBOLS, point)})
    with mpmath.workdps(50):
        for line in lines:
            exec(line, scope)
        return [scope[n] for n in names]


_SETTINGS = settings(max_examples=200, deadline=None,
                     suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


@_SETTINGS
@given(EXPRESSIONS, POINTS)
def test_printed_expression_evaluates_as_sympy_does(expr, point):
    assume(expr.free_symbols)
    want = _reference(expr, point)
    try:
        (got,) = _evaluate([f"_r = {printer().doprint(expr)}"], ["_r"], point)
    except ZeroDivisionError:
        assume(False)
    assert _close(got, want), (expr, printer().doprint(expr), point, got, want)


@_SETTINGS
@given(st.lists(EXPRESSIONS, min_size=1, max_size=3), POINTS)
def test_emitted_lines_with_common_subexpressions_evaluate_as_sympy_does(exprs, point):
    """The emitter's path: ``cse`` splits the expressions into assignments, each printed on
    its own line (where a bare 1/(A + B) is most often printed)."""
    wants = [_reference(e, point) for e in exprs]
    w = _Writer(lambda e: e)
    names = [f"_r{i}" for i in range(len(exprs))]
    w.emit(list(zip(names, exprs)))
    try:
        gots = _evaluate(w.lines, names, point)
    except ZeroDivisionError:
        assume(False)
    for e, got, want in zip(exprs, gots, wants):
        assert _close(got, want), (e, w.lines, point, got, want)


@pytest.mark.parametrize("expr, text", [
    (1 / (X + Y), "(1.0/(x + y))"),
    ((X + Y) ** -2, "(1.0/((x + y)*(x + y)))"),
    (1 / (X * Y + Z), "(1.0/(x*y + z))"),
    ((X + Y) ** sp.Rational(-1, 2), "(1.0/math.sqrt(x + y))"),
])
def test_a_quotient_of_a_sum_keeps_its_parentheses(expr, text):
    """The reported pattern, and its printed text as it is now (kept readable)."""
    assert printer().doprint(expr) == text
