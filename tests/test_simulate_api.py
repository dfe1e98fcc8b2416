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


def _one_motion(ds, start):
    """The motion ``start`` of a batch Dataset, trimmed of its padding."""
    b = ds.isel(start=start)
    k, e = int(b.n_points), int(b.n_events)
    return b, k, e


def test_a_batch_of_starts_is_one_call_identical_to_a_call_per_start():
    import pytest

    kw = dict(omega=0.0, xdot=0.0, f=0.3)
    phis = [0.2, 1.0, 1.7]
    for t_eval in (None, np.linspace(0.0, 3.0, 31)):
        batch = phasemap.simulate("elliptic_pendulum", 3.0, phi=phis, t_eval=t_eval, **kw)
        assert batch.sizes["start"] == 3
        for i, phi in enumerate(phis):
            one = phasemap.simulate("elliptic_pendulum", 3.0, phi=phi, t_eval=t_eval, **kw)
            b, k, e = _one_motion(batch, i)
            assert float(b.initial_phi) == phi
            assert phasemap.Event(int(b.end_reason)).name.lower() == one.attrs["end_reason"]
            assert int(b.n_reversals) == int(one.attrs["n_reversals"])
            assert int(b.n_steps) == int(one.attrs["n_steps"])
            assert k == one.sizes["t"] and e == one.sizes["event"]
            np.testing.assert_array_equal(b.t.values[:k], one.t.values)
            for name in ("phi", "omega", "x", "xdot", "branch"):
                np.testing.assert_array_equal(b[name].values[:k], one[name].values)
            for name in ("event_t", "event_kind", "event_branch", "event_phi", "event_xdot"):
                np.testing.assert_array_equal(b[name].values[:e], one[name].values)
            assert np.all(np.isnan(b.event_t.values[e:]))
    with pytest.raises(ValueError, match="one length"):
        phasemap.simulate("elliptic_pendulum", 1.0, phi=[0.1, 0.2], omega=[0.0], xdot=0.0)
    with pytest.raises(ValueError, match="f must be a scalar"):
        phasemap.simulate("elliptic_pendulum", 1.0, phi=[0.1, 0.2], omega=0.0, xdot=0.0,
                          f=[0.1, 0.2])
    with pytest.raises(ValueError, match="phi"):
        phasemap.simulate("elliptic_pendulum", 1.0, phi=[0.1, np.nan], xdot=0.0)


def test_event_codes_are_append_only_and_each_says_whether_it_ends_a_motion():
    """The codes atlases and fate maps store keep their meaning (issue 38: events that
    continue a motion will be added after them), and which events end a motion is named
    event by event, not read from the order of the codes."""
    from phasemap.core import events

    stored = ["start", "reversal", "stick", "slip", "switch", "rest", "contact_lost",
              "no_solution", "indeterminate", "continuum", "singular", "horizon",
              "max_events", "step_failure", "stiff", "left_domain", "max_steps"]
    assert [e.name.lower() for e in phasemap.Event][:len(stored)] == stored
    assert [int(e) for e in phasemap.Event][:len(stored)] == list(range(len(stored)))
    continuing = {"start", "reversal", "stick", "slip", "switch", "iwc", "liftoff", "impact",
                  "recontact", "zeno", "jam"}
    assert {e.name.lower() for e in phasemap.Event if not e.terminal} == continuing
    assert events.FATE_VALUES == tuple(sorted(events.FATES))
