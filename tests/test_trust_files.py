"""Opening a data file never runs code (issue 28).

An atlas is data: nothing read from its metadata is imported or executed, a
built-in name resolves to a built-in model only, a declared system's atlas is
recomputed only from the declaration it records, and malformed metadata gets
one clear ValueError or TypeError, never a traceback from deep inside.
"""

from __future__ import annotations

import json
import os
import pathlib
import random
import shutil
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

import phasemap
from phasemap.atlas.dataset import dataset_kind, declaration_hash, vocabulary
from phasemap.atlas.read import describe_atlas

ROOT = pathlib.Path(__file__).resolve().parents[1]
OWN_SYSTEM = ROOT / "docs" / "examples" / "own_system.py"

EVIL = """
import pathlib
with open(pathlib.Path(__file__).with_name("MARKER"), "a") as fh:
    fh.write("ran\\n")
"""

#: Every Python entry point that takes a dataset, each on the atlas in the current folder.
ENTRY_POINTS = """
import json, sys, xarray as xr, phasemap, phasemap.plot
from phasemap.atlas.dataset import vocabulary
ds = xr.open_dataset("shared.nc").load()
calls = {
    "accessor plot": lambda: ds.phasemap.plot(),
    "phasemap.plot.plot": lambda: phasemap.plot.plot(ds),
    "accessor model": lambda: ds.phasemap.model,
    "vocabulary": lambda: vocabulary(ds),
    "Scene.from_spec": lambda: phasemap.Scene.from_spec(json.loads(ds.attrs["phasemap_scene"])),
    "describe_atlas": lambda: phasemap.describe_atlas("shared.nc"),
}
for name, call in calls.items():
    try:
        call()
        print(name, "| ok")
    except (ValueError, TypeError) as e:
        assert "\\n" not in str(e), (name, str(e))
        print(name, "| refused:", e)
"""


def env() -> dict:
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT),
                                                        os.environ.get("PYTHONPATH", "")]),
                MPLBACKEND="Agg")


def run(args, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env(), capture_output=True,
                          text=True, timeout=600)


@pytest.fixture(scope="module")
def ladder_map():
    return phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 6),
                                          "f": np.linspace(0, 1, 5)},
                          fixed={"omega": 0.0}).compute()


@pytest.mark.parametrize("keep_words", [True, False])
def test_an_atlas_naming_a_python_file_never_runs_it(ladder_map, tmp_path, keep_words):
    """The reproducer: ``evil.py`` beside an atlas whose model is ``evil.py``, opened in
    that folder through every entry point (with and without the atlas's own words, so
    that a figure would have to look the model up)."""
    ds = ladder_map.copy()
    ds.attrs["phasemap_model"] = "evil.py"
    spec = json.loads(ds.attrs["phasemap_scene"])
    ds.attrs["phasemap_scene"] = json.dumps({**spec, "model": "evil.py"})
    if not keep_words:
        del ds.attrs["phasemap_variables"]
    phasemap.write_atlas(ds, tmp_path / "shared.nc")
    (tmp_path / "evil.py").write_text(EVIL)
    done = run(["-c", ENTRY_POINTS], tmp_path)
    assert done.returncode == 0, done.stderr
    said = dict(line.split(" | ", 1) for line in done.stdout.splitlines())
    assert "is not a built-in model" in said["Scene.from_spec"]
    assert "is not a built-in model" in said["accessor model"]
    assert said["accessor plot"] == "ok" and said["describe_atlas"] == "ok"
    for command in (["plot", "shared.nc"], ["info", "shared.nc"]):
        done = run(["-m", "phasemap.cli", *command], tmp_path)
        assert done.returncode == 0, done.stderr
    assert not (tmp_path / "MARKER").exists()


# ----------------------------------------------------------------- declared systems ---
COMPUTE = """
import json, sys, numpy as np, phasemap
scene = phasemap.Scene(sys.argv[1], axes={"theta": np.linspace(0.05, 1.5, 12),
                       "f": np.linspace(0.0, 2.0, 8)}, fixed={"xdot": -1.0, "omega": 0.0})
phasemap.write_atlas(scene.compute(), sys.argv[2])
"""

