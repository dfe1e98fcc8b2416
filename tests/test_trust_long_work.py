"""Long and large work a user can trust (issue 10): one test per item at least.

Wrong results (chunked options, overflow, end labels), large work (size
checks, progress, Ctrl-C, output checks) and the smaller things a user trips
over (CLI, info, README numbers, offline cfchecks).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import xarray as xr

import phasemap
from phasemap.model import MAX_MAGNITUDE, MIN_POSITIVE
from phasemap.models import MODELS


# ---------------------------------------------------- 1. chunked fate maps --
def test_chunked_fate_map_uses_the_integrator_options():
    scene = phasemap.Scene("hinge_pendulum", axes={"phi": [2.5, 3.0]}, fixed={"omega": 0.0},
                           layers=["fate", "t_final", "n_reversals", "t_rest", "phi_rest"],
                           options={"t_end": 0.5, "rtol": 1e-9})
    eager = scene.compute()
    assert np.all(eager.t_final.values == 0.5)  # still swinging at t_end
    lazy = scene.compute(chunks=1).compute()
    xr.testing.assert_identical(lazy.drop_attrs(), eager.drop_attrs())


# --------------------------------------------------------- 2. overflow -----
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


@pytest.mark.parametrize("model", sorted(MODELS))
def test_no_overflow_is_ever_counted_as_a_solution(model):
    """At random states with every value anywhere in its allowed range (1e-30 to 1e30),
    each admissible branch has finite accelerations and reactions."""
    m = MODELS[model]
    rng = np.random.default_rng(10)
    checked = 0
    for _ in range(1500):
        values = {}
        for var in m.state + m.params:
            kind = rng.integers(4)
            mag = 10.0 ** rng.uniform(-30, 30)
            x = 0.0 if kind == 0 else (MAX_MAGNITUDE if kind == 1 else mag)
            if var.lower >= 0:
                x = max(x, MIN_POSITIVE) if var.lower_open else x
                if var.upper < math.inf:
                    x = min(x, var.upper)
            elif rng.integers(2):
                x = -x
            values[var.name] = x
        if model == "wheel":
            values["l"] = min(values["l"], values["r"])
        c = phasemap.classify(m, **values)
        for b in c.branches:
            if b.status != phasemap.BranchStatus.ADMISSIBLE:
                continue  # a continuum has no values
            numbers = [*b.accelerations.values(), *b.reactions.values()]
            assert all(math.isfinite(x) for x in numbers), (repr(values), b)
            checked += 1
    assert checked > 500


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
