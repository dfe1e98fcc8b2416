"""The derivations of the built-in declarations shipped in the package (issue 40): a first
classify without sympy, never a stale derivation, and the text sympy derives today."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import phasemap
from phasemap.core import tiers
from phasemap.core.cache import load_module
from phasemap.declare import loader
from phasemap.systems import ship
from phasemap.systems import DECLARED

ROOT = Path(__file__).resolve().parents[1]


def test_every_built_in_declaration_ships_its_derivation_of_this_tree():
    """A change to phasemap.declare, the numerics or a declaration makes its file stale:
    the fix is one command."""
    assert ship.stale() == [], "run: python -m phasemap.systems.ship"
    for source in DECLARED.values():
        assert loader.shipped_file(source).is_file()
    assert not loader.key_of(ROOT / "phasemap" / "systems" / "painleve_rod.py") \
        == loader.key_of(ROOT / "phasemap" / "systems" / "painleve_rod.py", versions=False)


def test_the_package_data_holds_the_shipped_files():
    """A wheel carries them (package data), not only a clone."""
    text = (ROOT / "pyproject.toml").read_text()
    assert '"phasemap.systems" = ["derived/*.json"]' in text


FIRST = """
import json, sys
import phasemap
out = {}
for name in %r:
    c = phasemap.classify(name)
    out[name] = [int(c.n_solutions), "sympy" in sys.modules]