PLOT_FRESH = """
import sys, xarray as xr, phasemap
ds = xr.open_dataset(sys.argv[1]).load()
fig = ds.phasemap.plot()
ax = fig.axes[0]
print(ax.get_xlabel())
print(ax.get_legend().get_title().get_text().replace("\\n", " "))
loaded = [m for m in sys.modules if "_declared_" in m or "own_system" in m]  # generated ones
print("modules:", loaded)
"""


def test_a_declared_atlas_plots_with_its_symbols_where_the_declaration_was_never_seen(
        tmp_path):
    declaration = tmp_path / "made" / "own_system.py"
    declaration.parent.mkdir()
    shutil.copy(OWN_SYSTEM, declaration)
    done = run(["-c", COMPUTE, str(declaration), str(tmp_path / "rod.nc")], tmp_path)
    assert done.returncode == 0, done.stderr
    shutil.rmtree(declaration.parent)
    done = run(["-c", PLOT_FRESH, str(tmp_path / "rod.nc")], tmp_path)
    assert done.returncode == 0, done.stderr
    xlabel, heading, modules = done.stdout.splitlines()
    assert xlabel == r"$\theta$ (rad)"
    assert r"$\omega$ = 0 rad s$^{-1}$" in heading and r"$\dot x$ = −1 m s$^{-1}$" in heading
    assert modules == "modules: []"
    with xr.open_dataset(tmp_path / "rod.nc") as ds:
        assert len(ds.attrs["phasemap_declaration_sha256"]) == 64
        words = vocabulary(ds)
    assert words.variables["theta"][:2] == (r"\theta", "rad")
    assert words.coefficient is not None and words.branches


def test_a_builtin_atlas_plots_from_its_own_words(ladder_map):
    """Labels come from the atlas, not from the model's code: an atlas of a model this
    phasemap does not know (another version's) is labelled all the same."""
    ds = ladder_map.copy()
    ds.attrs["phasemap_model"] = "ladder_of_another_version"
    fig = ds.phasemap.plot()
    assert fig.axes[0].get_xlabel() == r"$\varphi$ (rad)"
    assert vocabulary(ds).edges["phi"][1] == "the bar lies flat on the floor"
    with pytest.raises(ValueError, match="is not a built-in model"):
        _ = ds.phasemap.model


def test_a_declared_atlas_is_recomputed_only_from_its_own_declaration(tmp_path):
    declaration = tmp_path / "own_system.py"
    shutil.copy(OWN_SYSTEM, declaration)
    model = phasemap.get_model(declaration)
    scene = phasemap.Scene(model, axes={"theta": np.linspace(0.05, 1.5, 5)},
                           fixed={"f": 0.5, "xdot": -1.0, "omega": 0.0})
    spec = json.loads(json.dumps(scene.spec()))
    assert spec["declaration_sha256"] == declaration_hash(model)
    with pytest.raises(ValueError, match="not a built-in model; pass the declaration"):
        phasemap.Scene.from_spec(spec)
    again = phasemap.Scene.from_spec(spec, model=str(declaration))
    assert again.spec() == scene.spec()
    # the same system, one inertia changed: refused, in one line saying what differs
    text = declaration.read_text()
    changed = tmp_path / "other" / "own_system.py"
    changed.parent.mkdir()
    assert "inertia=m * l**2 / 3," in text
    changed.write_text(text.replace("inertia=m * l**2 / 3,", "inertia=m * l**2 / 30,"))
    with pytest.raises(ValueError) as err:   # the attribute's JSON text, as a file holds it
        phasemap.Scene.from_spec(json.dumps(spec), model=str(changed))
    message = str(err.value)
    assert "\n" not in message and "declared otherwise" in message
    assert spec["declaration_sha256"][:12] in message and "names agree" in message
    # a spec that names a built-in but records another declaration of it
    ladder = phasemap.Scene("ladder", axes={"phi": [0.1, 0.2]}, fixed={"f": 0.5}).spec()
    assert phasemap.Scene.from_spec(ladder).spec() == ladder
    with pytest.raises(ValueError, match="declared otherwise"):
        phasemap.Scene.from_spec({**ladder, "declaration_sha256": "0" * 64})
    with pytest.raises(ValueError, match="the spec is of 'ladder'"):
        phasemap.Scene.from_spec(ladder, model=str(declaration))


