"""Bad input gets one clear error at every public entry point (issue 23 item 9).

Each case below failed on the code before phasemap.core.args: an OverflowError, a
numba TypeError, a numpy ufunc error, ``unknown layer 'n'``, a date read as
50.0, ``atol=np.int64(1)`` refused.  The fuzz at the end throws a few hundred
awkward values at classify, Scene, compute, simulate and phase_curve.
"""

from __future__ import annotations

import fractions
import math
import random

import numpy as np
import pytest

import phasemap
from phasemap.core import args as _args
from phasemap.motion.phase import phase_curve
import re

HUGE = 10**400

#: compiles the hinge pendulum's phase-curve tracer, as tests/test_phase_curve.py does:
#: one xdist group, so that it is compiled once (tests/conftest.py)
XDIST_GROUP = "tests/test_phase_curve.py"


# ------------------------------------------------------------ the checker -----
@pytest.mark.parametrize("value", [0.5, 1, np.float32(0.5), np.float16(0.5), np.int8(1),
                                   np.uint64(3), np.int64(2), np.longdouble(0.25),
                                   np.array(0.5), np.array(2), fractions.Fraction(1, 4)])
def test_real_takes_python_and_numpy_scalars(value):
    x = _args.real("phi", value, "ladder")
    assert type(x) is float and x == float(value)


@pytest.mark.parametrize("value", [True, np.bool_(False), np.datetime64("2020"),
                                   np.timedelta64(3, "s"), "0.5", b"1", 1 + 2j,
                                   np.complex128(1), None, [0.5], (0.5,), {}, object(),
                                   np.array([0.5]), np.array("x")])
def test_real_refuses_everything_else_naming_the_argument(value):
    with pytest.raises(TypeError, match="^ladder: phi must be") as err:
        _args.real("phi", value, "ladder")
    assert isinstance(err.value, ValueError)  # phasemap's promise: bad input is a ValueError


def test_huge_integers_are_a_value_error_not_an_overflow():
    with pytest.raises(ValueError, match=r"phi = 10\*\*400 is too large to be represented"):
        _args.real("phi", HUGE, "hinge_pendulum")
    with pytest.raises(ValueError, match="an integer of 401 digits"):
        _args.real("phi", HUGE + 1)
    with pytest.raises(ValueError, match=r"phi = 10\*\*5000 is too large"):  # str() refuses it
        _args.real("phi", 10**5000)
    with pytest.raises(ValueError, match=r"axis phi\[1\] = 10\*\*400"):
        _args.reals("axis phi", [0.5, HUGE])


def test_count():
    assert _args.count("max_steps", np.int64(7)) == 7 and _args.count("n", 1e6) == 10**6
    for bad, words in [(10**30, r"max_steps = 10\*\*30 is too large"),
                       (2.5, "whole number"), (0, ">= 1"), (math.nan, "whole number"),
                       (np.uint64(2**64 - 1), "too large")]:
        with pytest.raises(ValueError, match=words):
            _args.count("max_steps", bad)
    with pytest.raises(TypeError, match="max_steps must be a real number"):
        _args.count("max_steps", True)


def test_names_get_did_you_mean():
    message = _args.unknown("variable", "omgea", ["phi", "omega", "f"], "ladder")
    assert message == ("ladder: unknown variable 'omgea'; did you mean 'omega'? "
                       "(allowed: phi, omega, f)")
    assert _args.unknown("variable", "zzz", ["phi"]) == "unknown variable 'zzz'; allowed: phi"


@pytest.mark.parametrize("text, value", [
    ("1.5708", 1.5708), ("-3e-2", -0.03), ("pi", math.pi), ("pi/2", math.pi / 2),
    ("2*pi/3", 2 * math.pi / 3), ("-(pi - 0.5)", -(math.pi - 0.5)), (" (1 + 2) * 0.5 ", 1.5),
    ("+pi", math.pi), ("inf", math.inf),
])
def test_parse_real(text, value):
    assert _args.parse_real(text, "phi") == value


@pytest.mark.parametrize("text", ["", "pi**2", "__import__('os').system('true')", "e",
                                  "phi", "1/0", "abs(-1)", "[1]", "1 if 1 else 2", "(" * 300,
                                  "1j", "True", "'1'", "pi.real", "1,2", "x=1"])
def test_parse_real_refuses_anything_but_arithmetic(text):
    with pytest.raises(ValueError, match="^phi: "):
        _args.parse_real(text, "phi")


