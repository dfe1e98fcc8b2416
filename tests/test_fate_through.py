"""Fate maps through contact changes (issue 38): ``options={"through_contacts": True}``
follows the cells whose reduced motion ends where a contact changes, each exactly as
``phasemap.simulate`` moves it from its start."""

import numpy as np
import pytest

import phasemap
from phasemap.core import events as ev
from phasemap.core.args import WrongType

AXES = {"theta": np.linspace(0.3, 1.3, 9), "xdot": np.linspace(-4.0, -0.5, 7)}
FIXED = {"omega": 2.0, "f": 2.0}
LAYERS = ["fate", "t_final", "n_reversals", "t_rest"]


@pytest.fixture(scope="module")
def rod_maps():
    reduced = phasemap.Scene("painleve_rod", axes=AXES, fixed=FIXED, layers=LAYERS,
                             options={"t_end": 1.0}).compute()
    scene = phasemap.Scene("painleve_rod", axes=AXES, fixed=FIXED, layers=LAYERS,
                           options={"t_end": 1.0, "through_contacts": True})
    return reduced, scene, scene.compute()


def test_cells_that_meet_a_contact_change_are_followed_as_simulate_follows_them(rod_maps):
    reduced, scene, through = rod_maps
    before = reduced.fate.values
    goes_on = np.isin(before, [ev.CONTACT_LOST, ev.NO_SOLUTION, ev.INDETERMINATE,
                               ev.SINGULAR])
    assert goes_on.sum() >= 20            # the rod at f = 2: impacts without collision
    # no cell is left at a contact change, and every other cell is the compiled one's
    after = through.fate.values
    assert not np.isin(after[goes_on], [ev.CONTACT_LOST, ev.INDETERMINATE]).any()
    for name in LAYERS:
        a, b = reduced[name].values[~goes_on], through[name].values[~goes_on]
        assert np.array_equal(a, b, equal_nan=True)
    # each followed cell is the motion simulate gives from its start
    for i, j in list(zip(*np.nonzero(goes_on)))[::5]:
        ds = phasemap.simulate("painleve_rod", 1.0, rtol=1e-6, atol=1e-6,
                               theta=AXES["theta"][i], xdot=AXES["xdot"][j], **FIXED)
        assert int(after[i, j]) == int(ev.Event[ds.attrs["end_reason"].upper()])
        assert float(through.t_final[i, j]) == float(ds.event_t[-1])
        assert int(through.n_reversals[i, j]) == int(
            np.count_nonzero(ds.event_kind.values == ev.REVERSAL))
    rest = after == ev.REST
    assert np.array_equal(np.isnan(through.t_rest.values), ~rest)


def test_a_chunked_fate_map_through_contact_changes_equals_the_eager_one(rod_maps):
    _, scene, through = rod_maps
    lazy = scene.compute(chunks=4).compute()
    for name in LAYERS:
        assert np.array_equal(lazy[name].values, through[name].values, equal_nan=True)


def test_the_spec_keeps_the_contact_settings(rod_maps, tmp_path):
    _, scene, through = rod_maps
    spec = scene.spec()
    assert spec["options"]["through_contacts"] is True
    assert spec["options"]["impact_law"] == "stronge"
    again = phasemap.Scene.from_spec(spec)
    assert again.contact == scene.contact and again.spec() == spec
    path = tmp_path / "rod.nc"
    through.to_netcdf(path)
    import json

    import xarray as xr

    with xr.open_dataset(path) as ds:
        assert json.loads(ds.attrs["phasemap_scene"])["options"]["through_contacts"] is True
    plain = phasemap.Scene("painleve_rod", axes=AXES, fixed=FIXED, layers=LAYERS)
    assert "through_contacts" not in plain.spec()["options"]


@pytest.mark.parametrize("model, options, error, message", [
    ("painleve_rod", {"through_contacts": "yes"}, WrongType, "True or False"),
    ("painleve_rod", {"impact_law": "newton"}, ValueError, "through_contacts=True"),
    ("painleve_rod", {"through_contacts": True, "impact_law": "bounce"}, ValueError,
     "impact_law must be one of"),
    ("painleve_rod", {"through_contacts": True, "restitution": 2.0}, ValueError,
     "restitution must be in"),
    ("hinge_pendulum", {"through_contacts": True}, ValueError, "needs a declared system"),
    ("painleve_rod", {"through_contact": True}, ValueError, "through_contacts"),
])
def test_contact_settings_of_a_fate_map_are_checked(model, options, error, message):
    with pytest.raises(error, match=message):
        phasemap.Scene(model, axes={"omega": [0.0, 1.0]}, layers=["fate"], options=options)


