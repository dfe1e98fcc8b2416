"""Dask-backed scenes: task names that hold everything deciding the values, and a cluster.

Two declaration files may declare one system name with different physics; the
same scene may be chunked two ways.  Their dask arrays must never share task
names, or dask hands one result to the other (or refuses to combine them).
"""

from __future__ import annotations

import textwrap

import dask
import numpy as np
import pytest
import xarray as xr

import phasemap

ROD = '''
import sympy as sp
from phasemap.declare import Body, Coordinate, Parameter, PointContact, Rate, System

f = Parameter("f", "1", "friction coefficient at the floor", default=0.5, lower=0.0)
l = Parameter("l", "m", "half length of the rod", default=1.0, lower=0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration", default=9.81, lower=0.0)
m = Parameter("m", "kg", "mass of the rod", default=1.0, lower=0.0, lower_open=True)
theta = Coordinate("theta", "rad", "angle of the rod to the floor", default=1.0, lower=0.0,
                   upper=float(sp.pi), rate=Rate("omega", "rad s-1", "angular velocity",
                                                 scale=sp.sqrt(g / l)))
x = Coordinate("x", "m", "position of end A",
               rate=Rate("xdot", "m s-1", "velocity of end A", scale=sp.sqrt(g * l)))
y = Coordinate("y", "m", "height of end A")

SYSTEM = System(
    "my_rod", "A rod with one end on a rough floor", "Painleve (1895)",
    coordinates=(theta, x, y), parameters=(f, l, g, m),
    bodies=(Body(m, (x + l * sp.cos(theta), y + l * sp.sin(theta)),
                 inertia=INERTIA, angle=theta),),
    potential=m * g * (y + l * sp.sin(theta)),
    contacts=(PointContact("A", point=(x, y), normal=(0, 1), friction=f),),
)
'''

AXES = {"theta": np.linspace(0.05, 3.1, 40), "f": np.linspace(0.0, 3.0, 30)}
FIXED = {"omega": 0.0, "xdot": -1.0}


@pytest.fixture(scope="module")
def rods(tmp_path_factory):
    """Two files that declare ``my_rod``: a uniform rod (m l^2/3) and a concentrated one."""
    scenes = []
    for folder, inertia in (("uniform", "m * l**2 / 3"), ("concentrated", "m * l**2 / 30")):
        path = tmp_path_factory.mktemp(folder) / "rod.py"
        path.write_text(textwrap.dedent(ROD).replace("INERTIA", inertia))
        scenes.append(phasemap.Scene(str(path), axes=AXES, fixed=FIXED))
    a, b = scenes
    assert a.model.name == b.model.name == "my_rod"
    eager = [s.compute() for s in scenes]
    assert int((eager[0].n_solutions != eager[1].n_solutions).sum()) > 100   # they differ
    return scenes, eager


def test_same_named_systems_from_two_files_computed_together_keep_their_own_values(rods):
    (a, b), (ea, eb) = rods
    la, lb = dask.compute(a.compute(chunks=10).n_solutions, b.compute(chunks=10).n_solutions)
    np.testing.assert_array_equal(la.values, ea.n_solutions.values)
    np.testing.assert_array_equal(lb.values, eb.n_solutions.values)


def test_one_scene_chunked_two_ways_combines():
    h = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 30),
                                                "delta": np.linspace(0, 1.5, 25)})
    total = (h.compute(chunks=10).n_solutions + h.compute(chunks=7).n_solutions).compute()
    np.testing.assert_array_equal(total.values, 2 * h.compute().n_solutions.values)
    assert h.compute(chunks=10).n_solutions.data.name != h.compute(chunks=7).n_solutions.data.name
    assert h.compute(chunks=10).n_solutions.data.name == h.compute(chunks=10).n_solutions.data.name


def test_a_local_cluster_gives_the_eager_results(rods):
    """Two worker processes: the same-named user systems (maps) and a fate map with
    integrator options, each identical to the eager result."""
    distributed = pytest.importorskip("distributed")
    (a, b), (ea, eb) = rods
    fates = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 12),
                                                    "omega": [-2.0, 0.0, 3.0]},
                           layers=["fate", "n_reversals", "t_final", "phi_rest"],
                           options={"t_end": 8.0, "method": "DOP853", "rtol": 1e-8,
                                    "max_events": 6, "max_steps": 20000})
    ef = fates.compute()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        held = client.compute(a.compute(chunks=10))   # a's future still held ...
        la, lb, lf = client.gather(client.compute([a.compute(chunks=10),
                                                   b.compute(chunks=10),
                                                   fates.compute(chunks={"phi": 5})]))
        held.result()
    for lazy, eager in ((la, ea), (lb, eb), (lf, ef)):
        xr.testing.assert_identical(lazy.drop_attrs(), eager.drop_attrs())


def test_chunked_fate_map_uses_the_integrator_options():
    scene = phasemap.Scene("hinge_pendulum", axes={"phi": [2.5, 3.0]}, fixed={"omega": 0.0},
                           layers=["fate", "t_final", "n_reversals", "t_rest", "phi_rest"],
                           options={"t_end": 0.5, "rtol": 1e-9})
    eager = scene.compute()
    assert np.all(eager.t_final.values == 0.5)  # still swinging at t_end
    lazy = scene.compute(chunks=1).compute()
    xr.testing.assert_identical(lazy.drop_attrs(), eager.drop_attrs())


def test_a_large_lazy_atlas_builds_no_task_per_block():
    scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 1_000_000),
                                           "f": np.linspace(0, 3, 1_000_000)})
    lazy = scene.compute(chunks={"phi": 16, "f": 1_000_000})   # 62500 blocks
    graph = lazy.n_solutions.data.dask
    assert lazy.n_solutions.data.npartitions == 62_500
    assert not any(layer.is_materialized() for layer in graph.layers.values())