# ------------------------------------------------ the cases of the issue -----
def test_classify_huge_int_names_the_argument():
    with pytest.raises(ValueError, match="hinge_pendulum: phi = 10"):
        phasemap.classify("hinge_pendulum", phi=HUGE)


def test_unknown_names_get_did_you_mean():
    with pytest.raises(ValueError, match="did you mean 'omega'"):
        phasemap.classify("ladder", omgea=0.0)
    with pytest.raises(ValueError, match="unknown model 'ladr'; did you mean 'ladder'"):
        phasemap.classify("ladr")
    with pytest.raises(ValueError, match="did you mean 'max_step' or 'max_steps'"):
        phasemap.Scene("hinge_pendulum", axes={"phi": [0.1]}, layers=["fate"],
                       options={"max_step_count": 10})


def test_exact_bounds_in_domain_messages():
    with pytest.raises(ValueError, match=r"phi = 1.5708 is outside its domain "
                                         r"\[0, 1.5707963267948966\]"):
        phasemap.classify("ladder", phi=1.5708)


def test_simulate_counts_and_numpy_tolerances():
    with pytest.raises(ValueError, match="hinge_pendulum: max_steps = 10"):
        phasemap.simulate("hinge_pendulum", 0.1, max_steps=10**30)
    ds = phasemap.simulate("hinge_pendulum", np.float32(0.1), atol=np.int64(1),
                           max_steps=np.int64(1000), phi=np.float64(0.5), omega=np.int32(0))
    assert ds.attrs["phasemap_atol"] == 1.0 and ds.attrs["phasemap_max_steps"] == 1000


def test_fate_options_are_checked_before_numba():
    with pytest.raises(ValueError, match="hinge_pendulum: max_steps = 10"):
        phasemap.Scene("hinge_pendulum", axes={"phi": [0.1]}, layers=["fate"],
                       options={"max_steps": 10**30})


@pytest.fixture(scope="module")
def small_scene():
    return phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 5), "f": [0.1, 0.5]})


@pytest.mark.parametrize("chunks, words", [
    (2.5, "chunks must be a whole number"), (10**30, r"chunks = 10\*\*30 is too large"),
    ("a", "chunks must be an int, a mapping"), ({"ph": 2}, "did you mean 'phi'"),
    ({"phi": 0}, r"chunks\['phi'\] must be an integer >= 1"), ([2, 2], "chunks must be"),
])
def test_chunks_are_checked(small_scene, chunks, words):
    with pytest.raises(ValueError, match=words):
        small_scene.compute(chunks=chunks)


@pytest.mark.parametrize("chunks, expected", [
    ("auto", ((5,), (2,))), (np.int64(2), ((2, 2, 1), (2,))), (10**6, ((5,), (2,))),
    ({"f": 1}, ((5,), (1, 1))),
])
def test_chunks_accepted(small_scene, chunks, expected):
    assert small_scene.compute(chunks=chunks).n_solutions.chunks == expected


def test_a_single_layer_name_is_one_layer():
    scene = phasemap.Scene("ladder", axes={"phi": [0.1, 0.2]}, layers="n_solutions")
    assert scene.layers == ("n_solutions",)
    with pytest.raises(ValueError) as err:
        phasemap.Scene("ladder", axes={"phi": [0.1, 0.2]}, layers=["n_solution"])
    assert "did you mean 'n_solutions'" in str(err.value)
    assert "phasemap.layers_for('ladder')" in str(err.value) and "stagnation" not in str(err.value)


def test_dates_are_not_axes():
    with pytest.raises(TypeError, match="ladder: axis phi must hold real numbers"):
        phasemap.Scene("ladder", axes={"phi": np.array(["2020"], dtype="datetime64[Y]")})
    with pytest.raises(TypeError, match="ladder: f must be a real number"):
        phasemap.Scene("ladder", axes={"phi": [0.1]}, fixed={"f": np.datetime64("2020")})


def test_phase_curve_huge_phi_says_so():
    with pytest.raises(ValueError, match="hinge_pendulum: phi = 10"):
        phase_curve("hinge_pendulum", phi=HUGE)


# ------------------------------------------------------------------- fuzz -----
from fuzzing import AWKWARD  # noqa: E402 - one list for both fuzzes


