"""How a motion ends (issue 10): each end label says what happened.

The other tests of issue 10 live beside the module each one tests (the command
line in test_cli.py, chunked and lazy scenes in test_scene_dask.py, overflow in
test_args.py and test_ties_symmetry_input.py, progress in test_scene_long_work.py,
the README's numbers in test_readme_claims.py).
"""

from __future__ import annotations

import math

import pytest

import phasemap


# ------------------------------------------------------- 3. end labels -----
def test_ladder_lying_flat_leaves_the_domain_and_says_which_edge():
    ds = phasemap.simulate("ladder", t_end=10.0, phi=1.4, omega=1.0, f=1.0)
    assert ds.attrs["end_reason"] == "left_domain"
    assert float(ds.event_t[-1]) < 1.0 and float(ds.event_phi[-1]) == math.pi / 2
    assert "lies flat on the floor" in ds.attrs["end_message"]
    curve = phasemap.phase_curve("ladder", phi=1.4, omega=1.0, f=1.0)
    assert curve.attrs["end_reason"] == "left_domain"
    assert "lies flat" in curve.attrs["end_message"]
    fates = phasemap.Scene("ladder", axes={"phi": [1.4]}, fixed={"omega": 1.0, "f": 1.0},
                           layers=["fate"]).compute()
    assert int(fates.fate[0]) == phasemap.Event.LEFT_DOMAIN
    assert "left_domain" in fates.fate.attrs["flag_meanings"].split()


@pytest.mark.parametrize("excess", [1e-9, 1e-3])
def test_hinge_leaving_the_reaction_free_curve_has_no_solution(excess):
    """delta just above l, started exactly on l omega^2 + g cos phi = 0: the unique free
    motion leaves the curve at once into states with no solution."""
    phi, g = 2.0, 9.81
    omega = math.sqrt(-g * math.cos(phi))
    assert phasemap.classify("hinge_pendulum", phi=phi, omega=omega, delta=1 + excess
                             ).n_solutions == 1
    ds = phasemap.simulate("hinge_pendulum", t_end=1.0, phi=phi, omega=omega,
                           delta=1 + excess)
    assert ds.attrs["end_reason"] == "no_solution"
    assert float(ds.event_t[-1]) < 1e-6


def test_running_out_of_steps_has_its_own_name():
    ds = phasemap.simulate("hinge_pendulum", t_end=100.0, max_steps=50, phi=2.0, delta=0.01)
    assert ds.attrs["end_reason"] == "max_steps" and int(ds.attrs["n_steps"]) == 50
    events = phasemap.simulate("hinge_pendulum", t_end=100.0, max_events=2, phi=2.0,
                               delta=0.01)
    assert events.attrs["end_reason"] == "max_events"
