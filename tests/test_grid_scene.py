"""The grid evaluator and Scene: cell-by-cell equal to classify(), lazily and eagerly."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from conftest import assert_atlas_round_trip

import phasemap
from phasemap.core import numerics as nx

G = 9.81
# per model: axis candidates with ranges inside the domain (velocity axes include 0)
AXES = {
    "ladder": {"phi": (0, math.pi / 2), "omega": (-3, 3), "f": (0, 3), "l": (0.5, 2),
               "g": (0, 12)},
    "wheel": {"phi": (-4, 4), "omega": (-6, 6), "delta": (0, 0.8), "r": (1, 2), "l": (0, 1),
              "rho": (0.1, 1)},
    "elliptic_pendulum": {"phi": (-4, 4), "omega": (-4, 4), "xdot": (-2, 2), "f": (0, 6),
                          "l": (0.5, 2)},
    "hinge_pendulum": {"phi": (-4, 4), "omega": (-5, 5), "delta": (0, 2), "l": (0.5, 2),
                       "g": (0, 12)},
}


def _axis(rng, name, lo, hi, uniform):
    n = int(rng.integers(1, 5))
    if uniform:
        a = np.linspace(lo, hi, n)
    else:
        a = np.sort(rng.uniform(lo, hi, n))
    if name in ("omega", "xdot") and rng.random() < 0.6:
        a = np.unique(np.append(a, 0.0))  # an axis never repeats a value
    return a


@pytest.mark.slow
@pytest.mark.parametrize("model", list(AXES))
@pytest.mark.parametrize("uniform", [True, False])
def test_grid_equals_classify_cell_by_cell(model, uniform):
    rng = np.random.default_rng(hash((model, uniform)) % 2 ** 32)
    m = phasemap.MODELS[model]
    every_layer = list(phasemap.layers_for(m))
    # the innermost axis is the same for every scene (the relative velocity; every
    # layer): one kernel specialisation per model, the one tests/test_kernels.py's
    # "all" layers with the velocity innermost compiles too (the ladder's took 38 s
    # of compile at -O1 for phi innermost), as compiling is most of this test's time.
    # tests/test_kernels.py varies the innermost axis and the layer set.
    inner = m.velocity
    rest = [n for n in AXES[model] if n != inner]
    for ndim in (1, 2, 3, 4):
        names = list(rng.choice(rest, size=ndim - 1, replace=False)) + [inner]
        axes = {n: _axis(rng, n, *AXES[model][n], uniform) for n in names}
        ds = phasemap.Scene(model, axes=axes, layers=every_layer).compute()
        assert ds.n_solutions.dims == tuple(names)
        for index in np.ndindex(*ds.n_solutions.shape):
            point = {n: float(axes[n][i]) for n, i in zip(names, index)}
            c = phasemap.classify(model, **point)
            cell = ds.isel(dict(zip(names, index)))
            assert int(cell.n_solutions) == c.n_solutions, (point, c)
            assert bool(cell.stagnation) == c.stagnation
            assert bool(cell.contact_lost) == c.contact_lost
            assert bool(cell.singular) == c.singular
            admissible = {b.name: b for b in c.candidates  # solutions, separations included
                          if b.status in (phasemap.BranchStatus.ADMISSIBLE,
                                          phasemap.BranchStatus.SEPARATION)}
            applies = {b.name: b for b in c.candidates}
            for b in m.branches:
                for v in m.accelerations + m.reactions:
                    got = float(cell[f"{v.name}_{b}"])
                    if b in admissible:
                        want = {**admissible[b].accelerations, **admissible[b].reactions}
                        assert got == want[v.name]
                    else:
                        assert math.isnan(got)
                if b != m.branches[m.stick_branch]:
                    got = float(cell[f"coef_{b}"])
                    if b in applies:
                        assert got == applies[b].coefficient or (
                            math.isnan(got) and math.isnan(applies[b].coefficient))
                    else:
                        assert math.isnan(got)


def test_default_layers_follow_the_relative_velocity():
    phi = np.linspace(0, 1, 3)
    assert phasemap.Scene("ladder", axes={"phi": phi}).layers == ("n_solutions", "stagnation")
    assert phasemap.Scene("ladder", axes={"phi": phi},
                          fixed={"omega": 1.0}).layers == ("n_solutions",)
    assert phasemap.Scene("elliptic_pendulum", axes={"phi": phi},
                          fixed={"xdot": 1.0}).layers == ("n_solutions",)
    assert phasemap.Scene("elliptic_pendulum", axes={"phi": phi, "xdot": np.linspace(-1, 1, 5)}
                          ).layers == ("n_solutions", "stagnation")
    assert phasemap.Scene("elliptic_pendulum", axes={"phi": phi, "xdot": [-1, 1]}
                          ).layers == ("n_solutions",)
    ds = phasemap.Scene("ladder", axes={"phi": phi}, fixed={"omega": 1.0}).compute()
    assert list(ds.data_vars) == ["n_solutions"]


def test_only_requested_layers_are_stored():
    ds = phasemap.Scene("wheel", axes={"phi": np.linspace(-1, 1, 4)},
                        layers=["phi_ddot_roll_pos", "singular"]).compute()
    assert list(ds.data_vars) == ["phi_ddot_roll_pos", "singular"]


def test_metadata_comes_from_the_registry_and_the_model():
    ds = phasemap.Scene("elliptic_pendulum", axes={"phi": np.linspace(-1, 1, 3), "f": [1.0, 4.0]},
                        fixed={"xdot": 1.0}, layers=["n_solutions", "N_slide_pos_Npos"]).compute()
    assert ds.phi.attrs == {"units": "rad", "long_name": "angle of the bar from the downward vertical",
                            "phasemap_symbol": r"\varphi"}
    assert ds.n_solutions.dtype == np.int8
    assert list(ds.n_solutions.attrs["flag_values"]) == [0, 1, 2, 3, 4]
    assert ds.n_solutions.attrs["flag_meanings"] == "none unique two continuum three_or_more"
    assert ds.N_slide_pos_Npos.attrs["units"] == "N"
    assert ds.attrs["phasemap_model"] == "elliptic_pendulum"
    assert ds.attrs["phasemap_fixed_xdot"] == 1.0
    assert ds.attrs["Conventions"] == phasemap.atlas.dataset.CONVENTIONS


def test_the_dataset_holds_the_kernels_arrays_as_xarray_would_build_it():
    from phasemap.maps.grid import evaluate

    scene = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 7),
                                                   "omega": [-1.0, 0.0, 2.0]},
                           layers=["n_solutions", "stagnation", "R_n_stick"])
    reg = phasemap.layers_for(scene.model)
    arrays = evaluate(scene.model, scene.axes, scene.fixed, [reg[n] for n in scene.layers])
    ds = scene._dataset(arrays)
    for name, a in arrays.items():  # no copy after the kernel
        assert np.shares_memory(ds[name].values, a)
    # built directly, it is what xarray's own constructor (merge, default indexes) builds
    merged = xr.Dataset({n: ds[n].variable for n in ds.data_vars},
                        {n: ds[n].variable for n in ds.coords}, ds.attrs)
    xr.testing.assert_identical(ds, merged)
    assert list(ds.xindexes) == list(merged.xindexes) == ["phi", "omega"]
    for n in ds.xindexes:
        assert ds.xindexes[n].equals(merged.xindexes[n])
    assert ds.sel(omega=0.0).n_solutions.dims == ("phi",)  # the indexes work


def test_spec_recomputes_the_same_atlas():
    scene = phasemap.Scene("hinge_pendulum",
                           axes={"phi": np.linspace(-3, 3, 7), "delta": [0.1, 0.35, 1.2]},
                           fixed={"omega": 0.0}, layers=["n_solutions", "stagnation", "singular"])
    ds = scene.compute()
    again = phasemap.Scene.from_spec(json.loads(ds.attrs["phasemap_scene"])).compute()
    xr.testing.assert_equal(ds, again)
    assert json.loads(ds.attrs["phasemap_scene"])["axes"]["phi"] == {"start": -3.0, "stop": 3.0,
                                                                     "count": 7}


@pytest.mark.parametrize("kwargs, words", [
    (dict(model="ladder", axes={}), "at least one axis"),
    (dict(model="ladder", axes={"zeta": [1.0]}), "unknown variable 'zeta'"),
    (dict(model="ladder", axes={"phi": []}), "non-empty 1-D"),
    (dict(model="ladder", axes={"phi": [[0.1, 0.2]]}), "non-empty 1-D"),
    (dict(model="ladder", axes={"phi": [0.1, math.nan]}), "phi must be finite"),
    (dict(model="ladder", axes={"phi": [0.1, 2.0]}), "phi = 2 is outside its domain"),
    (dict(model="ladder", axes={"phi": [0.1]}, fixed={"phi": 0.2}), "both an axis and fixed"),
    (dict(model="ladder", axes={"phi": [0.1]}, layers=["nope"]), "unknown layer 'nope'"),
    (dict(model="ladder", axes={"phi": [0.1]}, layers=[]), "at least one layer"),
    (dict(model="wheel", axes={"l": [0.5, 1.5]}), "must not exceed r"),
    (dict(model="wheel", axes={"l": [0.5, 1.5], "r": [2.0, 3.0]}), None),
    (dict(model="nope", axes={"phi": [0.1]}), "unknown model 'nope'"),
])
def test_scene_bad_input(kwargs, words):
    if words is None:  # every combination valid: no error
        phasemap.Scene(**kwargs)
        return
    with pytest.raises(ValueError, match=words):
        phasemap.Scene(**kwargs)


def test_progress_bar_path_equals_the_single_call(monkeypatch):
    import phasemap.maps.scene as scene_mod

    scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 37),
                                           "f": np.linspace(0, 2, 11)})
    whole = scene.compute()
    monkeypatch.setattr(scene_mod, "SLAB_CELLS", 50)
    xr.testing.assert_identical(scene.compute(progress=True).drop_attrs(), whole.drop_attrs())


# ------------------------------------------------------------------ dask -----
def assert_same_atlas(a: xr.Dataset, b: xr.Dataset):
    """Identical data, coordinates and attributes, except when each was created."""
    stamp = ("history", "date_created")
    xr.testing.assert_identical(a.drop_attrs(deep=False).assign_attrs(
        {k: v for k, v in a.attrs.items() if k not in stamp}),
        b.drop_attrs(deep=False).assign_attrs({k: v for k, v in b.attrs.items() if k not in stamp}))
    assert a.attrs.keys() == b.attrs.keys()


SCENE = dict(model="elliptic_pendulum",
             axes={"phi": np.linspace(-math.pi, math.pi, 61), "f": np.linspace(0, 6, 23),
                   "xdot": [-1.0, 0.0, 1.0]},
             layers=["n_solutions", "stagnation", "singular", "x_ddot_slide_pos_Npos"])


def test_dask_path_equals_eager():
    scene = phasemap.Scene(**SCENE)
    eager = scene.compute()
    lazy = scene.compute(chunks={"phi": 16, "f": 7})
    assert lazy.n_solutions.chunks == ((16, 16, 16, 13), (7, 7, 7, 2), (3,))
    assert_same_atlas(lazy.compute(), eager)
    with pytest.raises(ValueError, match="not an axis"):
        scene.compute(chunks={"omega": 3})
    with pytest.raises(ValueError, match=">= 1"):
        scene.compute(chunks=0)


def test_local_cluster_with_two_workers_equals_eager():
    distributed = pytest.importorskip("distributed")
    scene = phasemap.Scene(**SCENE)
    eager = scene.compute()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        remote = client.compute(scene.compute(chunks=16)).result(timeout=600)
    assert_same_atlas(remote, eager)


# ----------------------------------------------------------------- atlas -----
@pytest.mark.slow
@pytest.mark.parametrize("model", list(AXES))
def test_atlas_of_each_model_round_trips_and_passes_cfchecks(model, tmp_path):
    m = phasemap.MODELS[model]
    # the default axes with phi innermost: the kernel of test_grid_equals_classify_cell_by_cell
    # (every layer, phi innermost), so that this test compiles nothing of its own
    names = sorted(m.default_axes, key=lambda n: n == "phi")
    scene = phasemap.Scene(model, axes={n: np.linspace(*m.default_axes[n][:2], 9)
                                        for n in names},
                           layers=list(phasemap.layers_for(m)))
    assert_atlas_round_trip(scene.compute(), tmp_path, f"{model}.nc")


def test_summary_codes_match_the_enumerations():
    assert [int(s) for s in phasemap.Solvability] == [nx.N_NONE, nx.N_UNIQUE, nx.N_TWO,
                                                      nx.N_CONTINUUM, nx.N_THREE_OR_MORE]