# ----------------------------------------------------------------- untrusted values ---
def test_a_spec_is_checked_before_anything_it_names_is_made(monkeypatch):
    good = {"model": "ladder", "axes": {"phi": {"start": 0.0, "stop": 1.0, "count": 3}},
            "fixed": {"f": 0.5}}
    assert phasemap.Scene.from_spec(good).shape == (3,)
    numpy_count = {**good, "axes": {"phi": {"start": 0.0, "stop": 1.0, "count": np.int64(3)}}}
    assert phasemap.Scene.from_spec(numpy_count).shape == (3,)

    def no_allocation(*args, **kwargs):
        raise AssertionError("allocated")

    monkeypatch.setattr(np, "linspace", no_allocation)
    cases = {
        "unknown key": {**good, "exec": "import os"},
        "values,": {**good, "axes": {"phi": {"start": 0.0, "stop": 1.0, "count": 10 ** 12}}},
        "cells": {**good, "axes": {"phi": {"start": 0.0, "stop": 1.0, "count": 10 ** 6},
                                   "f": {"start": 0.0, "stop": 1.0, "count": 10 ** 6}},
                  "fixed": {}},
        "count must be": {**good, "axes": {"phi": {"start": 0.0, "stop": 1.0,
                                                   "count": "3"}}},
        "start and stop": {**good, "axes": {"phi": {"start": [0], "stop": 1.0,
                                                    "count": 3}}},
        "model must be": {**good, "model": ["ladder"]},
        "fixed must": {**good, "fixed": {"f": "0.5"}},
        "layers must": {**good, "layers": "n_solutions"},
        "options must": {**good, "options": {"t_end": [1]}},
        "a spec is a mapping": ["ladder"],
    }
    for what, spec in cases.items():
        with pytest.raises(ValueError) as err:
            phasemap.Scene.from_spec(spec)
        message = str(err.value)
        assert "\n" not in message and message.startswith("Scene.from_spec:"), message
        assert what.split()[0] in message, (what, message)


#: Values a file's attribute can hold, the malformed ones first.
JUNK = [None, "", "{", "[]", "{}", "null", "3", "evil.py", "../../evil.py", "/tmp/evil.py",
        "[" * 100_000 + "]" * 100_000, np.array([1.0, 2.0, 3.0]),  # too deep for json; vlen
        "ladder", "hinge_pendulum", "trajectory", "fate", "map", "atlas", 3, -1, 0.5, np.nan,
        np.inf, True, np.array([1, 2]), np.array(["a", "b"]), "x" * 10_000, "\x00", "é",
        json.dumps({"variables": {"phi": 3}}), json.dumps({"variables": {"phi": ["a"]}}),
        json.dumps({"variables": [1, 2]}), json.dumps({"branches": "slide"}),
        json.dumps({"coefficient": [1, 2, 3, 4]}), json.dumps({"edges": {"phi": ["a"]}}),
        json.dumps({"model": "evil.py", "axes": {"phi": [0.1]}}),
        json.dumps({"model": "ladder", "axes": {"phi": {"start": 0, "stop": 1,
                                                        "count": 10 ** 15}}}),
        json.dumps({"model": "ladder", "axes": {"phi": [0.1, "a"]}}),
        json.dumps({"model": "ladder", "axes": {"phi": [0.1, 0.2]}, "fixed": {"f": 0.5},
                    "options": {"t_end": -1}}),
        json.dumps({"model": "ladder", "axes": {"phi": [0.1, 0.2]}, "fixed": {"f": 0.5},
                    "layers": ["nope"]}),
        json.dumps({"model": "ladder", "axes": {"phi": [0.2, 0.1, 0.2]}}),
        json.dumps({"model": "ladder", "axes": {"phi": [1e300]}}),
        json.dumps([1, 2, 3]), json.dumps({"options": {"t_end": "x"}})]

ATTRIBUTES = ["phasemap_model", "phasemap_kind", "phasemap_variables", "phasemap_scene",
              "phasemap_declaration_sha256", "phasemap_fixed_omega", "phasemap_fixed_f",
              "phasemap_version", "title", "Conventions"]


