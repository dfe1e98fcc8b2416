"""The generated contract and grid kernels: one physics source, every path the same answer.

The grid kernels are specialised per (layer set, innermost axis); ``point`` and
``branch`` are generated from the same branch functions.  Here every cell of
random 1- to 4-D scenes of the six built-in models must equal, bit for bit,
what ``point`` gives at that cell reduced by ``_numerics.summarize`` (the
per-point path, as it was before the grid kernels were specialised), for layer
masks from one summary layer up to every layer (packed summary bytes, float
fields), with the innermost axis the relative velocity, an angle with derived
inputs and a parameter.  Each (model, mask, inner axis) compiles one kernel, so
the masks are chosen to cover every layer with few kernels.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

import phasemap
from phasemap import _codegen
from phasemap import _numerics as nx
from phasemap.grid import evaluate
from phasemap.layers import SUMMARY, layers_for
from phasemap.model import Branch

# per model: axes with ranges inside the domain (velocity axes pass through 0)
RANGES = {
    "ladder": {"phi": (0, math.pi / 2), "omega": (-3, 3), "f": (0, 3), "l": (0.5, 2),
               "g": (0, 12), "m": (0.5, 2)},
    "wheel": {"phi": (-4, 4), "omega": (-6, 6), "delta": (0, 0.8), "r": (1, 2), "l": (0, 1),
              "rho": (0.1, 1), "g": (0, 12)},
    "elliptic_pendulum": {"phi": (-4, 4), "omega": (-4, 4), "xdot": (-2, 2), "f": (0, 6),
                          "l": (0.5, 2), "m": (0.5, 2)},
    "hinge_pendulum": {"phi": (-4, 4), "omega": (-5, 5), "delta": (0, 2), "l": (0.5, 2),
                       "g": (0, 12)},
    "painleve_rod": {"theta": (0.01, 3.1), "omega": (-4, 4), "xdot": (-2, 2), "f": (0, 3),
                     "l": (0.5, 2), "g": (0, 12)},
    "rod_on_step": {"theta": (0.5, 1.55), "omega": (-4, 4), "f": (0, 2), "l": (0.9, 2),
                    "h": (0.3, 0.8), "g": (0, 12)},
}
# (layer mask, inner axis): "velocity" is the model's relative velocity (a state),
# "angle" a state with derived inputs (sin, cos), the others parameters.
MASKS = [("all", "velocity"), (("n_solutions",), "param"),
         (("stagnation", "singular", "field"), "angle"),
         (("contact_lost", "field", "coef"), "param")]


def _mask(m, mask, rng):
    reg = layers_for(m)
    grid_layers = [l for l in reg.values() if not l.fate]
    if mask == "all":
        return grid_layers
    fields = [l for l in grid_layers if not l.is_summary and l.admissible_only]
    coefs = [l for l in grid_layers if not l.admissible_only]
    chosen = []
    for k in mask:
        if k == "field":
            chosen += list(rng.choice(fields, size=2, replace=False))
        elif k == "coef":
            chosen.append(coefs[int(rng.integers(len(coefs)))])
        else:
            chosen.append(reg[k])
    return chosen


def _inner(m, kind, rng):
    if kind == "velocity":
        return m.velocity
    if kind == "angle":
        return m.derived[0].source
    params = [p.name for p in m.params if p.name in RANGES[m.name]]
    return params[int(rng.integers(len(params)))]


def _scene(m, inner, ndim, rng):
    others = [n for n in RANGES[m.name] if n != inner]
    names = list(rng.choice(others, size=ndim - 1, replace=False)) + [inner]
    axes = {}
    for n in names:
        lo, hi = RANGES[m.name][n]
        a = np.sort(rng.uniform(lo, hi, int(rng.integers(2, 7))))
        if n in (m.velocity, "omega", "xdot") and rng.random() < 0.7:
            a = np.sort(np.append(a, 0.0))  # the stick branch applies
        axes[n] = a
    fixed = {k: v for k, v in m.defaults.items() if k not in axes}
    if m.velocity not in axes:
        fixed[m.velocity] = float(rng.choice([0.0, 0.7, -0.4]))
    return axes, fixed


def _expected(m, layer, out):
    """What ``layer`` holds at a cell whose candidate rows are ``out``."""
    if layer.is_summary:
        return nx.summarize(out, m.stick_branch)[SUMMARY.index(layer.name)]
    st = out[layer.branch, nx.STATUS]
    solution = st == nx.ADMISSIBLE or st == nx.SEPARATION  # separation is a solution
    keep = solution or (not layer.admissible_only and st != nx.ABSENT)
    return out[layer.branch, layer.column] if keep else np.nan


def _same(a, b):
    return (a == b) or (math.isnan(a) and math.isnan(b))


@pytest.mark.slow
@pytest.mark.parametrize("model", list(RANGES))
@pytest.mark.parametrize("mask,inner_kind", MASKS)
def test_point_branch_and_grid_agree(model, mask, inner_kind):
    m = phasemap.get_model(model)
    rng = np.random.default_rng(zlib.crc32(f"{model} {mask} {inner_kind}".encode()))
    layers = _mask(m, mask, rng)
    inner = _inner(m, inner_kind, rng)
    slot = {n: i for i, n in enumerate(m.inputs)}
    out = np.empty((len(m.branches), m.n_fields))
    row = np.empty(m.n_fields)
    statuses = set()
    for ndim in (1, 2, 3, 4):
        axes, fixed = _scene(m, inner, ndim, rng)
        got = evaluate(m, axes, fixed, layers)
        shape = tuple(len(a) for a in axes.values())
        assert all(got[l.name].shape == shape for l in layers)
        assert list(axes)[-1] == inner
        for index in np.ndindex(*shape):
            values = {**fixed, **{n: float(axes[n][i]) for n, i in zip(axes, index)}}
            v = m.input_vector(values)
            m.point(v, out)
            statuses |= set(out[:, nx.STATUS])
            for layer in layers:
                want = _expected(m, layer, out)
                assert _same(float(got[layer.name][index]), float(want)), (layer.name, values)
            # the integrator's along-stage branch is the same row where the branch applies
            # to a moving state
            vel = v[slot[m.velocity]]
            for b, d in enumerate(m.directions):
                if d != 0.0 and d * vel > 0.0 and out[b, nx.STATUS] != nx.ABSENT:
                    m.branch(v, b, row)
                    assert all(_same(x, y) for x, y in zip(row, out[b])), (b, values)
    # the scenes reach admissible branches and at least one other status
    assert nx.ADMISSIBLE in statuses and len(statuses) >= 2


def test_a_hand_module_and_its_declaration_each_have_their_own_layers():
    from references import ladder

    declared, hand = phasemap.get_model("ladder"), ladder.MODEL  # both named "ladder"
    assert hand.name == declared.name and hand.branches != declared.branches
    for m in (hand, declared, hand):
        reg = layers_for(m)
        assert list(reg)[:4] == list(SUMMARY)
        fields = [l for l in reg.values() if l.branch >= 0]
        assert fields and all(l.name.endswith("_" + m.branches[l.branch]) for l in fields)


def test_a_single_point_scene_matches_classify():
    m = phasemap.MODELS["wheel"]
    reg = layers_for(m)
    values = {**m.defaults, "phi": 0.3, "omega": 0.0}
    got = evaluate(m, {}, values, [reg["n_solutions"], reg["stagnation"]])
    c = phasemap.classify("wheel", phi=0.3, omega=0.0)
    assert got["n_solutions"].shape == ()
    assert int(got["n_solutions"]) == c.n_solutions and bool(got["stagnation"]) == c.stagnation


def test_layers_are_returned_by_name_whatever_their_order():
    m = phasemap.MODELS["hinge_pendulum"]
    reg = layers_for(m)
    axes = {"phi": np.linspace(-3, 3, 7), "omega": np.array([-1.0, 0.0, 2.0])}
    fixed = {k: v for k, v in m.defaults.items() if k not in axes}
    a = evaluate(m, axes, fixed, [reg["stagnation"], reg["n_solutions"]])
    b = evaluate(m, axes, fixed, [reg["n_solutions"], reg["stagnation"]])
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    assert a["stagnation"].any() and not a["stagnation"].all()


def test_generated_code_is_real_source_with_every_branch_inlined(tmp_path):
    m = phasemap.MODELS["elliptic_pendulum"]
    path = pathlib_of(m.contract)
    text = path.read_text()
    assert "do not edit" in text
    for b, spec in enumerate(m.candidates):
        assert f"BR{b}(" in text
    # a grid kernel's source names only what its layers need
    reg = layers_for(m)
    kernel = _codegen.grid_kernel(m, (reg["n_solutions"],), "f")
    src = pathlib_of(kernel).read_text()
    assert "q_n_solutions" in src and "q_singular" not in src and "r0[5]" not in src


def pathlib_of(obj):
    import inspect
    import pathlib

    return pathlib.Path(inspect.getfile(getattr(obj, "py_func", obj)))


def test_a_branch_function_with_an_unknown_input_is_refused():
    from numba import njit

    m = phasemap.MODELS["hinge_pendulum"]

    @njit(inline="always")
    def bad(sigma, rest, omega, length):  # "length" is not an input of the model
        return (1.0, 0.0, 1.0, 0.0, 0.0, 0.0)

    broken = Branch("bad", 1.0, bad, (1.0,))
    with pytest.raises(ValueError, match="length"):
        _codegen._params(broken.func, 1, m.inputs, "hinge_pendulum: branch 'bad'")


def test_a_model_with_its_contract_built_still_pickles():
    # dask ships models to worker processes; the generated contract (a module)
    # stays behind and is rebuilt there
    import pickle

    m = phasemap.MODELS["hinge_pendulum"]
    out = np.empty((len(m.branches), m.n_fields))
    m.point(m.input_vector(m.defaults), out)
    copy = pickle.loads(pickle.dumps(m))
    again = np.empty_like(out)
    copy.point(copy.input_vector(copy.defaults), again)
    np.testing.assert_array_equal(out, again)
