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
from phasemap.core import codegen as _codegen
from phasemap.core import numerics as nx
from phasemap.maps.grid import evaluate
from phasemap.maps.layers import SUMMARY, layers_for
from phasemap.core.model import Candidate

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

    broken = Candidate("bad", 1.0, bad, (1.0,))
    with pytest.raises(ValueError, match="length"):
        _codegen.input_names(broken.func, 1, m.inputs, "hinge_pendulum: branch 'bad'")


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



def _assignments(body: str) -> dict:
    """``{local: right-hand side}`` of a generated function's ``body``."""
    import re

    return {m.group(1): m.group(2) for m in
            (re.match(r"\s+(_k_\w+) = (.*)", ln) for ln in body.splitlines()) if m}


def _reads(rhs: dict, name: str) -> set[str]:
    """The locals that ``name`` is computed from, directly or through others."""
    import re

    seen, todo = set(), [name]
    while todo:
        for dep in re.findall(r"\b_k_\w+", rhs.get(todo.pop(), "")):
            if dep not in seen:
                seen.add(dep)
                todo.append(dep)
    return seen


def test_a_declared_row_forms_its_acceleration_without_its_reactions():
    """The wheel's rolling row prints phi'' as one quotient over the row's determinant
    (the paper's right-hand side over its bracket), so that the integrator's
    right-hand side, which reads phi'' alone, computes no reaction; the row's
    status still reads every reaction and tie."""
    from phasemap.declare.emit import module_source
    from phasemap.systems.seeds.wheel import SYSTEM

    rhs = _assignments(module_source(SYSTEM).split("def mode_1(")[1].split("\n@njit")[0])
    q = _reads(rhs, "_k_Q0")
    assert "_k_D" in q and not {x for x in q if x.startswith(("_k_n", "_k_L", "_k_r"))}
    assert {"_k_n0", "_k_n1", "_k_ns0", "_k_L0", "_k_Ls0"} <= _reads(rhs, "_k_st")
    # the determinant is the bracket rho^2 + r^2 + l^2 - 2 r l cos(phi) + ...: its
    # l^2 sin^2 + l^2 cos^2 reduced
    d = [rhs[x] for x in _reads(rhs, "_k_D") | {"_k_D"} if x in rhs]
    assert not any("(sin_phi)*(sin_phi)" in e or "(cos_phi)*(cos_phi)" in e for e in d)


def test_a_declared_row_with_no_mass_has_no_solution_and_no_acceleration():
    """The quotient divides the mass matrix's determinant out of phi''; a zero mass
    (past the input checks) is still no solution, and the integrator's right-hand
    side gets no acceleration (NaN), as through the reactions before."""
    m = phasemap.get_model("wheel")
    values = {**m.defaults, "phi": 0.7, "omega": 1.0, "m": 0.0}
    v = m.input_vector(values)
    out = np.full((len(m.branches), m.n_fields), np.nan)
    m.point(v, out)
    assert nx.summarize(out, m.stick_branch)[0] == 0
    assert (out[:, nx.STATUS] != nx.ADMISSIBLE).all()
    roll = m.branches.index("roll_pos")
    assert np.isnan(m.contract.branch_row(v, roll)[nx.FIRST_ACC])
    values["m"] = 1.0
    assert np.isfinite(m.contract.branch_row(m.input_vector(values), roll)[nx.FIRST_ACC])


def test_edge_rows_left_out_of_a_loop_give_what_their_own_test_gives():
    """A declared row that exists only on an edge (the ladder's at phi = 0 and pi/2, 16 of
    its 27 rows) is left out of a grid loop where its edge test (``Candidate.edge``, which the
    row itself calls) reads no inner-axis value and is false at the outer state.  On grids
    through both edges, exactly and within the tie tolerance, with the edge rows outside
    (inner f) and inside (inner omega, the velocity) the loops' regimes, every cell is what
    the per-point classification gives; at some of them an edge row is a solution, so a
    loop that left it out there would differ.  (The layer sets are those of the figures'
    tests: no kernel of its own.)"""
    m = phasemap.MODELS["ladder"]
    edge = {b.name for b in m.candidates if b.edge is not None}
    assert len(edge) == 16 and all(b.bound is not None for b in m.candidates
                                   if b.name in edge)
    phi = np.array([0.0, 1e-13, 1e-9, 0.7, math.pi / 2 - 1e-9, math.pi / 2 - 1e-13,
                    math.pi / 2])
    scenes = [({"phi": phi, "f": np.array([0.0, 0.3, 1.0, math.sqrt(2.0), 2.5])},
               {"omega": w}, ["n_solutions", "stagnation"]) for w in (0.0, 0.7, -0.4)]
    scenes.append(({"phi": phi, "omega": np.array([-1.0, 0.0, 0.5])}, {"f": 0.4},
                   ["n_solutions", "stagnation"]))
    on_edge_solutions = 0
    for axes, fixed, layers in scenes:
        ds = phasemap.Scene("ladder", axes=axes, fixed=fixed, layers=layers).compute()
        names = list(axes)
        for index in np.ndindex(*ds.n_solutions.shape):
            point = {n: float(axes[n][i]) for n, i in zip(names, index)} | fixed
            c = phasemap.classify("ladder", **point)
            cell = ds.isel(dict(zip(names, index)))
            assert int(cell.n_solutions) == c.n_solutions, point
            assert bool(cell.stagnation) == c.stagnation, point
            on_edge_solutions += sum(b.name in edge and b.status in (
                phasemap.BranchStatus.ADMISSIBLE, phasemap.BranchStatus.SEPARATION)
                for b in c.candidates)
    assert on_edge_solutions > 0


def test_the_integrators_moving_test_computes_edge_rows_on_their_edges_only():
    """The integrator's test after a step (``_codegen.moving_test``) computes an edge row
    only where its edge test holds: at moving states on and off the ladder's edges it
    says what ``point`` (every row of the velocity's direction, each with its own test)
    says, for every mode, coefficient bit for bit; on the edges some edge row is a
    solution there, so a test that skipped them would differ."""
    m = phasemap.MODELS["ladder"]
    moving = _codegen.moving_test(m).moving
    point = _codegen.contract(m).point
    nb = len(m.candidates)
    solution = (nx.ADMISSIBLE, nx.SEPARATION)
    out = np.empty((nb, m.n_fields))
    edge_solutions = 0
    for phi in (0.0, 1e-13, 0.7, math.pi / 2 - 1e-13, math.pi / 2):
        for omega in (0.7, -0.4):
            for f in (0.0, 0.4, 1.0, 2.5):
                v = m.input_vector(m.complete({"phi": phi, "omega": omega, "f": f}))
                point(v, out)
                st = out[:, nx.STATUS]
                edge_solutions += sum(st[b] in solution for b in range(nb)
                                      if m.candidates[b].edge is not None)
                for mode in range(nb):
                    sole, coef = moving(v, mode)
                    others = [st[b] in solution or st[b] == nx.CONTINUUM
                              for b in range(nb) if b != mode]
                    assert sole == (st[mode] in solution and not any(others)), (phi, omega, f)
                    assert _same(coef, out[mode, nx.COEF]), (phi, omega, f, mode)
    assert edge_solutions > 0
