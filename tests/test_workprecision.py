"""phasemap.motion.workprecision: dimensionless errors with stated scales, the tracer swept
over tolerances, and the same numbers from the same inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

import phasemap
import phasemap.motion.workprecision as wp
from phasemap.systems.hinge_pendulum import weightless_motion

TOLS = (1e-5, 1e-8)


@pytest.fixture(scope="module")
def weightless_rows():
    return wp.work_precision("hinge_weightless", tolerances=TOLS,
                             methods=["phasemap", "phase_curve"], repeats=1, min_time=0.0)


def test_scales_are_the_peaks_of_the_exact_motion(weightless_rows):
    p = wp.PROBLEMS["hinge_weightless"]
    k = 0.3 / math.sqrt(1 - 0.3 ** 2)
    (phi, phi_hat, phi_units, _), (omega, omega_hat, omega_units, _) = \
        weightless_rows[0]["scales"]
    # phi grows monotonically to its value at t_end, omega decays from omega0 (36)
    assert (phi, phi_units, omega, omega_units) == ("phi", "rad", "omega", "rad s-1")
    assert phi_hat == pytest.approx(math.log1p(k * 5.0 * p.t_end) / k, rel=1e-12)
    assert omega_hat == 5.0


def test_scaled_errors_are_the_component_errors_over_their_scales(weightless_rows):
    """Recomputed from simulate (the same kernel) and the closed form (36)."""
    p = wp.PROBLEMS["hinge_weightless"]
    (_, phi_hat, _, _), (_, omega_hat, _, _) = weightless_rows[0]["scales"]
    for row in (r for r in weightless_rows if r["method"] == "phasemap"):
        ds = phasemap.simulate("hinge_pendulum", p.t_end, rtol=row["tol"], t_eval=p.t_save,
                               **p.values)
        phi, omega = weightless_motion(ds.t.values, 0.0, 5.0, 0.3, 1.0)
        d_phi, d_omega = ds.phi.values - phi, ds.omega.values - omega
        l2 = math.sqrt(np.mean(np.r_[(d_phi / phi_hat) ** 2, (d_omega / omega_hat) ** 2]))
        assert row["error_scaled_l2"] == pytest.approx(l2, rel=1e-9)
        assert row["error_l2"] == pytest.approx(math.sqrt(np.mean(np.r_[d_phi ** 2,
                                                                       d_omega ** 2])),
                                                rel=1e-9)
        end = np.abs([float(ds.event_phi[-1]) - phi[-1], float(ds.event_omega[-1]) - omega[-1]])
        assert row["error_scaled_final"] == pytest.approx(
            max(end[0] / phi_hat, end[1] / omega_hat), rel=1e-9)
        assert row["error_scaled_final"] < row["error_final"]  # both scales exceed 1


def test_the_tracer_runs_at_every_tolerance(weightless_rows):
    tracer = [r for r in weightless_rows if r["method"] == "phase_curve"]
    assert sorted(r["tol"] for r in tracer) == sorted(TOLS)
    for r in tracer:
        # the weightless omega(phi) is an exponential the tracer follows to rounding
        assert 0.0 <= r["error_scaled_l2"] < 1e-12 and r["fate"] == "horizon"
        assert r["seconds"] > 0


def test_same_inputs_give_the_same_numbers(weightless_rows):
    """The errors a figure, its table and its claims state come from one sweep and do
    not depend on the machine's load or a cold cache (the JIT warms outside the run
    the budget judges)."""
    again = wp.work_precision("hinge_weightless", tolerances=TOLS,
                              methods=["phasemap", "phase_curve"], repeats=1, min_time=0.0)
    keys = ("method", "tol", "error_final", "error_l2", "error_scaled_final",
            "error_scaled_l2", "fate", "n_reversals", "skipped", "scales")
    assert [[r[k] for k in keys] for r in again] == [[r[k] for k in keys]
                                                     for r in weightless_rows]


def test_the_floor_a_report_compares_with_is_in_the_unit_of_its_error():
    """A tight reference's floor in SI units (a max over rad and rad s-1) must not cut
    scaled errors: the report reads floor_scaled for them."""
    rows = [dict(system="s", model="m", method=m, tol=tol, skipped=False, same_fate=True,
                 seconds=1e-3 / tol ** 0.1, error_final=tol * 40.0, error_scaled_final=tol,
                 floor=1e-8, floor_scaled=1e-10)
            for m in ("phasemap", "RK45") for tol in (1e-4, 1e-6, 1e-8)]
    levels = (1e-5, 1e-8)
    scaled = wp.report(rows, levels=levels, error="error_scaled_final", method="phasemap")
    si = wp.report(rows, levels=levels, error="error_final", method="phasemap")
    # 1e-8 is above ten times the scaled floor (1e-9) and below ten times the SI one (1e-7)
    assert scaled.splitlines()[-1].count("(floor)") == 0 and "floor 1e-10" in scaled
    assert si.splitlines()[-1].count("(floor)") == 1 and "floor 1e-08" in si
