"""simulate()'s Dataset: branches at requested times, CF compliance, and the layer registry."""

from __future__ import annotations

import numpy as np

import phasemap
from conftest import assert_atlas_round_trip


def test_branch_at_requested_times_including_t_end():
    kw = dict(phi=1.0, omega=0.0, xdot=0.0, f=0.3)
    dense = phasemap.simulate("elliptic_pendulum", 4.0, t_eval=np.linspace(0, 4, 401), **kw)
    steps = phasemap.simulate("elliptic_pendulum", 4.0, **kw)
    assert steps.attrs["end_reason"] == "horizon"
    assert int(dense.branch[-1]) == int(steps.branch[-1]) >= 0  # not the horizon's "none"
    # between events the branch is the one the events table says
    ev_t, ev_b = steps.event_t.values, steps.event_branch.values
    for t, b in zip(dense.t.values[1:-1], dense.branch.values[1:-1]):
        k = np.searchsorted(ev_t, t, side="right") - 1
        if not np.isclose(t, ev_t[k]):
            assert b == ev_b[k]
    stick = dense.branch == phasemap.MODELS["elliptic_pendulum"].stick_branch
    assert int(stick.sum()) > 0 and bool((dense.xdot.where(stick, drop=True) == 0.0).all())


def test_trajectory_is_a_cf_netcdf_that_round_trips(tmp_path):
    ds = phasemap.simulate("wheel", 20.0, phi=2.0, omega=0.0, delta=0.02)
    assert_atlas_round_trip(ds, tmp_path, "wheel.nc")


def test_layers_for_takes_a_name_or_a_model():
    by_name = phasemap.layers_for("hinge_pendulum")
    assert by_name == phasemap.layers_for(phasemap.MODELS["hinge_pendulum"])
    assert {"fate", "phi_rest", "n_reversals", "t_rest", "t_final"} <= set(by_name)
    assert "x_rest" not in phasemap.layers_for("elliptic_pendulum")  # its stick is not rest


def test_the_trajectory_dataset_is_what_xarray_would_build():
    import xarray as xr

    ds = phasemap.simulate("hinge_pendulum", 10.0, phi=1.0, omega=0.0, delta=0.1)
    # built directly, it is what xarray's own constructor (merge, default indexes) builds
    merged = xr.Dataset({n: ds[n].variable for n in ds.data_vars},
                        {n: ds[n].variable for n in ds.coords}, ds.attrs)
    xr.testing.assert_identical(ds, merged)
    assert list(ds.xindexes) == list(merged.xindexes) == ["t"]
    assert ds.xindexes["t"].equals(merged.xindexes["t"])
    assert float(ds.phi.sel(t=0.0)) == 1.0  # the index works