def test_the_cli_follows_a_fate_map_through_contact_changes(tmp_path, capsys):
    from phasemap.cli import main

    out = tmp_path / "rod.nc"
    assert main(["atlas", "painleve_rod", "--axis", "theta=0.3:1.3:5", "--axis",
                 "xdot=-4:-0.5:4", "--set", "omega=2", "--set", "f=2", "--layers", "fate",
                 "--option", "t_end=1", "--option", "through_contacts=true", "-o",
                 str(out)]) == 0
    import xarray as xr

    with xr.open_dataset(out) as ds:
        assert not np.isin(ds.fate.values, [ev.CONTACT_LOST, ev.NO_SOLUTION]).any()
    assert main(["atlas", "painleve_rod", "--axis", "theta=0.3:1.3:5", "--layers", "fate",
                 "--option", "through_contacts=maybe", "-o", str(tmp_path / "x.nc")]) != 0
    assert "through_contacts must be true or false" in capsys.readouterr().err


def test_a_cell_that_cannot_be_followed_keeps_its_reduced_end_and_says_so(monkeypatch):
    """One cell's failure does not lose the map: it keeps the compiled integrator's end,
    and a warning counts the cells and names the first."""
    from phasemap.motion import simulate as sim

    real = sim.motion_end
    calls = []

    def flaky(model, t_end, **kw):
        calls.append(kw)
        if len(calls) == 2:
            raise ValueError("no such motion")
        return real(model, t_end, **kw)

    monkeypatch.setattr(sim, "motion_end", flaky)
    axes = AXES
    reduced = phasemap.Scene("painleve_rod", axes=axes, fixed=FIXED, layers=["fate"],
                             options={"t_end": 1.0}).compute()
    with pytest.warns(RuntimeWarning, match="1 of .* cells could not be followed.*no such"):
        through = phasemap.Scene("painleve_rod", axes=axes, fixed=FIXED, layers=["fate"],
                                 options={"t_end": 1.0, "through_contacts": True}).compute()
    kept = [(i, j) for i, j in zip(*np.nonzero(np.isin(reduced.fate.values, [
        ev.CONTACT_LOST, ev.NO_SOLUTION, ev.INDETERMINATE, ev.SINGULAR])))][1]
    assert int(through.fate[kept]) == int(reduced.fate[kept])
    assert len(calls) >= 3


@pytest.mark.parametrize("model, axes, t_end", [
    ("wheel", {"phi": (-np.pi, np.pi), "omega": (-6.0, 6.0)}, 3.0),
    ("painleve_rod", {"theta": (0.3, 1.3), "xdot": (-4.0, -0.5), "omega": (2.0, 2.0),
                      "f": (2.0, 2.0)}, 1.0),
    ("ladder", {"phi": (0.05, 1.5), "omega": (-3.0, 3.0)}, 2.0)])
def test_a_motions_end_without_its_dataset_is_the_datasets(model, axes, t_end):
    """What a followed cell keeps (motion_end: the fate, reversals, last event's time and
    state, read from the records) is what the Dataset of simulate gives, exactly, on
    random starts: motions that stay on their reduced model and motions that go on in
    full coordinates."""
    from phasemap.motion.simulate import end_of, motion_end

    m = phasemap.get_model(model)
    names = [c[0] for c in m.dynamics.coordinates]
    rng = np.random.default_rng(5)
    kinds = set()
    for _ in range(16):
        vals = {k: float(rng.uniform(*b)) for k, b in axes.items()}
        try:
            ds = phasemap.simulate(model, t_end, t_eval=[t_end], **vals)
        except ValueError:
            with pytest.raises(ValueError):
                motion_end(model, t_end, t_eval=[t_end], **vals)
            continue
        kinds.add(ds.attrs.get("phasemap_coordinates", "reduced"))
        want, got = end_of(ds, names), motion_end(model, t_end, t_eval=[t_end], **vals)
        assert (got.fate, got.n_reversals, got.t) == (want.fate, want.n_reversals, want.t)
        assert {k: got.state[k] for k in names} == want.state
    assert kinds == {"reduced", "full"}