def _readers(ds: xr.Dataset):
    yield "kind", lambda: dataset_kind(ds)
    yield "vocabulary", lambda: vocabulary(ds)
    yield "model", lambda: ds.phasemap.model
    yield "describe", lambda: describe_atlas(ds)
    yield "from_spec", lambda: phasemap.Scene.from_spec(ds.attrs.get("phasemap_scene"))


def _raised_by_phasemap(error: BaseException) -> bool:
    """Whether the innermost frame of ``error`` is phasemap's own code (a check that
    refuses), not a library's deep inside."""
    tb = error.__traceback__
    while tb.tb_next is not None:
        tb = tb.tb_next
    return pathlib.Path(tb.tb_frame.f_code.co_filename).resolve().is_relative_to(
        ROOT / "phasemap")


def test_the_readers_of_a_file_fuzzed_with_malformed_attributes(ladder_map, tmp_path,
                                                                 monkeypatch):
    """A seeded fuzz: each case sets one to three global attributes to junk (or deletes
    them); every reader gives a correct result or one ValueError/TypeError of one line,
    and every 10th case is drawn too.  No file named anywhere runs."""
    (tmp_path / "evil.py").write_text(EVIL)
    monkeypatch.chdir(tmp_path)
    rng = random.Random(28)
    outcomes = {"ok": 0, "refused": 0}
    for case in range(300):
        ds = ladder_map.copy()
        for name in rng.sample(ATTRIBUTES, rng.randint(1, 3)):
            value = rng.choice(JUNK + ["(delete)"])
            if isinstance(value, str) and value == "(delete)":
                ds.attrs.pop(name, None)
            elif value is not None:
                ds.attrs[name] = value
        readers = list(_readers(ds))
        if case % 10 == 0:
            readers.append(("plot", lambda: ds.phasemap.plot()))
        for what, call in readers:
            try:
                call()
                outcomes["ok"] += 1
            except (ValueError, TypeError) as e:
                message = str(e)
                assert _raised_by_phasemap(e), (case, what, dict(ds.attrs), message)
                assert message and "\n" not in message and "Traceback" not in message, \
                    (case, what, dict(ds.attrs), message)
                outcomes["refused"] += 1
        import matplotlib.pyplot as plt
        plt.close("all")
    assert not (tmp_path / "MARKER").exists()
    assert outcomes["ok"] > 100 and outcomes["refused"] > 100, outcomes


#: Values of a variable's attributes, the malformed ones first.
VARIABLE_JUNK = [None, "", "a b", "1 2 3", 3, np.nan, np.array([1.0]),
                 np.array([0, 1, 2, 3, 4, 5, 6, 7]), "\\frac{", "$\\frac{$", "$", "x" * 3000,
                 "m s-1", "rad2"]


def test_the_figure_and_description_of_a_file_fuzzed_in_its_variables(ladder_map):
    """A seeded fuzz of the attributes figures and ``phasemap info`` read from a variable
    (``flag_values``, ``flag_meanings``, ``phasemap_symbol``, ``units``,
    ``long_name``): drawn to the end, each gives a figure or one ValueError/TypeError
    raised by phasemap (a symbol that is not mathtext is not used)."""
    import matplotlib.pyplot as plt

    rng = random.Random(2028)
    drawn = 0
    cases = [("phi", "phasemap_symbol", "\\frac{"), ("f", "phasemap_symbol", "$"),
             ("phi", "long_name", "$\\frac{$"), ("phi", "units", "$\\frac{$"),
             ("phi", "units", np.array([1.0])), ("f", "long_name", np.array([1.0])),
             ("n_solutions", "flag_meanings", "a b"), ("n_solutions", "flag_values", 3)]
    cases += [(rng.choice(["n_solutions", "phi", "f"]),
               rng.choice(["flag_values", "flag_meanings", "phasemap_symbol", "units",
                           "long_name"]), rng.choice(VARIABLE_JUNK)) for _ in range(17)]
    for var, attr, value in cases:
        ds = ladder_map.copy()
        ds[var].attrs = dict(ladder_map[var].attrs)
        if value is None:
            ds[var].attrs.pop(attr, None)
        else:
            ds[var].attrs[attr] = value
        for what, call in (("plot", lambda: ds.phasemap.plot().canvas.draw()),
                           ("describe", lambda: describe_atlas(ds))):
            try:
                call()
                drawn += what == "plot"
            except (ValueError, TypeError) as e:
                assert _raised_by_phasemap(e) and "\n" not in str(e), (var, attr, value, e)
            plt.close("all")
    assert drawn > 12


