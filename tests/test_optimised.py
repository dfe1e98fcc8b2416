"""Every kernel family at numba's default optimisation, the code users run.

The suite compiles its kernels at LLVM -O1 with -O0 machine code (tests/conftest.py),
which keeps IEEE semantics and so checks the same numbers; CI also runs this module
alone at numba's defaults (``-m optimised``, see .ci/run), so that a miscompilation
or a numba bug that only the optimiser meets cannot ship unseen.  Each test checks an
independent fact (a closed form or a property of the physics), never a number phasemap
produced earlier:

* the grid kernels and the parallel driver: the ladder's rest zone phi <= 2 arctan f;
* the fate-map driver: the hinge pendulum rests only where l |sin phi| <= delta;
* the integrator (DOPRI5 and DOP853): the elliptic pendulum's stick-slip sequence, and
  the hinge pendulum's energy lost to the hinge friction between two velocity zeros;
* the phase-curve tracer: the hinge pendulum's first integral between reversals;
* the bifurcation tracer and its generated conditions: the Painleve rod's first paradox
  at f = 4/3, theta = arctan 2 (Genot & Brogliato 1999);
* a declared model's generated point functions: the rod's classification against the
  closed form of its slip coefficient.

The compiled flow of the full-coordinate motion (phasemap.motion.hybrid.flow) is not
here: its kernels take 37 s to build at numba's defaults, which this job's place at the
end of CI cannot afford (tests/test_flow.py checks it at the suite's optimisation).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import phasemap

pytestmark = pytest.mark.optimised


def test_grid_kernels_rest_zone():
    """Ladder at rest (omega = 0): rest exactly where phi <= 2 arctan f (the paper)."""
    phi = np.linspace(0.01, 1.5, 61)
    f = np.linspace(0.02, 1.0, 37)
    ds = phasemap.Scene("ladder", axes={"phi": phi, "f": f}, fixed={"omega": 0.0},
                        layers=["stagnation"]).compute()
    P, F = np.meshgrid(phi, f, indexing="ij")
    expected = P <= 2 * np.arctan(F)
    margin = np.abs(P - 2 * np.arctan(F)) > 1e-9
    assert np.array_equal(ds.stagnation.values.astype(bool)[margin], expected[margin])


def test_fate_map_rests_in_the_stagnation_zone():
    """Every hinge motion that ends at rest ends where l |sin phi| <= delta."""
    ds = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 15),
                                                "omega": np.linspace(-5, 5, 9)},
                        fixed={"delta": 0.2}, layers=["fate", "phi_rest"],
                        options={"t_end": 40.0}).compute()
    rest = ds.fate.values == int(phasemap.Event.REST)
    assert rest.mean() > 0.9
    assert np.all(np.abs(np.sin(ds.phi_rest.values[rest])) <= 0.2 + 1e-9)


@pytest.mark.parametrize("method", ["DOPRI5", "DOP853"])
def test_integrator_stick_slip_sequence(method):
    """The elliptic pendulum's slider sticks and slips twice within 3 s (guide example),
    and its velocity is exactly zero while it sticks."""
    ds = phasemap.simulate("elliptic_pendulum", t_end=3.0, phi=1.0, omega=0.0, xdot=1.0,
                           f=0.3, method=method, rtol=1e-10)
    kinds = [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]
    assert kinds == ["start", "stick", "slip", "stick", "slip", "horizon"]
    stick = phasemap.MODELS["elliptic_pendulum"].branches.index("stick")
    assert np.all(ds.xdot.values[ds.branch.values == stick] == 0.0)


def test_integrator_energy_balance_of_the_hinge():
    """Between two velocity zeros of the hinge pendulum, with delta = 0, energy is kept:
    the potential at both turning points is equal (|cos phi| the same)."""
    ds = phasemap.simulate("hinge_pendulum", phi=2.0, omega=0.0, delta=0.0, t_end=4.0,
                           rtol=1e-11, atol=1e-12)
    turns = ds.event_phi.values[[phasemap.Event(int(k)) == phasemap.Event.REVERSAL
                                 for k in ds.event_kind.values]]
    assert turns.size >= 2
    assert np.allclose(np.cos(turns), math.cos(2.0), atol=1e-8)


def test_phase_tracer_first_integral():
    """The hinge pendulum from phi = 2.5 at rest, delta = 0.1, stops after 5 reversals
    (guide example), and omega is exactly zero at every reversal."""
    c = phasemap.phase_curve("hinge_pendulum", phi=2.5, omega=0.0, delta=0.1)
    assert c.attrs["end_reason"] == "rest"
    assert int(c.attrs["n_reversals"]) == 5
    ends = c.stage_end_reason.values
    rev = ends == int(phasemap.Event.REVERSAL)
    assert rev.sum() == 5 and np.all(c.stage_end_omega.values[rev] == 0.0)


def test_bifurcation_tracer_first_paradox():
    """The Painleve rod's first paradox: f = 4/3 at theta = arctan 2."""
    t = phasemap.threshold("painleve_rod", "f", value=0, over={"theta": (0.1, 1.5)},
                           fixed={"xdot": -1.0, "omega": 0.0})
    assert t.value == pytest.approx(4 / 3, abs=1e-10)
    assert t.at["theta"] == pytest.approx(math.atan(2.0), abs=1e-8)


def test_declared_point_functions():
    """The rod sliding (xdot < 0) has no solution exactly where its slip coefficient
    1 - 3 cos theta (cos theta - f sin theta) ... is negative with the reaction
    admissible; away from the boundary the classification follows the closed form
    f > f*(theta) = (1 + 3 cos^2 theta) / (3 sin theta cos theta) (uniform rod)."""
    theta = np.linspace(0.2, 1.4, 25)
    f = np.linspace(0.0, 3.0, 31)
    ds = phasemap.Scene("painleve_rod", axes={"theta": theta, "f": f},
                        fixed={"xdot": -1.0, "omega": 0.0}, layers=["n_solutions"]).compute()
    T, F = np.meshgrid(theta, f, indexing="ij")
    fstar = (1 + 3 * np.cos(T) ** 2) / (3 * np.sin(T) * np.cos(T))
    far = np.abs(F - fstar) > 1e-6
    none = ds.n_solutions.values == 0
    assert np.array_equal(none[far], (F > fstar)[far])