def _entry_points(scene):
    """(argument name, call taking the value) for each argument of the public entry points."""
    calls = []
    for model in ("hinge_pendulum", "ladder"):
        for name in phasemap.MODELS[model].names:
            calls.append((name, lambda x, m=model, n=name: phasemap.classify(m, **{n: x})))
            calls.append((name, lambda x, m=model, n=name: phasemap.Scene(
                m, axes={n: [x]} if n != "omega" else {n: x}).size))
            calls.append((name, lambda x, m=model, n=name: phasemap.Scene(
                m, axes={"omega": [0.0, 1.0]}, fixed={n: x}).size))
    calls.append(("layers", lambda x: phasemap.Scene("ladder", axes={"phi": [0.1]}, layers=x)))
    calls.append(("chunks", lambda x: scene.compute(chunks=x)))
    for opt in ("t_end", "rtol", "atol", "max_step", "max_steps", "max_events", "method"):
        calls.append((opt, lambda x, o=opt: phasemap.Scene(
            "hinge_pendulum", axes={"phi": [0.5]}, layers=["fate"], options={o: x}).options))
        calls.append((opt, lambda x, o=opt: phasemap.simulate(
            "hinge_pendulum", **{"t_end": 0.05, "max_steps": 200, o: x})))
    calls.append(("t_eval", lambda x: phasemap.simulate("hinge_pendulum", 0.05, t_eval=x)))
    return calls


def _admissible_rows_finite(result) -> bool:
    if not isinstance(result, phasemap.Classification):
        return True
    return all(math.isfinite(v) for b in result.branches
               for v in (*b.accelerations.values(), *b.reactions.values()))


def test_fuzz_public_entry_points(small_scene):
    """A seeded fuzz: a result, or one ValueError/TypeError whose message names the
    argument; never an OverflowError, a KeyError, a numba error, or a NaN solution."""
    rng = random.Random(23)
    calls = _entry_points(small_scene)
    for _ in range(400):
        name, call = rng.choice(calls)
        _check_call(name, call, rng.choice(AWKWARD))


def _check_call(name, call, value):
    value_text = _args.describe(value)  # repr() refuses an integer of 5000 digits
    try:
        result = call(value)
    except (ValueError, TypeError) as err:
        text = str(err)
        assert name in text, (name, value_text, text)
        assert type(err).__module__ in ("builtins", "phasemap.core.args"), (name, value_text, text)
        assert "numba" not in text.lower() and "Traceback" not in text, (name, value_text, text)
    else:
        assert _admissible_rows_finite(result), (name, value_text)


def test_fuzz_phase_curve():
    """Every awkward value for each argument of phase_curve (about 300 calls)."""
    for name in ("phi", "omega", "delta", "rtol", "max_stages", "points_per_stage"):
        for value in AWKWARD:
            _check_call(name, lambda x: phase_curve(
                "hinge_pendulum", **{"phi": 0.5, "omega": 0.0, "max_stages": 2, name: x}),
                value)


# ---------------------------------------------------- values that would overflow -----
@pytest.mark.parametrize("model, values, words", [
    ("ladder", {"omega": 1e300}, "omega = 1e+300 is too large"),
    ("wheel", {"r": 1e155, "l": 0.5}, "r = 1e+155 is too large"),
    ("hinge_pendulum", {"l": 1e300}, "l = 1e+300 is too large"),
    ("hinge_pendulum", {"l": 1e-200}, "l = 1e-200 is too small"),
    ("elliptic_pendulum", {"m": 1e-160}, "m = 1e-160 is too small"),
])
def test_values_that_would_overflow_are_refused(model, values, words):
    with pytest.raises(ValueError, match=re.escape(words)):
        phasemap.classify(model, **values)
    name, value = next(iter(values.items()))
    with pytest.raises(ValueError, match=re.escape(words.split(" is ")[0])):
        phasemap.Scene(model, axes={name: [1.0, value]}, fixed={k: v for k, v in values.items()
                                                               if k != name})


@pytest.mark.parametrize("value", ["0.5", None, True, 1 + 2j])
def test_a_value_of_the_wrong_type_is_a_type_error_and_a_value_error(value):
    """classify('ladder', phi='0.5') raised a class named ArgumentTypeError, which reads as
    argparse's (issue 41 item 4): it is phasemap's WrongType, both errors the guide names."""
    with pytest.raises(TypeError, match=r"^ladder: phi must be a real number, got ") as err:
        phasemap.classify("ladder", phi=value)
    assert isinstance(err.value, ValueError)
    assert type(err.value).__name__ == "WrongType" and "argparse" not in repr(err.value)