print(json.dumps(out))
"""


def test_a_first_classify_of_each_declared_built_in_needs_no_sympy(tmp_path):
    """From an empty kernel cache, under the default tier: the models come from the
    shipped files, and sympy is never imported."""
    env = {**os.environ, "PHASEMAP_CACHE_DIR": str(tmp_path / "kernels"),
           "PHASEMAP_JIT": "off"}
    run = subprocess.run([sys.executable, "-c", FIRST % (list(DECLARED),)], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    got = json.loads(run.stdout.strip().splitlines()[-1])
    assert set(got) == set(DECLARED)
    for name, (n, sympy) in got.items():
        assert n >= 0 and not sympy, (name, n, sympy)


def _random_states(model, rng, n):
    out = []
    for _ in range(n):
        values = {}
        for name, (lo, hi, _) in model.default_axes.items():
            values[name] = float(rng.uniform(lo, hi))
        out.append(values)
    return out


@pytest.mark.parametrize("name", sorted(DECLARED))
def test_the_shipped_derivation_is_what_sympy_derives(name):
    """Under the sympy it was shipped with, the text is the derivation's, byte for byte.
    Under another, the two derivations agree on the classes and accelerations of random
    states (both run as interpreted twins here: the same bits as machine code)."""
    from phasemap.declare.emit import module_source

    source = DECLARED[name]
    shipped = json.loads(loader.shipped_file(source).read_text())
    S = loader.system(source)
    fresh = module_source(S)
    import sympy

    if shipped["sympy"] == sympy.__version__:
        assert fresh == shipped["source"]
    module = load_module(f"test_shipped_{name}_{abs(hash(fresh)) % 10**12}", lambda: fresh)
    check = loader._resolve(shipped["model"]["check"]) if shipped["model"]["check"] else None
    derived = loader.build(shipped["model"], module, check, None)
    model = phasemap.get_model(name)
    if shipped["sympy"] == sympy.__version__:      # (srepr, and so the hash, is sympy's)
        from phasemap.declare import full
        from phasemap.declare.build import declaration_sha256

        assert declaration_sha256(S) == shipped["model"]["declaration_sha256"] \
            == model.declaration.sha256
        assert loader.described(S, S.model) == shipped["model"]
        for kind in ship.KINDS:
            assert full.text(S, kind) == shipped[kind]["text"], kind
    # the default map's axes in the declaration's order, read from the shipped record
    # (a record written with sorted keys once turned the rod's (theta, f) into (f, theta))
    assert list(derived.default_axes.items()) == list(model.default_axes.items())
    if S.default_axes:
        assert list(model.default_axes) == list(S.default_axes)
    rng = np.random.default_rng(7)
    with tiers.forced("off"):
        for values in _random_states(model, rng, 40):
            a, b = phasemap.classify(model, **values), phasemap.classify(derived, **values)
            assert a.n_solutions == b.n_solutions, values
            assert [x.status for x in a.candidates] == [y.status for y in b.candidates]
            for x, y in zip(a.candidates, b.candidates):
                for key in x.accelerations:
                    np.testing.assert_allclose(x.accelerations[key], y.accelerations[key],
                                               rtol=1e-9, atol=1e-12)


def test_a_stale_shipped_file_is_derived_again(tmp_path, monkeypatch):
    """A shipped file whose key is not the tree's is never used: the model is derived."""
    source = DECLARED["painleve_rod"]
    data = json.loads(loader.shipped_file(source).read_text())
    data["key"] = "0" * 64
    data["source"] = data["source"].replace("import math", "import math\nMARKED = True", 1)
    data["model"]["module"] = f"test_shipped_{tmp_path.name}"   # (not in this process yet)
    (tmp_path / f"{source}.json").write_text(json.dumps(data))
    monkeypatch.setattr(loader, "SHIPPED", tmp_path)
    path = loader._file(source)
    assert loader._from_shipped(path, source) is None
    data["key"] = loader.key_of(path, versions=False)
    (tmp_path / f"{source}.json").write_text(json.dumps(data))
    model = loader._from_shipped(path, source)
    assert model is not None
    assert sys.modules[model.velocity_scale.py_func.__module__].MARKED is True
    # the shipped rewrite is of the text before the mark: not used (the marked text was
    # rewritten instead, above), and the file is stale until shipped again
    assert ship.stale([source]) == [source]
    from phasemap.core.cache import rewriter
    from phasemap.core.selects import selects

    ready = selects(data["source"]).replace("MARKED = True", "MARKED = 'shipped rewrite'")
    data["rewritten"] = ship.rewritten(data["source"], ready, rewriter())
    data["model"]["module"] = f"test_shipped_{tmp_path.name}_rewritten"
    (tmp_path / f"{source}.json").write_text(json.dumps(data))
    model = loader._from_shipped(path, source)
    # a rewrite of this text by this rewriter is written as shipped: selects is not run
    assert sys.modules[model.velocity_scale.py_func.__module__].MARKED == "shipped rewrite"
    assert ship.stale([source]) == []
    data["rewritten"]["by"] = "0" * 16      # another version of the rewriter made it
    data["model"]["module"] = f"test_shipped_{tmp_path.name}_other"
    (tmp_path / f"{source}.json").write_text(json.dumps(data))
    model = loader._from_shipped(path, source)
    assert sys.modules[model.velocity_scale.py_func.__module__].MARKED is True
    assert ship.stale([source]) == [source]
    # a file that is not JSON is no model
    (tmp_path / f"{source}.json").write_text("{")
    assert loader._from_shipped(path, source) is None and ship.stale([source]) == [source]


def test_only_built_in_modules_have_a_shipped_file():
    assert loader.shipped_file("/home/me/rod.py") is None
    assert loader.shipped_file("mypackage.rod") is None
    assert loader.shipped_file("phasemap.systems.painleve_rod").name == \
        "phasemap.systems.painleve_rod.json"