def _crafted(base: pathlib.Path, folder: pathlib.Path) -> dict[str, pathlib.Path]:
    """Atlases whose shapes a reader might not expect (issue 42 item 3), each made from
    ``base`` with netCDF4 directly, as a hostile or careless writer would."""
    import shutil

    import netCDF4

    made = {}
    for name in ("zero_dimensional", "nested_json", "array_attribute", "no_scene"):
        made[name] = shutil.copy(base, folder / f"{name}.nc")
    with netCDF4.Dataset(made["zero_dimensional"], "a") as nc:
        old = nc.variables["n_solutions"]
        attrs = {k: old.getncattr(k) for k in old.ncattrs() if k != "_FillValue"}
        nc.renameVariable("n_solutions", "n_old")
        z = nc.createVariable("n_solutions", "i1", ())
        z.setncatts(attrs)
        z.assignValue(1)
    with netCDF4.Dataset(made["nested_json"], "a") as nc:
        for attr in ("phasemap_scene", "phasemap_variables"):
            nc.setncattr(attr, "[" * 100_000 + "]" * 100_000)
    with netCDF4.Dataset(made["array_attribute"], "a") as nc:
        nc.variables["n_solutions"].setncattr("long_name", np.array([1.0, 2.0, 3.0]))
        nc.variables["n_solutions"].setncattr("flag_meanings", np.array([1, 2], dtype="i4"))
    with netCDF4.Dataset(made["no_scene"], "a") as nc:
        nc.delncattr("phasemap_scene")
    return made


CRAFTED_READERS = """
import sys, xarray as xr, phasemap
for path in sys.argv[1:]:
    for what in ("open_atlas", "accessor plot", "from_spec"):
        try:
            if what == "open_atlas":
                phasemap.open_atlas(path).close()
            elif what == "accessor plot":
                with xr.open_dataset(path) as ds:
                    ds.phasemap.plot()
            else:
                with xr.open_dataset(path) as ds:
                    phasemap.Scene.from_spec(ds.attrs.get("phasemap_scene"))
            print(path, what, "| ok")
        except (ValueError, TypeError) as e:
            print(path, what, "| refused", str(e).replace(chr(10), "<newline>"))
"""


def test_crafted_atlases_get_one_line_naming_the_file_from_every_reader(ladder_map, tmp_path):
    """A zero-dimensional layer, JSON nested too deeply for Python's decoder, an attribute
    stored as an array, and no ``phasemap_scene``: ``info``, ``plot`` and ``cfcheck``
    answer or refuse in one line that names the file, the library's readers with one
    ValueError/TypeError of one line (they gave IndexError, RecursionError, matplotlib's
    ValueError and KeyError)."""
    base = phasemap.write_atlas(ladder_map, tmp_path / "base.nc")
    made = _crafted(base, tmp_path)
    for name, path in made.items():
        for command in (["info", path.name], ["plot", path.name, "-o", f"{name}_fig"],
                        ["cfcheck", path.name]):
            done = run(["-m", "phasemap.cli", *command], tmp_path)
            assert "Traceback" not in done.stderr, (command, done.stderr)
            if done.returncode != 0:
                lines = done.stderr.strip().splitlines()
                assert done.returncode == 2 and len(lines) == 1, (command, done.stderr)
                assert path.name in lines[0], (command, lines[0])
    done = run(["-c", CRAFTED_READERS, *map(str, made.values())], tmp_path)
    assert done.returncode == 0, done.stderr
    said = {" ".join(line.split(" | ")[0].split()[1:]) + " " + pathlib.Path(
        line.split()[0]).stem: line.split(" | ", 1)[1] for line in done.stdout.splitlines()}
    assert len(said) == 12, done.stdout
    assert said["from_spec no_scene"].startswith("refused") and "phasemap_scene" in \
        said["from_spec no_scene"]
    assert "nested too deeply" in said["from_spec nested_json"]
    assert "nested too deeply" in said["accessor plot nested_json"]
    assert "0 dimension" in said["accessor plot zero_dimensional"]
