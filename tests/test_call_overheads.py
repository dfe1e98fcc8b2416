"""The shortcuts the public calls take to keep their per-call cost low (issue 22) decide
exactly what the long way decides: the same values pass, the same values fail, with the
same messages."""

from __future__ import annotations

import math

import numpy as np
import pytest

import phasemap
from phasemap.declare import runtime
from phasemap.motion.simulate import Options


def test_checked_options_are_remembered_per_type_not_per_value():
    """1 and True hash alike; a remembered max_events=1 must not let True through."""
    assert Options(max_events=1).checked("ladder").max_events == 1
    with pytest.raises(phasemap.core.args.WrongType, match="max_events"):
        Options(max_events=True).checked("ladder")
    assert Options(rtol=1e-9).checked("ladder") is Options(rtol=1e-9).checked("ladder")
    assert Options(rtol=np.float64(1e-9)).checked("ladder").rtol == 1e-9
    with pytest.raises(ValueError, match="rtol must be in"):
        Options(rtol=1.0).checked("ladder")
    # unhashable: validated, not remembered, and refused as all bad input is, with a
    # ValueError (the tuple (TypeError, ValueError) here let a plain TypeError pass)
    with pytest.raises(ValueError, match="t_end must be one real number, not a sequence"):
        Options(t_end=[1.0]).checked("ladder")


@pytest.mark.parametrize("values, message", [
    ({"phi": np.array([0.1, math.nan, 0.2])}, "phi must be finite"),
    ({"phi": np.array([0.1, 2.0, 0.2])}, r"phi = 2 is outside its domain \[0, "),
    ({"phi": np.array([-1e-300, 0.2])}, "phi = -1e-300 is outside its domain"),
    ({"f": np.array([[0.1], [-0.5]])}, "f = -0.5 is outside its domain"),
    ({"l": np.array([1e-310, 1.0])}, "l = 1e-310 is too small"),
    ({"phi": np.array([0.1, math.inf])}, "phi must be finite"),
])
def test_an_array_out_of_the_domain_is_refused_as_before(values, message):
    with pytest.raises(ValueError, match=message):
        phasemap.get_model("ladder").complete(values)


def test_an_array_on_the_domain_edges_passes_whole():
    m = phasemap.get_model("ladder")
    phi = np.array([0.0, 0.5, m.variables["phi"].upper])
    full = m.complete({"phi": phi, "f": 0.3})
    assert full["phi"] is not phi and np.array_equal(full["phi"], phi)
    assert full["f"] == 0.3 and full["omega"] == m.defaults["omega"]
    with pytest.raises(ValueError, match="unknown variable 'psi'"):
        m.complete({"psi": 0.1})


def test_the_domain_check_on_arrays_is_the_generated_function_value_by_value():
    """rod_on_step's ``inside``, run once on whole arrays, agrees with it called per value,
    on both sides of the domain's edge; and the Scene refuses what it refuses."""
    m = phasemap.get_model("rod_on_step")
    names = ["l", "h", "sin_theta", "cos_theta"]
    theta = np.linspace(0.05, 1.55, 301)
    h = np.array([0.1, 0.5, 0.9, 1.3])[:, None]
    args = (1.0, h, np.sin(theta), np.cos(theta))
    fast = runtime.on_arrays(m.inside.py_func)(*args)
    slow = np.vectorize(m.inside.py_func, otypes=[bool])(*args)
    assert list(m.inside.py_func.__code__.co_varnames[:4]) == names
    assert fast.shape == slow.shape == (4, 301) and fast.any() and not fast.all()
    assert np.array_equal(fast, slow)
    with pytest.raises(ValueError, match="rod_on_step: outside the domain"):
        phasemap.Scene(m, axes={"theta": theta}, fixed={"h": 0.9})


def test_code_that_takes_one_number_falls_back_to_a_call_per_value():
    def inside(x):
        return max(x, 0.0) > 0.5  # max() of an array raises: np.vectorize takes over

    check = runtime.checks("demo", None, type("F", (), {"py_func": staticmethod(inside)})(),
                             "x > 0.5")
    check({"x": np.array([0.6, 0.7])})
    with pytest.raises(ValueError, match="demo: outside the domain: x > 0.5"):
        check({"x": np.array([0.6, 0.2])})