def test_the_check_command_names_the_stale_files(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(loader, "SHIPPED", tmp_path)
    assert ship.main(["--check"]) == 1
    out = capsys.readouterr().out
    assert all(f"stale: {s}" in out for s in DECLARED.values())


# ------------------------------------------------------- the full coordinates, as text

MOTION = """
import hashlib, json, sys
import numpy as np
import phasemap
model = phasemap.get_model(sys.argv[1])
ds = phasemap.simulate(model, 3.0, **json.loads(sys.argv[2]))
digest = hashlib.sha256(b"".join(np.ascontiguousarray(ds[v].values).tobytes()
                                 for v in sorted(ds.variables) if ds[v].dtype.kind == "f"))
full = "phasemap_reduced_end" in ds.attrs       # the motion went on in full coordinates
print(json.dumps([ds.attrs["end_reason"], "sympy" in sys.modules, ds.sizes["event"],
                  digest.hexdigest(), full]))
"""


def _motion(model: str, env: dict, **values) -> list:
    run = subprocess.run([sys.executable, "-c", MOTION, model, json.dumps(values)], cwd=ROOT,
                         env=env, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


def test_a_motion_through_contact_changes_needs_no_sympy_after_its_derivation(tmp_path):
    """The ladder from an empty cache (shipped), then a declaration of the user's, whose
    second process reads its full coordinates from the kernel cache: neither imports
    sympy, and both give the motion of a process that derived everything."""
    env = {**os.environ, "PHASEMAP_CACHE_DIR": str(tmp_path / "kernels"),
           "PHASEMAP_JIT": "off"}
    ladder = dict(phi=0.6, omega=0.0, f=0.0)
    end, sympy, n_events, first, went_on = _motion("ladder", env, **ladder)
    assert not sympy and n_events >= 2 and went_on, (end, n_events)
    own = tmp_path / "rod.py"      # the built-in rod as a user's file: derived, then cached
    own.write_text((ROOT / "phasemap" / "systems" / "painleve_rod.py").read_text())
    rod = dict(theta=1.2, omega=-4.0, xdot=1.0, f=0.2)
    r1 = _motion(str(own), env, **rod)
    assert r1[1] and r1[4]                   # the first process derived it with sympy
    r2 = _motion(str(own), env, **rod)
    assert not r2[1] and r2[0] == r1[0] and r2[3] == r1[3], (r1, r2)
    # a process that builds the ladder's System and derives its mechanics with sympy
    env2 = {**env, "PHASEMAP_CACHE_DIR": str(tmp_path / "other")}
    code = ("import sys; from phasemap.declare import loader, full\n"
            "sys.modules['phasemap.declare.loader'].shipped_record = lambda s: None\n"
            "exec(open(sys.argv[3]).read())\n")
    script = tmp_path / "motion.py"
    script.write_text(MOTION)
    run = subprocess.run([sys.executable, "-c", code, "ladder", json.dumps(ladder),
                          str(script)], cwd=ROOT, env=env2, capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, run.stderr
    derived = json.loads(run.stdout.strip().splitlines()[-1])
    assert derived[1] and derived[0] == end and derived[2] == n_events
    import sympy

    if json.loads(loader.shipped_file(DECLARED["ladder"]).read_text())["sympy"] == \
            sympy.__version__:      # the same printed functions: the same bits
        assert derived[3] == first


def test_a_declaration_whose_contacts_cannot_open_says_so_from_the_cache():
    """A joint cannot open: the hinge pendulum's declaration has no full coordinates, and
    the message is the same whether derived now or read from the kernel cache (no second
    derivation)."""
    from phasemap.declare import full

    S = loader.system("phasemap.systems.seeds.hinge_pendulum")
    with pytest.raises(ValueError, match="Joint"):
        full.mechanics(S)
    full._MECHANICS.clear()
    with pytest.raises(ValueError, match="Joint"):
        full.mechanics(S)


def test_the_wheel_rolls_in_full_coordinates_with_its_rolling_integrated():
    """The wheel's rolling contact has full coordinates: it rolls (friction on its spin, its
    tangent held), and the reduced state's full coordinates integrate the rolling exactly:
    x_A = r phi, x_A' = r omega, y_A = r, y_A' = 0 (the disc turns by -phi)."""
    from phasemap.declare import full

    declaration = phasemap.get_model("wheel").declaration
    mech = full.mechanics(declaration)
    assert [c.rolls for c in mech.contacts] == [True]
    close = full.closure(declaration)
    rng = np.random.default_rng(2)
    for _ in range(10):
        values = {"phi": rng.uniform(-3, 3), "omega": rng.normal(), "delta": 0.05,
                  "r": rng.uniform(0.5, 2.0), "l": 0.3, "rho": 0.4, "g": 9.81, "m": 1.0}
        q, u = close(values)
        assert q.tolist() == [values["phi"], values["r"] * values["phi"], values["r"]]
        assert u.tolist() == [values["omega"], values["r"] * values["omega"], 0.0]
        p = np.array([values[k] for k in mech.parameters])
        M, h, g, J, b, mu = mech.pieces(q, u, p)
        assert g[0] == 0.0 and mu[0] == 0.05
        assert abs(J[0, 0] @ u) == 0.0 and abs(J[0, 2] @ u) <= 1e-15 * abs(u).max()
        assert J[0, 1] @ u == -values["omega"]          # the disc's own spin


@pytest.mark.parametrize("source", [DECLARED["rod_on_step"], DECLARED["ladder"], "belt",
                                    "stribeck_belt", "den_hartog"])
def test_the_full_coordinate_text_is_lambdify_s(source, monkeypatch):
    """Every function of the generated text (forces, gaps and rows, domain, bounds, body
    points, surfaces, moving belts, Stribeck laws, forcing periods, the closure) gives
    sympy's lambdified numbers at random arguments, bit for bit."""
    import sympy as sp

    from phasemap.declare import full
    from phasemap.systems.oscillators import OSCILLATORS

    S = OSCILLATORS[source] if source in OSCILLATORS else loader.system(source)
    twins = {}
    add = full._Writer.add

    def recorded(self, name, args, exprs, cse=False):
        add(self, name, args, exprs, cse)
        twins[name] = (len(args), sp.lambdify(args, exprs, modules="math", cse=cse))

    monkeypatch.setattr(full._Writer, "add", recorded)
    rng = np.random.default_rng(11)
    seen = set()
    for kind in ship.KINDS:
        twins.clear()
        ns = full._namespace()
        exec(full.text(S, kind), ns)
        assert (ns["ERROR"] is None) == bool(twins), (kind, ns["ERROR"])
        for name, (n, fn) in twins.items():
            seen.add(name)
            for _ in range(10):
                a = rng.uniform(0.1, 1.4, n)
                got = np.array(ns[name](*a), dtype=float)
                want = np.array(fn(*a), dtype=float)
                assert np.array_equal(got, want, equal_nan=True), (name, a)
    assert {"pieces", "domain", "bounds", "points", "surfaces"} <= seen


def test_every_kind_of_full_coordinate_function_is_met_above():
    """The oscillators above bring the optional functions: a moving surface, a Stribeck
    law per contact and a forcing period."""
    from phasemap.declare import full
    from phasemap.systems.oscillators import OSCILLATORS

    names = set()
    for source in ("belt", "stribeck_belt", "den_hartog"):
        ns = full._namespace()
        exec(full.text(OSCILLATORS[source], "mechanics"), ns)
        names |= {n for n in ns if n in ("surface", "period") or n.startswith("kinetic_")}
    assert {"surface", "period", "kinetic_0"} <= names


def test_a_stale_shipped_full_coordinate_text_is_not_used(monkeypatch):
    from phasemap.declare import full

    declaration = phasemap.get_model("painleve_rod").declaration
    key = full.shipped_key(declaration, "mechanics")
    record = {"mechanics": {"key": key, "text": "MARK = 1\n"}}
    monkeypatch.setattr(loader, "shipped_record", lambda source: record)
    assert full._shipped(declaration, "mechanics", key) == "MARK = 1\n"
    assert full._shipped(declaration, "mechanics", "0" * 64) is None
    assert full._shipped(loader.system(DECLARED["painleve_rod"]), "mechanics", key) is None
